"""The recorder: its own ROS context and node, raw (CDR) subscriptions that follow the graph, one take loop.

Every message is taken as serialized bytes with its source timestamp (no Python deserialization)
and written straight into the MCAP writer, or into a rolling RAM window in snapshot mode. Topics are
matched against the targets at every graph poll, so tags that appear later are recorded from their
first message; QoS follows the publishers (transient-local when they all offer it, so the values kept
by nodes already running are recorded too). A tag topic that only dbglog SDK nodes publish is not
subscribed when the batch topic is recorded: its samples are written from the batches (`_expand`), since
a subscriber there makes the SDK publish every sample once more as its own message.
"""

from __future__ import annotations

import contextlib
import functools
import threading
import time
from collections import deque
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from typing import Any

from dbglog._ros._batch import BATCH_DEPTH, SCALAR_TYPES, batch_robot, batch_topic, is_sdk_node
from dbglog._ros._grace import PublisherGrace
from dbglog._ros._markers import MARKER_TOPIC
from dbglog._ros._params import PARAMETER_EVENTS
from dbglog._ros._tags import TagError, TagName, parse_target, parse_topic
from dbglog.record._expand import BatchCounter, BatchExpander
from dbglog.record._writer import McapWriter

__all__ = ["DEFAULT_DEPTH", "Recorder", "Stats", "Targets", "Window", "parse_targets"]

ROSOUT = "/rosout"
DEFAULT_DEPTH = 1000
"""KEEP_LAST depth of each subscription: a second of backlog at 1 kHz."""
_TAKE_MAX = 4096
_GRAPH_PERIOD = 0.25
_MIN_CYCLE = 0.005
_WAIT_S = 0.05
"""Longest wait on the wait set: signals (Ctrl-C, SIGTERM, SIGUSR1) are handled at least this often."""
_BATCHED_TYPES = frozenset(f"std_msgs/msg/{t}" for t in SCALAR_TYPES)
EVENT_TOPICS = frozenset({PARAMETER_EVENTS, MARKER_TOPIC})
"""Recorded with any targets (unless left out): every parameter change on the graph and the user's markers,
what a replay shows on its timeline."""


@dataclass(frozen=True)
class Targets:
    """Which topics to record."""

    everything: bool = False
    all_tags: bool = True
    topics: frozenset[str] = frozenset()
    prefixes: tuple[str, ...] = ()
    """Tag topics: the tag itself and its sub-tags (``motor`` -> ``motor/rpm``)."""
    batch: bool = True
    """Record the SDK's batch topics (every sample with its source time) with tag targets: each robot's
    with its tags."""
    events: bool = True
    """Record `EVENT_TOPICS` (parameter changes, user markers) whatever the targets."""

    def wants(self, topic: str) -> bool:
        """True when `topic` is to be recorded."""
        if topic in EVENT_TOPICS:
            return self.events or self.everything or topic in self.topics
        robot = batch_robot(topic)
        if robot is not None:
            return topic in self.topics or (
                self.batch
                and (self.everything or self.all_tags or any(_robot_of(p) == robot for p in self.prefixes))
            )
        if self.all_tags and parse_topic(topic) is not None:
            return True
        if self.everything or topic in self.topics:
            return True
        return any(topic == p or topic.startswith(p + "/") for p in self.prefixes)


def _robot_of(topic: str) -> str | None:
    """The robot namespace of a tag topic (None for another topic)."""
    name = parse_topic(topic)
    return name.robot if name is not None else None


def parse_targets(
    targets: Sequence[str], *, everything: bool, batch: bool = True, events: bool = True
) -> Targets:
    """Read ``proximity``, ``速度`` or ``robot1:proximity`` as a tag (`parse_target`), ``/odom`` as a
    topic; none: every tag (of every robot) plus /rosout. With any targets, `events` adds
    ``/parameter_events`` and ``/_dbglog/markers``.

    Raises:
        ValueError: a target is empty or malformed (the message names it).
    """
    if everything:
        return Targets(everything=True, all_tags=True, batch=batch, events=events)
    if not targets:
        return Targets(all_tags=True, topics=frozenset({ROSOUT}), batch=batch, events=events)
    topics: set[str] = set()
    prefixes: list[str] = []
    for target in targets:
        name = target.strip().rstrip("/")
        try:
            parsed = parse_target(name) if name else None
        except TagError as exc:
            raise ValueError(f"{target!r} is not a tag: {exc}") from None
        if isinstance(parsed, TagName):
            prefixes.append(parsed.topic)
        elif parsed is None or " " in name or "." in name:
            raise ValueError(f"{target!r} is not a tag or a topic (a topic starts with /, a tag is a name)")
        else:
            topics.add(name)
    return Targets(
        all_tags=False, topics=frozenset(topics), prefixes=tuple(prefixes), batch=batch, events=events
    )


