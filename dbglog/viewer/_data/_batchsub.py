"""The engine's reader of dbglog's batch topic: every sample of every SDK tag, in order, with its time.

Each robot namespace has its own batch topic (``/robot1/_dbglog/samples``, `batch_topic`), whose
tags are that robot's. A per-tag topic whose every publisher belongs to a node that also publishes
batches in the topic's namespace is *covered*: the engine does not subscribe to it (so the SDK's
per-tag copies cost it nothing) and feeds the topic's bindings from the batches instead. Topics with
any other publisher (the bridge, a user's node) keep their own subscription. Runs on the engine's
ROS thread only; no Dear PyGui.
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from dbglog._ros._batch import (
    BATCH_TYPE,
    SCALAR_TYPES,
    BatchError,
    TagSamples,
    batch_robot,
    batch_topic,
    decode_batch,
)
from dbglog._ros._cdr import read_string, string_payload
from dbglog._ros._grace import PublisherGrace
from dbglog._ros._node import no_callback
from dbglog._ros._numbers import as_numbers
from dbglog._ros._qos import batch_qos
from dbglog._ros._tags import parse_topic, topic_for_tag
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding, ValueKind
from dbglog.viewer._data._series import NO_MESSAGE_YET, Series
from dbglog.viewer._data._sinks import as_received, flush, number_type

__all__ = ["BatchIngest", "BatchStats"]

_log = logging.getLogger("dbglog.viewer.engine")
_MAX_TAKE = 2000
"""Batches taken per wake-up at most (others get their turn)."""
_MAX_DRAIN_S = 0.05
"""A subscription's batches are taken for at most this long a wake-up: a viewer started beside robots takes
their kept batches (1000 each) for seconds, and the engine's graph polls and other subscriptions come
between (they waited for all of it: 7 s beside two robots of 300 tags on 2 loaded cores)."""
_SCALAR_TYPE_NAMES = frozenset(f"std_msgs/msg/{name}" for name in SCALAR_TYPES)


@dataclass(frozen=True, slots=True)
class BatchStats:
    """What the batch reader received."""

    batches: int
    samples: int
    lost_batches: int
    """Batches a writer sent that never arrived (gaps in its sequence numbers)."""
    writers: int
    covered: tuple[str, ...]
    """Topics fed from batches instead of their own subscription."""


@dataclass(eq=False, slots=True)
class _Covered:
    """A per-tag topic fed from batches, and its bindings' sinks."""

    msg_type: str
    sinks: dict[Binding, Any] = field(default_factory=dict)


