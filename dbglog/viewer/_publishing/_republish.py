"""Republish a replayed recording on ROS 2 at the time cursor, so RViz and ``dbglog echo`` follow it.

Playing, every message the cursor passes goes out in time order with its recorded bytes; a seek, step or
loop sends each topic's latest message at the cursor once; then ``/clock``. The UI thread only hands the
cursor over (`Republisher.follow`, O(1)); a background thread with its own node publishes, bounded per
move. Pure planning (`plan_move`, `merge_moves`, `messages_between`, `state_at`); docs/recordings.md.
"""

from __future__ import annotations

import logging
import math
import struct
import threading
import time
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any, Final, NamedTuple

import numpy as np

from dbglog._ros._cdr import CDR_HEADER, SCALAR_FORMATS, scalar_encoder
from dbglog._ros._node import PrivateNode
from dbglog._ros._qos import TAG_HISTORY_DEPTH, subscription_qos
from dbglog._ros._types import TypeGateError, message_class
from dbglog.viewer._data._history import History
from dbglog.viewer._data._replay import ReplaySource

__all__ = [
    "CLOCK_TOPIC",
    "MAX_STREAM",
    "REPUBLISH_DEPTH",
    "CursorState",
    "Outgoing",
    "Republisher",
    "Seek",
    "Stream",
    "clock_payload",
    "merge_moves",
    "messages_between",
    "plan_move",
    "scalar_payload",
    "state_at",
]

_log = logging.getLogger("dbglog.viewer.republish")

REPUBLISH_DEPTH: Final = TAG_HISTORY_DEPTH
"""Keep-last depth of every republished topic (transient-local: what a late subscriber is re-sent)."""
MAX_STREAM: Final = 5000
"""The most messages one cursor move publishes one by one; a longer stretch is sent as its end state."""
CLOCK_TOPIC: Final = "/clock"
LATCHED_TOPICS: Final = frozenset({"/tf_static"})
"""Topics whose state is every message so far (each static transform publisher latches its own)."""
SLACK_S: Final = 0.1
"""Recorded seconds (times the speed) a playing cursor may run ahead of the wall clock and still stream."""
SETTLE_S: Final = 1.0
"""New publishers wait up to this long for the subscribers already on the graph to match them."""
_BYTE_FORMAT: Final = "<Bxxx"
_CLOCK: Final = struct.Struct("<4siI")


@dataclass(frozen=True, slots=True)
class CursorState:
    """The time cursor as the UI thread handed it over."""

    t: float | None
    """Source time shown (epoch seconds), None while live."""
    playing: bool
    wall: float
    """`time.monotonic()` when it was handed over."""
    speed: float = 1.0


@dataclass(frozen=True, slots=True)
class Stream:
    """Publish every message with ``after < time <= upto``, in time order."""

    after: float
    upto: float


@dataclass(frozen=True, slots=True)
class Seek:
    """Publish each topic's latest message at or before `t`, once."""

    t: float


def plan_move(prev: CursorState | None, cur: CursorState) -> Stream | Seek | None:
    """Decide what a cursor move republishes: the stretch played, the state at a new time, or nothing.

    A forward move of a playing cursor (or one that just started or stopped playing) streams when it is
    no longer than the speed allows for the wall time between the two hand-overs; anything else that
    moves the cursor (a seek, a step, a loop back to the start, a jump while playing) is a `Seek`.
    """
    if cur.t is None:
        return None
    if prev is None or prev.t is None:
        return Seek(cur.t)
    if cur.t == prev.t:
        return None
    if cur.t > prev.t and (prev.playing or cur.playing):
        speed = max(prev.speed, cur.speed)
        if cur.t - prev.t <= speed * (max(0.0, cur.wall - prev.wall) + SLACK_S):
            return Stream(prev.t, cur.t)
    return Seek(cur.t)


def merge_moves(pending: Stream | Seek, move: Stream | Seek) -> Stream | Seek:
    """Return the one move that does both, for a publishing thread behind the cursor.

    Two contiguous stretches are one; anything followed by a seek is that seek; a stretch after a seek
    not yet sent is the state at its end (the thread is behind: it catches up with the cursor's state).
    """
    if isinstance(move, Seek):
        return move
    if isinstance(pending, Stream) and pending.upto == move.after:
        return Stream(pending.after, move.upto)
    return Seek(move.upto)


