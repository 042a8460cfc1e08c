"""Replay and the File menu's recordings under Xvfb, driven by the real mouse and keyboard (xdotool).

A recording of known values is written with dbglog's `McapWriter` (CDR from `rclpy.serialization`).
`dbglog view --replay` runs as a real process for the command-line cases; for the window cases the real
viewer runs in a child process whose frame hook reports what it shows (the cursor, playback, the widgets'
values, where the bar's buttons, the menus and the dialogs are); the live case has the real data engine
and a real ROS 2 publisher in this process. Nothing here calls the viewer's handlers.
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests._ros import RosPeer, wait_until
from tests._viewer_child import ROOT, ViewerChild, report_frame

pytestmark = pytest.mark.gui

T0_NS = 1_700_000_000_000_000_000
T0 = T0_NS * 1e-9
STEP_S = 0.1
N = 600
"""The recording: 60 s at 10 Hz."""
SPEED, MODE, NEAR, CMD = "/rosdashboard/rp_speed", "/rosdashboard/rp_mode", "/rosdashboard/rp_near", "/rp_cmd"


def speed_at(t: float) -> float | None:
    """The speed the recording holds at time `t` (the last sample at or before it)."""
    i = math.floor((t - T0) / STEP_S + 1e-6)
    return None if i < 0 else min(i, N - 1) * 0.5


def mode_at(t: float) -> str | None:
    """The mode the recording holds at `t` (it changes every 5 s)."""
    i = math.floor((t - T0) / STEP_S + 1e-6)
    return None if i < 0 else f"mode {min(i, N - 1) // 50}"


def write_recording(path: Path, *, chunk_bytes: int = 1 << 20) -> Path:
    """A 60 s recording: a speed (i/2 at 10 Hz), a mode every 5 s, a bool every 3 s, a Twist at 10 Hz."""
    from geometry_msgs.msg import Twist
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Bool, Float64, String

    from dbglog.record import McapWriter

    w = McapWriter(path, chunk_bytes=chunk_bytes)
    speed = w.add_channel(SPEED, "std_msgs/msg/Float64")
    mode = w.add_channel(MODE, "std_msgs/msg/String")
    near = w.add_channel(NEAR, "std_msgs/msg/Bool")
    cmd = w.add_channel(CMD, "geometry_msgs/msg/Twist")
    for i in range(N):
        t = T0_NS + i * 100_000_000
        w.write(speed, t, serialize_message(Float64(data=i * 0.5)), t)
        if i % 50 == 0:
            w.write(mode, t, serialize_message(String(data=f"mode {i // 50}")), t)
        if i % 30 == 0:
            w.write(near, t, serialize_message(Bool(data=(i // 30) % 2 == 1)), t)
        twist = Twist()
        twist.linear.x = float(i)
        w.write(cmd, t, serialize_message(twist), t)
    w.close()
    return path


def replay_dashboard(tmp: Path, *, plot_window: float = 10.0) -> Path:
    """A dial and a plot of the speed, a String of the mode, an LED, a plot of a Twist field, a toggle."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    speed = Binding(SPEED, "data")
    widgets = [  # the control first: its publishing service starts while the others are being filled
        WidgetConfig("toggle", "Fan", 680, 300, 200, 80, (Binding("/rp_fan"),), {"state": True}),
        WidgetConfig("dial", "Speed", 20, 20, 240, 260, (speed,), {"minimum": 0, "maximum": 300}),
        WidgetConfig("plot", "Plot", 280, 20, 420, 260, (speed,), {"window": plot_window}),
        WidgetConfig("string", "Mode", 720, 20, 280, 260, (Binding(MODE, "data"),), {}),
        WidgetConfig("led", "Near", 20, 300, 200, 160, (Binding(NEAR, "data"),), {}),
        WidgetConfig("plot", "Cmd", 240, 300, 420, 200, (Binding(CMD, "linear.x"),), {}),
    ]
    path = tmp / "replay.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


# -- the command line ------------------------------------------------------------------------------------


