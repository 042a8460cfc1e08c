"""dbglog's MCAP writer and reader against independent implementations, and on damaged files."""

from __future__ import annotations

import hashlib
import os
import struct
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from geometry_msgs.msg import Twist
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import serialize_message
from std_msgs.msg import Bool, Float64, Int32, String

from dbglog.record import McapWriter, RecordingError, read_recording
from dbglog.record._msgdef import message_definition

T0 = 1_700_000_000_000_000_000


def _twist(i: int) -> Twist:
    msg = Twist()
    msg.linear.x = i * 0.25
    msg.angular.z = -i * 1.5
    return msg


def _sample_file(path: Path, n: int = 500, *, chunk_bytes: int = 1 << 20) -> McapWriter:
    """Write four topics of n messages each (not closed: the caller closes or abandons it)."""
    w = McapWriter(path, chunk_bytes=chunk_bytes)
    chans = {
        "/rosdashboard/speed": w.add_channel("/rosdashboard/speed", "std_msgs/msg/Float64"),
        "/rosdashboard/count": w.add_channel("/rosdashboard/count", "std_msgs/msg/Int32"),
        "/rosdashboard/ok": w.add_channel("/rosdashboard/ok", "std_msgs/msg/Bool"),
        "/rosdashboard/state": w.add_channel("/rosdashboard/state", "std_msgs/msg/String"),
        "/cmd_vel": w.add_channel("/cmd_vel", "geometry_msgs/msg/Twist"),
    }
    for i in range(n):
        t = T0 + i * 10_000_000
        w.write(chans["/rosdashboard/speed"], t + 5, serialize_message(Float64(data=i * 0.1 - 3)), t)
        w.write(chans["/rosdashboard/count"], t + 5, serialize_message(Int32(data=i - 250)), t)
        w.write(chans["/rosdashboard/ok"], t + 5, serialize_message(Bool(data=i % 3 == 0)), t)
        w.write(chans["/rosdashboard/state"], t + 5, serialize_message(String(data=f"step {i} é")), t)
        w.write(chans["/cmd_vel"], t + 5, serialize_message(_twist(i)), t)
    return w


def test_written_file_reads_back_value_by_value_with_mcap_ros2(tmp_path: Path) -> None:
    """Every message dbglog writes decodes with mcap + mcap_ros2 to the value and time written."""
    path = tmp_path / "run.mcap"
    _sample_file(path).close()
    got: dict[str, list[tuple[int, int, Any]]] = {}
    with path.open("rb") as f:
        for _schema, channel, message, decoded in make_reader(
            f, decoder_factories=[DecoderFactory()]
        ).iter_decoded_messages():
            got.setdefault(channel.topic, []).append((message.log_time, message.publish_time, decoded))
    assert sorted(got) == [
        "/cmd_vel",
        "/rosdashboard/count",
        "/rosdashboard/ok",
        "/rosdashboard/speed",
        "/rosdashboard/state",
    ]
    for i in range(500):
        t = T0 + i * 10_000_000
        assert got["/rosdashboard/speed"][i][:2] == (t + 5, t)
        assert got["/rosdashboard/speed"][i][2].data == i * 0.1 - 3
        assert got["/rosdashboard/count"][i][2].data == i - 250
        assert got["/rosdashboard/ok"][i][2].data == (i % 3 == 0)
        assert got["/rosdashboard/state"][i][2].data == f"step {i} é"
        assert got["/cmd_vel"][i][2].linear.x == i * 0.25
        assert got["/cmd_vel"][i][2].angular.z == -i * 1.5
    with path.open("rb") as f:
        reader = make_reader(f)
        assert reader.get_header().profile == "ros2"
        summary = reader.get_summary()
        assert summary is not None
        assert summary.statistics is not None
        assert summary.statistics.message_count == 2500
        assert summary.chunk_indexes
        assert all(c.compression == "zstd" for c in summary.chunk_indexes)
        assert all(c.message_index_offsets for c in summary.chunk_indexes)
        schemas = {s.name: s for s in summary.schemas.values()}
        assert schemas["geometry_msgs/msg/Twist"].encoding == "ros2msg"
        assert "MSG: geometry_msgs/Vector3" in schemas["geometry_msgs/msg/Twist"].data.decode()
        assert {c.message_encoding for c in summary.channels.values()} == {"cdr"}


