"""``dbglog view --replay FILE --republish``: the recording published on ROS 2 at the time cursor.

Which messages a cursor move sends is checked without ROS (`plan_move`, `messages_between`, `state_at`
over a real `History` and a real `Timeline`); the `Republisher` then publishes a real recording to a real
rclpy subscriber in this process; and the real ``dbglog view`` process, driven by the keyboard under Xvfb
(xdotool), is followed by a subscriber here.
"""

from __future__ import annotations

import functools
import math
import os
import signal
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from tests._ros import RosPeer, wait_quiet, wait_until
from tests._viewer_child import ViewerChild, report_frame

ROOT = Path(__file__).resolve().parent.parent
T0_NS = 1_700_000_000_000_000_000
T0 = T0_NS * 1e-9
N = 200
"""The recording: 20 s at 10 Hz."""
SPEED, MODE, CMD, ODD = "/rosdashboard/rr_speed", "/rosdashboard/rr_mode", "/rr_cmd", "/rr_odd"


def write_recording(path: Path) -> Path:
    """20 s: a speed i/2 and a Twist (linear.x = i) at 10 Hz, a mode every 5 s, a type not installed here."""
    from geometry_msgs.msg import Twist
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64, String

    from dbglog.record import McapWriter

    w = McapWriter(path, chunk_bytes=4096)
    speed = w.add_channel(SPEED, "std_msgs/msg/Float64")
    mode = w.add_channel(MODE, "std_msgs/msg/String")
    cmd = w.add_channel(CMD, "geometry_msgs/msg/Twist")
    odd = w.add_channel(ODD, "rr_nowhere_msgs/msg/Odd", definition="int32 a\n")
    for i in range(N):
        t = T0_NS + i * 100_000_000
        w.write(speed, t, serialize_message(Float64(data=i * 0.5)), t)
        if i % 50 == 0:
            w.write(mode, t, serialize_message(String(data=f"mode {i // 50}")), t)
        twist = Twist()
        twist.linear.x = float(i)
        w.write(cmd, t, serialize_message(twist), t)
        w.write(odd, t, b"\x00\x01\x00\x00" + i.to_bytes(4, "little"), t)
    w.close()
    return path


# -- which messages a cursor move sends (no ROS) ----------------------------------------------------------


def test_plan_move_streams_playback_and_seeks_anything_else() -> None:
    """Playing forward at the speed streams; a first cursor, a seek, step, wrap or jump is a Seek."""
    from dbglog.viewer._publishing._republish import CursorState, Seek, Stream, plan_move

    def at(t: float | None, wall: float, playing: bool = True, speed: float = 1.0) -> CursorState:
        return CursorState(t, playing, wall, speed)

    assert plan_move(None, at(5.0, 0.0, False)) == Seek(5.0)
    assert plan_move(None, at(None, 0.0, False)) is None
    assert plan_move(at(5.0, 0.0), at(5.0, 1.0)) is None  # not moved
    assert plan_move(at(5.0, 0.0), at(5.05, 0.05)) == Stream(5.0, 5.05)
    assert plan_move(at(5.0, 0.0, False), at(5.02, 7.0)) == Stream(5.0, 5.02)  # play pressed
    assert plan_move(at(9.9, 0.0), at(10.0, 0.05, False)) == Stream(9.9, 10.0)  # stopped at the end
    assert plan_move(at(5.0, 0.0), at(5.4, 0.04, speed=10.0)) == Stream(5.0, 5.4)
    assert plan_move(at(5.0, 0.0, speed=10.0), at(3605.0, 0.05, speed=10.0)) == Seek(3605.0)  # an hour: seek
    assert plan_move(at(5.0, 0.0), at(9.0, 0.05)) == Seek(9.0)  # the bar clicked while playing
    assert plan_move(at(9.9, 0.0), at(0.0, 0.05)) == Seek(0.0)  # loop wrap
    assert plan_move(at(5.0, 0.0, False), at(5.1, 0.05, False)) == Seek(5.1)  # a step while paused
    assert plan_move(at(5.0, 0.0, False), at(4.0, 0.05, False)) == Seek(4.0)


