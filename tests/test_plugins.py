"""Widget plugins end to end: pip-installed entry points fill the toolbox; broken ones cannot hurt the viewer.

The example plugin (examples/laserscan_plugin) and the broken test plugins (tests/plugins) are installed with
``pip install --no-deps --target`` into temporary folders, never into the shared venv; each viewer runs in a
process of its own (one Dear PyGui context per process) with PYTHONPATH pointing at such a folder, so that
`importlib.metadata` finds the entry points exactly as it would after a normal ``pip install``.
"""

from __future__ import annotations

import json
import math
import os
import shutil
import subprocess
import sys
import time
import warnings
from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from dbglog.viewer._data._model import Binding, FieldInfo, SeriesSnapshot, Status, ValueKind
from dbglog.viewer._ui import StaticSource
from dbglog.viewer._widgets import BUILTIN_WIDGETS, WidgetRegistry
from dbglog.viewer._widgets._registry import declaration_problem
from dbglog.viewer.widget_api import Property, PropKind, Widget
from tests._children import run_scenario
from tests.test_ui import count_color, read_png

ROOT = Path(__file__).resolve().parent.parent
EXAMPLE = ROOT / "examples" / "laserscan_plugin"
BROKEN = Path(__file__).resolve().parent / "plugins"
POINT_RGB = (255, 60, 220)
"""Point colour set in the test dashboards: nothing else in the viewer is this magenta."""
BROKEN_NAMES = ("broken_import", "not_a_widget", "wrong_name", "bad_default", "no_update", "missing_class")
RAISING_NAMES = ("raises_create", "raises_resize", "raises_update")


# -- installing the plugins -------------------------------------------------------------------------


def pip_install_target(target: Path, *projects: Path) -> Path:
    """`pip install --no-deps --target` copies of `projects` (built outside the source tree) into `target`."""
    work = target.parent / f"{target.name}-src"
    copies = []
    for project in projects:
        copy = work / project.name
        shutil.copytree(project, copy, ignore=shutil.ignore_patterns("build", "*.egg-info", "__pycache__"))
        copies.append(str(copy))
    proc = subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "--quiet", "--target", str(target), *copies],
        capture_output=True,
        text=True,
        timeout=300,
        check=False,
    )
    assert proc.returncode == 0, f"pip install failed:\n{proc.stdout}\n{proc.stderr}"
    return target


@pytest.fixture(scope="module")
def laserscan_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with only the example laser-scan plugin installed."""
    return pip_install_target(tmp_path_factory.mktemp("plugins") / "laserscan", EXAMPLE)


@pytest.fixture(scope="module")
def broken_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with only the broken test plugins installed."""
    return pip_install_target(tmp_path_factory.mktemp("plugins") / "broken", BROKEN)


@pytest.fixture(scope="module")
def all_plugins(laserscan_dir: Path, broken_dir: Path) -> list[Path]:
    """Both folders: the laser-scan plugin and the broken test plugins."""
    return [laserscan_dir, broken_dir]


def env_with(plugins: Sequence[Path]) -> dict[str, str]:
    """The environment of a child process that sees the plugins installed in the `plugins` folders."""
    env = dict(os.environ)
    parts = [str(p) for p in plugins]
    if env.get("PYTHONPATH"):
        parts.append(env["PYTHONPATH"])
    env["PYTHONPATH"] = os.pathsep.join(parts)
    env.pop("PYTHONSAFEPATH", None)
    return env


def discover_in_child(plugins: Sequence[Path]) -> dict[str, Any]:
    """Run `WidgetRegistry.discover()` in a fresh interpreter seeing `plugins`; return what it found."""
    code = (
        "import json; from dbglog.viewer._widgets import WidgetRegistry; r = WidgetRegistry.discover(); "
        "print(json.dumps({'names': r.names(), 'origins': r.origins, 'problems': r.problems, "
        "'failed': r.failed}))"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
        env=env_with(plugins),
    )
    assert proc.returncode == 0, proc.stderr
    result: dict[str, Any] = json.loads(proc.stdout)
    return result


