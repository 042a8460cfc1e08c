"""The real Dear PyGui viewer under Xvfb: add, move, snap, resize, delete, rename, dialogs, files, shots.

Dear PyGui 2.3 crashes now and then when a second context is created in one process, so every scenario
runs in a fresh Python process with its own viewer, driven through the same methods the mouse and the
drag-and-drop callbacks use; data comes from a `StaticSource` whose arrays the scenario controls.
"""

from __future__ import annotations

import json
import shutil
import struct
import time
import warnings
import zlib
from collections.abc import Sequence
from pathlib import Path

import dearpygui.dearpygui as dpg
import numpy as np
import numpy.typing as npt
import pytest

from dbglog.viewer._data._model import Binding, FieldInfo, SeriesSnapshot, Status
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._document._dashboard import WidgetConfig, load_dashboard
from dbglog.viewer._ui import StaticSource, ViewerApp
from dbglog.viewer._ui._dialogs import (
    MessageDialog,
    PropertiesDialog,
    RenameDialog,
    TopicDialog,
    regex_preview,
)
from dbglog.viewer._ui._frame import TITLE_H, CanvasItem
from dbglog.viewer._ui._theme import STATUS_COLORS
from dbglog.viewer._ui._timebar import CHANGE_COLOR, RAIL_Y, TimeBar
from dbglog.viewer._ui._timescale import TimeScale
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer._widgets._geometry import Rect
from dbglog.viewer._widgets._plot import PlotWidget
from dbglog.viewer.widget_api import EventMark, Widget
from tests._children import run_dbglog, run_scenario

pytestmark = pytest.mark.gui

GOLDEN = Path(__file__).parent / "golden" / "dashboards"