class BatchIngest:
    """Subscribes to each robot's batch topic while a writer exists; routes samples to covered topics' sinks.

    Args:
        make_sink: the engine's ``(binding, series, cls, msg_type) -> sink``.
        feed: the engine's ``(sink, messages, times, now)`` for typed values (text, regex).
        record_latency: the engine's latency recorder (times in seconds since the epoch).
        message_class: ``type name -> class``.
        history: the engine's history: every tag's samples are kept there as they arrive, so a binding
            made later (or just before its writer is seen on the graph) starts with the tag's past.
        claim: the engine's ``(topic, msg_type) -> attached``, asked when samples of a bound topic
            arrive before the graph shows its publishers (a short-lived writer may be gone by then).
        own: the engine's ``topic -> subscribed``: a topic the engine reads on its own subscription keeps
            its history from there (another node publishes it too, and the SDK then sends every sample
            on the topic as well), so its samples in batches are not held a second time.
    """

    def __init__(
        self,
        *,
        make_sink: Callable[[Binding, Series, Any, str], Any],
        feed: Callable[..., None],
        feed_numbers: Callable[..., None],
        record_latency: Callable[[Any], None],
        message_class: Callable[[str], Any],
        history: History,
        claim: Callable[[str, str], bool] | None = None,
        own: Callable[[str], bool] | None = None,
    ) -> None:
        self._make_sink = make_sink
        self._feed = feed
        self._feed_numbers = feed_numbers
        self._record_latency = record_latency
        self._message_class = message_class
        self._history = history
        self._claim = claim
        self._own = own
        self._wanted: frozenset[str] = frozenset()
        self.subs: dict[str, Any] = {}
        """Robot namespace (``""``: the root) -> the subscription to its batch topic."""
        self._cls: Any = None
        self._writer_nodes: dict[str, frozenset[tuple[str, str]]] = {}
        """Robot namespace -> the nodes writing its batches."""
        self._grace = PublisherGrace()
        """When new SDK nodes and unknown publishers were first seen (see `should_wait`)."""
        self._covered: dict[str, _Covered] = {}
        self._types: dict[str, str] = {}
        """The std_msgs type each tag seen in batches has (its newest)."""
        self._last_seq: dict[int, int] = {}
        self._newest: dict[Binding, float] = {}
        """Newest sample time each binding holds: a re-attached binding is seeded only past it."""
        self._batches = 0
        self._samples = 0
        self._lost = 0
        self.taken = 0
        """Messages taken from the batch topics, re-sent ones included (the engine's take counter)."""
        self.behind = False
        """The last `drain` left batches waiting (a slice's time or count ran out)."""

    # --- graph (engine thread) ----------------------------------------------------------------------

    def refresh(self, node: Any, names: list[str]) -> int:
        """Follow the batch writers on the graph (`names`: its topics): subscribe to each robot's batch
        topic while it has one; return the graph queries made."""
        robots = sorted({r for r in map(batch_robot, names) if r is not None} | set(self.subs))
        for robot in robots:
            topic = batch_topic(robot)
            infos = node.get_publishers_info_by_topic(topic)
            writers = frozenset((i.node_namespace, i.node_name) for i in infos if i.topic_type == BATCH_TYPE)
            self._writer_nodes[robot] = writers
            if writers and robot not in self.subs:
                self._cls = self._cls or self._message_class(BATCH_TYPE)
                self.subs[robot] = node.create_subscription(
                    self._cls, topic, no_callback, batch_qos(), raw=True
                )
        return len(robots)

    def covers(self, infos: list[Any], name: str) -> bool:
        """True when every publisher of topic `name` is a batch writer of its robot publishing a std_msgs
        scalar."""
        tag = parse_topic(name)
        writers = self._writer_nodes.get(tag.robot if tag is not None else "", frozenset())
        return bool(infos) and all(
            (i.node_namespace, i.node_name) in writers and i.topic_type in _SCALAR_TYPE_NAMES for i in infos
        )

    def should_wait(self, name: str, infos: list[Any]) -> bool:
        """True while topic `name` has a publisher too new (or too unknown) to tell whether it sends batches
        (`PublisherGrace.should_wait`)."""
        return self._grace.should_wait(name, infos, self._writer_nodes.values())

    def types(self) -> dict[str, str]:
        """Return the std_msgs type of every tag seen in batches (its newest)."""
        return dict(self._types)

    def past_type(self, name: str) -> str | None:
        """Return the type of a tag whose past the history holds from batches (None if it holds none)."""
        msg_type = self._types.get(name)
        return msg_type if msg_type is not None and self._history.kind(name) is not None else None

    def is_covered(self, name: str) -> bool:
        """True when `name` is fed from batches now."""
        return name in self._covered

    def attach(self, name: str, msg_type: str, bindings: dict[Binding, Series]) -> None:
        """Feed `bindings` of topic `name` from batches (new ones start with the tag's recent samples)."""
        covered = self._covered.get(name)
        if covered is None or covered.msg_type != msg_type:
            covered = self._covered[name] = _Covered(msg_type)
        for binding in [b for b in covered.sinks if b not in bindings]:
            del covered.sinks[binding]
        cls = self._message_class(msg_type)
        for binding, series in bindings.items():
            if binding in covered.sinks:
                continue
            sink = self._make_sink(binding, series, cls, msg_type)
            covered.sinks[binding] = sink
            if sink.kind is None:
                continue
            held = series.snapshot(1e9).last_time  # values it already has (an earlier subscription)
            if held is not None:
                self._newest[binding] = max(self._newest.get(binding, held), held)
            series.set_type(msg_type, sink.kind)
            if series.count == 0:
                series.set_waiting(NO_MESSAGE_YET)
            past = self._past(name, self._newest.get(binding))
            if past is not None:  # received "as long ago" as its newest sample is old: its age is true
                self._push(sink, [past], as_received(past[0]))

    def _past(self, name: str, after: float | None) -> tuple[Any, Any] | None:
        """Return the tag's held samples newer than `after` (all with None) as one chunk, or None."""
        history = self._history
        t0 = -np.inf if after is None else float(np.nextafter(after, np.inf))
        kind = history.kind(name)
        if kind == "numbers":  # as held: int64/uint64 exact (the live ring makes floats of them itself)
            times, values = history.range(name, t0, np.inf)
            return (times, values) if len(times) else None
        if kind == "payloads":
            times, payloads = history.payloads(name, t0, np.inf)
            texts = [(read_string(p) or b"").decode("utf-8", "replace") for p in payloads]
            return (times, texts) if texts else None
        return None

    def detach(self, name: str) -> None:
        """Stop feeding topic `name` from batches (it has another publisher, or none); what its bindings'
        transforms held back for older samples goes out first."""
        covered = self._covered.pop(name, None)
        if covered is not None:
            now = time.monotonic()
            for sink in covered.sinks.values():
                flush(sink, now)

    def keep_only(self, wanted: dict[str, dict[Binding, Series]]) -> None:
        """Forget covered topics and bindings nothing binds any more."""
        self._wanted = frozenset(wanted)
        for name in [n for n in self._covered if n not in wanted]:
            del self._covered[name]
        bound = {b for bindings in wanted.values() for b in bindings}
        for binding in [b for b in self._newest if b not in bound]:
            del self._newest[binding]

    def close(self, node: Any) -> None:
        """Destroy the subscriptions (engine stop)."""
        for sub in self.subs.values():
            node.destroy_subscription(sub)
        self.subs.clear()

    def stats(self) -> BatchStats:
        """Return the counters."""
        return BatchStats(
            self._batches, self._samples, self._lost, len(self._last_seq), tuple(sorted(self._covered))
        )

    # --- ingest (engine thread) ---------------------------------------------------------------------

    def drain(self, ready: set[int]) -> tuple[int, int]:
        """Take the batches of the subscriptions in `ready` (handle pointers), keep every sample in the
        history and feed covered topics' sinks; return (batches taken, takes that found any)."""
        taken = takes = 0
        behind = False
        for robot, sub in list(self.subs.items()):
            if sub.handle.pointer in ready:
                n, left = self._drain(sub, robot)
                taken += n
                takes += n > 0
                behind = behind or left
        self.taken += taken
        self.behind = behind
        return taken, takes

    def _drain(self, sub: Any, robot: str) -> tuple[int, bool]:
        """Take up to `_MAX_TAKE` batches of one robot's subscription, for at most `_MAX_DRAIN_S` (at least
        one); return how many it took and whether it stopped before the queue was empty."""
        take = sub.handle.take_message
        n = 0
        until = time.monotonic() + _MAX_DRAIN_S
        while True:
            if n >= _MAX_TAKE or (n > 0 and time.monotonic() >= until):
                return n, True
            got = take(self._cls, True)
            if got is None:
                return n, False
            n += 1
            try:
                batch = decode_batch(got[0])
            except BatchError as exc:
                _log.debug("viewer engine: skipping a batch: %s", exc)
                continue
            last = self._last_seq.get(batch.writer)
            if last is not None:
                if batch.seq <= last:
                    continue  # re-sent history after a re-subscription: already taken
                self._lost += batch.seq - last - 1
            self._last_seq[batch.writer] = batch.seq
            self._batches += 1
            self._samples += batch.samples
            for samples in batch.tags:
                self._ingest(samples, robot)

    def _ingest(self, samples: TagSamples, robot: str = "") -> None:
        name = topic_for_tag(samples.tag, robot)
        self._types[name] = "std_msgs/msg/" + samples.std_type
        times = samples.times_ns.astype(np.float64) * 1e-9
        chunk = (times, samples.values)
        own = self._own
        if own is None or not own(name):
            self._remember(name, times, samples.values)
        covered = self._covered.get(name)
        if covered is None:
            claim = self._claim
            if name in self._wanted and claim is not None and claim(name, "std_msgs/msg/" + samples.std_type):
                self._record_latency(times)  # attaching fed this chunk from the history
            return
        for sink in covered.sinks.values():
            self._push(sink, [chunk])
        self._record_latency(times)

    def _remember(self, name: str, times: Any, values: Any) -> None:
        """Keep a tag's samples in the history (a tag whose type changed starts a new history).

        Numbers keep the batch's dtype (`value_dtype`): int64/uint64 exact beyond 2**53, bools as bools.
        """
        history = self._history
        kind = "payloads" if isinstance(values, list) else "numbers"
        if history.kind(name) not in (None, kind):
            history.drop(name)
        if kind == "numbers":
            try:
                history.append_numbers(name, times, values)
            except ValueError:  # held as another dtype (Float64 -> Int64): the new type starts afresh
                history.drop(name)
                history.append_numbers(name, times, values)
        else:
            history.append_payloads(
                name, times, [string_payload(v) for v in values], msg_type="std_msgs/msg/String"
            )

    def _push(self, sink: Any, chunks: list[tuple[Any, Any]], now: float | None = None) -> None:
        """Feed one sink, guarding the others from its failure."""
        if sink.resolved is None:
            return
        now = time.monotonic() if now is None else now
        try:
            for times, values in chunks:
                self._newest[sink.binding] = max(self._newest.get(sink.binding, -np.inf), float(times[-1]))
                if isinstance(values, list):
                    self._feed(sink, [_Sample(v) for v in values], times.tolist(), now)
                elif sink.kind not in (ValueKind.NUMBER, ValueKind.BOOL) or sink.regex or sink.extra:
                    self._feed(sink, [_Sample(v) for v in _typed(values, sink)], times.tolist(), now)
                else:  # a column of numbers, as the engine feeds one decoded from per-tag CDR
                    self._feed_numbers(
                        sink, times, values if sink.chain is None else values.astype(float), now
                    )
        except Exception as exc:  # this binding's error alone
            _log.debug("viewer engine: batch feed for %s failed", sink.binding, exc_info=True)
            sink.resolved = None
            sink.series.set_error(f"cannot read batch samples: {type(exc).__name__}: {exc}")


def _typed(values: Any, sink: Any) -> list[Any]:
    """Numbers back as the field's Python type (bool, int or float), as typed messages hold them."""
    return as_numbers(values, number_type(sink))


class _Sample:
    """Stands in for a std_msgs scalar message: the engine's field accessors read ``.data``."""

    __slots__ = ("data",)

    def __init__(self, data: object) -> None:
        self.data = data
