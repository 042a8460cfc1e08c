"""Watch a variable in the real viewer, driven by the real mouse and keyboard (xdotool under Xvfb).

Real watched programs: tests/data/watch/loop.py run by ``dbglog run`` (a plain script) and talker.py (an
rclpy node with a 100 Hz timer, ``DBGLOG_WATCH=1``), both in the Python that runs the tests (so the suite
under 3.11 and 3.12 watches each). The viewer runs in a child process with the real data engine; a frame
hook there reports the dialog's parts with their window-pixel rectangles and each widget's status and
values; this process points, clicks and types with xdotool and checks what the widgets show against what
the programs did.
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests._children import stop_child
from tests._viewer_child import ViewerChild, report_frame
from tests._watch_targets import line_of

pytestmark = [pytest.mark.gui, pytest.mark.slow]

DATA = Path(__file__).resolve().parent / "data" / "watch"
LOOP, TALKER = DATA / "loop.py", DATA / "talker.py"
STEP_LINE = line_of("step", LOOP)
TICK_LINE = line_of("tick", TALKER)
HOT_LINE = line_of("hot", LOOP)
BLANK_LINE = STEP_LINE - 7
"""An empty line of loop.py (between two functions): no code."""
START_S = 60.0
"""How long a program or a watch may take to come up on a loaded machine."""
GONE_S = 12.0
"""How long a killed program may take to show as gone (its last announcement 3 s old at most, then 3.5 s)."""


# -- the child: a live viewer whose frame hook reports the dialog and the widgets ----------------------------


def _rect(item: int | str) -> list[float] | None:
    """An item's rectangle in window pixels [x, y, w, h], or None when it is not drawn."""
    import dearpygui.dearpygui as dpg

    if not dpg.does_item_exist(item):
        return None
    state = dpg.get_item_state(item)
    if not state.get("visible") or "rect_min" not in state:
        return None
    (x, y), (w, h) = state["rect_min"], state["rect_size"]
    return [float(x), float(y), float(w), float(h)]


def _rows(parent: int | str) -> list[list[Any]]:
    """The selectable rows of a list: [label, rect, selected]."""
    import dearpygui.dearpygui as dpg

    out: list[list[Any]] = []
    for child in dpg.get_item_children(parent, 1) or []:
        item = child
        if dpg.get_item_type(child).endswith("mvGroup"):
            item = (dpg.get_item_children(child, 1) or [child])[0]
        if dpg.get_item_type(item).endswith("mvSelectable"):
            out.append([dpg.get_item_label(item), _rect(item), bool(dpg.get_value(item))])
    return out


def _menubar(window: int | str) -> dict[str, Any]:
    """Each menu's label position and size, and where its entries start while it is open."""
    import dearpygui.dearpygui as dpg

    out: dict[str, Any] = {}
    for bar in dpg.get_item_children(window, 1) or []:
        if not dpg.get_item_type(bar).endswith("mvMenuBar"):
            continue
        for menu in dpg.get_item_children(bar, 1) or []:
            entries = dpg.get_item_children(menu, 1) or []
            out[dpg.get_item_label(menu)] = {
                "pos": list(dpg.get_item_state(menu).get("pos", [0, 0])),
                "size": list(dpg.get_text_size(dpg.get_item_label(menu))),
                "entries": {
                    dpg.get_item_label(e): list(dpg.get_item_state(e).get("pos", [0, 0])) for e in entries
                },
            }
    return out


