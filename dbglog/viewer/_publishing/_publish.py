"""The viewer's publishing service for control widgets: its own rclpy context, node and thread.

The app creates one service and owns it: every widget gets it in its `WidgetContext` at mount, with its
publish targets (the data engine never subscribes to a control's topic to learn its type). Widgets call
`PublishService.update` from the UI thread; it only stores the request and wakes the
service thread, so the UI never waits on ROS. The thread resolves each topic's type from the graph
(a clash is an error in that widget's state), keeps one publisher per topic, sends at most
``rate_limit_hz`` messages per widget (the latest value always goes out, a little later), repeats at
``repeat_hz`` when asked, and counts the topic's foreign subscribers for the widget's status. Several
value controls on one topic (two sliders on ``/cmd_vel``: ``linear.x`` and ``angular.z``) compose one
message, each setting its own field.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field, replace
from typing import Any, Final

from dbglog._ros._node import NodeIdentity, PrivateNode, own_nodes
from dbglog.viewer._data._interfaces import (
    InterfaceError,
    fill_message,
    form_fields,
    message_type,
    normalize_type,
)
from dbglog.viewer._data._model import Status
from dbglog.viewer._publishing._requests import DEFAULT_RATE_LIMIT_HZ, PublishRequest, PublishState

__all__ = [
    "DEFAULT_RATE_LIMIT_HZ",
    "PublishRequest",
    "PublishService",
    "PublishState",
]

_log = logging.getLogger("dbglog.viewer.publish")

MAX_RATE_HZ: Final = 1000.0
_GRAPH_PERIOD_S: Final = 0.5
_MATCH_WAIT_S: Final = 2.0
"""A new publisher holds its first message this long at most, until the known subscribers have matched."""
_MIN_WAIT_S: Final = 0.005
_DISCOVERY_S: Final = 1.0
"""The service waits this long after starting ROS before it resolves types (discovery needs a moment)."""


@dataclass(eq=False, slots=True)
class _Entry:
    request: PublishRequest
    rate_limit_hz: float
    repeat_hz: float
    pending: bool
    last_sent: float = -1e18
    sent: int = 0
    error: str = ""
    msg_type: str | None = None
    path: str = ""
    """The field path the single value sets, once resolved."""
    basis: object = None
    """What the type was last resolved from (the request without its value, the graph read)."""
    waiting: str = ""
    """Why no type is chosen yet: the topic is not on the graph and the default type cannot serve it."""


@dataclass(eq=False, slots=True)
class _Topic:
    msg_type: str
    cls: Any
    publisher: Any
    users: set[object] = field(default_factory=set)
    created: float = field(default_factory=time.monotonic)


@dataclass(slots=True)
class _Graph:
    types: dict[str, set[str]] = field(default_factory=dict)
    """Types of the topic's endpoints outside this viewer."""
    subscribers: dict[str, int] = field(default_factory=dict)
    all_subscribers: dict[str, int] = field(default_factory=dict)
    """Every subscription on the topic, the viewer's own included (to know when all have matched)."""
    generation: int = 0
    """Counts the reads, so a resolved type can tell it is from an older look at the graph."""


