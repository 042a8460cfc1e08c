"""Plain data shared by the viewer's data engine and its UI: bindings, snapshots, topics, fields.

No ROS and no Dear PyGui here: the engine produces these, the UI and the terminal consume them.
"""

from __future__ import annotations

import enum
from dataclasses import dataclass, field, replace
from typing import Protocol

import numpy as np
import numpy.typing as npt

from dbglog._ros._params import split_name
from dbglog._ros._tags import TagName, parse_topic, tag_of
from dbglog.viewer._values._transforms import Transform

__all__ = [
    "EVERY_ROBOT",
    "SELECTED_ROBOT",
    "Binding",
    "DataSource",
    "FieldInfo",
    "SeriesSnapshot",
    "Status",
    "TopicInfo",
    "ValueKind",
    "judge_age",
]


class Status(enum.StrEnum):
    """Where a series stands, shown on every widget."""

    WAITING = "waiting"
    """The topic is not published (yet)."""
    LIVE = "live"
    """Messages are arriving."""
    STALE = "stale"
    """No message for longer than the stale time."""
    ERROR = "error"
    """Data arrives but cannot be turned into values; the snapshot's ``reason`` says why."""


class ValueKind(enum.StrEnum):
    """What kind of value a series holds; numbers and bools also fill the numeric arrays."""

    NUMBER = "number"
    BOOL = "bool"
    TEXT = "text"
    ARRAY = "array"


SELECTED_ROBOT = "$selected"
"""`Binding.robot` of a binding that follows the robot the viewer's switcher selects."""
EVERY_ROBOT = "$every"
"""`Binding.robot` of a binding with one series per robot (an overlay across robots)."""


@dataclass(frozen=True, slots=True)
class Binding:
    """A topic, a field path inside its messages (``""`` = the whole single-valued message), a regex.

    A robot-relative binding (`robot` set) names its topic as in the root namespace (``/rosdashboard/speed``,
    ``/odom``): the dashboard resolves it to each robot's own topic (``/robot1/rosdashboard/speed``) before
    a data source sees it (`dbglog.viewer._data._robots.Fleet`).
    """

    topic: str
    field: str = ""
    regex: str = ""
    transforms: tuple[Transform, ...] = ()
    """The binding's transforms, in order (frozen values, so a binding stays hashable); applied by the engine
    at ingest (docs/transforms.md). A rejected list from a file is one `Invalid`, shown as the error."""
    node: str = ""
    """Log topics (``rcl_interfaces/msg/Log``): only lines of this logger, exact name or fnmatch glob
    (``planner*``), as a bridge rule's ``node``; empty: every node."""
    level: str = ""
    """Log topics: only lines at this level or above (``debug``, ``info``, ``warn``, ``error``, ``fatal``),
    as a bridge rule's ``level``; empty: every level."""
    robot: str = ""
    """``""``: the topic as written; `SELECTED_ROBOT`: in the namespace of the robot the viewer selects;
    `EVERY_ROBOT`: in every robot's namespace that has it (one series each)."""

    @property
    def parameter(self) -> tuple[str, str] | None:
        """The node and the parameter of a binding to a node's parameter, None for a topic: a topic written
        ``NODE:PARAMETER`` (``/pid_node:kp`` -> ``("/pid_node", "kp")``; no topic name has a colon) is one,
        which a widget that declares ``parameters`` shows and sets."""
        if ":" not in self.topic:
            return None
        try:
            return split_name(self.topic)
        except ValueError:
            return None


def judge_age(age_s: float, stale_after: float) -> tuple[Status, str]:
    """Return LIVE, or STALE with its reason, for a series whose last message is `age_s` old."""
    if age_s > stale_after:
        return Status.STALE, f"no message for {age_s:.1f} s"
    return Status.LIVE, ""


@dataclass(frozen=True, slots=True)
class SeriesSnapshot:
    """A consistent copy of one series at one moment, safe to read on any thread."""

    binding: Binding
    status: Status
    reason: str = ""
    """Why the status is ERROR (or WAITING), for a tooltip."""
    kind: ValueKind | None = None
    msg_type: str | None = None
    """The ROS type, e.g. ``std_msgs/msg/Float64``, once known from the graph."""
    times: npt.NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    """Source timestamps (seconds since the epoch), oldest first."""
    values: npt.NDArray[np.float64] = field(default_factory=lambda: np.empty(0))
    """Numeric values (bools as 0/1) aligned with ``times``; empty for text series."""
    texts: tuple[str, ...] = ()
    """Recent text values, oldest first (text series only)."""
    last: float | int | bool | str | tuple[float, ...] | None = None
    """The latest value with its kind kept (array series: a tuple of numbers)."""
    last_time: float | None = None
    rate_hz: float = 0.0
    """Messages per second over the last few seconds."""
    age_s: float | None = None
    """Seconds since the latest message (None before the first)."""
    count: int = 0
    """Messages taken into this series so far; grows monotonically, so a reader can skip redraws."""

    def with_stale_time(self, stale_after: float) -> SeriesSnapshot:
        """Return the snapshot judged live or stale by another stale time (e.g. a widget's own)."""
        if self.status not in (Status.LIVE, Status.STALE) or self.age_s is None:
            return self
        status, reason = judge_age(self.age_s, stale_after)
        return self if status is self.status else replace(self, status=status, reason=reason)


@dataclass(frozen=True, slots=True)
class TopicInfo:
    """A topic seen on the ROS graph."""

    name: str
    types: tuple[str, ...]
    publishers: int = 0

    @property
    def tag(self) -> str | None:
        """The dbglog tag of a ``[/<robot>]/rosdashboard/`` topic as shown: the user's own text, with its
        robot (``robot1:speed``) in a robot's namespace (`TagName.label`); None for any other topic."""
        return tag_of(self.name)

    @property
    def tag_name(self) -> TagName | None:
        """The robot namespace and tag of a dbglog topic (`parse_topic`), None for any other topic."""
        return parse_topic(self.name)

    @property
    def robot(self) -> str:
        """The robot namespace of a dbglog topic (``/robot1``; ``""`` for the root and other topics)."""
        name = parse_topic(self.name)
        return name.robot if name is not None else ""


@dataclass(frozen=True, slots=True)
class FieldInfo:
    """One field path of a message type, for the topic setup dialog."""

    path: str
    """e.g. ``pose.position.z`` or ``ranges[]`` for a sequence."""
    type_name: str
    """The ROS field type, e.g. ``double``, ``string``, ``sequence<float>``, ``geometry_msgs/Vector3``."""
    numeric: bool
    """True when a binding to this path yields numbers or bools."""


class DataSource(Protocol):
    """What the UI and the terminal commands need from the data engine."""

    def bind(self, binding: Binding) -> None:
        """Start filling a series for `binding` (idempotent, never blocks)."""

    def unbind(self, binding: Binding) -> None:
        """Stop filling the series for `binding` and free it."""

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Return the current state of the series for `binding`."""

    def topics(self) -> list[TopicInfo]:
        """Return every topic on the graph, sorted by name."""

    def fields(self, topic: str) -> list[FieldInfo]:
        """Return the field paths of the topic's message type (empty while the type is unknown)."""
