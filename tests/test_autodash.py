"""The automatic dashboard picks a fitting widget per kind of tag and lays them out tidily."""

from __future__ import annotations

import itertools

from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._data._model import Binding, FieldInfo, TopicInfo
from dbglog.viewer._document._autodash import AutoLayout, retype, suggest


def _tag(name: str, msg_type: str) -> TopicInfo:
    return TopicInfo(f"/rosdashboard/{name}", (f"std_msgs/msg/{msg_type}",), 1)


def _types(info: TopicInfo, **kw: object) -> list[str]:
    return [s.type for s in suggest(info, **kw)]  # type: ignore[arg-type]


def test_numbers_get_a_plot() -> None:
    """A plain number tag becomes a plot of the whole value."""
    (s,) = suggest(_tag("proximity", "Float64"))
    assert s.type == "plot"
    assert s.bindings == (Binding("/rosdashboard/proximity"),)
    assert _types(_tag("count", "Int32")) == ["plot"]


def test_bool_gets_an_led_and_string_a_text() -> None:
    """Bools become LEDs and strings text widgets."""
    assert _types(_tag("bumper", "Bool")) == ["led"]
    assert _types(_tag("state", "String")) == ["string"]


def test_known_ranges_add_a_gauge() -> None:
    """Names that tell the range add a gauge beside the plot: fractions, percentages and angles."""
    conf = suggest(_tag("sound/confidence", "Float64"))
    assert [s.type for s in conf] == ["plot", "thermo"]
    assert conf[1].properties["maximum"] == 1.0
    battery = suggest(_tag("battery", "Float32"))
    assert battery[1].type == "thermo"
    assert battery[1].properties["maximum"] == 100.0
    azimuth = suggest(_tag("sound/azimuth", "Float64"))
    assert azimuth[1].type == "compass"
    assert azimuth[1].properties["units"] == "radians"
    heading = suggest(_tag("turtle/heading_deg", "Float64"))
    assert heading[1].properties["units"] == "degrees"


def test_arrays_plot_their_elements() -> None:
    """Multi-arrays plot their first elements, as many as are known (up to four)."""
    info = _tag("ranges", "Float64MultiArray")
    (s,) = suggest(info, array_length=lambda _t: 3)
    assert [b.field for b in s.bindings] == ["data[0]", "data[1]", "data[2]"]
    (s,) = suggest(info, array_length=lambda _t: 100)
    assert len(s.bindings) == 4
    (s,) = suggest(info)
    assert [b.field for b in s.bindings] == ["data[0]"]


def test_other_messages_plot_numeric_fields() -> None:
    """With --all, other messages plot their scalar numeric fields; unknown or empty ones get nothing."""
    twist = TopicInfo("/cmd_vel", ("geometry_msgs/msg/Twist",), 1)
    fields = [
        FieldInfo("linear.x", "double", True),
        FieldInfo("linear.y", "double", True),
        FieldInfo("header.frame_id", "string", False),
    ]
    (s,) = suggest(twist, fields=lambda _t: fields)
    assert s.type == "plot"
    assert s.name == "/cmd_vel"
    assert [b.field for b in s.bindings] == ["linear.x", "linear.y"]
    assert suggest(twist) == []
    assert suggest(TopicInfo("/x", (), 0)) == []


def test_dict_subtags_share_a_group() -> None:
    """Sub-tags of one dict carry the dict's tag as their group."""
    groups = {s.group for n in ("azimuth", "elevation") for s in suggest(_tag(f"sound/{n}", "Float64"))}
    assert groups == {"sound"}


