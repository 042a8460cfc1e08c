"""The automatic dashboard: a suggested widget for every discovered tag, placed on a tidy grid.

Pure logic (no ROS, no Dear PyGui): the UI feeds it the graph's topics as they appear and adds the
widgets it returns. Numbers get a plot (and a gauge where the name tells the range), bools an LED,
strings a text widget, arrays a plot of their elements; a dict's sub-tags share a row.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Iterable
from dataclasses import dataclass, field, replace

from dbglog.viewer._data._model import Binding, FieldInfo, TopicInfo
from dbglog.viewer._document._dashboard import WidgetConfig
from dbglog.viewer.widget_api import PropertyError, PropValue, Widget

__all__ = ["AutoLayout", "Suggestion", "is_array_type", "retype", "suggest"]

_NUMBER_TYPES = frozenset(
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
_ARRAY_TYPE = re.compile(r"std_msgs/msg/(Float|Int|UInt)(8|16|32|64)MultiArray|std_msgs/msg/ByteMultiArray")
_FRACTION = re.compile(r"confidence|probability|prob|ratio|fraction|certainty|likelihood|score")
_PERCENT = re.compile(r"percent|pct|battery|charge|humidity|duty")
_ANGLE = re.compile(r"azimuth|heading|yaw|bearing|theta|direction|orientation")
_DEGREES = re.compile(r"deg")
MAX_PLOT_SERIES = 4
"""How many elements of an array (or numeric fields of a message) one suggested plot shows."""


@dataclass(frozen=True, slots=True)
class Suggestion:
    """One suggested widget for a topic, before it has a place."""

    type: str
    """The widget type name (``plot``, ``compass``, ``thermo``, ``led``, ``string`` ...)."""
    name: str
    bindings: tuple[Binding, ...]
    properties: dict[str, PropValue] = field(default_factory=dict)
    group: str = ""
    """Suggestions of one group (a dict's sub-tags) are placed together."""


def is_array_type(msg_type: str) -> bool:
    """Whether `msg_type` is a std_msgs ``*MultiArray`` (its length is learnt from the first message)."""
    return _ARRAY_TYPE.fullmatch(msg_type) is not None


def _leaf(name: str) -> str:
    return name.rstrip("/").rsplit("/", 1)[-1].lower()


def _gauge_for(name: str, binding: Binding) -> Suggestion | None:
    leaf = _leaf(name)
    if _FRACTION.search(leaf):
        return Suggestion("thermo", name, (binding,), {"minimum": 0.0, "maximum": 1.0, "decimals": 2.0})
    if _PERCENT.search(leaf):
        return Suggestion("thermo", name, (binding,), {"minimum": 0.0, "maximum": 100.0, "unit": "%"})
    if _ANGLE.search(leaf):
        units = "degrees" if _DEGREES.search(leaf) else "radians"
        return Suggestion("compass", name, (binding,), {"units": units})
    return None


def suggest(
    info: TopicInfo,
    *,
    array_length: Callable[[str], int | None] = lambda _topic: None,
    fields: Callable[[str], list[FieldInfo]] = lambda _topic: [],
) -> list[Suggestion]:
    """Return the widgets suggested for one topic (empty when nothing fits).

    Args:
        info: the topic and its type from the graph.
        array_length: the number of elements the topic's arrays have, when known (from live data).
        fields: the topic's field paths (for messages that are not single std_msgs values).
    """
    if not info.types:
        return []
    msg_type = info.types[0]
    tag = info.tag
    name = tag if tag is not None else info.name
    group = name.rsplit("/", 1)[0] if "/" in name else ""
    whole = Binding(info.name)
    out: list[Suggestion] = []
    if msg_type == "std_msgs/msg/Bool":
        out.append(Suggestion("led", name, (whole,)))
    elif msg_type == "std_msgs/msg/String":
        out.append(Suggestion("string", name, (whole,)))
    elif msg_type in _NUMBER_TYPES:
        out.append(Suggestion("plot", name, (whole,)))
        gauge = _gauge_for(name, whole)
        if gauge is not None:
            out.append(gauge)
    elif _ARRAY_TYPE.fullmatch(msg_type):
        n = max(1, min(MAX_PLOT_SERIES, array_length(info.name) or 1))
        out.append(Suggestion("plot", name, tuple(Binding(info.name, f"data[{i}]") for i in range(n))))
    else:
        numeric = [f for f in fields(info.name) if f.numeric and "[" not in f.path][:MAX_PLOT_SERIES]
        if numeric:
            out.append(Suggestion("plot", name, tuple(Binding(info.name, f.path) for f in numeric)))
    return [Suggestion(s.type, s.name, s.bindings, s.properties, group) for s in out]


_SIZES: dict[str, tuple[float, float]] = {
    "plot": (2, 1),
    "compass": (1, 1),
    "dial": (1, 1),
    "knob": (1, 1),
    "thermo": (1, 1),
    "led": (1, 1),
    "string": (2, 1),
}
"""Cells (columns, rows) each widget type takes on the grid; unknown types take one cell."""


@dataclass
class AutoLayout:
    """Places suggestions on a grid, incrementally: tags seen later never move earlier widgets.

    Each group (the sub-tags of one dict, or all top-level tags) claims whole rows in order of first
    appearance and fills them left to right; a full row makes the group claim the next free row.
    """

    columns: int = 6
    cell_width: float = 240.0
    cell_height: float = 190.0
    gap: float = 10.0
    origin: tuple[float, float] = (10.0, 10.0)
    _seen: set[str] = field(default_factory=set)
    _rows: int = 0
    _cursor: dict[str, tuple[int, int]] = field(default_factory=dict)
    """group -> (row, next free column) of the group's current row."""

    def seen(self, topic: str) -> bool:
        """Whether widgets were already made for `topic`."""
        return topic in self._seen

    def add(
        self,
        suggestions: Iterable[Suggestion],
        topic: str,
        *,
        free: Callable[[float, float, float, float], bool] | None = None,
    ) -> list[WidgetConfig]:
        """Place the suggestions for `topic` (once per topic) and return them as widget configs.

        Args:
            suggestions: what `suggest` returned for the topic.
            topic: the topic's name (a topic is placed only once).
            free: tells whether the rectangle (x, y, width, height) is free on the canvas; cells taken
                by widgets the user moved there are skipped, so nothing placed earlier ever moves.
        """
        if topic in self._seen:
            return []
        self._seen.add(topic)
        placed = []
        for s in suggestions:
            span = min(int(_SIZES.get(s.type, (1, 1))[0]), self.columns)
            width = span * self.cell_width + (span - 1) * self.gap
            for _ in range(10_000):  # bounded: every miss moves the cursor on
                row, col = self._slot(s.group, span)
                x = self.origin[0] + col * (self.cell_width + self.gap)
                y = self.origin[1] + row * (self.cell_height + self.gap)
                if free is None or free(x, y, width, self.cell_height):
                    break
            placed.append(
                WidgetConfig(s.type, s.name, x, y, width, self.cell_height, s.bindings, dict(s.properties))
            )
        return placed

    def _slot(self, group: str, span: int) -> tuple[int, int]:
        row, col = self._cursor.get(group, (-1, self.columns))
        if col + span > self.columns:
            row, col = self._rows, 0
            self._rows += 1
        self._cursor[group] = (row, col + span)
        return row, col

    def fit_columns(self, width: float, *, min_cell: float = 180.0) -> None:
        """Use as many columns of at least `min_cell` pixels as fit `width`, widened to fill it exactly."""
        usable = width - 2 * self.origin[0] + self.gap
        self.columns = max(2, int(usable // (min_cell + self.gap)))
        self.cell_width = max(min_cell, usable / self.columns - self.gap)

    def skip_rows(self, rows: int) -> None:
        """Leave `rows` rows free at the top (for widgets that were already on the canvas)."""
        self._rows = max(self._rows, rows)


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