def _dialog_state(app: Any) -> dict[str, Any] | None:
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._ui._watchdialog import WatchDialog

    d = app.dialog
    if not isinstance(d, WatchDialog):
        return None if d is None else {"kind": type(d).__name__}
    (x, y), (w, h) = dpg.get_item_pos(d.window), dpg.get_item_rect_size(d.window)
    return {
        "kind": "WatchDialog",
        "rect": [float(x), float(y), float(w), float(h)],
        "window_h": float(dpg.get_viewport_client_height()),
        "procs": _rows(d.proc_list),
        "procs_rect": _rect(d.proc_box),
        "proc_note": dpg.get_value(d.proc_note),
        "file": dpg.get_value(d.file_input),
        "file_rect": _rect(d.file_input),
        "file_active": bool(dpg.is_item_active(d.file_input)),
        "files": _rows(d.file_list),
        "file_note": dpg.get_value(d.file_note),
        "every_rect": _rect(d.every_box),
        "every": bool(dpg.get_value(d.every_box)),
        "chosen_file": d.file,
        "source_note": dpg.get_value(d.source_note),
        "source_rect": _rect(d.source_box),
        "source": {str(n): _rect(row) for n, row in d._rows.items()},
        "line": d.line,
        "names_note": dpg.get_value(d.names_note),
        "names": d.names is not None,
        "expr": dpg.get_value(d.expr_input),
        "expr_active": bool(dpg.is_item_active(d.expr_input)),
        "completions": _rows(d.completion_list),
        "expr_note": dpg.get_value(d.expr_note),
        "when": dpg.get_value(d.when_input),
        "when_rect": _rect(d.when_input),
        "ok_enabled": bool(dpg.get_item_configuration(d.ok_button).get("enabled")),
        "ok_rect": _rect(d.ok_button),
        "error": dpg.get_value(d.error_text),
    }


def _items_state(app: Any) -> list[dict[str, Any]]:
    out = []
    for item in app.items:
        watch = getattr(item.config, "watch", None)
        values: list[float] = []
        for b in item.series:
            snap = app.source.snapshot(b)
            values += [float(v) for v in snap.values[-400:]]
        out.append(
            {
                "name": item.name,
                "type": item.config.type,
                "topics": [b.topic for b in item.bindings],
                "status": item.status.value,
                "pill": item.pill_label,
                "reason": item.reason,
                "watch": None if watch is None else watch.to_dict(),
                "values": values,
            }
        )
    return out


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: a live viewer (the real engine) on an empty dashboard or ``open:FILE``."""
    warnings.simplefilter("error")
    warnings.filterwarnings("ignore", "module 'sre_", DeprecationWarning)
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    tmp = Path(tmp_dir)
    probe = tmp / "probe"
    registry = WidgetRegistry.builtin()
    with Engine(stale_after=2.0) as engine:
        app = ViewerApp(engine, registry, width=1280, height=1000)
        app.start()
        try:
            if scenario.startswith("open:"):
                path = Path(scenario.removeprefix("open:"))
                app.load(load_dashboard(path, registry.get), path)

            def hook() -> None:
                state = {
                    "frame": app.loop.rendered,
                    "mouse": list(dpg.get_mouse_pos(local=False)),
                    "menubar": _menubar(app.main),
                    "status": app.status.text,
                    "path": str(app.doc.path) if app.doc.path else None,
                    "dirty": app.doc.dirty,
                    "file_dialog": app.files.request is not None,
                    "dialog": _dialog_state(app),
                    "items": _items_state(app),
                }
                report_frame(app, probe, state)

            app.frame_hooks.append(hook)
            app.run()
        finally:
            app.close()


# -- the watched programs ------------------------------------------------------------------------------------


def _env(**extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if not k.startswith("DBGLOG_WATCH") and k != "DBGLOG"}
    env.update(extra)
    return env


class Program:
    """A watched program: loop.py under ``dbglog run`` (its steps as JSON lines) or talker.py."""

    def __init__(self, script: Path, tmp: Path, name: str, *more: str) -> None:
        self.out, self.stop_file, self.err = tmp / f"{name}.out", tmp / f"{name}.stop", tmp / f"{name}.err"
        self.stop_file.unlink(missing_ok=True)
        if script == TALKER:
            argv = [sys.executable, str(script), str(self.stop_file), *more]
            env = _env(DBGLOG_WATCH="1")
        else:
            argv = [sys.executable, "-m", "dbglog", "run", str(script), str(self.out), str(self.stop_file)]
            env = _env()
        with self.err.open("wb") as err:  # a file, never a pipe that fills and stops the program
            self.proc = subprocess.Popen(argv, env=env, stdout=subprocess.DEVNULL, stderr=err)

    @property
    def pid(self) -> int:
        """The program's pid."""
        return self.proc.pid

    def said(self) -> str:
        """Whether it still runs, and the end of what it wrote to stderr (for a failing test's message)."""
        code = self.proc.poll()
        text = self.err.read_text(errors="replace")[-3000:] if self.err.exists() else ""
        return f"{'running' if code is None else f'exited {code}'}; stderr: {text or '(nothing)'}"

    def speeds(self) -> set[float]:
        """The values of ``speed`` (and ``robot.speed``) the program has had at its step line."""
        if not self.out.exists():
            return set()
        lines = [json.loads(t) for t in self.out.read_text().splitlines() if t.endswith("}")]
        return {float(line["speed"]) for line in lines if "speed" in line}

    def finish(self) -> None:
        """Ask it to stop, and make sure it did."""
        self.stop_file.touch()
        try:
            self.proc.wait(20)
        except subprocess.TimeoutExpired:
            stop_child(self.proc, signal.SIGKILL)

    def kill(self) -> None:
        """Kill it outright (as a crash would)."""
        self.proc.kill()
        self.proc.wait(10)