# -- the registry, without a display ----------------------------------------------------------------


class _Fine(Widget):
    """A minimal valid widget."""

    type_name = "fine"
    label = "Fine"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build nothing."""

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Draw nothing."""


def test_declaration_checks_name_each_problem() -> None:
    """Each bad declaration is refused with a reason naming what is wrong; a valid one passes."""
    assert declaration_problem(_Fine) == ""
    cases: dict[str, dict[str, object]] = {
        "missing a 'label'": {"label": ""},
        "'accepts' must be": {"accepts": frozenset({"number"})},
        "'properties' must be a tuple": {"properties": {"a": 1}},
        "is not a Property": {"properties": ("x",)},
        "is not [a-z_]": {"properties": (Property("Bad-Name", PropKind.TEXT, ""),)},
        "declared twice": {
            "properties": (Property("a", PropKind.TEXT, ""), Property("a", PropKind.TEXT, ""))
        },
        "a choice needs": {"properties": (Property("c", PropKind.CHOICE, "x"),)},
        "default of property 'n'": {"properties": (Property("n", PropKind.NUMBER, 5.0, maximum=1.0),)},
        "'max_bindings' must be within": {"max_bindings": 0},
        "'max_bindings' must be a whole": {"max_bindings": 2.5},
        "'default_size' must be": {"default_size": (100,)},
        "'min_size' must be": {"min_size": (0, 10)},
    }
    for expected, attrs in cases.items():
        bad = type("Bad", (_Fine,), attrs)
        assert expected in declaration_problem(bad), (expected, declaration_problem(bad))
    abstract = type("Half", (Widget,), {"type_name": "half", "label": "Half"})
    assert "does not implement create, update" in declaration_problem(abstract)


def test_register_refuses_bad_classes_and_duplicates() -> None:
    """register() records a problem instead of raising; the first class of a name wins."""
    registry = WidgetRegistry.builtin()
    assert not registry.register(object, name="obj", origin="pkg-a")
    assert not registry.register(type("Late", (_Fine,), {"type_name": "dial"}), name="dial", origin="pkg-b")
    assert not registry.register(_Fine, name="other", origin="pkg-c")
    assert not registry.register(type("Bad", (_Fine,), {"max_bindings": 99}), name="fine", origin="pkg-d")
    assert registry.register(_Fine, name="fine", origin="pkg-e")
    assert registry.names() == [*BUILTIN_WIDGETS, "fine"]
    assert registry.origins["fine"] == "pkg-e"
    problems = "\n".join(registry.problems)
    assert "'obj' from pkg-a" in problems
    assert "already provided by builtin" in problems
    assert "entry point name differs from type_name 'fine'" in problems
    assert "'max_bindings' must be within 1..16" in problems
    assert registry.missing_reason("fine") == ""
    assert "no installed package provides the widget type 'nothing'" in registry.missing_reason("nothing")
    assert "entry point 'nothing' in the group 'dbglog.widgets'" in registry.missing_reason("nothing")


def test_pip_installed_plugin_is_discovered_beside_builtins(laserscan_dir: Path) -> None:
    """After pip install, discover() lists the built-ins in order, then the plugin, from its package."""
    found = discover_in_child([laserscan_dir])
    assert found["names"] == [*BUILTIN_WIDGETS, "laserscan"]
    assert found["origins"]["laserscan"] == "dbglog-laserscan"
    assert found["origins"]["plot"] == "builtin"
    assert found["problems"] == []
    assert discover_in_child([])["names"] == list(BUILTIN_WIDGETS), "nothing leaks into the shared venv"