def test_moves_handed_over_while_the_thread_is_busy_merge() -> None:
    """Contiguous stretches merge; a seek replaces what waits; a stretch after a waiting seek is a seek."""
    from dbglog.viewer._publishing._republish import Seek, Stream, merge_moves

    assert merge_moves(Stream(1.0, 2.0), Stream(2.0, 3.0)) == Stream(1.0, 3.0)
    assert merge_moves(Stream(1.0, 2.0), Seek(0.5)) == Seek(0.5)
    assert merge_moves(Seek(1.0), Seek(7.0)) == Seek(7.0)
    assert merge_moves(Seek(1.0), Stream(1.0, 1.5)) == Seek(1.5)
    assert merge_moves(Stream(1.0, 2.0), Stream(5.0, 6.0)) == Seek(6.0)


def _history() -> Any:
    from dbglog.viewer._data._history import History

    h = History(clock=None, max_seconds=1e9)
    h.append_numbers("/a", np.array([1.0, 2.0, 3.0]), np.array([10.0, 20.0, 30.0]))
    h.append_payloads("/b", np.array([2.0, 2.5]), [b"b-2.0", b"b-2.5"], msg_type="x_msgs/msg/B")
    h.append_payloads("/tf_static", np.array([0.5, 1.5, 9.0]), [b"s1", b"s2", b"s3"], msg_type="t/msg/T")
    return h


TYPES = {"/a": "std_msgs/msg/Int32", "/b": "x_msgs/msg/B", "/tf_static": "t/msg/T"}


def test_messages_between_is_time_ordered_after_exclusive_upto_inclusive_and_bounded() -> None:
    """All messages of ``(after, upto]`` in time order (ties by topic); None when over the limit."""
    from dbglog._ros._cdr import encode_scalar
    from dbglog.viewer._publishing._republish import Outgoing, messages_between

    h, topics = _history(), sorted(TYPES)
    got = messages_between(h, TYPES, topics, 1.0, 2.5, 10)
    assert got == [
        Outgoing(1.5, "/tf_static", b"s2"),
        Outgoing(2.0, "/a", encode_scalar("<i", 20)),
        Outgoing(2.0, "/b", b"b-2.0"),
        Outgoing(2.5, "/b", b"b-2.5"),
    ]
    assert messages_between(h, TYPES, topics, 1.0, 2.5, 3) is None
    assert messages_between(h, TYPES, topics, 2.5, 2.5, 10) == []
    assert messages_between(h, TYPES, topics, 3.0, 100.0, 10) == [Outgoing(9.0, "/tf_static", b"s3")]


def test_state_at_is_each_topics_latest_and_every_static_transform() -> None:
    """The state at t: each topic's latest message at or before t, all of /tf_static, oldest first."""
    from dbglog._ros._cdr import encode_scalar
    from dbglog.viewer._publishing._republish import Outgoing, state_at

    h, topics = _history(), sorted(TYPES)
    assert state_at(h, TYPES, topics, 2.2) == [
        Outgoing(0.5, "/tf_static", b"s1"),
        Outgoing(1.5, "/tf_static", b"s2"),
        Outgoing(2.0, "/a", encode_scalar("<i", 20)),
        Outgoing(2.0, "/b", b"b-2.0"),
    ]
    assert state_at(h, TYPES, topics, 0.1) == []
    assert [m.topic for m in state_at(h, TYPES, ["/a"], 99.0)] == ["/a"]


