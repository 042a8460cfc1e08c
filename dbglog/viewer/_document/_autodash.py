"""The automatic dashboard: every tag bound once, in panels by robot and namespace, on a tidy canvas.

Pure logic (no ROS, no Dear PyGui): the UI offers the graph's topics as they appear (`AutoPlan.offer`), tells
what their first values say (`Observed`), and carries out what `AutoPlan.step` returns: widgets to add and
widgets that gain a series. Tags are grouped by robot, then by the first level of their name (one level
deeper where a group is large, `LARGE_GROUP`); each group is a *panel*, a titled frame on the canvas around
its widgets. A panel's numbers share a few plots of up to `SERIES_PER_PLOT` series, tags of similar
magnitude together; its bools and texts share a States widget (lamps and a list); arrays and other messages
get a plot each; a gauge joins a number whose name tells its range while the dashboard stays within its
widget budget. Everything is in natural order (``s2`` before ``s10``). A placement is final: tags seen
later join their panel (a plot gains a series, the States widget a lamp) and nothing placed ever moves.
"""

from __future__ import annotations

import enum
import math
import re
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace

from dbglog._ros._tags import natural_key, robot_label
from dbglog.viewer._data._model import Binding, FieldInfo, TopicInfo
from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S
from dbglog.viewer._document._dashboard import WidgetConfig
from dbglog.viewer._widgets._geometry import Rect, overlaps
from dbglog.viewer.widget_api import PropertyError, PropValue, Widget

__all__ = [
    "LARGE_GROUP",
    "NUMBER_TYPES",
    "SERIES_PER_PLOT",
    "STATES_PER_WIDGET",
    "WIDGET_BUDGET",
    "Action",
    "AddWidget",
    "AutoPlan",
    "AutoTag",
    "GroupKey",
    "Observed",
    "Panel",
    "SetBindings",
    "TagKind",
    "classify",
    "is_array_type",
    "magnitude",
    "partition",
    "retype",
]

NUMBER_TYPES = frozenset(
    f"std_msgs/msg/{t}"
    for t in (
        "Float32",
        "Float64",
        "Int8",
        "Int16",
        "Int32",
        "Int64",
        "UInt8",
        "UInt16",
        "UInt32",
        "UInt64",
        "Byte",
        "Char",
    )
)
"""The std_msgs types whose value is one number (drawn in plots)."""
_STATE_TYPES = frozenset({"std_msgs/msg/Bool", "std_msgs/msg/String"})
_ARRAY_TYPE = re.compile(r"std_msgs/msg/(Float|Int|UInt)(8|16|32|64)MultiArray|std_msgs/msg/ByteMultiArray")
_FRACTION = re.compile(r"confidence|probability|prob|ratio|fraction|certainty|likelihood|score")
_PERCENT = re.compile(r"percent|pct|battery|charge|humidity|duty")
_ANGLE = re.compile(r"azimuth|heading|yaw|bearing|theta|direction|orientation")
_DEGREES = re.compile(r"deg")

MAX_PLOT_SERIES = 4
"""How many elements of an array (or numeric fields of a message) its plot shows."""
SERIES_PER_PLOT = 8
"""The most series of one panel's numbers a plot draws together (the Plot's `max_bindings`)."""
STATES_PER_WIDGET = 16
"""The most bools and texts one States widget shows (its `max_bindings`)."""
WIDGET_BUDGET = 100
"""The widgets the automatic dashboard aims to stay within: splitting a panel's plots by magnitude and
adding gauges stop before it. Every tag is bound whatever it costs, so many groups may pass it."""
LARGE_GROUP = 48
"""A group with more tags than this when its panel is first built is split one level deeper."""
SPREAD_DECADES = 1.0
"""Numbers whose magnitudes lie within this many decades (a factor of 10) are drawn in one plot."""

QUIET_S = 1.0
"""Tags are placed once the graph showed no new tag for this long (so a burst lands in natural order)..."""
MAX_WAIT_S = 6.0
"""... or once the oldest waiting tag has waited this long, however busy the graph."""
READY_COUNT = 10
"""A number's magnitude is known after this many samples..."""
READY_S = 1.5
"""... or this long after it was first offered, with at least one sample..."""
TAG_WAIT_S = 4.0
"""... or, with none, this long after (a silent tag, an array whose length never came, is placed anyway)."""

PANEL_TITLE_H = 26.0
"""The height of a panel's title band, above its widgets."""
PANEL_PAD = 8.0
"""The space between a panel's frame and its widgets (left, right, bottom)."""
PANEL_GAP = 14.0
"""The space between two panels."""

_SPAN = {"plot": 2, "states": 1, "compass": 1, "thermo": 1}
"""Cells (columns) a widget of each type takes in a panel; a States widget of many entries takes two."""


