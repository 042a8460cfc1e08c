"""The viewer's headless data engine: ROS topics in, bounded series out, on its own thread.

One thread owns a private rclpy context and node. It never runs an executor: it waits on a wait set
of its subscriptions, takes raw CDR bytes straight from each ready subscription handle and decodes a
whole batch at once (numpy for fixed-offset numeric fields, typed messages otherwise). It also polls
the ROS graph: bindings wait in the background until their topic has a publisher, subscriptions
follow the publishers' type and QoS, and the topic list stays current. Readers on any thread get
copies (``snapshot``); nothing here imports Dear PyGui.
"""

from __future__ import annotations

import functools
import logging
import threading
import time
import weakref
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field
from types import TracebackType
from typing import Any, Self

import numpy as np
import numpy.typing as npt

from dbglog._regex._compile import CompiledRegex
from dbglog._ros._batch import batch_robot
from dbglog._ros._cdr import CDR_HEADER, HEADER_SIZE, decode_fixed
from dbglog._ros._census import Census, take_census
from dbglog._ros._graph import Endpoints, GraphView
from dbglog._ros._node import NodeIdentity, PrivateNode, WaitSet, no_callback, take_batch
from dbglog._ros._qos import LOG_DEPTH, subscription_qos
from dbglog._ros._tags import parse_topic
from dbglog.viewer._data._batchsub import BatchIngest, BatchStats
from dbglog.viewer._data._events import EVENT_TOPICS, EventStore, events_of
from dbglog.viewer._data._fields import (
    FieldPathError,
    fixed_size,
    list_fields,
    message_class,
)
from dbglog.viewer._data._history import DEFAULT_MAX_BYTES, DEFAULT_MAX_SECONDS, History
from dbglog.viewer._data._logstore import LogStore
from dbglog.viewer._data._model import Binding, FieldInfo, SeriesSnapshot, Status, TopicInfo
from dbglog.viewer._data._series import NO_MESSAGE_YET, Series, SeriesTimes
from dbglog.viewer._data._sinks import (
    Sink,
    backfill,
    break_sink,
    feed,
    feed_numbers,
    flush,
    make_sink,
    prepare,
    release,
    same_values,
    scalar_plan,
)
from dbglog.viewer._data._suggest import close_matches, sub_topics, unpublished_reason
from dbglog.viewer._values._transforms import TransformChain

__all__ = ["Engine", "EngineStats", "queue_depth_for"]

_log = logging.getLogger("dbglog.viewer.engine")
_MAX_BATCH = 20_000
"""At most this many messages are taken from one subscription per cycle (others get their turn)."""
_RESUBSCRIBE_DEDUP_S = 1.0
_FILL_LIMIT = 0.5
"""A rest after a busy cycle never lets a subscription's queue fill past this share of its depth."""
_FEW_PER_TAKE = 16
"""A cycle whose takes found fewer messages than this each, on average, rests longer (see `_gather`)."""
_LATENCY_SAMPLES = 1 << 20
_MIN_DEPTH = 50
"""No subscription queues fewer messages than this, however many topics share the budget."""
_VARIABLE_DEPTH = 100
"""Queue depth cap for variable-size messages (strings, arrays, images): their size is unknown."""
_QUIET_POLL_S = 1.0
"""How often an unbound held tag that sends little is looked at (`Engine._split`): not waited on."""
_POLLED_SHARE = 4
"""An unbound held tag that sent less than 1/4 of its queue's depth in the last `_QUIET_POLL_S` is looked
at once in that time; one that sent more is waited on (its queue must not fill meanwhile)."""
_SUGGEST_AFTER_S = 3.0
"""A wanted topic still without a publisher this long is probably misspelled: say what the graph has."""
_EVERY_NODE_TOPICS = frozenset({"/parameter_events"})
"""Topics every rclpy node publishes, the engine's own included: they don't make the graph non-empty."""
LOG_TYPE = "rcl_interfaces/msg/Log"
"""The type of ``/rosout`` and other log topics."""
LOG_QUEUE = 20_000
"""Queue depth of a log topic's subscription: a second of lines at 20,000 lines/s may wait while this thread
is busy or starved (the Log console keeps every line); DDS's memory grows only while lines wait."""


def _stretch(busy: float, window: float, fullest: float, cycle: float, most: float) -> float:
    """Return how long the engine rests after a cycle that used `busy` seconds of CPU.

    Nothing beyond the usual `cycle` while the engine keeps up (a cycle's work takes less than that
    cycle). When it falls behind (a flood: many topics, each with a few messages a cycle), it rests as
    long as it worked, at most `most`: its messages wait in DDS until they make batches big enough
    that the per-batch costs (a take that finds nothing, a history append, numpy calls) stop
    dominating, and the engine uses about half a core instead of all of it. Never so long that a queue
    passes half its depth: the fullest one took `fullest` of its depth in the last `window` seconds,
    and fills in proportion to the time.
    """
    if busy <= cycle or fullest >= _FILL_LIMIT:
        return 0.0
    rest = min(busy, most)
    if fullest > 0.0:
        rest = min(rest, window * _FILL_LIMIT / fullest - busy)
    return max(0.0, rest)


def _gather(taken: int, takes: int, window: float, fullest: float, cycle: float, most: float) -> float:
    """Return how long the next cycle lasts, at least, after one whose `takes` takes found `taken` messages
    that had come in the last `window` seconds.

    A take costs about as much as a few messages (the call that finds the queue empty, a history append,
    the series' lock, numpy calls on a short column), so when a faster machine drains the queues faster
    than the publishers fill them, each take finds a message or two and those costs are paid per message.
    Then the cycle lasts longer, up to `most`, so that each take finds about `_FEW_PER_TAKE` messages: the
    latency a sample can gain is `most`, and only while messages are few. A cycle that took nothing (the
    guard, a graph poll) or took enough a take lasts `cycle`, as before; no queue passes half its depth:
    the fullest took `fullest` of its depth in those `window` seconds.
    """
    if takes <= 0 or most <= cycle or taken >= _FEW_PER_TAKE * takes:
        return cycle
    rest = min(most, window * _FEW_PER_TAKE * takes / max(1, taken))
    if fullest > 0.0:
        rest = min(rest, window * _FILL_LIMIT / fullest)
    return max(cycle, rest)


def queue_depth_for(n_topics: int, message_size: int | None, *, max_depth: int, budget: int) -> int:
    """Return the KEEP_LAST depth of one subscription among `n_topics` sharing a queue budget.

    DDS keeps the memory of every message it ever queued for a reader (its pools only grow), so the
    depths share one budget of queued messages: a few topics get deep queues that ride out long
    pauses, many topics get shallower ones, and a burst can never grow memory past the budget.
    Variable-size messages (``message_size`` None) are capped lower because one may be megabytes.
    """
    depth = budget // max(1, n_topics)
    if message_size is None:
        depth = min(depth, _VARIABLE_DEPTH)
    return max(1, min(max_depth, max(_MIN_DEPTH, depth)))


