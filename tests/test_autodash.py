"""The automatic dashboard's plan: tags by robot and namespace in panels, few widgets, natural order."""

from __future__ import annotations

import itertools
import math
import random
from collections import Counter

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog._ros._tags import natural_key
from dbglog.viewer._data._model import Binding, FieldInfo, TopicInfo
from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S
from dbglog.viewer._document._autodash import (
    LARGE_GROUP,
    MAX_WAIT_S,
    QUIET_S,
    SERIES_PER_PLOT,
    TAG_WAIT_S,
    AddWidget,
    AutoPlan,
    AutoTag,
    Observed,
    SetBindings,
    TagKind,
    classify,
    magnitude,
    partition,
    retype,
)
from dbglog.viewer._widgets._geometry import Rect, overlaps

_TYPES = {"number": "std_msgs/msg/Float64", "bool": "std_msgs/msg/Bool", "string": "std_msgs/msg/String"}


def _info(tag: str, kind: str = "number", robot: str = "") -> TopicInfo:
    return TopicInfo(f"{robot}/rosdashboard/{tag}", (_TYPES.get(kind, kind),), 1)


def _tag(tag: str, kind: str = "number", robot: str = "") -> AutoTag:
    out = classify(_info(tag, kind, robot))
    assert out is not None
    return out


def _fleet(robots: list[str], subsystems: int = 15, numbers: int = 16, states: int = 4) -> list[AutoTag]:
    tags = []
    for robot in robots:
        for k in range(subsystems):
            tags += [_tag(f"s{k}/v{j}", "number", robot) for j in range(numbers)]
            tags += [_tag(f"s{k}/f{j}", "bool" if j % 2 else "string", robot) for j in range(states)]
    return tags


def _extent(tag: AutoTag) -> float:
    """The fleet's magnitudes: v<j> swings 10^(j mod 4 - 1)."""
    leaf = tag.text.rsplit("/", 1)[-1]
    return 10.0 ** (int(leaf[1:]) % 4 - 1) if leaf.startswith("v") and leaf[1:].isdigit() else 1.0


def _plan_all(
    tags: list[AutoTag], plan: AutoPlan | None = None, **step: object
) -> tuple[AutoPlan, list[AddWidget]]:
    plan = plan if plan is not None else AutoPlan(first_wait_s=0.0)
    for tag in tags:
        plan.offer(tag, 0.0)
    actions = plan.step(MAX_WAIT_S, lambda t: Observed(20, _extent(t)), **step)  # type: ignore[arg-type]
    adds = [a for a in actions if isinstance(a, AddWidget)]
    assert len(adds) == len(actions)
    return plan, adds


def _disjoint(a: Rect, b: Rect) -> bool:
    return not overlaps(a, b)


# -- what each topic is -------------------------------------------------------------------------------


def test_numbers_bools_and_texts_are_classified() -> None:
    """Numbers are series (a gauge noted when the name tells the range); bools and strings are states."""
    speed = _tag("proximity")
    assert (speed.kind, speed.bindings, speed.gauge) == (
        TagKind.NUMBER,
        (Binding("/rosdashboard/proximity"),),
        None,
    )
    assert _tag("count", "std_msgs/msg/Int32").kind is TagKind.NUMBER
    assert _tag("bumper", "bool").kind is TagKind.STATE
    assert _tag("state", "string").kind is TagKind.STATE
    assert _tag("sound/confidence").gauge == ("thermo", {"minimum": 0.0, "maximum": 1.0, "decimals": 2.0})
    assert _tag("battery").gauge == ("thermo", {"minimum": 0.0, "maximum": 100.0, "unit": "%"})
    assert _tag("sound/azimuth").gauge == ("compass", {"units": "radians"})
    assert _tag("turtle/heading_deg").gauge == ("compass", {"units": "degrees"})
    robot = _tag("s3/speed", robot="/robot1")
    assert (robot.robot, robot.text, robot.label) == ("/robot1", "s3/speed", "robot1:s3/speed")


def test_arrays_and_other_messages_get_their_elements_and_fields() -> None:
    """Arrays bind their first elements (as many as known, up to four); other messages their fields."""
    info = _info("ranges", "std_msgs/msg/Float64MultiArray")
    assert [b.field for b in classify(info, array_length=3).bindings] == ["data[0]", "data[1]", "data[2]"]  # type: ignore[union-attr]
    assert len(classify(info, array_length=100).bindings) == 4  # type: ignore[union-attr]
    assert [b.field for b in classify(info).bindings] == ["data[0]"]  # type: ignore[union-attr]
    twist = TopicInfo("/turtle1/cmd_vel", ("geometry_msgs/msg/Twist",), 1)
    fields = [
        FieldInfo("linear.x", "double", True),
        FieldInfo("linear.y", "double", True),
        FieldInfo("header.frame_id", "string", False),
    ]
    other = classify(twist, fields=lambda _t: fields)
    assert other is not None
    assert (other.kind, other.is_tag, other.label) == (TagKind.FIELDS, False, "/turtle1/cmd_vel")
    assert [b.field for b in other.bindings] == ["linear.x", "linear.y"]
    assert classify(twist) is None
    assert classify(TopicInfo("/x", (), 0)) is None


