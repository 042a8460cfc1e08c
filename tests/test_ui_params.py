"""Node parameters and events in the real viewer, driven like a desktop (xdotool under Xvfb).

Real rclpy nodes in this process declare parameters (ranges with steps, a read-only one, an
on-set-parameters callback that rejects a value, a node that never spins); the real viewer runs in a child
process with the real data engine and parameter client, as ``dbglog view`` runs them, and its frame hook
reports what is on screen. Widgets bound to ``/robot/ui_pid:NAME`` are dragged, clicked and typed into;
changes made from this process (another process, as ``ros2 param set`` or rqt would) must reach the
timeline within 200 ms; the Events list, a marker with a note, time travel, Topic setup's type-ahead and a
replay are used as a user would. Nothing here calls the viewer's handlers.
"""

from __future__ import annotations

import functools
import json
import os
import shutil
import statistics
import time
import warnings
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from dbglog._ros._paramclient import DEFAULT_TIMEOUT_S
from dbglog.viewer._publishing._params import RETRY_S
from tests._param_nodes import CURSED, ParamNodes
from tests._viewer_child import ViewerChild, report_frame

pytestmark = pytest.mark.gui

NODE = "ui_pid"
FQN = f"/robot/{NODE}"
HUNG = f"/{NODE}_hung"
SIGNAL = "/ui_params/signal"
WAIT = 60.0


def _rect(item: int | str) -> list[float]:
    import dearpygui.dearpygui as dpg

    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


# -- the child: the real viewer, engine and parameter client, and a probe ---------------------------------