class Outgoing(NamedTuple):
    """One message to publish: its recorded time, topic and CDR bytes."""

    time: float
    topic: str
    payload: bytes


def scalar_payload(msg_type: str) -> Callable[[object], bytes] | None:
    """Return value -> CDR bytes for a single-value std_msgs type (None for any other type)."""
    if not msg_type.startswith("std_msgs/msg/"):
        return None
    name = msg_type.rsplit("/", 1)[1]
    fmt = _BYTE_FORMAT if name in ("Byte", "Char") else SCALAR_FORMATS.get(name)
    if fmt is None:
        return None
    pack = scalar_encoder(fmt)
    convert: Callable[[Any], object] = bool if name == "Bool" else float if name.startswith("Float") else int
    return lambda value: pack(convert(value))


def clock_payload(t: float) -> bytes:
    """Return the CDR bytes of a rosgraph_msgs/Clock at source time `t` (rounded to the microsecond)."""
    us = round(t * 1e6)
    sec, rest = divmod(us, 1_000_000)
    return _CLOCK.pack(CDR_HEADER, sec, rest * 1000)


def _index(store: History, topic: str, t: float) -> int:
    """The index of the topic's last sample at or before `t` (-1 before its first)."""
    sample = store.at(topic, t)
    return -1 if sample is None else sample.index


def _payloads(store: History, topic: str, msg_type: str, t0: float, t1: float) -> tuple[Any, list[bytes]]:
    """Times and CDR bytes of a topic's messages with ``t0 <= time <= t1``."""
    if store.kind(topic) == "numbers":
        encode = scalar_payload(msg_type)
        times, values = store.range(topic, t0, t1)
        if encode is None:
            return np.empty(0), []
        return times, [encode(v) for v in values.tolist()]
    return store.payloads(topic, t0, t1)


def messages_between(
    store: History, types: Mapping[str, str], topics: Sequence[str], after: float, upto: float, limit: int
) -> list[Outgoing] | None:
    """Return the messages of `topics` with ``after < time <= upto`` in time order; None if over `limit`."""
    if upto <= after:
        return []
    counts = {topic: _index(store, topic, upto) - _index(store, topic, after) for topic in topics}
    if sum(counts.values()) > limit:
        return None
    t0 = float(np.nextafter(after, math.inf))
    out: list[Outgoing] = []
    for topic in topics:  # sorted by name: messages of the same time go out in topic order
        if counts[topic] <= 0:
            continue
        times, payloads = _payloads(store, topic, types.get(topic, ""), t0, upto)
        out.extend(Outgoing(t, topic, p) for t, p in zip(times.tolist(), payloads, strict=True))
    out.sort(key=lambda m: m.time)  # stable: ties keep topic order, each topic keeps its own
    return out


def state_at(store: History, types: Mapping[str, str], topics: Sequence[str], t: float) -> list[Outgoing]:
    """Return each topic's latest message at or before `t` (every one of a latched topic), oldest first."""
    out: list[Outgoing] = []
    for topic in topics:
        if topic in LATCHED_TOPICS:
            times, payloads = _payloads(store, topic, types.get(topic, ""), -math.inf, t)
            keep = slice(-REPUBLISH_DEPTH, None)
            out.extend(
                Outgoing(a, topic, p) for a, p in zip(times.tolist()[keep], payloads[keep], strict=True)
            )
            continue
        sample = store.at(topic, t)
        if sample is None:
            continue
        if isinstance(sample.value, bytes):
            out.append(Outgoing(sample.time, topic, sample.value))
            continue
        encode = scalar_payload(types.get(topic, ""))
        if encode is not None:
            out.append(Outgoing(sample.time, topic, encode(sample.value)))
    out.sort(key=lambda m: m.time)
    return out


@dataclass(slots=True)
class _Prepared:
    """What the worker knows of one recording: its publishers and what it could not republish."""

    types: dict[str, str]
    publishers: dict[str, Any] = field(default_factory=dict)
    skipped: dict[str, str] = field(default_factory=dict)
    """Topic -> why it is not republished."""


