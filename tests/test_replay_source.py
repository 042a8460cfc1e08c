"""A recording as the viewer's data source (issue 17.4): bindings, fields, regex and transforms work as
live, the state at any time, files from independent writers, a batch topic from a real SDK recording."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest
from geometry_msgs.msg import Twist
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, String

from dbglog.record import McapWriter, RecordingError
from dbglog.viewer._data._model import Binding, Status, ValueKind
from dbglog.viewer._data._replay import load_replay
from dbglog.viewer._data._timeline import NOT_YET, Timeline
from dbglog.viewer._values._transforms import Scale

ROOT = Path(__file__).resolve().parent.parent
T0 = 1_700_000_000_000_000_000
STEP = 10_000_000  # 100 Hz


def _file(path: Path, n: int = 300) -> None:
    w = McapWriter(path)
    speed = w.add_channel("/rosdashboard/speed", "std_msgs/msg/Float64")
    words = w.add_channel("/log/words", "std_msgs/msg/String")
    twist = w.add_channel("/cmd_vel", "geometry_msgs/msg/Twist")
    for i in range(n):
        t = T0 + i * STEP
        w.write(speed, t, serialize_message(Float64(data=i * 0.5)), t)
        w.write(words, t, serialize_message(String(data=f"distance {i} mm")), t)
        msg = Twist()
        msg.linear.x, msg.angular.z = float(i), -2.0 * i
        w.write(twist, t, serialize_message(msg), t)
    w.close()


def test_bindings_fields_regex_and_transforms_replay_as_live(tmp_path: Path) -> None:
    """Every kind of binding fills from the whole file at bind; the end of the file is 'live'."""
    path = tmp_path / "run.mcap"
    _file(path)
    source = load_replay(path)
    speed, scaled = Binding("/rosdashboard/speed"), Binding("/rosdashboard/speed", transforms=(Scale(10.0),))
    lin, words = Binding("/cmd_vel", "linear.x"), Binding("/log/words")
    mm = Binding("/log/words", regex=r"distance (\d+) mm")
    for b in (speed, scaled, lin, words, mm):
        source.bind(b)
    assert source.snapshot(speed).values.tolist()[-3:] == [148.5, 149.0, 149.5]
    assert source.snapshot(scaled).last == 1495.0
    assert source.snapshot(lin).values.tolist() == [float(i) for i in range(300)]
    assert source.snapshot(mm).values.tolist() == [float(i) for i in range(300)]
    assert source.snapshot(words).kind is ValueKind.TEXT
    assert source.samples_held(speed) == 300
    assert source.time_span() == (T0 * 1e-9, (T0 + 299 * STEP) * 1e-9)
    at = source.snapshot_at(lin, (T0 + 120 * STEP) * 1e-9 + 0.004)
    assert at.last == 120.0
    assert at.status is Status.LIVE
    assert source.snapshot_at(words, (T0 + 7 * STEP) * 1e-9).last == "distance 7 mm"
    early = source.snapshot_at(speed, T0 * 1e-9 - 1)
    assert early.status is Status.WAITING
    assert early.reason == NOT_YET
    # The same Timeline the live viewer uses steps through the file.
    timeline = Timeline(source)
    timeline.seek((T0 + 10 * STEP) * 1e-9)
    assert timeline.step([speed], +1)
    assert timeline.snapshot(speed).last == 5.5
    assert [t.name for t in source.topics()] == ["/cmd_vel", "/log/words", "/rosdashboard/speed"]
    assert any(f.path == "linear.x" for f in source.fields("/cmd_vel"))


def test_bad_bindings_say_what_is_wrong(tmp_path: Path) -> None:
    """A topic not in the file names close matches; a bad field or regex is that binding's error."""
    path = tmp_path / "run.mcap"
    _file(path, 20)
    source = load_replay(path)
    typo, field = Binding("/rosdashboard/sped"), Binding("/cmd_vel", "linear.q")
    regex = Binding("/log/words", regex="(unclosed")
    for b in (typo, field, regex):
        source.bind(b)
    snap = source.snapshot(typo)
    assert snap.status is Status.ERROR
    assert "not in" in snap.reason
    assert "/rosdashboard/speed" in snap.reason
    bad = source.snapshot(field)
    assert bad.status is Status.ERROR
    assert "field 'q' is not in geometry_msgs/msg/Vector3" in bad.reason
    assert source.snapshot(regex).status is Status.ERROR


def test_a_missing_or_foreign_file_is_refused_by_name(tmp_path: Path) -> None:
    """Opening something that is not a recording says which file and why."""
    with pytest.raises(RecordingError, match=r"nope\.mcap: no such file"):
        load_replay(tmp_path / "nope.mcap")
    junk = tmp_path / "junk.mcap"
    junk.write_bytes(b"hello, not mcap")
    with pytest.raises(RecordingError, match=r"junk\.mcap: not an MCAP file"):
        load_replay(junk)


