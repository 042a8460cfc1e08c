"""The batch wire format (`dbglog._ros._batch`): version 2 carries every integer exactly, version 1 is still
read, an unknown version is refused; and end to end, a real SDK process's big integers reach a real
viewer engine's history exactly.
"""

from __future__ import annotations

import struct
import time
import uuid
from array import array
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest

from dbglog._ros._batch import (
    SCALAR_TYPES,
    SLOT_FORMATS,
    BatchError,
    decode_batch,
    encode_batch,
    pack_values,
    type_code,
)
from dbglog._ros._tags import topic_for_tag
from dbglog.record import McapWriter, read_recording
from dbglog.record._inspect import echo_lines, tag_series, tags_table
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding, ValueKind
from dbglog.viewer._data._replay import history_of
from dbglog.viewer._publishing._republish import _payloads
from tests._children import run_sdk
from tests._ros import wait_until

T0 = 1_700_000_000_000_000_000
BIG = 2**62 + 1
"""An Int64 a float64 cannot hold (it would become 2**62)."""
NEG = -(2**62) - 1
U64_MAX = 2**64 - 1
_VERSION_AT = 16 + 4
"""Offset of the version byte in a batch message: the CDR prefix, then the magic."""

# Samples of one batch, interleaved as a flush makes them: (tag, type, value).
_SAMPLES: list[tuple[str, str, object]] = [
    ("big", "Int64", BIG),
    ("u", "UInt64", U64_MAX),
    ("f", "Float64", 0.1),
    ("ok", "Bool", True),
    ("s", "String", "héllo"),
    ("big", "Int64", NEG),
    ("u", "UInt64", 2**63 + 3),
    ("f", "Float64", -1e300),
    ("ok", "Bool", False),
    ("s", "String", ""),
    ("small", "Int8", -128),
    ("u8", "UInt8", 255),
    ("f32", "Float32", 1.5),
    ("big", "Int64", 2**63 - 1),
]


def _encode(samples: list[tuple[str, str, object]], *, v1: bool = False, seq: int = 0) -> bytes:
    """A batch of `samples` as the SDK's publisher thread builds it (version 1: every value as f64)."""
    names = list(dict.fromkeys((tag, std_type) for tag, std_type, _ in samples))
    tags = [(type_code(std_type), tag.encode()) for tag, std_type in names]
    index = array("H", [names.index((tag, std_type)) for tag, std_type, _ in samples])
    times = array("q", [T0 + 1000 * i for i in range(len(samples))])
    strings: list[bytes] = []
    numbers: list[float] = []
    for _, std_type, value in samples:
        if std_type == "String":
            strings.append(str(value).encode())
            numbers.append(len(strings) - 1)
        else:
            assert isinstance(value, int | float)
            numbers.append(value)
    if v1:
        values = array("d", numbers).tobytes()
    else:
        values = pack_values("".join(SLOT_FORMATS[type_code(t)] for _, t, _ in samples), numbers)
    message = bytearray(encode_batch(7, seq, tags, index, times, values, strings))
    if v1:
        assert message[_VERSION_AT] == 2
        message[_VERSION_AT] = 1  # the same header and sections: only the values column differs
    return bytes(message)


def _by_tag(message: bytes) -> dict[str, tuple[str, list[int], list[object], str | None]]:
    """Decode `message`: tag -> (type, times, values as Python objects, numpy dtype or None for texts)."""
    out: dict[str, tuple[str, list[int], list[object], str | None]] = {}
    for s in decode_batch(message).tags:
        if isinstance(s.values, list):
            out[s.tag] = (s.std_type, s.times_ns.tolist(), list(s.values), None)
        else:
            out[s.tag] = (s.std_type, s.times_ns.tolist(), s.values.tolist(), str(s.values.dtype))
    return out


