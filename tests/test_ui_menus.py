"""The viewer's menus under Xvfb, clicked with the real mouse: the context menu and its widget types, Save As.

Each test starts the real `ViewerApp.run` loop in a process of its own. A frame hook there reports what is
on screen (widgets, menu entries and dialogs with their window-pixel rectangles, the keyboard focus) to a
JSON file; this process reads it to know where to point, and moves, clicks and types with xdotool (XTEST:
the same events a real mouse and keyboard make). Nothing here calls a callback or handler directly.
"""

from __future__ import annotations

import json
import os
import shutil
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from tests._viewer_child import ViewerChild as Viewer

pytestmark = pytest.mark.gui

ROOT = Path(__file__).resolve().parent.parent
WAIT_S = 30.0
"""How long the viewer may take to show what a click asked for (generous for a loaded CI machine)."""


# -- the child: a real viewer whose frame hook reports what is on screen ---------------------------------


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


def _window_rect(window: int | str) -> list[float] | None:
    import dearpygui.dearpygui as dpg

    if not dpg.does_item_exist(window) or not dpg.is_item_shown(window):
        return None
    (x, y), (w, h) = dpg.get_item_pos(window), dpg.get_item_rect_size(window)
    return [float(x), float(y), float(w), float(h)]


def _labelled(window: int | str) -> dict[str, list[float] | None]:
    """Every labelled item in `window` (menu entries, buttons) -> its rectangle in window pixels.

    Dear PyGui reports no rectangle for a menu entry, only where it starts inside its window: its
    rectangle is then that line across the window, or for an entry of an open submenu, that line in
    the submenu Dear ImGui places to the right of the menu, level with the submenu's own entry.
    """
    import dearpygui.dearpygui as dpg

    (wx, wy), (ww, _) = dpg.get_item_pos(window), dpg.get_item_rect_size(window)
    out: dict[str, list[float] | None] = {}
    origin: dict[int | str, tuple[float, float]] = {window: (float(wx), float(wy))}
    stack = [window]
    while stack:
        item = stack.pop()
        for slot in (1, 2):
            for child in dpg.get_item_children(item, slot) or []:
                if not dpg.is_item_shown(child):  # an entry hidden now is not in the menu
                    continue
                label = dpg.get_item_label(child)
                rect = _rect(child)
                state = dpg.get_item_state(child)
                if rect is None and item in origin and "pos" in state:
                    x, y = state["pos"]
                    h = dpg.get_text_size(label)[1] if label else 0.0
                    ox, oy = origin[item]
                    rect = [ox + x, oy + y, float(ww - 2 * x), float(h)]
                if rect is not None and dpg.get_item_type(child) == "mvAppItemType::mvMenu":
                    origin[child] = (float(wx + ww - 4), rect[1] - 8)
                if label and label not in out:
                    out[label] = rect
                stack.append(child)
    return out


def _menubar(window: int | str) -> dict[str, Any]:
    """The window's menu bar: each menu's label position and size, and where its entries sit when open.

    Dear PyGui gives a menu-bar menu and its entries no rectangle: only where the label starts in the bar,
    and, while the menu is open, where each entry starts inside the menu's popup (which opens below the bar).
    """
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