class TagKind(enum.StrEnum):
    """How a topic is shown."""

    NUMBER = "number"
    """A number: a series in one of its panel's plots (and maybe a gauge)."""
    STATE = "state"
    """A bool (a lamp) or a text (a line in the list) of its panel's States widget."""
    ARRAY = "array"
    """A ``*MultiArray``: a plot of its first elements of its own."""
    FIELDS = "fields"
    """Another message type (``--all``): a plot of its numeric fields of its own."""


@dataclass(frozen=True, slots=True)
class GroupKey:
    """A panel's group: a robot namespace and a path of the tags' names (``s3``, ``arm/joint1``)."""

    robot: str
    """``""`` for the root namespace, else ``/robot1``."""
    path: str
    """The shared first levels of the names; ``""`` for tags without a ``/``."""
    topics: bool = False
    """A group of other topics (``--all``), not of dbglog tags."""

    @property
    def title(self) -> str:
        """What the panel is called: ``robot1:s3``, ``s3``, ``robot1``, ``/turtle1`` (other topics)."""
        if self.topics:
            return "/" + self.path if self.path else "/"
        robot = robot_label(self.robot)
        if robot and self.path:
            return f"{robot}:{self.path}"
        return robot or self.path or "tags"

    def sort_key(self) -> tuple[object, ...]:
        """Robots in natural order (the root first), then tags before other topics, then the path."""
        return (natural_key(self.robot), self.topics, natural_key(self.path))


@dataclass(frozen=True, slots=True)
class AutoTag:
    """One topic as the automatic dashboard shows it."""

    topic: str
    kind: TagKind
    bindings: tuple[Binding, ...]
    """What its widget shows: the whole value, an array's elements, a message's fields."""
    robot: str = ""
    text: str = ""
    """The tag as logged (``s3/speed``); for another topic its name without the leading ``/``."""
    is_tag: bool = True
    gauge: tuple[str, dict[str, PropValue]] | None = None
    """The gauge its name suggests (type and properties), when there is room for one."""

    @property
    def label(self) -> str:
        """How the tag is shown: ``robot1:s3/speed``, ``s3/speed``, ``/turtle1/pose``."""
        if not self.is_tag:
            return self.topic
        robot = robot_label(self.robot)
        return f"{robot}:{self.text}" if robot else self.text

    @property
    def parts(self) -> list[str]:
        """The levels of its name (``["s3", "speed"]``)."""
        return [p for p in self.text.split("/") if p]

    def sort_key(self) -> tuple[object, ...]:
        """Natural order: by robot, then tags before other topics, then by the name."""
        return (natural_key(self.robot), not self.is_tag, natural_key(self.text))


@dataclass(frozen=True, slots=True)
class Observed:
    """What a tag's first values say (read by the UI from its series)."""

    count: int = 0
    """Samples so far."""
    extent: float | None = None
    """The largest absolute finite value seen (None: none yet)."""
    length: int | None = None
    """An array's length, once a message came."""


@dataclass(frozen=True, slots=True)
class AddWidget:
    """Add this widget to the canvas; `key` names it in later steps."""

    key: int
    config: WidgetConfig
    panel: str
    """The title of its panel."""


@dataclass(frozen=True, slots=True)
class SetBindings:
    """Give the widget `key` these bindings (it gained a series or a lamp)."""

    key: int
    bindings: tuple[Binding, ...]


Action = AddWidget | SetBindings


def is_array_type(msg_type: str) -> bool:
    """Whether `msg_type` is a std_msgs ``*MultiArray`` (its length is learnt from the first message)."""
    return _ARRAY_TYPE.fullmatch(msg_type) is not None


def _gauge_for(name: str) -> tuple[str, dict[str, PropValue]] | None:
    """The gauge a name suggests: a thermometer for a fraction or a percentage, a compass for an angle."""
    leaf = name.rstrip("/").rsplit("/", 1)[-1].lower()
    if _FRACTION.search(leaf):
        return "thermo", {"minimum": 0.0, "maximum": 1.0, "decimals": 2.0}
    if _PERCENT.search(leaf):
        return "thermo", {"minimum": 0.0, "maximum": 100.0, "unit": "%"}
    if _ANGLE.search(leaf):
        return "compass", {"units": "degrees" if _DEGREES.search(leaf) else "radians"}
    return None