def test_version_2_round_trips_every_type_exactly() -> None:
    """Int64 beyond 2**53, UInt64 beyond 2**63, floats, bools and texts come back as sent, typed by tag."""
    got = _by_tag(_encode(_SAMPLES))
    assert got["big"] == ("Int64", [T0, T0 + 5000, T0 + 13000], [BIG, NEG, 2**63 - 1], "int64")
    assert got["u"] == ("UInt64", [T0 + 1000, T0 + 6000], [U64_MAX, 2**63 + 3], "uint64")
    assert got["f"] == ("Float64", [T0 + 2000, T0 + 7000], [0.1, -1e300], "float64")
    assert got["ok"] == ("Bool", [T0 + 3000, T0 + 8000], [True, False], "bool")
    assert got["s"] == ("String", [T0 + 4000, T0 + 9000], ["héllo", ""], None)
    assert got["small"] == ("Int8", [T0 + 10000], [-128], "int64")
    assert got["u8"] == ("UInt8", [T0 + 11000], [255], "uint64")
    assert got["f32"] == ("Float32", [T0 + 12000], [1.5], "float64")
    assert {type(v) for v in [*got["big"][2], *got["u"][2]]} == {int}
    batch = decode_batch(_encode(_SAMPLES, seq=41))
    assert (batch.writer, batch.seq, batch.samples) == (7, 41, len(_SAMPLES))


def test_a_batch_of_one_slot_kind_packs_like_the_mixed_path() -> None:
    """A column of one kind (one C loop) holds the same bytes as packing each value with its own code."""
    cases: list[tuple[str, list[float]]] = [
        ("d", [0.5, -2.0, 1e-300]),
        ("q", [BIG, NEG, 0]),
        ("Q", [U64_MAX, 1, 0]),
    ]
    for code, values in cases:
        assert pack_values(code * 3, values) == b"".join(struct.pack("<" + code, v) for v in values)
    assert pack_values("", []) == b""
    assert len(pack_values("dqQ", [0.5, NEG, U64_MAX])) == 24
    with pytest.raises(struct.error):
        pack_values("dq", [0.5, 2**63])  # the SDK checks ranges before queuing: this never goes out


def test_every_type_code_has_a_value_slot() -> None:
    """Floats in f64, signed integers in i64, unsigned ones, bools and text numbers in u64."""
    assert len(SLOT_FORMATS) == len(SCALAR_TYPES)
    for name, slot in zip(SCALAR_TYPES, SLOT_FORMATS, strict=True):
        want = "d" if name.startswith("Float") else "q" if name.startswith("Int") else "Q"
        assert slot == want, name


def test_version_1_from_an_older_sdk_is_still_read() -> None:
    """A version-1 batch (all f64) decodes, its integers typed like version 2's (rounded as it sent them)."""
    samples = [s for s in _SAMPLES if s[1] != "UInt64" and s[2] != 2**63 - 1]
    samples.append(("big", "Int64", 2**63 - 1))  # f64 made it 2**63: saturated, not wrapped around
    got = _by_tag(_encode(samples, v1=True))
    assert got["big"] == ("Int64", [T0, T0 + 4000, T0 + 11000], [2**62, -(2**62), 2**63 - 1], "int64")
    assert got["f"][2:] == ([0.1, -1e300], "float64")
    assert got["ok"][2:] == ([True, False], "bool")
    assert got["s"][2:] == (["héllo", ""], None)
    assert got["small"][2:] == ([-128], "int64")
    assert got["u8"][2:] == ([255], "uint64")


def test_an_unknown_version_is_refused_with_a_clear_message() -> None:
    """Version 3 (a newer SDK) raises BatchError naming the version and the versions this dbglog reads."""
    message = bytearray(_encode(_SAMPLES))
    message[_VERSION_AT] = 3
    with pytest.raises(BatchError, match=r"batch version 3 is not supported .*reads versions 1, 2"):
        decode_batch(bytes(message))
    message[_VERSION_AT] = 0
    with pytest.raises(BatchError, match="batch version 0 is not supported"):
        decode_batch(bytes(message))


