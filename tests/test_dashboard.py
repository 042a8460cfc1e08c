"""Dashboard files: schema validation with clear messages, legacy ROSDashboard import, atomic saves."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding
from dbglog.viewer._document._dashboard import (
    FORMAT,
    ROBOT_VERSION,
    VERSION,
    WATCH_VERSION,
    Dashboard,
    DashboardError,
    RawWidget,
    WatchConfig,
    WidgetConfig,
    dumps,
    load_dashboard,
    parse_dashboard,
    save_dashboard,
)
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer.widget_api import PropKind

GOLDEN = Path(__file__).parent / "golden" / "dashboards"
REGISTRY = WidgetRegistry.builtin()
LOOKUP = REGISTRY.get


def _widgets(result_widgets: list[WidgetConfig | RawWidget]) -> list[WidgetConfig]:
    return [w for w in result_widgets if isinstance(w, WidgetConfig)]


def test_legacy_file_opens_with_ranges_and_bindings() -> None:
    """The original ROSDashboard format opens: types, place, size, subscription and numeric properties."""
    result = load_dashboard(GOLDEN / "legacy_two_gauges.json", LOOKUP)
    assert result.legacy
    assert result.messages == []
    dial, knob = _widgets(result.dashboard.widgets)
    assert (dial.type, dial.name, dial.x, dial.y) == ("dial", "Speed", 120.0, 100.0)
    assert dial.bindings == (Binding("/rosdashboard/speed", "data", ""),)
    assert (dial.properties["minimum"], dial.properties["maximum"]) == (-8.0, 8.0)
    assert knob.type == "knob"
    assert knob.bindings == (Binding("/rosdashboard/gain", "data", ""),), "regex '.*' means the whole value"
    assert (knob.properties["minimum"], knob.properties["maximum"]) == (-4.0, 4.0)


def test_legacy_small_size_grows_to_the_minimum() -> None:
    """A legacy 100x100 dial (ROSDashboard ignored sizes) grows quietly to the dial's minimum size."""
    result = load_dashboard(GOLDEN / "legacy_two_gauges.json", LOOKUP)
    dial = _widgets(result.dashboard.widgets)[0]
    cls = REGISTRY.get("dial")
    assert cls is not None
    assert (dial.width, dial.height) == (float(cls.min_size[0]), float(cls.min_size[1]))


def test_legacy_all_seven_types_open() -> None:
    """Every ROSDashboard widget type maps to a viewer widget."""
    result = load_dashboard(GOLDEN / "legacy_all_widgets.json", LOOKUP)
    types = [w.type for w in _widgets(result.dashboard.widgets)]
    assert types == ["dial", "knob", "compass", "thermo", "string", "led", "plot"]
    plot = _widgets(result.dashboard.widgets)[-1]
    assert plot.bindings[0].regex == "speed=([0-9.]+)"
    assert result.messages == []


def test_viewing_never_modifies_the_file(tmp_path: Path) -> None:
    """Loading a legacy file leaves its bytes and mtime as they were."""
    path = tmp_path / "old.json"
    shutil.copyfile(GOLDEN / "legacy_all_widgets.json", path)
    before = (path.read_bytes(), path.stat().st_mtime_ns)
    load_dashboard(path, LOOKUP)
    assert (path.read_bytes(), path.stat().st_mtime_ns) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["old.json"]


def test_legacy_unknown_type_kept_and_bad_property_named() -> None:
    """An unknown legacy type is kept raw; a bad property value and an unknown property are named."""
    result = load_dashboard(GOLDEN / "legacy_unknown_type.json", LOOKUP)
    raw, dial = result.dashboard.widgets
    assert isinstance(raw, RawWidget)
    assert raw.data["type"] == "DragButton"
    assert isinstance(dial, WidgetConfig)
    assert dial.bindings == (Binding("/rosdashboard/speed", "", ""),)
    text = "\n".join(result.messages)
    assert "widget #1 'Reset': unknown ROSDashboard widget type \"DragButton\"" in text
    assert "widget #2 'Speed'" in text
    assert "'minimum' value 'fast' is not a number" in text
    assert "unknown property 'colour'" in text