@pytest.fixture(scope="module")
def talker(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Program]:
    """talker.py, an rclpy node importing dbglog with DBGLOG_WATCH=1, for the whole module."""
    program = Program(TALKER, tmp_path_factory.mktemp("talker"), "talker")
    yield program
    program.finish()


@pytest.fixture(scope="module")
def loop(tmp_path_factory: pytest.TempPathFactory) -> Iterator[Program]:
    """loop.py run by dbglog run, for the whole module."""
    program = Program(LOOP, tmp_path_factory.mktemp("loop"), "loop")
    yield program
    program.finish()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], ViewerChild]]:
    """Start viewers on the display (ready for input); each is killed at the end."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[ViewerChild] = []

    def start(scenario: str) -> ViewerChild:
        folder = tmp_path / f"viewer{len(started)}"
        folder.mkdir()
        v = ViewerChild(scenario, folder, display, "test_ui_watch")
        started.append(v)
        v.ready(timeout=START_S)
        return v

    yield start
    for v in started:
        v.stop()


# -- driving the window -------------------------------------------------------------------------------------


def center(rect: list[float]) -> tuple[float, float]:
    """The middle of an [x, y, w, h] rectangle."""
    return rect[0] + rect[2] / 2, rect[1] + rect[3] / 2


def fits(state: dict[str, Any]) -> bool:
    """Whether the whole dialog, its buttons included, is inside the window."""
    _x, y, _w, h = dialog(state)["rect"]
    return bool(y >= 0 and y + h <= dialog(state)["window_h"])


def names(rows: list[list[Any]]) -> list[str]:
    """The first words of a list's rows (a file's name, a completion)."""
    return [row[0].split()[0] for row in rows]


def dialog(state: dict[str, Any]) -> dict[str, Any]:
    """The reported Watch dialog (empty when none is open)."""
    return state.get("dialog") or {}


def item(state: dict[str, Any], name: str) -> dict[str, Any]:
    """The reported widget called `name` (empty when there is none)."""
    return next((i for i in state["items"] if i["name"] == name), {})


def live(state: dict[str, Any], name: str) -> list[float]:
    """The values of the widget called `name` once it shows live (else none)."""
    widget = item(state, name)
    return list(widget["values"]) if widget.get("status") == "live" else []


def open_by_menu(v: ViewerChild) -> dict[str, Any]:
    """Watch > Watch a variable... with the mouse; return the state once the dialog is open."""
    menu = v.state()["menubar"]["Watch"]
    (mx, my), (tw, th) = menu["pos"], menu["size"]
    v.click(mx + tw / 2, my + th / 2 + 3)
    state = v.wait_for(lambda s: s["menubar"]["Watch"]["entries"]["Watch a variable\u2026"][1] > 0)
    ex, ey = state["menubar"]["Watch"]["entries"]["Watch a variable\u2026"]
    v.click(mx + ex + 20, th + 2 * 5 + ey + th / 2)  # the popup opens below the bar (text + padding)
    return v.wait_for(lambda s: dialog(s).get("kind") == "WatchDialog")


def choose_process(v: ViewerChild, word: str, program: Program) -> None:
    """Click the process whose row says `word` once it is listed (the wheel brings it into view)."""
    try:
        state = v.wait_for(lambda s: any(word in r[0] for r in dialog(s)["procs"]), START_S)
    except AssertionError as exc:
        raise AssertionError(f"{word!r} was never listed: the program {program.said()}\n{exc}") from None
    for _ in range(20):
        row = next(r for r in dialog(state)["procs"] if word in r[0])
        box = dialog(state)["procs_rect"]
        if row[1] is not None and box[1] <= row[1][1] and row[1][1] + row[1][3] <= box[1] + box[3]:
            v.click(*center(row[1]))
            try:  # (a row that another process's coming or going rebuilt under the click took nothing)
                v.wait_for(lambda s: any(word in r[0] and r[2] for r in dialog(s)["procs"]), 5.0)
                return
            except AssertionError:
                state = v.state()
                continue
        shown = next(r[1] for r in dialog(state)["procs"] if r[1] is not None)
        v.move(*center(shown))
        v.xdo("click", "5")  # the wheel, one notch down
        state = v.frames(3)
    raise AssertionError(f"the process {word!r} never came into view: {dialog(state)['procs']}")


def scroll_to_line(v: ViewerChild, line: int) -> list[float]:
    """Turn the wheel over the source until `line` is in view; return its row's rectangle."""
    state = v.wait_for(lambda s: dialog(s)["source"])
    for _ in range(40):
        rect = dialog(state)["source"].get(str(line))
        view = dialog(state)["source_rect"]
        inside = (
            view is not None
            and rect is not None
            and view[1] + 4 <= rect[1] <= view[1] + view[3] - rect[3] - 4
        )
        if rect is not None and inside:
            return list(rect)
        v.move(*center(view))
        v.xdo("click", "5")  # the wheel, one notch down
        state = v.frames(3)
    raise AssertionError(f"line {line} never came into view: {dialog(state)['source_note']}")