def test_numbers_are_serialised_as_rclpy_reads_them_and_the_clock_to_the_microsecond() -> None:
    """A number held for a std_msgs scalar topic becomes CDR rclpy reads as the same value; /clock too."""
    from rclpy.serialization import deserialize_message
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Bool, Byte, Float32, Int64, UInt8

    from dbglog.viewer._publishing._republish import clock_payload, scalar_payload

    for cls, value in ((Float32, 1.5), (Int64, -(2**40)), (Bool, 1.0), (UInt8, 255.0)):
        encode = scalar_payload(f"std_msgs/msg/{cls.__name__}")
        assert encode is not None
        assert deserialize_message(encode(value), cls).data == value
    byte = scalar_payload("std_msgs/msg/Byte")
    assert byte is not None
    assert deserialize_message(byte(7), Byte).data == b"\x07"
    assert scalar_payload("std_msgs/msg/String") is None
    assert scalar_payload("geometry_msgs/msg/Twist") is None
    clock = deserialize_message(clock_payload(T0 + 12.3456781), Clock).clock
    assert (clock.sec, clock.nanosec) == (1_700_000_012, 345_678_000)


def test_a_real_timeline_playing_looping_and_seeking_plans_the_right_moves() -> None:
    """Driven like the viewer drives it, the timeline's cursor streams what it plays, seeks what it jumps."""
    from dbglog.viewer._data._replay import ReplaySource
    from dbglog.viewer._data._timeline import Timeline
    from dbglog.viewer._publishing._republish import CursorState, Seek, Stream, plan_move

    now = [100.0]
    h = _history()
    timeline = Timeline(ReplaySource(h, TYPES), ticks=lambda: now[0], recording=True)
    timeline.loop = True
    moves: list[Stream | Seek | None] = []
    prev: CursorState | None = None

    def hand_over() -> None:
        nonlocal prev
        state = CursorState(timeline.cursor, timeline.playing, now[0], timeline.speed)
        moves.append(plan_move(prev, state))
        prev = state

    timeline.pause()
    hand_over()
    timeline.play()  # at the end: from the start
    hand_over()
    for _ in range(4):
        now[0] += 2.0
        timeline.tick()
        hand_over()
    timeline.seek(6.0)  # the bar, while playing
    hand_over()
    for _ in range(2):  # 6 -> 8 -> 10 past the end: loops back to the start
        now[0] += 2.0
        timeline.tick()
        hand_over()
    assert moves == [
        Seek(9.0),
        Seek(0.5),
        Stream(0.5, 2.5),
        Stream(2.5, 4.5),
        Stream(4.5, 6.5),
        Stream(6.5, 8.5),
        Seek(6.0),
        Stream(6.0, 8.0),
        Seek(0.5),
    ]


# -- the republisher with a real recording and a real subscriber ------------------------------------------


@pytest.fixture
def peer() -> Iterator[RosPeer]:
    """A real ROS 2 participant in this process."""
    with RosPeer("republish_test_peer") as p:
        yield p


def _latched() -> Any:
    from rclpy.qos import DurabilityPolicy, QoSProfile, ReliabilityPolicy

    return QoSProfile(
        depth=1000, reliability=ReliabilityPolicy.RELIABLE, durability=DurabilityPolicy.TRANSIENT_LOCAL
    )


def _settled(values: Callable[[], list[Any]], n: int, timeout: float = 15.0) -> list[Any]:
    """Wait for at least `n` values, then a moment for any extra one; return them."""
    assert wait_until(lambda: len(values()) >= n, timeout), values()
    time.sleep(0.3)
    return values()


