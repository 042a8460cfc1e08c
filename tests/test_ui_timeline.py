"""The timeline under Xvfb with real input and real ROS: Space, the arrows, End, clicks on the bar, --cursor.

A real rclpy publisher in this process sends known values at known times (a counter at 5 Hz, a word at
1 Hz); the real viewer, with the real data engine, runs in a child process whose frame hook reports what
its widgets draw (the dial's readout, the String's latest line, the plot's values at the cursor) and
where the timeline bar is. Keys and clicks are xdotool's (XTEST: the events a real keyboard and mouse
make); nothing here calls the viewer's handlers.
"""

from __future__ import annotations

import bisect
import json
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

COUNT = "/rosdashboard/tl_count"
WORD = "/rosdashboard/tl_word"
COUNT_HZ, WORD_EVERY = 5.0, 5
"""The counter goes up 5 times a second; the word changes with every 5th count (once a second)."""


# -- the child: the real viewer and engine, and a probe reporting what the widgets draw ---------------------


def timeline_dashboard(tmp: Path) -> Path:
    """A dial and a plot of the counter, a String of the word, a text field (to type into)."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    count, word = Binding(COUNT, "data"), Binding(WORD, "data")
    widgets = [
        WidgetConfig(
            "dial", "Count", 20, 20, 240, 260, (count,), {"minimum": 0, "maximum": 500, "decimals": 0}
        ),
        WidgetConfig("plot", "Plot", 280, 20, 420, 260, (count,), {"window": 10.0}),
        WidgetConfig("string", "Word", 720, 20, 280, 260, (word,), {}),
        WidgetConfig("text_field", "Note", 20, 300, 320, 72, (Binding("/tl_note"),), {}),
    ]
    path = tmp / "timeline.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


def _rect(item: int | str) -> list[float]:
    import dearpygui.dearpygui as dpg

    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


class Probe:
    """Frame hook: writes what the viewer shows to ``state.json``; answers screenshot requests."""

    def __init__(self, app: Any, tmp: Path) -> None:
        self.app, self.tmp = app, tmp

    def shown(self, item: Any) -> Any:
        """What the widget drew: the dial's readout, the String's big line, the plot's cursor values."""
        import dearpygui.dearpygui as dpg

        widget = item.widget
        kind = item.config.type
        if widget is None:
            return None
        if kind == "dial":
            return dpg.get_item_configuration(widget._readout)["text"]
        if kind == "string":  # the big line, then the history box's lines (newest first)
            return [widget.latest_text, *str(dpg.get_value(widget.history)).splitlines()]
        if kind == "plot":
            return widget.cursor_values
        if kind == "text_field":
            return dpg.get_value(widget.input)
        return None

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._ui._auto import json_value

        app = self.app
        ox, oy = app.canvas.origin()
        scale = app.timebar.scale
        items = {}
        for item in app.items:
            snaps = item.snapshots(app.timeline)
            items[item.name] = {
                "rect": [item.rect.x + ox, item.rect.y + oy, item.rect.w, item.rect.h],
                "status": item.status.value,
                "pill": item.pill_label,
                "values": [json_value(s.last) for s in snaps],
                "times": [s.last_time for s in snaps],
                "shown": self.shown(item),
                "updates": item.updates,
                # A plot: frames whose lines the line worker drew (shown a frame later), the newest drawn.
                "lines_later": getattr(item.widget, "lines_later", None),
                "drawn_to": getattr(item.widget, "drawn_to", None),
            }
        note = next(i.widget for i in app.items if i.name == "Note")  # (a click brings a widget to the front)
        return {
            "pid": os.getpid(),
            "frame": app.loop.rendered,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "live": app.timeline.live,
            "cursor": app.timeline.cursor,
            "span": list(app.time.time_span() or ()) or None,
            "track": _rect(app.timebar.track),
            "scale": None if scale is None else [scale.oldest, scale.newest, scale.x0, scale.x1],
            "button": _rect(app.timebar.button),
            "button_label": dpg.get_item_label(app.timebar.button),
            "note_input": _rect(note.input) if note is not None else None,
            "selected": app.doc.selected.name if app.doc.selected is not None else None,
            "items": items,
            "status": app.status.text,
        }

    def hook(self) -> None:
        """Report; write screenshots asked for with ``shot-NAME.request`` files."""
        report_frame(self.app, self.tmp, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the timeline dashboard on the real engine, until killed."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)  # rclpy's import of sre_parse
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    with Engine(stale_after=2.0) as engine:
        app = ViewerApp(engine, registry, width=1280, height=760)
        app.start()
        try:
            path = timeline_dashboard(tmp)
            app.load(load_dashboard(path, registry.get), path)
            probe = Probe(app, tmp / "probe")
            app.frame_hooks.append(probe.hook)
            app.run()
        finally:
            app.close()


# -- this side: the robot publishing known values, and a desktop --------------------------------------------


class Feed:
    """A real ROS 2 publisher of a counter (5 Hz) and a word (1 Hz), remembering when it sent each value."""

    def __init__(self) -> None:
        from std_msgs.msg import Float64, String

        self.peer = RosPeer("timeline_feed")
        self.count_pub = self.peer.publisher(COUNT, Float64)
        self.word_pub = self.peer.publisher(WORD, String)
        self.sent: list[tuple[float, int]] = []
        """(time sent, counter value), in order."""
        self.words: list[tuple[float, str]] = []
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from std_msgs.msg import Float64, String

        k = 0
        start = time.monotonic()
        while not self._stop.is_set():
            k += 1
            if k % WORD_EVERY == 1:
                word = String()
                word.data = f"w{k // WORD_EVERY}"
                self.words.append((time.time(), word.data))
                self.word_pub.publish(word)
            msg = Float64()
            msg.data = float(k)
            self.sent.append((time.time(), k))
            self.count_pub.publish(msg)
            self._stop.wait(max(0.0, start + k / COUNT_HZ - time.monotonic()))

    def count_at(self, t: float) -> int | None:
        """The counter value last sent at or before `t`."""
        i = bisect.bisect_right([s for s, _ in self.sent], t) - 1
        return self.sent[i][1] if i >= 0 else None

    def word_at(self, t: float) -> str | None:
        """The word last sent at or before `t`."""
        i = bisect.bisect_right([s for s, _ in self.words], t) - 1
        return self.words[i][1] if i >= 0 else None

    def sent_time(self, value: int) -> float:
        """When the counter value `value` was sent."""
        return next(t for t, k in self.sent if k == value)

    def close(self) -> None:
        """Stop publishing and leave the graph."""
        self._stop.set()
        self._thread.join(5)
        self.peer.close()


@pytest.fixture(scope="module")
def feed() -> Iterator[Feed]:
    """The publisher, running for the whole module (every viewer started sees it publishing)."""
    f = Feed()
    yield f
    f.close()


class Viewer(ViewerChild):
    """The real viewer in a child process, with the timeline probe."""

    def __init__(self, tmp: Path, display: str) -> None:
        super().__init__("timeline", tmp, display, "test_ui_timeline")

    def tap(self, key: str, *, shift: bool = False) -> None:
        """Press and let go of `key` at once (a held arrow repeats, as keys do); Shift held around it."""
        if shift:
            self.xdo("keydown", "shift")
            self.frames(2)
        self.xdo("key", key)
        self.frames(2)
        if shift:
            self.xdo("keyup", "shift")
            self.frames(2)

    def item(self, name: str) -> dict[str, Any]:
        """The reported widget called `name`."""
        return dict(self.state()["items"][name])

    def track_point(self, fraction: float) -> tuple[float, float]:
        """The window pixel `fraction` of the way along the timeline's track (its rail)."""
        state = self.state()
        x, y, _w, _h = state["track"]
        _oldest, _newest, x0, x1 = state["scale"]
        return x + x0 + fraction * (x1 - x0), y + 11

    def time_at(self, x: float) -> float:
        """The time the track shows under window pixel `x` now."""
        state = self.state()
        oldest, newest, x0, x1 = state["scale"]
        f = min(1.0, max(0.0, (x - state["track"][0] - x0) / (x1 - x0)))
        return float(oldest + f * (newest - oldest))

    def seconds_per_px(self) -> float:
        """How many seconds one pixel of the track stands for now."""
        oldest, newest, x0, x1 = self.state()["scale"]
        return float((newest - oldest) / (x1 - x0))


@pytest.fixture
def viewer(display: str, tmp_path: Path, feed: Feed) -> Iterator[Callable[[], Viewer]]:
    """Start the viewer once the feed runs; wait until its widgets are live with a few seconds of history."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start() -> Viewer:
        v = Viewer(tmp_path, display)
        started.append(v)
        v.ready()
        v.wait_for(
            lambda s: (
                all(s["items"][n]["status"] == "live" for n in ("Count", "Word"))
                and s["span"] is not None
                and s["span"][1] - s["span"][0] > 4.0
            ),
            timeout=60,
        )
        return v

    yield start
    for v in started:
        v.stop()


def moved(v: Viewer, key: str, *, shift: bool = False) -> Callable[[dict[str, Any]], bool]:
    """Tap `key` and return the condition 'the cursor has moved' (to wait for)."""
    cursor = v.state()["cursor"]
    v.tap(key, shift=shift)
    return lambda s: bool(s["cursor"] != cursor)


def _shown_count(item: dict[str, Any]) -> int:
    """The dial's readout as a whole number."""
    return int(item["shown"])


# -- the tests -------------------------------------------------------------------------------------------


def test_space_pauses_values_hold_and_end_returns_live(viewer: Callable[[], Viewer], feed: Feed) -> None:
    """Space pauses at the newest sample: widgets hold while the robot keeps publishing; End resumes."""
    v = viewer()
    v.key("space")
    state = v.wait_for(lambda s: not s["live"] and s["cursor"] is not None)
    assert state["button_label"] == "Live"
    cursor = state["cursor"]
    # Paused at the newest sample held: what the dial shows is the counter as sent at the cursor.
    shown = _shown_count(state["items"]["Count"])
    assert shown == state["items"]["Count"]["values"][0]
    assert abs(shown - (feed.count_at(cursor) or 0)) <= 1
    sent_then = feed.sent[-1][1]
    shot = v.shot("paused")
    time.sleep(2.0)  # the robot publishes ten more counts meanwhile
    held = v.frames(3)
    assert feed.sent[-1][1] >= sent_then + 8
    assert held["cursor"] == cursor
    assert not held["live"]
    for name in ("Count", "Plot", "Word"):
        assert held["items"][name]["shown"] == state["items"][name]["shown"], name
        assert held["items"][name]["values"] == state["items"][name]["values"], name
    assert held["items"]["Count"]["updates"] == state["items"]["Count"]["updates"], "redrawn while paused"
    assert held["span"][1] > state["span"][1] + 1.0, "the history keeps growing while paused"
    assert held["items"]["Count"]["pill"] == "live then", "paused, the pill says the status at the cursor"
    v.key("End")
    live = v.wait_for(lambda s: s["live"] and _shown_count(s["items"]["Count"]) >= sent_then + 8)
    assert live["items"]["Count"]["pill"] == "live"
    assert live["cursor"] is None
    assert live["button_label"] == "Pause"
    assert shot.stat().st_size > 0


def test_click_and_drag_on_the_bar_move_the_cursor_there(viewer: Callable[[], Viewer], feed: Feed) -> None:
    """A click on the track pauses at the time under the pointer; a drag follows it; Live resumes."""
    v = viewer()
    x, y = v.track_point(0.5)
    before = v.time_at(x)
    slack = 2 * v.seconds_per_px()
    v.click(x, y)
    state = v.wait_for(lambda s: not s["live"])
    after = v.time_at(x)  # the history grows meanwhile: the time under x moves right, never left
    assert before - slack <= state["cursor"] <= after + slack, (before, state["cursor"], after)
    count = state["items"]["Count"]
    assert abs(_shown_count(count) - (feed.count_at(state["cursor"]) or 0)) <= 1
    c = state["cursor"]
    latest, *history = state["items"]["Word"]["shown"]
    assert latest in {feed.word_at(c - 0.05), feed.word_at(c + 0.05)}
    # The String's history runs up to the cursor: its newest line is that word, nothing later is listed.
    assert history[0].endswith(f"  {latest}")
    assert all(int(line.split("w")[-1]) <= int(latest[1:]) for line in history)
    assert len(history) >= 2
    assert state["items"]["Plot"]["shown"] == [float(count["values"][0])]

    # Drag from a quarter to three quarters of the way: the cursor ends under the pointer.
    start, end = v.track_point(0.25), v.track_point(0.75)
    before = v.time_at(end[0])
    v.drag(start, end)
    state = v.wait_for(lambda s: not s["live"] and s["cursor"] > before - 2 * slack)
    after = v.time_at(end[0])
    assert before - slack <= state["cursor"] <= after + slack
    assert abs(_shown_count(state["items"]["Count"]) - (feed.count_at(state["cursor"]) or 0)) <= 1
    v.shot("dragged")

    button = state["button"]
    v.click(button[0] + button[2] / 2, button[1] + button[3] / 2)
    v.wait_for(lambda s: s["live"] and s["cursor"] is None)


def test_a_continuous_drag_draws_plot_lines_while_rendering_and_settles_exact(
    viewer: Callable[[], Viewer], feed: Feed
) -> None:
    """A hand's drag along the bar (a move every few ms, frames not waited for): the cursor moves frame after
    frame, so the plot's lines are computed on the line worker during the render and shown a frame later;
    once the pointer stops, the plot draws up to the very sample at the cursor, as a still frame does."""
    v = viewer()
    x, y = v.track_point(0.2)
    v.click(x, y)
    v.wait_for(lambda s: not s["live"])
    before = v.item("Plot")["lines_later"]
    # Along to 0.65 of the bar, then a jump of seconds in one move: the lines of the frame before it are far
    # from the cursor then.
    state = v.hand_drag((x, y), v.track_point(0.65)[0], v.track_point(0.8)[0])
    plot, count = state["items"]["Plot"], state["items"]["Count"]
    seen = f"cursor {state['cursor']!r}, plot {plot}, dial {count}\n{v.output()}"
    assert plot["lines_later"] > before, f"the plot's lines never went to the line worker: {seen}"
    # Settled: the newest point drawn is the last sample at the cursor (no frame-old lines left).
    assert plot["drawn_to"] == plot["times"][0] == count["times"][0] <= state["cursor"], seen
    assert plot["shown"] == [float(count["values"][0])], seen
    assert abs(_shown_count(count) - (feed.count_at(state["cursor"]) or 0)) <= 1, seen
    settled = v.frames(3)["items"]["Plot"]
    assert settled["lines_later"] == plot["lines_later"], f"lines deferred with the cursor still: {seen}"
    v.shot("dragged-continuously")


def test_arrows_step_one_message_of_the_selected_widget(viewer: Callable[[], Viewer], feed: Feed) -> None:
    """Left/Right step to the previous/next message of the selected widget; Shift steps one second."""
    v = viewer()
    x, y, _w, _h = v.item("Count")["rect"]
    v.click(x + 60, y + 12)  # the title strip: selects the dial
    v.wait_for(lambda s: s["selected"] == "Count")
    v.key("space")
    state = v.wait_for(lambda s: not s["live"])
    k = _shown_count(state["items"]["Count"])
    if state["items"]["Count"]["times"][0] != state["cursor"]:
        k += 1  # paused on a word sent just before its count: the first step back lands on this count
    for step, key in ((-1, "Left"), (-1, "Left"), (+1, "Right")):
        state = v.wait_for(moved(v, key))
        k += step
        count = state["items"]["Count"]
        assert _shown_count(count) == k, (key, count)
        # The cursor is exactly on that message, which the robot sent then.
        assert state["cursor"] == count["times"][0]
        assert abs(state["cursor"] - feed.sent_time(k)) < 0.1
        assert state["items"]["Plot"]["shown"] == [float(k)]
    cursor = state["cursor"]
    state = v.wait_for(moved(v, "Left", shift=True))
    assert state["cursor"] == pytest.approx(cursor - 1.0, abs=1e-6)
    # Five counts a second: a second back is the fifth count before, or the sixth if that came late.
    assert _shown_count(state["items"]["Count"]) in {k - 5, k - 6}
    assert state["items"]["Count"]["times"][0] <= state["cursor"] < feed.sent_time(k - 4)

    # With the String selected, the arrows step through its messages: a word a second.
    x, y, _w, _h = v.item("Word")["rect"]
    v.click(x + 60, y + 12)
    v.wait_for(lambda s: s["selected"] == "Word")
    word, word_time = v.item("Word")["shown"], v.item("Word")["times"][0]
    cursor = v.state()["cursor"]
    assert word_time < cursor  # a second back from a count's time: between two words
    state = v.wait_for(moved(v, "Left"))  # to the word on show: its message is the previous one
    assert state["cursor"] == word_time
    assert state["items"]["Word"]["shown"][0] == word[0]
    state = v.wait_for(moved(v, "Left"))  # to the word before, a second earlier
    names = [w for _t, w in feed.words]
    before = feed.words[names.index(word[0]) - 1]  # the word the robot sent before the one on show
    assert state["cursor"] == pytest.approx(before[0], abs=0.1)
    assert state["cursor"] == state["items"]["Word"]["times"][0]
    assert state["items"]["Word"]["shown"][0] == feed.word_at(state["cursor"] + 0.01) != word[0]
    assert state["items"]["Word"]["shown"][1].endswith(f"  {feed.word_at(state['cursor'] + 0.01)}")
    v.shot("stepped")


def test_time_keys_are_the_text_fields_while_typing(viewer: Callable[[], Viewer]) -> None:
    """Space and the arrows typed into a control's text field edit the text; the dashboard stays live."""
    v = viewer()
    x, y, w, h = v.state()["note_input"]
    v.click(x + w / 2, y + h / 2)
    v.type("a b")
    v.key("Left", "End", "space")
    state = v.frames(5)
    assert state["live"]
    assert state["cursor"] is None
    assert state["items"]["Note"]["shown"] == "a b "
    v.key("Escape")  # leaves the field
    x, y, _w, _h = v.item("Word")["rect"]
    v.click(x + 60, y + 12)
    v.key("space")
    v.wait_for(lambda s: not s["live"])


# -- a plugin widget that knows nothing of time ------------------------------------------------------------


def plugin_time_travel() -> None:
    """Child-process body: a plugin-style widget, written as before the timeline, shown paused and stepped."""
    warnings.simplefilter("error")
    from collections.abc import Sequence

    import dearpygui.dearpygui as dpg

    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import WidgetConfig
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from dbglog.viewer.widget_api import SeriesSnapshot, Status, ValueKind, Widget

    class Readout(Widget):
        """Shows the latest value and its age; no code about time travel at all."""

        type_name = "readout"
        label = "Readout"
        accepts = frozenset({ValueKind.NUMBER})

        def create(self, parent: int | str, width: int, height: int) -> None:
            self.text = dpg.add_text("-", parent=parent)
            self.seen: list[tuple[object, float | None, float, Status]] = []

        def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
            snap = snapshots[0]
            self.seen.append((snap.last, snap.last_time, now, snap.status))
            age = "" if snap.last_time is None else f" ({now - snap.last_time:.1f} s old)"
            dpg.set_value(self.text, f"{snap.last}{age}")

    registry = WidgetRegistry.builtin()
    assert registry.register(Readout, origin="a-plugin")
    source = StaticSource()
    t0 = 1_700_000_000.0
    for k in range(100):  # 0..99 every 0.1 s, then a gap of 10 s, then 100
        source.push("/p", "data", float(k), t0 + k * 0.1)
    source.push("/p", "data", 100.0, t0 + 20.0)
    app = ViewerApp(source, registry, width=800, height=500)
    app.start()
    try:
        item = app.canvas.add_config(
            WidgetConfig("readout", "R", 20, 20, 300, 80, (Binding("/p", "data"),), {})
        )
        widget = item.widget
        assert isinstance(widget, Readout)
        for _ in range(3):
            app.frame()
        assert widget.seen[-1][0] == 100.0
        assert [widget.paused_at] == [None]  # live (a list: mypy would narrow the attribute for good)
        app.time.seek(t0 + 4.25)
        for _ in range(3):
            app.frame()
        last, last_time, now, status = widget.seen[-1]
        assert (last, last_time, now, status) == (42.0, t0 + 4.2, t0 + 4.25, Status.LIVE), widget.seen[-1]
        assert widget.paused_at == t0 + 4.25
        assert dpg.get_value(widget.text) == "42.0 (0.0 s old)"
        app.time.seek(t0 + 15.0)  # in the gap: the last value then, stale then (by its age at the cursor)
        for _ in range(3):
            app.frame()
        assert widget.seen[-1] == (99.0, t0 + 9.9, t0 + 15.0, Status.STALE), widget.seen[-1]
        assert item.status is Status.STALE
        redraws = len(widget.seen)
        source.push("/p", "data", 101.0, t0 + 20.5)  # new data while paused: nothing to redraw
        for _ in range(3):
            app.frame()
        assert len(widget.seen) == redraws
        assert app.time.step_time(+1)  # the next message: 100 at t0 + 20
        for _ in range(3):
            app.frame()
        assert widget.seen[-1][:3] == (100.0, t0 + 20.0, t0 + 20.0)
        app.time.go_live()
        for _ in range(3):
            app.frame()
        assert widget.seen[-1][0] == 101.0
        assert widget.paused_at is None
    finally:
        app.close()


def test_a_plugin_widget_travels_in_time_without_code_for_it(display: str) -> None:
    """A widget written with no notion of time gets the value, its age and its status as they were then."""
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        "from tests import test_ui_timeline; test_ui_timeline.plugin_time_travel()"
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        env={**os.environ, "DISPLAY": display},
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )
    assert done.returncode == 0, f"{done.stdout}\n{done.stderr}"