def highlight(v: ViewerChild, word: str) -> None:
    """Move the completions' highlight onto `word` with the arrow keys (a key whose release a loaded
    machine delays repeats, as Dear ImGui repeats a held key: each step is looked at before the next)."""

    def at(state: dict[str, Any]) -> int:
        return next(i for i, row in enumerate(dialog(state)["completions"]) if row[2])

    for _ in range(10):
        state = v.state()
        now, want = at(state), names(dialog(state)["completions"]).index(word)
        if now == want:
            return
        v.key("Down" if want > now else "Up")

        def moved(state: dict[str, Any], before: int = now) -> bool:
            return at(state) != before

        v.wait_for(moved)
    raise AssertionError(f"the highlight never reached {word!r}: {dialog(v.state())['completions']}")


# -- the tests ----------------------------------------------------------------------------------------------


def test_menu_dialog_plots_a_scripts_variable_saved_and_rearmed(
    viewer: Callable[[str], ViewerChild], tmp_path: Path
) -> None:
    """Watch > Watch a variable... on a dbglog-run script: a typed file picked from the type-ahead, a clicked
    line, an expression completed with the arrows; a plot fills with the program's values; saved, it is
    armed again when reopened in a restarted program, shows "gone" when the program is killed and is armed
    in the next one."""
    first = Program(LOOP, tmp_path, "run1")
    try:
        v = viewer("empty")
        state = open_by_menu(v)
        v.shot("watch-dialog-open")
        choose_process(v, f"pid {first.pid} ", first)
        state = v.wait_for(
            lambda s: dialog(s)["file_active"] and "loop.py" in dialog(s)["file_note"], START_S
        )
        v.type("loo")
        state = v.wait_for(lambda s: names(dialog(s)["files"]) == ["loop.py"])
        v.click(*center(dialog(state)["files"][0][1]))
        state = v.wait_for(lambda s: dialog(s)["chosen_file"] == str(LOOP) and dialog(s)["source"], START_S)
        assert "lines 1\u2013" in dialog(state)["source_note"]
        v.click(*center(scroll_to_line(v, STEP_LINE)))
        state = v.wait_for(lambda s: dialog(s)["names"] and dialog(s)["expr_active"], START_S)
        assert dialog(state)["line"] == STEP_LINE
        v.type("r")  # ranges, robot (locals), Robot (a global)
        state = v.wait_for(lambda s: names(dialog(s)["completions"])[:2] == ["ranges", "robot"])
        v.shot("watch-dialog-completion")
        assert fits(v.frames(3)), "the dialog with its completions fits the window"
        highlight(v, "robot")
        v.key("Return")
        state = v.wait_for(lambda s: dialog(s)["expr"] == "robot" and dialog(s)["expr_active"])
        v.key("End")  # the field took the keyboard with its text selected, as Dear ImGui does
        v.type(".speed")
        state = v.wait_for(lambda s: dialog(s)["expr"] == "robot.speed" and dialog(s)["ok_enabled"])
        v.shot("watch-dialog-ready")
        v.key("Return")
        state = v.wait_for(lambda s: dialog(s) == {} and item(s, "robot.speed"))
        plot = item(state, "robot.speed")
        assert plot["type"] == "plot"
        assert plot["watch"] == {"file": str(LOOP), "line": STEP_LINE, "exprs": ["robot.speed"]}
        state = v.wait_for(lambda s: len(live(s, "robot.speed")) >= 20, START_S)
        plot = item(state, "robot.speed")
        assert plot["topics"] == ["/rosdashboard/watch/robot/speed"]
        assert f"pid {first.pid}" in plot["reason"]
        assert set(plot["values"]) <= first.speeds(), "every value plotted is one the program had"
        assert plot["values"] == sorted(plot["values"])
        v.shot("watch-plot-live")

        v.key("ctrl+s")  # a new dashboard: Save asks for a name
        v.wait_for(lambda s: s["file_dialog"])
        v.type(str(tmp_path / "watched"))
        v.key("Return")
        state = v.wait_for(lambda s: s["path"] == str(tmp_path / "watched.json") and not s["dirty"])
        saved = json.loads((tmp_path / "watched.json").read_text())
        assert saved["version"] == 3  # WATCH_VERSION
        assert saved["widgets"][0]["watch"] == plot["watch"]
        v.stop()
    finally:
        first.finish()

    second = Program(LOOP, tmp_path, "run2")  # the program restarted while no viewer ran
    third: Program | None = None
    try:
        v = viewer(f"open:{tmp_path / 'watched.json'}")

        def fills_from(program: Program) -> Callable[[dict[str, Any]], bool]:
            def check(s: dict[str, Any]) -> bool:
                plot = item(s, "robot.speed")
                ok = f"pid {program.pid}" in plot["reason"] and plot["status"] == "live"
                return ok and bool(set(plot["values"]) & program.speeds())

            return check

        state = v.wait_for(fills_from(second), START_S)
        assert not state["dirty"], "reopening and arming changes nothing to save"
        second.kill()  # its node stays on the graph until the middleware's lease ends (20 s): not waited for
        state = v.wait_for(lambda s: item(s, "robot.speed")["pill"] == "gone", GONE_S)
        assert f"pid {second.pid}" in item(state, "robot.speed")["reason"]
        v.shot("watch-gone")
        third = Program(LOOP, tmp_path, "run3")
        v.wait_for(fills_from(third), START_S)
    finally:
        second.finish()
        if third is not None:
            third.finish()