# -- panels, order, budget ----------------------------------------------------------------------------


def test_two_robots_of_300_tags_fit_the_budget_every_tag_once_in_natural_order() -> None:
    """2 robots x 15 subsystems x 20 tags: 30 panels of two plots and a States widget (90 widgets), every
    tag bound exactly once, panels and series in natural order, offered in any order."""
    tags = _fleet(["/robot1", "/robot2"])
    random.Random(7).shuffle(tags)
    plan, adds = _plan_all(tags)
    assert len(adds) == 90
    assert plan.made == 90
    bound = Counter(b.topic for a in adds for b in a.config.bindings)
    assert set(bound) == {t.topic for t in tags}
    assert set(bound.values()) == {1}
    titles = [p.title for p in plan.panels]
    assert titles == [f"robot{r}:s{k}" for r in (1, 2) for k in range(15)]
    for panel in plan.panels:
        assert [w.type for w in panel.widgets] == ["plot", "plot", "states"]
        for w in panel.widgets:
            keys = [natural_key(b.topic) for b in w.bindings]
            assert keys == sorted(keys), w.bindings
    first = plan.panels[0].widgets[0]
    assert [b.topic.rsplit("/", 1)[-1] for b in first.bindings] == [
        "v0",
        "v1",
        "v4",
        "v5",
        "v8",
        "v9",
        "v12",
        "v13",
    ]


def test_widgets_never_overlap_and_stay_in_their_panel() -> None:
    """Widgets lie inside their panel's frame, below its title; panels and widgets never overlap."""
    plan, adds = _plan_all(_fleet(["/robot1", "/robot2"], subsystems=4, numbers=5, states=3))
    rects = [Rect(a.config.x, a.config.y, a.config.width, a.config.height) for a in adds]
    for a, b in itertools.combinations(rects, 2):
        assert _disjoint(a, b)
    for p, q in itertools.combinations(plan.panels, 2):
        assert _disjoint(p.rect, q.rect)
    for panel in plan.panels:
        frame = panel.rect
        for w in panel.widgets:
            r = panel.cell_rect(w.col, w.row, w.span)
            assert frame.x < r.x
            assert r.x + r.w < frame.x + frame.w
            assert frame.y + 20 < r.y
            assert r.y + r.h < frame.y + frame.h
        assert frame.x + frame.w <= plan.right + 1e-6


def test_similar_magnitudes_share_a_plot_when_the_budget_allows() -> None:
    """A panel's numbers spanning decades are split by magnitude while within budget, never otherwise."""
    tags = [_tag(f"arm/{n}") for n in ("small_a", "small_b", "big")]
    extents = {"small_a": 0.5, "small_b": 0.8, "big": 1000.0}
    plan = AutoPlan(first_wait_s=0.0)
    for tag in tags:
        plan.offer(tag, 0.0)
    actions = plan.step(MAX_WAIT_S, lambda t: Observed(20, extents[t.text.rsplit("/", 1)[-1]]))
    plots = [
        [b.topic.rsplit("/", 1)[-1] for b in a.config.bindings] for a in actions if isinstance(a, AddWidget)
    ]
    assert plots == [["big"], ["small_a", "small_b"]]
    tight = AutoPlan(budget=1, first_wait_s=0.0)
    for tag in tags:
        tight.offer(tag, 0.0)
    (one,) = tight.step(MAX_WAIT_S, lambda t: Observed(20, extents[t.text.rsplit("/", 1)[-1]]))
    assert isinstance(one, AddWidget)
    assert len(one.config.bindings) == 3


def test_gauges_come_while_the_budget_allows() -> None:
    """A gauge joins a number whose name tells its range on a small dashboard, not on one past its budget."""
    small = [_tag("sound/azimuth"), _tag("sound/confidence"), _tag("head/turning", "bool")]
    _plan, adds = _plan_all(small)
    assert sorted(a.config.type for a in adds) == ["compass", "plot", "states", "thermo"]
    compass = next(a for a in adds if a.config.type == "compass")
    assert compass.config.name == "sound/azimuth"
    assert compass.config.properties == {"units": "radians"}
    big = _fleet(["/robot1", "/robot2"]) + [_tag(f"s{k}/battery", robot="/robot1") for k in range(15)]
    _plan, adds = _plan_all(big)
    assert "thermo" not in {a.config.type for a in adds}