# -- the command line: --cursor with --screenshot and --report-json -----------------------------------------


def test_cli_screenshot_at_a_cursor_reports_the_values_then(display: str, tmp_path: Path, feed: Feed) -> None:
    """`dbglog view DASH --screenshot --after 9 --cursor -2 --report-json`: each widget's value 2 s back.

    (After 6 s, with two suites on 2 cores, the viewer had once received its first 1 Hz word only in the
    last 2 s, so at the cursor the String rightly showed nothing: 9 s leaves room for discovery.)
    """
    dash = timeline_dashboard(tmp_path)
    png, report = tmp_path / "cursor.png", tmp_path / "report.json"
    assert wait_until(lambda: len(feed.sent) > 10, timeout=30)
    done = subprocess.run(
        [
            sys.executable, "-m", "dbglog", "view", str(dash),
            "--screenshot", str(png), "--after", "9",
            "--cursor", "-2", "--report-json", str(report), "--history", "10m", "--history-mb", "64",
        ],
        env={**os.environ, "DISPLAY": display},
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=120,
        check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert png.stat().st_size > 0
    data = json.loads(report.read_text())
    cursor, placed_from, (oldest, newest) = data["cursor"], data["cursor_from"], data["span"]
    # Counted back from the newest sample when it was placed (the span moves on while the frames at the
    # cursor are drawn: a background viewer on a loaded CI machine once took 0.8 s over them).
    assert cursor == pytest.approx(placed_from - 2.0, abs=1e-6), (cursor, placed_from)
    assert oldest < cursor
    assert placed_from <= newest
    widgets = {w["name"]: w for w in data["widgets"]}
    count = widgets["Count"]["values"][0]
    assert abs(count - (feed.count_at(cursor) or 0)) <= 1, (count, feed.count_at(cursor))
    assert widgets["Plot"]["values"] == [count]
    assert widgets["Word"]["values"][0] in {feed.word_at(cursor - 0.25), feed.word_at(cursor + 0.25)}
    assert widgets["Note"]["values"] == [None]
    assert widgets["Note"]["samples"] == [None]
    # The history holds the counts received since the viewer subscribed (~5 s at 5 Hz), not one.
    assert widgets["Count"]["samples"][0] >= 10
    assert widgets["Word"]["samples"][0] >= 4
    assert widgets["Count"]["status"] == "live"  # 2 s back the counter was arriving