def test_broken_plugins_are_reported_and_left_out(all_plugins: list[Path]) -> None:
    """Plugins that fail to import or declare badly are reported with the reason and not listed."""
    found = discover_in_child(all_plugins)
    assert found["names"] == [*BUILTIN_WIDGETS, "laserscan", *RAISING_NAMES]
    problems = "\n".join(found["problems"])
    for name in BROKEN_NAMES:
        assert f"'{name}' from dbglog-test-plugins" in problems, name
        assert name in found["failed"]
    assert "ModuleNotFoundError" in found["failed"]["broken_import"]
    assert "is not a dbglog Widget class" in problems
    assert "entry point name differs from type_name 'something_else'" in problems
    assert "default of property 'level'" in problems
    assert "does not implement update" in problems
    assert "NoSuchClass" in found["failed"]["missing_class"]


# -- the viewer, one process per scenario -----------------------------------------------------------


class ScanSource(StaticSource):
    """A StaticSource that also serves array series, such as a LaserScan's ranges (test data only)."""

    def __init__(self) -> None:
        super().__init__()
        self.arrays: dict[tuple[str, str], SeriesSnapshot] = {}

    def push_array(self, topic: str, field: str, values: Sequence[float]) -> None:
        """Make (topic, field) a live array series whose latest value is `values`."""
        old = self.arrays.get((topic, field))
        self.arrays[(topic, field)] = SeriesSnapshot(
            Binding(topic, field),
            Status.LIVE,
            kind=ValueKind.ARRAY,
            msg_type="sensor_msgs/msg/LaserScan",
            last=tuple(float(v) for v in values),
            last_time=time.time(),
            count=(old.count if old else 0) + 1,
            age_s=0.0,
        )

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Serve an array series when one was pushed for (topic, field), else what StaticSource has."""
        snap = self.arrays.get((binding.topic, binding.field))
        return replace(snap, binding=binding) if snap is not None else super().snapshot(binding)


def front_wall(n: int = 360, distance: float = 3.0) -> list[float]:
    """Ranges of a full-circle scan from -180 degrees that sees a round wall only in front (+-90 degrees)."""
    angles = -math.pi + np.arange(n) * (2 * math.pi / n)
    return [distance if abs(a) <= math.pi / 2 else math.inf for a in angles]


def run_here(name: str, tmp: str) -> None:
    """Child-process entry: run scenario `name` against a fresh viewer with the discovered widgets."""
    warnings.simplefilter("error")
    from dbglog.viewer._ui import ViewerApp

    source = ScanSource()
    source.add_topic("/scan", "sensor_msgs/msg/LaserScan", [FieldInfo("ranges[]", "sequence<float>", True)])
    source.add_topic("/speed", "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    app = ViewerApp(source, WidgetRegistry.discover(), width=1280, height=860)
    app.start()
    try:
        globals()[f"scenario_{name}"](app, source, Path(tmp))
    finally:
        app.close()


def frames(app: Any, n: int = 3) -> None:
    """Render a few frames."""
    for _ in range(n):
        app.frame()


def scenario_plugin_in_toolbox_drop_bind_and_draw(app: Any, source: ScanSource, tmp: Path) -> None:
    """The plugin's button follows the built-ins; a drop opens topic setup; bound to ranges it draws live."""
    import dearpygui.dearpygui as dpg
    from dbglog_laserscan import LaserScanWidget

    from dbglog.viewer._ui._dialogs import TopicDialog

    assert list(app.canvas.tools.buttons) == [*BUILTIN_WIDGETS, "laserscan"]
    assert dpg.get_item_label(app.canvas.tools.buttons["laserscan"]) == "Laser scan"
    payloads = [
        c
        for c in dpg.get_item_children(app.canvas.tools.buttons["laserscan"], 3) or []
        if dpg.get_item_type(c).endswith("DragPayload")
    ]
    assert len(payloads) == 1
    assert dpg.get_item_configuration(payloads[0])["drag_data"] == "laserscan"
    app.canvas.pointer_override = app.canvas.to_window((120, 100))
    dpg.get_item_drop_callback(app.canvas.window)(app.canvas.window, "laserscan", None)
    item = app.items[-1]
    assert item.widget_cls is LaserScanWidget
    dialog = app.dialog
    assert isinstance(dialog, TopicDialog)
    dialog.choose_topic("/scan")
    assert any("ranges[]" in label for label in dpg.get_item_configuration(dialog.field_combo)["items"])
    dialog.choose_field("ranges[]")
    assert dialog.apply()
    assert item.bindings == (Binding("/scan", "ranges[]"),)
    frames(app)
    assert item.status.value == "waiting"
    source.push_array("/scan", "ranges[]", front_wall())
    frames(app)
    widget = item.widget
    assert isinstance(widget, LaserScanWidget)
    assert item.status is Status.LIVE
    assert not item.failed
    assert widget.points_drawn == 181, "the readings within +-90 degrees"
    assert widget.closest is not None
    assert widget.closest[0] == 3.0
    assert widget.display_range == 10.0
    shot = read_png(app.screenshot(tmp / "drawn.png"))
    assert count_color(shot, (86, 214, 140), tol=4) > 150, "the default green points are on screen"


