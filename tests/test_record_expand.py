"""The recorder's batch expansion: SDK batch samples written as their tags' own messages (mcap_ros2 reads)."""

from __future__ import annotations

import os
import random
import threading
from array import array
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory

from dbglog._ros._batch import SLOT_FORMATS, encode_batch, pack_values, type_code
from dbglog.record import McapWriter
from dbglog.record._expand import BatchExpander
from tests._children import run_dbglog
from tests._ros import RosPeer, wait_until

T0 = 1_700_000_000_000_000_000


def _batch(writer: int, seq: int, k: int) -> bytes:
    """A batch of 3 samples of each of six tags (one not wanted), the k-th such batch."""
    tags = [
        (type_code("Float64"), b"speed"),
        (type_code("Int32"), b"count"),
        (type_code("Bool"), b"ok"),
        (type_code("String"), b"state"),
        (type_code("Int8"), b"small"),
        (type_code("Float64"), b"hidden"),
    ]
    index, times = array("H"), array("q")
    values: list[float] = []
    strings: list[bytes] = []
    for i in range(3):
        n = 3 * k + i
        for pos, (code, _name) in enumerate(tags):
            index.append(pos)
            times.append(T0 + n * 1000 + pos)
            if code == type_code("String"):
                values.append(len(strings))
                strings.append(f"step {n} é".encode())
            elif code == type_code("Bool"):
                values.append(n % 2)
            else:
                values.append(n * 0.5 if pos in (0, 5) else n - 4)
    slots = "".join(SLOT_FORMATS[tags[pos][0]] for pos in index)
    return encode_batch(writer, seq, tags, index, times, pack_values(slots, values), strings)