def test_key_opens_the_dialog_on_an_rclpy_node(
    viewer: Callable[[str], ViewerChild], talker: Program, loop: Program
) -> None:
    """Ctrl+Shift+W opens the dialog; an rclpy node with DBGLOG_WATCH=1 is chosen among the processes
    (libraries too offers rclpy's files), its file taken from the type-ahead with Enter, a line clicked,
    ``self.count`` typed with completion (a held Enter takes the name and adds nothing) and a condition (one
    with a call refused as typed): a plot shows the node's counter at the hits the condition lets through."""
    v = viewer("empty")
    v.key("ctrl+shift+w")
    v.wait_for(lambda s: dialog(s).get("kind") == "WatchDialog")
    choose_process(v, "watch_talker", talker)
    state = v.wait_for(lambda s: "1 file of your code" in dialog(s)["file_note"], START_S)
    v.click(*center(dialog(state)["every_rect"]))  # libraries too: rclpy's files are offered
    state = v.wait_for(lambda s: dialog(s)["file_note"].endswith("files loaded by /watch_talker"), START_S)
    assert int(dialog(state)["file_note"].split()[0]) > 20
    v.click(*center(dialog(state)["file_rect"]))
    v.type("n")
    v.wait_for(lambda s: len(dialog(s)["files"]) >= 5)
    assert fits(v.frames(3)), "the dialog with its longest file list fits the window"
    v.type("ode.py")
    state = v.wait_for(lambda s: "node.py" in names(dialog(s)["files"]))
    v.click(*center(dialog(state)["every_rect"]))
    state = v.wait_for(lambda s: "1 file of your code" in dialog(s)["file_note"], START_S)
    v.click(*center(dialog(state)["file_rect"]))
    v.key("ctrl+a", "BackSpace")
    v.type("talk")
    state = v.wait_for(lambda s: names(dialog(s)["files"])[:1] == ["talker.py"])
    v.key("Return")
    state = v.wait_for(lambda s: dialog(s)["chosen_file"] == str(TALKER) and dialog(s)["source"], START_S)
    v.click(*center(scroll_to_line(v, TICK_LINE)))
    v.wait_for(lambda s: dialog(s)["names"] and dialog(s)["expr_active"], START_S)
    v.type("sel")
    v.wait_for(lambda s: names(dialog(s)["completions"]) == ["self"])
    v.xdo("keydown", "Return")  # held: Dear ImGui repeats it after 0.275 s, every 0.05 s
    time.sleep(0.6)
    v.xdo("keyup", "Return")
    state = v.wait_for(lambda s: dialog(s).get("expr") == "self" and dialog(s)["expr_active"])
    v.frames(3)
    assert dialog(v.state()).get("expr") == "self", "a held Enter took the name and added no widget"
    # The expression on from there: typed whole over what the field holds (its cursor, after a completion
    # taken, may still be behind a selection of it on a loaded machine: ".count" then replaced "self").
    v.key("ctrl+a")
    v.type("self.count")
    state = v.wait_for(lambda s: dialog(s)["expr"] == "self.count" and dialog(s)["ok_enabled"])
    v.click(*center(dialog(state)["when_rect"]))  # only when, as a conditional breakpoint
    v.type("self.count % 3 == len(x)")
    state = v.wait_for(lambda s: "calls are not allowed" in dialog(s)["expr_note"])
    assert not dialog(state)["ok_enabled"]
    v.key("ctrl+a", "BackSpace")
    v.type("self.count % 3 == 0")
    v.wait_for(lambda s: dialog(s)["when"] == "self.count % 3 == 0" and dialog(s)["ok_enabled"])
    v.key("Return")
    state = v.wait_for(lambda s: len(item(s, "self.count").get("values", [])) >= 10, START_S)
    counter = item(state, "self.count")
    assert counter["watch"]["node"] == "/watch_talker"
    assert counter["watch"]["when"] == "self.count % 3 == 0"
    assert counter["topics"] == ["/rosdashboard/watch/self/count"]
    values = counter["values"]
    assert all(float(x).is_integer() and x > 0 and x % 3 == 0 for x in values), "only the hits wanted"
    steps = [b - a for a, b in itertools.pairwise(values)]
    assert steps.count(3) >= len(steps) // 2, "every third count"