def test_own_reader_reads_back_values_times_and_payloads(tmp_path: Path) -> None:
    """read_recording gives the scalar values vectorised, the source times and the exact CDR bytes."""
    path = tmp_path / "run.mcap"
    _sample_file(path, chunk_bytes=4096).close()  # many chunks
    rec = read_recording(path)
    assert rec.indexed
    assert rec.problems == []
    assert rec.unreadable == {}
    speed = rec.topics["/rosdashboard/speed"]
    assert speed.values is not None
    assert speed.values.tolist() == [i * 0.1 - 3 for i in range(500)]
    assert speed.times_ns.tolist() == [T0 + i * 10_000_000 for i in range(500)]
    count, ok = rec.topics["/rosdashboard/count"], rec.topics["/rosdashboard/ok"]
    assert count.values is not None
    assert count.values.tolist() == [float(i - 250) for i in range(500)]
    assert ok.values is not None
    assert ok.values.tolist() == [float(i % 3 == 0) for i in range(500)]
    state = rec.topics["/rosdashboard/state"]
    assert state.values is None
    assert [state.payload(i) for i in (0, 499)] == [
        serialize_message(String(data="step 0 é")),
        serialize_message(String(data="step 499 é")),
    ]
    assert list(rec.topics["/cmd_vel"].payloads()) == [serialize_message(_twist(i)) for i in range(500)]


def test_reader_reads_a_file_written_by_mcap_ros2(tmp_path: Path) -> None:
    """A file from mcap_ros2's own writer loads with the same values and times."""
    from mcap_ros2.writer import Writer

    path = tmp_path / "peer.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        float_schema = writer.register_msgdef("std_msgs/msg/Float64", "float64 data\n")
        twist_def = message_definition("geometry_msgs/msg/Twist")
        assert twist_def is not None
        twist_schema = writer.register_msgdef("geometry_msgs/msg/Twist", twist_def)
        for i in range(300):
            t = T0 + i * 1_000_000
            writer.write_message("/x", float_schema, {"data": i / 7}, log_time=t, publish_time=t)
            twist = {"linear": {"x": float(i), "y": 0.0, "z": 0.0}, "angular": {"x": 0.0, "y": 0.0, "z": 2.0}}
            writer.write_message("/tw", twist_schema, twist, log_time=t, publish_time=t)
        writer.finish()  # type: ignore[no-untyped-call]
    rec = read_recording(path)
    assert rec.problems == []
    x = rec.topics["/x"]
    assert x.values is not None
    assert x.values.tolist() == [i / 7 for i in range(300)]
    assert x.times_ns.tolist() == [T0 + i * 1_000_000 for i in range(300)]
    from rclpy.serialization import deserialize_message

    assert [deserialize_message(p, Twist).linear.x for p in rec.topics["/tw"].payloads()] == [
        float(i) for i in range(300)
    ]