def test_a_string_sample_pointing_past_the_texts_is_refused() -> None:
    """A corrupt text number (u64 beyond the strings) is a BatchError, not an IndexError."""
    tags = [(type_code("String"), b"s")]
    message = encode_batch(1, 0, tags, array("H", [0]), array("q", [T0]), pack_values("Q", [5]), [b"x"])
    with pytest.raises(BatchError, match="missing text"):
        decode_batch(message)


def test_a_recording_of_batches_keeps_big_integers_exact(tmp_path: Path) -> None:
    """`dbglog tags`/`echo` and the recorder's expansion read a batch's Int64/UInt64 samples exactly."""
    from dbglog.record._expand import BatchExpander

    path = tmp_path / "ints.mcap"
    message = _encode(_SAMPLES)
    with McapWriter(path) as w:
        batch = w.add_channel("/_dbglog/samples", "std_msgs/msg/UInt8MultiArray")
        w.write(batch, T0, message, T0)
        expander = BatchExpander(w, lambda topic: topic.endswith(("/big", "/u")))
        assert expander.expand(T0, message) == 5
    series = tag_series(read_recording(path))
    assert series["big"].values.tolist() == [BIG, NEG, 2**63 - 1]  # type: ignore[union-attr]
    assert series["u"].values.tolist() == [U64_MAX, 2**63 + 3]  # type: ignore[union-attr]
    assert list(echo_lines(path, "big", warn=lambda _: None)) == [str(BIG), str(NEG), str(2**63 - 1)]
    assert list(echo_lines(path, "u", warn=lambda _: None)) == [str(U64_MAX), str(2**63 + 3)]
    rows = {line.split()[0]: line.split()[-2:] for line in tags_table(path, warn=lambda _: None).splitlines()}
    assert rows["big"] == [str(BIG), str(2**63 - 1)]  # first and last value
    assert rows["u"] == [str(U64_MAX), str(2**63 + 3)]
    # The expanded per-tag messages hold the integers as the tags' own topics would.
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        got: dict[str, list[int]] = {}
        for _, channel, _, decoded in reader.iter_decoded_messages(
            topics=["/rosdashboard/big", "/rosdashboard/u"]
        ):
            got.setdefault(channel.topic, []).append(decoded.data)
    assert got == {"/rosdashboard/big": [BIG, NEG, 2**63 - 1], "/rosdashboard/u": [U64_MAX, 2**63 + 3]}
    # A replay holds them exactly and --republish serialises them again exactly.
    store, types = history_of(read_recording(path), max_bytes=1 << 20)
    assert store.range("/rosdashboard/big", -np.inf, np.inf)[1].tolist() == [BIG, NEG, 2**63 - 1]
    _, payloads = _payloads(store, "/rosdashboard/u", types["/rosdashboard/u"], -np.inf, np.inf)
    assert [int.from_bytes(p[4:12], "little") for p in payloads] == [U64_MAX, 2**63 + 3]


# --- end to end: a real SDK process, a real viewer engine -------------------------------------------------

_RUN = f"bint_{uuid.uuid4().hex[:6]}"


@pytest.fixture(scope="module")
def engine() -> Iterator[Engine]:
    """One real viewer engine with a history."""
    with Engine(node_name="batch_int_engine", history_seconds=600, history_bytes=16 << 20) as e:
        yield e


