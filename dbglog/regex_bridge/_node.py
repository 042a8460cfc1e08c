"""The regex bridge as a ROS 2 node: reads ``/rosout`` (and String topics), publishes typed tag values.

Ingest is a dedicated thread that takes serialized messages straight from the subscription handles
in a tight loop, blocking on an rcl wait set only when every queue is empty: no executor, no callback
and no Python message object per line. Each burst taken from a subscription is matched as one batch
(`Matcher.match_many_bytes`). Output values are published as pre-serialized CDR.
"""

from __future__ import annotations

import threading
import time
from dataclasses import dataclass
from types import TracebackType
from typing import Any, Final, Self

import rclpy
from rcl_interfaces.msg import Log
from rclpy.context import Context
from rclpy.guard_condition import GuardCondition
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
from rclpy.node import Node
from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
from rclpy.serialization import deserialize_message
from std_msgs.msg import Bool, Float64, Int64, String

from dbglog.api._qos import tag_qos
from dbglog.regex_bridge._cdr import encode_value, read_log, read_string
from dbglog.regex_bridge._engine import Matcher
from dbglog.regex_bridge._rules import ROSOUT, RuleSet

__all__ = ["DEFAULT_DEPTH", "DEFAULT_NODE_NAME", "Bridge", "BridgeStats"]

DEFAULT_NODE_NAME: Final = "dbglog_bridge"
DEFAULT_DEPTH: Final = 10_000
"""History depth of the source subscriptions: at 20k lines/s, half a second of slack."""
_BURST: Final = 256
"""Messages taken from one subscription before looking at the others."""
_WAIT_NS: Final = 200_000_000
_MSG_TYPES: Final = {"float": Float64, "int": Int64, "bool": Bool}
_MAX_NAMES: Final = 1024


@dataclass(frozen=True, slots=True)
class BridgeStats:
    """What the bridge has done since it started."""

    lines: int
    """Messages taken from the source topics (the bridge's own log lines included)."""
    values: int
    """Values published."""
    unparseable: int
    """Captures that were not numbers of their output's kind (never published)."""
    errors: int
    """Messages that could not be handled at all (unreadable, or a publish that failed)."""


def source_qos(depth: int = DEFAULT_DEPTH) -> QoSProfile:
    """Return the QoS of a source subscription: reliable, volatile, deep keep-last history."""
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=depth,
        reliability=ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.VOLATILE,
    )


def _unused(_msg: Any) -> None:  # pragma: no cover - the ingest thread takes messages itself
    """Callback of the source subscriptions; never called (no executor spins them)."""