@dataclass(frozen=True, slots=True)
class EngineStats:
    """Counters for benchmarks and diagnostics."""

    taken: int
    """Messages taken from all subscriptions so far."""
    per_topic: dict[str, int]
    depths: dict[str, int]
    """KEEP_LAST queue depth of each subscription, by topic."""
    cycles: int
    """Wait-set wake-ups so far."""
    takes: int
    """Takes that found messages (a subscription's queue drained in one go; the batch topic's included)."""
    batches_taken: int
    """Messages taken from the batch topics so far (each holds many samples; not in `taken`)."""
    subscriptions: int
    thread_cpu_s: float
    """CPU seconds used by the engine's own thread (DDS's receive threads not included)."""
    graph_polls: int
    """Looks at the ROS graph so far (every ``graph_period``, and after each change of bindings)."""
    graph_queries: int
    """Questions asked of the ROS graph so far: node and topic lists, each node's endpoints, publisher lists
    (each costs tens of µs, and a per-topic one more as the graph grows)."""
    graph_counts: int
    """Counts of every graph topic's endpoints so far (when the graph changed, once more when it settled,
    and every ``RECOUNT_S``: see ``GraphView``)."""
    graph_lists: int
    """Reads of the graph's topic list so far (every poll of a small graph, less often of a big one)."""
    polled: frozenset[str]
    """Topics looked at every ``_QUIET_POLL_S`` instead of waited on (unbound tags that send little)."""
    catching_up: bool = False
    """Messages are being taken, or the last wake-up left some waiting (a backlog is taken in slices: a
    robot's kept history arrives as a burst of up to 1000 batches); `Engine.catching_up` without the rest."""


@dataclass(eq=False, slots=True)
class _TopicSub:
    """A live subscription on one topic (ROS thread only) and the bindings it feeds."""

    name: str
    msg_type: str
    cls: Any
    sub: Any
    reliable: bool
    transient: bool
    sinks: dict[Binding, Sink] = field(default_factory=dict)
    fast: list[tuple[Sink, int, str]] | None = None
    newest_ns: int = 0
    skip_deadline: float = 0.0
    held_until_ns: int = 0
    """While skipping (re-sent history), the history already holds the topic's samples up to this stamp."""
    scalar: tuple[int, str] | None = None
    """(offset, dtype) of ``data`` when the message is a std_msgs scalar: its history keeps numbers."""
    taken: int = 0
    depth: int = 1
    """The subscription's KEEP_LAST queue depth."""
    taken_at_poll: int = 0
    """`taken` at the last graph poll."""
    polled: bool = False
    """Sent little in the last `_QUIET_POLL_S` (`Engine._split`): unbound, it is looked at once in that time
    instead of waited on. A new subscription is waited on until then (a new tag's first burst, and the
    history its publisher re-sends, find its queue empty)."""
    pointer: int = 0
    """The subscription handle's pointer (how a wait set names it ready)."""


class _Subs(dict[str, _TopicSub]):
    """The engine's subscriptions by topic; `version` goes up whenever one comes or goes."""

    version = 0

    def __setitem__(self, name: str, topic: _TopicSub) -> None:
        self.version += 1
        super().__setitem__(name, topic)

    def __delitem__(self, name: str) -> None:
        self.version += 1
        super().__delitem__(name)

    def pop(self, name: str, *default: Any) -> Any:
        self.version += 1
        return super().pop(name, *default)


def _offered(infos: list[Any]) -> tuple[bool, bool]:
    """Return (best effort, transient local) for a subscription that matches every one of these publishers."""
    from rclpy.qos import DurabilityPolicy, ReliabilityPolicy

    best_effort = any(i.qos_profile.reliability == ReliabilityPolicy.BEST_EFFORT for i in infos)
    transient = all(i.qos_profile.durability == DurabilityPolicy.TRANSIENT_LOCAL for i in infos)
    return best_effort, transient


def _scalars(buffers: list[bytes], plan: tuple[int, str]) -> npt.NDArray[Any] | None:
    """Return the field at `plan` (payload offset, dtype) of every message in its own dtype, or None when a
    message is not little-endian CDR or too short.

    An Int64 or UInt64 stays exact beyond 2**53 (as a batch carries it), so the history of a tag read on its
    own topic and in batches is one column of one dtype.
    """
    offset, dtype = plan
    start = HEADER_SIZE + offset
    end = start + np.dtype(dtype).itemsize
    head = CDR_HEADER[:2]
    if not all(len(b) >= end and b[:2] == head for b in buffers):
        return None
    return np.frombuffer(b"".join([b[start:end] for b in buffers]), dtype=dtype)


def matched_reason(matched: int, publishers: int) -> str:
    """Say why a subscribed topic shows nothing yet, from how many of its publishers DDS matched."""
    if matched <= 0:
        return (
            f"{NO_MESSAGE_YET} (not matched with its publisher yet: discovery under way, or the "
            "publisher's QoS is incompatible)"
        )
    if matched < publishers:
        return f"{NO_MESSAGE_YET} (matched with {matched} of its {publishers} publishers)"
    whom = "its publisher" if publishers == 1 else f"all {publishers} of its publishers"
    return f"subscribed and matched with {whom}; no message yet"


def _normalize(topic: str) -> str:
    topic = topic.strip()
    return topic if topic.startswith("/") else "/" + topic


def wait_saying(
    event: threading.Event, timeout: float, slow: Callable[[], None] | None, slow_after: float
) -> bool:
    """Wait up to `timeout` s for `event`; when it is not set after `slow_after` s, call `slow` once first.

    Returns whether the event was set.
    """
    first = min(timeout, slow_after) if slow is not None else timeout
    if event.wait(first):
        return True
    if slow is None or first >= timeout:
        return False
    slow()
    return event.wait(timeout - first)