def classify(
    info: TopicInfo,
    *,
    array_length: int | None = None,
    fields: Callable[[str], list[FieldInfo]] = lambda _topic: [],
) -> AutoTag | None:
    """Return how the automatic dashboard shows a topic, or None when nothing fits (yet).

    Args:
        info: the topic and its type from the graph.
        array_length: the number of elements the topic's arrays have, when known (from live data).
        fields: the topic's field paths (for messages that are not single std_msgs values).
    """
    if not info.types:
        return None
    msg_type = info.types[0]
    name = info.tag_name
    robot, text = (name.robot, name.text) if name is not None else ("", info.name.strip("/"))
    is_tag = name is not None
    whole = Binding(info.name)
    kind: TagKind
    bindings: tuple[Binding, ...]
    gauge = None
    if msg_type in _STATE_TYPES:
        kind, bindings = TagKind.STATE, (whole,)
    elif msg_type in NUMBER_TYPES:
        kind, bindings, gauge = TagKind.NUMBER, (whole,), _gauge_for(text)
    elif _ARRAY_TYPE.fullmatch(msg_type):
        n = max(1, min(MAX_PLOT_SERIES, array_length or 1))
        kind, bindings = TagKind.ARRAY, tuple(Binding(info.name, f"data[{i}]") for i in range(n))
    else:
        numeric = [f for f in fields(info.name) if f.numeric and "[" not in f.path][:MAX_PLOT_SERIES]
        if not numeric:
            return None
        kind, bindings = TagKind.FIELDS, tuple(Binding(info.name, f.path) for f in numeric)
    return AutoTag(info.name, kind, bindings, robot, text, is_tag, gauge)


def magnitude(extent: float | None) -> float:
    """The decade of a tag's largest absolute value (``log10``): 0 while unknown, -6 for zeros alone."""
    if extent is None or not math.isfinite(extent):
        return 0.0
    return math.log10(extent) if extent > 1e-6 else -6.0


def partition(magnitudes: Sequence[float], parts: int, cap: int) -> list[int]:
    """Cut sorted magnitudes into `parts` runs of at most `cap` each; return the runs' sizes.

    The cut keeps the widest run (in decades) as narrow as it can be, then the largest run as small.
    With too few parts for `cap`, the fewest that fit are used.

    Args:
        magnitudes: the numbers' magnitudes, in increasing order.
        parts: how many runs (plots) to make.
        cap: the most numbers a run may hold.
    """
    n = len(magnitudes)
    if n == 0:
        return []
    parts = max(parts, math.ceil(n / cap))
    parts = min(parts, n)
    inf = (math.inf, math.inf)
    # best[k][i]: the cost of cutting the first i numbers into k runs, and the size of the last run.
    best: list[list[tuple[float, float]]] = [[inf] * (n + 1) for _ in range(parts + 1)]
    last: list[list[int]] = [[0] * (n + 1) for _ in range(parts + 1)]
    best[0][0] = (0.0, 0.0)
    for k in range(1, parts + 1):
        for i in range(1, n + 1):
            for size in range(1, min(cap, i) + 1):
                prev = best[k - 1][i - size]
                if prev == inf:
                    continue
                spread = magnitudes[i - 1] - magnitudes[i - size]
                cost = (max(prev[0], spread), max(prev[1], size))
                if cost < best[k][i]:
                    best[k][i], last[k][i] = cost, size
    sizes, i = [], n
    for k in range(parts, 0, -1):
        sizes.append(last[k][i])
        i -= last[k][i]
    return sizes[::-1]


def _spread(magnitudes: Sequence[float], sizes: Sequence[int]) -> float:
    """The widest run in decades when `magnitudes` are cut into runs of `sizes`."""
    widest, start = 0.0, 0
    for size in sizes:
        widest = max(widest, magnitudes[start + size - 1] - magnitudes[start])
        start += size
    return widest


def _common_path(texts: Iterable[str]) -> str:
    """The levels every name shares before its last one (``s3/a/x``, ``s3/b`` -> ``s3``)."""
    paths = [t.split("/")[:-1] for t in texts]
    if not paths:
        return ""
    shared = paths[0]
    for p in paths[1:]:
        n = 0
        while n < min(len(shared), len(p)) and shared[n] == p[n]:
            n += 1
        shared = shared[:n]
    return "/".join(shared)


@dataclass(eq=False)
class PlannedWidget:
    """A widget the plan made: where it sits in its panel and what it shows."""

    key: int
    type: str
    name: str
    bindings: list[Binding]
    col: int
    row: int
    span: int
    magnitudes: list[float] = field(default_factory=list)
    """A numbers plot: each series' magnitude (the plot's range of magnitudes joins new tags)."""
    numbers: bool = False
    """A plot of its panel's numbers (which new numbers may join), not an array's or a message's."""