def test_a_file_from_mcap_ros2s_writer_replays(tmp_path: Path) -> None:
    """An independent writer's file (mcap_ros2) replays value by value."""
    from mcap_ros2.writer import Writer

    path = tmp_path / "peer.mcap"
    with path.open("wb") as f:
        writer = Writer(f)
        schema = writer.register_msgdef("std_msgs/msg/Float64", "float64 data\n")
        for i in range(100):
            t = T0 + i * STEP
            writer.write_message("/x", schema, {"data": i / 4}, log_time=t, publish_time=t)
        writer.finish()  # type: ignore[no-untyped-call]
    source = load_replay(path)
    b = Binding("/x")
    source.bind(b)
    assert source.snapshot(b).values.tolist() == [i / 4 for i in range(100)]


def test_a_real_sdk_recording_replays_every_sample_from_the_batch_topic(tmp_path: Path) -> None:
    """dbglog record next to an SDK publisher: the replayed tag holds every logged sample, in order."""
    out = tmp_path / "sdk.mcap"
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    recorder = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "record", "-o", str(out)],
        env=env,
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        time.sleep(2.0)
        code = textwrap.dedent(
            """
            import time, dbglog
            dbglog.init()
            time.sleep(1.5)
            for i in range(500):
                dbglog.logfloat("replay/ramp", float(i))
                dbglog.logstring("replay/state", f"s{i}", throttle=0.0)
                time.sleep(0.002)
            assert dbglog.flush(5.0)
            time.sleep(1.0)
            """
        )
        done = subprocess.run(
            [sys.executable, "-c", code], env=env, cwd=ROOT, capture_output=True, text=True, timeout=90
        )
        assert done.returncode == 0, done.stderr
        time.sleep(1.0)
    finally:
        recorder.send_signal(2)
        _, err = recorder.communicate(timeout=30)
    assert recorder.returncode == 0, err
    source = load_replay(out)
    ramp, state = Binding("/rosdashboard/replay/ramp"), Binding("/rosdashboard/replay/state")
    source.bind(ramp)
    source.bind(state)
    assert source.snapshot(ramp).values.tolist() == [float(i) for i in range(500)]
    assert source.snapshot(state).last == "s499"
    assert source.samples_held(state) == 500


def _playing(timeline: Timeline) -> bool:
    """Read the playing flag afresh (each tick may change it)."""
    return timeline.playing