def test_a_large_group_is_split_one_level_deeper() -> None:
    """A group of more tags than LARGE_GROUP gets a panel per next level; its own leaves keep one."""
    tags = [_tag(f"arm/joint{j}/{q}") for j in range(1, 14) for q in ("pos", "vel", "eff", "temp")]
    tags.append(_tag("arm/mode", "string"))
    assert len(tags) > LARGE_GROUP
    plan, _adds = _plan_all(tags)
    assert [p.title for p in plan.panels] == ["arm", *(f"arm/joint{j}" for j in range(1, 14))]
    late = plan.step  # a later tag of a split group goes to its deeper panel
    plan.offer(_tag("arm/joint2/current"), 10.0)
    actions = late(10.0 + MAX_WAIT_S, lambda t: Observed(20, 1.0))
    (join,) = actions
    assert isinstance(join, SetBindings)
    assert plan.panel_of(join.key).title == "arm/joint2"  # type: ignore[union-attr]


def test_robots_and_names_sort_naturally() -> None:
    """robot2 before robot10, s2 before s10, the root namespace first, top-level tags in their own panel."""
    tags = [_tag("s10/x", robot="/robot10"), _tag("s2/x", robot="/robot2"), _tag("s10/x", robot="/robot2")]
    tags += [_tag("speed"), _tag("s1/x")]
    _plan, adds = _plan_all(tags)
    assert [a.panel for a in adds] == ["tags", "s1", "robot2:s2", "robot2:s10", "robot10:s10"]


# -- when tags are placed -----------------------------------------------------------------------------


def test_tags_wait_for_a_quiet_graph_and_their_values() -> None:
    """Nothing is placed while tags keep appearing or a number has no values yet; then all at once."""
    plan = AutoPlan(first_wait_s=0.0)
    plan.offer(_tag("a/x"), 0.0)
    plan.offer(_tag("a/flag", "bool"), 0.5)
    values = {"/rosdashboard/a/x": Observed()}

    def seen(t: AutoTag) -> Observed | None:
        return values.get(t.topic)

    assert plan.step(0.5 + QUIET_S / 2, seen) == []  # the graph is not quiet yet
    assert plan.step(0.5 + QUIET_S, seen) == []  # quiet, but a/x has sent nothing
    values["/rosdashboard/a/x"] = Observed(20, 3.0)
    adds = plan.step(0.5 + QUIET_S + 0.1, seen)
    assert [a.config.type for a in adds if isinstance(a, AddWidget)] == ["plot", "states"]
    assert plan.waiting == []


def test_the_first_panels_wait_for_discovery_to_settle() -> None:
    """Nothing is placed before the discovery horizon: a robot found at its next announcement still lands
    in natural order with the first panels (robot1 before robot2, however the graph showed them)."""
    plan = AutoPlan()
    plan.offer(_tag("s1/x", "bool", "/robot2"), 0.0)
    assert plan.step(0.0, lambda t: None) == []
    assert plan.step(DISCOVERY_HORIZON_S - 0.5, lambda t: None) == []
    plan.offer(_tag("s1/x", "bool", "/robot1"), DISCOVERY_HORIZON_S - 0.5)
    adds = plan.step(DISCOVERY_HORIZON_S + QUIET_S, lambda t: None)
    assert [a.panel for a in adds if isinstance(a, AddWidget)] == ["robot1:s1", "robot2:s1"]


def test_a_silent_tag_or_a_busy_graph_does_not_hold_placement_forever() -> None:
    """A number that never sends is placed after TAG_WAIT_S; tags keep being placed on a graph never quiet."""
    plan = AutoPlan(first_wait_s=0.0)
    plan.offer(_tag("a/silent"), 0.0)
    assert plan.step(TAG_WAIT_S - 0.1, lambda t: Observed()) == []
    assert len(plan.step(TAG_WAIT_S, lambda t: Observed())) == 1
    busy = AutoPlan(first_wait_s=0.0)
    for i in range(20):  # a new tag every half second, forever
        busy.offer(_tag(f"b/t{i}", "bool"), i * 0.5)
        busy.step(i * 0.5, lambda t: None)
    assert busy.made >= 1
    assert len(busy.waiting) < 20


# -- tags that come later -----------------------------------------------------------------------------