def test_reader_reads_a_rosbag2_mcap_directory_written_by_rosbags(tmp_path: Path) -> None:
    """A rosbag2 bag (MCAP storage, metadata.yaml) written by rosbags opens as a directory."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    store = get_typestore(Stores.ROS2_JAZZY)
    float64 = store.types["std_msgs/msg/Float64"]
    string = store.types["std_msgs/msg/String"]
    bag = tmp_path / "bag"
    with Writer(bag, version=9, storage_plugin=StoragePlugin.MCAP) as writer:
        a = writer.add_connection("/rosdashboard/v", "std_msgs/msg/Float64", typestore=store)
        b = writer.add_connection("/chatter", "std_msgs/msg/String", typestore=store)
        for i in range(200):
            t = T0 + i * 20_000_000
            writer.write(a, t, store.serialize_cdr(float64(data=i * 2.5), "std_msgs/msg/Float64"))
            writer.write(b, t, store.serialize_cdr(string(data=f"hi {i}"), "std_msgs/msg/String"))
    assert (bag / "metadata.yaml").is_file()
    rec = read_recording(bag)
    assert rec.problems == []
    v = rec.topics["/rosdashboard/v"]
    assert v.values is not None
    assert v.values.tolist() == [i * 2.5 for i in range(200)]
    assert v.times_ns.tolist() == [T0 + i * 20_000_000 for i in range(200)]
    from dbglog.record._inspect import echo_lines

    assert list(echo_lines(bag, "/chatter"))[:2] == ["hi 0", "hi 1"]
    assert list(echo_lines(bag, "v"))[-1] == "497.5"


def _flushed(path: Path, n_chunks: int, per_chunk: int) -> McapWriter:
    """A recording flushed every `per_chunk` messages (as the recorder does each second)."""
    w = McapWriter(path)
    ch = w.add_channel("/rosdashboard/speed", "std_msgs/msg/Float64")
    for k in range(n_chunks):
        for j in range(per_chunk):
            i = k * per_chunk + j
            w.write(ch, T0 + i, serialize_message(Float64(data=float(i))), T0 + i)
        w.flush()
    return w


def test_a_file_without_summary_is_scanned_and_named(tmp_path: Path) -> None:
    """A recording never closed (killed) opens by scanning: every flushed message, a clear problem."""
    path = tmp_path / "killed.mcap"
    _flushed(path, 5, 100).abandon()
    rec = read_recording(path)
    assert not rec.indexed
    speed = rec.topics["/rosdashboard/speed"]
    assert speed.values is not None
    assert speed.values.tolist() == [float(i) for i in range(500)]
    assert len(rec.problems) == 1
    assert str(path) in rec.problems[0]
    assert "no summary or index: the file does not end with an MCAP footer" in rec.problems[0]
    assert "read by scanning the whole file: 500 messages in" in rec.problems[0]


@pytest.mark.parametrize("cut", [0.3, 0.55, 0.8, 0.97])
def test_a_truncated_file_gives_its_readable_part(tmp_path: Path, cut: float) -> None:
    """A file cut anywhere opens: the whole chunks before the cut, a message naming the file and the cut."""
    whole = tmp_path / "whole.mcap"
    _flushed(whole, 10, 100).close()
    data = whole.read_bytes()
    path = tmp_path / "cut.mcap"
    path.write_bytes(data[: int(len(data) * cut)])
    rec = read_recording(path)
    assert not rec.indexed
    assert any(str(path) in p and "truncated" in p for p in rec.problems) or cut > 0.9
    speed = rec.topics["/rosdashboard/speed"]
    assert speed.values is not None
    n = len(speed.values)
    assert n % 100 == 0
    assert speed.values.tolist() == [float(i) for i in range(n)]
    assert n >= 100 * int(10 * cut) - 200  # at most the chunk in flight and the one cut are lost


def test_a_corrupt_chunk_is_skipped_and_named(tmp_path: Path) -> None:
    """Garbage inside one chunk loses that chunk only; the message names the file and the byte."""
    path = tmp_path / "bad.mcap"
    _flushed(path, 4, 100).close()
    data = bytearray(path.read_bytes())
    with path.open("rb") as f:
        summary = make_reader(f).get_summary()
    assert summary is not None
    second = sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset)[1]
    middle = second.chunk_start_offset + second.chunk_length - 20
    data[middle : middle + 8] = b"\xff" * 8
    path.write_bytes(bytes(data))
    rec = read_recording(path)
    assert len(rec.problems) == 1
    assert str(path) in rec.problems[0]
    assert f"byte {second.chunk_start_offset}" in rec.problems[0]
    assert "corrupt" in rec.problems[0]
    speed = rec.topics["/rosdashboard/speed"]
    assert speed.values is not None
    assert speed.values.tolist() == [float(i) for i in range(400) if not 100 <= i < 200]


def test_not_an_mcap_file_is_refused_by_name(tmp_path: Path) -> None:
    """A file that is not MCAP (or empty, or missing) raises a RecordingError naming it."""
    text = tmp_path / "notes.mcap"
    text.write_text("hello")
    with pytest.raises(RecordingError, match=r"notes\.mcap: not an MCAP file"):
        read_recording(text)
    empty = tmp_path / "empty.mcap"
    empty.write_bytes(b"")
    with pytest.raises(RecordingError, match=r"empty\.mcap: the file is empty"):
        read_recording(empty)
    with pytest.raises(RecordingError, match=r"missing\.mcap: no such file"):
        read_recording(tmp_path / "missing.mcap")


def test_opening_never_modifies_the_file(tmp_path: Path) -> None:
    """Reading a whole and an unfinished file leaves their bytes and modification times alone."""
    whole, killed = tmp_path / "whole.mcap", tmp_path / "killed.mcap"
    _flushed(whole, 3, 50).close()
    _flushed(killed, 3, 50).abandon()
    for path in (whole, killed):
        os.chmod(path, 0o444)
        before = (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns)
        read_recording(path)
        assert (hashlib.sha256(path.read_bytes()).hexdigest(), path.stat().st_mtime_ns) == before


def test_unknown_types_are_listed_as_unreadable_and_the_rest_reads(tmp_path: Path) -> None:
    """A topic whose type has no definition and is not installed is unreadable; the others load."""
    path = tmp_path / "mixed.mcap"
    w = McapWriter(path)
    odd = w.add_channel("/odd", "nosuchpkg/msg/Thing")
    ok = w.add_channel("/ok", "std_msgs/msg/Float64")
    for i in range(10):
        w.write(odd, T0 + i, b"\x00\x01\x00\x00" + struct.pack("<I", i), T0 + i)
        w.write(ok, T0 + i, serialize_message(Float64(data=i)), T0 + i)
    w.close()
    rec = read_recording(path)
    assert list(rec.topics) == ["/ok"]
    assert "nosuchpkg/msg/Thing" in rec.unreadable["/odd"]
    assert "10 messages" in rec.unreadable["/odd"]


def test_writer_never_overwrites_unless_forced(tmp_path: Path) -> None:
    """An existing file is refused (named, with the --force hint) and kept; force replaces it."""
    path = tmp_path / "keep.mcap"
    path.write_bytes(b"precious")
    with pytest.raises(RecordingError, match=r"keep\.mcap already exists \(use --force"):
        McapWriter(path)
    assert path.read_bytes() == b"precious"
    McapWriter(path, force=True).close()
    assert read_recording(path).topics == {}


def test_values_without_payloads_match_and_out_of_order_times_are_sorted(tmp_path: Path) -> None:
    """keep_payloads=False reads the same values; messages logged out of order come back sorted."""
    path = tmp_path / "shuffled.mcap"
    w = McapWriter(path, chunk_bytes=2000)
    ch = w.add_channel("/rosdashboard/v", "std_msgs/msg/Float64")
    order = [(i * 7919) % 600 for i in range(600)]
    for i in order:
        w.write(ch, T0 + i * 1000, serialize_message(Float64(data=float(i))), T0 + i * 1000)
    w.close()
    for keep in (True, False):
        v = read_recording(path, keep_payloads=keep).topics["/rosdashboard/v"]
        assert v.values is not None
        assert v.values.tolist() == [float(i) for i in range(600)]
        assert v.times_ns.tolist() == [T0 + i * 1000 for i in range(600)]
    full = read_recording(path).topics["/rosdashboard/v"]
    assert full.payload(5) == serialize_message(Float64(data=5.0))


def test_tags_and_echo_of_a_file_name_what_is_missing(tmp_path: Path) -> None:
    """tags_table lists tags with count and first/last value; echo names an unknown tag, topic or field."""
    from dbglog.record._inspect import echo_lines, tags_table

    path = tmp_path / "run.mcap"
    _sample_file(path, 50).close()
    rows = {line.split()[0]: line.split() for line in tags_table(path).splitlines()[2:]}
    assert sorted(rows) == ["count", "ok", "speed", "state"]
    assert rows["count"][1:3] == ["std_msgs/msg/Int32", "50"]
    assert rows["count"][-2:] == ["-250", "-201"]
    assert rows["ok"][-2:] == ["true", "false"]
    assert "/cmd_vel" in tags_table(path, all_topics=True)
    assert (
        list(echo_lines(path, "/cmd_vel.angular.z", stamp=True))[1] == f"{(T0 + 10_000_000) / 1e9:.6f} -1.5"
    )
    assert list(echo_lines(path, "/cmd_vel/linear/x"))[2] == "0.5"
    with pytest.raises(
        RecordingError, match=r"no tag 'nope' in this recording \(tags: count, ok, speed, state\)"
    ):
        list(echo_lines(path, "nope"))
    with pytest.raises(RecordingError, match=r"no topic /nope in this recording"):
        list(echo_lines(path, "/nope"))
    with pytest.raises(
        RecordingError,
        match=r"field 'speed' is not in geometry_msgs/msg/Twist; its fields are: linear, angular",
    ):
        list(echo_lines(path, "/cmd_vel.speed"))
    warnings: list[str] = []
    _flushed(tmp_path / "killed.mcap", 2, 10).abandon()
    assert list(echo_lines(tmp_path / "killed.mcap", "speed", warn=warnings.append))[-1] == "19.0"
    assert len(warnings) == 1
    assert "killed.mcap: no summary or index" in warnings[0]


def test_a_time_range_reads_only_its_messages(tmp_path: Path) -> None:
    """start_ns/end_ns keep the messages logged inside the range, indexed or scanned, sorted."""
    path = tmp_path / "range.mcap"
    w = _flushed(path, 10, 100)  # log times T0 + 0 ... T0 + 999, ten chunks
    w.close()
    for keep in (True, False):
        rec = read_recording(path, start_ns=T0 + 250, end_ns=T0 + 612, keep_payloads=keep)
        speed = rec.topics["/rosdashboard/speed"]
        assert speed.values is not None
        assert speed.values.tolist() == [float(i) for i in range(250, 613)]
        assert speed.times_ns.tolist() == [T0 + i for i in range(250, 613)]
    assert read_recording(path, start_ns=T0 + 250).topics["/rosdashboard/speed"].payload(0) == (
        serialize_message(Float64(data=250.0))
    )
    killed = tmp_path / "killed.mcap"
    _flushed(killed, 3, 100).abandon()
    tail = read_recording(killed, start_ns=T0 + 290).topics["/rosdashboard/speed"]
    assert tail.values is not None
    assert tail.values.tolist() == [float(i) for i in range(290, 300)]


def _cli(*argv: str) -> subprocess.CompletedProcess[str]:
    """Run the real ``dbglog`` command."""
    return subprocess.run(
        [sys.executable, "-m", "dbglog", *argv], capture_output=True, text=True, timeout=60, check=False
    )


def test_cli_tags_file_and_echo_file(tmp_path: Path) -> None:
    """`dbglog tags FILE` and `dbglog echo TARGET --file FILE` read a recording from the command line."""
    path = tmp_path / "run.mcap"
    _sample_file(path, 50).close()
    tags = _cli("tags", str(path))
    assert tags.returncode == 0, tags.stderr
    rows = {line.split()[0]: line.split() for line in tags.stdout.splitlines()[2:]}
    assert sorted(rows) == ["count", "ok", "speed", "state"]
    assert rows["speed"][1:3] == ["std_msgs/msg/Float64", "50"]
    assert "/cmd_vel" in _cli("tags", str(path), "--all").stdout
    echo = _cli("echo", "speed", "--file", str(path), "--count", "3")
    assert echo.returncode == 0, echo.stderr
    assert echo.stdout.splitlines() == ["-3.0", "-2.9", "-2.8"]
    stamped = _cli("echo", "/cmd_vel.linear.x", "--file", str(path), "--stamp")
    assert stamped.stdout.splitlines()[1] == f"{(T0 + 10_000_000) / 1e9:.6f} 0.25"
    missing = _cli("echo", "nope", "--file", str(path))
    assert missing.returncode == 1
    assert "no tag 'nope' in this recording" in missing.stderr
    gone = _cli("tags", str(tmp_path / "gone.mcap"))
    assert gone.returncode == 1
    assert "gone.mcap: no such file" in gone.stderr
    assert _cli("tags", str(path), "--watch").returncode == 2
