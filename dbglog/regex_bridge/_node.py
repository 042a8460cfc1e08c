"""The regex bridge as a ROS 2 node: reads ``/rosout`` (and String topics), publishes typed tag values.

Ingest is a dedicated thread that takes serialized messages straight from the subscription handles
in a tight loop, blocking on an rcl wait set only when every queue is empty: no executor, no callback
and no Python message object per line. Each burst taken from a subscription is matched as one batch
(`Matcher.match_many_bytes`). Output values are published as pre-serialized CDR.

``/rosout`` is read transient-local, like its publishers write it, so lines written before the bridge
(or its subscription) was discovered arrive from the publishers' history. A value is published once
per log line (logger, stamp, text) and output topic: what DDS delivers again, or a relay repeats, within
`DEDUP_WINDOW` is skipped, and on a clean stop the bridge leaves what it published lately in a state
file, so that a restarted bridge does not publish it again from history.
"""

from __future__ import annotations

import base64
import binascii
import json
import os
import threading
import time
from dataclasses import dataclass
from hashlib import blake2b
from pathlib import Path
from types import TracebackType
from typing import Any, Final, Self

from rcl_interfaces.msg import Log
from rclpy.qos import QoSProfile
from rclpy.serialization import deserialize_message
from std_msgs.msg import Bool, Float64, Int64, String

from dbglog._regex._compile import NumberKind
from dbglog._ros._cdr import SCALAR_FORMATS, read_log, read_string, scalar_encoder
from dbglog._ros._node import PrivateNode, WaitSet, take_batch
from dbglog._ros._qos import LOG_DEPTH, log_qos, subscription_qos
from dbglog._ros._tags import dotted_namespace, logger_namespace, robot_label
from dbglog.regex_bridge._engine import Matcher
from dbglog.regex_bridge._rules import ROSOUT, RuleSet

__all__ = [
    "DEDUP_WINDOW",
    "DEFAULT_DEPTH",
    "DEFAULT_NODE_NAME",
    "OUTPUT_DEPTH",
    "Bridge",
    "BridgeStats",
    "encode_value",
]

DEFAULT_NODE_NAME: Final = "dbglog_bridge"
DEFAULT_DEPTH: Final = 10_000
"""History depth of the source subscriptions: at 20k lines/s, half a second of slack."""
OUTPUT_DEPTH: Final = LOG_DEPTH
"""Values each output topic keeps for a reader that matches late (reliable, transient-local, like a tag's).

As deep as the ``/rosout`` history a bridge reads on start (rcl keeps 1000 lines a node): a bridge that
starts beside the robot publishes that backlog at once, before a viewer, ``dbglog echo`` or ``dbglog
record`` already waiting has matched its new publishers (discovery takes up to seconds), and those readers
still get every value from the first line. A tag's 100 lost the start of such a burst."""
_BURST: Final = 256
"""Messages taken from one subscription before looking at the others."""
_WAIT_NS: Final = 200_000_000
_MSG_TYPES: Final = {"float": Float64, "int": Int64, "bool": Bool}
_ENCODERS: Final = {kind: scalar_encoder(SCALAR_FORMATS[cls.__name__]) for kind, cls in _MSG_TYPES.items()}
_MAX_NAMES: Final = 1024
DEDUP_WINDOW: Final = 12.0
"""Seconds (at least, at most twice that) a published line is remembered: ``/rosout`` publishers keep a
line for 10 s (their lifespan), so no history re-delivers it later."""
_GRAPH_AGE_S: Final = 0.05
"""``namespace: node`` rules: the graph's node list is asked again at most this often for a logger it
lacks (a node whose first line arrives before discovery shows it; ~13 µs a query at 31 nodes)."""
_HOLD_S: Final = 2.0
"""How long a ``namespace: node`` value waits for its node to show on the graph (discovery tells the
node list a little after the node's first /rosout line can arrive) before its logger's dotted name
decides."""
_MAX_HELD: Final = 10_000
_STATE_FORMAT: Final = "dbglog-bridge-published"
_STATE_VERSION: Final = 1
_DIGEST: Final = 16


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
    duplicates: int = 0
    """Values not published again: their line was already published on that topic (see `DEDUP_WINDOW`)."""


def encode_value(kind: NumberKind, value: float | int | bool) -> bytes:
    """Serialize `value` as a little-endian CDR std_msgs Float64, Int64 or Bool."""
    return _ENCODERS[kind](value)


