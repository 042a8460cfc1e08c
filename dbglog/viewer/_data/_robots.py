"""Robots: the namespaces the viewer discovers, which one is selected, and robot-relative bindings resolved.

A lab runs several identical robots, each in its namespace (``/robot1/rosdashboard/speed``, ...; docs/api.md
*Robots*). A dashboard binding may follow "the selected robot" (`SELECTED_ROBOT`) or show "every robot"
(`EVERY_ROBOT`, one series each); its topic is written as in the root namespace. `Fleet` knows the robots
seen (in the order they appeared), the topics of each, and the selection, and turns such bindings into the
concrete ones a data source fills. Pure Python over `TopicInfo` lists and a `History`: no ROS, no Dear PyGui.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, replace

from dbglog._ros._tags import natural_key, normalize_robot, parse_topic, robot_label
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding, Status, TopicInfo

__all__ = [
    "NO_NAMESPACE",
    "ROBOT_MODES",
    "Fleet",
    "RobotState",
    "is_relative",
    "parse_robot",
    "relative_to",
    "resolve",
    "robot_name",
    "robot_of",
    "topic_rate",
]

NO_NAMESPACE = "(no namespace)"
"""How the robot without a namespace (the plain ``/rosdashboard/`` tags) is named."""
ROBOT_MODES = ("", SELECTED_ROBOT, EVERY_ROBOT)
"""The values `Binding.robot` may have: the topic as written, the selected robot's, every robot's."""
SETTLE_S = 3.0
"""Until a robot is chosen, the selection follows the first robot this long after the first is seen."""
RATE_WINDOW_S = 5.0
"""A topic's rate is counted over this many seconds before the moment shown."""


def robot_name(robot: str) -> str:
    """How a robot is shown: ``robot1``, ``lab/robot1``, or ``(no namespace)`` for the root."""
    return robot_label(robot) or NO_NAMESPACE


def parse_robot(text: str) -> str:
    """Read a robot as a user names it (``robot1``, ``/lab/robot1``; ``/``, ``""`` or ``(no namespace)`` for
    the root) into its namespace (``/robot1``, ``""``).

    Raises:
        TagError: not a namespace dbglog's topics can be in; the message says why.
    """
    if text.strip() == NO_NAMESPACE:
        return ""
    return normalize_robot(text)


def is_relative(binding: Binding) -> bool:
    """Whether `binding` is resolved per robot (it follows the selected robot, or shows every robot)."""
    return binding.robot in (SELECTED_ROBOT, EVERY_ROBOT)


def resolve(binding: Binding, robot: str) -> Binding:
    """The concrete binding of a robot-relative one in `robot`'s namespace (``""``: the root)."""
    return replace(binding, topic=robot + binding.topic, robot="")


def robot_of(topic: str, robots: Iterable[str] = ()) -> str:
    """The robot a topic belongs to: a dbglog tag's namespace, else the longest of `robots` the topic lies
    in (``/robot1/odom`` -> ``/robot1``), else the root (``""``)."""
    name = parse_topic(topic)
    if name is not None:
        return name.robot
    best = ""
    for robot in robots:
        if robot and topic.startswith(robot + "/") and len(robot) > len(best):
            best = robot
    return best


def relative_to(binding: Binding, mode: str, robots: Iterable[str] = ()) -> Binding:
    """`binding` (a concrete topic) made robot-relative (`mode`: `SELECTED_ROBOT` or `EVERY_ROBOT`), or
    concrete again (``""``): the topic loses the namespace of the robot it belongs to (`robot_of`).

    Raises:
        ValueError: `mode` is none of `ROBOT_MODES`.
    """
    if mode not in ROBOT_MODES:
        raise ValueError(f"robot mode must be one of {ROBOT_MODES}, not {mode!r}")
    if not mode:
        return replace(binding, robot="")
    topic = binding.topic if binding.topic.startswith("/") else "/" + binding.topic
    robot = robot_of(topic, robots)
    return replace(binding, topic=topic[len(robot) :], robot=mode)


def topic_rate(
    store: History, topic: str, t: float, window: float = RATE_WINDOW_S
) -> tuple[float, float | None]:
    """A topic's messages a second over the `window` seconds before `t`, and the time of its last message
    at or before `t` (None: none held); from the history, two searches whatever the topic's size."""
    last = store.at(topic, t)
    if last is None:
        return 0.0, None
    before = store.at(topic, t - window)
    n = last.index - (before.index if before is not None else -1)
    return (n / window if n > 1 else 0.0), last.time


@dataclass(frozen=True, slots=True)
class RobotState:
    """A robot as the switcher lists it: its status at the moment shown, its tags, its newest message."""

    robot: str
    status: Status
    """LIVE (a tag sent within the stale time), STALE, or WAITING (no message of its tags held)."""
    tags: int
    """Its dbglog tags seen (on the graph or in the history)."""
    newest: float | None
    """Source time of its newest message held (None: none)."""

    @property
    def name(self) -> str:
        """How the robot is shown."""
        return robot_name(self.robot)