class Bridge:
    """Run `rules` as a ROS 2 node with its own context until `close()`.

    Every output publisher exists once the constructor returns, so viewers see each tag before its
    first value. Lines from the bridge's own logger are never matched (no feedback loops).

    Example:
        >>> with Bridge(load_rules("rules.yaml")) as bridge:
        ...     stop_event.wait()
    """

    def __init__(
        self,
        rules: RuleSet,
        *,
        node_name: str = DEFAULT_NODE_NAME,
        depth: int = DEFAULT_DEPTH,
        warn_every: float = 5.0,
    ) -> None:
        """Create the node, its publishers and subscriptions, and start the ingest thread.

        Args:
            rules: validated rules (`load_rules`).
            node_name: the ROS node name.
            depth: history depth of each source subscription.
            warn_every: at most one warning about unparseable captures per this many seconds.
        """
        self.matcher = Matcher(rules)
        self._warn_every = warn_every
        self._context = Context()
        rclpy.init(context=self._context)
        try:
            self.node = Node(node_name, context=self._context, start_parameter_services=False)
            qos = tag_qos()
            self._publishers = {
                o.topic: self.node.create_publisher(_MSG_TYPES[o.kind], o.topic, qos) for o in rules.outputs
            }
            self._sources = [
                (
                    self.node.create_subscription(
                        Log if topic == ROSOUT else String, topic, _unused, source_qos(depth), raw=True
                    ),
                    topic,
                    topic == ROSOUT,
                )
                for topic in rules.source_topics
            ]
            self._wake = GuardCondition(None, None, context=self._context)
        except Exception:
            rclpy.shutdown(context=self._context)
            raise
        self._own_logger = self.node.get_logger().name
        self._names: dict[bytes, str] = {}
        self._lines = 0
        self._errors = 0
        self._warned_at = -float("inf")
        self._warned_count = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, name=f"{node_name}-ingest", daemon=True)
        self._thread.start()

    @property
    def topics(self) -> tuple[str, ...]:
        """Every output topic, in rules-file order."""
        return tuple(self._publishers)

    @property
    def stats(self) -> BridgeStats:
        """Counters so far."""
        m = self.matcher.stats
        return BridgeStats(self._lines, m.values, m.unparseable_total, self._errors)

    def close(self) -> None:
        """Stop the ingest thread, destroy the node and shut its context down (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake.trigger()
        self._thread.join(timeout=10)
        self.node.destroy_node()
        if self._context.ok():
            rclpy.shutdown(context=self._context)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def _run(self) -> None:
        wait_set = _rclpy.WaitSet(len(self._sources), 1, 0, 0, 0, 0, self._context.handle)
        while not self._stop.is_set():
            busy = False
            for sub, topic, is_log in self._sources:
                handle, msg_type = sub.handle, sub.msg_type
                texts: list[bytes] = []
                names: list[str] = []
                levels: list[int] = []
                for _ in range(_BURST):
                    try:
                        taken = handle.take_message(msg_type, True)
                    except Exception:  # e.g. the context is going away; the loop re-checks
                        self._errors += 1
                        break
                    if taken is None:
                        break
                    busy = True
                    self._lines += 1
                    try:
                        self._read(taken[0], is_log, texts, names, levels)
                    except Exception:  # a bad line never stops the bridge
                        self._errors += 1
                if texts:
                    self._match_and_publish(texts, names, levels, topic)
            self._maybe_warn()
            if not busy and not self._stop.is_set():
                wait_set.clear_entities()
                for sub, _topic, _is_log in self._sources:
                    wait_set.add_subscription(sub.handle)
                wait_set.add_guard_condition(self._wake.handle)
                try:
                    wait_set.wait(_WAIT_NS)
                except Exception:  # shutdown interrupts the wait
                    if not self._context.ok():
                        return

    def _read(
        self, raw: bytes, is_log: bool, texts: list[bytes], names: list[str], levels: list[int]
    ) -> None:
        """Append a taken message's text, logger and level to the batch (not the bridge's own lines)."""
        if is_log:
            fields = read_log(raw)
            if fields is None:
                msg = deserialize_message(raw, Log)
                fields = (msg.level, msg.name.encode(), msg.msg.encode("utf-8", "surrogatepass"))
            level, name_bytes, text = fields
            name = self._names.get(name_bytes)
            if name is None:
                if len(self._names) >= _MAX_NAMES:
                    self._names.clear()
                name = self._names[name_bytes] = name_bytes.decode("utf-8", "replace")
            if name == self._own_logger:
                return
        else:
            data = read_string(raw)
            text = data if data is not None else deserialize_message(raw, String).data.encode()
            name, level = "", 0
        texts.append(text)
        names.append(name)
        levels.append(level)

    def _match_and_publish(self, texts: list[bytes], names: list[str], levels: list[int], topic: str) -> None:
        """Match a batch of lines in one go (`Matcher.match_many_bytes`) and publish every value."""
        try:
            batch = self.matcher.match_many_bytes(texts, names, levels, topic)
        except Exception:  # never expected; counted, and the bridge goes on
            self._errors += len(texts)
            return
        publishers = self._publishers
        for values in batch:
            for out_topic, kind, value in values:
                try:
                    publishers[out_topic].publish(encode_value(kind, value))
                except Exception:  # counted; the next value may well go through
                    self._errors += 1

    def _maybe_warn(self) -> None:
        stats = self.matcher.stats
        total = stats.unparseable_total if stats.unparseable else 0
        if total == self._warned_count:
            return
        now = time.monotonic()
        if now - self._warned_at < self._warn_every:
            return
        last = stats.last_unparseable
        new = total - self._warned_count
        self._warned_at, self._warned_count = now, total
        detail = f" (last: {last.text!r} for {last.topic}, expected {last.kind})" if last else ""
        self.node.get_logger().warning(
            f"{new} captured value{'s' if new != 1 else ''} could not be parsed and "
            f"{'were' if new != 1 else 'was'} not published{detail}; {total} so far"
        )