def test_big_integers_logged_by_the_sdk_reach_the_engine_history_exactly(engine: Engine) -> None:
    """logint(tag, 2**62 + 1) and a UInt64 2**64 - 1 from an SDK process are exact in the viewer's history."""
    signed, unsigned, plain = f"{_RUN}/stamp_ns", f"{_RUN}/counter", f"{_RUN}/unbound"
    bound = Binding(topic_for_tag(signed))
    engine.bind(bound)
    code = f"""
        import time, dbglog
        dbglog.init()
        time.sleep(2.0)  # the viewer's engine sees the batch writer first
        for k in range(3):
            dbglog.logint({signed!r}, {BIG} + k)
            dbglog.logint({unsigned!r}, {U64_MAX} - k, msg_type="std_msgs/msg/UInt64")
            dbglog.logint({plain!r}, -{BIG} - k)
            dbglog.logfloat({plain!r} + "_f", 0.25 * k)
            time.sleep(0.02)
        assert dbglog.flush(5.0)
        assert dbglog.stats().dropped == 0
        """
    before = engine.batch_stats().samples
    store = engine.store
    topics = [topic_for_tag(t) for t in (signed, unsigned, plain)]
    done = run_sdk(code, stay_until=lambda: all(store.count(t) >= 3 for t in topics))
    assert done.returncode == 0, done.stderr
    assert wait_until(lambda: all(store.count(t) >= 3 for t in topics), 30), store.stats()
    assert engine.batch_stats().samples - before >= 12  # they came in batches
    values = {t: store.range(t, -np.inf, np.inf)[1] for t in topics}
    assert values[topics[0]].dtype == np.int64
    assert values[topics[0]].tolist() == [BIG, BIG + 1, BIG + 2]
    assert values[topics[1]].dtype == np.uint64
    assert values[topics[1]].tolist() == [U64_MAX, U64_MAX - 1, U64_MAX - 2]
    assert values[topics[2]].tolist() == [-BIG, -BIG - 1, -BIG - 2]
    assert store.range(topic_for_tag(plain + "_f"), -np.inf, np.inf)[1].tolist() == [0.0, 0.25, 0.5]
    # The bound series: fed from the batches, its newest value kept as the exact int.
    assert wait_until(lambda: engine.snapshot(bound).count >= 3, 30), engine.snapshot(bound)
    snap = engine.snapshot(bound)
    assert snap.kind == ValueKind.NUMBER
    assert snap.last == BIG + 2
    assert type(snap.last) is int
    assert topic_for_tag(signed) in engine.batch_stats().covered


def test_a_big_int_tag_another_node_also_publishes_keeps_every_sample_exactly_once(engine: Engine) -> None:
    """An Int64 tag published by an SDK process (in batches, and on its topic) and by a plain rclpy node
    (on its topic): the engine reads it on its topic, and its history keeps every sample of both, exact,
    once each (the batches' copies are not held a second time, and the two never drop each other)."""
    from std_msgs.msg import Int64

    from dbglog._ros._qos import tag_qos
    from tests._ros import RosPeer

    tag = f"{_RUN}/shared"
    topic = topic_for_tag(tag)
    bound = Binding(topic)
    engine.bind(bound)
    with RosPeer("batch_int_plain") as peer:
        pub = peer.publisher(topic, Int64, tag_qos())
        for k in range(5):
            pub.publish(Int64(data=-k))
        code = f"""
            import time, dbglog
            dbglog.init()
            time.sleep(1.0)
            for k in range(20):
                dbglog.logint({tag!r}, {BIG} + k)
                time.sleep(0.01)
            assert dbglog.flush(5.0)
            """
        done = run_sdk(code, stay_until=lambda: engine.store.count(topic) >= 25)  # its 20 and the first 5
        assert done.returncode == 0, done.stderr
        for k in range(5, 10):
            pub.publish(Int64(data=-k))
        want = sorted([-k for k in range(10)] + [BIG + k for k in range(20)])
        assert wait_until(lambda: engine.store.count(topic) >= len(want), 30), engine.store.count(topic)
        held = engine.store.range(topic, -np.inf, np.inf)[1]
        assert held.dtype == np.int64
        assert sorted(held.tolist()) == want
        assert engine.snapshot(bound).count == len(want)
    assert topic not in engine.batch_stats().covered  # read on its own topic


