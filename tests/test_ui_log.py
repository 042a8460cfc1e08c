"""The Log console under Xvfb, driven like a desktop: real rclpy loggers, the real viewer and engine, xdotool.

Loggers in a child process (three nodes) write known lines to the real /rosout, some before the viewer
starts; the viewer runs in another child process whose frame hook reports what the console draws (its rows,
where their numbers are, its status line), the dialog, the widgets and the clipboard. Every action here is a
real mouse move, click, wheel turn or key press (xdotool's XTEST events); no handler is called directly.
"""

from __future__ import annotations

import itertools
import os
import shutil
import subprocess
import sys
import textwrap
import time
import uuid
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests._ros import first_line, wait_until
from tests._viewer_child import WAIT_S, ViewerChild, in_view, report_frame
from tests.test_ui_menus import _labelled, _menubar

pytestmark = pytest.mark.gui

RUN = f"c{uuid.uuid4().hex[:5]}"
PLANNER, DRIVER, POWER = f"{RUN}_planner", f"{RUN}_driver", f"{RUN}_power"
LINES = 60
"""Lines each node writes per phase."""
STALLED_LINES = sum(1 for i in range(LINES) if i % 7 == 6)
"""The driver's "motor left/right/rear stalled" errors among them (every 7th line)."""

_WRITER = textwrap.dedent(
    """
    import sys
    import rclpy
    from rclpy.context import Context
    from rclpy.logging import LoggingSeverity
    from rclpy.node import Node

    planner_name, driver_name, power_name, count = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4])
    MOTORS = ("left", "right", "rear")
    ctx = Context()
    rclpy.init(context=ctx)
    nodes = [Node(n, context=ctx) for n in (planner_name, driver_name, power_name)]  # kept: on the graph
    planner, driver, power = (n.get_logger() for n in nodes)
    driver.set_level(LoggingSeverity.DEBUG)

    def write(start):
        for i in range(start, start + count):
            planner.info(f"distance to wall: {0.5 + i * 0.01:.2f} m (angle {-i} deg)")
            if i % 10 == 9:
                power.warning(f"battery low: {90 - i}% left")
            else:
                power.info(f"battery={90 - i}% {12.0 - i * 0.01:.2f}V")
            if i % 7 == 6:
                driver.error(f"motor {MOTORS[i % 3]} stalled: current {10 + i * 0.1:.1f} A")
            else:
                driver.debug(f"tick {i}")

    write(0)
    print("logged", flush=True)
    for line in sys.stdin:
        write(int(line))
        print("logged", flush=True)
    """
)


def planner_line(i: int) -> str:
    """The planner's i-th line."""
    return f"distance to wall: {0.5 + i * 0.01:.2f} m (angle {-i} deg)"


# -- the child: the real viewer and engine, and a probe reporting what the console draws ---------------------


def _rect(item: int | str) -> list[float] | None:
    import dearpygui.dearpygui as dpg

    if not dpg.does_item_exist(item):
        return None
    (x, y), (w, h) = dpg.get_item_rect_min(item), dpg.get_item_rect_size(item)
    return [float(x), float(y), float(w), float(h)]