class Probe:
    """Frame hook: writes the viewer's visible state to `state.json` whenever it changes."""

    def __init__(self, app: Any, tmp: Path) -> None:
        self.app, self.tmp = app, tmp
        self.frame = 0

    def state(self) -> dict[str, Any]:
        """What is on screen now."""
        import dearpygui.dearpygui as dpg

        from dbglog.viewer._ui._dialogs import TopicDialog

        app = self.app
        ox, oy = app.canvas.origin()
        items = [
            {
                "name": i.name,
                "type": i.config.type,
                "rect": [i.rect.x + ox, i.rect.y + oy, i.rect.w, i.rect.h],
                "topics": [b.topic for b in i.bindings],
                "fields": [b.field for b in i.bindings],
            }
            for i in app.items
        ]
        state: dict[str, Any] = {
            "pid": os.getpid(),
            "tree_query": app.tree.model.query,
            "items": items,
            "toolbox": {dpg.get_item_label(b): _rect(b) for b in app.canvas.tools.buttons.values()},
            "selected": app.doc.selected.name if app.doc.selected is not None else None,
            "dirty": app.doc.dirty,
            "path": str(app.doc.path) if app.doc.path else None,
            "mouse": list(dpg.get_mouse_pos(local=False)),
            "menu": _labelled(app.pointer_input.menu) if dpg.is_item_shown(app.pointer_input.menu) else None,
            "menu_rect": _window_rect(app.pointer_input.menu),
            "file_dialog": None,
            "dialog": None,
            "status": app.status.text,
            "menubar": _menubar(app.main),
        }
        request = app.files.request
        if request is not None and dpg.does_item_exist(request.item):
            state["file_dialog"] = {"save": request.save, "shown": bool(dpg.is_item_shown(request.item))}
            save_as = getattr(request, "dialog", None)  # the viewer's own Save As (not Open's file dialog)
            if save_as is not None:
                state["file_dialog"].update(
                    name=dpg.get_value(save_as.name_input),
                    name_active=bool(dpg.is_item_active(save_as.name_input)),
                    folder=str(save_as.folder),
                    error=dpg.get_value(save_as.error),
                    rect=_window_rect(save_as.window),
                    controls=_labelled(save_as.window),
                )
        dialog = app.dialog
        if dialog is not None:
            info: dict[str, Any] = {
                "kind": type(dialog).__name__,
                "title": dpg.get_item_label(dialog.window),
                "rect": _window_rect(dialog.window),
                "controls": _labelled(dialog.window),
            }
            if isinstance(dialog, TopicDialog):
                info.update(
                    topic=dpg.get_value(dialog.topic_input),
                    topic_rect=_rect(dialog.topic_input),
                    topic_active=bool(dpg.is_item_active(dialog.topic_input)),
                    suggestions=list(dialog._suggestions),
                    highlighted=dpg.get_value(dialog.suggest_list),
                    texts=[
                        str(dpg.get_value(t))
                        for t in _all_children(dialog.window)
                        if dpg.get_item_type(t) == "mvAppItemType::mvText"
                        and dpg.get_item_state(t).get("visible")
                    ],
                )
            state["dialog"] = info
        return state

    def hook(self) -> None:
        """Report; answer screenshot requests (`shot-NAME` files the test drops into the folder)."""
        import dearpygui.dearpygui as dpg

        self.frame += 1
        for request in sorted(self.tmp.glob("shot-*.request")):
            name = request.stem.removeprefix("shot-")
            request.unlink()
            dpg.output_frame_buffer(file=str(self.tmp / f"{name}.png"))
            pacer = getattr(self.app, "pacer", None)  # a viewer that renders only on change: render now
            if pacer is not None:
                pacer.request()
        state = self.state()
        state["frame"] = self.app.loop.rendered  # frames drawn (input is read then)
        out = self.tmp / "state.json.tmp"
        out.write_text(json.dumps(state, indent=1))
        out.replace(self.tmp / "state.json")


def _all_children(parent: int | str) -> list[int | str]:
    import dearpygui.dearpygui as dpg

    out: list[int | str] = []
    stack = [parent]
    while stack:
        item = stack.pop()
        for slot in (1, 2):
            kids = dpg.get_item_children(item, slot) or []
            out.extend(kids)
            stack.extend(kids)
    return out