def test_a_later_tag_joins_its_panel_without_moving_anything() -> None:
    """A later number joins the plot nearest its magnitude (series in natural order), a later bool the
    States widget; a far magnitude gets a new plot in the panel; what was placed keeps its place."""
    tags = [_tag(f"s1/a{j}") for j in (1, 3, 10)] + [_tag("s1/ok", "bool")]
    plan, adds = _plan_all(tags)
    placed = {a.key: (a.config.x, a.config.y, a.config.width, a.config.height) for a in adds}
    plot = next(a for a in adds if a.config.type == "plot")
    plan.offer(_tag("s1/a2"), 10.0)
    plan.offer(_tag("s1/fault", "bool"), 10.0)
    plan.offer(_tag("s1/huge"), 10.0)
    extents = {"a2": 0.5, "huge": 1e6}
    actions = plan.step(
        10.0 + MAX_WAIT_S, lambda t: Observed(20, extents.get(t.text.rsplit("/", 1)[-1], 1.0))
    )
    joins = {
        a.key: [b.topic.rsplit("/", 1)[-1] for b in a.bindings] for a in actions if isinstance(a, SetBindings)
    }
    assert joins[plot.key] == ["a1", "a2", "a3", "a10"]
    states = next(a for a in adds if a.config.type == "states")
    assert joins[states.key] == ["fault", "ok"]
    (new,) = [a for a in actions if isinstance(a, AddWidget)]
    assert (new.config.type, new.config.name, new.panel) == ("plot", "s1/huge", "s1")
    panel = plan.panels[0]
    for w in panel.widgets:  # nothing moved
        if w.key in placed:
            r = panel.cell_rect(w.col, w.row, w.span)
            assert (r.x, r.y, r.w, r.h) == placed[w.key]
    assert len(plan.panels) == 1


def test_a_later_tag_leaves_a_changed_widget_alone() -> None:
    """A widget the user changed (or deleted) gains nothing: the later tag gets a widget of its own."""
    plan, adds = _plan_all([_tag("s1/a"), _tag("s1/ok", "bool")])
    plan.offer(_tag("s1/b"), 10.0)
    plan.offer(_tag("s1/fault", "bool"), 10.0)
    actions = plan.step(10.0 + MAX_WAIT_S, lambda t: Observed(20, 1.0), alive=lambda _k, _b: False)
    assert [type(a) for a in actions] == [AddWidget, AddWidget]
    new_rects = [
        Rect(a.config.x, a.config.y, a.config.width, a.config.height)
        for a in actions
        if isinstance(a, AddWidget)
    ]
    old_rects = [Rect(a.config.x, a.config.y, a.config.width, a.config.height) for a in adds]
    for a, b in itertools.product(new_rects, old_rects):
        assert _disjoint(a, b)