class Probe:
    """Frame hook: writes what the viewer shows to ``state.json``; answers screenshot requests."""

    def __init__(self, app: Any, tmp: Path) -> None:
        self.app, self.tmp = app, tmp

    def console(self, widget: Any) -> dict[str, Any]:
        """The console's rows (text, id, where its numbers are drawn), toolbar and status."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._widgets._log import HEADER_H, ROW_H

        rect = _rect(widget.drawlist) or [0.0, 0.0, 0.0, 0.0]
        rows = []
        for r, row in enumerate(widget._rows):
            text = dpg.get_item_configuration(row.message)["text"]
            if not text and not dpg.get_item_configuration(row.time)["text"]:
                continue
            line_id = int(widget.shown_ids[widget.top + r])
            spans = widget._number_spans(line_id)
            y = rect[1] + HEADER_H + r * ROW_H + ROW_H / 2
            rows.append(
                {
                    "id": line_id,
                    "text": text,
                    "node": dpg.get_item_configuration(row.node)["text"],
                    "level": dpg.get_item_configuration(row.level)["text"],
                    "y": y,
                    "numbers": [[rect[0] + x0, rect[0] + x1] for x0, x1 in spans],
                    "time": float(widget.store.times([line_id])[0]),
                }
            )
        store = widget.store
        return {
            "rect": rect,
            "rows": rows,
            "shown": len(widget.shown_ids),
            "held": len(store) if store is not None else 0,
            "top": widget.top,
            "follow": widget.follow,
            "selected": sorted(widget.selected),
            "status": dpg.get_value(widget.status_text),
            "error": widget.error,
            "complete": widget.complete,
            "tooltip": dpg.get_value(widget.tip_text) if dpg.is_item_shown(widget.tooltip) else None,
            "search": _rect(widget.search_input),
            "typed": [
                widget.search,
                dpg.get_value(widget.search_input),
                dpg.get_value(widget.include_input),
                dpg.get_value(widget.exclude_input),
                dpg.get_value(widget.level_combo),
                widget.prop("include"),
                widget.prop("level"),
            ],
            "include": _rect(widget.include_input),
            "exclude": _rect(widget.exclude_input),
            "level": _rect(widget.level_combo),
            "nodes_button": _rect(widget.nodes_button),
            "nodes": {name: _rect(box) for name, box in widget._node_boxes.items()},
            "nodes_shown": bool(dpg.is_item_shown(widget.nodes_popup)),
            "copy": _rect(widget.copy_button),
            "follow_box": _rect(widget.follow_box),
            "hidden": widget.prop("hidden_nodes"),
        }

    def state(self) -> dict[str, Any]:
        """The viewer's state now."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._ui._dialogs import TopicDialog
        from dbglog.viewer._ui._plotnumber import PlotNumberDialog

        app = self.app
        shown: Any = app.dialog
        ox, oy = app.canvas.origin()
        view = app.canvas.view_rect()
        items = []
        console = None
        for item in app.items:
            snaps = item.snapshots(app.timeline)
            legend = getattr(item.widget, "legend_plan", None)
            entry = {
                "legend": list(legend.labels) if legend is not None else None,
                "name": item.name,
                "type": item.config.type,
                "rect": [item.rect.x + ox, item.rect.y + oy, item.rect.w, item.rect.h],
                "status": item.status.value,
                "bindings": [[b.topic, b.field, b.regex, b.node, b.level] for b in item.bindings],
                "values": [len(s.values) for s in snaps],
                "props": dict(item.config.properties) if item.config.editable is not None else {},
            }
            items.append(entry)
            if item.config.type == "log" and item.widget is not None and console is None:
                console = self.console(item.widget)
        dialog = None
        if isinstance(shown, PlotNumberDialog):
            d: Any = shown
            dialog = {
                "count": d.matches.count if d.matches is not None else None,
                "pattern": d.proposal.pattern if d.proposal is not None else None,
                "number": d.number,
                "ok": _rect(d.ok_button),
                "copy": _rect(d.copy_button),
                "copied": d.copied,
                "ms": d.preview_ms,
            }
        elif isinstance(shown, TopicDialog):
            d = shown
            dialog = {
                "topic": True,
                "log_group": bool(dpg.is_item_shown(d.log_group)),
                "node": _rect(d.node_input),
                "level": _rect(d.level_combo),
                "ok": _rect(d.ok_button),
            }
        return {
            "pid": os.getpid(),
            "frame": app.loop.rendered,
            "menu": _labelled(app.pointer_input.menu) if dpg.is_item_shown(app.pointer_input.menu) else None,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "live": app.timeline.live,
            "cursor": app.timeline.cursor,
            "items": items,
            "console": console,
            "dialog": dialog,
            "menubar": _menubar(app.main),
            "clipboard": dpg.get_clipboard_text(),
            "scroll": [dpg.get_x_scroll(app.canvas.window), dpg.get_y_scroll(app.canvas.window)],
            "view": [ox + view.x, oy + view.y, view.w, view.h],
            "marks": len(app.host.marks(0.0, 1e12)[0]),
            "bar_marks": [list(m) for m in app.timebar._marked],
            "status": app.status.text,
        }

    def hook(self) -> None:
        """Report; write screenshots asked for with ``shot-NAME.request`` files."""
        report_frame(self.app, self.tmp, self.state())


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: the viewer on the real engine (empty, or with a console), until killed."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)  # rclpy's import of sre_parse
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding
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
    slow = scenario == "console_slow"  # a loaded machine's frame rate
    with Engine(stale_after=2.0) as engine:
        app = ViewerApp(engine, registry, width=1280, height=800, fps=8.0 if slow else 60.0)
        if slow:
            app.loop.idle_render_s = 3600.0  # no idle frames: only the keys' own frames can finish a word
        app.start()
        import dearpygui.dearpygui as dpg

        dpg.set_clipboard_text("-")  # reading an empty X clipboard aborts Dear PyGui: the probe reads it
        try:
            if scenario in ("console", "console_plot", "console_slow"):
                path = tmp / "console.json"
                widgets = [WidgetConfig("log", "Log", 20, 20, 960, 420, (Binding("/rosout"),), {})]
                if scenario == "console_plot":
                    percent = Binding("/rosout", "msg", r"(\d+)%")
                    widgets.append(
                        WidgetConfig("plot", "Battery", 20, 460, 480, 240, (percent,), {"window": 300})
                    )
                save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets), 20, True), path)
                app.load(load_dashboard(path, registry.get), path)
            probe = Probe(app, tmp / "probe")
            app.frame_hooks.append(probe.hook)
            app.run()
        finally:
            app.close()