def _read(path: Path) -> dict[str, list[tuple[int, Any, dict[str, str]]]]:
    """Every message decoded by mcap + mcap_ros2: topic -> (publish time, message, channel metadata)."""
    out: dict[str, list[tuple[int, Any, dict[str, str]]]] = {}
    with path.open("rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        for _schema, channel, message, decoded in reader.iter_decoded_messages(log_time_order=False):
            out.setdefault(channel.topic, []).append((message.publish_time, decoded, dict(channel.metadata)))
    return out


def test_batch_samples_become_their_tags_messages(tmp_path: Path) -> None:
    """Wanted tags' samples decode as their std_msgs type and source times; re-sent skipped, gaps counted."""
    path = tmp_path / "x.mcap"
    with McapWriter(path) as w:
        expander = BatchExpander(w, lambda topic: topic != "/rosdashboard/hidden")
        assert expander.expand(T0, _batch(7, 0, 0)) == 15
        assert expander.expand(T0 + 1, _batch(7, 1, 1)) == 15
        assert expander.expand(T0 + 2, _batch(7, 1, 1)) == 0  # the same batch again (re-subscription)
        assert expander.expand(T0 + 3, _batch(8, 0, 2)) == 15  # another writer counts on its own
        assert expander.expand(T0 + 4, b"\x00\x01\x00\x00 not a batch") == 0
        assert expander.expand(T0 + 5, _batch(7, 4, 3)) == 15  # batches 2 and 3 of writer 7 never came
    assert expander.bad == 1
    assert expander.missing == 2
    assert expander.topics == {f"/rosdashboard/{t}" for t in ("speed", "count", "ok", "state", "small")}
    got = _read(path)
    assert sorted(got) == sorted(expander.topics)
    n = range(12)
    assert [m.data for _, m, _ in got["/rosdashboard/speed"]] == [i * 0.5 for i in n]
    assert [m.data for _, m, _ in got["/rosdashboard/count"]] == [i - 4 for i in n]
    assert [m.data for _, m, _ in got["/rosdashboard/small"]] == [i - 4 for i in n]
    assert [m.data for _, m, _ in got["/rosdashboard/ok"]] == [i % 2 == 1 for i in n]
    assert [m.data for _, m, _ in got["/rosdashboard/state"]] == [f"step {i} é" for i in n]
    assert [t for t, _, _ in got["/rosdashboard/speed"]] == sorted(T0 + i * 1000 for i in n)
    assert [t for t, _, _ in got["/rosdashboard/state"]] == [T0 + i * 1000 + 3 for i in n]
    assert got["/rosdashboard/speed"][0][2] == {"dbglog_from": "/_dbglog/samples"}


def test_write_fixed_takes_a_channel_per_message(tmp_path: Path) -> None:
    """write_fixed with one channel id per message files each message under its own channel."""
    path = tmp_path / "y.mcap"
    with McapWriter(path, chunk_bytes=64) as w:  # small chunks: the split keeps each message's channel
        a = w.add_channel("/a", "std_msgs/msg/Float64")
        b = w.add_channel("/b", "std_msgs/msg/Float64")
        values = np.arange(10, dtype="<f8")
        rows = np.zeros((10, 12), dtype=np.uint8)
        rows[:, 1] = 1
        rows[:, 4:] = values.view(np.uint8).reshape(10, 8)
        chans = np.array([a, b] * 5, dtype=np.int64)
        times = T0 + np.arange(10, dtype=np.int64)
        w.write_fixed(chans, times, rows, times)
    got = _read(path)
    assert [m.data for _, m, _ in got["/a"]] == [0.0, 2.0, 4.0, 6.0, 8.0]
    assert [t for t, _, _ in got["/b"]] == [T0 + i for i in (1, 3, 5, 7, 9)]


def test_record_rejects_a_queue_depth_below_one(tmp_path: Path) -> None:
    """--queue-depth 0 is refused with a clear message and exit code 2, before any file is made."""
    done = run_dbglog("record", "-o", str(tmp_path / "q.mcap"), "--queue-depth", "0")
    assert done.returncode == 2
    assert "--queue-depth must be at least 1, not 0" in done.stderr
    assert not (tmp_path / "q.mcap").exists()


def test_a_tag_whose_sdk_node_shows_its_batch_writer_late_is_recorded_from_the_batches(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Discovery tells a node's endpoints in any order: a recorder that saw an SDK node's tag before its
    batch writer subscribed to the tag for good, and the file's topic missed what came before that
    subscription matched (in 1 of 4 runs it started at sample 822 of 5000). It now waits (the grace,
    here 5 s so that a loaded machine cannot outlast it) and writes the tag from the batches: every sample."""
    from std_msgs.msg import Float64, UInt8MultiArray

    from dbglog._ros import _grace
    from dbglog._ros._batch import BATCH_TOPIC
    from dbglog._ros._qos import batch_qos, tag_qos
    from dbglog.record._recorder import Recorder, parse_targets

    monkeypatch.setattr(_grace, "GRACE_S", 5.0)
    tag = f"late_writer_{os.getpid()}_{random.randrange(1 << 20)}"
    topic = f"/rosdashboard/{tag}"
    path = tmp_path / "late.mcap"
    n = 50
    with McapWriter(path) as writer, RosPeer(f"dbglog_{random.randrange(10**6, 10**7)}") as sdk:
        recorder = Recorder(parse_targets([], everything=False), writer, node_name=f"late_writer_rec_{tag}")
        thread = threading.Thread(target=recorder.run)
        thread.start()
        try:
            sdk.publisher(topic, Float64, tag_qos())  # the tag's publisher, and no batch writer yet
            assert wait_until(lambda: "late_writer_rec_" + tag in sdk.node.get_node_names(), 20)
            # A few graph polls (every 0.25 s) of the recorder see the tag and no batch writer of its node.
            assert not wait_until(lambda: bool(_recorders(sdk, topic)), 1.0), "subscribed to the tag itself"
            batches = sdk.publisher(BATCH_TOPIC, UInt8MultiArray, batch_qos())
            assert wait_until(lambda: batches.get_subscription_count() > 0, 20)
            for seq in range(n // 5):
                batches.publish(_tag_batch(tag, seq, 5))
            assert wait_until(lambda: recorder.stats.from_batch >= n, 20), recorder.stats
            assert not _recorders(sdk, topic)
        finally:
            recorder.stop()
            thread.join(10)
    got = _read(path)
    assert [m.data for _, m, _ in got[topic]] == [float(i) for i in range(n)]


def _recorders(peer: RosPeer, topic: str) -> list[str]:
    """The recorders subscribed to `topic`."""
    return [i.node_name for i in peer.node.get_subscriptions_info_by_topic(topic) if "_rec_" in i.node_name]


def _tag_batch(tag: str, seq: int, k: int) -> bytes:
    """The `seq`-th batch of `k` Float64 samples of one tag, values and times counting on from it."""
    index = array("H", [0] * k)
    times = array("q", [T0 + (seq * k + i) * 1000 for i in range(k)])
    values = [float(seq * k + i) for i in range(k)]
    return encode_batch(
        1, seq, [(type_code("Float64"), tag.encode())], index, times, pack_values("d" * k, values), []
    )