def read_png(path: Path) -> npt.NDArray[np.uint8]:
    """Decode an 8-bit RGB/RGBA PNG (what Dear PyGui writes) into an (h, w, channels) array."""
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n", f"{path} is not a PNG"
    i, idat = 8, bytearray()
    w = h = ctype = 0
    while i < len(data):
        (n,) = struct.unpack(">I", data[i : i + 4])
        kind = data[i + 4 : i + 8]
        if kind == b"IHDR":
            w, h, _depth, ctype = struct.unpack(">IIBB", data[i + 8 : i + 18])
        elif kind == b"IDAT":
            idat += data[i + 8 : i + 8 + n]
        i += 12 + n
    bpp = {6: 4, 2: 3}[ctype]
    raw = zlib.decompress(bytes(idat))
    stride = w * bpp
    out = np.zeros((h, stride), dtype=np.uint8)
    prev = np.zeros(stride, dtype=np.int64)
    for r in range(h):
        f = raw[r * (stride + 1)]
        line = np.frombuffer(raw, dtype=np.uint8, count=stride, offset=r * (stride + 1) + 1).astype(np.int64)
        if f == 0:
            cur = line
        elif f == 1:
            cur = line.reshape(w, bpp).cumsum(axis=0).reshape(-1) & 255
        elif f == 2:
            cur = (line + prev) & 255
        else:
            cl, pl = line.tolist(), prev.tolist()
            for x in range(stride):
                a = cl[x - bpp] if x >= bpp else 0
                b = pl[x]
                if f == 3:
                    cl[x] = (cl[x] + ((a + b) >> 1)) & 255
                    continue
                c = pl[x - bpp] if x >= bpp else 0
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                cl[x] = (cl[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
            cur = np.array(cl, dtype=np.int64)
        out[r] = cur
        prev = cur
    return out.reshape(h, w, bpp)


def count_color(img: npt.NDArray[np.uint8], rgb: Sequence[int], tol: int = 6) -> int:
    """Count pixels within `tol` of an RGB colour."""
    diff = np.abs(img[:, :, :3].astype(np.int64) - np.array(rgb[:3]))
    return int(np.all(diff <= tol, axis=2).sum())


def make_source() -> StaticSource:
    """A data source with a few topics on its 'graph'."""
    src = StaticSource()
    src.add_topic("/rosdashboard/speed", "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    src.add_topic("/rosdashboard/state", "std_msgs/msg/String", [FieldInfo("data", "string", False)])
    src.add_topic(
        "/robot/pose",
        "geometry_msgs/msg/Pose",
        [
            FieldInfo("position", "geometry_msgs/Point", False),
            FieldInfo("position.x", "double", True),
            FieldInfo("position.z", "double", True),
        ],
    )
    return src


def run_here(name: str, tmp: str) -> None:
    """Child-process entry: run scenario `name` against a fresh viewer (one context per process)."""
    warnings.simplefilter("error")
    source = make_source()
    app = ViewerApp(source, WidgetRegistry.builtin(), width=1200, height=800)
    app.start()
    try:
        globals()[f"scenario_{name}"](app, source, Path(tmp))
    finally:
        app.close()


def props(item: CanvasItem) -> dict[str, object]:
    """The item's saved property values."""
    assert isinstance(item.config, WidgetConfig)
    return dict(item.config.properties)


def frames(app: ViewerApp, n: int = 3) -> None:
    """Render a few frames."""
    for _ in range(n):
        app.frame()


def drop(app: ViewerApp, type_name: str, at: tuple[float, float]) -> CanvasItem:
    """Drop a toolbox widget at canvas point `at` through the canvas's registered drop callback."""
    app.canvas.pointer_override = app.canvas.to_window(at)
    callback = dpg.get_item_drop_callback(app.canvas.window)
    assert callback == app.canvas.on_drop
    before = len(app.items)
    callback(app.canvas.window, type_name, None)
    assert len(app.items) == before + 1
    return app.items[-1]


def title_point(item: CanvasItem, app: ViewerApp) -> tuple[float, float]:
    """A window point on the item's title strip."""
    r = item.rect
    return app.canvas.to_window((r.x + 40, r.y + TITLE_H / 2))


def scenario_toolbox_lists_every_widget_with_drag_payload(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """The toolbox has a draggable button per registered widget, and the canvas accepts that payload."""
    assert list(app.canvas.tools.buttons) == [
        *("plot", "dial", "knob", "compass", "thermo", "string", "led", "states", "log"),
        *("toggle", "slider", "button", "text_field", "publish"),
    ]
    for button in app.canvas.tools.buttons.values():
        payloads = [
            c for c in dpg.get_item_children(button, 3) or [] if dpg.get_item_type(c).endswith("DragPayload")
        ]
        assert len(payloads) == 1
        assert dpg.get_item_configuration(payloads[0])["payload_type"] == "dbglog-widget"
    assert dpg.get_item_configuration(app.canvas.window)["payload_type"] == "dbglog-widget"


def scenario_drop_adds_widget_on_grid_and_opens_topic_setup(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Dropping a toolbox widget places it snapped under the pointer and opens its topic setup at once."""
    item = drop(app, "dial", (205, 113))
    frames(app)
    assert item.config.type == "dial"
    assert (item.rect.x, item.rect.y) == (180, 100)
    assert isinstance(app.dialog, TopicDialog)
    assert app.dialog.item is item
    assert item.status is Status.WAITING
    assert app.doc.dirty


def scenario_topic_dialog_typeahead_fields_and_regex_preview(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Type-ahead suggests graph topics, the field list comes from the type, the regex preview is live."""
    item = drop(app, "string", (100, 100))
    dialog = app.dialog
    assert isinstance(dialog, TopicDialog)
    dpg.set_value(dialog.topic_input, "/rob")
    assert dialog.suggestions()[0].startswith("/robot/pose")
    dpg.set_value(dialog.topic_input, "state")
    assert [s.split()[0] for s in dialog.suggestions()] == ["/rosdashboard/state"]
    dialog.choose_topic("/robot/pose")
    items = dpg.get_item_configuration(dialog.field_combo)["items"]
    assert any("position.z" in label for label in items)
    dialog.choose_topic("/rosdashboard/state")
    dialog.choose_field("data")
    source.push("/rosdashboard/state", "data", "mode=DOCKING battery=81%")
    dialog.set_regex("mode=(\\w+)")
    frames(app, 2)
    assert (dialog.preview_ok, dialog.preview_text) == (True, "extracts: 'DOCKING'")
    dialog.set_regex("(?<=mode)x")
    frames(app, 2)
    assert (dialog.preview_ok, dialog.preview_text[:12]) == (False, "regex error:")
    assert "lookarounds are not supported" in dpg.get_value(dialog.preview)
    assert not dialog.apply(), "a regex RE2 rejects is not accepted"
    dialog.set_regex("mode=(\\w+)")
    assert dialog.apply()
    assert app.dialog is None
    assert item.bindings == (Binding("/rosdashboard/state", "data", "mode=(\\w+)"),)
    assert Binding("/rosdashboard/state", "data", "mode=(\\w+)") in source.bound
    frames(app, 3)
    assert item.status is Status.LIVE
    assert item.widget is not None
    assert getattr(item.widget, "latest_text", "") == "DOCKING"


def scenario_topic_dialog_robot_choice(app: ViewerApp, source: StaticSource, tmp_path: Path) -> None:
    """With robots in namespaces, Topic setup offers the selected robot's and every robot's topic: a series
    set so becomes relative, and opens again as the selected robot's topic with its choice shown."""
    for robot in ("/robot1", "/robot2"):
        source.add_topic(
            f"{robot}/rosdashboard/speed", "std_msgs/msg/Float64", [FieldInfo("data", "double", True)]
        )
    app.robots.discover()
    app.robots.select("/robot2")
    item = drop(app, "plot", (100, 100))
    dialog = app.dialog
    assert isinstance(dialog, TopicDialog)
    labels = dpg.get_item_configuration(dialog.robot_combo)["items"]
    assert labels == [
        "this topic as typed",
        "the selected robot's (now robot2)",
        "every robot's: one series each",
    ]
    assert dpg.get_value(dialog.robot_combo) == "this topic as typed"
    dialog.choose_topic("/robot1/rosdashboard/speed")
    dialog.choose_robot_mode(labels[1])
    dialog.add_series()
    dialog.choose_topic("/robot2/rosdashboard/speed")
    dialog.choose_robot_mode(labels[2])
    assert dialog.apply()
    assert item.bindings == (
        Binding("/rosdashboard/speed", robot="$selected"),
        Binding("/rosdashboard/speed", robot="$every"),
    )
    assert [b.topic for b in item.series] == [  # the root's tags are a robot too: (no namespace)
        "/robot2/rosdashboard/speed",
        "/rosdashboard/speed",
        "/robot1/rosdashboard/speed",
    ]
    again = app.dialogs.topic(item)
    assert isinstance(again, TopicDialog)
    assert dpg.get_value(again.topic_input) == "/robot2/rosdashboard/speed"
    assert dpg.get_value(again.robot_combo) == labels[1]
    again.remove_series()
    again.choose_robot_mode(labels[0])
    assert again.apply()
    assert list(item.bindings) == [Binding("/robot2/rosdashboard/speed")], "as typed: robot2's"


def test_regex_preview_function() -> None:
    """The preview says what a regex extracts, that it does not match, or why RE2 rejects it."""
    assert regex_preview("", "x") == (True, "no regex: the whole value is used")
    assert regex_preview("v=(\\d+)", "v=42") == (True, "extracts: '42'")
    assert regex_preview("v=(\\d+)", "nothing") == (False, "no match in the latest value")
    ok, text = regex_preview("(a)\\1", "aa")
    assert not ok
    assert "backreferences are not supported" in text


def scenario_move_with_snap_outline_and_landing(app: ViewerApp, source: StaticSource, tmp_path: Path) -> None:
    """Dragging the title strip moves the widget, an outline shows the snapped spot, release lands there."""
    item = app.add_widget("dial", 100, 100)
    assert item is not None
    frames(app)
    start = item.rect
    app.pointer_input.press(title_point(item, app))
    x0, y0 = title_point(item, app)
    app.pointer_input.drag_to((x0 + 133, y0 + 47))
    frames(app)
    assert item.rect == Rect(start.x + 133, start.y + 47, start.w, start.h), "the widget follows the pointer"
    outline = dpg.get_item_children(app.canvas.overlay, 2)
    assert len(outline) == 1, "one outline rectangle shows where it will land"
    ox, oy = app.canvas.origin()
    pmin = dpg.get_item_configuration(outline[0])["pmin"]
    assert (pmin[0] - ox, pmin[1] - oy) == (start.x + 140, start.y + 40)
    app.pointer_input.release((x0 + 133, y0 + 47))
    frames(app)
    assert item.rect == Rect(start.x + 140, start.y + 40, start.w, start.h)
    assert dpg.get_item_children(app.canvas.overlay, 2) == []
    assert app.doc.dashboard().to_dict()["widgets"][0]["x"] == start.x + 140


def scenario_move_without_snap_keeps_exact_position(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """With snap off the widget lands exactly where it was dropped."""
    app.set_snap(False)
    item = app.add_widget("led", 33, 47)
    assert item is not None
    frames(app)
    start = item.rect
    x0, y0 = title_point(item, app)
    app.pointer_input.press((x0, y0))
    app.pointer_input.release((x0 + 7, y0 + 3))
    assert item.rect == Rect(start.x + 7, start.y + 3, start.w, start.h)


def scenario_resize_from_corner_snaps_and_respects_minimum(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Dragging the bottom-right grip resizes (snapped), never below the widget's minimum size."""
    item = app.add_widget("thermo", 100, 100)
    assert item is not None
    frames(app)
    r = item.rect
    corner = app.canvas.to_window((r.x + r.w - 4, r.y + r.h - 4))
    app.pointer_input.press(corner)
    app.pointer_input.release((corner[0] + 61, corner[1] + 29))
    frames(app)
    assert item.rect == Rect(r.x, r.y, r.w + 60, r.h + 20)
    assert item.widget is not None
    assert item.widget.width == int(r.w + 60) - 12
    app.pointer_input.press(
        app.canvas.to_window((item.rect.x + item.rect.w - 4, item.rect.y + item.rect.h - 4))
    )
    app.pointer_input.release(app.canvas.to_window((item.rect.x + 5, item.rect.y + 5)))
    assert item.rect.w >= 100
    assert item.rect.h >= 140 + TITLE_H


def scenario_delete_by_drop_zone_key_and_menu(app: ViewerApp, source: StaticSource, tmp_path: Path) -> None:
    """A widget is deleted by dropping it on the delete zone, by the Delete key, and from its context menu."""
    a = app.add_widget("dial", 0, 0)
    b = app.add_widget("knob", 300, 0)
    c = app.add_widget("compass", 600, 0)
    assert a is not None
    assert b is not None
    assert c is not None
    app.apply_bindings(a, (Binding("/rosdashboard/speed", "data"),))
    frames(app)
    app.pointer_input.press(title_point(a, app))
    trash = app.canvas.trash_rect()
    target = (trash.x + trash.w / 2, trash.y + trash.h / 2)
    app.pointer_input.drag_to(target)
    assert dpg.get_item_children(app.canvas.overlay, 2) == [], "no landing outline over the delete zone"
    app.pointer_input.release(target)
    assert a not in app.items
    assert not dpg.does_item_exist(a.window)
    assert Binding("/rosdashboard/speed", "data") not in source.bound, "its series is released"
    app.pointer_input.press(title_point(b, app))
    app.pointer_input.release(title_point(b, app))
    app.actions.run("widget.delete")
    assert b not in app.items
    r = c.rect
    assert app.pointer_input.context_menu(app.canvas.to_window((r.x + 50, r.y + 80))) is c
    frames(app)
    assert dpg.is_item_shown(app.pointer_input.menu)
    labels = [dpg.get_item_label(m) for m in dpg.get_item_children(app.pointer_input.menu, 1) or []]
    assert labels[:4] == ["Topic setup\u2026", "Properties\u2026", "Rename\u2026", "Bring to front"]
    delete = next(
        m for m in dpg.get_item_children(app.pointer_input.menu, 1) or [] if dpg.get_item_label(m) == "Delete"
    )
    dpg.get_item_callback(delete)(delete, None, None)
    app.frame()  # a menu entry's command runs on the UI thread, at the next frame
    assert app.items == []


def scenario_delete_key_ignored_while_dialog_open(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """The Delete key never deletes a widget while a dialog (e.g. a text field) has the keyboard."""
    item = drop(app, "dial", (50, 50))
    assert app.dialog is not None
    app.actions.run("widget.delete")
    assert item in app.items


def scenario_context_menu_reopens_dialogs_and_rename(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """The context menu opens topic setup, properties and rename; renaming changes the title."""
    item = app.add_widget("dial", 40, 40)
    assert item is not None
    frames(app)
    app.pointer_input.context_menu(app.canvas.to_window((item.rect.x + 60, item.rect.y + 80)))
    entries = {dpg.get_item_label(m): m for m in dpg.get_item_children(app.pointer_input.menu, 1) or []}
    dpg.get_item_callback(entries["Topic setup\u2026"])(0, None, None)
    app.frame()
    assert isinstance(app.dialog, TopicDialog)
    app.dialog.close()
    frames(app)  # (a hand takes frames to right click again: Dear ImGui forgets the closed modal meanwhile)
    app.pointer_input.context_menu(app.canvas.to_window((item.rect.x + 60, item.rect.y + 80)))
    dpg.get_item_callback(entries["Rename\u2026"])(0, None, None)
    app.frame()
    dialog = app.dialog
    assert isinstance(dialog, RenameDialog)
    assert not dialog.apply("   ")
    assert dialog.apply("Wheel speed")
    assert item.name == "Wheel speed"
    assert item.config.name == "Wheel speed"


def scenario_properties_dialog_validates_and_applies(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Properties come from the widget's declarations; an invalid value is refused with a message."""
    item = app.add_widget("dial", 40, 40)
    assert item is not None
    app.apply_bindings(item, (Binding("/rosdashboard/speed", "data"),))
    dialog = app.dialogs.properties(item)
    assert isinstance(dialog, PropertiesDialog)
    assert set(dialog.editors) == {"minimum", "maximum", "unit", "decimals", "color"}
    dialog.set_value("decimals", 42.0)
    assert not dialog.apply()
    assert "above the maximum 9" in dpg.get_value(dialog.errors["decimals"])
    assert props(item)["decimals"] == 1.0
    dialog.set_value("decimals", 3.0)
    dialog.set_value("maximum", 8.0)
    dialog.set_value("unit", "m/s")
    dialog.set_value("color", "#10e020ff")
    assert dialog.apply()
    assert props(item)["decimals"] == 3.0
    assert props(item)["maximum"] == 8.0
    assert props(item)["unit"] == "m/s"
    assert props(item)["color"] == "#10e020ff"
    source.push("/rosdashboard/speed", "data", 4.25)
    frames(app)
    assert item.widget is not None
    readout = dpg.get_item_configuration(item.widget._readout)["text"]  # type: ignore[attr-defined]
    assert readout == "4.250 m/s"


def scenario_widget_stale_time_overrides_the_viewers(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """A widget's own stale time (Properties) judges its series live or stale, is validated and saved."""
    topic = "/rosdashboard/hits"
    source.push(topic, "data", 3.0)
    source.set_status(topic, "data", Status.STALE, "no message for 5.0 s", age_s=5.0)
    events = app.add_widget("dial", 40, 40)
    plain = app.add_widget("dial", 300, 40)
    assert events is not None
    assert plain is not None
    for item in (events, plain):
        app.apply_bindings(item, (Binding(topic, "data"),))
    frames(app)
    assert [events.status, plain.status] == [Status.STALE, Status.STALE]
    dialog = app.dialogs.properties(events)
    assert isinstance(dialog, PropertiesDialog)
    for typed, expected in (("-3", "more than 0"), ("soon", "number of seconds, got 'soon'")):
        dpg.set_value(dialog.stale_input, typed)
        assert not dialog.apply()
        assert expected in dpg.get_value(dialog.stale_error)
    dpg.set_value(dialog.stale_input, "30")
    assert dialog.apply()
    frames(app)
    # An event topic: 5 s of quiet is normal for it.
    assert [events.status, plain.status] == [Status.LIVE, Status.STALE]
    assert app.doc.dirty
    # A shorter time of its own makes a widget call a series stale that the viewer still calls live.
    source.set_status(topic, "data", Status.LIVE, age_s=5.0)
    dialog = app.dialogs.properties(plain)
    assert isinstance(dialog, PropertiesDialog)
    dpg.set_value(dialog.stale_input, "1.5")
    assert dialog.apply()
    frames(app)
    assert (events.status, plain.status) == (Status.LIVE, Status.STALE)
    assert plain.reason.endswith("no message for 5.0 s")
    path = tmp_path / "stale.json"
    assert app.files.save(path)
    saved = [w.get("stale_after") for w in json.loads(path.read_text())["widgets"]]
    assert saved == [30.0, 1.5]
    dialog = app.dialogs.properties(events)
    assert isinstance(dialog, PropertiesDialog)
    assert dpg.get_value(dialog.stale_input) == "30"
    dpg.set_value(dialog.stale_input, "")  # blank: back to the viewer's stale time
    assert dialog.apply()
    assert isinstance(events.config, WidgetConfig)
    assert events.config.stale_after is None


def scenario_save_and_reopen_round_trip(app: ViewerApp, source: StaticSource, tmp_path: Path) -> None:
    """A dashboard built in the UI saves atomically and reopens with the same widgets."""
    for i, kind in enumerate(["plot", "dial", "knob", "compass", "thermo", "string", "led"]):
        item = app.add_widget(kind, 20 + 160 * (i % 4), 20 + 300 * (i // 4))
        assert item is not None
        app.apply_bindings(item, (Binding(f"/rosdashboard/{kind}", "data"),))
    app.doc.rename(app.items[0], "Speeds")
    path = tmp_path / "dash.json"
    assert app.files.save(path)
    assert not app.doc.dirty
    saved = app.doc.dashboard()
    app.files.new()
    assert app.items == []
    assert app.files.open_path(path)
    frames(app)
    assert app.doc.dashboard() == saved
    assert app.items[0].name == "Speeds"
    assert app.files.save()
    assert (tmp_path / "dash.json.bak").exists()


def scenario_failed_open_keeps_current_dashboard(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Opening a broken file shows the error naming the file and keeps the dashboard on screen."""
    item = app.add_widget("dial", 0, 0)
    bad = tmp_path / "broken.json"
    bad.write_text("{not json")
    assert not app.files.open_path(bad)
    assert app.items == [item]
    assert isinstance(app.dialog, MessageDialog)
    assert str(bad) in app.dialog.message
    assert "not valid JSON" in app.dialog.message


def scenario_legacy_open_never_modifies_file_and_unknown_kept(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """Viewing a legacy file leaves it as is; an unknown entry shows a placeholder, saves back as is."""
    path = tmp_path / "legacy.json"
    shutil.copyfile(GOLDEN / "legacy_unknown_type.json", path)
    before = path.read_bytes()
    assert app.files.open_path(path)
    frames(app, 5)
    assert path.read_bytes() == before
    placeholder, dial = app.items
    assert placeholder.widget is None
    assert placeholder.status is Status.ERROR
    assert dial.config.type == "dial"
    assert any("DragButton" in m for m in app.doc.load_messages)
    out = tmp_path / "new.json"
    assert app.files.save(out)
    data = json.loads(out.read_text())
    assert data["widgets"][0] == json.loads(before)["widgets"][0]


def scenario_only_changed_series_are_redrawn(app: ViewerApp, source: StaticSource, tmp_path: Path) -> None:
    """A widget whose snapshot count and status did not change is not redrawn."""
    item = app.add_widget("dial", 0, 0)
    assert item is not None
    app.apply_bindings(item, (Binding("/rosdashboard/speed", "data"),))
    source.push("/rosdashboard/speed", "data", 1.0)
    frames(app, 3)
    before = item.updates
    frames(app, 10)
    assert item.updates == before
    source.push("/rosdashboard/speed", "data", 2.0)
    frames(app, 2)
    assert item.updates == before + 1


def scenario_plot_draws_no_more_points_than_pixels(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """A plot over 200k samples sends at most two points per pixel column per series."""
    item = app.add_widget("plot", 0, 0)
    assert item is not None
    app.apply_bindings(item, (Binding("/rosdashboard/speed", "data"), Binding("/rosdashboard/gain", "data")))
    t = time.time() - 10 + np.linspace(0, 10, 200_000)
    source.set_series("/rosdashboard/speed", "data", t, np.sin(t))
    source.set_series("/rosdashboard/gain", "data", t, np.cos(t))
    frames(app, 3)
    widget = item.widget
    assert isinstance(widget, PlotWidget)
    assert 0 < widget.points_drawn <= 2 * (2 * widget.width)
    widget.set_paused(True)
    drawn = widget.points_drawn
    source.set_series("/rosdashboard/speed", "data", t[:10], np.sin(t[:10]))
    frames(app, 2)
    assert widget.points_drawn == drawn, "a paused plot keeps its picture"


class _Exploding(Widget):
    """A widget that raises while drawing."""

    type_name = "exploding"
    label = "Exploding"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build nothing."""
        dpg.add_text("boom soon", parent=parent)

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Raise."""
        raise RuntimeError("kaboom")


def scenario_failing_widget_is_disabled_others_keep_running(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """A widget that raises while drawing turns red with the reason; the other widgets keep updating."""
    assert app.registry.register(_Exploding, origin="test")
    bad = app.add_widget("exploding", 0, 0)
    good = app.add_widget("dial", 300, 0)
    assert bad is not None
    assert good is not None
    for item in (bad, good):
        app.apply_bindings(item, (Binding("/rosdashboard/speed", "data"),))
    source.push("/rosdashboard/speed", "data", 3.0)
    frames(app, 3)
    assert bad.status is Status.ERROR
    assert "kaboom" in bad.failed
    assert "kaboom" in dpg.get_value(bad.tooltip_text)
    before = good.updates
    source.push("/rosdashboard/speed", "data", 4.0)
    frames(app, 3)
    assert good.updates == before + 1


def scenario_screenshot_shows_status_colours_and_widgets(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """The PNG shows live green, stale grey, error red and waiting orange pills, and a non-blank canvas."""
    spec = [
        ("dial", "speed", Status.LIVE),
        ("led", "estop", Status.LIVE),
        ("thermo", "temp", Status.STALE),
        ("compass", "heading", Status.ERROR),
        ("knob", "nothing", Status.WAITING),
    ]
    for i, (kind, topic, status) in enumerate(spec):
        item = app.add_widget(kind, 20 + 240 * (i % 3), 20 + 280 * (i // 3))
        assert item is not None
        app.apply_bindings(item, (Binding(f"/rosdashboard/{topic}", "data"),))
        if status is not Status.WAITING:
            source.push(f"/rosdashboard/{topic}", "data", 1.0 if kind != "compass" else 90.0)
        if status in (Status.STALE, Status.ERROR):
            source.set_status(f"/rosdashboard/{topic}", "data", status, "cannot convert 'abc'")
    frames(app, 3)
    assert [i.status for i in app.items] == [s for _, _, s in spec]
    path = app.screenshot(tmp_path / "shot.png")
    img = read_png(path)
    assert img.shape[:2] == (800, 1200)
    for status in Status:
        assert count_color(img, STATUS_COLORS[status]) > 20, f"{status.value} colour missing"
    assert count_color(img, (60, 220, 100)) > 1000, "the lit LED is green"
    canvas = img[60:700, 250:1150, :3]
    assert len(np.unique(canvas.reshape(-1, 3), axis=0)) > 200, "the canvas is not blank"


def drawn_items(item: int | str) -> list[int | str]:
    """Every drawing (line, rectangle, text...) under a drawlist or layer, its layers opened."""
    found: list[int | str] = []
    for child in dpg.get_item_children(item, 2) or []:
        kind = dpg.get_item_type(child)
        found += drawn_items(child) if kind.endswith("mvDrawLayer") else [child]
    return found


def scenario_a_flood_of_log_marks_costs_the_timeline_a_few_items(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """400 adjacent pixel columns of warnings and errors (a /rosout flood) are drawn as a few rectangles, and
    a move of the cursor alone redraws the track without drawing the marks again."""
    flood = np.arange(300, 700, dtype=np.intp)
    levels = np.where((flood // 100) % 2 == 1, 40, 30).astype(np.uint8)  # 4 blocks of 100 columns
    timeline = Timeline(StaticSource())

    def marks(scale: TimeScale) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.uint8]]:
        return flood, levels

    with dpg.window(pos=(0, 0), width=1000, height=60):
        bar = TimeBar(timeline, lambda: (1000.0, 1060.0), timeline.seek, lambda: None, marks=marks)
    bar.fit(1000)
    bar.draw()
    frames(app, 2)
    first = drawn_items(bar.track)
    assert len(first) < 60, f"{len(first)} items for 4 runs of marks and the rail"
    timeline.pause(1030.0)
    bar.draw()
    frames(app, 2)
    again = drawn_items(bar.track)
    kept = set(first) & set(again)
    assert len(kept) == 4, "the 4 runs are kept as drawn, the rest of the track redrawn"
    assert {dpg.get_item_type(i) for i in kept} == {"mvAppItemType::mvDrawRect"}


class _OneChange:
    """The timeline's events: one parameter change at `t` (what `TimelineEvents` asks)."""

    def __init__(self, t: float) -> None:
        self.t = t

    def event_times(self) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.bool_]]:
        return np.array([self.t]), np.array([False])

    def events(self, t0: float, t1: float) -> list[EventMark]:
        return [EventMark(self.t, "changed", "ui_pid.kp 1 \u2192 2")] if t0 <= self.t <= t1 else []


def scenario_the_newest_event_shows_over_the_live_knob(
    app: ViewerApp, source: StaticSource, tmp_path: Path
) -> None:
    """A parameter change that is the newest thing held sits where the LIVE knob is: its diamond is drawn
    over the knob, not hidden under it."""
    timeline = Timeline(StaticSource())
    with dpg.window(pos=(0, 700), width=1000, height=60, no_title_bar=True):
        change = _OneChange(1060.0)
        bar = TimeBar(timeline, lambda: (1000.0, 1060.0), timeline.seek, lambda: None, events=change)
    for _ in range(3):
        bar.fit(1000)
        bar.draw()
        frames(app, 1)
    assert bar.scale is not None
    [(x, _marker)] = bar.event_marks
    assert x == round(bar.scale.x_of(1060.0)), "the change is at the knob's pixel"
    track = bar.track_rect()
    img = read_png(app.screenshot(tmp_path / "knob.png"))
    cx, cy = round(track.x + x), round(track.y + RAIL_Y)
    around = img[cy - 5 : cy + 6, cx - 5 : cx + 6]
    assert count_color(around, CHANGE_COLOR, tol=30) >= 6, "the change's diamond is under the knob"


SCENARIOS = sorted(n.removeprefix("scenario_") for n in dir() if n.startswith("scenario_"))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_ui_scenario(scenario: str, tmp_path: Path) -> None:
    """Each UI scenario (see its docstring) passes in a process of its own (one Dear PyGui context each)."""
    run_scenario("test_ui", scenario, tmp_path)


def test_cli_unreadable_file_exits_nonzero_naming_it(tmp_path: Path) -> None:
    """`dbglog view` on a broken file prints the file and the problem and exits non-zero."""
    bad = tmp_path / "bad.json"
    bad.write_text('{"format": "dbglog-dashboard", "version": 7, "widgets": []}')
    proc = run_dbglog("view", str(bad))
    assert proc.returncode == 2
    assert str(bad) in proc.stderr
    assert "version 7 is newer" in proc.stderr
    proc = run_dbglog(
        "view", str(tmp_path / "nowhere" / "missing.json")
    )  # a new file needs an existing folder
    assert proc.returncode == 2
    assert f"folder {tmp_path / 'nowhere'} does not exist" in proc.stderr


def test_cli_screenshot_of_legacy_dashboard(tmp_path: Path) -> None:
    """`dbglog view FILE --screenshot` renders a legacy file to a PNG, exits 0, leaves the file alone."""
    path = tmp_path / "legacy.json"
    shutil.copyfile(GOLDEN / "legacy_all_widgets.json", path)
    before = path.read_bytes()
    out = tmp_path / "shot.png"
    proc = run_dbglog("view", str(path), "--screenshot", str(out), "--after", "0.5", "--size", "1280x800")
    assert proc.returncode == 0, proc.stderr
    assert path.read_bytes() == before
    img = read_png(out)
    assert img.shape[:2] == (800, 1280)
    assert count_color(img, STATUS_COLORS[Status.WAITING]) > 20, "unpublished topics show waiting"
    result = load_dashboard(path, WidgetRegistry.builtin().get)
    assert len([w for w in result.dashboard.widgets if isinstance(w, WidgetConfig)]) == 7


def test_cli_template_opens_an_untitled_copy(tmp_path: Path) -> None:
    """`--template` opens the file's widgets as a new, untitled dashboard; without a file it is refused."""
    path = tmp_path / "team.json"
    shutil.copyfile(GOLDEN / "legacy_all_widgets.json", path)
    before = path.read_bytes()
    report = tmp_path / "report.json"
    proc = run_dbglog(
        "view",
        str(path),
        "--template",
        "--screenshot",
        str(tmp_path / "shot.png"),
        "--after",
        "0.3",
        "--report-json",
        str(report),
    )
    assert proc.returncode == 0, proc.stderr
    data = json.loads(report.read_text())
    assert data["file"] is None
    assert data["modified"] is False
    assert len(data["widgets"]) == 7
    assert path.read_bytes() == before
    refused = run_dbglog("view", "--template")
    assert refused.returncode == 2
    assert "--template needs a dashboard file" in refused.stderr