# -- this side: the loggers and a desktop --------------------------------------------------------------------


class Loggers:
    """A child process with three rclpy nodes that log known lines; `more(start)` logs another batch."""

    def __init__(self) -> None:
        self.proc = subprocess.Popen(
            [sys.executable, "-c", _WRITER, PLANNER, DRIVER, POWER, str(LINES)],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert self.proc.stdout is not None
        assert first_line(self.proc.stdout) == "logged"

    def more(self, start: int) -> None:
        """Log lines `start` .. `start + LINES - 1` of every node."""
        assert self.proc.stdin is not None
        assert self.proc.stdout is not None
        self.proc.stdin.write(f"{start}\n")
        self.proc.stdin.flush()
        assert first_line(self.proc.stdout) == "logged"

    def close(self) -> None:
        """End the process (its /rosout publishers go with it)."""
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None:
                stream.close()
        self.proc.wait(20)


_TYPED_FIELD = {"search": 1, "include": 2, "exclude": 3}
"""Where each toolbar field's text is in the report's ``typed`` list."""


class Viewer(ViewerChild):
    """The real viewer in a child process, with the console probe."""

    def __init__(self, scenario: str, tmp: Path, display: str) -> None:
        super().__init__(scenario, tmp, display, "test_ui_log")

    def console(self) -> dict[str, Any]:
        """The console as last reported."""
        return dict(self.state()["console"])

    def click_field(self, name: str) -> None:
        """Click into one of the console's toolbar fields."""
        x, y, w, h = self.console()[name]
        self.click(x + w / 2, y + h / 2)

    def clear_and_type(self, name: str, text: str) -> None:
        """Replace the text of a toolbar field by typing (select all, delete, type), and wait until the
        field holds it.

        Dear ImGui uses about one key event a frame, so on a loaded machine a word takes a few seconds of
        frames to reach the field (CI once saw "STALLE" of "STALLED" after 20 s: the viewer then waited
        for its idle frames; it now keeps rendering while keys are used).
        """
        self.click_field(name)
        self.key("ctrl+a", "BackSpace")
        if not text:
            return
        self.type(text)
        assert wait_until(lambda: self.typed(name) == text, timeout=WAIT_S), (name, text, self.typed(name))

    def typed(self, name: str) -> str:
        """What the toolbar field `name` holds, as last reported."""
        console = self.state().get("console") or {}
        return str(console.get("typed", [""] * 4)[_TYPED_FIELD[name]])


@pytest.fixture
def loggers() -> Iterator[Loggers]:
    """The three logging nodes, having written their first lines."""
    procs = Loggers()
    yield procs
    procs.close()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start the viewer (scenario "empty" or "console") and give it the keyboard."""
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


def ours(console: dict[str, Any]) -> list[dict[str, Any]]:
    """The rows written by this run's nodes."""
    return [r for r in console["rows"] if r["node"].startswith(RUN)]


def wait_console(v: Viewer, ok: Callable[[dict[str, Any]], Any], timeout: float = 40.0) -> dict[str, Any]:
    """Wait until the console's report satisfies `ok`."""
    return dict(v.wait_for(lambda s: s["console"] is not None and ok(s["console"]), timeout)["console"])


# -- the tests -----------------------------------------------------------------------------------------------


def test_view_menu_opens_a_console_with_lines_written_before_the_viewer(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """View > Log console adds a console on /rosout; lines the nodes wrote before the viewer started are
    there, newest at the bottom; new lines follow."""
    v = viewer("empty")
    v.menu_entry("View", "Log console")
    state = v.wait_for(lambda s: any(i["type"] == "log" for i in s["items"]))
    (log,) = [i for i in state["items"] if i["type"] == "log"]
    assert log["bindings"] == [["/rosout", "", "", "", ""]]
    console = wait_console(v, lambda c: c["held"] >= 3 * LINES and len(ours(c)) >= 5)
    last = ours(console)[-1]
    assert last["text"] in (planner_line(LINES - 1), f"tick {LINES - 1}", f"battery={90 - LINES + 1}% ")
    loggers.more(LINES)
    console = wait_console(v, lambda c: any(r["text"] == planner_line(2 * LINES - 1) for r in c["rows"]))
    assert console["follow"]
    console = wait_console(v, lambda c: c["held"] >= 6 * LINES)  # the other nodes' last lines too


def test_filters_typed_and_clicked(viewer: Callable[[str], Viewer], loggers: Loggers) -> None:
    """Search, include and exclude typed with the keyboard, the level and node toggles clicked: the console
    shows exactly the matching lines; a pattern RE2 refuses is named in red and left out."""
    v = viewer("console")
    wait_console(v, lambda c: c["held"] >= 3 * LINES)
    v.clear_and_type("search", "STALLED")
    console = wait_console(v, lambda c: len(ours(c)) > 0 and c["shown"] == STALLED_LINES)
    assert all("stalled" in r["text"] and r["level"] == "ERROR" for r in ours(console))
    v.clear_and_type("search", "")
    v.clear_and_type("include", r"^battery=\d+%")
    console = wait_console(v, lambda c: c["shown"] == LINES - LINES // 10)
    assert all(r["text"].startswith("battery=") for r in console["rows"])
    v.clear_and_type("include", "")
    v.clear_and_type("exclude", "(tick")
    console = wait_console(v, lambda c: c["error"] != "")
    assert console["error"].startswith("exclude: ")
    assert "missing )" in console["error"]
    console = wait_console(v, lambda c: c["shown"] == c["held"])  # left out: the other filters still apply
    v.clear_and_type("exclude", "tick|battery")
    console = wait_console(v, lambda c: c["error"] == "" and len(ours(c)) > 0)
    assert all(not r["text"].startswith(("tick", "battery")) for r in ours(console))
    v.clear_and_type("exclude", "")
    x, y, w, h = v.console()["level"]
    v.click(x + w / 2, y + h / 2)  # the level combo's list opens below it, 19 px an entry: warn is the 4th
    v.click(x + w / 2, y + h + 8 + 3 * 19)
    console = wait_console(
        v, lambda c: all(r["level"] in ("WARN", "ERROR", "FATAL") for r in ours(c)) and ours(c)
    )
    assert {r["level"] for r in ours(console)} <= {"WARN", "ERROR"}
    x, y, w, h = console["nodes_button"]
    v.click(x + w / 2, y + h / 2)
    console = wait_console(v, lambda c: c["nodes_shown"] and DRIVER in c["nodes"] and c["nodes"][DRIVER])
    bx, by, _, bh = console["nodes"][DRIVER]
    v.click(bx + 10, by + bh / 2)  # untick the driver
    console = wait_console(v, lambda c: DRIVER in c["hidden"])
    v.key("Escape")
    console = wait_console(v, lambda c: ours(c) and all(r["node"] != DRIVER for r in ours(c)))
    assert {r["level"] for r in ours(console)} == {"WARN"}


def test_a_word_typed_fast_reaches_the_field_at_a_low_frame_rate(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """At 8 frames a second, a word typed at 60 ms a key takes ~3 s of frames (Dear ImGui uses one key
    event a frame): the viewer keeps rendering until the field holds all of it, with no idle frame to help."""
    v = viewer("console_slow")
    wait_console(v, lambda c: c["held"] >= 3 * LINES)
    v.clear_and_type("search", "STALLED")  # typed at 60 ms a key; fails unless the field holds the word
    console = wait_console(v, lambda c: len(ours(c)) > 0 and c["shown"] == STALLED_LINES)  # and it filters
    assert all("stalled" in r["text"] for r in ours(console))


def test_click_moves_the_cursor_and_the_paused_console_ends_there(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """A click on a line pauses the dashboard at its time: the console ends with that line, which stays under
    the mouse, selected; End returns to live and the console follows the newest lines again."""
    v = viewer("console")
    console = wait_console(v, lambda c: c["held"] >= 3 * LINES)  # every line in: nothing scrolls any more
    row = ours(console)[-8]
    x, _, w, _ = console["rect"]
    v.click(x + w / 2, row["y"])
    state = v.wait_for(lambda s: s["cursor"] is not None and s["console"]["rows"][-1]["id"] == row["id"])
    assert state["cursor"] == pytest.approx(row["time"], abs=1e-6)
    assert state["console"]["rows"][-1]["y"] == row["y"]
    assert state["console"]["selected"] == [row["id"]]
    assert "up to" in state["console"]["status"]
    loggers.more(LINES)  # new lines while paused: the console stays at the cursor
    # Once the console has read them all (the frames their arrival asks for; paused, nothing else is drawn
    # but a 10 s idle frame, which counting frames here waited out three times), it still ends at the row.
    console = wait_console(v, lambda c: c["held"] >= 6 * LINES and "to read" not in c["status"])
    assert console["rows"][-1]["id"] == row["id"]
    v.key("End")
    state = v.wait_for(
        lambda s: s["live"] and any(r["text"] == planner_line(2 * LINES - 1) for r in s["console"]["rows"])
    )
    assert state["console"]["follow"]


def test_wheel_scrolls_the_console_and_copy_takes_the_selection(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """The wheel over the rows scrolls the console (not the canvas) and stops following; a click and a
    Shift+click select a range; Copy puts those lines on the clipboard as `dbglog logs` prints them."""
    v = viewer("console")
    console = wait_console(v, lambda c: c["held"] >= 3 * LINES)
    x, y, w, h = console["rect"]
    v.move(x + w / 2, y + h / 2)
    top = console["top"]
    v.xdo("click", "--repeat", "3", "4")  # wheel up, three notches of three lines
    console = wait_console(v, lambda c: c["top"] == top - 9)
    console = v.frames(5)["console"]  # and no more
    assert console["top"] == top - 9
    assert not console["follow"]
    assert v.state()["scroll"] == [0, 0]
    rows = console["rows"]
    first, last = rows[2], rows[6]
    v.click(x + w / 2, last["y"])  # pauses there: the later lines go, this one stays under the mouse
    state = v.wait_for(lambda s: s["cursor"] is not None and s["console"]["rows"][-1]["id"] == last["id"])
    assert [r["id"] for r in state["console"]["rows"]][2] == first["id"]
    v.xdo("keydown", "shift")
    v.frames(2)
    v.click(x + w / 2, first["y"])
    v.xdo("keyup", "shift")
    console = wait_console(v, lambda c: len(c["selected"]) == 5)
    assert console["selected"] == [r["id"] for r in rows[2:7]]
    cx, cy, cw, ch = console["copy"]
    v.click(cx + cw / 2, cy + ch / 2)
    state = v.wait_for(lambda s: str(s["clipboard"]).count("\n") == 5)
    copied = state["clipboard"].splitlines()
    for line, row in zip(copied, rows[2:7], strict=True):
        assert line.endswith(f"[{row['node']}] {row['text']}")


def test_right_click_a_number_plots_it_filled_from_the_stored_lines(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """Right-click the distance in a planner line: the dialog proposes a pattern for that kind of line and
    counts the stored lines it matches; Copy as bridge rule gives the YAML; OK adds a Plot on /rosout with
    that pattern and the planner as node filter, already holding one value per matched line."""
    v = viewer("console")
    console = wait_console(
        v, lambda c: c["held"] >= 3 * LINES and any(r["node"] == PLANNER for r in c["rows"])
    )
    row = next(r for r in reversed(console["rows"]) if r["node"] == PLANNER)
    x0, x1 = row["numbers"][0]
    v.click((x0 + x1) / 2, row["y"], button=3)
    state = v.wait_for(lambda s: s["dialog"] is not None and s["dialog"]["count"] is not None)
    dialog = state["dialog"]
    assert dialog["count"] == LINES
    assert dialog["number"] == 0
    assert "\\s+wall\\:\\s+(" in dialog["pattern"], "the word nearest the number stays literal"
    cx, cy, cw, ch = dialog["copy"]
    v.click(cx + cw / 2, cy + ch / 2)
    state = v.wait_for(lambda s: s["dialog"] is not None and s["dialog"]["copied"])
    rule = state["clipboard"]
    assert rule.startswith("rules:\n  - tag: wall\n")
    assert f"node: '{PLANNER}'" in rule
    ox, oy, ow, oh = state["dialog"]["ok"]
    v.click(ox + ow / 2, oy + oh / 2)
    state = v.wait_for(lambda s: s["dialog"] is None and any(i["type"] == "plot" for i in s["items"]))
    (plot,) = [i for i in state["items"] if i["type"] == "plot"]
    assert plot["name"] == "wall"
    named = dialog["pattern"].replace("\\:\\s+(", "\\:\\s+(?P<wall>", 1)  # the capture named after the tag
    assert plot["bindings"] == [["/rosout", "msg", named, PLANNER, ""]]
    state = v.wait_for(lambda s: next(i for i in s["items"] if i["type"] == "plot")["values"] == [LINES])
    loggers.more(LINES)  # and it goes on live
    v.wait_for(lambda s: next(i for i in s["items"] if i["type"] == "plot")["values"] == [2 * LINES])


def test_plot_this_number_takes_every_line_of_that_kind_and_its_legend_names_the_number(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """Right-click the current in a "motor left stalled" error: the proposal keeps the word nearest the
    number and generalises the others, so the right and rear motors' lines count too (the count shows
    before OK); the new plot, scrolled into view below the console, names the number in its legend."""
    v = viewer("console")

    def stalled(c: dict[str, Any]) -> list[dict[str, Any]]:
        return [r for r in c["rows"] if r["node"] == DRIVER and "stalled" in r["text"]]

    console = wait_console(v, lambda c: c["held"] >= 3 * LINES and stalled(c))
    row = stalled(console)[-1]
    x0, x1 = row["numbers"][0]
    v.click((x0 + x1) / 2, row["y"], button=3)
    state = v.wait_for(lambda s: s["dialog"] is not None and s["dialog"]["count"] is not None)
    dialog = state["dialog"]
    assert dialog["count"] == STALLED_LINES, "every motor's stalls, not only this one's"
    assert "current\\s+(" in dialog["pattern"]
    v.shot("plot-number-dialog")
    ox, oy, ow, oh = dialog["ok"]
    v.click(ox + ow / 2, oy + oh / 2)
    state = v.wait_for(lambda s: s["dialog"] is None and any(i["type"] == "plot" for i in s["items"]))
    state = v.wait_for(
        lambda s: next(i for i in s["items"] if i["type"] == "plot")["values"] == [STALLED_LINES]
    )

    def plot(s: dict[str, Any]) -> dict[str, Any]:
        return next(i for i in s["items"] if i["type"] == "plot")

    assert plot(state)["name"] == "current"
    state = v.wait_for(lambda s: in_view(plot(s)["rect"], s["view"]))
    assert state["scroll"][1] > 0, "the plot below the console was scrolled to"
    state = v.wait_for(lambda s: plot(s)["legend"])  # (a plot lays its legend out once in view)
    assert plot(state)["legend"] == ["current"], "the tag's name, not /rosout.msg"
    v.shot("plot-number-added")


def test_warnings_and_errors_mark_the_timeline(viewer: Callable[[str], Viewer], loggers: Loggers) -> None:
    """The console's WARN and ERROR lines mark the timeline bar, in their colours (one mark per pixel column,
    the worst level wins; adjacent columns of one level are one run)."""
    v = viewer("console")
    wait_console(v, lambda c: c["held"] >= 3 * LINES)

    def marked(n: int) -> int:  # the power node's warnings and the driver's errors among the first n lines
        return sum(1 for i in range(n) if i % 10 == 9) + sum(1 for i in range(n) if i % 7 == 6)

    first, both = marked(LINES), marked(2 * LINES)
    state = v.wait_for(lambda s: s["marks"] == first and s["bar_marks"])
    levels = {level for _, _, level in state["bar_marks"]}
    assert levels <= {30, 40}
    assert 40 in levels
    loggers.more(LINES)
    time.sleep(2.0)  # a minute of lines later, the first batch is a few pixels left of the new one
    state = v.wait_for(lambda s: s["marks"] == both and len(s["bar_marks"]) >= 2)
    runs = state["bar_marks"]
    assert all(first <= last for first, last, _ in runs)
    assert all(a[1] < b[0] for a, b in itertools.pairwise(runs)), "runs in pixel order, apart"


def test_topic_setup_sets_a_log_bindings_node_and_level(
    viewer: Callable[[str], Viewer], loggers: Loggers
) -> None:
    """Topic setup of a widget on /rosout offers the node and minimum level of the lines it reads: typed and
    picked there, the plot keeps only those lines' values (its past included) and the dashboard saves them."""
    v = viewer("console_plot")
    percents = LINES  # the power node's lines all hold a percentage: 54 "battery=" lines and 6 warnings
    state = v.wait_for(
        lambda s: next(i for i in s["items"] if i["name"] == "Battery")["values"] == [percents]
    )
    plot = next(i for i in state["items"] if i["name"] == "Battery")
    x, y, w, _ = plot["rect"]
    v.click(x + w / 3, y + 12, button=3)  # the title strip: the widget menu
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Topic setup\u2026"))
    mx, my, _, mh = state["menu"]["Topic setup\u2026"]
    v.click(mx + 30, my + mh / 2)
    v.wait_for(lambda s: s["dialog"] is not None and s["dialog"].get("topic") and s["dialog"]["log_group"])
    state = v.frames(3)  # laid out with the log row shown
    nx, ny, nw, nh = state["dialog"]["node"]
    v.click(nx + nw / 2, ny + nh / 2)
    v.type(POWER)
    lx, ly, lw, lh = state["dialog"]["level"]
    v.click(lx + lw / 2, ly + lh / 2)  # its list opens below it, 22 px an entry in a dialog: warn is the 4th
    v.click(lx + lw / 2, ly + lh + 17 + 3 * 22)
    v.frames(3)
    ox, oy, ow, oh = v.state()["dialog"]["ok"]
    v.click(ox + ow / 2, oy + oh / 2)
    warnings = sum(1 for i in range(LINES) if i % 10 == 9)
    state = v.wait_for(
        lambda s: next(i for i in s["items"] if i["name"] == "Battery")["values"] == [warnings]
    )
    plot = next(i for i in state["items"] if i["name"] == "Battery")
    assert plot["bindings"] == [["/rosout", "msg", r"(\d+)%", POWER, "warn"]]