class _Published:
    """Which (line digest, output topic) pairs were published lately: two sets, the older one dropped
    every `window` seconds, so each pair is remembered between one and two windows."""

    __slots__ = ("before", "now", "since", "window")

    def __init__(self, window: float) -> None:
        self.window = window
        self.now: set[tuple[bytes, str]] = set()
        self.before: set[tuple[bytes, str]] = set()
        self.since = time.monotonic()

    def age(self, now: float) -> None:
        """Forget the pairs published more than two windows ago."""
        if now - self.since >= self.window:
            self.before, self.now, self.since = self.now, set(), now

    def save(self, path: Path) -> None:
        """Write every remembered pair to `path` (atomically, readable by the user only).

        Raises:
            OSError: the file could not be written.
        """
        by_topic: dict[str, list[bytes]] = {}
        for digest, topic in self.now | self.before:
            by_topic.setdefault(topic, []).append(digest)
        doc = {
            "format": _STATE_FORMAT,
            "version": _STATE_VERSION,
            "saved": time.time(),
            "topics": {t: base64.b64encode(b"".join(ds)).decode("ascii") for t, ds in by_topic.items()},
        }
        path.parent.mkdir(parents=True, exist_ok=True, mode=0o700)
        tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
        try:
            tmp.write_text(json.dumps(doc), encoding="utf-8")
            os.replace(tmp, path)
        finally:
            tmp.unlink(missing_ok=True)

    def load(self, path: Path) -> int:
        """Remember the pairs a previous bridge saved in `path` less than one window ago; return how many.

        Raises:
            OSError: the file exists but could not be read.
            ValueError: the file is not a state file of this version.
        """
        try:
            text = path.read_text(encoding="utf-8")
        except FileNotFoundError:
            return 0
        except UnicodeDecodeError as exc:
            raise ValueError(f"not UTF-8 ({exc.reason})") from None
        try:
            doc = json.loads(text)
        except json.JSONDecodeError as exc:
            raise ValueError(f"not JSON ({exc.msg}, line {exc.lineno})") from None
        if not isinstance(doc, dict) or doc.get("format") != _STATE_FORMAT:
            raise ValueError(f'not a bridge state file (no "format": "{_STATE_FORMAT}")')
        if doc.get("version") != _STATE_VERSION:
            raise ValueError(f"state file version {doc.get('version')!r}, this bridge reads {_STATE_VERSION}")
        saved, topics = doc.get("saved"), doc.get("topics")
        if not isinstance(saved, int | float) or not isinstance(topics, dict):
            raise ValueError("'saved' must be a number and 'topics' a mapping")
        if not 0 <= time.time() - saved <= self.window:
            return 0  # older than /rosout's history: nothing in it can come back
        count = 0
        for topic, packed in topics.items():
            if not isinstance(topic, str) or not isinstance(packed, str):
                raise ValueError("'topics' must map topic names to base64 text")
            try:
                raw = base64.b64decode(packed, validate=True)
            except binascii.Error:
                raise ValueError(f"the digests of {topic!r} are not base64") from None
            if len(raw) % _DIGEST:
                raise ValueError(f"the digests of {topic!r} are not {_DIGEST}-byte digests")
            for at in range(0, len(raw), _DIGEST):
                self.before.add((raw[at : at + _DIGEST], topic))
                count += 1
        return count