def view(display: str, *args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    """Run ``dbglog view ARGS`` on the display."""
    return subprocess.run(
        [sys.executable, "-m", "dbglog", "view", *args],
        env={**os.environ, "DISPLAY": display},
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
    )


def test_cli_replay_screenshot_at_a_cursor_reports_the_recorded_values(display: str, tmp_path: Path) -> None:
    """`--replay FILE DASH --screenshot --cursor T --report-json`: each widget shows the file's value at T."""
    rec, dash = write_recording(tmp_path / "run.mcap"), replay_dashboard(tmp_path)
    for cursor, expected in (("-12.34", T0 + 59.9 - 12.34), (f"{T0 + 21.05:.3f}", T0 + 21.05)):
        png, report = tmp_path / "shot.png", tmp_path / "r.json"
        done = view(
            display, str(dash), "--replay", str(rec), "--screenshot", str(png), "--after", "0.3",
            "--cursor", cursor, "--report-json", str(report),
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        assert "warning" not in done.stderr
        assert png.stat().st_size > 0
        data = json.loads(report.read_text())
        assert data["replay"] == str(rec)
        assert data["span"] == pytest.approx([T0, T0 + 59.9])
        assert data["cursor"] == pytest.approx(expected, abs=1e-6)
        widgets = {w["name"]: w for w in data["widgets"]}
        t = data["cursor"]
        assert widgets["Speed"]["values"] == [speed_at(t)]
        assert widgets["Plot"]["values"] == [speed_at(t)]
        assert widgets["Mode"]["values"] == [mode_at(t)]
        assert widgets["Near"]["values"] == [math.floor((t - T0) / 3) % 2 == 1]
        assert widgets["Cmd"]["values"] == [float(round((speed_at(t) or 0) * 2))]
        assert widgets["Speed"]["samples"] == [N]
        assert widgets["Mode"]["samples"] == [N // 50]
        assert widgets["Speed"]["status"] == "live"
        # A control in a replay still publishes (its service imports rclpy while the replay decodes).
        assert [w["name"] for w in data["widgets"] if w["status"] == "error"] == []


def shown_by_topic(report: dict[str, Any]) -> dict[str, tuple[str, Any]]:
    """Each topic's widget type and the value shown for it (a widget may show several topics)."""
    return {
        b["topic"]: (w["type"], value)
        for w in report["widgets"]
        for b, value in zip(w["bindings"], w["values"], strict=True)
    }


def test_cli_replay_without_a_dashboard_shows_every_topic_and_its_end(display: str, tmp_path: Path) -> None:
    """Without DASH the automatic dashboard has a widget per tag and topic of the file, shown at its end."""
    rec = write_recording(tmp_path / "run.mcap")
    png, report = tmp_path / "auto.png", tmp_path / "r.json"
    done = view(
        display,
        "--replay",
        str(rec),
        "--screenshot",
        str(png),
        "--after",
        "0.5",
        "--report-json",
        str(report),
    )
    assert done.returncode == 0, done.stderr
    data = json.loads(report.read_text())
    assert data["cursor"] == pytest.approx(T0 + 59.9)
    bound = {b["topic"] for w in data["widgets"] for b in w["bindings"]}
    assert bound == {SPEED, MODE, NEAR, CMD}
    shown = shown_by_topic(data)
    assert shown[SPEED][1] == speed_at(T0 + 59.9)
    assert shown[MODE] == ("states", "mode 11")
    assert shown[NEAR][0] == "states"
    cmd = next(w for w in data["widgets"] if w["bindings"][0]["topic"] == CMD)
    assert cmd["bindings"][0]["field"] == "linear.x"


def test_cli_replay_of_files_without_an_index_plays_every_message(display: str, tmp_path: Path) -> None:
    """`--replay` of an index-less file (the `mcap` writer: no chunks, or no index and no summary) holds
    every message, and says once on stderr that it had no index and how long the scan took."""
    from mcap.writer import CompressionType, IndexType

    from tests import _mcap_layouts
    from tests._mcap_layouts import Layout, write

    n = _mcap_layouts.N
    for i, layout in enumerate(
        (
            Layout(False, CompressionType.NONE, IndexType.ALL, True, True, True, True, True),
            Layout(True, CompressionType.ZSTD, IndexType.NONE, False, False, False, False, True),
        )
    ):
        rec, report = write(tmp_path / f"plain{i}.mcap", layout), tmp_path / f"r{i}.json"
        done = view(
            display, "--replay", str(rec), "--screenshot", str(tmp_path / f"p{i}.png"), "--after", "0.3",
            "--report-json", str(report),
        )  # fmt: skip
        assert done.returncode == 0, done.stderr
        notes = [line for line in done.stderr.splitlines() if "warning" in line]
        assert len(notes) == 1, done.stderr
        assert f"{rec}: no " in notes[0]
        assert f"read by scanning the whole file: {3 * n} messages in " in notes[0]
        widgets = json.loads(report.read_text())["widgets"]
        samples = {
            (b["topic"], b["field"]): held
            for w in widgets
            for b, held in zip(w["bindings"], w["samples"], strict=True)
        }
        assert samples[("/rosdashboard/speed", "")] == n
        assert shown_by_topic({"widgets": widgets})["/rosdashboard/speed"][1] == (n - 1) * 0.5
        assert {held for (topic, _f), held in samples.items() if topic == "/cmd_vel"} == {
            n
        }  # each Twist field


# A window over a recording takes a screenshot to a new file, then one that fails (no time to capture) over
# a file already there, and closes without drawing again. Prints the old file's bytes after the failure.
_SHOTS = """
import sys
from pathlib import Path
from dbglog.viewer._data._replay import load_replay
from dbglog.viewer._ui import ViewerApp
from dbglog.viewer._widgets import WidgetRegistry

folder = Path(sys.argv[2])
app = ViewerApp(load_replay(sys.argv[1]), WidgetRegistry.builtin(), width=640, height=480)
app.start()
try:
    app.screenshot(folder / "new.png")
    try:
        app.screenshot(folder / "old.png", timeout=0)
    except TimeoutError as exc:
        print("failed:", exc)
    print((folder / "old.png").read_text())
finally:
    app.close()
"""


def test_screenshots_get_the_umask_and_a_failed_one_keeps_the_file_there(
    display: str, tmp_path: Path
) -> None:
    """A screenshot is a new file with 0666 less the umask; one that fails leaves the file it was to
    replace as it was (bytes and mode) and nothing temporary beside it."""
    rec = write_recording(tmp_path / "run.mcap")
    shots = tmp_path / "shots"
    shots.mkdir()
    (shots / "old.png").write_text("an older picture")
    (shots / "old.png").chmod(0o600)
    done = subprocess.run(
        [sys.executable, "-c", _SHOTS, str(rec), str(shots)],
        env={**os.environ, "DISPLAY": display},
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        umask=0o027,
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        f"failed: {shots / 'old.png'}: the window was not captured within 0 s",
        "an older picture",
    ]
    assert sorted(p.name for p in shots.iterdir()) == ["new.png", "old.png"]
    assert (shots / "new.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert (shots / "new.png").stat().st_mode & 0o777 == 0o640
    assert (shots / "old.png").read_text() == "an older picture"
    assert (shots / "old.png").stat().st_mode & 0o777 == 0o600


def test_cli_replay_of_a_damaged_or_missing_file(display: str, tmp_path: Path) -> None:
    """A cut-short file plays its readable part with warnings on stderr; a missing or foreign file is one
    line and exit 1."""
    rec = write_recording(tmp_path / "run.mcap", chunk_bytes=4096)  # many chunks: most survive a cut
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(rec.read_bytes()[: rec.stat().st_size * 2 // 3])
    report = tmp_path / "r.json"
    done = view(
        display, str(replay_dashboard(tmp_path)), "--replay", str(cut),
        "--screenshot", str(tmp_path / "c.png"), "--after", "0.3", "--report-json", str(report),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    warnings_seen = [line for line in done.stderr.splitlines() if "warning" in line]
    assert warnings_seen
    assert all(str(cut) in line for line in warnings_seen), done.stderr
    assert "Traceback" not in done.stderr
    data = json.loads(report.read_text())
    speed = next(w for w in data["widgets"] if w["name"] == "Speed")
    assert 0 < speed["samples"][0] < N  # the readable part
    assert speed["values"] == [speed_at(data["span"][1])]

    for bad, why in ((tmp_path / "nope.mcap", "no such file"), (tmp_path / "junk.json", "not an MCAP file")):
        if bad.suffix == ".json":
            bad.write_text("{}")
        done = view(display, "--replay", str(bad), "--screenshot", str(tmp_path / "x.png"))
        assert done.returncode == 1
        assert done.stderr.strip().count("\n") == 0, done.stderr
        assert done.stderr.startswith(f"dbglog view: error: {bad}: {why}"), done.stderr
        assert not (tmp_path / "x.png").exists()


# -- the window: a probe reporting what it shows ---------------------------------------------------------


def _icon(app: Any, which: str) -> list[float] | None:
    import dearpygui.dearpygui as dpg

    group = app.timebar.loop_group if which == "loop" else app.timebar.play
    if not dpg.is_item_shown(group):
        return None
    r = app.timebar.icon_rect(which)
    return [r.x, r.y, r.w, r.h]


class Probe:
    """Frame hook: what the viewer shows, to ``state.json``; screenshots on request."""

    def __init__(self, app: Any, tmp: Path) -> None:
        self.app, self.tmp = app, tmp

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._ui._auto import json_value
        from dbglog.viewer._ui._dialogs import SaveAsDialog
        from tests.test_ui_menus import _labelled, _menubar, _rect, _window_rect

        app = self.app
        timeline, bar = app.timeline, app.timebar
        ox, oy = app.canvas.origin()
        items = {
            i.name: {
                "rect": [i.rect.x + ox, i.rect.y + oy, i.rect.w, i.rect.h],
                "values": [json_value(s.last) for s in i.snapshots(timeline)],
                "times": [s.last_time for s in i.snapshots(timeline)],
                "topics": [b.topic for b in i.series],
                # A plot: frames whose lines the line worker drew (shown a frame later), the newest drawn.
                "lines_later": getattr(i.widget, "lines_later", None),
                "drawn_to": getattr(i.widget, "drawn_to", None),
            }
            for i in app.items
        }
        state: dict[str, Any] = {
            "pid": os.getpid(),
            "frame": app.loop.rendered,
            "clock": time.monotonic(),
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "recording": timeline.recording,
            "replay": app.time.replay_name,
            "live": timeline.live,
            "cursor": timeline.cursor,
            "playing": timeline.playing,
            "speed": timeline.speed,
            "loop": timeline.loop,
            "span": list(app.time.time_span() or ()) or None,
            "play": _icon(app, "play"),
            "loop_button": _icon(app, "loop"),
            "speed_button": _rect(bar.speed),
            "speed_label": dpg.get_item_label(bar.speed),
            "speed_menu": _labelled(bar.speed_menu) if bar.speed_menu_open else None,
            "track": _rect(bar.track),
            "scale": None
            if bar.scale is None
            else [bar.scale.oldest, bar.scale.newest, bar.scale.x0, bar.scale.x1],
            "menubar": _menubar(app.main),
            "items": items,
            "selected": app.doc.selected.name if app.doc.selected is not None else None,
            "status": app.status.text,
            "status_left": dpg.get_value(app.status.info),
            "dialog": None,
            "back_to_live": bool(dpg.is_item_shown(app.menus.entries["recording.back_to_live"])),
        }
        dialog = app.dialog
        if dialog is not None:
            info: dict[str, Any] = {
                "kind": type(dialog).__name__,
                "title": dpg.get_item_label(dialog.window),
                "rect": _window_rect(dialog.window),
                "controls": _labelled(dialog.window),
            }
            if isinstance(dialog, SaveAsDialog):
                choice = app.recordings._choice
                info.update(
                    name=dpg.get_value(dialog.name_input),
                    name_active=bool(dpg.is_item_active(dialog.name_input)),
                    folder=str(dialog.folder),
                    note=dpg.get_value(dialog.error),
                    ranges=[r.label for r in app.recordings._ranges],
                    radio=_rect(choice) if choice is not None and dpg.does_item_exist(choice) else None,
                    radio_value=dpg.get_value(choice)
                    if choice is not None and dpg.does_item_exist(choice)
                    else None,
                )
            state["dialog"] = info
        return state

    def hook(self) -> None:
        """Report; write screenshots asked for with ``shot-NAME.request`` files."""
        report_frame(self.app, self.tmp, self.state())


LIVE_TAG = "/rosdashboard/rp_live"
LIVE_HZ = 20.0


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: ``replay`` (the recording and its dashboard) or ``live`` (the real engine)."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)  # rclpy's import of sre_parse
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._document._dashboard import (
        Dashboard,
        RawWidget,
        WidgetConfig,
        load_dashboard,
        save_dashboard,
    )
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()

    def run(app: ViewerApp, dash: Path) -> None:
        app.start()
        try:
            app.load(load_dashboard(dash, registry.get), dash)
            probe = Probe(app, tmp / "probe")
            app.frame_hooks.append(probe.hook)
            app.run()
        finally:
            app.close()

    if scenario == "replay":
        rec = write_recording(tmp / "run.mcap")
        run(
            ViewerApp(load_replay(rec), registry, width=1280, height=760, recording=True),
            replay_dashboard(tmp),
        )
        return
    from dbglog.viewer._data._engine import Engine

    count = Binding(LIVE_TAG, "data")
    widgets = [
        WidgetConfig("dial", "Count", 20, 20, 240, 260, (count,), {"minimum": 0, "maximum": 1000}),
        WidgetConfig("plot", "Plot", 280, 20, 420, 260, (count,), {"window": 2.0}),
    ]
    dash = tmp / "live.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), dash)
    with Engine(stale_after=2.0) as engine:
        run(ViewerApp(engine, registry, width=1280, height=760), dash)


class Viewer(ViewerChild):
    """The real viewer in a child process, with this module's probe."""

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        super().__init__(scenario, tmp, display, "test_ui_replay")

    def click_rect(self, rect: list[float]) -> None:
        """Click the middle of an [x, y, w, h] rectangle."""
        self.click(rect[0] + rect[2] / 2, rect[1] + rect[3] / 2)

    def menu(self, label: str) -> None:
        """Click File, then its entry `label`, with the mouse."""
        self.menu_entry("File", label)

    def track_point(self, fraction: float) -> tuple[float, float]:
        """The window pixel `fraction` of the way along the timeline's track."""
        state = self.state()
        x, y, _w, _h = state["track"]
        _oldest, _newest, x0, x1 = state["scale"]
        return x + x0 + fraction * (x1 - x0), y + 11


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start a viewer child (``replay`` or ``live``) and wait for its first frames; killed at the end."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start(scenario: str) -> Viewer:
        v = Viewer(scenario, tmp_path, display)
        started.append(v)
        v.ready()
        return v

    yield start
    for v in started:
        v.stop()


def rate(v: Viewer, seconds: float) -> float:
    """How many seconds of the recording the cursor crossed per second of the clock, over `seconds`."""
    a = v.frames(2)
    time.sleep(seconds)
    b = v.frames(2)
    return float((b["cursor"] - a["cursor"]) / (b["clock"] - a["clock"]))


def test_play_speed_and_loop_by_mouse(viewer: Callable[[str], Viewer]) -> None:
    """The play button plays from the start at 1x, the speed menu makes it 5x, the loop toggle loops; paused,
    the window idles and the widgets show the file's values at the cursor."""
    v = viewer("replay")
    state = v.wait_for(lambda s: s["cursor"] is not None)
    assert state["recording"]
    assert state["replay"] == "run.mcap"
    assert "replay of run.mcap" in state["status_left"]
    assert state["cursor"] == pytest.approx(T0 + 59.9)  # opens at its end
    assert not state["playing"]
    assert state["back_to_live"] is False
    v.click_rect(state["play"])
    state = v.wait_for(lambda s: s["playing"])
    assert state["cursor"] < T0 + 5  # from the end, play starts again at the start
    assert rate(v, 1.5) == pytest.approx(1.0, abs=0.25)

    v.click_rect(v.state()["speed_button"])
    state = v.wait_for(lambda s: s["speed_menu"] is not None)
    assert list(state["speed_menu"]) == [
        "0.1\u00d7",
        "0.25\u00d7",
        "0.5\u00d7",
        "1\u00d7",
        "2\u00d7",
        "5\u00d7",
        "10\u00d7",
    ]
    v.click_rect(state["speed_menu"]["5\u00d7"])
    state = v.wait_for(lambda s: s["speed"] == 5.0 and s["speed_menu"] is None)
    assert state["speed_label"] == "5\u00d7"
    assert state["playing"]
    assert rate(v, 1.5) == pytest.approx(5.0, rel=0.2)

    v.click_rect(v.state()["play"])  # pause
    state = v.wait_for(lambda s: not s["playing"])
    held = v.frames(3)
    assert held["cursor"] == state["cursor"]
    t = held["cursor"]
    assert held["items"]["Speed"]["values"] == [speed_at(t)]
    assert held["items"]["Mode"]["values"] == [mode_at(t)]
    assert held["items"]["Cmd"]["values"] == [float(round((speed_at(t) or 0) * 2))]
    v.move(5, 300)  # away from the buttons, then leave it alone (input keeps it drawing for a second)
    time.sleep(1.5)
    idle_from = v.state()
    time.sleep(2.0)
    idle_to = v.state()
    assert idle_to["cursor"] == held["cursor"]
    assert idle_to["frame"] - idle_from["frame"] <= 8, "a paused replay keeps rendering"
    shot = v.shot("paused")

    v.click_rect(v.state()["loop_button"])
    v.wait_for(lambda s: s["loop"])
    x, y = v.track_point(0.97)
    v.click(x, y)  # near the end
    v.wait_for(lambda s: s["cursor"] > T0 + 55)
    v.key("space")  # plays (a recording: Space plays and pauses)
    state = v.wait_for(lambda s: s["playing"] and s["cursor"] < T0 + 20)  # looped round to the start
    v.key("space")
    v.wait_for(lambda s: not s["playing"])
    assert shot.stat().st_size > 0


def test_a_continuous_drag_in_a_replay_ends_drawn_at_the_cursor(viewer: Callable[[str], Viewer]) -> None:
    """A hand's drag along the bar (a move every few ms, ending in a jump of seconds): the plots' lines go
    to the line worker while the cursor moves, and once it stops they are the cursor's at once, though in a
    replay nothing new arrives to redraw them."""
    v = viewer("replay")
    v.wait_for(lambda s: s["cursor"] is not None)
    x, y = v.track_point(0.2)
    far_x, end_x = v.track_point(0.65)[0], v.track_point(0.8)[0]
    v.click(x, y)
    v.wait_for(lambda s: s["cursor"] < T0 + 20)
    before = v.state()["items"]["Plot"]["lines_later"]
    state = v.hand_drag((x, y), far_x, end_x)
    t = state["cursor"]
    plot = state["items"]["Plot"]
    seen = f"cursor {t!r}, plot {plot}\n{v.output()}"
    assert t > T0 + 40, seen
    assert plot["lines_later"] > before, f"the plot's lines never went to the line worker: {seen}"
    assert plot["values"] == [speed_at(t)], seen
    # The newest point drawn is the recording's last sample at the cursor, not a frame-old one.
    assert plot["drawn_to"] == plot["times"][0] <= t, seen


# -- the File menu -------------------------------------------------------------------------------------------


class Feed:
    """A real ROS 2 publisher of a counter at 20 Hz on a tag topic."""

    def __init__(self) -> None:
        from std_msgs.msg import Float64

        self.peer = RosPeer("replay_feed")
        self.pub = self.peer.publisher(LIVE_TAG, Float64)
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from std_msgs.msg import Float64

        start = time.monotonic()
        while not self._stop.is_set():
            self.sent += 1
            self.pub.publish(Float64(data=float(self.sent)))
            self._stop.wait(max(0.0, start + self.sent / LIVE_HZ - time.monotonic()))

    def close(self) -> None:
        """Stop publishing and leave the graph."""
        self._stop.set()
        self._thread.join(5)
        self.peer.close()


@pytest.fixture
def feed() -> Iterator[Feed]:
    """The counter, publishing for the test."""
    f = Feed()
    yield f
    f.close()


def type_name(v: Viewer, name: str) -> dict[str, Any]:
    """Type `name` over the dialog's pre-filled name (it starts selected) and wait until it shows."""
    v.wait_for(lambda s: s["dialog"] is not None and s["dialog"].get("name_active"))
    v.type(name)
    return v.wait_for(lambda s: s["dialog"]["name"] == name)


def test_save_history_and_export_csv_by_mouse(
    viewer: Callable[[str], Viewer], feed: Feed, tmp_path: Path
) -> None:
    """File > Save history as recording... writes everything held as MCAP (it replays value by value);
    File > Export CSV... writes the selected plot's window; asking again before replacing a file."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._data._replay import load_replay

    v = viewer("live")
    v.wait_for(lambda s: s["span"] is not None and s["span"][1] - s["span"][0] > 3.0, timeout=60)

    v.menu("Save history as recording\u2026")
    state = v.wait_for(
        lambda s: s["dialog"] is not None and s["dialog"]["title"] == "Save history as recording"
    )
    dialog = state["dialog"]
    assert dialog["name"].startswith("history-")
    assert dialog["name"].endswith(".mcap")
    assert dialog["folder"] == str(tmp_path)  # beside the dashboard
    assert dialog["ranges"][0].startswith("Everything held: ")
    assert dialog["ranges"][1].startswith("What the plots show: 2 s, ")
    type_name(v, "incident")
    sent_before = feed.sent
    v.key("Return")
    state = v.wait_for(lambda s: s["dialog"] is None and "saved" in s["status"])
    sent_after = feed.sent
    saved = tmp_path / "incident.mcap"
    assert str(saved) in state["status"]
    source = load_replay(saved)
    assert source.problems == []
    b = Binding(LIVE_TAG)
    source.bind(b)
    values = source.snapshot(b).values.tolist()
    assert len(values) >= 50
    assert values == [float(k) for k in range(int(values[0]), int(values[0]) + len(values))]  # none lost
    assert sent_before - LIVE_HZ <= values[-1] <= sent_after  # up to the moment of saving

    # Select the plot, pause, and export its 2 s window.
    plot = v.state()["items"]["Plot"]["rect"]
    v.click(plot[0] + 60, plot[1] + 12)
    v.wait_for(lambda s: s["selected"] == "Plot")
    v.key("space")
    paused = v.wait_for(lambda s: s["cursor"] is not None)
    v.menu("Export CSV\u2026")
    state = v.wait_for(lambda s: (s["dialog"] or {}).get("title") == "Export CSV" and s["dialog"]["radio"])
    assert state["dialog"]["ranges"][1].startswith("The window of 'Plot': 2 s, ")
    radio = state["dialog"]["radio"]
    v.click(radio[0] + 10, radio[1] + radio[3] * 0.75)  # the second choice
    v.wait_for(lambda s: s["dialog"]["radio_value"] == s["dialog"]["ranges"][1])
    name = v.state()["dialog"]["name"]
    v.click_rect(v.state()["dialog"]["controls"]["Export"])
    state = v.wait_for(lambda s: s["dialog"] is None and "exported" in s["status"])
    rows = list(csv.reader((tmp_path / name).read_text().splitlines()))
    assert rows[0] == ["time", f"{LIVE_TAG}.data"]
    times = [float(r[0]) for r in rows[1:]]
    counts = [float(r[1]) for r in rows[1:]]
    cursor = paused["cursor"]
    assert cursor - 2.0 - 1e-6 <= times[0]
    assert times[-1] <= cursor + 1e-6
    assert len(rows) - 1 == pytest.approx(2.0 * LIVE_HZ, abs=4)
    assert counts == [float(k) for k in range(int(counts[0]), int(counts[0]) + len(counts))]
    assert counts[-1] == v.state()["items"]["Count"]["values"][0]  # what the dial shows at the cursor

    # The same name again: the dialog asks first; a second press replaces it.
    v.menu("Export CSV\u2026")
    type_name(v, name.removesuffix(".csv"))  # the extension is added once
    v.key("Return")
    state = v.wait_for(lambda s: "already exists" in (s["dialog"] or {}).get("note", ""))
    before = (tmp_path / name).stat().st_mtime_ns
    v.click_rect(state["dialog"]["controls"]["Export"])
    v.wait_for(lambda s: s["dialog"] is None and "exported" in s["status"])
    assert (tmp_path / name).stat().st_mtime_ns >= before
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")], "no temporary file left"


def test_open_recording_by_mouse_replays_it_in_the_window(
    viewer: Callable[[str], Viewer], feed: Feed, tmp_path: Path
) -> None:
    """File > Open recording... on a live viewer replays the file with the same dashboard; Play plays it;
    File > Back to live returns to the live data."""
    v = viewer("live")
    v.wait_for(lambda s: s["items"]["Count"]["values"][0] is not None, timeout=60)
    rec = tmp_path / "other.mcap"
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64

    from dbglog.record import McapWriter

    with McapWriter(rec) as w:
        ch = w.add_channel(LIVE_TAG, "std_msgs/msg/Float64")
        for i in range(100):  # 7000 + i, 10 s at 10 Hz
            t = T0_NS + i * 100_000_000
            w.write(ch, t, serialize_message(Float64(data=7000.0 + i)), t)
    v.menu("Open recording\u2026")
    state = v.wait_for(lambda s: s["dialog"] is not None and s["dialog"]["title"] == "Open recording")
    assert state["dialog"]["folder"] == str(tmp_path)
    type_name(v, "other")  # .mcap added
    v.key("Return")
    state = v.wait_for(lambda s: s["dialog"] is None and s["recording"])
    assert state["replay"] == "other.mcap"
    assert state["cursor"] == pytest.approx(T0 + 9.9)
    assert state["items"]["Count"]["values"] == [7099.0]
    assert state["back_to_live"]
    v.key("Home")
    state = v.wait_for(lambda s: s["cursor"] == pytest.approx(T0))
    assert state["items"]["Count"]["values"] == [7000.0]
    v.click_rect(state["play"])
    v.wait_for(lambda s: s["playing"] and s["items"]["Count"]["values"][0] > 7005)
    v.key("space")
    state = v.wait_for(lambda s: not s["playing"])
    assert state["items"]["Count"]["values"] == [7000.0 + math.floor((state["cursor"] - T0) * 10 + 1e-6)]

    v.menu("Back to live")
    state = v.wait_for(lambda s: not s["recording"] and s["live"])
    assert not state["back_to_live"]
    assert state["loop_button"] is None  # a recording's control
    sent = feed.sent
    v.wait_for(
        lambda s: s["items"]["Count"]["values"][0] is not None and s["items"]["Count"]["values"][0] >= sent
    )

    # Live, the play button replays the history from a paused cursor and goes live once it catches up.
    v.click(*v.track_point(0.3))
    state = v.wait_for(lambda s: s["cursor"] is not None)
    v.click_rect(state["play"])
    v.wait_for(lambda s: s["playing"])
    v.click_rect(v.state()["speed_button"])
    state = v.wait_for(lambda s: s["speed_menu"] is not None)
    v.click_rect(state["speed_menu"]["10\u00d7"])
    v.wait_for(lambda s: s["live"] and not s["playing"])

    # A file that is not a recording: the dialog says so and stays open; the window stays live.
    (tmp_path / "junk.mcap").write_text("not mcap")
    v.menu("Open recording\u2026")
    type_name(v, "junk.mcap")
    v.key("Return")
    state = v.wait_for(lambda s: "not an MCAP file" in (s["dialog"] or {}).get("note", ""))
    assert str(tmp_path / "junk.mcap") in state["dialog"]["note"]
    assert not state["recording"]
    v.key("Escape")
    v.wait_for(lambda s: s["dialog"] is None)
    assert wait_until(lambda: v.proc.poll() is None, 0.5)