def test_layout_groups_rows_and_never_overlaps() -> None:
    """Each group starts its own row; widgets never overlap; a topic is placed only once."""
    layout = AutoLayout(columns=4)
    placed = []
    for name, t in [
        ("sound/azimuth", "Float64"),
        ("turtle/x", "Float64"),
        ("sound/confidence", "Float64"),
        ("turtle/near_wall", "Bool"),
        ("sound/elevation", "Float64"),
    ]:
        info = _tag(name, t)
        placed += layout.add(suggest(info), info.name)
    assert layout.add(suggest(_tag("turtle/x", "Float64")), "/rosdashboard/turtle/x") == []
    rows: dict[float, set[str]] = {}
    for w in placed:
        rows.setdefault(w.y, set()).add(w.name.split("/")[0])
    assert all(len(groups) == 1 for groups in rows.values()), rows
    for a, b in itertools.combinations(placed, 2):
        assert (
            a.x + a.width <= b.x or b.x + b.width <= a.x or a.y + a.height <= b.y or b.y + b.height <= a.y
        ), (a, b)


@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b", "c", ""]), st.sampled_from(["plot", "led", "string", "compass"])
        ),
        max_size=40,
    ),
    st.integers(min_value=1, max_value=8),
)
def test_layout_property_no_overlap_within_columns(items: list[tuple[str, str]], columns: int) -> None:
    """Whatever arrives in whatever order, widgets stay inside the columns and never overlap."""
    from dbglog.viewer._document._autodash import Suggestion

    layout = AutoLayout(columns=columns)
    placed = []
    for i, (group, kind) in enumerate(items):
        placed += layout.add([Suggestion(kind, f"{group}/t{i}", (Binding(f"/t{i}"),), {}, group)], f"/t{i}")
    right = layout.origin[0] + columns * (layout.cell_width + layout.gap)
    for w in placed:
        assert w.x + w.width <= right
    for a, b in itertools.combinations(placed, 2):
        assert a.x + a.width <= b.x or b.x + b.width <= a.x or a.y + a.height <= b.y or b.y + b.height <= a.y


def test_layout_skips_cells_that_are_not_free() -> None:
    """A cell the user already filled is skipped: the widget lands in the next free one."""
    layout = AutoLayout(columns=4)
    taken = (layout.origin[0], layout.origin[1], 300.0, 100.0)

    def free(x: float, y: float, w: float, h: float) -> bool:
        tx, ty, tw, th = taken
        return x + w <= tx or tx + tw <= x or y + h <= ty or ty + th <= y

    (placed,) = layout.add(suggest(_tag("a", "Bool")), "/rosdashboard/a", free=free)
    assert free(placed.x, placed.y, placed.width, placed.height)


def test_fit_columns_fills_the_width() -> None:
    """Columns of at least the minimum width fill the canvas exactly; never fewer than two."""
    layout = AutoLayout()
    layout.fit_columns(1226, min_cell=180)
    assert layout.columns == 6
    right = layout.origin[0] + layout.columns * (layout.cell_width + layout.gap) - layout.gap
    assert abs(right - (1226 - layout.origin[0])) < 1e-6
    layout.fit_columns(100)
    assert layout.columns == 2


def test_retype_keeps_name_place_bindings_and_shared_properties() -> None:
    """A swapped kind keeps name, place, bindings (as many as fit) and valid shared properties."""
    from dbglog.viewer._document._dashboard import WidgetConfig
    from dbglog.viewer._widgets._gauges import DialWidget, ThermoWidget

    binds = (Binding("/rosdashboard/a"), Binding("/rosdashboard/b"))
    plot = WidgetConfig("plot", "speed", 30, 40, 420, 100, binds, {"window": 5.0, "y_min": -3.0})
    dial = retype(plot, DialWidget, min_frame=(120, 148))
    assert (dial.type, dial.name, dial.x, dial.y) == ("dial", "speed", 30, 40)
    assert dial.bindings == binds[:1]
    assert (dial.width, dial.height) == (420, 148)
    assert dial.properties == DialWidget.default_properties()
    ranged = WidgetConfig(
        "dial", "t", 0, 0, 200, 200, binds[:1], {"minimum": -5.0, "maximum": 5.0, "unit": "C"}
    )
    thermo = retype(ranged, ThermoWidget)
    assert (thermo.properties["minimum"], thermo.properties["maximum"], thermo.properties["unit"]) == (
        -5.0,
        5.0,
        "C",
    )