def test_widgets_show_each_watch_state(
    viewer: Callable[[str], ViewerChild], loop: Program, tmp_path: Path
) -> None:
    """A dashboard's watches each show their state on the widget: armed and live, a line with no code, a
    missing name, a property (reading it would run code), a call (refused before it is sent), disarmed by
    the CPU rule."""
    from dbglog.viewer._document._dashboard import (
        Dashboard,
        RawWidget,
        WatchConfig,
        WidgetConfig,
        save_dashboard,
    )

    def widget(name: str, line: int, expr: str, x: float, y: float, cpu: float | None = None) -> WidgetConfig:
        watch = WatchConfig(str(LOOP), line, (expr,), max_cpu=cpu)
        return WidgetConfig("string", name, x, y, 300, 160, (), {}, None, watch)

    widgets = [
        widget("good", STEP_LINE, "speed", 20, 20),
        widget("blank", BLANK_LINE, "speed", 340, 20),
        widget("missing", STEP_LINE, "nosuch", 20, 200),
        widget("costly", STEP_LINE, "robot.costly", 340, 200),
        widget("call", STEP_LINE, "len(ranges)", 660, 200),
        widget("hot", HOT_LINE, "acc", 660, 20, cpu=0.1),
    ]
    path = tmp_path / "states.json"
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget](widgets)), path)
    v = viewer(f"open:{path}")

    def shown(s: dict[str, Any]) -> dict[str, str]:
        return {i["name"]: i["pill"] for i in s["items"]}

    want = {"good": "live", "blank": "no line", "hot": "cpu limit"}
    want |= dict.fromkeys(("missing", "costly", "call"), "expr error")
    state = v.wait_for(lambda s: shown(s) == want, START_S)
    reasons = {i["name"]: i["reason"] for i in state["items"]}
    assert f"pid {loop.pid}" in reasons["good"]
    assert str(BLANK_LINE) in reasons["blank"]
    assert "nosuch" in reasons["missing"]
    assert "property: reading it would run code" in reasons["costly"]
    assert "'len(ranges)' is not allowed" in reasons["call"]
    assert "disarmed so as not to slow the program" in reasons["hot"]
    assert {i["status"] for i in state["items"] if i["name"] != "good"} == {"error"}
    assert not state["dirty"], "binding a widget to its watch's topics is no edit: the file opens unmodified"
    v.shot("watch-states")