def test_current_file_with_problems_loads_the_rest() -> None:
    """Unknown type kept verbatim, bad fields named with widget and field, good widgets load intact."""
    result = load_dashboard(GOLDEN / "current_with_problems.json", LOOKUP)
    good, scan, bad = result.dashboard.widgets
    assert isinstance(good, WidgetConfig)
    assert good.properties["color"] == "#ff0000"
    assert good.properties["unit"] == "m/s"
    assert isinstance(scan, RawWidget)
    assert scan.data["plugin_data"] == {"keep": [1, 2, 3]}
    assert isinstance(bad, WidgetConfig)
    assert bad.x == 0.0
    assert bad.properties["minimum"] == 0.0
    # A regex that does not compile is kept as written (the widget shows the error), never dropped.
    assert bad.bindings == (Binding("/rosdashboard/temp", "data", "(?<=x)\\d"),)
    text = "\n".join(result.messages)
    assert "widget #2 'Scan': unknown widget type 'laser_scan'" in text
    assert "widget #3 'Bad thermo': field 'x' must be a number" in text
    assert "widget #3 'Bad thermo': property 'minimum': expected a number" in text
    assert "widget #3 'Bad thermo': unknown property 'sparkle'" in text
    assert "widget #3 'Bad thermo': bindings[0]: field 'regex'" in text
    assert "lookarounds are not supported" in text
    assert result.dashboard.grid_size == 10


def _one_dial(**extra: Any) -> dict[str, Any]:
    entry = {"type": "dial", "name": "Hits", "x": 0, "y": 0, "width": 200, "height": 200, **extra}
    return {"format": FORMAT, "version": VERSION, "widgets": [entry]}


def test_widget_stale_time_loads_saves_and_is_validated() -> None:
    """A widget's own stale time round-trips; absent stays absent; nonsense is named and ignored."""
    result = parse_dashboard(_one_dial(stale_after=30), LOOKUP)
    assert result.messages == []
    (dial,) = _widgets(result.dashboard.widgets)
    assert dial.stale_after == 30.0
    assert json.loads(dumps(result.dashboard))["widgets"][0]["stale_after"] == 30.0
    plain = parse_dashboard(_one_dial(), LOOKUP)
    assert _widgets(plain.dashboard.widgets)[0].stale_after is None
    assert "stale_after" not in json.loads(dumps(plain.dashboard))["widgets"][0]
    for bad, expected in (
        (0, "must be more than 0"),
        (-2.5, "must be more than 0"),
        (1e9, "at most 86400 seconds"),
        ("30", 'must be a number of seconds, got "30"'),
        (True, "must be a number of seconds"),
    ):
        loaded = parse_dashboard(_one_dial(stale_after=bad), LOOKUP)
        (message,) = loaded.messages
        assert message.startswith("widget #1 'Hits': field 'stale_after' ")
        assert expected in message
        assert message.endswith("using the viewer's stale time")
        assert _widgets(loaded.dashboard.widgets)[0].stale_after is None


def test_unknown_entries_save_back_unchanged(tmp_path: Path) -> None:
    """An unknown-type entry is written back byte-for-byte equal as JSON data."""
    result = load_dashboard(GOLDEN / "current_with_problems.json", LOOKUP)
    out = tmp_path / "out.json"
    save_dashboard(result.dashboard, out)
    original = json.loads((GOLDEN / "current_with_problems.json").read_text())
    saved = json.loads(out.read_text())
    assert saved["widgets"][1] == original["widgets"][1]
    assert saved["format"] == FORMAT
    assert saved["version"] == 1, "nothing in it needs a newer version"


WATCH = {"file": "/ws/controller.py", "line": 42, "exprs": ["error", "self.gain"]}


def test_watch_round_trips_and_makes_the_file_version_3() -> None:
    """A widget's watch loads, saves and loads back equal; a file with one is version 3, one without 1."""
    full = {**WATCH, "node": "/controller", "when": "error > 0.1", "throttle": 0.5, "max_cpu": 2.5}
    for raw in (WATCH, full):
        result = parse_dashboard(_one_dial(watch=raw), LOOKUP)
        assert result.messages == []
        (dial,) = _widgets(result.dashboard.widgets)
        assert dial.watch == WatchConfig(
            "/ws/controller.py",
            42,
            ("error", "self.gain"),
            node=str(raw.get("node", "")),
            when=str(raw.get("when", "")),
            throttle=raw.get("throttle"),  # type: ignore[arg-type]
            max_cpu=raw.get("max_cpu"),  # type: ignore[arg-type]
        )
        saved = json.loads(dumps(result.dashboard))
        assert saved["version"] == WATCH_VERSION
        assert saved["widgets"][0]["watch"] == raw
    plain = json.loads(dumps(parse_dashboard(_one_dial(), LOOKUP).dashboard))
    assert plain["version"] == 1
    assert "watch" not in plain["widgets"][0]