def test_republisher_streams_what_plays_and_sends_the_state_after_a_seek(
    peer: RosPeer, tmp_path: Path
) -> None:
    """Playing sends each message passed in order; a seek or jump the state at t; /clock; unknowns named."""
    from geometry_msgs.msg import Twist
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Float64, String

    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._data._timeline import Timeline
    from dbglog.viewer._publishing._republish import Republisher

    source = load_replay(write_recording(tmp_path / "run.mcap"))
    speed, mode = peer.subscribe(SPEED, Float64, _latched()), peer.subscribe(MODE, String, _latched())
    cmd, clock = peer.subscribe(CMD, Twist, _latched()), peer.subscribe("/clock", Clock, 100)
    now = [0.0]
    timeline = Timeline(source, ticks=lambda: now[0], recording=True)
    republisher = Republisher(ticks=lambda: now[0])
    republisher.start()

    def hand_over() -> None:
        republisher.follow(source, timeline.cursor, playing=timeline.playing, speed=timeline.speed)
        assert republisher.wait_idle(10.0)

    try:
        timeline.pause()  # as the viewer opens: at the end
        hand_over()
        assert _settled(speed.values, 1) == [(N - 1) * 0.5]
        assert mode.values() == [f"mode {(N - 1) // 50}"]
        notes = republisher.take_notes()
        assert len(notes) == 1
        assert ODD in notes[0]
        assert "rr_nowhere_msgs/msg/Odd" in notes[0]
        assert SPEED not in notes[0]

        timeline.seek(T0 + 5.05)  # i = 50
        hand_over()
        assert _settled(speed.values, 2)[1:] == [25.0]
        assert mode.values()[1:] == ["mode 1"]
        assert [m.linear.x for m in cmd.messages][1:] == [50.0]

        timeline.play()
        for _ in range(40):  # 2 s at 1x, in frames of 50 ms
            now[0] += 0.05
            timeline.tick()
            hand_over()
        played = _settled(speed.values, 2 + 20)[2:]
        assert played == [(50 + k) * 0.5 for k in range(1, 21)]
        assert [m.linear.x for m in cmd.messages][2:] == [float(50 + k) for k in range(1, 21)]
        assert mode.values()[2:] == []  # the next mode is at 10 s
        assert wait_until(lambda: len(clock.messages) > 0)
        last = clock.messages[-1].clock
        assert last.sec + last.nanosec * 1e-9 == pytest.approx(T0 + 7.05, abs=1e-6)

        timeline.seek(T0 + 12.0)  # while playing: a jump, not a stream
        now[0] += 0.05
        timeline.tick()
        hand_over()
        assert _settled(speed.values, 2 + 20 + 1)[22:] == [60.0]  # the state at 12.05 s: i = 120
        assert mode.values()[2:] == ["mode 2"]
        assert republisher.take_notes() == []
        assert republisher.jumped == 0
    finally:
        republisher.close()