def scenario_plugin_properties_save_reopen_resize(app: Any, source: ScanSource, tmp: Path) -> None:
    """The generated properties dialog validates and applies; save, reopen and resize keep it working."""
    from dbglog.viewer._document._dashboard import WidgetConfig
    from dbglog.viewer._ui._dialogs import PropertiesDialog
    from dbglog.viewer._widgets._geometry import Rect

    item = app.add_widget("laserscan", 20, 20)
    app.apply_bindings(item, (Binding("/scan", "ranges[]"),))
    source.push_array("/scan", "ranges[]", front_wall(distance=2.0))
    frames(app)
    dialog = app.dialogs.properties(item)
    assert isinstance(dialog, PropertiesDialog)
    assert set(dialog.editors) == {p.name for p in item.widget_cls.properties}
    dialog.set_value("max_range", -1.0)
    assert not dialog.apply(), "a negative range is refused"
    dialog.set_value("max_range", 4.0)
    dialog.set_value("style", "points")
    dialog.set_value("color", "#ff3cdcff")
    assert dialog.apply()
    frames(app)
    widget = item.widget
    assert widget.display_range == 4.0
    assert widget.points_drawn == 181
    assert isinstance(item.config, WidgetConfig)
    assert item.config.properties["color"] == "#ff3cdcff"
    item.place(Rect(item.rect.x, item.rect.y, 420, 420), rebuild=True)
    frames(app)
    assert item.widget.points_drawn == 181, "redrawn at the new size"
    path = tmp / "scan.json"
    assert app.files.save(path)
    saved = json.loads(path.read_text())["widgets"][0]
    assert saved["type"] == "laserscan"
    assert saved["properties"]["max_range"] == 4.0
    assert saved["bindings"] == [{"topic": "/scan", "field": "ranges[]", "regex": ""}]
    app.files.new()
    assert app.files.open_path(path)
    assert app.doc.load_messages == []
    reopened = app.items[0]
    assert reopened.config == item.config
    frames(app)
    assert reopened.status is Status.LIVE
    shot = read_png(app.screenshot(tmp / "props.png"))
    assert count_color(shot, POINT_RGB, tol=4) > 150, "the chosen point colour is on screen"