def _output_qos() -> QoSProfile:
    """Return the QoS of an output topic: reliable, transient-local, keep-last `OUTPUT_DEPTH`."""
    return subscription_qos(OUTPUT_DEPTH, reliable=True, transient=True)


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
        state_dir: Path | None = None,
        dedup_window: float = DEDUP_WINDOW,
        namespace: str = "",
    ) -> None:
        """Create the node, its publishers and subscriptions, and start the ingest thread.

        Args:
            rules: validated rules (`load_rules`; the topics of their outputs are already in the bridge's
                namespace, but for ``namespace: node`` ones).
            node_name: the ROS node name.
            depth: history depth of each source subscription.
            warn_every: at most one warning about unparseable captures per this many seconds.
            state_dir: where the bridge keeps what it published lately (one file per node name and ROS
                domain, written by `close`, read at start), so that a restarted bridge does not publish
                lines from ``/rosout``'s history twice; None keeps nothing between runs.
            dedup_window: how long (at least) a published line is remembered.
            namespace: the bridge node's namespace (``""``: the root; normalized).
        """
        self.matcher = Matcher(rules)
        self._warn_every = warn_every
        self._published = _Published(dedup_window)
        self._duplicates = 0
        self._ros = PrivateNode(node_name, rosout=True, namespace=namespace)
        self._context = self._ros.context
        try:
            self.node = self._ros.node
            qos = _output_qos()
            self._publishers = {
                o.topic: self.node.create_publisher(_MSG_TYPES[o.kind], o.topic, qos)
                for o in rules.outputs
                if not o.follow_node
            }
            self._follow = {o.topic: o.kind for o in rules.outputs if o.follow_node}
            """Root topics of ``namespace: node`` outputs (published under each line's node namespace)."""
            self._namespaces: dict[str, str] = {}
            """Logger name -> its node's namespace (``namespace: node`` rules)."""
            self._graph: list[tuple[str, str]] = []
            self._graph_at = -float("inf")
            self._held: list[tuple[float, str, str, NumberKind, float | int | bool, bytes | None]] = []
            """Values of ``namespace: node`` rules waiting for their node on the graph (`_release_held`)."""
            self._state: Path | None = None
            if state_dir is not None:
                where = robot_label(namespace).replace("/", ".") + "." if namespace else ""
                self._state = state_dir / f"{where}{node_name}-domain{self._context.get_domain_id()}.json"
                self._load_state(self._state)
            self._sources = [
                (
                    self.node.create_subscription(
                        Log if topic == ROSOUT else String,
                        topic,
                        _unused,
                        log_qos(depth, durable=topic == ROSOUT),
                        raw=True,
                    ),
                    topic,
                    topic == ROSOUT,
                )
                for topic in rules.source_topics
            ]
            self._wake = self._ros.guard()
        except Exception:
            self._ros.close()
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
        """Every output topic published so far, in rules-file order (``namespace: node`` ones once a
        line gave them a namespace)."""
        return tuple(self._publishers)

    @property
    def stats(self) -> BridgeStats:
        """Counters so far."""
        m = self.matcher.stats
        duplicates = self._duplicates
        return BridgeStats(self._lines, m.values - duplicates, m.unparseable_total, self._errors, duplicates)

    @property
    def state_file(self) -> Path | None:
        """The file that carries what was published lately over to the next run (None: not kept)."""
        return self._state

    def close(self) -> None:
        """Stop the ingest thread, save the state file, destroy the node, end its context (idempotent)."""
        if self._stop.is_set():
            return
        self._stop.set()
        self._wake.trigger()
        self._thread.join(timeout=10)
        if not self._thread.is_alive():
            try:
                self._release_held(force=True)
            except Exception:  # the context going away: those values are lost
                self._errors += len(self._held)
        if self._state is not None and not self._thread.is_alive():
            try:
                self._published.save(self._state)
            except OSError as exc:
                self.node.get_logger().warning(
                    f"could not write the state file {self._state} ({exc.strerror or exc}): a bridge started "
                    "within the next 10 s may publish lines from /rosout's history a second time"
                )
        self._ros.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def _load_state(self, path: Path) -> None:
        try:
            self._published.load(path)
        except (OSError, ValueError) as exc:
            reason = exc.strerror if isinstance(exc, OSError) and exc.strerror else str(exc)
            self.node.get_logger().warning(
                f"ignoring the state file {path} ({reason}): lines the previous bridge published may be "
                "published again from /rosout's history"
            )

    def _run(self) -> None:
        wait_set = WaitSet(self._ros, self._wake)
        subscriptions = [sub for sub, _topic, _is_log in self._sources]
        while not self._stop.is_set():
            busy = False
            self._published.age(time.monotonic())
            for sub, topic, is_log in self._sources:
                handle, msg_type = sub.handle, sub.msg_type
                texts: list[bytes] = []
                names: list[str] = []
                levels: list[int] = []
                raws: list[bytes] = []
                try:
                    taken, _stamps = take_batch(handle.take_message, msg_type, True, _BURST)
                except Exception:  # e.g. the context is going away; the loop re-checks
                    self._errors += 1
                    taken = []
                busy = busy or bool(taken)
                self._lines += len(taken)
                for raw in taken:
                    try:
                        self._read(raw, is_log, texts, names, levels, raws)
                    except Exception:  # a bad line never stops the bridge
                        self._errors += 1
                if texts:
                    self._match_and_publish(texts, names, levels, raws if is_log else None, topic)
            try:
                self._release_held()
            except Exception:  # never expected; counted, and the bridge goes on
                self._errors += 1
            self._maybe_warn()
            if not busy and not self._stop.is_set():
                try:
                    wait_set.wait(subscriptions, _WAIT_NS)
                except Exception:  # shutdown interrupts the wait
                    if not self._context.ok():
                        return

    def _read(
        self,
        raw: bytes,
        is_log: bool,
        texts: list[bytes],
        names: list[str],
        levels: list[int],
        raws: list[bytes],
    ) -> None:
        """Add a taken message's text, logger, level and bytes to the batch (not the bridge's own lines)."""
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
        raws.append(raw)

    def _match_and_publish(
        self,
        texts: list[bytes],
        names: list[str],
        levels: list[int],
        raws: list[bytes] | None,
        topic: str,
    ) -> None:
        """Match a batch of lines in one go (`Matcher.match_many_bytes`) and publish every value.

        With `raws` (Log messages), a value is skipped when its line (logger, stamp, text) was already
        published on its topic: history that DDS delivers again, or a line that a relay repeats.
        """
        try:
            batch = self.matcher.match_many_bytes(texts, names, levels, topic)
        except Exception:  # never expected; counted, and the bridge goes on
            self._errors += len(texts)
            return
        follow = self._follow
        self._release_held()  # first: a node's held values go out before its newer ones
        held = {logger for _since, logger, *_rest in self._held}
        for i, values in enumerate(batch):
            if not values:
                continue
            digest: bytes | None = None
            if raws is not None:
                # The stamp is the 8 bytes after the CDR header (builtin_interfaces/Time) in every Log.
                line_id = raws[i][4:12] + names[i].encode("utf-8", "surrogatepass") + b"\0" + texts[i]
                digest = blake2b(line_id, digest_size=_DIGEST).digest()
            for out_topic, kind, value in values:
                if out_topic in follow:
                    logger = names[i]
                    try:
                        namespace = None if logger in held else self._node_namespace(logger)
                    except Exception:  # the graph query failed (shutting down?): wait as for discovery
                        namespace = None
                    if namespace is None:  # its node not on the graph yet: wait for discovery a moment
                        self._hold(logger, out_topic, kind, value, digest)
                        held.add(logger)
                        continue
                    out_topic = self._in_namespace(namespace, out_topic)
                self._publish(out_topic, kind, value, digest)

    def _publish(self, topic: str, kind: NumberKind, value: float | int | bool, digest: bytes | None) -> None:
        """Publish one value, unless its line (`digest`) was published on `topic` already."""
        if digest is not None:
            published = self._published
            key = (digest, topic)
            if key in published.now or key in published.before:
                self._duplicates += 1
                return
            published.now.add(key)
        try:
            self._publishers[topic].publish(encode_value(kind, value))
        except Exception:  # counted; the next value may well go through
            self._errors += 1

    def _node_namespace(self, logger: str) -> str | None:
        """The namespace of the node on the graph that logged as `logger`, None while the graph lacks it
        (the node list is asked again at most every `_GRAPH_AGE_S`)."""
        namespace = self._namespaces.get(logger)
        if namespace is not None:
            return namespace
        namespace = logger_namespace(logger, self._graph)
        now = time.monotonic()
        if namespace is None and now - self._graph_at >= _GRAPH_AGE_S:
            self._graph_at = now
            self._graph = list(self.node.get_node_names_and_namespaces())
            namespace = logger_namespace(logger, self._graph)
        if namespace is not None:
            if len(self._namespaces) >= _MAX_NAMES:
                self._namespaces.clear()
            self._namespaces[logger] = namespace
        return namespace

    def _in_namespace(self, namespace: str, topic: str) -> str:
        """The topic of a ``namespace: node`` output in `namespace` (its publisher made if new)."""
        full = namespace + topic
        if full not in self._publishers:
            self._publishers[full] = self.node.create_publisher(
                _MSG_TYPES[self._follow[topic]], full, _output_qos()
            )
        return full

    def _hold(
        self, logger: str, topic: str, kind: NumberKind, value: float | int | bool, digest: bytes | None
    ) -> None:
        """Keep a ``namespace: node`` value whose node the graph does not show yet (`_release_held`)."""
        if len(self._held) >= _MAX_HELD:
            self._release_held(force=True)
        self._held.append((time.monotonic(), logger, topic, kind, value, digest))

    def _release_held(self, *, force: bool = False) -> None:
        """Publish the held values whose node the graph shows now, in the order they came; after
        `_HOLD_S` (or `force`), those of a node it never showed go by the logger's dotted name
        (``robot1.ctrl`` -> ``/robot1``)."""
        if not self._held:
            return
        now = time.monotonic()
        found: dict[str, str | None] = {}
        keep: list[tuple[float, str, str, NumberKind, float | int | bool, bytes | None]] = []
        for item in self._held:
            since, logger, topic, kind, value, digest = item
            if logger not in found:
                try:
                    found[logger] = self._node_namespace(logger)
                except Exception:  # the context going away: the dotted name, or wait
                    found[logger] = None
            namespace = found[logger]
            if namespace is None and (force or now - since >= _HOLD_S):
                namespace = found[logger] = dotted_namespace(logger)
            if namespace is None:
                keep.append(item)
            else:
                self._publish(self._in_namespace(namespace, topic), kind, value, digest)
        self._held = keep

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