def test_a_replay_arms_no_watch_and_shows_the_recorded_values(display: str, tmp_path: Path) -> None:
    """``dbglog view --replay`` with a dashboard of watches arms none (no ROS): the widget shows the
    recording's values of the watch's tag and says it is not armed; the watch is kept for saving."""
    from rclpy.serialization import serialize_message
    from std_msgs.msg import Float64

    from dbglog.record import McapWriter
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import (
        Dashboard,
        RawWidget,
        WatchConfig,
        WidgetConfig,
        save_dashboard,
    )

    topic, t0 = "/rosdashboard/watch/speed", 1_700_000_000_000_000_000
    writer = McapWriter(tmp_path / "run.mcap")
    channel = writer.add_channel(topic, "std_msgs/msg/Float64")
    for i in range(50):
        writer.write(channel, t0 + i * 100_000_000, serialize_message(Float64(data=i * 0.5)), t0)
    writer.close()
    watch = WatchConfig(str(LOOP), STEP_LINE, ("speed",))
    plot = WidgetConfig("plot", "speed", 20, 20, 420, 260, (Binding(topic, "data"),), {}, None, watch)
    save_dashboard(Dashboard(list[WidgetConfig | RawWidget]([plot])), tmp_path / "dash.json")
    report = tmp_path / "report.json"
    dash, rec, shot = tmp_path / "dash.json", tmp_path / "run.mcap", tmp_path / "shot.png"
    done = subprocess.run(
        [sys.executable, "-m", "dbglog", "view", str(dash), "--replay", str(rec), "--screenshot", str(shot),
         "--after", "0.3", "--report-json", str(report)],
        env={**os.environ, "DISPLAY": display}, capture_output=True, text=True, timeout=120, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    (widget,) = json.loads(report.read_text())["widgets"]
    assert widget["values"] == [24.5]
    assert widget["status"] == "live"
    assert widget["reason"].startswith("not armed: a recording is shown")
    assert json.loads(report.read_text())["dashboard"]["widgets"][0]["watch"] == watch.to_dict()


def test_the_window_keeps_drawing_while_a_process_does_not_answer(
    viewer: Callable[[str], ViewerChild], tmp_path: Path
) -> None:
    """A process stopped (SIGSTOP) after it was listed never answers: the dialog says it is reading its
    files while the window goes on drawing and taking input, then says the process did not answer."""
    frozen = Program(LOOP, tmp_path, "frozen")
    try:
        v = viewer("empty")
        v.key("ctrl+shift+w")
        v.wait_for(lambda s: dialog(s).get("kind") == "WatchDialog")
        choose_process(v, f"pid {frozen.pid} ", frozen)
        state = v.wait_for(lambda s: "file of your code" in dialog(s)["file_note"], START_S)
        os.kill(frozen.pid, signal.SIGSTOP)
        v.click(*center(dialog(state)["every_rect"]))  # ask again: it will not answer now
        state = v.wait_for(lambda s: dialog(s)["file_note"].startswith("reading the files"))
        x, y, _w, h = dialog(state)["source_rect"]
        first, start, k = int(state["frame"]), time.monotonic(), 0
        while time.monotonic() - start < 2.5:  # the client gives up after 5 s: still asking meanwhile
            v.move(x + 20 + 30 * (k % 20), y + h / 2)  # each move is seen by a drawn frame
            k += 1
        state = v.state()
        assert dialog(state)["file_note"].startswith("reading the files"), "still asking"
        assert int(state["frame"]) - first >= 10, "the window drew while the process did not answer"
        state = v.wait_for(lambda s: "did not answer" in dialog(s)["error"], START_S)
        assert dialog(state)["error"].startswith("cannot list the process's files")
    finally:
        with contextlib.suppress(ProcessLookupError):
            os.kill(frozen.pid, signal.SIGCONT)
        frozen.finish()


def test_a_process_listed_before_its_node_is_named_by_it_once_it_has_one(
    viewer: Callable[[str], ViewerChild], tmp_path: Path
) -> None:
    """An rclpy program listed before it made its node (by its program's name) is listed by its node's name
    once it has one, and a watch set in it is for that node."""
    v = viewer("empty")
    v.key("ctrl+shift+w")
    v.wait_for(lambda s: dialog(s).get("kind") == "WatchDialog")
    make_node = tmp_path / "make-node"
    late = Program(TALKER, tmp_path, "late", str(make_node))  # its node once the test has seen it without
    try:
        early = f"talker.py   pid {late.pid} "
        try:
            v.wait_for(lambda s: any(r[0].startswith(early) for r in dialog(s)["procs"]), START_S)
        except AssertionError as exc:
            raise AssertionError(f"never listed without its node: the program {late.said()}\n{exc}") from None
        choose_process(v, early, late)
        make_node.touch()
        named = f"/watch_talker   pid {late.pid} "
        state = v.wait_for(lambda s: any(r[0].startswith(named) for r in dialog(s)["procs"]), START_S)
        assert dialog(state)["proc_note"] == f"watching in /watch_talker (pid {late.pid})"
        assert any(r[2] for r in dialog(state)["procs"] if f"pid {late.pid} " in r[0]), "still the chosen one"
    finally:
        late.finish()