def test_watch_of_an_unknown_widget_type_keeps_the_file_version_3() -> None:
    """An entry kept verbatim (a plugin not installed) with a watch is saved back as version 3."""
    data = _one_dial(watch=WATCH)
    data["widgets"][0]["type"] = "not_installed"
    result = parse_dashboard(data, LOOKUP)
    assert isinstance(result.dashboard.widgets[0], RawWidget)
    assert json.loads(dumps(result.dashboard))["version"] == WATCH_VERSION


def test_watch_in_a_file_before_version_3_is_an_unknown_field() -> None:
    """Versions 1 and 2 have no watches: the field is named and ignored, as any unknown field."""
    data = _one_dial(watch=WATCH)
    data["version"] = ROBOT_VERSION
    result = parse_dashboard(data, LOOKUP)
    assert result.messages == ["widget #1 'Hits': unknown field 'watch' ignored"]
    assert _widgets(result.dashboard.widgets)[0].watch is None


@pytest.mark.parametrize(
    ("watch", "expected"),
    [
        ("x", "field 'watch' must be an object, got a string"),
        ({**WATCH, "file": ""}, "'watch.file' must be a file name"),
        ({**WATCH, "file": "a\nb"}, "'watch.file' contains the control character U+000A"),
        ({**WATCH, "line": 0}, "'watch.line' must be a whole number 1..10000000, got 0"),
        ({**WATCH, "line": True}, "'watch.line' must be a whole number"),
        ({**WATCH, "line": 4.5}, "'watch.line' must be a whole number"),
        ({**WATCH, "exprs": []}, "'watch.exprs' must be a list of 1 to 16 expressions"),
        ({**WATCH, "exprs": "error"}, "'watch.exprs' must be a list"),
        ({**WATCH, "exprs": ["ok", 3]}, "'watch.exprs[1]' must be an expression, got 3"),
        ({**WATCH, "exprs": ["x" * 501]}, "'watch.exprs[0]' is longer than 500 characters"),
        ({**WATCH, "node": 5}, "'watch.node' must be a string, got 5"),
        ({**WATCH, "throttle": -1}, "'watch.throttle' must be 0..3600 seconds, got -1"),
        ({**WATCH, "throttle": "fast"}, "'watch.throttle' must be 0..3600 seconds"),
        ({**WATCH, "max_cpu": 80}, "'watch.max_cpu' must be 0.1..50 percent, got 80"),
    ],
)
def test_a_bad_watch_is_left_out_naming_the_field(watch: object, expected: str) -> None:
    """A watch field of the wrong kind leaves the watch out with a message naming it; the widget loads."""
    if isinstance(watch, dict) and watch.get("file") == "a\\nb":
        watch = {**watch, "file": "a\nb"}
    result = parse_dashboard(_one_dial(watch=watch), LOOKUP)
    (message,) = result.messages
    assert message.startswith("widget #1 'Hits': field ")
    assert expected in message
    assert message.endswith("the watch is left out")
    (dial,) = _widgets(result.dashboard.widgets)
    assert dial.watch is None
    assert dial.name == "Hits"


def test_a_watch_expression_the_reader_refuses_is_kept_as_written() -> None:
    """An expression outside the watch language loads as written (the widget shows the refusal once armed);
    an unknown key of the watch is named and ignored."""
    result = parse_dashboard(_one_dial(watch={**WATCH, "exprs": ["len(x)"], "colour": "red"}), LOOKUP)
    assert result.messages == ["widget #1 'Hits': field 'watch': unknown field 'colour' ignored"]
    assert _widgets(result.dashboard.widgets)[0].watch == WatchConfig("/ws/controller.py", 42, ("len(x)",))