@dataclass(eq=False)
class Panel:
    """A titled frame on the canvas around one group's widgets, laid out in cells."""

    group: GroupKey
    title: str
    x: float
    y: float
    columns: int
    rows: int
    cell: tuple[float, float, float]
    """(cell width, cell height, gap) in pixels."""
    widgets: list[PlannedWidget] = field(default_factory=list)

    @property
    def rect(self) -> Rect:
        """The frame's rectangle in canvas pixels (title band included)."""
        cw, ch, gap = self.cell
        w = 2 * PANEL_PAD + self.columns * cw + (self.columns - 1) * gap
        h = PANEL_TITLE_H + self.rows * ch + max(0, self.rows - 1) * gap + PANEL_PAD
        return Rect(self.x, self.y, w, h)

    def cell_rect(self, col: int, row: int, span: int) -> Rect:
        """The rectangle of a widget `span` cells wide at (col, row) of the panel."""
        cw, ch, gap = self.cell
        return Rect(
            self.x + PANEL_PAD + col * (cw + gap),
            self.y + PANEL_TITLE_H + row * (ch + gap),
            span * cw + (span - 1) * gap,
            ch,
        )

    def taken(self, col: int, row: int, span: int) -> bool:
        """Whether one of the panel's widgets holds any of the cells (col..col+span-1, row)."""
        return any(w.row == row and w.col < col + span and col < w.col + w.span for w in self.widgets)


@dataclass
class _Pending:
    tag: AutoTag
    since: float


@dataclass
class _Content:
    """What a new panel will hold, before it is placed."""

    group: GroupKey
    numbers: list[tuple[AutoTag, float]]
    """Numbers and their magnitudes, in increasing magnitude."""
    others: list[AutoTag]
    """Arrays and messages: a plot each."""
    states: list[AutoTag]
    plots: int = 0
    """How many plots its numbers get."""
    gauges: bool = False