def start_dashboard(tmp: Path) -> Path:
    """The dashboard the tests open: a dial on the speed topic and an LED without one."""
    from dbglog.viewer._data._model import Binding
    from dbglog.viewer._document._dashboard import Dashboard, RawWidget, WidgetConfig, save_dashboard

    widgets = [
        WidgetConfig("dial", "Speed", 40, 40, 240, 260, (Binding("/rosdashboard/speed", "data"),), {}),
        WidgetConfig("led", "Lamp", 340, 40, 200, 160, (), {}),
        WidgetConfig("toggle", "Fan", 600, 40, 200, 98, (Binding("/fan/on"),), {"state": False}),
    ]
    unknown = RawWidget(
        {"type": "sonar", "name": "Sonar", "x": 340, "y": 400, "width": 200, "height": 120}, ""
    )
    path = tmp / "dash.json"
    save_dashboard(Dashboard([*widgets, unknown], 20, True), path)
    return path


def run_here(scenario: str, tmp_dir: str) -> None:
    """Child-process entry: open the start dashboard (or none) and run the viewer until it closes."""
    warnings.simplefilter("error")
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from tests.test_ui import make_source

    tmp = Path(tmp_dir)
    registry = WidgetRegistry.builtin()
    source = make_source()
    source.push("/rosdashboard/speed", "data", 3.5)
    app = ViewerApp(source, registry, width=1200, height=760)
    app.start()
    try:
        if scenario == "dashboard":
            path = start_dashboard(tmp)
            app.load(load_dashboard(path, registry.get), path)
        probe = Probe(app, tmp / "probe")
        app.frame_hooks.append(probe.hook)
        app.run()
    finally:
        app.close()


# -- this side: a desktop with a mouse and a keyboard ----------------------------------------------------


def center(rect: list[float]) -> tuple[float, float]:
    """The middle of an [x, y, w, h] rectangle."""
    return rect[0] + rect[2] / 2, rect[1] + rect[3] / 2