def test_legacy_saves_in_current_format(tmp_path: Path) -> None:
    """Saving a legacy dashboard writes the current format, which loads back equal."""
    result = load_dashboard(GOLDEN / "legacy_all_widgets.json", LOOKUP)
    out = tmp_path / "new.json"
    save_dashboard(result.dashboard, out)
    data = json.loads(out.read_text())
    assert data["format"] == FORMAT
    assert "posX" not in out.read_text()
    again = load_dashboard(out, LOOKUP)
    assert not again.legacy
    assert again.messages == []
    assert again.dashboard == result.dashboard


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (b"", "not valid JSON"),
        (b"{nope", "not valid JSON"),
        (b"[1, 2]", "expected a JSON object at the top, got a list"),
        (b'{"format": "dbglog-dashboard", "version": 99, "widgets": []}', "version 99 is newer"),
        (b'{"format": "other", "version": 1, "widgets": []}', "'format' is 'other'"),
        (b'{"hello": 1}', "no 'widgets' list"),
        (b"\xff\xfe\x00", "not UTF-8"),
        (b'{"widgets": [{"x": 1e999}]}', "out of range"),
        (b'{"format": "dbglog-dashboard", "version": 1, "widgets": [NaN]}', "NaN is not allowed"),
    ],
)
def test_unreadable_files_raise_clear_errors(tmp_path: Path, content: bytes, expected: str) -> None:
    """A file that is not a dashboard raises DashboardError naming the file and the problem."""
    path = tmp_path / "bad.json"
    path.write_bytes(content)
    with pytest.raises(DashboardError) as info:
        load_dashboard(path, LOOKUP)
    assert str(path) in str(info.value)
    assert expected in str(info.value)


def test_missing_file_and_directory(tmp_path: Path) -> None:
    """A missing path or a directory is a DashboardError naming it."""
    with pytest.raises(DashboardError, match="no such file"):
        load_dashboard(tmp_path / "missing.json", LOOKUP)
    with pytest.raises(DashboardError, match="is a directory"):
        load_dashboard(tmp_path, LOOKUP)


def test_atomic_save_keeps_bak_and_no_temp_files(tmp_path: Path) -> None:
    """A second save keeps the first version as .bak and leaves no temporary files behind."""
    path = tmp_path / "d.json"
    first = Dashboard([WidgetConfig("dial", "One", 0, 0, 200, 200)])
    second = Dashboard([WidgetConfig("dial", "Two", 0, 0, 200, 200)])
    save_dashboard(first, path)
    save_dashboard(second, path)
    assert json.loads(path.read_text())["widgets"][0]["name"] == "Two"
    assert json.loads((tmp_path / "d.json.bak").read_text())["widgets"][0]["name"] == "One"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json", "d.json.bak"]


def test_failed_save_keeps_previous_file(tmp_path: Path) -> None:
    """A save that cannot serialise, or cannot write, leaves the previous file intact."""
    path = tmp_path / "d.json"
    save_dashboard(Dashboard([WidgetConfig("dial", "Keep", 0, 0, 200, 200)]), path)
    before = path.read_bytes()
    broken = Dashboard([WidgetConfig("dial", "Bad", 0, 0, 200, 200, properties={"minimum": float("nan")})])
    with pytest.raises(DashboardError, match="cannot serialise"):
        save_dashboard(broken, path)
    assert path.read_bytes() == before
    os.chmod(tmp_path, 0o500)
    try:
        # root ignores permissions: then use a path whose folder is a file.
        target = path / "inside.json" if os.access(tmp_path, os.W_OK) else path
        with pytest.raises(DashboardError, match="cannot save"):
            save_dashboard(Dashboard(), target)
    finally:
        os.chmod(tmp_path, 0o700)
    assert path.read_bytes() == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["d.json"]


# --- property tests -------------------------------------------------------------------------------