class PublishService:
    """Publishes for control widgets on its own thread; every method is safe and quick on the UI thread.

    Args:
        node_name: the service's ROS node name.
        graph_period: seconds between looks at the ROS graph (topic types, subscribers).
        own_nodes: returns the nodes that are the viewer itself (its engine, this service), whose
            endpoints are not counted as subscribers nor asked for types; by default this process's
            private nodes (``dbglog._ros._node.own_nodes``).
    """

    def __init__(
        self,
        *,
        node_name: str = "dbglog_viewer_controls",
        graph_period: float = _GRAPH_PERIOD_S,
        own_nodes: Callable[[], frozenset[NodeIdentity]] = own_nodes,
    ) -> None:
        self.node_name = node_name
        self._own_nodes = own_nodes
        self.graph_period = graph_period
        self._cond = threading.Condition()
        self._entries: dict[object, _Entry] = {}
        self._states: dict[object, PublishState] = {}
        self._thread: threading.Thread | None = None
        self._running = False
        self._dirty = False
        self._start_error = ""

    # --- UI side ------------------------------------------------------------------------------------

    def update(
        self,
        key: object,
        request: PublishRequest,
        *,
        send: bool,
        rate_limit_hz: float = DEFAULT_RATE_LIMIT_HZ,
        repeat_hz: float = 0.0,
    ) -> None:
        """Set what control `key` publishes; with `send`, queue one message (rate limited). Never blocks."""
        rate = min(MAX_RATE_HZ, max(0.01, float(rate_limit_hz)))
        repeat = min(rate, max(0.0, float(repeat_hz)))
        with self._cond:
            entry = self._entries.get(key)
            if entry is None:
                entry = self._entries[key] = _Entry(request, rate, repeat, send)
                self._states.setdefault(key, PublishState(Status.WAITING, "looking at the ROS graph"))
            else:
                if entry.request.topic != request.topic or entry.request.msg_type != request.msg_type:
                    entry.msg_type = None  # resolve again
                    entry.error = ""
                entry.request, entry.rate_limit_hz, entry.repeat_hz = request, rate, repeat
                entry.pending = entry.pending or send
            self._dirty = True
            self._cond.notify()
        self._ensure_thread()

    def state(self, key: object) -> PublishState:
        """Return the state of control `key` (WAITING before it was ever updated)."""
        if self._start_error:
            return PublishState(Status.ERROR, self._start_error)
        return self._states.get(key) or PublishState(Status.WAITING, "nothing to publish yet")

    def release(self, key: object) -> None:
        """Forget control `key` (its publisher goes when no control uses the topic)."""
        with self._cond:
            self._entries.pop(key, None)
            self._states.pop(key, None)
            self._dirty = True
            self._cond.notify()

    def stop(self, timeout: float = 5.0) -> None:
        """Stop the thread and shut its context down."""
        thread = self._thread
        if thread is None:
            return
        with self._cond:
            self._running = False
            self._cond.notify()
        thread.join(timeout)
        self._thread = None

    def _alive(self) -> bool:
        return self._running

    def _ensure_thread(self) -> None:
        if self._thread is not None:
            return
        self._running = True
        self._thread = threading.Thread(target=self._run, name="dbglog-publish", daemon=True)
        self._thread.start()

    # --- the service thread ---------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            ros = PrivateNode(self.node_name)
            node, context = ros.node, ros.context
        except Exception as exc:
            self._start_error = f"cannot start ROS for publishing: {exc}"
            _log.error("%s", self._start_error)
            return
        topics: dict[str, _Topic] = {}
        graph = _Graph()
        next_graph = 0.0
        # Let discovery see the graph first, so that a type is not chosen before the topic is known.
        settle_until = time.monotonic() + _DISCOVERY_S
        with self._cond:
            while self._running and time.monotonic() < settle_until:
                self._cond.wait(settle_until - time.monotonic())
        try:
            while True:
                with self._cond:
                    if not self._running:
                        break
                    timeout = self._next_wake(next_graph)
                    if not self._dirty and timeout > 0:
                        self._cond.wait(timeout)
                    if not self._alive():
                        break
                    self._dirty = False
                    entries = dict(self._entries)
                now = time.monotonic()
                try:
                    if now >= next_graph:
                        generation = graph.generation + 1
                        graph = self._read_graph(node, {e.request.topic for e in entries.values()})
                        graph.generation = generation
                        next_graph = now + self.graph_period
                    self._cycle(node, entries, topics, graph, now)
                except Exception:
                    if not context.ok():
                        break
                    _log.exception("publishing cycle failed; continuing")
                    time.sleep(0.05)
        finally:
            ros.close([functools.partial(node.destroy_publisher, t.publisher) for t in topics.values()])

    def _next_wake(self, next_graph: float) -> float:
        now = time.monotonic()
        due = next_graph
        for entry in self._entries.values():
            if entry.pending:
                due = min(due, entry.last_sent + 1.0 / entry.rate_limit_hz)
            if entry.repeat_hz > 0:
                due = min(due, entry.last_sent + 1.0 / entry.repeat_hz)
        return max(_MIN_WAIT_S, due - now)

    def _read_graph(self, node: Any, names: set[str]) -> _Graph:
        graph = _Graph()
        own = self._own_nodes()
        for name in names:
            types: set[str] = set()
            subscribers = 0
            try:
                subs = node.get_subscriptions_info_by_topic(name)
                pubs = node.get_publishers_info_by_topic(name)
            except Exception:  # a bad topic name: `_resolve` reports it
                _log.debug("graph query for %r failed", name, exc_info=True)
                continue
            graph.all_subscribers[name] = len(subs)
            for info in subs:
                if (info.node_namespace, info.node_name) in own:
                    continue
                subscribers += 1
                types.add(info.topic_type)
            for info in pubs:
                if (info.node_namespace, info.node_name) not in own:
                    types.add(info.topic_type)
            graph.types[name] = types
            graph.subscribers[name] = subscribers
        return graph

    def _cycle(
        self, node: Any, entries: dict[object, _Entry], topics: dict[str, _Topic], graph: _Graph, now: float
    ) -> None:
        # Drop publishers nobody uses any more.
        for name, used in list(topics.items()):
            used.users &= {k for k, e in entries.items() if e.request.topic == name}
            if not used.users:
                node.destroy_publisher(used.publisher)
                del topics[name]
        for key, entry in entries.items():
            basis = (replace(entry.request, value=None), graph.generation, len(topics))
            if basis != entry.basis:  # the request's topic/type/field or the graph changed
                entry.basis = basis
                self._resolve(node, key, entry, topics, graph)
        for key, entry in entries.items():
            topic = topics.get(entry.request.topic)
            if entry.repeat_hz > 0 and now >= entry.last_sent + 1.0 / entry.repeat_hz:
                entry.pending = True
            if (
                entry.pending
                and not entry.error
                and topic is not None
                and key in topic.users
                and now >= entry.last_sent + 1.0 / entry.rate_limit_hz
                and not self._matching(topic, graph, now)
            ):
                entry.pending = False
                try:
                    msg = self._message(topic, entry, entries)
                except InterfaceError as exc:
                    entry.error = str(exc)
                else:
                    topic.publisher.publish(msg)
                    entry.sent += 1
                    entry.last_sent = now
            self._states[key] = self._state_of(entry, graph)

    @staticmethod
    def _matching(topic: _Topic, graph: _Graph, now: float) -> bool:
        """True while a new publisher is still being matched with the topic's known subscribers."""
        if now - topic.created > _MATCH_WAIT_S:
            return False
        wanted = graph.all_subscribers.get(topic.publisher.topic_name, 0)
        return bool(topic.publisher.get_subscription_count() < wanted)

    def _resolve(
        self, node: Any, key: object, entry: _Entry, topics: dict[str, _Topic], graph: _Graph
    ) -> None:
        """Choose the type for `entry` and give it a publisher, or set its error."""
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        request = entry.request
        name = request.topic
        others = graph.types.get(name, set())
        try:
            explicit = normalize_type(request.msg_type) if request.msg_type else ""
            if len(others) > 1:
                raise InterfaceError(f"{name} has endpoints of several types: {', '.join(sorted(others))}")
            on_graph = next(iter(others), "")
            if explicit and on_graph and explicit != on_graph:
                raise InterfaceError(
                    f"type clash: {name} is {on_graph} on the ROS graph, but this widget publishes {explicit}"
                )
            chosen = explicit or on_graph or normalize_type(request.default_type)
            entry.waiting = "" if explicit or on_graph else self._default_cannot_serve(chosen, request)
            if entry.waiting:  # e.g. a field of a Twist before the robot is up: wait for the graph to say
                entry.msg_type, entry.error = None, ""
                topic = topics.get(name)
                if topic is not None:
                    topic.users.discard(key)
                return
            topic = topics.get(name)
            if topic is not None and topic.msg_type != chosen:
                if topic.users - {key}:
                    raise InterfaceError(
                        f"type clash: another control publishes {topic.msg_type} on {name}, this one {chosen}"
                    )
                node.destroy_publisher(topic.publisher)
                del topics[name]
                topic = None
            cls = message_type(chosen)
            entry.path = self._value_path(cls, chosen, request)
            entry.msg_type = chosen
            if topic is None:
                qos = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)
                topic = topics[name] = _Topic(chosen, cls, node.create_publisher(cls, name, qos))
            topic.users.add(key)
            self._message(topic, entry, {key: entry})  # checks the values fit the type now
            entry.error = ""
        except InterfaceError as exc:
            entry.error = str(exc)
            topic = topics.get(name)
            if topic is not None:
                topic.users.discard(key)
        except Exception as exc:  # rclpy rejects a topic name, a type support is broken, ...
            entry.error = f"cannot publish on {name!r}: {exc}"

    @staticmethod
    def _default_cannot_serve(default: str, request: PublishRequest) -> str:
        """Say why a topic not on the graph must wait for it: the default type lacks the request's field
        (or fields); "" when the default type serves it."""
        cls = message_type(default)
        wait = f"waiting for {request.topic} on the ROS graph to learn its type"
        if request.fields is not None:
            try:
                fill_message(cls, request.fields)
            except InterfaceError as exc:
                if "no field" in str(exc):
                    return f"{wait} ({default} does not fit: {exc}; or choose the type in Topic setup)"
            return ""
        path = request.field.strip()
        if not path or path in {f.path for f in form_fields(cls)}:
            return ""
        return f"{wait} ({default} has no field {path!r}; or choose the type in Topic setup)"

    @staticmethod
    def _value_path(cls: Any, msg_type: str, request: PublishRequest) -> str:
        if request.fields is not None:
            return ""
        fields = {f.path: f for f in form_fields(cls)}
        path = request.field.strip()
        if not path:
            if len(fields) != 1:
                shown = ", ".join(list(fields)[:6]) or "(none)"
                raise InterfaceError(
                    f"{request.topic} is {msg_type}, which has several fields: "
                    f"choose one in Topic setup ({shown})"
                )
            path = next(iter(fields))
        info = fields.get(path)
        if info is None:
            raise InterfaceError(f"{msg_type} has no settable field {path!r}")
        wanted = {"bool": {"bool"}, "number": {"int", "float"}, "string": {"string"}}.get(
            request.value_kind, set()
        )
        if info.kind not in wanted:
            raise InterfaceError(
                f"type clash: {request.topic} field {path!r} is {info.type_name} ({msg_type}); "
                f"this widget sends a {request.value_kind}"
            )
        return path

    @staticmethod
    def _message(topic: _Topic, entry: _Entry, entries: Mapping[object, _Entry]) -> Any:
        request = entry.request
        if request.fields is not None:
            return fill_message(topic.cls, request.fields)
        values: dict[str, object] = {}
        for other in entries.values():  # value controls on the same topic compose one message
            r = other.request
            if (
                other is not entry
                and r.topic == request.topic
                and r.fields is None
                and r.value is not None
                and other.path
                and other.msg_type == topic.msg_type
                and not other.error
            ):
                values[other.path] = r.value
        if request.value is not None:
            values[entry.path] = request.value
        kinds = {f.path: f.kind for f in form_fields(topic.cls)}
        for path, value in values.items():
            if kinds.get(path) == "int" and isinstance(value, float):
                values[path] = round(value)
        return fill_message(topic.cls, values)

    def _state_of(self, entry: _Entry, graph: _Graph) -> PublishState:
        name = entry.request.topic
        subs = graph.subscribers.get(name, 0)
        if entry.error:
            return PublishState(Status.ERROR, entry.error, entry.msg_type, subs, entry.sent)
        if entry.waiting:
            return PublishState(Status.WAITING, entry.waiting, None, subs, entry.sent)
        if entry.msg_type is None:
            return PublishState(Status.WAITING, "resolving the topic's type", None, subs, entry.sent)
        sent = f"; {entry.sent} sent" if entry.sent else ""
        if subs == 0:
            return PublishState(
                Status.WAITING,
                f"no subscriber on {name} yet ({entry.msg_type}{sent})",
                entry.msg_type,
                0,
                entry.sent,
            )
        plural = "s" if subs != 1 else ""
        return PublishState(
            Status.LIVE,
            f"{subs} subscriber{plural} on {name} ({entry.msg_type}{sent})",
            entry.msg_type,
            subs,
            entry.sent,
        )