class Fleet:
    """The robots the viewer has seen, their topics, and which robot is selected.

    Robots are the namespaces of dbglog tags (`parse_topic`), the root included when it has tags, in natural
    order (``robot2`` before ``robot10``). One seen is never forgotten: a robot that stops publishing stays
    listed (stale). Until a robot is chosen (`select`, ``dbglog view --robot``), the first robot with a
    namespace in natural order is selected (the root while there is none): for `SETTLE_S` after the first
    robot is seen (discovery brings robot1 and robot2 a moment apart), then it stays.

    Args:
        selected: the robot to start with (a namespace: ``/robot1``, ``""``); None: the first seen.
        clock: monotonic seconds.
    """

    def __init__(self, selected: str | None = None, *, clock: Callable[[], float] = time.monotonic) -> None:
        self.selected = selected if selected is not None else ""
        """The namespace bindings that follow the selected robot resolve in (``""``: the root)."""
        self.chosen = selected is not None
        """Whether the selection was chosen (else it follows the first robot seen)."""
        self.robots: list[str] = []
        """Every robot seen, in natural order."""
        self.topics: frozenset[str] = frozenset()
        """Every topic name seen (the graph's and the history's)."""
        self.infos: tuple[TopicInfo, ...] = ()
        """The graph's topics at the last `observe`."""
        self.tags: dict[str, list[str]] = {}
        """Robot -> the topics of its dbglog tags."""
        self.version = 0
        """Grows whenever what the relative bindings resolve to may change (selection, robots, topics)."""
        self._names: tuple[str, ...] = ()
        self._clock = clock
        self._first_seen: float | None = None
        """When the first robot was seen (the automatic selection settles `SETTLE_S` later)."""
        self._every: dict[Binding, list[str]] = {}
        """An every-robot binding -> the robots that have its topic, in the order they first did (its series'
        order: a robot that appears later is added at the end, and no series changes colour)."""

    # -- what was discovered --------------------------------------------------------------------------

    def observe(self, infos: Sequence[TopicInfo], held: Iterable[str] = ()) -> bool:
        """Take the graph's topics and the topics a history holds (gone robots' too); True when it changed.

        Cheap when nothing changed (the names compare equal), so it may be called a few times a second.
        """
        held_names = sorted(n for n in held if n.startswith("/"))
        names = tuple(i.name for i in infos) + tuple(held_names)
        if names == self._names:
            self.infos = tuple(infos)
            return False
        self._names = names
        self.infos = tuple(infos)
        self.topics = frozenset(names)
        tags: dict[str, list[str]] = {}
        for name in dict.fromkeys(names):
            tag = parse_topic(name)
            if tag is not None:
                tags.setdefault(tag.robot, []).append(name)
        self.tags = tags
        self.robots = sorted(set(self.robots) | set(tags), key=natural_key)
        if self.robots and not self.chosen:
            now = self._clock()
            if self._first_seen is None:
                self._first_seen = now
            settling = now - self._first_seen <= SETTLE_S
            if settling or self.selected not in tags or not self.selected:
                self.selected = next((r for r in self.robots if r), self.robots[0])
        self.version += 1
        return True

    def select(self, robot: str) -> bool:
        """Select `robot` (a namespace; one not seen yet is selected all the same); True when it changed."""
        self.chosen = True
        if robot == self.selected:
            return False
        self.selected = robot
        self.version += 1
        return True

    def step(self, direction: int) -> bool:
        """Select the next (+1) or previous (-1) robot in the list, round; True when it changed."""
        if not self.robots:
            return False
        at = self.robots.index(self.selected) if self.selected in self.robots else -direction
        return self.select(self.robots[(at + direction) % len(self.robots)])

    @property
    def namespaced(self) -> bool:
        """Whether some robot has a namespace (with the root alone, there is nothing to switch)."""
        return any(self.robots)

    # -- resolving ------------------------------------------------------------------------------------

    def expand(self, binding: Binding) -> tuple[Binding, ...]:
        """The concrete bindings of `binding`: itself; the selected robot's; or every robot's that has the
        topic (in the order they got it; the selected robot's while none has it yet)."""
        if binding.robot == SELECTED_ROBOT:
            return (resolve(binding, self.selected),)
        if binding.robot != EVERY_ROBOT:
            return (binding,)
        seen = self._every.setdefault(binding, [])
        have = [r for r in self.robots if r not in seen and r + binding.topic in self.topics]
        seen.extend(have)
        if not seen:
            return (resolve(binding, self.selected),)
        return tuple(resolve(binding, r) for r in seen)

    def expand_all(self, bindings: Iterable[Binding]) -> tuple[Binding, ...]:
        """Every concrete binding of `bindings`, in order, each once."""
        return tuple(dict.fromkeys(c for b in bindings for c in self.expand(b)))

    def relative(self, binding: Binding, mode: str) -> Binding:
        """`binding` made robot-relative (`mode`) against the robots seen (see `relative_to`)."""
        return relative_to(binding, mode, self.robots)

    def shown(self, binding: Binding) -> Binding:
        """The concrete binding to show for `binding` where one is needed (Topic setup): the selected
        robot's for a relative binding."""
        return resolve(binding, self.selected) if is_relative(binding) else binding

    # -- status ---------------------------------------------------------------------------------------

    def states(self, store: History | None, at: float | None, stale_after: float) -> list[RobotState]:
        """Each robot's state at source time `at` (None: now), from `store` (None: WAITING for all)."""
        t = time.time() if at is None else at
        out = []
        for robot in self.robots:
            topics = self.tags.get(robot, [])
            newest: float | None = None
            if store is not None:
                for topic in topics:
                    held = _newest(store, topic, t)
                    if held is not None and (newest is None or held > newest):
                        newest = held
            if newest is None:
                status = Status.WAITING
            else:
                status = Status.LIVE if t - newest <= stale_after else Status.STALE
            out.append(RobotState(robot, status, len(topics), newest))
        return out


def _newest(store: History, topic: str, t: float) -> float | None:
    """The source time of `topic`'s newest sample at time `t` (None before its first): its newest held
    when that is not after `t` (live, the usual case: no search, no sample read; a robot's 2,000 tags are
    looked at every second), else the sample at `t`."""
    span = store.span(topic)
    if span is None or span[0] > t:
        return None
    if span[1] <= t:
        return span[1]
    sample = store.at(topic, t)
    return None if sample is None else sample.time