json_leaf = (
    st.none()
    | st.booleans()
    | st.integers(-(10**6), 10**6)
    | st.floats(allow_nan=False, allow_infinity=False)
    | st.text(max_size=8)
)
junk = st.recursive(
    json_leaf,
    lambda inner: st.lists(inner, max_size=4) | st.dictionaries(st.text(max_size=8), inner, max_size=4),
    max_leaves=20,
)
keys = st.sampled_from(
    ["type", "name", "x", "y", "width", "height", "bindings", "properties", "posX", "posY", "subscription"]
)
widget_like = st.dictionaries(
    keys, junk | st.sampled_from([*REGISTRY.names(), "DragDial", "DragPlot"]), max_size=8
)
dashboard_like = st.fixed_dictionaries(
    {"widgets": st.lists(widget_like | junk, max_size=5)},
    optional={"format": st.just(FORMAT) | junk, "version": st.just(1) | junk, "grid": junk},
)


@given(dashboard_like | junk)
@settings(max_examples=300, suppress_health_check=[HealthCheck.too_slow])
def test_junk_gives_dashboard_error_or_partial_load(data: Any) -> None:
    """Any JSON-shaped junk either raises DashboardError or loads with every widget accounted for."""
    try:
        result = parse_dashboard(data, LOOKUP)
    except DashboardError as exc:
        message = str(exc)
        assert message, "a DashboardError always says what is wrong"
        return
    for widget in result.dashboard.widgets:
        assert isinstance(widget, WidgetConfig | RawWidget)
    json.loads(dumps(result.dashboard))  # whatever loaded can be saved


SAFE_CHARS = st.characters(blacklist_categories=("Cs", "Cc"))
"""Text a dashboard keeps as it is: no lone surrogates, no control characters (see text_problem)."""


_one_line = st.text(SAFE_CHARS, min_size=1, max_size=30).map(str.strip).filter(bool)
watches = st.builds(
    WatchConfig,
    _one_line,
    st.integers(1, 10_000_000),
    st.lists(_one_line, min_size=1, max_size=16).map(tuple),
    node=st.just("") | _one_line,
    when=st.just("") | _one_line,
    throttle=st.none() | st.floats(0, 3600),
    max_cpu=st.none() | st.floats(0.1, 50),
)


def _config(type_name: str) -> st.SearchStrategy[WidgetConfig]:
    cls = REGISTRY.get(type_name)
    assert cls is not None
    props: dict[str, st.SearchStrategy[Any]] = {}
    for p in cls.properties:
        if p.kind is PropKind.NUMBER:
            lo = p.minimum if p.minimum is not None else -1e9
            hi = p.maximum if p.maximum is not None else 1e9
            props[p.name] = (
                st.integers(int(lo), int(hi)).map(float) if p.integer else st.floats(lo, hi, allow_nan=False)
            )
        elif p.kind is PropKind.BOOL:
            props[p.name] = st.booleans()
        elif p.kind is PropKind.CHOICE:
            props[p.name] = st.sampled_from(p.choices)
        elif p.kind is PropKind.COLOR:
            props[p.name] = st.from_regex(r"#[0-9a-f]{8}", fullmatch=True)
        else:
            props[p.name] = st.text(SAFE_CHARS, max_size=20)
    several = cls.max_bindings > 1 and not cls.publishes
    binding = st.builds(
        Binding,
        st.from_regex(r"/[a-z][a-z0-9_/]{0,20}", fullmatch=True),
        st.from_regex(r"[a-z_.]{0,12}", fullmatch=True).map(str.strip),
        st.sampled_from(["", "x=(\\d+)", "^(.*)$"]),
        robot=st.sampled_from(["", SELECTED_ROBOT, *([EVERY_ROBOT] if several else [])]),
    )
    mw, mh = cls.min_size
    return st.builds(
        WidgetConfig,
        st.just(type_name),
        st.text(SAFE_CHARS, min_size=1, max_size=30),
        st.floats(0, 5000),
        st.floats(0, 5000),
        st.floats(mw, 5000),
        st.floats(mh, 5000),
        st.lists(binding, max_size=cls.max_bindings).map(tuple),
        st.fixed_dictionaries(props),
        st.none() | st.floats(0.001, 86_400),
        st.none() | watches,
    )


valid_dashboards = st.builds(
    Dashboard,
    st.lists(st.sampled_from(REGISTRY.names()).flatmap(_config), max_size=6),
    st.integers(2, 400),
    st.booleans(),
)


@given(valid_dashboards)
@settings(max_examples=150, suppress_health_check=[HealthCheck.too_slow])
def test_round_trip_is_identity(dashboard: Dashboard) -> None:
    """Serialising a valid dashboard and loading it back gives the same dashboard with no messages."""
    result = parse_dashboard(json.loads(dumps(dashboard)), LOOKUP)
    assert result.messages == []
    assert result.dashboard == dashboard