@dataclass
class _Sub:
    topic: str
    msg_type: str
    cls: Any
    sub: Any
    channel: int
    reliable: bool
    transient: bool
    depth: int
    lost_event: Any = None
    """rcl event handle of DDS's "message lost" status (None where the RMW does not offer it)."""
    lost: int = 0
    count: int = 0


_Held = tuple[str, str, int, int, bytes, int, frozenset[str]]
"""Snapshot mode, one message held: topic, type, log time, source time, CDR bytes, and for a batch the
messages its samples are written as and the topics subscribed when it came (those are not expanded)."""
_NONE: frozenset[str] = frozenset()


@dataclass
class Window:
    """Snapshot mode: what the RAM window holds now (what a snapshot would write) and what left it."""

    messages: int = 0
    """Messages a snapshot writes now: those received plus the samples of the batches among them."""
    from_batch: int = 0
    """Of those, the samples written from batches as their tags' messages."""
    dropped: int = 0
    """Messages (counted the same way) that left the window as older than it."""


@dataclass
class Stats:
    """What the recorder has done so far."""

    messages: int = 0
    """Messages written (or kept in the RAM window), samples written from batches included."""
    from_batch: int = 0
    """Of those, samples of SDK tags written from the batch topic (their topics not subscribed)."""
    topics: int = 0
    bytes_on_disk: int = 0
    longest_gap_s: float = 0.0
    """Longest time the take loop spent away from its wait set (graph polls, chunk writes, the OS)."""
    full_takes: int = 0
    """Takes that found a subscription's queue full: older messages may have been dropped by it."""
    fullest: float = 0.0
    """Highest share of a subscription's queue found waiting by one take (1.0: full)."""
    dds_lost: int = 0
    """Messages DDS reports lost before they reached the queues (publisher history overwritten first)."""
    skipped: dict[str, str] = field(default_factory=dict)
    """Topic -> why it is not recorded (type not installed, publishers disagree)."""