def test_a_full_panel_grows_where_there_is_room() -> None:
    """A panel without a free cell grows a column to its right or a row below it, never over another
    panel or a widget the user placed; with neither free, a second panel of the group starts."""
    plan, _adds = _plan_all([_tag("a/x"), _tag("b/y")])
    first, second = plan.panels
    blocked: list[Rect] = [second.rect]

    def free(r: Rect) -> bool:
        return all(_disjoint(r, b) for b in blocked)

    size = (first.columns, first.rows)
    below = Rect(0, 0, 0, 0)
    for i in range(8):  # each far from every plot's magnitude: a new plot each time
        if i == 2:  # the user puts a widget right below the panel, which has grown by then
            assert (first.columns, first.rows) != size
            below = Rect(first.x, first.rect.y + first.rect.h + 2, 300, 100)
            blocked.append(below)
        plan.offer(_tag(f"a/far{i}"), 10.0 * (i + 1))
        extent = 10.0 ** (3 * (i + 1))

        def seen(_t: AutoTag, e: float = extent) -> Observed:
            return Observed(20, e)

        for a in plan.step(10.0 * (i + 1) + MAX_WAIT_S, seen, free=free):
            if isinstance(a, AddWidget):
                blocked.append(Rect(a.config.x, a.config.y, a.config.width, a.config.height))
    for p, q in itertools.combinations(plan.panels, 2):
        assert _disjoint(p.rect, q.rect)
    assert all(p.rect.x + p.rect.w <= plan.right + 1e-6 for p in plan.panels)
    assert all(_disjoint(p.rect, below) for p in plan.panels)
    grown = [p for p in plan.panels if p.title == "a"]
    assert sum(len(p.widgets) for p in grown) == 9
    assert len(grown) > 1  # no room left beside or below it: the group goes on in a panel of its own
    for r1, r2 in itertools.combinations(blocked[1:], 2):
        assert _disjoint(r1, r2)


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(
            st.sampled_from(["a", "b", "c/d", "c/e", ""]),
            st.sampled_from(["number", "bool", "string"]),
            st.sampled_from(["", "/r1", "/r2"]),
            st.integers(min_value=-3, max_value=6),
        ),
        min_size=1,
        max_size=50,
    ),
    st.integers(min_value=1, max_value=5),
    st.integers(min_value=2, max_value=8),
)
def test_whatever_arrives_widgets_never_overlap(
    items: list[tuple[str, str, str, int]], batches: int, columns: int
) -> None:
    """Tags of any groups, kinds and magnitudes, arriving in any batches: every tag bound once, widgets and
    panels never overlap each other, widgets stay in their panel and the panels within the canvas."""
    plan = AutoPlan(columns=columns, first_wait_s=0.0)
    mags: dict[str, int] = {}
    rects: list[Rect] = []
    bound: Counter[str] = Counter()
    per = math.ceil(len(items) / batches)
    widgets: dict[int, tuple[Binding, ...]] = {}
    for b in range(batches):
        now = 100.0 * b
        for i, (group, kind, robot, mag) in enumerate(items[b * per : (b + 1) * per]):
            tag = _tag(f"{group}/t{b}_{i}" if group else f"t{b}_{i}", kind, robot)
            mags[tag.topic] = mag
            plan.offer(tag, now)
        for a in plan.step(now + MAX_WAIT_S, lambda t: Observed(20, 10.0 ** mags[t.topic])):
            if isinstance(a, AddWidget):
                rects.append(Rect(a.config.x, a.config.y, a.config.width, a.config.height))
                widgets[a.key] = a.config.bindings
            else:
                widgets[a.key] = a.bindings
    for bindings in widgets.values():
        bound.update(b.topic for b in bindings)
    assert set(bound) == set(mags)
    assert set(bound.values()) == {1}
    for r1, r2 in itertools.combinations(rects, 2):
        assert _disjoint(r1, r2)
    for p, q in itertools.combinations(plan.panels, 2):
        assert _disjoint(p.rect, q.rect)
    for panel in plan.panels:
        assert panel.rect.x + panel.rect.w <= plan.right + 1e-6
        for w in panel.widgets:
            r = panel.cell_rect(w.col, w.row, w.span)
            assert panel.rect.x < r.x
            assert r.x + r.w < panel.rect.x + panel.rect.w
            assert len(w.bindings) <= (SERIES_PER_PLOT if w.type == "plot" else 16)


# -- the pieces ---------------------------------------------------------------------------------------


@given(
    st.lists(st.floats(min_value=-6, max_value=6), min_size=1, max_size=12),
    st.integers(1, 5),
    st.integers(1, 5),
)
def test_partition_cuts_sorted_magnitudes_as_tightly_as_possible(
    values: list[float], parts: int, cap: int
) -> None:
    """Runs cover every number in order, each at most `cap`, as many as asked (or as `cap` needs), and no
    other cut into that many runs has a narrower widest run."""
    mags = sorted(values)
    sizes = partition(mags, parts, cap)
    n = len(mags)
    assert sum(sizes) == n
    assert all(1 <= s <= cap for s in sizes)
    assert len(sizes) == min(n, max(parts, math.ceil(n / cap)))

    def widest(cut: list[int]) -> float:
        out, start = 0.0, 0
        for s in cut:
            out = max(out, mags[start + s - 1] - mags[start])
            start += s
        return out

    k = len(sizes)
    best = min(
        widest([b - a for a, b in itertools.pairwise((0, *cuts, n))])
        for cuts in itertools.combinations(range(1, n), k - 1)
        if all(b - a <= cap for a, b in itertools.pairwise((0, *cuts, n)))
    )
    assert widest(sizes) == pytest.approx(best)


def test_magnitude_is_the_decade_of_the_largest_value() -> None:
    """The decade of the largest absolute value; unknown reads as 1, zeros alone as tiny."""
    assert magnitude(1000.0) == pytest.approx(3.0)
    assert magnitude(None) == 0.0
    assert magnitude(math.nan) == 0.0
    assert magnitude(0.0) == -6.0


def test_fit_width_fills_the_canvas() -> None:
    """Cells of at least the minimum width fill a panel as wide as the canvas; never fewer than two."""
    plan = AutoPlan(first_wait_s=0.0)
    plan.fit_width(1226, min_cell=180)
    assert plan.columns == 6
    assert plan.right == pytest.approx(1226 - plan.origin[0])
    plan.fit_width(100)
    assert plan.columns == 2


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