class Republisher:
    """Publishes a `ReplaySource` on ROS 2 following the viewer's time cursor (see the module).

    Create it, `start` it (starts ROS: may raise), call `follow` from the UI thread every turn of the
    loop, show `take_notes` to the user, `close` it.

    Args:
        node_name: the private node's name.
        publish_clock: publish ``/clock`` at the cursor time (a recording with its own ``/clock`` keeps it).
        ticks: the monotonic clock the timeline plays by (seconds).
    """

    def __init__(
        self,
        *,
        node_name: str = "dbglog_replay",
        publish_clock: bool = True,
        ticks: Callable[[], float] = time.monotonic,
    ) -> None:
        self.node_name = node_name
        self.publish_clock = publish_clock
        self._ticks = ticks
        self.enabled = True
        """False: cursor moves are ignored (`set_enabled`)."""
        self.published = 0
        """Messages published so far (``/clock`` not counted)."""
        self.seeks = 0
        """Moves sent as the state at the cursor."""
        self.jumped = 0
        """Messages passed over because a move held more than `MAX_STREAM` (sent as its end state)."""
        self._ros: PrivateNode | None = None
        self._thread: threading.Thread | None = None
        self._cond = threading.Condition()
        self._pending: tuple[ReplaySource, Stream | Seek] | None = None
        """The move the publishing thread is to send next (moves handed over meanwhile merge into it)."""
        self._last_key: tuple[object, ...] = ()
        self._source: object = None
        self._prev: CursorState | None = None
        self._stop = False
        self._notes: list[str] = []
        self._clock_pub: Any = None
        self._idle = threading.Event()
        self._idle.set()

    # --- UI thread ------------------------------------------------------------------------------------

    def start(self) -> None:
        """Start ROS (a private node) and the publishing thread.

        Raises:
            Exception: ROS cannot start (rclpy's error).
        """
        if self._ros is not None:
            return
        self._ros = PrivateNode(self.node_name)
        self._thread = threading.Thread(target=self._run, name="dbglog-republish", daemon=True)
        self._thread.start()

    def follow(self, source: object, cursor: float | None, *, playing: bool, speed: float = 1.0) -> None:
        """Hand over the cursor right after the timeline moved it (cheap: nothing happens when it did not).

        Args:
            source: the data shown (only a `ReplaySource` is republished).
            cursor: the timeline's cursor (None: live).
            playing: whether the timeline plays.
            speed: its playback speed.
        """
        key = (id(source), cursor, playing, speed)
        if key == self._last_key or not self.enabled:
            return
        self._last_key = key
        state = CursorState(cursor, playing, self._ticks(), speed)
        if source is not self._source:  # another recording opened, or back to live: start afresh
            self._source, self._prev = source, None
        prev, self._prev = self._prev, state
        if not isinstance(source, ReplaySource):
            return  # live data is not ours to republish
        move = plan_move(prev, state)
        if move is None:
            return
        with self._cond:
            pending = self._pending
            if pending is not None and pending[0] is source:
                move = merge_moves(pending[1], move)
            self._pending = (source, move)
            self._idle.clear()
            self._cond.notify()

    def set_enabled(self, on: bool) -> None:
        """Stop republishing (what waits is dropped), or start again with the state at the cursor."""
        self.enabled = on
        self._last_key, self._prev = (), None
        if not on:
            with self._cond:
                self._pending = None

    def take_notes(self) -> list[str]:
        """Return (and forget) what the user should be told: topics skipped, moves cut short."""
        with self._cond:
            notes, self._notes = self._notes, []
        return notes

    def wait_idle(self, timeout: float) -> bool:
        """Wait until every cursor handed over is published (for tests and scripts); False on timeout."""
        return self._idle.wait(timeout)

    def close(self) -> None:
        """Stop the thread and ROS (idempotent)."""
        with self._cond:
            self._stop = True
            self._cond.notify()
        if self._thread is not None:
            self._thread.join(timeout=5.0)
            self._thread = None
        if self._ros is not None:
            self._ros.close()
            self._ros = None

    # --- the publishing thread ------------------------------------------------------------------------

    def _note(self, text: str) -> None:
        _log.info("%s", text)
        with self._cond:
            self._notes.append(text)

    def _run(self) -> None:
        prepared: _Prepared | None = None
        while True:
            with self._cond:
                while self._pending is None and not self._stop:
                    self._idle.set()
                    self._cond.wait()
                if self._stop:
                    self._idle.set()
                    return
                assert self._pending is not None
                src, move = self._pending
                self._pending = None
            try:
                if prepared is None or src.types is not prepared.types:
                    prepared = self._prepare(src, prepared)
                self._send(src, prepared, move)
            except Exception as exc:  # never kill the thread: say it once and go on
                _log.debug("republishing failed", exc_info=True)
                self._note(f"republish: {exc}")

    def _prepare(self, src: ReplaySource, old: _Prepared | None) -> _Prepared:
        """Create a publisher per topic of `src` (keeping `old`'s), name the topics that cannot be."""
        assert self._ros is not None
        node = self._ros.node
        types = src.types
        prepared = _Prepared(types)
        created: list[Any] = []
        if old is not None:  # a recording opened in place of another: its topics only
            for topic, pub in old.publishers.items():
                if types.get(topic) != old.types.get(topic):
                    node.destroy_publisher(pub)
        qos = subscription_qos(REPUBLISH_DEPTH, reliable=True, transient=True)
        for topic, msg_type in sorted(types.items()):
            if old is not None and topic in old.publishers and old.types.get(topic) == msg_type:
                prepared.publishers[topic] = old.publishers[topic]
                continue
            if old is not None and topic in old.skipped and old.types.get(topic) == msg_type:
                prepared.skipped[topic] = old.skipped[topic]
                continue
            try:
                cls = message_class(msg_type)
                pub = node.create_publisher(cls, topic, qos)
            except TypeGateError:
                prepared.skipped[topic] = f"{msg_type} is not installed here"
                continue
            except Exception as exc:  # an invalid topic name, a type rmw refuses
                prepared.skipped[topic] = f"{msg_type}: {exc}"
                continue
            prepared.publishers[topic] = pub
            created.append(pub)
        if self.publish_clock and self._clock_pub is None and CLOCK_TOPIC not in types:
            try:
                cls = message_class("rosgraph_msgs/msg/Clock")
                self._clock_pub = node.create_publisher(cls, CLOCK_TOPIC, subscription_qos(1, reliable=True))
                created.append(self._clock_pub)
            except Exception as exc:
                self.publish_clock = False
                self._note(f"republish: no {CLOCK_TOPIC} ({exc})")
        new_skips = {t: why for t, why in prepared.skipped.items() if old is None or t not in old.skipped}
        if new_skips:
            listed = [f"{t} ({why})" for t, why in sorted(new_skips.items())]
            shown = ", ".join(listed[:8]) + (f" and {len(listed) - 8} more" if len(listed) > 8 else "")
            self._note(f"republish: {len(listed)} topic(s) not republished: {shown}")
        self._settle(created)
        return prepared

    def _settle(self, publishers: list[Any]) -> None:
        """Give new publishers a moment to match the subscribers already on the graph (`SETTLE_S` at most)."""
        if not publishers or self._ros is None:
            return
        node = self._ros.node
        deadline = time.monotonic() + SETTLE_S
        while time.monotonic() < deadline and not self._stop:
            if all(p.get_subscription_count() >= node.count_subscribers(p.topic_name) for p in publishers):
                return
            time.sleep(0.02)

    def _send(self, src: ReplaySource, prepared: _Prepared, move: Stream | Seek) -> None:
        """Publish what `move` calls for, then the clock."""
        store, types = src.store, prepared.types
        topics = sorted(prepared.publishers)
        if isinstance(move, Stream):
            batch = messages_between(store, types, topics, move.after, move.upto, MAX_STREAM)
            at = move.upto
            if batch is None:
                passed = sum(_index(store, t, move.upto) - _index(store, t, move.after) for t in topics)
                if not self.jumped:
                    self._note(
                        f"republish: the cursor passed {passed} messages at once (more than {MAX_STREAM}): "
                        "sent each topic's state at the cursor instead"
                    )
                self.jumped += passed
                batch = state_at(store, types, topics, move.upto)
                self.seeks += 1
        else:
            at = move.t
            batch = state_at(store, types, topics, move.t)
            self.seeks += 1
        publishers = prepared.publishers
        for message in batch:
            if self._stop:
                return
            publishers[message.topic].publish(message.payload)
            self.published += 1
        if self._clock_pub is not None:
            self._clock_pub.publish(clock_payload(at))