def test_a_publisher_whose_node_rmw_does_not_know_yet_is_waited_for(monkeypatch: pytest.MonkeyPatch) -> None:
    """rmw names an endpoint's node `_NODE_NAME_UNKNOWN_` until it learns it (or once the node is going
    away): the engine and the recorder wait (the grace time) before deciding how to read the topic, then
    go on."""
    from rclpy.topic_endpoint_info import TopicEndpointInfo

    from dbglog._ros import _grace
    from dbglog._ros._grace import UNKNOWN_NODE, PublisherGrace
    from dbglog.viewer._data._batchsub import BatchIngest
    from dbglog.viewer._data._history import History

    monkeypatch.setattr(_grace, "GRACE_S", 0.2)
    monkeypatch.setattr(_grace, "UNKNOWN_GAP_S", 0.1)

    def unused(*_args: object) -> None:
        raise AssertionError("not called")

    ingest = BatchIngest(
        make_sink=unused,
        feed=unused,
        feed_numbers=unused,
        record_latency=unused,
        message_class=unused,
        history=History(),
    )
    unknown = [TopicEndpointInfo(node_name=UNKNOWN_NODE, node_namespace="_NODE_NAMESPACE_UNKNOWN_")]
    known = [TopicEndpointInfo(node_name="bridge", node_namespace="/", topic_type="std_msgs/msg/Int64")]
    assert ingest.should_wait("/rosdashboard/a", unknown)
    assert not ingest.should_wait("/rosdashboard/a", known)  # a node rmw knows, not dbglog's: read it
    assert wait_until(lambda: not ingest.should_wait("/rosdashboard/a", unknown), 5.0)  # never known
    time.sleep(0.15)  # unseen for longer than the gap: the next unknown stretch has its own grace
    assert ingest.should_wait("/rosdashboard/a", unknown)
    assert ingest.should_wait("/rosdashboard/b", unknown)  # each topic its own
    grace = PublisherGrace()  # the recorder's own
    assert grace.should_wait("/rosdashboard/a", unknown, [])