def scenario_broken_plugins_reported_others_usable(app: Any, source: ScanSource, tmp: Path) -> None:
    """The toolbox lists usable plugins only and shows each broken one's problem; a dashboard naming one
    keeps its entry as a placeholder that says the plugin is installed but failed."""
    import dearpygui.dearpygui as dpg

    assert list(app.canvas.tools.buttons) == [*BUILTIN_WIDGETS, "laserscan", *RAISING_NAMES]
    texts = [str(dpg.get_value(c)) for c in dpg.get_item_children(app.canvas.tools.window, 1) or []]
    assert "Plugin problems" in texts
    for name in BROKEN_NAMES:
        assert any(f"'{name}'" in t for t in texts), name
    entry = {"type": "broken_import", "name": "Broken", "x": 20, "y": 20, "width": 200, "height": 120}
    path = tmp / "broken.json"
    path.write_text(json.dumps({"format": "dbglog-dashboard", "version": 1, "widgets": [entry]}))
    assert app.files.open_path(path)
    frames(app)
    (item,) = app.items
    assert item.widget_cls is None
    assert "installed but unusable" in item.reason
    assert "ModuleNotFoundError" in item.reason
    body = [str(dpg.get_value(c)) for c in dpg.get_item_children(item.body, 1) or []]
    assert "'broken_import' is not available" in body


def scenario_raising_plugins_disabled_others_keep_running(app: Any, source: ScanSource, tmp: Path) -> None:
    """Plugins raising in create, update or resize are disabled with the reason; the rest keep updating."""
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._ui._theme import STATUS_COLORS
    from dbglog.viewer._widgets._geometry import Rect

    dial = app.add_widget("dial", 0, 0)
    scan = app.add_widget("laserscan", 260, 0)
    in_update = app.add_widget("raises_update", 600, 0)
    in_create = app.add_widget("raises_create", 0, 300)
    in_resize = app.add_widget("raises_resize", 260, 300)
    for item in (dial, in_update, in_resize):
        app.apply_bindings(item, (Binding("/speed", "data"),))
    app.apply_bindings(scan, (Binding("/scan", "ranges[]"),))
    assert "plugin bug in create" in in_create.failed
    assert in_create.status is Status.ERROR
    source.push("/speed", "data", 1.0)
    source.push_array("/scan", "ranges[]", front_wall())
    frames(app)
    assert not in_update.failed, "the first update works"
    source.push("/speed", "data", 2.0)
    frames(app)
    assert "ZeroDivisionError('plugin bug in update')" in in_update.failed
    in_resize.place(Rect(in_resize.rect.x, in_resize.rect.y, 300, 260), rebuild=True)
    assert "plugin bug in resize" in in_resize.failed
    for item in (in_update, in_create, in_resize):
        assert item.status is Status.ERROR
        body = [str(dpg.get_value(c)) for c in dpg.get_item_children(item.body, 1) or []]
        assert body[0] == "Widget disabled"
        assert item.failed in body[1]
        assert item.failed in dpg.get_value(item.tooltip_text)
    before = (dial.updates, scan.updates, in_update.updates)
    for value in (3.0, 4.0, 5.0):
        source.push("/speed", "data", value)
        source.push_array("/scan", "ranges[]", front_wall(distance=value))
        frames(app, 2)
    assert dial.updates == before[0] + 3
    assert scan.updates == before[1] + 3
    assert in_update.updates == before[2], "a disabled widget is not called again"
    assert scan.widget.closest[0] == 5.0
    assert dial.status is Status.LIVE
    assert scan.status is Status.LIVE
    path = tmp / "faulty.json"
    assert app.files.save(path)
    saved = [w["type"] for w in json.loads(path.read_text())["widgets"]]
    assert saved == ["dial", "laserscan", "raises_update", "raises_create", "raises_resize"]
    shot = read_png(app.screenshot(tmp / "faulty.png"))
    assert count_color(shot, STATUS_COLORS[Status.ERROR]) > 60, "three red error pills"
    assert count_color(shot, STATUS_COLORS[Status.LIVE]) > 20, "live pills beside them"