class Recorder:
    """Record the wanted topics into an MCAP writer (or a RAM window) until `stop` is called.

    `run` blocks in the calling thread; `on_tick` is called about once a second (for the live
    summary and the snapshot trigger).
    """

    def __init__(
        self,
        targets: Targets,
        writer: McapWriter | None,
        *,
        window_s: float | None = None,
        flush_period: float = 0.5,
        node_name: str | None = None,
        depth: int = DEFAULT_DEPTH,
    ) -> None:
        """Prepare (nothing is subscribed before `run`).

        Args:
            targets: what to record.
            writer: the MCAP writer; None for snapshot mode (RAM window of `window_s`).
            window_s: snapshot mode's window.
            flush_period: seconds between chunk flushes.
            node_name: the recorder's node name (default ``dbglog_record_<pid>``).
            depth: KEEP_LAST depth of each subscription (messages that may wait to be taken).
        """
        import os

        self.targets = targets
        self.writer = writer
        self.window_ns = int(window_s * 1e9) if window_s else 0
        self.ring: deque[_Held] = deque()
        """Snapshot mode: the messages held, oldest first."""
        self.window = Window()
        self._counter = BatchCounter()
        self._subscribed: tuple[int, frozenset[str]] = (-1, _NONE)
        self.flush_period = flush_period
        self.node_name = node_name or f"dbglog_record_{os.getpid()}"
        self.depth = depth
        self.stats = Stats()
        self._subs: dict[str, _Sub] = {}
        self.via_batch: set[str] = set()
        """Tag topics only SDK nodes publish, recorded from the batch topic instead of subscribed."""
        self._grace = PublisherGrace()
        """A tag whose publisher is too new or unknown to tell whether it writes batches is decided later."""
        self._expander: BatchExpander | None = None
        self._version = 0
        self._running = True
        self.warn: Callable[[str], None] = lambda _m: None

    def stop(self) -> None:
        """Ask `run` to return (safe from a signal handler)."""
        self._running = False

    def run(self, on_tick: Callable[[], None] | None = None) -> None:
        """Subscribe, take and write until `stop`; the writer is flushed, not closed."""
        from dbglog._ros._node import PrivateNode, WaitSet

        syncing = threading.Event()
        syncer = None
        if self.writer is not None:
            self._expander = BatchExpander(self.writer, self._from_batch)
            # fsync can block for long on a busy disk: never in the take loop (a stall loses messages
            # once the publishers' KEEP_LAST history wraps).
            syncer = threading.Thread(target=self._sync_loop, args=(syncing,), name="dbglog-record-sync")
            syncer.daemon = True
            syncer.start()
        # The ground floor's private node: our own context, the command line never parsed by rclpy.
        ros = PrivateNode(self.node_name)
        node = ros.node
        try:
            wait_set = WaitSet(ros, ros.guard())
            next_graph = next_flush = next_tick = 0.0
            wait_subs: list[_Sub] = []
            wait_version = -1
            by_pointer: dict[Any, _Sub] = {}
            last_wait_end = 0.0
            while self._running:
                now = cycle_start = time.monotonic()
                if now >= next_graph:
                    self._refresh(node)
                    next_graph = now + _GRAPH_PERIOD
                if self._version != wait_version:
                    wait_version = self._version
                    wait_subs = list(self._subs.values())
                    by_pointer = {s.sub.handle.pointer: s for s in wait_subs}
                if wait_subs:
                    before = time.monotonic()
                    if last_wait_end and before - last_wait_end > self.stats.longest_gap_s:
                        self.stats.longest_gap_s = before - last_wait_end
                    ready = wait_set.wait([s.sub for s in wait_subs], int(_WAIT_S * 1e9))
                    last_wait_end = time.monotonic()
                    for pointer in ready:
                        self._take(by_pointer[pointer])
                else:
                    time.sleep(_WAIT_S)
                now = time.monotonic()
                # Under load, let messages queue for a few ms: fewer, bigger takes per cycle.
                rest = _MIN_CYCLE - (now - cycle_start)
                if rest > 0:
                    time.sleep(rest)
                if self.writer is not None and now >= next_flush:
                    self.writer.flush()
                    next_flush = now + self.flush_period
                if now >= next_tick:
                    self._trim()
                    self._count_lost()
                    if on_tick is not None:
                        on_tick()
                    next_tick = now + 1.0
            # Drain what already arrived before returning.
            for s in list(self._subs.values()):
                self._take(s)
            self._count_lost()
        finally:
            syncing.set()
            if syncer is not None:
                syncer.join()
            if self.writer is not None:
                self.writer.flush(sync=True)
            destroy: list[Callable[[], object]] = []
            for s in self._subs.values():
                if s.lost_event is not None:
                    destroy.append(s.lost_event.destroy_when_not_in_use)
                destroy.append(functools.partial(node.destroy_subscription, s.sub))
            ros.close(destroy)

    def _sync_loop(self, done: threading.Event) -> None:
        """Push what was flushed to the disk once a second (survives a power cut, not only a kill)."""
        import os

        assert self.writer is not None
        fd = self.writer.fileno()
        while not done.wait(1.0):
            with contextlib.suppress(OSError):
                os.fsync(fd)

    # ----- graph ------------------------------------------------------------------------------------

    def _refresh(self, node: Any) -> None:
        from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

        names = sorted(
            (n for n, _types in node.get_topic_names_and_types()), key=lambda n: batch_robot(n) is None
        )
        batch_nodes: dict[str, set[tuple[str, str]]] = {}
        """Robot namespace -> the SDK nodes writing its batches."""
        for name in names:  # the batch topics first: they decide which tag topics they cover
            if not self.targets.wants(name):
                continue
            infos = node.get_publishers_info_by_topic(name)
            if not infos:
                continue
            pub_types = sorted({i.topic_type for i in infos})
            if len(pub_types) > 1:
                self._skip(name, f"publishers disagree on its type ({', '.join(pub_types)})")
                continue
            robot = batch_robot(name)
            tag_robot = _robot_of(name)
            if robot is not None:
                batch_nodes[robot] = {
                    (i.node_namespace, i.node_name) for i in infos if is_sdk_node(i.node_name)
                }
            elif name not in self._subs and tag_robot is not None and pub_types[0] in _BATCHED_TYPES:
                if batch_topic(tag_robot) in self._subs and all(
                    (i.node_namespace, i.node_name) in batch_nodes.get(tag_robot, ()) for i in infos
                ):
                    # Only SDK nodes that send the batch publish it: its samples come from the batches (a
                    # subscriber here would make each SDK publish every sample twice).
                    if name not in self.via_batch:
                        self.via_batch.add(name)
                        self._count_topics()
                    continue
                if self.targets.wants(batch_topic(tag_robot)) and self._grace.should_wait(
                    name, infos, batch_nodes.values()
                ):
                    # Its publisher may be an SDK's whose batch writer (or node, for rmw) is not known yet:
                    # subscribed now, the tag would be read apart from its batches for good, and the
                    # file's topic would miss the samples sent before the subscription matched.
                    continue
            best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
            transient = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
            old = self._subs.get(name)
            downgrade = old is not None and (
                (old.reliable and best_effort) or (old.transient and not transient)
            )
            if old is not None and old.msg_type == pub_types[0] and not downgrade:
                continue
            self._subscribe(node, name, pub_types[0], not best_effort, transient, old)

    def _skip(self, name: str, why: str) -> None:
        if self.stats.skipped.get(name) != why:
            self.stats.skipped[name] = why
            self.warn(f"not recording {name}: {why}")

    def _subscribe(
        self, node: Any, name: str, msg_type: str, reliable: bool, transient: bool, old: _Sub | None
    ) -> None:
        from dbglog._ros._qos import subscription_qos
        from dbglog._ros._types import TypeGateError, message_class

        try:
            cls = message_class(msg_type)
        except TypeGateError as exc:
            self._skip(name, str(exc))
            return
        if old is not None:
            self._count_lost_of(old)
            if old.lost_event is not None:
                old.lost_event.destroy_when_not_in_use()
            node.destroy_subscription(old.sub)
        depth = max(self.depth, BATCH_DEPTH) if batch_robot(name) is not None else self.depth
        qos = subscription_qos(depth, reliable=reliable, transient=transient)
        sub = node.create_subscription(cls, name, lambda _m: None, qos, raw=True)
        channel = 0
        if self.writer is not None:
            channel = self.writer.add_channel(name, msg_type, metadata={"offered_qos_profiles": ""})
        self._subs[name] = _Sub(
            name, msg_type, cls, sub, channel, reliable, transient, depth, _lost_event(sub)
        )
        self.via_batch.discard(name)
        self._version += 1
        self.stats.skipped.pop(name, None)
        self._count_topics()

    @property
    def batches_missing(self) -> int:
        """SDK batches never received while recording (gaps in their writers' numbers)."""
        return self._expander.missing if self._expander is not None else 0

    def _count_topics(self) -> None:
        expanded = self.via_batch | (self._expander.topics if self._expander is not None else set())
        self.stats.topics = len(self._subs) + len(expanded - self._subs.keys())

    def _from_batch(self, topic: str) -> bool:
        """True when tag `topic` is to be written from the batches (wanted, not subscribed itself)."""
        return topic not in self._subs and self.targets.wants(topic)

    # ----- data -------------------------------------------------------------------------------------

    def _take(self, s: _Sub) -> None:
        take = s.sub.handle.take_message
        cls = s.cls
        clock = time.time_ns
        writer = self.writer
        n = 0
        robot = batch_robot(s.topic)
        expander = self._expander if robot is not None else None
        if writer is not None and expander is not None:
            write = writer.write
            channel = s.channel
            expand = expander.expand
            known = len(expander.topics)
            samples = 0
            for _ in range(_TAKE_MAX):
                got = take(cls, True)
                if got is None:
                    break
                now = clock()
                write(channel, now, got[0], got[1]["source_timestamp"])
                samples += expand(now, got[0], robot or "")
                n += 1
            self.stats.from_batch += samples
            self.stats.messages += samples
            if len(expander.topics) != known:
                self._count_topics()
        elif writer is not None:
            write = writer.write
            channel = s.channel
            for _ in range(_TAKE_MAX):
                got = take(cls, True)
                if got is None:
                    break
                write(channel, clock(), got[0], got[1]["source_timestamp"])
                n += 1
        else:
            append = self.ring.append
            topic, msg_type = s.topic, s.msg_type
            subscribed, wanted = _NONE, None
            robot = batch_robot(topic)
            if robot is not None:  # the samples a snapshot will write from it, counted now
                subscribed = self._subscribed_now()
                wanted = functools.partial(self._from_batch_of, subscribed)
            samples = 0
            for _ in range(_TAKE_MAX):
                got = take(cls, True)
                if got is None:
                    break
                k = 0 if wanted is None else self._counter.count(got[0], wanted, robot or "")
                append((topic, msg_type, clock(), got[1]["source_timestamp"], got[0], k, subscribed))
                samples += k
                n += 1
            self.window.messages += n + samples
            self.window.from_batch += samples
            self.stats.from_batch += samples
            self.stats.messages += samples
        s.count += n
        stats = self.stats
        stats.messages += n
        if n >= s.depth:
            stats.full_takes += 1
        if n > stats.fullest * s.depth:
            stats.fullest = min(1.0, n / s.depth)

    def _count_lost(self) -> None:
        """Add up DDS's "message lost" counts of every subscription into `stats.dds_lost`."""
        for s in self._subs.values():
            self._count_lost_of(s)

    def _count_lost_of(self, s: _Sub) -> None:
        if s.lost_event is None:
            return
        try:
            total = int(s.lost_event.take_event().total_count)
        except Exception:  # an RMW without the event, or the context going away
            s.lost_event = None
            return
        if total > s.lost:
            self.stats.dds_lost += total - s.lost
            s.lost = total

    def _subscribed_now(self) -> frozenset[str]:
        """The topics subscribed now (one shared set per change of the subscriptions)."""
        if self._subscribed[0] != self._version:
            self._subscribed = (self._version, frozenset(self._subs))
        return self._subscribed[1]

    def _from_batch_of(self, subscribed: frozenset[str], topic: str) -> bool:
        """`_from_batch` as it was when `subscribed` were the subscriptions."""
        return topic not in subscribed and self.targets.wants(topic)

    def _trim(self) -> None:
        """Snapshot mode: drop what is older than the window."""
        if not self.window_ns:
            return
        oldest = time.time_ns() - self.window_ns
        ring = self.ring
        window = self.window
        while ring and ring[0][2] < oldest:
            samples = ring.popleft()[5]
            window.messages -= 1 + samples
            window.from_batch -= samples
            window.dropped += 1 + samples

    def snapshot(self, writer: McapWriter) -> int:
        """Write the RAM window into `writer` (then closed); return how many messages it held.

        That is `window.messages` at the time: each batch is expanded as it was counted when it came.
        """
        self._trim()
        items = list(self.ring)
        channels: dict[tuple[str, str], int] = {}
        expander = BatchExpander(writer, self._from_batch)
        count = 0
        try:
            for topic, msg_type, log_time, source, data, samples, subscribed in items:
                key = (topic, msg_type)
                channel = channels.get(key)
                if channel is None:
                    channel = channels[key] = writer.add_channel(topic, msg_type)
                writer.write(channel, log_time, data, source)
                count += 1
                if samples:
                    wanted = functools.partial(self._from_batch_of, subscribed)
                    count += expander.expand(log_time, data, batch_robot(topic) or "", wanted)
            writer.close()
        except BaseException:
            writer.abandon()
            raise
        return count


def _lost_event(sub: Any) -> Any:
    """Return an rcl event handle of `sub`'s "message lost" status, or None when the RMW has none."""
    from rclpy.event_handler import QoSSubscriptionEventType
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

    try:
        with sub.handle:
            return _rclpy.EventHandle(sub.handle, QoSSubscriptionEventType.RCL_SUBSCRIPTION_MESSAGE_LOST)
    except Exception:  # UnsupportedEventTypeError and the like: not counted then
        return None