def test_a_new_sdk_node_is_waited_for_until_it_shows_its_batch_writer(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A ``dbglog_<pid>`` node publishing a scalar tag is waited for until it is seen writing batches, at
    most the grace time; its other tags (arrays, messages) and other nodes' are never waited for."""
    from rclpy.topic_endpoint_info import TopicEndpointInfo

    from dbglog._ros import _grace
    from dbglog._ros._grace import PublisherGrace

    monkeypatch.setattr(_grace, "GRACE_S", 0.2)
    sdk = ("/", "dbglog_4242")

    def pub(node: str, msg_type: str = "std_msgs/msg/Float64") -> list[TopicEndpointInfo]:
        return [TopicEndpointInfo(node_name=node, node_namespace="/", topic_type=msg_type)]

    grace = PublisherGrace()
    assert grace.should_wait("/rosdashboard/a", pub("dbglog_4242"), [])
    assert not grace.should_wait("/rosdashboard/a", pub("dbglog_4242"), [frozenset({sdk})])  # now seen
    assert not grace.should_wait("/rosdashboard/v", pub("dbglog_4242", "std_msgs/msg/Float64MultiArray"), [])
    assert not grace.should_wait("/rosdashboard/a", pub("talker"), [])
    assert wait_until(lambda: not grace.should_wait("/rosdashboard/a", pub("dbglog_4242"), []), 5.0)


def test_a_backlog_of_kept_batches_is_taken_a_time_budget_a_wake_up(monkeypatch: pytest.MonkeyPatch) -> None:
    """A robot's kept batches (transient-local, found at once by a new reader) are taken for at most the
    drain budget a wake-up, at least one each, so the engine's graph polls come between; none is lost."""
    from std_msgs.msg import UInt8MultiArray

    from dbglog._ros._batch import batch_topic
    from dbglog._ros._node import PrivateNode
    from dbglog._ros._qos import batch_qos
    from dbglog.viewer._data import _batchsub
    from dbglog.viewer._data._batchsub import BatchIngest
    from dbglog.viewer._data._history import History
    from tests._ros import RosPeer

    kept = 40
    robot = f"/{_RUN}_backlog"
    with RosPeer("batch_backlog_robot") as peer:
        pub = peer.publisher(batch_topic(robot), UInt8MultiArray, batch_qos())
        for seq in range(kept):
            pub.publish(_encode([("s0/v", "Float64", float(seq))], seq=seq))  # serialized, as the SDK sends
        history = History()
        ingest = BatchIngest(
            make_sink=lambda *_a: None,
            feed=lambda *_a: None,
            feed_numbers=lambda *_a: None,
            record_latency=lambda _t: None,
            message_class=lambda _n: UInt8MultiArray,
            history=history,
        )
        reader = PrivateNode("batch_backlog_reader")
        try:

            def subscribed() -> bool:
                ingest.refresh(reader.node, [batch_topic(robot)])  # subscribes once the writer is seen
                return robot in ingest.subs

            assert wait_until(subscribed, 10)
            assert peer.wait_for_subscribers(pub)
            sub = ingest.subs[robot]
            ready = {sub.handle.pointer}
            topic = topic_for_tag("s0/v", robot)
            time.sleep(0.3)  # the kept batches reach the reader: the whole backlog waits there before a take
            monkeypatch.setattr(_batchsub, "_MAX_DRAIN_S", 0.0)  # the budget runs out after the first
            per_wake_up: list[int] = []

            behind: list[bool] = []

            def take() -> bool:
                per_wake_up.append(ingest.drain(ready)[0])
                behind.append(ingest.behind)
                return sum(per_wake_up) >= kept

            assert wait_until(take, 10)
            assert max(per_wake_up) == 1, per_wake_up  # one a wake-up: the backlog did not hold the loop
            assert sum(per_wake_up) == kept
            assert history.range(topic, -np.inf, np.inf)[1].tolist() == [float(s) for s in range(kept)]
            assert all(behind), behind  # each stopped on the budget: more may wait
            assert ingest.drain(ready) == (0, 0)
            assert not ingest.behind  # the queue was found empty
        finally:
            reader.close()


def test_the_engine_says_it_is_catching_up_while_a_backlog_is_taken_in_slices(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """While a robot's kept batches are taken a slice a wake-up, the engine says it is catching up, so a
    reader (``dbglog tags``) never takes the first slice for all there is: whenever the history held part
    of the backlog, the engine said so after; once it says it caught up, the history holds all of it."""
    from std_msgs.msg import UInt8MultiArray

    from dbglog._ros._batch import batch_topic
    from dbglog._ros._qos import batch_qos
    from dbglog.viewer._data import _batchsub
    from tests._ros import RosPeer

    kept = 40
    robot = f"/{_RUN}_slices"
    topic = topic_for_tag("s0/v", robot)
    monkeypatch.setattr(_batchsub, "_MAX_DRAIN_S", 0.0)  # one batch a wake-up
    with RosPeer("batch_slices_robot") as peer:
        pub = peer.publisher(batch_topic(robot), UInt8MultiArray, batch_qos())
        for seq in range(kept):
            pub.publish(_encode([("s0/v", "Float64", float(seq))], seq=seq))
        with Engine(node_name="batch_slices_engine", history_seconds=600) as eng:
            seen: list[tuple[int, bool]] = []

            def caught_up() -> bool:
                held = eng.store.count(topic)
                seen.append((held, eng.catching_up))  # read after the count, as `dbglog tags` does
                return held == kept and not seen[-1][1]

            assert wait_until(caught_up, 30, interval=0.001), seen[-5:]
            partial = [(held, catching) for held, catching in seen if 0 < held < kept]
            assert partial, seen  # the slices were seen one by one
            assert all(catching for _, catching in partial), partial
            assert eng.store.range(topic, -np.inf, np.inf)[1].tolist() == [float(s) for s in range(kept)]