def scenario_missing_plugin_placeholder_saved_back_unchanged(app: Any, source: ScanSource, tmp: Path) -> None:
    """Without the plugin, its entry is a placeholder naming what is missing and is saved back as it was."""
    import dearpygui.dearpygui as dpg

    from dbglog.viewer._document._dashboard import RawWidget

    assert "laserscan" not in app.canvas.tools.buttons
    entry = {
        "type": "laserscan",
        "name": "Front lidar",
        "x": 300,
        "y": 40,
        "width": 300,
        "height": 320,
        "bindings": [{"topic": "/scan", "field": "ranges[]", "regex": ""}],
        "properties": {"max_range": 8.0, "style": "points", "color": "#ff3cdcff"},
        "plugin_extra": {"kept": [1, 2.5, "three", None, True]},
    }
    dial = {
        "type": "dial",
        "name": "Speed",
        "x": 20,
        "y": 40,
        "width": 220,
        "height": 248,
        "bindings": [{"topic": "/speed", "field": "data", "regex": ""}],
        "properties": {"minimum": 0.0, "maximum": 10.0, "unit": "", "decimals": 1.0, "color": "#f66648ff"},
    }
    original = {
        "format": "dbglog-dashboard",
        "version": 1,
        "grid": {"size": 20, "snap": True},
        "widgets": [dial, entry],
    }
    path = tmp / "needs_plugin.json"
    path.write_text(json.dumps(original, indent=2))
    assert app.files.open_path(path)
    frames(app)
    placeholder = app.items[1]
    assert isinstance(placeholder.config, RawWidget)
    assert placeholder.widget_cls is None
    body = [str(dpg.get_value(c)) for c in dpg.get_item_children(placeholder.body, 1) or []]
    assert body[0] == "'laserscan' is not available"
    assert "no installed package provides the widget type 'laserscan'" in body[1]
    assert "entry point 'laserscan' in the group 'dbglog.widgets'" in body[1]
    assert placeholder.status is Status.ERROR
    assert str(dpg.get_value(placeholder.tooltip_text)).startswith("Error"), "a red pill, not waiting"
    assert any("unknown widget type 'laserscan'" in m for m in app.doc.load_messages)
    source.push("/speed", "data", 4.0)
    frames(app)
    assert app.items[0].status is Status.LIVE, "the other widgets work"
    app.doc.rename(app.items[0], "Speed (m/s)")
    out = tmp / "saved.json"
    assert app.files.save(out)
    saved = json.loads(out.read_text())
    assert saved["widgets"][1] == entry, "the plugin's entry comes back exactly as it was"
    assert saved["widgets"][0]["name"] == "Speed (m/s)"
    assert json.loads(path.read_text()) == original, "opening never wrote the file"


SCENARIOS = {
    "plugin_in_toolbox_drop_bind_and_draw": "clean",
    "plugin_properties_save_reopen_resize": "clean",
    "broken_plugins_reported_others_usable": "all",
    "raising_plugins_disabled_others_keep_running": "all",
    "missing_plugin_placeholder_saved_back_unchanged": "none",
}


@pytest.fixture
def plugin_dirs(request: pytest.FixtureRequest) -> dict[str, list[Path]]:
    """Map of 'clean' / 'all' / 'none' to the PYTHONPATH folders of that plugin set."""
    return {
        "clean": [request.getfixturevalue("laserscan_dir")],
        "all": request.getfixturevalue("all_plugins"),
        "none": [],
    }


@pytest.mark.gui
@pytest.mark.parametrize("scenario", sorted(SCENARIOS))
def test_plugin_scenario(scenario: str, plugin_dirs: dict[str, list[Path]], tmp_path: Path) -> None:
    """Each plugin scenario (see its docstring) passes in a viewer process of its own."""
    env = env_with(plugin_dirs[SCENARIOS[scenario]])
    run_scenario("test_plugins", scenario, tmp_path, timeout=100, env=env)


# -- end to end: pip-installed plugin, real ROS 2 publisher, `dbglog view` ---------------------------