class Engine(SeriesTimes):
    """Turn (topic, field, regex) bindings into live series; implements ``DataSource``.

    Example:
        >>> with Engine() as engine:
        ...     engine.bind(Binding("/rosdashboard/proximity"))
        ...     snap = engine.snapshot(Binding("/rosdashboard/proximity"))

    Args:
        history: values kept per series (a ring buffer).
        stale_after: seconds without a message before a series turns STALE.
        graph_period: seconds between ROS graph polls (topic list, late publishers, type changes).
        min_cycle: minimum seconds between two wake-ups; under load messages queue in DDS meanwhile
            and are decoded as one batch (bounded extra latency, far less per-message overhead).
        max_stretch: after a cycle whose work took longer than `min_cycle` (a flood), the engine rests
            as long as it worked, at most this long: bigger batches, half the CPU (see ``_stretch``).
        max_gather: after a cycle whose takes found few messages each (the engine drains faster than the
            publishers write), the next one comes up to this long after it instead of `min_cycle`, so
            that a take finds more (see ``_gather``); at most `min_cycle`: off.
        queue_depth: the deepest KEEP_LAST queue of one subscription (absorbs bursts and pauses).
        queue_budget: messages queued in DDS across all subscriptions; each subscription's depth is
            its share of this (see ``queue_depth_for``), which bounds memory after a long pause.
        node_name: the engine's ROS node name.
        measure_latency: record publish-to-buffer latencies (for the benchmark).
        history_seconds: how far back the history reaches (every dbglog tag and every bound topic,
            raw, and every binding's values): what time travel and back-filled widgets read.
        history_bytes: the history's memory cap; the oldest samples go first.
        hold_tags: keep every dbglog tag on the graph in the history, bound or not, whoever publishes it:
            the SDK's scalar tags come in its batches, any other tag (the regex bridge's, a user's node's,
            the SDK's arrays and messages) gets a subscription of its own as soon as the engine sees it,
            so a plot added later shows its past. The terminal commands, which read one binding, leave
            it off.
        census: at each graph poll, count the participants on this host and those the engine found,
            and its discovery sockets' drops (`census`): ``dbglog tags`` waits on it.
    """

    def __init__(
        self,
        *,
        history: int = 10_000,
        stale_after: float = 2.0,
        graph_period: float = 0.25,
        min_cycle: float = 0.005,
        max_stretch: float = 0.02,
        max_gather: float = 0.01,
        queue_depth: int = 1000,
        queue_budget: int = 35_000,
        node_name: str = "dbglog_viewer",
        measure_latency: bool = False,
        history_seconds: float = DEFAULT_MAX_SECONDS,
        history_bytes: int = DEFAULT_MAX_BYTES,
        hold_tags: bool = True,
        census: bool = False,
    ) -> None:
        if history < 1:
            raise ValueError(f"history must be at least 1 value, not {history}")
        if not stale_after > 0:
            raise ValueError(f"stale_after must be > 0 seconds, not {stale_after}")
        if not graph_period > 0:
            raise ValueError(f"graph_period must be > 0 seconds, not {graph_period}")
        if queue_depth < 1:
            raise ValueError(f"queue_depth must be at least 1, not {queue_depth}")
        if queue_budget < 1:
            raise ValueError(f"queue_budget must be at least 1 message, not {queue_budget}")
        self.history = history
        self.stale_after = stale_after
        self.graph_period = graph_period
        self.min_cycle = max(0.0, min_cycle)
        self.max_stretch = max(0.0, max_stretch)
        self.max_gather = max(0.0, max_gather)
        self.queue_depth = queue_depth
        self.queue_budget = queue_budget
        self.node_name = node_name
        self.hold_tags = hold_tags
        self._census_wanted = census
        self._census: Census | None = None
        self._lock = threading.Lock()
        self.store = History(max_seconds=history_seconds, max_bytes=history_bytes)
        """The history: topics by name (raw: numbers or CDR payloads) and each series' values by its key."""
        self._held_types: dict[str, str] = {}
        """The ROS type of each topic the history holds from its own subscription."""
        self._dead_keys: list[str] = []
        """Store keys of unbound series, dropped by the ROS thread (the only writer)."""
        self._series: dict[Binding, Series] = {}
        self._regexes: dict[Binding, CompiledRegex | None] = {}
        self._chains: dict[Binding, TransformChain | None] = {}
        self._static_errors: dict[Binding, str] = {}
        self._topics: tuple[TopicInfo, ...] = ()
        self._types: dict[str, tuple[str, ...]] = {}
        self._graph = GraphView()
        """The graph's nodes, topics and endpoint counts, each read only as often as it is worth."""
        self._rows_key: tuple[object, ...] | None = None
        """What the topic list and the held tags were last built from (`_refresh_graph`)."""
        self._graph_names: frozenset[str] = frozenset()
        """The graph's topic names (batch topics left out), as last listed."""
        self._held: dict[str, tuple[Endpoints, tuple[str, ...]]] = {}
        """Each unbound tag topic with a publisher, and its endpoints and types (`_hold_tags`)."""
        self._asked: dict[str, tuple[int, list[Any]]] = {}
        """Each wanted topic's publishers, and the graph's `GraphView.version` when they were asked for: asked
        again at every poll while it has none or waits (see `_settled`), else when the graph changed and at
        each recount (a per-topic question scans every endpoint: 20 of them cost 1 % of a core beside 2,000
        topics at every poll)."""
        self._deciding = False
        """A topic's publisher was too new to decide on at the last poll: the topic list is read at every
        poll meanwhile (a new batch writer must be seen within the grace)."""
        self._dirty = threading.Event()
        self._running = False
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._start_error: BaseException | None = None
        self._guard: Any = None
        self.identity: NodeIdentity | None = None
        """The engine node's identity on the graph once started (publishers tell its endpoints by it)."""
        self._taken = 0
        self._takes = 0
        self._cycles = 0
        self._catching_up = False
        self._thread_cpu = 0.0
        self._graph_polls = 0
        self._polled: frozenset[str] = frozenset()
        self._graph_queries = 0
        """Questions asked of the graph besides the `GraphView`'s (publisher lists)."""
        self._subs = _Subs()
        self._held_seen: dict[str, tuple[Endpoints, tuple[str, ...]]] = {}
        """Each unbound tag topic's (endpoints, types) when the engine last decided how to hold it."""
        self._held_waiting: set[str] = set()
        """Unbound tag topics whose publisher is too new to decide on: looked at again at every poll."""
        self._batches = BatchIngest(
            make_sink=self._make_sink,
            feed=feed,
            feed_numbers=feed_numbers,
            record_latency=self._record_latency,
            message_class=message_class,
            history=self.store,
            claim=self._claim_for_batch,
            own=self._reads_itself,
        )
        """dbglog SDK tags arrive in batches on one hidden topic (see ``_batchsub``)."""
        self._reported: set[tuple[str, str]] = set()
        """(topic, error) pairs already logged with a traceback."""
        self._absent_since: dict[str, float] = {}
        """When each wanted topic was first seen without a publisher (monotonic seconds)."""
        self._graph_since = 0.0
        """When the engine's node joined the graph: discovery needs a moment before absence means much."""
        self._latency: npt.NDArray[np.float64] | None = (
            np.full(_LATENCY_SAMPLES, np.nan) if measure_latency else None  # pages touched now
        )
        self._latency_n = 0
        self._logs: weakref.WeakValueDictionary[str, LogStore] = weakref.WeakValueDictionary()
        """Log stores by topic (`log_store`), each fed every batch of its topic while someone holds it."""
        self._logs_lock = threading.Lock()
        self._events: EventStore | None = None
        """Parameter changes and markers (`events`), fed every batch of `EVENT_TOPICS` once made."""
        self._kept: set[str] = set()
        """Topics subscribed and kept in the history with no binding (the events store's)."""
        self._ordering: weakref.WeakSet[Sink] = weakref.WeakSet()
        """Sinks of stateful transforms, whose samples may wait for older ones (`release` each cycle)."""

    # --- lifecycle ----------------------------------------------------------------------------------

    def start(
        self, timeout: float = 15.0, *, slow: Callable[[], None] | None = None, slow_after: float = 5.0
    ) -> None:
        """Start the ROS thread (own context and node); returns once it is running.

        Args:
            timeout: seconds to wait for it.
            slow: called once when it is not running after `slow_after` seconds (to say why it waits).
            slow_after: seconds before `slow` is called.

        Raises:
            RuntimeError: ROS could not be initialised; the message gives rclpy's reason.
        """
        if self._thread is not None:
            return
        self._running = True
        self._ready.clear()
        self._thread = threading.Thread(target=self._run, name="dbglog-engine", daemon=True)
        self._thread.start()
        if not wait_saying(self._ready, timeout, slow, slow_after):
            raise RuntimeError(f"the viewer engine did not start within {timeout:g} s")
        if self._start_error is not None:
            self._thread.join(timeout=5)
            self._thread = None
            raise RuntimeError(f"the viewer engine could not start ROS: {self._start_error}")

    def stop(self, timeout: float = 10.0) -> None:
        """Stop the ROS thread and release its context; series stay readable."""
        thread = self._thread
        if thread is None:
            return
        self._running = False
        self._wake()
        thread.join(timeout)
        self._thread = None
        for logs in list(self._logs.values()):  # their workers end; the lines stay readable
            logs.close()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.stop()

    # --- DataSource ---------------------------------------------------------------------------------

    def bind(self, binding: Binding) -> None:
        """Start filling a series for `binding` (idempotent, never blocks)."""
        with self._lock:
            if binding in self._series:
                return
            series = Series(binding, self.history, self.store)
            self._series[binding] = series
            prepared = self._check(binding) or prepare(binding)
            if isinstance(prepared, str):
                self._regexes[binding] = self._chains[binding] = None
                self._static_errors[binding] = prepared
                series.set_error(prepared)
            else:
                self._regexes[binding], self._chains[binding] = prepared
        self._wake()

    def unbind(self, binding: Binding) -> None:
        """Stop filling the series for `binding` and free it."""
        with self._lock:
            series = self._series.pop(binding, None)
            if series is not None:
                series.store = None  # its values leave the history (the ROS thread drops them)
                self._dead_keys.append(series.own_key)
            self._regexes.pop(binding, None)
            self._chains.pop(binding, None)
            self._static_errors.pop(binding, None)
        self._wake()

    def snapshot(self, binding: Binding) -> SeriesSnapshot:
        """Return the current state of the series for `binding` (ERROR "not bound" if it is not)."""
        series = self._series.get(binding)
        if series is None:
            return SeriesSnapshot(binding, Status.ERROR, reason="not bound (call bind() first)")
        return series.snapshot(self.stale_after)

    # --- history (the TimeSource methods come from SeriesTimes) ----------------------------------

    def held_types(self) -> dict[str, str]:
        """Return the ROS type of every topic the history holds (to save it as a recording)."""
        types = {**self._batches.types(), **self._held_types}
        return {name: t for name, t in types.items() if self.store.kind(name) is not None}

    def census(self) -> Census | None:
        """Return the participants found at the last graph poll (``census=True``; None before, or without)."""
        return self._census

    def topics(self) -> list[TopicInfo]:
        """Return every topic on the graph (with a publisher or a foreign subscriber), by name."""
        return list(self._topics)

    def fields(self, topic: str) -> list[FieldInfo]:
        """Return the field paths of the topic's message type (empty while the type is unknown)."""
        types = self._types.get(_normalize(topic), ())
        for type_name in types:
            try:
                return list_fields(message_class(type_name))
            except FieldPathError:
                continue
        return []

    # --- extras -------------------------------------------------------------------------------------

    def bindings(self) -> list[Binding]:
        """Return the bound bindings."""
        with self._lock:
            return list(self._series)

    def stats(self) -> EngineStats:
        """Return ingest counters."""
        subs = dict(self._subs)
        return EngineStats(
            taken=self._taken,
            per_topic={name: s.taken for name, s in subs.items()},
            depths={name: int(s.sub.qos_profile.depth) for name, s in subs.items()},
            cycles=self._cycles,
            takes=self._takes,
            batches_taken=self._batches.taken,
            subscriptions=len(subs),
            thread_cpu_s=self._thread_cpu,
            graph_polls=self._graph_polls,
            graph_queries=self._graph_queries + self._graph.queries,
            graph_counts=self._graph.recounts,
            graph_lists=self._graph.lists,
            polled=self._polled,
            catching_up=self._catching_up,
        )

    @property
    def catching_up(self) -> bool:
        """Whether messages are being taken or the last wake-up left some waiting (`EngineStats`)."""
        return self._catching_up

    def batch_stats(self) -> BatchStats:
        """Return what arrived on dbglog's batch topic (batches, samples, lost batches, covered topics)."""
        return self._batches.stats()

    def latencies(self) -> npt.NDArray[np.float64]:
        """Return recorded publish-to-buffer latencies in seconds (``measure_latency=True`` only)."""
        if self._latency is None:
            return np.empty(0)
        return self._latency[: min(self._latency_n, _LATENCY_SAMPLES)].copy()

    def _check(self, binding: Binding) -> str | None:
        """Return what is wrong with the binding's topic name, None when it is a valid ROS name."""
        from rclpy.validate_full_topic_name import validate_full_topic_name

        try:
            validate_full_topic_name(_normalize(binding.topic))
        except Exception as exc:  # rclpy raises its own InvalidTopicNameException
            return f"bad topic name {binding.topic!r}: {exc}"
        return None

    def _wake(self) -> None:
        self._dirty.set()
        guard = self._guard
        if guard is not None:
            try:
                guard.trigger()
            except Exception:  # the context is shutting down: the thread is leaving anyway
                _log.debug("engine guard trigger failed", exc_info=True)

    # --- the ROS thread -----------------------------------------------------------------------------

    def _run(self) -> None:
        try:
            ros = PrivateNode(self.node_name)
            self._guard = ros.guard()
        except Exception as exc:
            self._start_error = exc
            self._ready.set()
            return
        self.identity = ros.identity
        self._graph.own = ros.identity
        self._graph_since = time.monotonic()
        self._ready.set()
        node = ros.node
        try:
            self._loop(ros)
        finally:
            self._guard = None
            subs, self._subs = list(self._subs.values()), _Subs()
            destroy = [functools.partial(node.destroy_subscription, topic.sub) for topic in subs]
            ros.close([functools.partial(self._batches.close, node), *destroy])

    def _loop(self, ros: PrivateNode) -> None:
        node, context = ros.node, ros.context
        next_graph = 0.0
        wait_set = WaitSet(ros, self._guard)
        poll_set = WaitSet(ros, ros.guard())  # (its guard is never triggered: `_wake` wakes `wait_set`)
        waited: list[Any] = []
        polled: list[Any] = []
        by_pointer: dict[int, _TopicSub] = {}
        split = -1  # the `_subs` version the lists were made from
        next_quiet = 0.0
        previous_woke = time.monotonic()
        while self._running and context.ok():
            cycle_start = time.monotonic()
            woke, woke_cpu = cycle_start, self._thread_cpu
            fullest = 0.0
            taken = takes = 0
            try:
                reconciled = False
                if self._dirty.is_set():
                    self._dirty.clear()
                    self._reconcile(node)
                    next_graph = 0.0
                    reconciled = True  # (a binding may have come to a quiet topic)
                if cycle_start >= next_graph:
                    self._refresh_graph(node)
                    next_graph = time.monotonic() + self.graph_period
                quiet = cycle_start >= next_quiet
                if quiet:
                    next_quiet = cycle_start + _QUIET_POLL_S
                if quiet or reconciled or split != self._subs.version:
                    split = self._subs.version
                    waited, polled, by_pointer = self._split(quiet)
                    self._polled = frozenset(by_pointer[sub.handle.pointer].name for sub in polled)
                ready = poll_set.wait(polled, 0) if quiet and polled else set()
                timeout = 0.0 if ready else max(0.0, next_graph - time.monotonic())
                ready |= wait_set.wait(waited + list(self._batches.subs.values()), int(timeout * 1e9))
                woke, woke_cpu = time.monotonic(), time.thread_time()
                self._cycles += 1
                if ready:
                    self._catching_up = True  # (before the first take: a reader sees no partial drain done)
                    behind = False
                    for pointer in ready:
                        topic = by_pointer.get(pointer)
                        if topic is not None:
                            n = self._drain(topic)
                            fullest = max(fullest, n / topic.depth)
                            taken += n
                            takes += n > 0
                            behind = behind or n >= _MAX_BATCH
                    if self._batches.subs:
                        n, k = self._batches.drain(ready)
                        taken += n
                        takes += k
                        behind = behind or self._batches.behind
                    self._takes += takes
                    self._catching_up = behind
                else:  # nothing waits (a slice that took the last message said it was behind)
                    self._catching_up = False
                if self._ordering:
                    self._release(time.monotonic())
            except Exception:
                if not (self._running and context.ok()):
                    return
                _log.exception("viewer engine cycle failed; continuing")
                wait_set.reset()
                poll_set.reset()
                split = -1  # the wait lists are made again
                time.sleep(0.05)
            self._thread_cpu = time.thread_time()
            now = time.monotonic()
            busy = self._thread_cpu - woke_cpu
            window = woke - previous_woke
            stretch = _stretch(busy, window, fullest, self.min_cycle, self.max_stretch)
            cycle = _gather(taken, takes, window, fullest, self.min_cycle, self.max_gather)
            rest = max(cycle - (now - cycle_start), stretch)
            previous_woke = woke
            if rest > 0 and self._running:
                time.sleep(rest)

    def _split(self, quiet: bool) -> tuple[list[Any], list[Any], dict[int, _TopicSub]]:
        """Return the subscriptions to wait on, those to look at every `_QUIET_POLL_S` only, and every one by
        its handle's pointer.

        rmw's wait costs every subscription in it each time (a few µs each, more while it blocks): beside
        2,000 held tags that send nothing, waiting on them at each graph poll was most of an idle engine's
        work. An unbound tag held in the history that sent less than `1/_POLLED_SHARE` of its queue in the
        last `_QUIET_POLL_S` is looked at once in that time instead: its messages wait in its queue until
        then (they keep their source times). `quiet`: that time is up, each topic's messages since decide.
        """
        kept = self._kept
        waited: list[Any] = []
        polled: list[Any] = []
        by_pointer: dict[int, _TopicSub] = {}
        for name, topic in self._subs.items():
            if quiet:
                fresh, topic.taken_at_poll = topic.taken - topic.taken_at_poll, topic.taken
                topic.polled = fresh * _POLLED_SHARE < topic.depth
            if topic.polled and not topic.sinks and name not in kept:
                polled.append(topic.sub)
            else:
                waited.append(topic.sub)
            by_pointer[topic.pointer] = topic
        return waited, polled, by_pointer

    # --- bindings and the graph (ROS thread) -----------------------------------------------------

    def _wanted(self) -> dict[str, dict[Binding, Series]]:
        with self._lock:
            wanted: dict[str, dict[Binding, Series]] = defaultdict(dict)
            for binding, series in self._series.items():
                if binding not in self._static_errors:
                    wanted[_normalize(binding.topic)][binding] = series
            for name in self._kept:
                wanted.setdefault(name, {})  # subscribed with no binding
            return wanted

    def _reconcile(self, node: Any) -> None:
        """Drop subscriptions nobody needs; attach new bindings to existing subscriptions."""
        with self._lock:
            dead, self._dead_keys = self._dead_keys, []
        for key in dead:
            self.store.drop(key)
        wanted = self._wanted()
        self._batches.keep_only(wanted)
        for name, topic in list(self._subs.items()):
            want = wanted.get(name, {})
            for binding in list(topic.sinks):
                if binding not in want:
                    del topic.sinks[binding]
            if name not in wanted:
                if self._holds(name):  # an unbound tag: its history goes on (the graph poll may drop it)
                    topic.fast = self._fast_plan(topic)
                    self._held_seen.pop(name, None)
                    continue
                node.destroy_subscription(topic.sub)
                del self._subs[name]
                continue
            new = {b: series for b, series in want.items() if b not in topic.sinks}
            if new and topic.transient and self.store.kind(name) is None:
                # A new binding on a latched topic the history lacks: subscribe again for the kept history.
                self._subscribe(node, name, topic.msg_type, want, topic.reliable, True, topic)
                continue
            for binding, series in new.items():
                sink = self._make_sink(binding, series, topic.cls, topic.msg_type)
                topic.sinks[binding] = sink
                if sink.kind is not None:
                    series.set_type(topic.msg_type, sink.kind)
                    series.set_waiting(NO_MESSAGE_YET)
                    backfill(
                        self.store, topic.name, topic.cls, sink
                    )  # the new widget starts with the topic's past
            topic.fast = self._fast_plan(topic)

    def _make_sink(self, binding: Binding, series: Series, cls: Any, msg_type: str) -> Sink:
        """Resolve one binding against the topic's type (its regex and transforms as bound)."""
        regex, chain = self._regexes.get(binding), self._chains.get(binding)
        sink = make_sink(binding, series, cls, msg_type, regex, chain)
        series.share(_normalize(binding.topic) if same_values(sink, cls, msg_type) else None)
        if sink.reorder is not None:
            self._ordering.add(sink)
        return sink

    @staticmethod
    def _fast_plan(topic: _TopicSub) -> list[tuple[Sink, int, str]] | None:
        """Return the raw-CDR plan when every bound field has a fixed offset, else None."""
        plan = []
        for sink in topic.sinks.values():
            if sink.resolved is None:
                continue
            if sink.resolved.cdr is None or sink.regex is not None or sink.extra or sink.lines is not None:
                return None
            plan.append((sink, *sink.resolved.cdr))
        return plan

    def _refresh_graph(self, node: Any) -> None:
        """Look at the graph: its nodes at every poll, its topics and their endpoints when due (`GraphView`),
        every wanted topic's publishers; follow them, and hold the unbound tags."""
        started = time.thread_time()
        if self._census_wanted:  # before the topics: they are then at least as new as the census
            try:
                self._census = take_census(node)
            except Exception:  # the census is advice: the poll goes on without it
                _log.debug("viewer engine: census failed", exc_info=True)
        self._graph_polls += 1
        graph = self._graph
        listed, counted = graph.look(  # (`dbglog tags`, the census on, reads the topics at every poll)
            node,
            time.monotonic(),
            period=self.graph_period,
            eager=self._deciding or self._census_wanted,
            own_subs=self._subs,
        )
        if listed:
            self._graph_queries += self._batches.refresh(node, [n for n, _t in graph.topics])  # batch writers
        wanted = self._wanted()
        publishers: dict[str, list[Any]] = {}
        on_graph: list[tuple[str, int, tuple[str, ...]]] = []
        asked = self._asked
        for name in [n for n in asked if n not in wanted]:
            del asked[name]
        for name in wanted:
            version, infos = asked.get(name, (-1, []))
            if counted or version != graph.version or not infos or not self._settled(name):
                infos = node.get_publishers_info_by_topic(name)
                asked[name] = (graph.version, infos)
                self._graph_queries += 1
            publishers[name] = infos
            on_graph.append((name, len(infos), tuple(sorted({info.topic_type for info in infos}))))
        key = (graph.version, frozenset(wanted), tuple(on_graph))
        rebuilt = key != self._rows_key
        if rebuilt:
            self._rows_key = key
            self._rebuild_rows(wanted, {name: (pubs, types) for name, pubs, types in on_graph})
        for name in [n for n in self._absent_since if n not in wanted]:
            del self._absent_since[name]
        self._deciding = False
        for name, bindings in wanted.items():
            try:
                self._follow(node, name, bindings, name in self._graph_names, publishers[name])
            except Exception as exc:  # one odd topic must not stop the others
                if (name, str(exc)) not in self._reported:  # once, not every graph poll
                    self._reported.add((name, str(exc)))
                    _log.exception("viewer engine: topic %s failed", name)
                for series in bindings.values():
                    series.set_error(f"internal error on {name}: {exc}")
        if self.hold_tags and (rebuilt or self._held_waiting):
            self._hold_tags(node, set(wanted))
            self._deciding |= bool(self._held_waiting)
        if listed:  # what a read of the topic list costs, all told, sets how often it is read
            graph.took(time.thread_time() - started)

    def _rebuild_rows(
        self, wanted: dict[str, dict[Binding, Series]], seen: dict[str, tuple[int, tuple[str, ...]]]
    ) -> None:
        """Build the topic list, each topic's types and the unbound tags to hold from the graph's last
        list and counts; a wanted topic's publishers and types are the ones `seen` at this poll."""
        topics: list[TopicInfo] = []
        held: dict[str, tuple[Endpoints, tuple[str, ...]]] = {}
        types: dict[str, tuple[str, ...]] = {}
        names: list[str] = []
        counts = self._graph.counts
        nobody = Endpoints(0, 0, ())
        for name, type_list in self._graph.topics:
            if batch_robot(name) is not None:
                continue
            names.append(name)
            ends = counts.get(name, nobody)
            pubs, listed_types = ends.publishers, tuple(type_list)
            if name in seen:
                pubs, wanted_types = seen[name]
                listed_types = wanted_types or listed_types
            elif pubs and self._holds(name):
                held[name] = (ends, listed_types)
            if pubs == 0 and ends.subscribers <= 0:
                continue
            types[name] = listed_types
            topics.append(TopicInfo(name, listed_types, pubs))
        self._types = types
        self._topics = tuple(sorted(topics, key=lambda t: t.name))
        self._graph_names = frozenset(names)
        self._held = held

    def _follow(
        self, node: Any, name: str, bindings: dict[Binding, Series], on_graph: bool, infos: list[Any]
    ) -> None:
        """Subscribe, re-subscribe or wait, as the publishers of one wanted topic require."""
        topic = self._subs.get(name)
        if not infos:
            if not bindings:  # a kept topic (the events store's) with no publisher now: nothing to say
                return
            now = time.monotonic()
            since = self._absent_since.setdefault(name, now)
            if topic is not None:
                reason = "the topic has no publisher now"
            elif now - max(since, self._graph_since) >= _SUGGEST_AFTER_S:
                reason = self._unpublished(name, on_graph)
            else:
                reason = (
                    "topic is not on the ROS graph yet"
                    if not on_graph
                    else "the topic has no publisher (yet)"
                )
            past = self._batches.past_type(name) if topic is None else None
            if past is not None:
                self._batches.attach(name, past, bindings)  # nothing publishes it now: show its past
            else:
                self._batches.detach(name)
            for series in bindings.values():
                series.set_waiting(reason)
            return
        self._absent_since.pop(name, None)
        pub_types = sorted({info.topic_type for info in infos})
        if self._batches.covers(infos, name) and len(pub_types) == 1:
            # Every publisher is a dbglog SDK that also sends batches: read every sample from those.
            if topic is not None:
                now = time.monotonic()
                for sink in topic.sinks.values():
                    flush(sink, now)  # what its transforms held back goes out before the batches' sinks
                node.destroy_subscription(topic.sub)
                del self._subs[name]
            self._batches.attach(name, pub_types[0], bindings)
            return
        self._batches.detach(name)
        if topic is None and self._batches.should_wait(name, infos):
            self._deciding = True
            for series in bindings.values():
                series.set_waiting("the topic's publisher just appeared; checking whether it sends batches")
            return
        best_effort, transient = _offered(infos)
        if topic is not None and topic.msg_type in pub_types:
            if (topic.reliable and best_effort) or (topic.transient and not transient):
                self._subscribe(node, name, topic.msg_type, bindings, not best_effort, transient, topic)
            elif topic.taken == 0:  # nothing arrived on it yet: say whether DDS matched its publishers
                reason = matched_reason(topic.sub.get_publisher_count(), len(infos))
                for series in bindings.values():
                    if series.count == 0:
                        series.set_waiting(reason)
            return
        if len(pub_types) > 1:
            for series in bindings.values():
                series.set_error(f"publishers disagree on the type of {name}: {', '.join(pub_types)}")
            return
        self._subscribe(node, name, pub_types[0], bindings, not best_effort, transient, topic)

    def _settled(self, name: str) -> bool:
        """True when wanted topic `name` is read (its own subscription, or batches): its publishers need not
        be asked for at every poll."""
        return name in self._subs or self._batches.is_covered(name)

    def _claim_for_batch(self, name: str, msg_type: str) -> bool:
        """Feed a bound topic from batches before the graph shows its publisher (none of its own yet)."""
        if name in self._subs:  # before building the binding table: batches call this per tag
            return False
        bindings = self._wanted().get(name)
        if not bindings:
            return False
        self._batches.attach(name, msg_type, bindings)
        return True

    def _reads_itself(self, name: str) -> bool:
        """True when the engine reads topic `name` on a subscription of its own (ROS thread)."""
        return name in self._subs

    def _holds(self, name: str) -> bool:
        """True for a topic the history keeps unbound: a dbglog tag (any robot's), with `hold_tags`."""
        return self.hold_tags and parse_topic(name) is not None

    def _hold_tags(self, node: Any, wanted: set[str]) -> None:
        """Keep the unbound tag topics with a publisher (`_held`) in the history.

        The SDK's tags come in batches (nothing to do); any other tag gets a subscription of its own. A topic
        is looked at again when its publishing nodes, their count or its types changed at a count of the
        graph, and at every poll while its publisher is too new to decide on (`BatchIngest.should_wait`).
        """
        held = self._held
        for name in [n for n in self._subs if n not in held and n not in wanted]:
            node.destroy_subscription(self._subs.pop(name).sub)  # an unbound tag that left the graph
        for name in [n for n in self._held_seen if n not in held]:
            del self._held_seen[name]
        self._held_waiting &= held.keys()
        for name, seen in held.items():
            if name not in self._held_waiting and self._held_seen.get(name) == seen:
                continue
            self._held_seen[name] = seen
            self._held_waiting.discard(name)
            infos = node.get_publishers_info_by_topic(name)
            self._graph_queries += 1
            try:
                self._hold(node, name, infos)
            except Exception:  # one odd topic must not stop the others
                if (name, "hold") not in self._reported:
                    self._reported.add((name, "hold"))
                    _log.exception("viewer engine: keeping %s in the history failed", name)

    def _hold(self, node: Any, name: str, infos: list[Any]) -> None:
        """Subscribe to one unbound tag topic unless its publishers send batches (or none is left)."""
        topic = self._subs.get(name)
        pub_types = sorted({info.topic_type for info in infos})
        if not infos or (self._batches.covers(infos, name) and len(pub_types) == 1):
            if topic is not None:  # gone, or now in batches: those hold it
                node.destroy_subscription(topic.sub)
                del self._subs[name]
            return
        if topic is None and self._batches.should_wait(name, infos):
            self._held_waiting.add(name)
            return
        if len(pub_types) > 1:  # publishers disagree: a binding says so; nothing to hold meanwhile
            return
        best_effort, transient = _offered(infos)
        if topic is not None:
            fits = not ((topic.reliable and best_effort) or (topic.transient and not transient))
            if topic.msg_type == pub_types[0] and fits:
                return
        self._subscribe(node, name, pub_types[0], {}, not best_effort, transient, topic)

    def _unpublished(self, name: str, on_graph: bool) -> str:
        """Say why nothing arrives on `name` after a while: close matches, sub-topics or an empty graph."""
        known = {t.name for t in self._topics if t.publishers} - _EVERY_NODE_TOPICS
        if on_graph and known and not sub_topics(name, known) and not close_matches(name, known):
            return f"nothing publishes {name} (it has subscribers only)"
        return unpublished_reason(name, known)

    def _subscribe(
        self,
        node: Any,
        name: str,
        msg_type: str,
        bindings: dict[Binding, Series],
        reliable: bool,
        transient: bool,
        old: _TopicSub | None,
    ) -> None:
        type_changed = old is not None and old.msg_type != msg_type
        if old is not None:
            node.destroy_subscription(old.sub)
            del self._subs[name]
        if type_changed:
            self.store.drop(name)
        try:
            cls = message_class(msg_type)
        except FieldPathError as exc:
            for series in bindings.values():
                series.set_error(str(exc), msg_type=msg_type)
            return
        depth = queue_depth_for(
            max(len(self._wanted()), len(self._subs) + 1),
            fixed_size(cls),
            max_depth=self.queue_depth,
            budget=self.queue_budget,
        )
        if msg_type == LOG_TYPE:
            depth = max(depth, LOG_DEPTH, LOG_QUEUE)  # the history re-sent to a late reader, and bursts
        elif name in self._kept:
            depth = max(depth, LOG_DEPTH)  # every node's declarations at a launch, a recorder's markers
        qos = subscription_qos(depth, reliable=reliable, transient=transient)
        sub = node.create_subscription(cls, name, no_callback, qos, raw=True)
        topic = _TopicSub(
            name, msg_type, cls, sub, reliable, transient, depth=depth, pointer=sub.handle.pointer
        )
        topic.scalar = scalar_plan(cls, msg_type)
        if self.store.kind(name) == ("numbers" if topic.scalar else "payloads"):
            # A latched publisher re-sends what the history may already hold: skip that much.
            span = self.store.span(name)
            if span is not None:
                topic.held_until_ns = round(span[1] * 1e9) + 512  # float seconds are ~256 ns coarse
                topic.skip_deadline = time.monotonic() + _RESUBSCRIBE_DEDUP_S
        elif self.store.kind(name) is not None:
            self.store.drop(name)
        if old is not None:
            topic.taken, topic.taken_at_poll = old.taken, old.taken_at_poll
        for binding, series in bindings.items():
            previous = old.sinks.get(binding) if old is not None and not type_changed else None
            if previous is not None and previous.kind is not None:
                # Same type, new subscription: a transient-local publisher re-sends what we already hold.
                previous.skip_until_ns = topic.newest_ns = old.newest_ns if old is not None else 0
                topic.skip_deadline = time.monotonic() + _RESUBSCRIBE_DEDUP_S
                topic.sinks[binding] = previous
                continue
            sink = self._make_sink(binding, series, cls, msg_type)
            topic.sinks[binding] = sink
            if sink.kind is None:
                continue
            if type_changed and old is not None:
                series.set_type(
                    msg_type,
                    sink.kind,
                    error=f"type changed from {old.msg_type} to {msg_type}; waiting for its first message",
                )
            else:
                series.set_type(msg_type, sink.kind)
                series.set_waiting(NO_MESSAGE_YET)
                if backfill(self.store, topic.name, topic.cls, sink):
                    sink.skip_until_ns = topic.held_until_ns
        topic.fast = self._fast_plan(topic)
        self._subs[name] = topic

    # --- ingest (ROS thread) ----------------------------------------------------------------------

    def _drain(self, topic: _TopicSub) -> int:
        """Take and decode what waits on one subscription; return how many messages it took."""
        cls = topic.cls
        buffers, stamps = take_batch(topic.sub.handle.take_message, cls, True, _MAX_BATCH)
        if not stamps:
            return 0
        self._count(topic, stamps)
        self._decode(topic, buffers, stamps)
        return len(stamps)

    def _decode(self, topic: _TopicSub, buffers: list[bytes], stamps: list[int]) -> None:
        """Keep a batch taken from `topic` in the history and feed it to the topic's bindings."""
        cls = topic.cls
        times = np.asarray(stamps, dtype=np.float64) * 1e-9
        if topic.fast is not None and not topic.fast and topic.scalar is None:  # nothing to decode: keep them
            self._remember(topic, buffers, stamps, times)
            self._record_latency(times)
            return
        if topic.fast is not None:
            fields = [(offset, dtype) for _, offset, dtype in topic.fast]
            if topic.scalar is not None and topic.scalar not in fields:
                fields.append(topic.scalar)
            columns = decode_fixed(buffers, fields)
            scalar = None if columns is None or topic.scalar is None else columns[fields.index(topic.scalar)]
            self._remember(topic, buffers, stamps, times, scalar)
            if columns is not None:
                now = time.monotonic()
                skipping = now < topic.skip_deadline
                broken = False
                for (sink, _, _), values in zip(topic.fast, columns[: len(topic.fast)], strict=True):
                    if sink.resolved is None:
                        continue
                    t = times
                    if skipping and sink.skip_until_ns:
                        keep = np.asarray(stamps, dtype=np.int64) > sink.skip_until_ns
                        t, values = times[keep], values[keep]
                    try:
                        feed_numbers(sink, t, values, now)
                    except Exception as exc:  # this binding's error alone; the others keep going
                        break_sink(sink, exc)
                        broken = True
                if broken:
                    topic.fast = self._fast_plan(topic)
                self._record_latency(times)
                return
        else:
            self._remember(topic, buffers, stamps, times)
        sinks = [sink for sink in topic.sinks.values() if sink.resolved is not None]
        if not sinks:  # every binding in error: nothing reads the messages
            self._record_latency(times)
            return
        times_list = times.tolist()
        from rclpy.serialization import deserialize_message

        messages = [deserialize_message(b, cls) for b in buffers]  # ~11 µs a Log message: only when read
        now = time.monotonic()
        skipping = now < topic.skip_deadline
        for sink in sinks:
            try:
                if skipping and sink.skip_until_ns:
                    fresh = [s > sink.skip_until_ns for s in stamps]
                    feed(
                        sink,
                        [m for m, k in zip(messages, fresh, strict=True) if k],
                        [t for t, k in zip(times_list, fresh, strict=True) if k],
                        now,
                    )
                else:
                    feed(sink, messages, times_list, now)
            except Exception as exc:  # this binding's error alone; the others keep going
                break_sink(sink, exc)
        self._record_latency(times)

    def _release(self, now: float) -> None:
        """Push the samples of stateful transforms that waited long enough for older ones."""
        for sink in list(self._ordering):
            try:
                release(sink, now)
            except Exception as exc:  # this binding's error alone
                break_sink(sink, exc)

    def _remember(
        self,
        topic: _TopicSub,
        buffers: list[bytes],
        stamps: list[int],
        times: npt.NDArray[np.float64],
        column: npt.NDArray[np.float64] | None = None,
    ) -> None:
        """Keep a batch of the topic's messages in the history (numbers for std_msgs scalars).

        `times`: the `stamps` in seconds; `column`: the scalar's values already decoded from `buffers`
        (the live decode's), if any.
        """
        if topic.held_until_ns and time.monotonic() < topic.skip_deadline:
            fresh = [s > topic.held_until_ns for s in stamps]
            if not all(fresh):  # a latched publisher re-sent what the history holds
                keep = np.asarray(fresh, dtype=bool)
                buffers = [b for b, k in zip(buffers, fresh, strict=True) if k]
                if column is not None:
                    column = column[keep]
                times = times[keep]
                if not len(times):
                    return
        self._held_types[topic.name] = topic.msg_type
        try:
            if topic.scalar is None:
                self._keep_payloads(topic, times, buffers)
                return
            if np.dtype(topic.scalar[1]).kind != "f" or column is None:
                column = _scalars(buffers, topic.scalar)  # integers and bools exact, as the batches hold them
            if column is None:  # not plain little-endian CDR: read them the slow way
                from rclpy.serialization import deserialize_message

                dtype = np.dtype(topic.scalar[1]).newbyteorder("=")
                column = np.array([deserialize_message(b, topic.cls).data for b in buffers], dtype=dtype)
            try:
                self.store.append_numbers(topic.name, times, column)
            except ValueError:  # held as another type from before (the topic's type changed): start afresh
                self.store.drop(topic.name)
                self.store.append_numbers(topic.name, times, column)
        except ValueError:  # e.g. the other kind held from before: that history is over
            self.store.drop(topic.name)

    # --- log stores: the Log console's lines (issue 18) ---------------------------------------------

    def log_store(self, topic: str) -> LogStore:
        """Return the store of every line of `topic` (an ``rcl_interfaces/msg/Log`` or String topic).

        Made on the first call holding the topic's past from the history, then given each batch the engine
        takes; held weakly (it goes when its last user drops it). A binding on the topic subscribes it.
        This engine only pushes raw batches to it; the store's own worker thread decodes and filters them.
        """
        name = _normalize(topic)
        with self._logs_lock:
            logs = self._logs.get(name)
            if logs is None:
                logs = LogStore(worker=True)
                if self.store.kind(name) == "payloads":
                    times, payloads = self.store.payloads(name, -np.inf, np.inf)
                    logs.push(self.store.msg_type(name), times, payloads)
                self._logs[name] = logs
        return logs

    def events(self) -> EventStore:
        """Return the store of every parameter change and user marker on the graph (made on the first call,
        which subscribes ``/parameter_events`` and ``/_dbglog/markers``; the same store after)."""
        with self._logs_lock:
            if self._events is None:
                self._events = events_of(self.store)  # whatever a binding already had kept
                with self._lock:
                    self._kept.update(EVENT_TOPICS)
            events = self._events
        self._wake()
        return events

    def _keep_payloads(self, topic: _TopicSub, times: npt.NDArray[np.float64], buffers: list[bytes]) -> None:
        """Keep a batch of messages in the history, and give it to the topic's log store or events store."""
        with self._logs_lock:  # a log store being made reads the history: each batch reaches it once
            self.store.append_payloads(topic.name, times, buffers, msg_type=topic.msg_type)
            logs = self._logs.get(topic.name)
            events = self._events if topic.name in EVENT_TOPICS else None
        if logs is not None:
            logs.push(topic.msg_type, times, buffers)
        if events is not None:
            events.push(topic.name, times, buffers)

    def _count(self, topic: _TopicSub, stamps: list[int]) -> None:
        topic.taken += len(stamps)
        self._taken += len(stamps)
        topic.newest_ns = max(topic.newest_ns, max(stamps))

    def _record_latency(self, times: npt.NDArray[np.float64]) -> None:
        if self._latency is None or not len(times):
            return
        lat = time.time() - times
        start = self._latency_n % _LATENCY_SAMPLES
        n = min(len(lat), _LATENCY_SAMPLES - start)
        self._latency[start : start + n] = lat[:n]
        self._latency_n += n