def _robot_file(version: int, *bindings: dict[str, Any], type_name: str = "plot") -> dict[str, Any]:
    entry = {"type": type_name, "name": "Speed", "x": 0, "y": 0, "width": 400, "height": 300}
    return {"format": FORMAT, "version": version, "widgets": [{**entry, "bindings": list(bindings)}]}


def test_bindings_to_the_selected_robot_and_every_robot_load_and_save_as_version_2(tmp_path: Path) -> None:
    """Version 2: ``"robot"`` makes the topic relative to the robot's namespace; it saves back as written."""
    data = _robot_file(
        2,
        {"robot": "$selected", "topic": "rosdashboard/speed", "field": "", "regex": ""},
        {"robot": "$every", "topic": "/odom", "field": "pose.x", "regex": ""},
        {"topic": "/robot1/rosdashboard/speed", "field": "", "regex": ""},
    )
    result = parse_dashboard(data, LOOKUP)
    assert result.messages == []
    (plot,) = _widgets(result.dashboard.widgets)
    assert plot.bindings == (
        Binding("/rosdashboard/speed", robot=SELECTED_ROBOT),
        Binding("/odom", "pose.x", robot=EVERY_ROBOT),
        Binding("/robot1/rosdashboard/speed"),
    )
    out = tmp_path / "robots.json"
    save_dashboard(result.dashboard, out)
    saved = json.loads(out.read_text())
    assert saved["version"] == ROBOT_VERSION
    assert saved["widgets"][0]["bindings"][:2] == [
        {"robot": "$selected", "topic": "rosdashboard/speed", "field": "", "regex": ""},
        {"robot": "$every", "topic": "odom", "field": "pose.x", "regex": ""},
    ]
    assert "robot" not in saved["widgets"][0]["bindings"][2]


def test_files_of_version_1_load_unchanged_and_stay_version_1() -> None:
    """A version-1 file's topics stay absolute (a stray "robot" is an unknown field), and a dashboard with
    no robot-relative binding saves as version 1, which older viewers open."""
    data = _robot_file(1, {"robot": "$selected", "topic": "rosdashboard/speed", "field": "", "regex": ""})
    result = parse_dashboard(data, LOOKUP)
    (plot,) = _widgets(result.dashboard.widgets)
    assert plot.bindings == (Binding("/rosdashboard/speed"),)
    assert result.messages == ["widget #1 'Speed': bindings[0]: unknown field 'robot' ignored"]
    assert json.loads(dumps(result.dashboard))["version"] == 1
    kept = Dashboard([RawWidget({"type": "x", "bindings": [{"robot": "$every", "topic": "a"}]}, "no plugin")])
    assert kept.needed_version() == ROBOT_VERSION, "an entry kept verbatim keeps what it needs"


def test_a_bad_robot_value_keeps_the_topic_as_written() -> None:
    """An unknown "robot" is named; every robot on a one-series widget or a control follows the selected
    robot instead; a newer version than 2 is refused."""
    bad = parse_dashboard(_robot_file(2, {"robot": "robot1", "topic": "/x"}), LOOKUP)
    assert _widgets(bad.dashboard.widgets)[0].bindings == (Binding("/x"),)
    assert bad.messages == [
        "widget #1 'Speed': bindings[0]: field 'robot' must be '$selected' or '$every', got \"robot1\"; "
        "the topic '/x' is used as written"
    ]
    for type_name, what in (("dial", "shows one series"), ("toggle", "publishes to one topic")):
        one = parse_dashboard(_robot_file(2, {"robot": "$every", "topic": "x"}, type_name=type_name), LOOKUP)
        assert _widgets(one.dashboard.widgets)[0].bindings == (Binding("/x", robot=SELECTED_ROBOT),)
        assert one.messages == [
            f"widget #1 'Speed': bindings[0]: a {type_name} {what}: it follows the selected robot instead "
            "of every robot"
        ]
    with pytest.raises(DashboardError, match=f"version {VERSION + 1} is newer than this viewer understands"):
        parse_dashboard(_robot_file(VERSION + 1), LOOKUP)