def laserscan_dashboard(topic: str) -> dict[str, Any]:
    """A dashboard with one laser-scan widget taking ranges and angles from the message fields.

    Its angle properties (0..10 degrees) are deliberately wrong: the picture is right only if the bound
    angle_min / angle_increment fields win, as documented.
    """
    return {
        "format": "dbglog-dashboard",
        "version": 1,
        "grid": {"size": 20, "snap": True},
        "widgets": [
            {
                "type": "laserscan",
                "name": "Front lidar",
                "x": 20,
                "y": 20,
                "width": 360,
                "height": 380,
                "bindings": [
                    {"topic": topic, "field": "ranges[]", "regex": ""},
                    {"topic": topic, "field": "angle_min", "regex": ""},
                    {"topic": topic, "field": "angle_increment", "regex": ""},
                ],
                "properties": {
                    "max_range": 5.0,
                    "angle_min": 0.0,
                    "angle_max": 10.0,
                    "style": "points",
                    "point_size": 3.0,
                    "color": "#ff3cdcff",
                },
            }
        ],
    }


@pytest.mark.gui
def test_dbglog_view_shows_live_laserscan_from_real_publisher(laserscan_dir: Path, tmp_path: Path) -> None:
    """With the plugin pip-installed, `dbglog view` draws a real LaserScan live: report and pixels agree."""
    from sensor_msgs.msg import LaserScan

    from dbglog.viewer._ui._theme import STATUS_COLORS
    from tests._ros import RosPeer

    topic = "/plugin_e2e/scan"
    dashboard = tmp_path / "lidar.json"
    dashboard.write_text(json.dumps(laserscan_dashboard(topic), indent=2))
    before = dashboard.read_bytes()
    shot, report = tmp_path / "lidar.png", tmp_path / "report.json"
    msg = LaserScan()
    msg.header.frame_id = "laser"
    msg.angle_min = -math.pi
    msg.angle_increment = 2 * math.pi / 360
    msg.angle_max = msg.angle_min + 359 * msg.angle_increment
    msg.range_min, msg.range_max = 0.05, 30.0
    msg.ranges = front_wall(360, 3.0)
    args = ["view", str(dashboard), "--screenshot", str(shot), "--after", "1", "--wait-live", "30"]
    args += ["--report-json", str(report), "--size", "1100x720"]
    with RosPeer("plugin_e2e_lidar") as peer:
        pub = peer.publisher(topic, LaserScan)
        proc = subprocess.Popen(
            [sys.executable, "-m", "dbglog", *args],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            env=env_with([laserscan_dir]),
        )
        deadline = time.monotonic() + 90
        while proc.poll() is None and time.monotonic() < deadline:
            pub.publish(msg)
            time.sleep(0.1)
        if proc.poll() is None:
            proc.kill()
        out, err = proc.communicate(timeout=20)
    assert proc.returncode == 0, f"{out}\n{err}"
    assert dashboard.read_bytes() == before, "viewing never writes the dashboard"
    (widget,) = json.loads(report.read_text())["widgets"]
    assert (widget["type"], widget["status"]) == ("laserscan", "live"), widget
    img = read_png(shot)
    assert count_color(img, STATUS_COLORS[Status.LIVE]) > 20, "the green live pill"
    ys, xs = np.nonzero(np.all(np.abs(img[:, :, :3].astype(int) - POINT_RGB) <= 4, axis=2))
    assert len(xs) > 300, "the scan's points are drawn"
    width, height = xs.max() - xs.min(), ys.max() - ys.min()
    assert width > 150, "the points span the wall, not the 10 degree sector of the (overridden) properties"
    assert 1.6 < width / max(height, 1) < 2.5, "a half circle: readings over +-90 degrees at one range"
    robot = np.all(np.abs(img[:, :, :3].astype(int) - (86, 166, 240)) <= 4, axis=2)
    band = robot[max(0, ys.min() - 40) : ys.max() + 40, xs.min() : xs.max()]
    robot_y = np.nonzero(band)[0].mean() + max(0, ys.min() - 40)
    assert robot_y > ys.min() + 0.75 * height, "the wall is in front of the robot marker, i.e. above it"
