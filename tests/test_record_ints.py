"""A recording's single-value std_msgs topics keep their own type: Int64/UInt64 values beyond 2**53 read,
replay, echo and republish exactly (not through float64), whether a dbglog tag topic or any other."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

from rclpy.serialization import deserialize_message, serialize_message
from std_msgs.msg import Bool, Float32, Int8, Int64, UInt8, UInt64

from dbglog.record import McapWriter, TopicData, read_recording
from dbglog.record._inspect import echo_lines, tag_series, tags_table
from dbglog.viewer._data._model import Binding, ValueKind
from dbglog.viewer._data._replay import load_replay
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._publishing._republish import messages_between, state_at

T0 = 1_700_000_000_000_000_000
STEP = 10_000_000
BIG = 2**62 + 1
"""An Int64 a float64 cannot hold (it would become 2**62)."""
NEG = -(2**62) - 1
U64_MAX = 2**64 - 1
SIGNED = [BIG, NEG, 2**63 - 1, -(2**63), BIG + 2]
UNSIGNED = [U64_MAX, 2**63 + 3, 0, U64_MAX - 2]
TAG = "/rosdashboard/big"
TICKS = "/robot/ticks"


def _big_endian_int64(value: int) -> bytes:
    """The CDR bytes of an Int64 as a big-endian writer sends them (CDR_BE header)."""
    return b"\x00\x00\x00\x00" + value.to_bytes(8, "big", signed=True)


def _file(path: Path) -> Path:
    """A recording of a tag Int64 topic (one message big-endian), a plain UInt64 topic and small types."""
    w = McapWriter(path)
    tag = w.add_channel(TAG, "std_msgs/msg/Int64")
    ticks = w.add_channel(TICKS, "std_msgs/msg/UInt64")
    small = w.add_channel("/robot/small", "std_msgs/msg/Int8")
    byte = w.add_channel("/robot/u8", "std_msgs/msg/UInt8")
    ok = w.add_channel("/robot/ok", "std_msgs/msg/Bool")
    ratio = w.add_channel("/robot/ratio", "std_msgs/msg/Float32")
    for i, value in enumerate(SIGNED):
        t = T0 + i * STEP
        payload = _big_endian_int64(value) if i == 2 else serialize_message(Int64(data=value))
        w.write(tag, t, payload, t)
        w.write(small, t, serialize_message(Int8(data=-100 + i)), t)
        w.write(byte, t, serialize_message(UInt8(data=250 + i)), t)
        w.write(ok, t, serialize_message(Bool(data=i % 2 == 0)), t)
        w.write(ratio, t, serialize_message(Float32(data=i * 0.5)), t)
    for i, value in enumerate(UNSIGNED):
        t = T0 + i * STEP + 1
        w.write(ticks, t, serialize_message(UInt64(data=value)), t)
    w.close()
    return path


def _values(topics: dict[str, TopicData], name: str) -> tuple[str, list[object]]:
    """A topic's values: their dtype's name and the Python numbers."""
    values = topics[name].values
    assert values is not None, name
    return values.dtype.name, values.tolist()


def test_the_reader_keeps_each_scalar_topic_in_its_own_type(tmp_path: Path) -> None:
    """Int* int64, UInt* uint64 (64-bit integers exact, both byte orders), Float* float64, Bool bool."""
    path = _file(tmp_path / "ints.mcap")
    for keep in (True, False):
        topics = read_recording(path, keep_payloads=keep).topics
        assert _values(topics, TAG) == ("int64", SIGNED)
        assert _values(topics, TICKS) == ("uint64", UNSIGNED)
        assert _values(topics, "/robot/small") == ("int64", [-100, -99, -98, -97, -96])
        assert _values(topics, "/robot/u8") == ("uint64", [250, 251, 252, 253, 254])
        assert _values(topics, "/robot/ok") == ("bool", [True, False, True, False, True])
        assert _values(topics, "/robot/ratio") == ("float64", [0.0, 0.5, 1.0, 1.5, 2.0])
    # A time range (the progressive replay's first read) keeps them exact too.
    part = read_recording(path, start_ns=T0 + STEP, end_ns=T0 + 3 * STEP).topics
    assert _values(part, TAG) == ("int64", SIGNED[1:4])
    assert _values(part, TICKS) == ("uint64", UNSIGNED[1:3])
    assert tag_series(read_recording(path))["big"].values.tolist() == SIGNED  # type: ignore[union-attr]


def test_a_replay_holds_and_binds_the_exact_integers(tmp_path: Path) -> None:
    """The replay's history keeps int64/uint64 columns with every integer exact; they bind as numbers."""
    source = load_replay(_file(tmp_path / "ints.mcap"))
    times, values = source.store.range(TAG, -math.inf, math.inf)
    assert (values.dtype.name, values.tolist()) == ("int64", SIGNED)
    _, unsigned = source.store.range(TICKS, -math.inf, math.inf)
    assert (unsigned.dtype.name, unsigned.tolist()) == ("uint64", UNSIGNED)
    assert source.types[TICKS] == "std_msgs/msg/UInt64"
    assert source.store.at(TICKS, (T0 + 1) * 1e-9).value == U64_MAX  # type: ignore[union-attr]
    assert len(times) == len(SIGNED)
    # A binding on them is a number series over the whole file (its plotted values are float64); the value
    # a widget shows, at the end and at a cursor, keeps every digit.
    ticks, big = Binding(TICKS), Binding(TAG)
    source.bind(ticks)
    source.bind(big)
    snap = source.snapshot(ticks)
    assert (snap.kind, snap.count) == (ValueKind.NUMBER, len(UNSIGNED))
    assert (type(snap.last), snap.last) == (int, UNSIGNED[-1])
    assert source.snapshot(big).last == SIGNED[-1]
    timeline = Timeline(source)
    for binding, expected in ((big, SIGNED), (ticks, UNSIGNED)):
        held, _ = source.store.range(binding.topic, -math.inf, math.inf)
        for at, value in zip(held.tolist(), expected, strict=True):
            timeline.pause(at)
            assert timeline.snapshot(binding).last == value, (binding.topic, at)