class _Ticks:
    """A monotonic clock the test moves by hand (playback is wall time x speed)."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_playback_speed_loop_and_the_end(tmp_path: Path) -> None:
    """Space plays a recording from its start; the cursor moves with the clock times the speed."""
    path = tmp_path / "run.mcap"
    _file(path, 300)  # 2.99 s at 100 Hz
    source = load_replay(path)
    speed = Binding("/rosdashboard/speed")
    source.bind(speed)
    ticks = _Ticks()
    timeline = Timeline(source, ticks=ticks, recording=True)
    assert timeline.live  # opens at the end: everything shown
    assert timeline.snapshot(speed).last == 149.5
    timeline.toggle()  # at the end: play from the start
    assert _playing(timeline)
    assert timeline.snapshot(speed).last == 0.0
    ticks.now += 1.0
    timeline.tick()
    assert timeline.snapshot(speed).last == 50.0  # 1 s in = sample 100
    timeline.set_speed(2.0)
    ticks.now += 0.5
    timeline.tick()
    assert timeline.snapshot(speed).last == 100.0  # + 0.5 s x 2
    with pytest.raises(ValueError, match=r"from 0\.1 to 10"):
        timeline.set_speed(50)
    timeline.toggle()  # pause
    ticks.now += 5
    timeline.tick()
    assert timeline.snapshot(speed).last == 100.0
    timeline.toggle()
    ticks.now += 10
    timeline.tick()  # past the end: stops there
    assert not _playing(timeline)
    assert timeline.snapshot(speed).last == 149.5
    timeline.loop = True
    timeline.play(1.0)
    ticks.now += 3.5
    timeline.tick()  # past the end: back to the start, playing on
    assert _playing(timeline)
    assert timeline.snapshot(speed).last == 0.0


def test_a_long_recording_opens_with_its_end_and_loads_the_rest_behind(tmp_path: Path) -> None:
    """Progressive opening: the last seconds at once, then every binding refilled from the whole file."""
    path = tmp_path / "long.mcap"
    w = McapWriter(path)
    chan = w.add_channel("/rosdashboard/slow", "std_msgs/msg/Float64")
    for i in range(600):  # 60 s at 10 Hz
        t = T0 + i * 100_000_000
        w.write(chan, t, serialize_message(Float64(data=float(i))), t)
    w.close()
    source = load_replay(path, progressive=True)
    b = Binding("/rosdashboard/slow")
    source.bind(b)
    first = source.snapshot(b)
    assert first.last == 599.0
    span = source.time_span()
    assert span is not None
    if source.loading:  # the end only, for now
        assert span[1] - span[0] <= 10.0 + 1e-6
        assert first.values[0] >= 499.0
    deadline = time.monotonic() + 30
    while source.loading and time.monotonic() < deadline:
        time.sleep(0.01)
    assert not source.loading
    assert source.time_span() == (T0 * 1e-9, (T0 + 599 * 100_000_000) * 1e-9)
    assert source.samples_held(b) == 600
    assert source.snapshot_at(b, (T0 + 42 * 100_000_000) * 1e-9).last == 42.0
    assert source.problems == []


def test_a_plot_zoomed_out_past_the_snapshot_gets_the_history_as_an_envelope(tmp_path: Path) -> None:
    """The timeline answers a min/max envelope of every held sample in a range (up to the cursor, paused)."""
    path = tmp_path / "long.mcap"
    n = 30_000  # 300 s at 100 Hz: three times what a snapshot (10,000 samples) carries
    w = McapWriter(path)
    speed = w.add_channel("/rosdashboard/speed", "std_msgs/msg/Float64")
    twist = w.add_channel("/cmd_vel", "geometry_msgs/msg/Twist")
    words = w.add_channel("/log/words", "std_msgs/msg/String")
    for i in range(n):
        t = T0 + i * STEP
        w.write(speed, t, serialize_message(Float64(data=float(i % 1000))), t)
        msg = Twist()
        msg.linear.x = -float(i)
        w.write(twist, t, serialize_message(msg), t)
    w.write(words, T0, serialize_message(String(data="hello")), T0)
    w.close()
    source = load_replay(path)
    plain, field = Binding("/rosdashboard/speed"), Binding("/cmd_vel", "linear.x")
    text = Binding("/log/words")
    for b in (plain, field, text):
        source.bind(b)
    timeline = Timeline(source)
    start, end = T0 * 1e-9, (T0 + (n - 1) * STEP) * 1e-9
    assert len(timeline.snapshot(plain).times) == 10_000
    found = timeline.envelope(plain, start, end, 400)
    assert found is not None
    times, values = found
    assert 400 <= len(times) <= 2 * 400 + 2
    assert times[0] == pytest.approx(start)
    assert times[-1] == pytest.approx(end)
    assert bool((times[1:] >= times[:-1]).all())
    assert values.min() == 0.0
    assert values.max() == 999.0
    found = timeline.envelope(field, start, end, 400)
    assert found is not None
    assert found[1].min() == -(n - 1)
    assert found[1].max() == 0.0
    assert timeline.envelope(text, start, end, 400) is None
    # Paused in the middle: nothing after the cursor, not even the sample just past the range.
    timeline.seek(start + 100.0)
    found = timeline.envelope(field, start, end, 400)
    assert found is not None
    assert found[0][-1] <= start + 100.0
    assert found[1].min() == -10_000.0
    found = timeline.envelope(field, start + 150.0, end, 400)  # a range after the cursor: nothing yet
    assert found is not None
    assert len(found[0]) == 0


def test_a_recording_of_two_publishers_replays_in_source_time_order(tmp_path: Path) -> None:
    """Recorded in arrival order, two writers' samples of one tag (batches) and of one topic interleave in
    source time: the replayed series, transformed or not, and the state at a time are in source time."""
    from array import array

    import numpy as np

    from dbglog._ros._batch import BATCH_TOPIC, BATCH_TYPE, encode_batch, type_code

    path = tmp_path / "two.mcap"
    w = McapWriter(path)
    batches = w.add_channel(BATCH_TOPIC, BATCH_TYPE)
    speed = w.add_channel("/speed", "std_msgs/msg/Float64")
    tag = [(type_code("Float64"), b"two")]
    for k in range(20):  # writer 1 (value 1) and writer 2 (value 2), 10 ms batches 3.5 ms apart
        for writer, value, offset in ((1, 1.0, 0), (2, 2.0, 3_500_000)):
            times = array("q", [T0 + k * STEP + offset + i * 1_000_000 for i in range(10)])
            cdr = encode_batch(writer, k, tag, array("H", [0] * 10), times, array("d", [value] * 10), [])
            arrived = T0 + (k + 1) * STEP + offset
            w.write(batches, arrived, cdr, arrived)
            for t in times:  # the same samples on a plain topic, as a recorder gets them: in arrival order
                w.write(speed, arrived, serialize_message(Float64(data=value)), t)
    w.close()
    source = load_replay(path)
    bindings = (Binding("/rosdashboard/two"), Binding("/speed"), Binding("/speed", transforms=(Scale(10.0),)))
    for binding in bindings:
        source.bind(binding)
        snap = source.snapshot(binding)
        assert len(snap.times) == 400
        assert np.all(np.diff(snap.times) >= 0), binding
        assert np.count_nonzero(np.diff(snap.values)) > 30, "the two writers' samples interleave"
        mid = float(snap.times[201])
        then = source.snapshot_at(binding, mid)
        assert then.times.tolist() == snap.times[snap.times <= mid].tolist()
        assert then.last == snap.values[201]