def params_dashboard(tmp: Path) -> Path:
    """A slider, a knob, a toggle and text fields on the node's parameters; a slider on the node that never
    answers; a plot of a signal (the events draw on it); a dial (it shows topics) on a parameter."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    def on(name: str, node: str = FQN) -> tuple[Binding, ...]:
        return (Binding(f"{node}:{name}"),)

    widgets = [
        WidgetConfig("slider", "Gain", 20, 20, 360, 90, on("kp"), {}),
        WidgetConfig("text_field", "Gain text", 20, 120, 360, 90, on("kp"), {}),
        WidgetConfig("text_field", "Label", 20, 220, 360, 90, on("label"), {}),
        WidgetConfig("text_field", "Frame", 20, 320, 360, 90, on("frame"), {}),
        WidgetConfig("toggle", "Enabled", 400, 20, 200, 98, on("enabled"), {}),
        WidgetConfig("slider", "Hung", 400, 130, 340, 90, on("kp", HUNG), {}),
        WidgetConfig("knob", "Count", 760, 240, 240, 270, on("count"), {"decimals": 0}),
        WidgetConfig("plot", "Signal", 20, 420, 580, 260, (Binding(SIGNAL),), {"window": 20.0}),
        WidgetConfig("dial", "Kp dial", 620, 530, 160, 160, on("kp"), {}),
    ]
    path = tmp / "params.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
    return path


class Probe:
    """Frame hook: what the viewer shows (widgets, the timeline's event marks, the Events list, the dialog),
    and, after each rendered frame, when the timeline first showed each new event."""

    def __init__(self, app: Any, tmp: Path) -> None:
        self.app, self.tmp = app, tmp
        self.drawn: list[tuple[int, float]] = []
        """(events the timeline marked, wall time) each time that number grew, right after the render."""
        self.stalls: list[tuple[float, float]] = []
        """(monotonic time, seconds since the previous frame) of each frame over 0.2 s after the last."""
        self._last_render = 0.0
        after = app.after_render

        def after_render() -> None:
            after()
            now = time.monotonic()
            if self._last_render and now - self._last_render > 0.2:
                self.stalls.append((now, now - self._last_render))
            self._last_render = now
            marked = app.timebar.events_marked
            if not self.drawn or marked > self.drawn[-1][0]:
                self.drawn.append((marked, time.time()))

        app.after_render = after_render

    def shown(self, item: Any) -> Any:
        """What the widget shows: a slider's value, a knob's readout, a toggle's label, a field's text."""
        import dearpygui.dearpygui as dpg

        widget, kind = item.widget, item.config.type
        if widget is None:
            return None
        if kind == "slider":
            return dpg.get_value(widget.slider)
        if kind == "knob":
            return dpg.get_item_configuration(widget._readout)["text"]
        if kind == "toggle":
            return dpg.get_item_label(widget.button)
        if kind == "text_field":
            return dpg.get_value(widget.input)
        return None

    def parts(self, item: Any) -> dict[str, Any]:
        """Where the widget's input is on screen, what its note says, whether it takes input."""
        import dearpygui.dearpygui as dpg

        widget, kind = item.widget, item.config.type
        out: dict[str, Any] = {}
        if widget is None:
            return out
        if kind == "slider":
            out["input"] = _rect(widget.slider)
            out["enabled"] = bool(dpg.get_item_configuration(widget.slider)["enabled"])
            out["range"] = [
                dpg.get_item_configuration(widget.slider)["min_value"],
                dpg.get_item_configuration(widget.slider)["max_value"],
            ]
        elif kind == "text_field":
            out["input"] = _rect(widget.input)
            out["readonly"] = bool(dpg.get_item_configuration(widget.input)["readonly"])
        elif kind == "toggle":
            out["input"] = _rect(widget.button)
            out["enabled"] = bool(dpg.get_item_configuration(widget.button)["enabled"])
        elif kind == "knob":
            x, y, _w, _h = _rect(widget.drawlist)
            cx, cy, r = widget._geom
            out["knob"] = [x + cx, y + cy, r]
            out["note"] = dpg.get_item_configuration(widget._note)["text"] if widget._note else ""
        elif kind == "plot":
            out["lines"] = [[ln.time, ln.count, ln.label, ln.marker] for ln in widget.event_lines]
        if kind in ("slider", "text_field", "toggle") and widget.note:
            tip = getattr(widget, "_note_tip", 0)
            out["note_line"] = line = dpg.get_value(widget.note)
            out["note"] = dpg.get_value(tip) if tip else line  # all of it (on hover where cut)
            size = dpg.get_text_size(line)
            out["note_fits"] = bool(size) and size[0] <= item.rect.w - 4  # one line, inside the widget
        return out

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._ui._dialogs import MarkerDialog, TopicDialog

        app = self.app
        ox, oy = app.canvas.origin()
        items = {}
        for item in app.items:
            items[item.name] = {
                "rect": [item.rect.x + ox, item.rect.y + oy, item.rect.w, item.rect.h],
                "type": item.config.type,
                "status": item.status.value,
                "reason": item.reason,
                "pill": item.pill_label,
                "topics": [b.topic for b in item.bindings],
                "shown": self.shown(item),
                **self.parts(item),
            }
        store = app.host.event_store()
        events = store.all() if store is not None else []
        bar = app.timebar
        scale = bar.scale
        starts = list(app.loop.render_starts)
        panel = app.events_panel
        dialog: dict[str, Any] | None = None
        if isinstance(app.dialog, TopicDialog):
            d = app.dialog
            dialog = {
                "kind": "topic",
                "topic": dpg.get_value(d.topic_input),
                "active": bool(dpg.is_item_active(d.topic_input)),
                "suggestions": list(d._suggestions),
                "highlighted": dpg.get_value(d.suggest_list),
                "latest": dpg.get_value(d.latest),
            }
        elif isinstance(app.dialog, MarkerDialog):
            dialog = {"kind": "marker", "active": bool(dpg.is_item_active(app.dialog.input))}
        return {
            "pid": os.getpid(),
            "frame": app.loop.rendered,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "live": app.timeline.live,
            "cursor": app.timeline.cursor,
            "track": _rect(bar.track),
            "scale": None if scale is None else [scale.oldest, scale.newest, scale.x0, scale.x1],
            "marks": [list(m) for m in bar.event_marks],
            "hovered": list(bar.hovered_event) if bar.hovered_event is not None else None,
            "drawn": [list(d) for d in self.drawn],
            "events": [
                {
                    "time": e.time,
                    "kind": getattr(e, "kind", "marker"),
                    "label": getattr(e, "label", getattr(e, "note", "")),
                    "stamp": getattr(e, "stamp", None),
                }
                for e in events[-60:]
            ],
            "events_count": len(events),
            "panel": {
                "shown": panel.shown,
                "rows": [
                    {"time": ev.time, "rect": _rect(pick), "selected": bool(dpg.get_value(pick)), "id": row}
                    for ev, row, pick in panel.rows[:20]
                ],
                "count": len(panel.rows),
                "oldest": panel.rows[-1][0].time if panel.rows else None,
            },
            "dialog": dialog,
            "toolbox": {dpg.get_item_label(b): _rect(b) for b in app.canvas.tools.buttons.values()},
            "render_starts": starts,
            "stalls": self.stalls[-200:],
            "calls": CALLS[-200:],
            "now": time.monotonic(),
            "items": items,
            "status": app.status.text,
        }

    def hook(self) -> None:
        """Report; write screenshots asked for."""
        report_frame(self.app, self.tmp, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the parameters dashboard, live (engine and parameter client) or replaying a
    recording, until killed."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)  # rclpy's import of sre_parse
    from dbglog.viewer._cli._cli_view import follow_parameters
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    path = params_dashboard(tmp)
    if scenario == "replay":
        replay = load_replay(tmp / "run.mcap")
        app = ViewerApp(replay, registry, width=1280, height=800, recording=True)
        _run(app, path, tmp)
        return
    with Engine(stale_after=2.0) as engine:
        params = follow_parameters(engine.events())
        _count_calls(params)
        app = ViewerApp(engine, registry, width=1280, height=800, params=params)
        try:
            _run(app, path, tmp)
        finally:
            params.close()


CALLS: list[tuple[float, str]] = []
"""In the viewer's child: (monotonic time, node) of each describe or get the viewer asked of a node."""


def _count_calls(client: Any) -> None:
    """Note each describe and get the viewer asks (`CALLS`); the real client answers them."""
    for name in ("describe", "get"):
        call = getattr(client, name)

        def counted(node: str, *args: Any, _call: Any = call, **kwargs: Any) -> Any:
            CALLS.append((time.monotonic(), node))
            return _call(node, *args, **kwargs)

        setattr(client, name, counted)


def _run(app: Any, path: Path, tmp: Path) -> None:
    from dbglog.viewer._document._dashboard import load_dashboard

    app.start()
    try:
        app.load(load_dashboard(path, app.registry.get), path)
        probe = Probe(app, tmp / "probe")
        app.frame_hooks.append(probe.hook)
        app.run()
    finally:
        app.close()


# -- this side: the robot's nodes, a signal, and a desktop --------------------------------------------------


class Viewer(ViewerChild):
    """The real viewer in a child process, with the parameters probe."""

    def item(self, name: str) -> dict[str, Any]:
        """The reported widget called `name`."""
        return dict(self.state()["items"][name])

    def mark_x(self, t: float) -> float:
        """The window pixel of time `t` on the timeline's track."""
        state = self.state()
        oldest, newest, x0, x1 = state["scale"]
        return float(state["track"][0] + x0 + (t - oldest) / (newest - oldest) * (x1 - x0))

    def hover_mark(self, t: float) -> dict[str, Any]:
        """Put the pointer on the timeline's mark of time `t` (the marks slide left as the history grows:
        follow it) and return the state once the bar shows the mark's label."""
        for _ in range(20):
            x, y = self.mark_x(t), self.state()["track"][1] + 11
            self.xdo("mousemove", "--window", self.window, str(round(x)), str(round(y)))
            state = self.frames(2)
            if state["hovered"] is not None and abs(state["hovered"][0] + state["track"][0] - x) <= 6:
                return state
        raise AssertionError(f"the mark at {t} never showed its label: {self.state()}")

    def press_mark(self, t: float, tries: int = 5) -> bool:
        """Press the left button on the timeline's mark of time `t` (moving there and pressing at once: the
        marks slide as the history grows); True once the cursor went to exactly `t`."""
        for _ in range(tries):
            x, y = self.mark_x(t), self.state()["track"][1] + 11
            self.xdo("mousemove", "--window", self.window, str(round(x)), str(round(y)), "mousedown", "1")
            self.frames(2)
            self.xdo("mouseup", "1")
            state = self.wait_for(lambda s: s["cursor"] is not None)
            if state["cursor"] == t:
                return True
            self.key("End")  # missed it (it slid away): live again, and again
            self.wait_for(lambda s: s["live"])
        return False

    def wiggle(self, x: float, y: float, seconds: float) -> None:
        """Move the mouse to and fro around (x, y) for `seconds` (the user at work: frames at the cap)."""
        end = time.monotonic() + seconds
        k = 0
        while time.monotonic() < end:
            k += 1
            self.xdo("mousemove", "--window", self.window, str(round(x + 30 * (k % 2))), str(round(y)))
            time.sleep(0.03)

    def replace_text(self, rect: list[float], text: str) -> None:
        """Click into a text field, select what it holds, type `text` and press Enter."""
        self.click(rect[0] + rect[2] / 2, rect[1] + rect[3] / 2)
        self.key("ctrl+a")  # a letter typed right after is a letter (`ModifierHold`)
        self.type(text)
        self.key("Return")


@pytest.fixture(scope="module")
def nodes() -> Iterator[ParamNodes]:
    """The robot's nodes: /robot/ui_pid (and a twin in /arm), /ui_pid_hung that never answers."""
    with ParamNodes(NODE) as made:
        yield made


@pytest.fixture(scope="module")
def signal() -> Iterator[None]:
    """A signal at 20 Hz for the plot (its time range is where the events draw)."""
    import threading

    from std_msgs.msg import Float64

    from tests._ros import RosPeer

    stop = threading.Event()
    with RosPeer("ui_params_signal") as peer:
        pub = peer.publisher(SIGNAL, Float64)

        def run() -> None:
            k = 0
            while not stop.is_set():
                k += 1
                pub.publish(Float64(data=float(k % 40)))
                stop.wait(0.05)

        thread = threading.Thread(target=run, daemon=True)
        thread.start()
        yield
        stop.set()
        thread.join(5)


@pytest.fixture(scope="module")
def viewer(
    display: str, tmp_path_factory: pytest.TempPathFactory, nodes: ParamNodes, signal: None
) -> Iterator[Viewer]:
    """One live viewer for the module, once its widgets show the node's values."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    tmp = tmp_path_factory.mktemp("ui_params")
    v = Viewer("live", tmp, display, "test_ui_params")
    try:
        v.ready(timeout=WAIT)
        v.wait_for(
            lambda s: (
                all(s["items"][n]["status"] == "live" for n in ("Gain", "Label", "Enabled", "Count"))
                and s["items"]["Signal"]["status"] == "live"
            ),
            timeout=WAIT,
        )
        yield v
    finally:
        v.stop()


def _drew_more(before: int, state: dict[str, Any]) -> bool:
    """Whether the timeline has drawn more events than `before`."""
    return bool(state["drawn"][-1][0] > before)


# -- the tests ---------------------------------------------------------------------------------------------


def test_widgets_show_the_nodes_values_ranges_and_read_only(viewer: Viewer, nodes: ParamNodes) -> None:
    """Each widget shows its parameter's value as the node has it; the slider spans the descriptor's
    range; the read-only parameter is shown in a field that takes no typing, saying why."""
    state = viewer.state()
    items = state["items"]
    assert items["Gain"]["shown"] == nodes.value("kp")
    assert items["Gain"]["range"] == [0.0, 10.0]
    assert items["Gain"]["enabled"]
    assert "0.0..10.0 step 0.25" in items["Gain"]["note"]
    assert items["Label"]["shown"] == nodes.value("label")
    assert items["Enabled"]["shown"] == ("ON" if nodes.value("enabled") else "OFF")
    assert items["Count"]["shown"] == str(nodes.value("count"))
    frame = items["Frame"]
    assert (frame["status"], frame["shown"], frame["readonly"]) == ("live", "base_link", True)
    assert frame["note"] == "read-only (the node says so)"


def test_a_dial_bound_to_a_parameter_says_which_widgets_take_one(viewer: Viewer) -> None:
    """A dial (it shows topics) bound to a node's parameter is red, saying the binding is a parameter and
    which widgets show and set one (not the data source's 'bad topic name')."""
    state = viewer.wait_for(lambda s: s["items"]["Kp dial"]["status"] == "error", timeout=WAIT)
    reason = state["items"]["Kp dial"]["reason"]
    assert f"{FQN}:kp is a node's parameter" in reason
    assert "Slider, Knob, Toggle or Text field" in reason
    assert "bad topic name" not in reason


def test_a_node_that_never_answers_says_so_and_the_window_never_waits_for_it(viewer: Viewer) -> None:
    """The widget bound to the node that never spins turns red saying it did not answer, and while the
    viewer asks it again (every RETRY_S, each call waiting up to the client's timeout) no frame waits for
    it: the longest time between two frames, the mouse moving, stays far under that timeout."""
    state = viewer.wait_for(lambda s: s["items"]["Hung"]["status"] == "error", timeout=WAIT)
    hung = state["items"]["Hung"]
    assert "did not answer" in hung["reason"]
    assert HUNG in hung["reason"]
    assert "did not answer" in hung["note"]
    assert not hung["enabled"]
    canvas = state["items"]["Signal"]["rect"]
    began = state["now"]
    # Move the mouse (frames at the cap) until the viewer has asked the silent node again (every RETRY_S)
    # and that call has run out (DEFAULT_TIMEOUT_S), then look at every frame since.
    deadline = time.monotonic() + RETRY_S + 3 * DEFAULT_TIMEOUT_S
    asked: list[float] = []
    while not asked and time.monotonic() < deadline:
        viewer.wiggle(canvas[0] + 200, canvas[1] + 150, 1.0)
        asked = [t for t, node in viewer.state()["calls"] if node == HUNG and t > began]
    assert asked, "the viewer never asked the silent node again"
    end = asked[0] + DEFAULT_TIMEOUT_S + 1.0
    while time.monotonic() < deadline and viewer.state()["now"] < end:
        viewer.wiggle(canvas[0] + 200, canvas[1] + 150, 1.0)
    state = viewer.wait_for(lambda s: s["now"] >= end)  # a frame drawn after the call ran out
    stalls = [gap for t, gap in state["stalls"] if t > began]
    print(f"frames over 0.2 s apart while the silent node was asked again: {stalls}")
    # A call made on the UI thread would hold a frame for the client's whole timeout (DEFAULT_TIMEOUT_S);
    # a loaded machine has starved one frame for 1.1 s.
    assert all(gap < DEFAULT_TIMEOUT_S / 2 for gap in stalls), stalls
    assert viewer.state()["items"]["Hung"]["status"] == "error"


def test_slider_drag_sets_the_parameter_rate_limited_and_on_release(
    viewer: Viewer, nodes: ParamNodes
) -> None:
    """A real drag of the slider: values go out while it moves (at most the rate limit's), the one let go
    at once; the node ends at the slider's value on the step, and the slider shows the node's value."""
    x, y, w, h = viewer.item("Gain")["input"]
    start, began = time.monotonic(), time.time()
    viewer.drag((x + w * 0.2, y + h / 2), (x + w * 0.7, y + h / 2), steps=12)
    took = time.monotonic() - start
    state = viewer.wait_for(
        lambda s: nodes.value("kp") > 4.0 and s["items"]["Gain"]["shown"] == nodes.value("kp")
    )
    final = nodes.value("kp")
    assert final % 0.25 == 0, final
    state = viewer.wait_for(lambda s: s["events"][-1]["label"].endswith(f"\u2192 {final}"))
    sent = [e for e in state["events"] if "ui_pid.kp" in e["label"] and e["time"] >= began - 0.5]
    assert 2 <= len(sent) <= took * 20 + 2, (sent, took)  # sent while dragged, at most 20 a second


def test_knob_drag_sets_the_count_on_its_step(viewer: Viewer, nodes: ParamNodes) -> None:
    """A drag round the knob from its left to its right sets the integer parameter on its step of 5."""
    cx, cy, r = viewer.item("Count")["knob"]
    before = nodes.value("count")
    viewer.drag((cx - r * 0.6, cy), (cx + r * 0.6, cy + r * 0.1), steps=10)
    state = viewer.wait_for(
        lambda s: nodes.value("count") != before and s["items"]["Count"]["shown"] == str(nodes.value("count"))
    )
    count = nodes.value("count")
    assert count % 5 == 0
    assert count > 70, count
    assert state["items"]["Count"]["status"] == "live"


def test_toggle_click_switches_the_boolean(viewer: Viewer, nodes: ParamNodes) -> None:
    """A click on the toggle sets the opposite of the node's value; it shows the node's value after."""
    before = nodes.value("enabled")
    rect = viewer.item("Enabled")["input"]
    viewer.click(rect[0] + rect[2] / 2, rect[1] + rect[3] / 2)
    state = viewer.wait_for(
        lambda s: (
            nodes.value("enabled") is (not before)
            and s["items"]["Enabled"]["shown"] == ("ON" if not before else "OFF")
        )
    )
    assert state["items"]["Enabled"]["enabled"]


def test_text_fields_set_typed_values_and_say_what_was_refused(viewer: Viewer, nodes: ParamNodes) -> None:
    """Typed text is set on Enter as ros2 param set reads it; text of another type is refused in red here;
    the node's own refusal is shown with its reason; a read-only field takes nothing."""
    viewer.replace_text(viewer.item("Label")["input"], "robot one")
    viewer.wait_for(
        lambda s: nodes.value("label") == "robot one" and s["items"]["Label"]["shown"] == "robot one"
    )
    field = viewer.item("Gain text")["input"]
    viewer.replace_text(field, "abc")
    state = viewer.wait_for(lambda s: "not set" in s["items"]["Gain text"]["note"])
    assert state["items"]["Gain text"]["note"] == "not set: 'abc' is a string, not a double"
    viewer.replace_text(field, str(CURSED))
    state = viewer.wait_for(lambda s: "rejected" in s["items"]["Gain text"]["note"])
    assert state["items"]["Gain text"]["note"] == f"rejected {CURSED}: kp={CURSED} makes the arm oscillate"
    assert nodes.value("kp") != CURSED
    viewer.shot("rejected")
    viewer.replace_text(field, "2.5")
    viewer.wait_for(
        lambda s: (
            nodes.value("kp") == 2.5
            and s["items"]["Gain"]["shown"] == 2.5
            and "rejected" not in s["items"]["Gain text"]["note"]
        )
    )
    viewer.replace_text(viewer.item("Frame")["input"], "map")
    state = viewer.frames(6)
    assert nodes.value("frame") == "base_link"
    assert state["items"]["Frame"]["shown"] == "base_link"


def test_the_delete_key_in_a_text_field_edits_the_text_not_the_canvas(viewer: Viewer) -> None:
    """Delete pressed while typing in a selected widget's text field edits the text; the widget stays (the
    canvas's Delete waits while a text field has the keyboard)."""
    x, y, w, _h = viewer.item("Label")["rect"]
    viewer.click(x + w / 2 - 40, y + 12)  # its title strip: selected
    field = viewer.item("Label")["input"]
    viewer.click(field[0] + field[2] / 2, field[1] + field[3] / 2)
    viewer.key("End")
    viewer.type("xy")
    viewer.key("Left")
    viewer.key("Delete")
    state = viewer.frames(6)
    assert "Label" in state["items"], "Delete in a text field removed the widget"
    assert state["items"]["Label"]["shown"].endswith("x"), state["items"]["Label"]["shown"]
    viewer.key("Escape")


def test_a_change_from_another_process_is_on_the_timeline_within_200_ms(
    viewer: Viewer, nodes: ParamNodes
) -> None:
    """Changes set from another process appear on the timeline (a mark on the rail) within 200 ms of the
    node accepting them (its ParameterEvent's stamp) and as labelled lines on the plot; the pointer over a
    mark shows its label, a press on it puts the cursor at its time."""
    from dbglog._ros._paramclient import ParamClient

    latencies = []
    with ParamClient() as client:  # in this process: another than the viewer's, as ros2 param set is
        for value in (1.0, 1.5, 3.25, 4.5, 6.0, 7.75, 8.5, 9.0):
            before: int = viewer.state()["drawn"][-1][0]
            [result] = client.set(nodes.fqn, {"kp": value}).result(WAIT)
            assert result.ok, result
            state = viewer.wait_for(functools.partial(_drew_more, before))
            drawn_at = next(t for n, t in state["drawn"] if n > before)
            [change] = [e for e in state["events"] if e["label"].endswith(f"\u2192 {value}")][-1:]
            latencies.append(drawn_at - change["stamp"])
            time.sleep(0.3)
    print(
        "a change accepted -> its mark on the timeline: "
        + ", ".join(f"{1000 * t:.0f}" for t in latencies)
        + f" ms (median {1000 * statistics.median(latencies):.0f} ms)"
    )
    assert statistics.median(latencies) <= 0.2, latencies
    assert max(latencies) <= 3.0, latencies  # one frame starved by a loaded machine (1.1 s seen at load 9)
    state = viewer.state()
    lines = state["items"]["Signal"]["lines"]
    assert any("ui_pid.kp" in label for _t, _n, label, _m in lines), lines
    newest_line = lines[-1][0]  # the first of its events: the newest change, or one just before it
    assert state["events"][-1]["time"] - 1.0 <= newest_line <= state["events"][-1]["time"], lines
    viewer.shot("timeline-marks")
    # The pointer over the newest change's mark shows its label; a press puts the cursor at its time.
    newest = state["events"][-1]
    state = viewer.hover_mark(newest["time"])
    assert state["hovered"][1].startswith(newest["label"]), state["hovered"]
    assert viewer.press_mark(newest["time"]), "a press on the mark never put the cursor at its time"
    viewer.key("End")
    viewer.wait_for(lambda s: s["live"])


def test_events_list_click_travels_back_and_widgets_show_the_value_then(
    viewer: Viewer, nodes: ParamNodes
) -> None:
    """Ctrl+E shows the Events list; a click on a change puts the cursor there: the slider shows the value the
    parameter had then, takes no input and says so; End goes live with the node's value again."""
    viewer.key("ctrl+e")
    state = viewer.wait_for(lambda s: s["panel"]["shown"] and len(s["panel"]["rows"]) >= 5)
    kp_changes = [e for e in state["events"] if "ui_pid.kp" in e["label"] and e["kind"] == "changed"]
    target = kp_changes[-3]
    row = next(r for r in state["panel"]["rows"] if r["time"] == target["time"])
    viewer.click(row["rect"][0] + 30, row["rect"][1] + row["rect"][3] / 2)
    state = viewer.wait_for(lambda s: s["cursor"] == target["time"])
    then = float(target["label"].split("\u2192 ")[-1])
    gain = state["items"]["Gain"]
    assert gain["shown"] == then
    assert not gain["enabled"]
    assert gain["note"] == "paused: the value then, read-only"
    enabled = state["items"]["Enabled"]  # 200 px wide: the note is cut to its one line, not wrapped
    assert enabled["note"] == "paused: the value then, read-only"
    assert enabled["note_fits"], enabled["note_line"]
    assert enabled["note_line"].endswith("\u2026"), enabled["note_line"]
    assert gain["pill"] == "live then"
    assert next(r for r in state["panel"]["rows"] if r["time"] == target["time"])["selected"]
    viewer.shot("events-list-past")
    viewer.key("End")
    state = viewer.wait_for(lambda s: s["live"] and s["items"]["Gain"]["enabled"])
    assert state["items"]["Gain"]["shown"] == nodes.value("kp")
    viewer.key("ctrl+e")
    viewer.wait_for(lambda s: not s["panel"]["shown"])


def test_a_marker_with_a_note_is_added_shown_and_published(viewer: Viewer) -> None:
    """Ctrl+M asks for a note; typed and Enter, the marker is on the timeline (a flag), in the events, and on
    /_dbglog/markers for recorders."""
    from std_msgs.msg import String

    from dbglog._ros._markers import MARKER_TOPIC, marker_qos
    from tests._ros import RosPeer, wait_until

    with RosPeer("ui_params_markers") as peer:
        got: list[str] = []
        peer.node.create_subscription(String, MARKER_TOPIC, lambda m: got.append(m.data), marker_qos())
        plot = viewer.item("Signal")["rect"]
        viewer.click(plot[0] - 20 + 700, plot[1] - 420 + 600)  # a bare spot of the canvas: the keys are its
        viewer.key("ctrl+m")
        viewer.wait_for(lambda s: (s["dialog"] or {}).get("active"))
        viewer.type("robot bumped here")
        viewer.key("Return")
        state = viewer.wait_for(
            lambda s: s["dialog"] is None and any(e["kind"] == "marker" for e in s["events"])
        )
        [marker] = [e for e in state["events"] if e["kind"] == "marker"]
        assert marker["label"] == "robot bumped here"
        viewer.wait_for(lambda s: any(m for _x, m in s["marks"]))
        assert wait_until(lambda: bool(got), 20)
        assert json.loads(got[0])["note"] == "robot bumped here"
    viewer.shot("marker")


def test_topic_setup_types_ahead_over_the_nodes_parameters(viewer: Viewer, nodes: ParamNodes) -> None:
    """A slider dropped from the toolbox: its Topic setup suggests the nodes' parameters as the name is
    typed (with type and value); Enter takes one, Enter again binds it; the slider shows its value."""
    state = viewer.state()
    drop = (900.0, 120.0)
    toolbox = state["toolbox"]["Slider"]
    viewer.drag((toolbox[0] + toolbox[2] / 2, toolbox[1] + toolbox[3] / 2), drop)
    viewer.wait_for(lambda s: (s["dialog"] or {}).get("active"))
    viewer.type("ui_pid:cou")
    state = viewer.wait_for(lambda s: (s["dialog"] or {}).get("topic") == "ui_pid:cou")
    dialog = state["dialog"]
    assert [line.split("   ")[0] for line in dialog["suggestions"][:2]] == [
        f"{nodes.twin_fqn}:count",
        f"{FQN}:count",
    ]
    assert dialog["suggestions"][1].startswith(f"{FQN}:count   [parameter: integer = ")
    viewer.key("Down")
    viewer.wait_for(lambda s: str((s["dialog"] or {}).get("highlighted", "")).startswith(f"{FQN}:count"))
    viewer.key("Return")
    state = viewer.wait_for(lambda s: (s["dialog"] or {}).get("topic") == f"{FQN}:count")
    assert state["dialog"]["latest"].startswith("value now: ")
    viewer.frames(4)  # the field takes the keyboard again two frames after a suggestion is taken
    viewer.key("Return")
    state = viewer.wait_for(
        lambda s: (
            s["dialog"] is None
            and any(i["topics"] == [f"{FQN}:count"] and i["type"] == "slider" for i in s["items"].values())
        )
    )
    name = next(
        n for n, i in state["items"].items() if i["topics"] == [f"{FQN}:count"] and i["type"] == "slider"
    )
    state = viewer.wait_for(
        lambda s: s["items"][name]["status"] == "live" and s["items"][name]["shown"] == nodes.value("count")
    )
    assert state["items"][name]["range"] == [0.0, 100.0]


def _recording(path: Path, t0: float) -> list[tuple[float, str]]:
    """A recording of the signal, the node's parameter events (declared, then changed twice) and a marker;
    return the (time, label) of what the timeline must mark."""
    from rcl_interfaces.msg import Parameter, ParameterEvent
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64

    from dbglog._ros._markers import MARKER_TOPIC, MARKER_TYPE, Marker, encode_marker
    from dbglog._ros._params import PARAMETER_EVENTS, PARAMETER_EVENTS_TYPE, ParamValue
    from dbglog.record import McapWriter

    def event(kind: str, **values: object) -> bytes:
        msg = ParameterEvent(node=FQN)
        setattr(msg, kind, [Parameter(name=k, value=ParamValue.of(v).to_msg()) for k, v in values.items()])
        return bytes(serialize_message(msg))

    with McapWriter(path) as writer:
        signal = writer.add_channel(SIGNAL, "std_msgs/msg/Float64")
        params = writer.add_channel(PARAMETER_EVENTS, PARAMETER_EVENTS_TYPE)
        markers = writer.add_channel(MARKER_TOPIC, MARKER_TYPE)
        for k in range(200):  # 10 s at 20 Hz
            ns = round((t0 + k * 0.05) * 1e9)
            writer.write(signal, ns, bytes(serialize_message(Float64(data=float(k % 40)))), ns)
        for t, payload in (
            (t0 + 0.5, event("new_parameters", kp=1.0, count=10)),
            (t0 + 3.0, event("changed_parameters", kp=2.5)),
            (t0 + 6.0, event("changed_parameters", kp=4.0)),
        ):
            writer.write(params, round(t * 1e9), payload, round(t * 1e9))
        note = Marker(t0 + 4.5, "gain about to change")
        writer.write(markers, round((t0 + 5) * 1e9), encode_marker(note), round((t0 + 5) * 1e9))
    return [
        (t0 + 3.0, "robot/ui_pid.kp 1.0 \u2192 2.5"),
        (t0 + 4.5, "gain about to change"),
        (t0 + 6.0, "robot/ui_pid.kp 2.5 \u2192 4.0"),
    ]


def test_a_replay_shows_the_markers_lines_and_values_then(display: str, tmp_path: Path) -> None:
    """A recording replayed: its changes and marker are on the timeline and as lines on the plot; the
    widgets show the values the parameters had at the cursor, read-only; a click on the track moves
    them there; a marker added with Ctrl+M goes at the cursor."""
    t0 = 1_767_225_600.0
    marked = _recording(tmp_path / "run.mcap", t0)
    v = Viewer("replay", tmp_path, display, "test_ui_params")
    try:
        v.ready(timeout=WAIT)
        state = v.wait_for(lambda s: len(s["marks"]) == 3 and s["items"]["Gain"]["status"] == "live")
        assert [(e["time"], e["label"]) for e in state["events"]] == marked
        assert [m for _x, m in state["marks"]] == [False, True, False]
        gain = state["items"]["Gain"]
        assert (gain["shown"], gain["enabled"], gain["note"]) == (4.0, False, "a recording: read-only")
        lines = state["items"]["Signal"]["lines"]
        assert [(t, label) for t, _n, label, _m in lines] == [
            (t0 + 3.0, "ui_pid.kp 1.0 \u2192 2.5"),
            (t0 + 4.5, "gain about to change"),
            (t0 + 6.0, "ui_pid.kp 2.5 \u2192 4.0"),
        ]
        v.shot("replay")
        v.click(v.mark_x(t0 + 4.0), state["track"][1] + 11)
        state = v.wait_for(lambda s: s["cursor"] is not None and t0 + 3.3 < s["cursor"] < t0 + 4.7)
        assert state["items"]["Gain"]["shown"] == 2.5
        assert state["items"]["Gain text"]["shown"] == "2.5"
        assert state["items"]["Count"]["shown"] == "10"
        # A marker added while replaying goes at the cursor, on the timeline with the file's.
        at = state["cursor"]
        v.key("ctrl+m")
        v.wait_for(lambda s: (s["dialog"] or {}).get("active"))
        v.type("seen in the replay")
        v.key("Return")
        state = v.wait_for(lambda s: s["dialog"] is None and len(s["events"]) == 4)
        assert [(e["time"], e["label"]) for e in state["events"] if e["kind"] == "marker"] == sorted(
            [(t0 + 4.5, "gain about to change"), (at, "seen in the replay")]
        )
        v.wait_for(lambda s: sum(1 for _x, m in s["marks"] if m) == 2)
    finally:
        v.stop()


def test_the_events_list_keeps_the_newest_500_and_adds_new_ones_on_top(display: str, tmp_path: Path) -> None:
    """Of a recording's 600 changes the Events list holds the newest 500, newest first; a marker added at
    the end goes on top without the other rows being made again; a click on a row highlights it and
    puts the cursor there."""
    from rcl_interfaces.msg import Parameter, ParameterEvent
    from rclpy.serialization import serialize_message

    from dbglog._ros._params import PARAMETER_EVENTS, PARAMETER_EVENTS_TYPE, ParamValue
    from dbglog.record import McapWriter

    t0 = 1_767_225_600.0
    with McapWriter(tmp_path / "run.mcap") as writer:
        params = writer.add_channel(PARAMETER_EVENTS, PARAMETER_EVENTS_TYPE)
        for k in range(600):
            msg = ParameterEvent(node=FQN)
            msg.changed_parameters = [Parameter(name="count", value=ParamValue.of(k).to_msg())]
            ns = round((t0 + k * 0.01) * 1e9)
            writer.write(params, ns, bytes(serialize_message(msg)), ns)
    v = Viewer("replay", tmp_path, display, "test_ui_params")
    try:
        v.ready(timeout=WAIT)
        v.wait_for(lambda s: s["events_count"] == 600)
        v.key("ctrl+e")
        state = v.wait_for(lambda s: s["panel"]["shown"] and s["panel"]["count"] == 500)
        rows = state["panel"]["rows"]
        assert [r["time"] for r in rows[:3]] == pytest.approx([t0 + k * 0.01 for k in (599, 598, 597)])
        assert state["panel"]["oldest"] == pytest.approx(t0 + 100 * 0.01)
        v.key("ctrl+m")
        v.wait_for(lambda s: (s["dialog"] or {}).get("active"))
        v.type("the end")
        v.key("Return")
        state = v.wait_for(lambda s: s["dialog"] is None and s["panel"]["rows"][0]["time"] == s["cursor"])
        after = state["panel"]["rows"]
        assert [r["id"] for r in after[1:5]] == [r["id"] for r in rows[:4]], "rows were made again"
        assert state["panel"]["count"] == 500
        assert state["panel"]["oldest"] == pytest.approx(t0 + 101 * 0.01)
        target = after[6]
        v.click(target["rect"][0] + 30, target["rect"][1] + target["rect"][3] / 2)
        state = v.wait_for(lambda s: s["cursor"] == target["time"])
        assert [r["selected"] for r in state["panel"]["rows"][:8]] == [False] * 6 + [True, False]
    finally:
        v.stop()