def test_republisher_sends_the_end_state_of_a_stretch_too_long_to_stream(
    peer: RosPeer, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A playing stretch of more than MAX_STREAM messages is sent as the state at its end, said once."""
    from std_msgs.msg import Float64

    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._publishing import _republish
    from dbglog.viewer._publishing._republish import Republisher

    monkeypatch.setattr(_republish, "MAX_STREAM", 50)
    source = load_replay(write_recording(tmp_path / "run.mcap"))
    speed = peer.subscribe(SPEED, Float64, _latched())
    now = [0.0]
    republisher = Republisher(ticks=lambda: now[0], publish_clock=False)
    republisher.start()
    try:
        republisher.follow(source, T0 + 0.05, playing=True, speed=10.0)
        assert republisher.wait_idle(10.0)
        now[0] += 1.0  # 10 s at 10x: 100 speeds, 100 twists, 2 modes
        republisher.follow(source, T0 + 10.05, playing=True, speed=10.0)
        assert republisher.wait_idle(10.0)
        assert _settled(speed.values, 2) == [0.0, 50.0]
        assert republisher.jumped == 202
        (note,) = republisher.take_notes()[-1:]
        assert "202 messages" in note
        now[0] += 0.1  # then 1 s at 10x streams again
        republisher.follow(source, T0 + 11.05, playing=True, speed=10.0)
        assert republisher.wait_idle(10.0)
        assert _settled(speed.values, 12)[2:] == [50.0 + 0.5 * k for k in range(1, 11)]
    finally:
        republisher.close()


def test_another_recording_opened_is_republished_and_live_data_never(peer: RosPeer, tmp_path: Path) -> None:
    """A recording opened in place of another is republished (the old one's topics go); live data never."""
    from std_msgs.msg import Float64

    from dbglog.record import McapWriter
    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._publishing._republish import Republisher

    first = load_replay(write_recording(tmp_path / "run.mcap"))
    w = McapWriter(tmp_path / "other.mcap")
    other_topic = w.add_channel("/rr_other", "std_msgs/msg/Float64")
    w.write(other_topic, T0_NS, b"\x00\x01\x00\x00" + np.float64(4.25).tobytes(), T0_NS)
    w.close()
    second = load_replay(tmp_path / "other.mcap")
    other = peer.subscribe("/rr_other", Float64, _latched())
    republisher = Republisher(publish_clock=False)
    republisher.start()
    try:
        republisher.follow(first, T0 + 3.05, playing=False)
        assert republisher.wait_idle(10.0)
        assert wait_until(lambda: peer.node.count_publishers(CMD) == 1), "the first recording's publisher"
        republisher.follow(second, T0, playing=False)
        assert republisher.wait_idle(10.0)
        assert _settled(other.values, 1) == [4.25]
        assert wait_until(lambda: peer.node.count_publishers(CMD) == 0), "its publisher is gone"
        sent = republisher.published
        republisher.follow(object(), None, playing=False)  # back to live
        republisher.follow(object(), T0 + 1.0, playing=False)
        assert republisher.wait_idle(10.0)
        assert republisher.published == sent
    finally:
        republisher.close()


# -- the command line -----------------------------------------------------------------------------------


def test_republish_without_replay_is_a_clear_error() -> None:
    """`dbglog view --republish` without --replay: one line saying it needs a recording, exit 2."""
    done = subprocess.run(
        [sys.executable, "-m", "dbglog", "view", "--republish"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert done.stderr.strip() == (
        "dbglog view: error: --republish needs --replay FILE (it publishes a recording's messages)"
    )


def _xdo(display: str, *args: str) -> str:
    done = subprocess.run(
        ["xdotool", *args],
        env={**os.environ, "DISPLAY": display},
        capture_output=True,
        text=True,
        timeout=30,
        check=True,
    )
    return done.stdout


@pytest.mark.gui
def test_cli_republish_follows_the_keyboard(display: str, peer: RosPeer, tmp_path: Path) -> None:
    """The real viewer's Home, Space, Space, Right: start state, every message in order, pause, next state."""
    from rosgraph_msgs.msg import Clock
    from std_msgs.msg import Float64

    rec = write_recording(tmp_path / "run.mcap")
    speed = peer.subscribe(SPEED, Float64, _latched())
    clock = peer.subscribe("/clock", Clock, 100)
    err = (tmp_path / "stderr.txt").open("w")
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "view", "--replay", str(rec), "--republish", "--size", "1000x700"],
        env={**os.environ, "DISPLAY": display},
        cwd=ROOT,
        stdout=subprocess.DEVNULL,
        stderr=err,
    )

    def key(name: str) -> None:
        _xdo(display, "keydown", name)
        time.sleep(0.2)
        _xdo(display, "keyup", name)

    def clock_now() -> float:
        c = clock.messages[-1].clock if clock.messages else None
        return math.nan if c is None else c.sec + c.nanosec * 1e-9

    try:
        assert wait_until(lambda: speed.values() == [(N - 1) * 0.5], 60), (speed.values(), proc.poll())
        window = _xdo(display, "search", "--sync", "--pid", str(proc.pid)).split()[0]
        _xdo(display, "windowfocus", "--sync", window)
        key("Home")
        assert wait_until(lambda: speed.values()[1:] == [0.0], 30), speed.values()
        assert wait_until(lambda: clock_now() == pytest.approx(T0, abs=1e-6), 10), clock_now()
        key("space")
        assert wait_until(lambda: len(speed.values()) >= 2 + 15, 30), speed.values()
        key("space")
        # Paused: what was sent before the pause arrives (later on a loaded machine), then nothing more.
        assert wait_quiet(lambda: len(speed.values()), 1.0), speed.values()
        played = speed.values()[1:]
        assert played == [0.5 * k for k in range(len(played))], played
        paused_at = clock_now()
        assert paused_at >= T0 + (len(played) - 1) * 0.1 - 1e-6
        time.sleep(0.5)
        assert speed.values()[1:] == played  # paused: nothing more
        key("Right")  # a step to the next message: the state there, once
        assert wait_until(lambda: len(speed.values()) > 1 + len(played), 10), speed.values()
        assert wait_quiet(lambda: len(speed.values()), 0.5), speed.values()
        assert speed.values()[1 + len(played) :] == [played[-1] + 0.5]
        proc.send_signal(signal.SIGINT)
        assert proc.wait(30) == 130  # as dbglog commands end on SIGINT
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait(10)
        err.close()
    stderr = (tmp_path / "stderr.txt").read_text()
    assert f"dbglog view: warning: republish: 1 topic(s) not republished: {ODD}" in stderr, stderr
    assert "Traceback" not in stderr


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the window of ``dbglog view --replay run.mcap --republish``, reporting it."""
    import warnings

    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)  # rclpy's import of sre_parse
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._cli._cli_view import follow_cursor, open_replay, start_republisher
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from tests.test_ui_menus import _menubar

    tmp = Path(tmp_dir)
    replay = open_replay(tmp / "run.mcap", stale_after=2.0)
    republisher = start_republisher()
    assert replay is not None
    assert republisher is not None
    assert scenario == "republish"
    app = ViewerApp(replay, WidgetRegistry.builtin(), width=1000, height=700, recording=True)
    app.recordings.republisher = republisher
    app.start()
    app.cursor_hooks.append(functools.partial(follow_cursor, app, republisher))

    def report() -> None:
        state = {
            "frame": app.loop.rendered,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "cursor": app.timeline.cursor,
            "menubar": _menubar(app.main),
            "republishing": republisher.enabled,
        }
        report_frame(app, tmp / "probe", state)

    app.frame_hooks.append(report)
    try:
        app.run()
    finally:
        app.close()
        republisher.close()


@pytest.mark.gui
def test_view_menu_switches_republishing_off_and_on(display: str, peer: RosPeer, tmp_path: Path) -> None:
    """View \u203a Republish on ROS 2 clicked off: a seek sends nothing; on again: the state at the cursor."""
    from std_msgs.msg import Float64

    write_recording(tmp_path / "run.mcap")
    speed = peer.subscribe(SPEED, Float64, _latched())
    v = ViewerChild("republish", tmp_path, display, "test_republish")

    def click_republish() -> None:
        view = v.state()["menubar"]["View"]
        (fx, fy), (tw, th) = view["pos"], view["size"]
        v.click(fx + tw / 2, fy + th / 2 + 3)
        entry = "Republish on ROS 2"
        state = v.wait_for(lambda s: s["menubar"]["View"]["entries"].get(entry, [0, 0])[1] > 0)
        ex, ey = state["menubar"]["View"]["entries"][entry]
        v.click(fx + ex + 20, th + 2 * 5 + ey + th / 2)

    try:
        v.ready()
        assert wait_until(lambda: speed.values() == [(N - 1) * 0.5], 30), speed.values()
        click_republish()
        v.wait_for(lambda s: not s["republishing"])
        v.key("Home")
        v.wait_for(lambda s: s["cursor"] == pytest.approx(T0))
        time.sleep(0.5)
        assert speed.values() == [(N - 1) * 0.5]  # switched off: the seek went nowhere
        click_republish()
        v.wait_for(lambda s: s["republishing"])
        assert wait_until(lambda: speed.values()[1:] == [0.0], 10), speed.values()
    finally:
        v.stop()