def start_viewers(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Fixture body: start viewers on the display (ready for input); each is killed at the end."""
    assert shutil.which("xdotool"), "xdotool is missing: .ci/setup.sh installs it"
    started: list[Viewer] = []

    def start(scenario: str) -> Viewer:
        v = Viewer(scenario, tmp_path, display, "test_ui_menus")
        started.append(v)
        v.ready()
        return v

    yield start
    for v in started:
        v.stop()


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    yield from start_viewers(display, tmp_path)


def item_named(state: dict[str, Any], name: str) -> dict[str, Any]:
    """The reported widget called `name`."""
    return next(i for i in state["items"] if i["name"] == name)


# -- the context menu ---------------------------------------------------------------------------------------


def test_context_menu_change_type_by_clicking(viewer: Callable[[str], Viewer]) -> None:
    """Right-click a widget, Change widget type, click Plot: the dial becomes a plot on the same topic."""
    v = viewer("dashboard")
    state = v.state()
    dial = item_named(state, "Speed")
    assert dial["type"] == "dial"
    x, y, w, h = dial["rect"]
    v.click(x + w / 2, y + h / 2, button=3)
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Change widget type"))
    v.move(*center(state["menu"]["Change widget type"]))
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Plot"))
    shot = v.shot("type-menu")
    v.click(*center(state["menu"]["Plot"]))
    state = v.wait_for(lambda s: item_named(s, "Speed")["type"] == "plot")
    plot = item_named(state, "Speed")
    assert plot["topics"] == ["/rosdashboard/speed"]
    assert plot["rect"][:2] == dial["rect"][:2]
    assert state["menu"] is None
    assert state["dirty"] is True
    assert shot.stat().st_size > 0


def test_context_menu_offers_only_what_applies_to_the_widget(viewer: Callable[[str], Viewer]) -> None:
    """The context menu leaves out what cannot act on its widget: Overlay across robots shows on a plot only,
    Topic setup and Properties not on the placeholder of a widget type not installed."""
    v = viewer("dashboard")
    state = v.state()

    def menu_on(name: str) -> dict[str, Any]:
        x, y, w, _ = item_named(v.state(), name)["rect"]
        v.click(x + w / 2, y + 10, button=3)  # on the title (a plot takes a right click for itself)
        state = v.wait_for(
            lambda s: s["menu"] is not None and s["selected"] == name and s["menu"].get("Rename\u2026")
        )
        v.key("Escape")
        v.wait_for(lambda s: s["menu"] is None)
        return {label: rect for label, rect in state["menu"].items() if rect is not None}

    dial = menu_on("Speed")
    assert "Overlay across robots" not in dial
    assert "Topic setup\u2026" in dial
    assert "Properties\u2026" in dial
    assert "Overlay across robots" not in menu_on("Lamp")
    placeholder = menu_on("Sonar")
    assert "Topic setup\u2026" not in placeholder
    assert "Properties\u2026" not in placeholder
    assert "Delete" in placeholder
    x, y, w, h = item_named(state, "Speed")["rect"]
    v.click(x + w / 2, y + h / 2, button=3)
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Change widget type"))
    v.move(*center(state["menu"]["Change widget type"]))
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Plot"))
    v.click(*center(state["menu"]["Plot"]))
    v.wait_for(lambda s: item_named(s, "Speed")["type"] == "plot" and s["menu"] is None)
    assert "Overlay across robots" in menu_on("Speed")


def test_context_menu_closes_on_escape_and_outside_click(viewer: Callable[[str], Viewer]) -> None:
    """Escape closes the context menu; so does a click outside it, which does nothing else."""
    v = viewer("dashboard")
    x, y, w, h = item_named(v.state(), "Lamp")["rect"]
    v.click(x + w / 2, y + h / 2, button=3)
    v.wait_for(lambda s: s["menu"] is not None)
    v.key("Escape")
    v.wait_for(lambda s: s["menu"] is None)
    v.click(x + w / 2, y + h / 2, button=3)
    state = v.wait_for(lambda s: s["menu"] is not None)
    assert state["selected"] == "Lamp"
    v.click(x + w / 2, y + h + 200)  # empty canvas
    state = v.wait_for(lambda s: s["menu"] is None)
    v.frames(3)
    state = v.state()
    assert state["selected"] == "Lamp", "the click that closed the menu did not reach the canvas"
    assert item_named(state, "Lamp")["type"] == "led"
    assert state["dirty"] is False


# -- keys ----------------------------------------------------------------------------------------------


def test_a_letter_typed_just_after_a_ctrl_chord_is_a_letter(viewer: Callable[[str], Viewer]) -> None:
    """Ctrl+A in the tag tree's filter, then 'm' 40 ms after Ctrl is let go, is the letter m, no
    Ctrl+M (Add marker), Ctrl being up when it went down; a Ctrl+M then runs Add marker."""
    v = viewer("dashboard")
    v.key("ctrl+f")
    v.type("ab")
    v.wait_for(lambda s: s["tree_query"] == "ab")
    v.xdo("keydown", "ctrl", "sleep", "0.03", "key", "a", "keyup", "ctrl", "sleep", "0.04", "key", "m")
    state = v.wait_for(lambda s: s["tree_query"].endswith("m"))  # "m" once Ctrl+A selected "ab"
    v.frames(5)
    state = v.state()
    assert "marker" not in state["status"], "the m ran Add marker"
    assert state["tree_query"] in {"m", "abm"}
    x, y, w, _ = item_named(state, "Lamp")["rect"]
    v.click(x + w / 2, y + 10)  # the canvas takes the keyboard
    v.key("ctrl+m")  # Add marker, which this source (it keeps no events) answers in the status bar
    v.wait_for(lambda s: "no marker can be added" in s["status"])


# -- Save As ------------------------------------------------------------------------------------------------


def test_save_as_starts_with_the_file_name_and_adds_json_once(
    viewer: Callable[[str], Viewer], tmp_path: Path
) -> None:
    """Ctrl+Shift+S opens Save As on the dashboard's name, ready to type over; .json is added once."""
    v = viewer("dashboard")
    v.key("ctrl+shift+s")
    state = v.wait_for(lambda s: s["file_dialog"] is not None and s["file_dialog"]["name_active"])
    assert state["file_dialog"]["name"] == "dash.json"
    assert state["file_dialog"]["folder"] == str(tmp_path)
    shot = v.shot("save-as")
    v.type("mydash")
    state = v.wait_for(lambda s: s["file_dialog"]["name"] == "mydash")
    v.key("Return")
    state = v.wait_for(lambda s: s["file_dialog"] is None and s["path"] == str(tmp_path / "mydash.json"))
    assert state["dirty"] is False
    saved = json.loads((tmp_path / "mydash.json").read_text())
    assert [w["name"] for w in saved["widgets"]] == ["Speed", "Lamp", "Fan", "Sonar"]
    assert not [p.name for p in tmp_path.iterdir() if p.name.startswith(".")], "no hidden file"

    v.key("ctrl+shift+s")  # a name typed with .json keeps it as it is
    state = v.wait_for(lambda s: s["file_dialog"] is not None and s["file_dialog"]["name_active"])
    assert state["file_dialog"]["name"] == "mydash.json"
    v.type("other.json")
    v.key("Return")
    v.wait_for(lambda s: s["path"] == str(tmp_path / "other.json"))
    assert sorted(p.name for p in tmp_path.glob("*.json")) == ["dash.json", "mydash.json", "other.json"]
    assert shot.stat().st_size > 0


def test_file_menu_save_as_by_mouse(viewer: Callable[[str], Viewer], tmp_path: Path) -> None:
    """File > Save As... clicked with the mouse opens Save As on the dashboard's name; Enter saves."""
    v = viewer("dashboard")
    file_menu = v.state()["menubar"]["File"]
    (fx, fy), (tw, th) = file_menu["pos"], file_menu["size"]
    v.click(fx + tw / 2, fy + th / 2 + 3)
    # The open menu reports where each entry starts inside its popup, which opens below the menu bar
    # (the bar is one text line plus the theme's FramePadding of 5 px above and below).
    state = v.wait_for(lambda s: s["menubar"]["File"]["entries"]["Save As\u2026"][1] > 0)
    ex, ey = state["menubar"]["File"]["entries"]["Save As\u2026"]
    bar = th + 2 * 5
    v.click(fx + ex + 20, bar + ey + th / 2)
    state = v.wait_for(lambda s: s["file_dialog"] is not None and s["file_dialog"]["name_active"])
    assert state["file_dialog"]["name"] == "dash.json"
    v.type("bymouse")
    v.wait_for(lambda s: s["file_dialog"]["name"] == "bymouse")
    v.key("Return")
    v.wait_for(lambda s: s["file_dialog"] is None and s["path"] == str(tmp_path / "bymouse.json"))
    assert json.loads((tmp_path / "bymouse.json").read_text())["widgets"]


def test_save_as_asks_before_replacing_and_escape_cancels(
    viewer: Callable[[str], Viewer], tmp_path: Path
) -> None:
    """Enter on an existing name asks first (a second Enter replaces it); Escape closes Save As unsaved."""
    v = viewer("dashboard")
    before = (tmp_path / "dash.json").read_bytes()
    v.key("ctrl+shift+s")
    v.wait_for(lambda s: s["file_dialog"] is not None and s["file_dialog"]["name_active"])
    v.key("Return")
    state = v.wait_for(lambda s: "already exists" in (s["file_dialog"] or {}).get("error", ""))
    assert (tmp_path / "dash.json").read_bytes() == before
    shot = v.shot("replace")
    v.click(*center(state["file_dialog"]["controls"]["Save"]))
    v.wait_for(lambda s: s["file_dialog"] is None)
    assert (tmp_path / "dash.json.bak").read_bytes() == before

    v.key("ctrl+shift+s")
    v.wait_for(lambda s: s["file_dialog"] is not None and s["file_dialog"]["name_active"])
    v.type("never")
    v.key("Escape")
    v.wait_for(lambda s: s["file_dialog"] is None)
    v.frames(5)
    assert not (tmp_path / "never.json").exists()
    assert v.state()["path"] == str(tmp_path / "dash.json")
    assert shot.stat().st_size > 0