class AutoPlan:
    """Decides where every tag goes, once, and keeps each panel's layout; pure state, no canvas.

    Args:
        columns: the cells of a panel as wide as the canvas.
        cell_width / cell_height / gap: a cell's size and the space between cells, in pixels.
        origin: the top-left corner of the first panel.
        budget: the widgets the dashboard aims to stay within (`WIDGET_BUDGET`).
        quiet_s: how long the graph must show no new tag before tags are placed (`QUIET_S`; 0 for a
            recording, whose topics are all there at once).
        first_wait_s: nothing is placed before this long after the first `step` (the discovery horizon:
            robots already running are all on the graph by then, so the first panels come complete and in
            natural order; 0 for a recording, or a graph already known).
    """

    def __init__(
        self,
        *,
        columns: int = 6,
        cell_width: float = 190.0,
        cell_height: float = 190.0,
        gap: float = 10.0,
        origin: tuple[float, float] = (10.0, 10.0),
        budget: int = WIDGET_BUDGET,
        quiet_s: float = QUIET_S,
        first_wait_s: float = DISCOVERY_HORIZON_S,
    ) -> None:
        self.columns, self.cell_width, self.cell_height, self.gap = columns, cell_width, cell_height, gap
        self.origin = origin
        self.budget = budget
        self.quiet_s = quiet_s
        self.first_wait_s = first_wait_s
        self._started: float | None = None
        self.panels: list[Panel] = []
        self.version = 0
        """Changes whenever a panel is added or grows (the UI redraws the frames)."""
        self.made = 0
        """Widgets made so far."""
        self._known: set[str] = set()
        self._pending: dict[str, _Pending] = {}
        self._last_new = -math.inf
        self._split: set[GroupKey] = set()
        self._by_group: dict[GroupKey, list[Panel]] = {}
        self._widgets: dict[int, tuple[PlannedWidget, Panel]] = {}
        self._names: set[str] = set()
        self._shelf = (origin[1], 0.0, origin[0])
        """(top, height, next x) of the row of panels being filled."""

    # -- the canvas -----------------------------------------------------------------------------------

    def fit_width(self, width: float, *, min_cell: float = 180.0) -> None:
        """Use as many cells of at least `min_cell` pixels as fit a panel as wide as `width`."""
        usable = width - 2 * self.origin[0] - 2 * PANEL_PAD + self.gap
        self.columns = max(2, int(usable // (min_cell + self.gap)))
        self.cell_width = max(min_cell, usable / self.columns - self.gap)

    @property
    def right(self) -> float:
        """The right edge panels stay within."""
        full = 2 * PANEL_PAD + self.columns * self.cell_width + (self.columns - 1) * self.gap
        return self.origin[0] + full

    def skip_to(self, y: float) -> None:
        """Start the next panel at `y` or below (widgets already on the canvas stay above)."""
        top, height, _x = self._shelf
        self._shelf = (max(top + height + (PANEL_GAP if height else 0.0), y), 0.0, self.origin[0])

    # -- tags -----------------------------------------------------------------------------------------

    def known(self, topic: str) -> bool:
        """Whether `topic` was offered (placed or waiting)."""
        return topic in self._known

    def mark_known(self, topic: str) -> None:
        """Never place `topic` (it already has a widget, made before this plan)."""
        self._known.add(topic)

    def offer(self, tag: AutoTag, now: float) -> None:
        """Take a topic seen on the graph (once): it waits for its values, then `step` places it."""
        if tag.topic in self._known:
            return
        self._known.add(tag.topic)
        self._pending[tag.topic] = _Pending(tag, now)
        self._last_new = now

    def retag(self, tag: AutoTag) -> None:
        """Replace a waiting tag's description (an array's length became known)."""
        held = self._pending.get(tag.topic)
        if held is not None:
            held.tag = tag

    @property
    def waiting(self) -> list[AutoTag]:
        """The tags offered and not placed yet."""
        return [p.tag for p in self._pending.values()]

    def _ready(self, p: _Pending, seen: Observed | None, now: float) -> bool:
        waited = now - p.since
        if p.tag.kind is TagKind.NUMBER:
            count = seen.count if seen is not None else 0
            return count >= READY_COUNT or (count > 0 and waited >= READY_S) or waited >= TAG_WAIT_S
        if p.tag.kind is TagKind.ARRAY:
            return (seen is not None and seen.length is not None) or waited >= TAG_WAIT_S
        return True

    # -- placing --------------------------------------------------------------------------------------

    def step(
        self,
        now: float,
        observe: Callable[[AutoTag], Observed | None],
        *,
        alive: Callable[[int, tuple[Binding, ...]], bool] = lambda _key, _bindings: True,
        free: Callable[[Rect], bool] = lambda _rect: True,
    ) -> list[Action]:
        """Place the waiting tags once the graph is quiet and their values tell enough; return what to do.

        Args:
            now: the time (monotonic seconds).
            observe: what a waiting tag's values say so far (None: nothing to say, e.g. a bool).
            alive: whether the widget `key` is still on the canvas with exactly these bindings (a tag joins
                only such a widget: one the user changed or deleted is left as it is).
            free: whether a rectangle of the canvas holds no widget (the user's placed ones included).
        """
        if self._started is None:
            self._started = now
        if not self._pending or now - self._started < self.first_wait_s:
            return []
        seen = {topic: observe(p.tag) for topic, p in self._pending.items()}
        ready = {t for t, p in self._pending.items() if self._ready(p, seen[t], now)}
        oldest = min(p.since for p in self._pending.values())
        quiet = now - self._last_new >= self.quiet_s
        if not ((quiet and len(ready) == len(self._pending)) or (now - oldest >= MAX_WAIT_S and ready)):
            return []
        batch = sorted((self._pending.pop(t).tag for t in ready), key=AutoTag.sort_key)
        mags = {t: magnitude(s.extent if s is not None else None) for t, s in seen.items()}
        reserve = self._least_widgets(p.tag for p in self._pending.values())
        actions: list[Action] = []
        fresh: dict[GroupKey, list[AutoTag]] = {}
        for tag in batch:
            group = self._group_of(tag)
            if group in self._by_group:
                actions += self._join(tag, group, mags[tag.topic], alive, free)
            else:
                fresh.setdefault(group, []).append(tag)
        self._split_large(fresh)
        actions += self._build(fresh, mags, reserve, free)
        return actions

    def _group_of(self, tag: AutoTag) -> GroupKey:
        """The group a tag belongs to: its first level, deeper where that group was split."""
        parts = tag.parts
        depth = 1
        key = GroupKey(tag.robot, "/".join(parts[:depth]) if len(parts) > 1 else "", not tag.is_tag)
        while key in self._split and depth + 1 < len(parts):
            depth += 1
            key = GroupKey(tag.robot, "/".join(parts[:depth]), not tag.is_tag)
        return key

    def _split_large(self, fresh: dict[GroupKey, list[AutoTag]]) -> None:
        """Split each new group of more than `LARGE_GROUP` tags by its next level, as deep as needed."""
        changed = True
        while changed:
            changed = False
            for group, tags in list(fresh.items()):
                depth = len(group.path.split("/")) if group.path else 0
                if len(tags) <= LARGE_GROUP or not group.path or depth >= 4:
                    continue
                if not any(len(t.text.split("/")) > depth + 1 for t in tags):
                    continue  # every tag is a leaf of this level: nothing to split by
                self._split.add(group)
                del fresh[group]
                for tag in tags:
                    fresh.setdefault(self._group_of(tag), []).append(tag)
                changed = True

    def _least_widgets(self, tags: Iterable[AutoTag]) -> int:
        """The fewest widgets `tags` need (their numbers in full plots, their states in full lists)."""
        numbers = states = others = 0
        for tag in tags:
            if tag.kind is TagKind.NUMBER:
                numbers += 1
            elif tag.kind is TagKind.STATE:
                states += 1
            else:
                others += 1
        return math.ceil(numbers / SERIES_PER_PLOT) + math.ceil(states / STATES_PER_WIDGET) + others

    def _build(
        self,
        fresh: dict[GroupKey, list[AutoTag]],
        mags: dict[str, float],
        reserve: int,
        free: Callable[[Rect], bool],
    ) -> list[Action]:
        """Make the panels of new groups, in natural order; extras (more plots, gauges) while in budget."""
        contents = []
        for group in sorted(fresh, key=GroupKey.sort_key):
            tags = fresh[group]
            numbers = sorted(
                ((t, mags[t.topic]) for t in tags if t.kind is TagKind.NUMBER),
                key=lambda tm: (tm[1], tm[0].sort_key()),
            )
            others = [t for t in tags if t.kind in (TagKind.ARRAY, TagKind.FIELDS)]
            states = [t for t in tags if t.kind is TagKind.STATE]
            plots = math.ceil(len(numbers) / SERIES_PER_PLOT)
            contents.append(_Content(group, numbers, others, states, plots))
        least = sum(c.plots + len(c.others) + math.ceil(len(c.states) / STATES_PER_WIDGET) for c in contents)
        spare = self.budget - self.made - reserve - least
        # Extras come in rounds that every panel wanting one gets, or none does: panels alike look alike.
        while True:
            wanting = [c for c in contents if self._wants_split(c)]
            if not wanting or len(wanting) > spare:
                break
            for c in wanting:
                c.plots += 1
            spare -= len(wanting)
        gauges = sum(1 for c in contents for t, _m in c.numbers if t.gauge is not None)
        if gauges and gauges <= spare:
            for c in contents:
                c.gauges = True
        actions: list[Action] = []
        for c in contents:
            actions += self._make_panel(c, free)
        return actions

    @staticmethod
    def _wants_split(c: _Content) -> bool:
        """Whether a panel's numbers would be better apart: its plots span too many decades."""
        if c.plots >= len(c.numbers):
            return False
        magnitudes = [m for _t, m in c.numbers]
        return _spread(magnitudes, partition(magnitudes, c.plots, SERIES_PER_PLOT)) > SPREAD_DECADES

    def _make_panel(self, c: _Content, free: Callable[[Rect], bool]) -> list[Action]:
        """Lay out one new panel and place it on the canvas."""
        widgets: list[tuple[str, str, list[AutoTag], dict[str, PropValue], list[float], bool]] = []
        magnitudes = [m for _t, m in c.numbers]
        start = 0
        plots = []
        for size in partition(magnitudes, c.plots, SERIES_PER_PLOT):
            run = c.numbers[start : start + size]
            start += size
            plots.append((sorted((t for t, _m in run), key=AutoTag.sort_key), [m for _t, m in run]))
        for tags, mags in plots:
            widgets.append(("plot", self._plot_name(tags, c.group), tags, {}, mags, True))
        for tag in c.others:
            widgets.append(("plot", tag.label, [tag], {}, [], False))
        # The plots in the natural order of their first series, arrays and messages among them.
        widgets.sort(key=lambda w: w[2][0].sort_key())
        if c.gauges:
            for tag, _m in sorted(c.numbers, key=lambda tm: tm[0].sort_key()):
                if tag.gauge is not None:
                    widgets.append((tag.gauge[0], tag.label, [tag], dict(tag.gauge[1]), [], False))
        states = sorted(c.states, key=AutoTag.sort_key)
        for i in range(0, len(states), STATES_PER_WIDGET):
            chunk = states[i : i + STATES_PER_WIDGET]
            widgets.append(("states", f"{c.group.title} states", chunk, {}, [], False))
        spans = [self._span(kind, len(tags)) for kind, _n, tags, _p, _m, _num in widgets]
        if sum(spans) == self.columns - 1 and spans:
            # One cell short of the canvas: no other panel fits beside it, so its last widget takes the cell.
            spans[-1] += 1
        columns = min(self.columns, max(1, sum(spans)))
        cells: list[tuple[int, int]] = []
        col = row = 0
        for span in spans:
            if col + span > columns and col > 0:
                col, row = 0, row + 1
            cells.append((col, row))
            col += span
        panel = Panel(
            c.group,
            c.group.title,
            0.0,
            0.0,
            columns,
            (cells[-1][1] + 1) if cells else 1,
            (self.cell_width, self.cell_height, self.gap),
        )
        self._place_panel(panel, free)
        actions: list[Action] = []
        for (kind, name, tags, props, mags, numbers), span, (col, row) in zip(
            widgets, spans, cells, strict=True
        ):
            bindings = [b for t in tags for b in t.bindings]
            planned = PlannedWidget(
                self._next_key(), kind, name, bindings, col, row, span, list(mags), numbers
            )
            actions.append(self._add(planned, panel, props))
        return actions

    def _plot_name(self, tags: Sequence[AutoTag], group: GroupKey) -> str:
        """A plot's title: its tag when alone, else the path its tags share (at least the group's)."""
        if len(tags) == 1:
            return tags[0].label
        path = _common_path(t.text for t in tags)
        if group.topics:
            return "/" + path if path else group.title
        return GroupKey(group.robot, path).title if path else group.title

    @staticmethod
    def _span(kind: str, entries: int) -> int:
        if kind == "states":
            return 1 if entries <= 6 else 2
        return _SPAN.get(kind, 1)

    def _next_key(self) -> int:
        self.made += 1
        return self.made

    def _add(self, planned: PlannedWidget, panel: Panel, props: dict[str, PropValue]) -> AddWidget:
        if planned.type in (
            "plot",
            "states",
        ):  # a panel's second plot is "s3 2" (a gauge is named by its tag)
            name, n = planned.name, 1
            while name in self._names:
                n += 1
                name = f"{planned.name} {n}"
            planned.name = name
        self._names.add(planned.name)
        panel.widgets.append(planned)
        self._widgets[planned.key] = (planned, panel)
        self.version += 1
        r = panel.cell_rect(planned.col, planned.row, planned.span)
        config = WidgetConfig(planned.type, planned.name, r.x, r.y, r.w, r.h, tuple(planned.bindings), props)
        return AddWidget(planned.key, config, panel.title)

    def _clear_of_panels(self, rect: Rect, but: Panel | None = None) -> bool:
        return not any(p is not but and overlaps(p.rect, rect) for p in self.panels)

    def _place_panel(self, panel: Panel, free: Callable[[Rect], bool]) -> None:
        """Put a new panel to the right of the last one, or below them all: where its frame is free."""
        top, height, x = self._shelf
        step = self.cell_height + self.gap
        for _ in range(10_000):  # bounded: every miss moves on
            panel.x, panel.y = x, top
            rect = panel.rect
            if x > self.origin[0] and x + rect.w > self.right + 0.5:
                top, height, x = top + max(height + PANEL_GAP, step), 0.0, self.origin[0]
                continue
            if self._clear_of_panels(rect) and free(rect):
                break
            x += self.cell_width + self.gap
            if x + rect.w > self.right + 0.5:
                top, height, x = top + max(height + PANEL_GAP, step), 0.0, self.origin[0]
        self.panels.append(panel)
        self._by_group.setdefault(panel.group, []).append(panel)
        self._shelf = (top, max(height, panel.rect.h), x + panel.rect.w + PANEL_GAP)
        self.version += 1

    # -- tags that come later -------------------------------------------------------------------------

    def _join(
        self,
        tag: AutoTag,
        group: GroupKey,
        mag: float,
        alive: Callable[[int, tuple[Binding, ...]], bool],
        free: Callable[[Rect], bool],
    ) -> list[Action]:
        """A tag of a group that has its panel: it joins a widget there, or gets a new one in the panel."""
        panels = self._by_group[group]
        mine = [(w, p) for p in panels for w in p.widgets if alive(w.key, tuple(w.bindings))]
        actions: list[Action] = []
        if tag.kind is TagKind.NUMBER:
            plots = [w for w, _p in mine if w.numbers and len(w.bindings) < SERIES_PER_PLOT]
            nearest = min(plots, key=lambda w: (_distance(w.magnitudes, mag), len(w.bindings)), default=None)
            room = self.made + 1 <= self.budget
            if nearest is not None and (_distance(nearest.magnitudes, mag) <= SPREAD_DECADES or not room):
                nearest.magnitudes.append(mag)
                actions.append(self._extend(nearest, tag))
            else:
                actions.append(self._new_in(group, "plot", tag.label, [tag], {}, [mag], True, free))
            if tag.gauge is not None and self.made + 1 <= self.budget:
                kind, props = tag.gauge
                actions.append(self._new_in(group, kind, tag.label, [tag], dict(props), [], False, free))
        elif tag.kind is TagKind.STATE:
            lists = [(w, p) for w, p in mine if w.type == "states" and len(w.bindings) < STATES_PER_WIDGET]
            if lists:
                actions.append(self._extend(lists[0][0], tag))
            else:
                name = f"{group.title} states"
                actions.append(self._new_in(group, "states", name, [tag], {}, [], False, free))
        else:
            actions.append(self._new_in(group, "plot", tag.label, [tag], {}, [], False, free))
        return actions

    def _extend(self, w: PlannedWidget, tag: AutoTag) -> SetBindings:
        """Add `tag`'s series to a widget, the series kept in natural order."""
        by_topic: dict[str, list[Binding]] = {}
        for b in [*w.bindings, *tag.bindings]:
            by_topic.setdefault(b.topic, []).append(b)
        order = sorted(by_topic, key=lambda topic: _topic_key(topic))
        w.bindings = [b for topic in order for b in by_topic[topic]]
        self.version += 1
        return SetBindings(w.key, tuple(w.bindings))

    def _new_in(
        self,
        group: GroupKey,
        kind: str,
        name: str,
        tags: list[AutoTag],
        props: dict[str, PropValue],
        mags: list[float],
        numbers: bool,
        free: Callable[[Rect], bool],
    ) -> AddWidget:
        """A new widget in a group's panel: in a free cell of it, in a row added below it, or in a new panel
        of the same group when the space below is taken."""
        span = min(self._span(kind, sum(len(t.bindings) for t in tags)), self.columns)
        bindings = [b for t in tags for b in t.bindings]
        for panel in reversed(self._by_group[group]):
            span_here = min(span, panel.columns)
            for row in range(panel.rows):
                for col in range(panel.columns - span_here + 1):
                    if not panel.taken(col, row, span_here) and free(panel.cell_rect(col, row, span_here)):
                        planned = PlannedWidget(
                            self._next_key(), kind, name, bindings, col, row, span_here, mags, numbers
                        )
                        return self._add(planned, panel, props)
            if panel.columns + span <= self.columns:  # a column more at its right, where that is free
                strip = panel.cell_rect(panel.columns, 0, span)
                strip = Rect(strip.x, panel.y, strip.w + PANEL_PAD, panel.rect.h)
                panel.columns += span
                fits = panel.rect.x + panel.rect.w <= self.right + 0.5
                if fits and self._clear_of_panels(panel.rect, panel) and free(strip):
                    planned = PlannedWidget(
                        self._next_key(), kind, name, bindings, panel.columns - span, 0, span, mags, numbers
                    )
                    return self._add(planned, panel, props)
                panel.columns -= span
            below = panel.cell_rect(0, panel.rows, panel.columns)
            grown = Rect(panel.x, below.y, panel.rect.w, below.h + PANEL_PAD)
            if self._clear_of_panels(grown, panel) and free(grown):
                panel.rows += 1
                planned = PlannedWidget(
                    self._next_key(), kind, name, bindings, 0, panel.rows - 1, span_here, mags, numbers
                )
                return self._add(planned, panel, props)
        panel = Panel(
            group, group.title, 0.0, 0.0, max(span, 1), 1, (self.cell_width, self.cell_height, self.gap)
        )
        self._place_panel(panel, free)
        planned = PlannedWidget(self._next_key(), kind, name, bindings, 0, 0, span, mags, numbers)
        return self._add(planned, panel, props)

    # -- what the report and the frames show ----------------------------------------------------------

    def panel_of(self, key: int) -> Panel | None:
        """The panel that widget `key` was placed in."""
        held = self._widgets.get(key)
        return held[1] if held is not None else None


def _distance(magnitudes: Sequence[float], mag: float) -> float:
    """How many decades `mag` lies outside the range of `magnitudes` (0 inside; infinite when empty)."""
    if not magnitudes:
        return math.inf
    lo, hi = min(magnitudes), max(magnitudes)
    return max(0.0, lo - mag, mag - hi)


def _topic_key(topic: str) -> tuple[object, ...]:
    """A topic's place in natural order (dbglog tags by robot and text)."""
    info = TopicInfo(topic, ())
    name = info.tag_name
    if name is None:
        return ((), True, natural_key(topic))
    return (natural_key(name.robot), False, natural_key(name.text))


def retype(
    config: WidgetConfig, cls: type[Widget], *, min_frame: tuple[float, float] | None = None
) -> WidgetConfig:
    """Return `config` as a widget of another kind: same name, place and (as many) bindings.

    Properties the new kind declares too (a range, a unit, a colour) keep their values when valid
    there; the rest start at the new kind's defaults.

    Args:
        config: the widget as it is.
        cls: the new widget class.
        min_frame: the smallest frame (width, height) the new kind fits in; the size grows to it.
    """
    props = cls.default_properties()
    for name, value in config.properties.items():
        declared = cls.property_named(name)
        if declared is None:
            continue
        try:
            props[name] = declared.validate(value)
        except PropertyError:
            continue
    width, height = config.width, config.height
    if min_frame is not None:
        width, height = max(width, min_frame[0]), max(height, min_frame[1])
    return replace(
        config,
        type=cls.type_name,
        width=width,
        height=height,
        bindings=config.bindings[: max(1, cls.max_bindings)],
        properties=props,
    )