def test_echo_and_tags_print_the_exact_integers(tmp_path: Path) -> None:
    """`dbglog echo` of a plain topic or a tag and `dbglog tags --all` print every digit."""
    path = _file(tmp_path / "ints.mcap")
    quiet: list[str] = []
    assert list(echo_lines(path, TICKS, warn=quiet.append)) == [str(v) for v in UNSIGNED]
    assert list(echo_lines(path, TICKS + ".data", warn=quiet.append)) == [str(v) for v in UNSIGNED]
    assert list(echo_lines(path, "big", warn=quiet.append)) == [str(v) for v in SIGNED]
    flags = ["true", "false", "true", "false", "true"]
    assert list(echo_lines(path, "/robot/ok", warn=quiet.append)) == flags
    assert quiet == []
    table = tags_table(path, all_topics=True, warn=quiet.append)
    rows = {line.split()[0]: line.split()[-2:] for line in table.splitlines()[2:]}
    assert rows[TAG] == [str(BIG), str(BIG + 2)]  # first and last value
    assert rows[TICKS] == [str(U64_MAX), str(U64_MAX - 2)]
    assert rows["/robot/small"] == ["-100", "-96"]
    cli = subprocess.run(
        [sys.executable, "-m", "dbglog", "echo", TICKS, "--file", str(path), "--count", "2"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert cli.returncode == 0, cli.stderr
    assert cli.stdout.splitlines() == [str(U64_MAX), str(2**63 + 3)]


def test_republish_serialises_the_exact_integers(tmp_path: Path) -> None:
    """--republish's messages (streamed, and the state at t) carry the recorded integers exactly."""
    source = load_replay(_file(tmp_path / "ints.mcap"))
    topics = sorted([TAG, TICKS])
    streamed = messages_between(source.store, source.types, topics, -math.inf, math.inf, 100)
    assert streamed is not None
    got: dict[str, list[int]] = {}
    for m in streamed:
        cls = Int64 if m.topic == TAG else UInt64
        got.setdefault(m.topic, []).append(deserialize_message(m.payload, cls).data)
    assert got == {TAG: SIGNED, TICKS: UNSIGNED}
    state = state_at(source.store, source.types, topics, (T0 + 2 * STEP + 1) * 1e-9)
    assert {m.topic: m.payload for m in state} == {
        TAG: serialize_message(Int64(data=2**63 - 1)),
        TICKS: serialize_message(UInt64(data=0)),
    }
