"""The publishing path: the calling thread appends (channel, value, source time) to a queue; a daemon
thread drains it every few ms into one batch message and the per-tag std_msgs messages.

The calling thread never publishes a scalar itself: a deque append is atomic under the GIL, so the hot
path takes no lock and sets no event (the thread is woken only when it went to sleep after being idle).
"""

from __future__ import annotations

import contextlib
import os
import struct
import threading
import time
from array import array
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any, Protocol

from dbglog._ros._batch import SLOT_FORMATS, encode_batch, pack_values, type_code
from dbglog.api._channel import LISTEN_CHECK_S, Channel
from dbglog.api._native import load

if TYPE_CHECKING:
    import threading

    from dbglog.api._errors import Reporter

__all__ = ["FLUSH_PERIOD", "LISTEN_CHECK_S", "QUEUE_CAPACITY", "Pipe", "pack_batch", "take_items"]

QUEUE_CAPACITY = 100_000
"""Queued samples at most (about 10 s at 10k samples/s, ~15 MB); more are dropped and counted."""
FLUSH_PERIOD = 0.010
"""Seconds between two drains while samples flow: the batch latency and the batch size. 10 ms rather
than 5: per sample, the publisher thread and a viewer spend less CPU on bigger batches (docs/api.md)."""
_IDLE_AFTER = 0.2
"""Seconds without samples after which the thread blocks until the next sample wakes it."""
_MAX_BATCH = 4096
"""Samples per batch message at most (a longer backlog goes out as several batches)."""
_YIELD_NS = 30_000
"""Publish for at most this long (ns) while holding the GIL, then sleep `_YIELD_S`: a user's loop that
wakes up meanwhile waits for the GIL for at most this long. (``sleep(0)`` is not enough: the GIL has
no fairness, this thread would take it straight back before a woken thread is scheduled.)"""
_YIELD_S = 1e-5
_PACK_CHUNK = 512
"""Samples whose values are packed in one C call (~15-25 µs holding the GIL) in a batch's values column."""


def _breathe(since: int, limit_ns: int = _YIELD_NS) -> int:
    """Let other threads take the GIL if this one has held it `limit_ns` since `since`; the new mark.

    Marks are ``time.perf_counter_ns()``. Only the publisher thread breathes: a flush on the caller's
    thread (``flush()``, shutdown) must not sleep.
    """
    now = time.perf_counter_ns()
    if now - since <= limit_ns:
        return since
    time.sleep(_YIELD_S)
    return time.perf_counter_ns()


_NEWEST_EVERY = 0.1
"""Seconds between two publishes of the newest value on the topic of a tag nobody subscribes to."""

Item = tuple[Channel, object, int]


class Runtime(Protocol):
    """What the pipe needs of the runtime that owns it (`dbglog.api._runtime.Runtime`)."""

    @property
    def _lock(self) -> threading.RLock:
        """Taken to start the publisher thread once."""

    @property
    def state(self) -> str:
        """Only ``ready`` publishes."""

    @property
    def reporter(self) -> Reporter:
        """Counts and warnings."""

    @property
    def batch_publish(self) -> Callable[[bytes], None] | None:
        """Publishes a batch's CDR bytes (None: no batch writer)."""

    def note_writer(self) -> None:
        """Warn (once each) about the writer thread's failed writes or starvation since the last look."""

    def send_queued(self, ch: Channel, value: object) -> bool:
        """Publish a queued sample on its tag's topic; False when it was dropped."""


_STRING = type_code("String")
_FLOAT32 = type_code("Float32")


class Pipe:
    """The queue between the logging calls and the publisher thread."""

    # Slots: the compiled hot path reads `capacity` and `sleeping` straight from them (dbglog/api/_hot.c).
    __slots__ = (
        "_event",
        "_pid",
        "_thread",
        "calls",
        "capacity",
        "lock",
        "pending",
        "queue",
        "runtime",
        "seq",
        "sleeping",
        "writer",
    )

    def __init__(self, runtime: Runtime) -> None:
        self.runtime = runtime
        self.queue: deque[Item] = deque()
        self.capacity = QUEUE_CAPACITY
        self.sleeping = True
        """True while the thread waits for a sample: the next append must call `wake`."""
        self.writer = int.from_bytes(os.urandom(8), "little")
        self.seq = 0
        self._event = threading.Event()
        self.lock = threading.RLock()
        """Held while publishing: whoever destroys publishers takes it first (then the runtime's lock)."""
        self._thread: threading.Thread | None = None
        self._pid = os.getpid()
        self.pending: dict[Channel, object] = {}
        """The newest value of each unwatched tag not yet on its topic (published every `_NEWEST_EVERY`)."""
        self.calls: deque[Callable[[], object]] = deque()
        """Work other dbglog packages hand to the publisher thread (`call_soon`), run before each flush."""

    # ----- calling threads ------------------------------------------------------------------------

    def wake(self) -> None:
        """Wake the thread (started on first use) after it went to sleep."""
        self.sleeping = False
        if self._thread is None or self._pid != os.getpid():
            self._start_thread()
        self._event.set()

    def call_soon(self, fn: Callable[[], object]) -> None:
        """Run `fn` on the publisher thread before its next flush (its errors are swallowed there)."""
        self.calls.append(fn)
        self.wake()

    def _run_calls(self) -> None:
        calls = self.calls
        while calls:
            try:
                fn = calls.popleft()
            except IndexError:  # emptied meanwhile (a reset)
                return
            with contextlib.suppress(Exception):
                fn()

    def _start_thread(self) -> None:
        with self.runtime._lock:
            if self._thread is not None and self._pid == os.getpid():
                return
            self._pid = os.getpid()
            self._thread = threading.Thread(target=self._run, name="dbglog-publisher", daemon=True)
            self._thread.start()

    def new_writer(self) -> None:
        """Start a new batch sequence (a new connection is a new writer for readers)."""
        self.writer = int.from_bytes(os.urandom(8), "little")
        self.seq = 0

    def drain(self, timeout: float) -> bool:
        """Publish everything queued now, on this thread; False when `timeout` ran out first."""
        deadline = time.monotonic() + timeout
        if not self.lock.acquire(timeout=max(0.0, timeout)):
            return False
        try:
            self._run_calls()
            todo = len(self.queue)
            while todo > 0 and self.queue:
                if time.monotonic() > deadline:
                    return False
                todo -= self._flush_once(yield_gil=False)
            self._publish_pending(time.monotonic(), force=True)
            return True
        finally:
            self.lock.release()

    def clear(self) -> None:
        """Forget queued samples and calls (a reset)."""
        self.queue.clear()
        self.calls.clear()
        with self.lock:  # the publisher thread walks `pending` under it
            self.pending.clear()

    def after_fork_in_child(self) -> None:
        """The parent's thread does not exist here: start afresh (a new thread on first use)."""
        self.queue.clear()  # the same deque: the hot path holds it
        self.pending.clear()
        self.calls.clear()
        self._event = threading.Event()
        self.lock = threading.RLock()
        self._thread = None
        self.sleeping = True
        self._pid = os.getpid()
        self.new_writer()

    # ----- the publisher thread -------------------------------------------------------------------

    def _run(self) -> None:
        idle_since = time.monotonic()
        queue = self.queue
        while True:
            if self._pid != os.getpid():  # pragma: no cover - a thread never survives a fork
                return
            if self.calls:
                self._run_calls()
            # One batch at a time (a drain() on another thread may take its turn). What came in while
            # it was published waits for the next period unless a full batch is waiting: a flush costs
            # about as much for 10 samples as for 100 (docs/api.md).
            backlog = len(queue)
            while backlog:
                # Failures are reported per sample; the thread itself must survive anything.
                with self.lock, contextlib.suppress(Exception):
                    self._flush_once(yield_gil=True)
                idle_since = time.monotonic()
                backlog = len(queue) >= _MAX_BATCH
            with contextlib.suppress(Exception):  # strict mode raises in warn: not the user's thread
                self.runtime.note_writer()
            idle = time.monotonic() - idle_since > _IDLE_AFTER
            if self.pending:  # all of them before going to sleep
                with self.lock, contextlib.suppress(Exception):
                    self._publish_pending(time.monotonic(), force=idle, yield_gil=True)
            if idle:
                self.sleeping = True
                if not self.queue and not self.calls:
                    self._event.wait()
                self._event.clear()
                self.sleeping = False
                idle_since = time.monotonic()
                continue
            time.sleep(FLUSH_PERIOD)
            queue = self.queue

    def _flush_once(self, *, yield_gil: bool) -> int:
        """Take up to `_MAX_BATCH` samples: one batch message, then each sample on its tag's topic.

        With `yield_gil` (the publisher thread) no stretch of it holds the GIL much longer than
        `_YIELD_NS` (`_breathe`): a caller's loop that wakes up meanwhile gets it within that. The
        per-sample work (`take`, `pack_batch`) runs in C when the compiled module is there.
        """
        mark = time.perf_counter_ns()  # the GIL held since (about) now: the thread just woke up
        items = take(self.queue, _MAX_BATCH)
        if not items:
            return 0
        runtime = self.runtime
        if runtime.state != "ready":
            for _ in items:
                runtime.reporter.count("shut_down")
            return len(items)
        publish = runtime.batch_publish
        try:
            order, newest, message = pack_batch_of(
                items, None if publish is None else self.writer, self.seq, _YIELD_NS if yield_gil else 0
            )
        except Exception as exc:  # a value that fits no slot: each sample goes on its topic, as checked
            self._batch_failed("encoding", len(items), exc)
            order, newest, message = list(dict.fromkeys(ch for ch, _, _ in items)), [], None
        if yield_gil:
            mark = _breathe(mark)
        batched = False
        if publish is not None and message is not None:
            self.seq += 1
            try:
                publish(message)  # without the GIL (dbglog/_ros/_nogil.py, dbglog/api/_writer.c)
                batched = True
            except BufferError as exc:  # the writer thread cannot keep up: drop, count, say it once
                self._writer_full(len(items), exc)
                return len(items)
            except Exception as exc:
                self._batch_failed("publishing", len(items), exc)
        if yield_gil:
            time.sleep(_YIELD_S)
            mark = time.perf_counter_ns()
        published = runtime.reporter.published
        now = time.monotonic()
        watched: set[Channel] = set()
        for c in order:
            if now - c.checked > LISTEN_CHECK_S:
                c.listened(now)  # a C call: count the tag's subscribers
                if yield_gil:
                    mark = _breathe(mark)
            if not (batched and c.alive and not c.listening):
                watched.add(c)
        pending = self.pending
        if not watched:  # only the viewer listens (it reads the batch): each tag's newest on its topic
            published.add(len(items))
            pending.update(zip(order, newest, strict=True))
            self._publish_pending(now, yield_gil=yield_gil)
            return len(items)
        if not pending.keys().isdisjoint(watched):  # a subscriber came: its tag's older newest first
            self._publish_pending(now, force=True, only=watched, yield_gil=yield_gil)
        send = runtime.send_queued
        sent = 0
        try:
            for ch, value, _ in items:
                if ch not in watched:
                    pending[ch] = value  # in the batch; nobody reads the tag's topic: its newest goes there
                    sent += 1
                    continue
                encode = ch.encode
                if encode is not None and ch.alive:
                    try:
                        ch.publish_raw(encode(value))
                    except BufferError as exc:  # the writer is full: not around it (the order)
                        self._writer_full(1, exc)
                    except Exception:  # the general path retries, recovers and reports
                        if send(ch, value):
                            sent += 1
                    else:
                        sent += 1
                elif send(ch, value):
                    sent += 1
                if yield_gil:
                    mark = _breathe(mark)
        finally:
            published.add(sent)
        self._publish_pending(now, yield_gil=yield_gil)
        return len(items)

    def _writer_full(self, samples: int, exc: BufferError) -> None:
        """Count `samples` dropped because the writer thread is full; say it once."""
        reporter = self.runtime.reporter
        for _ in range(samples):
            reporter.count("queue_full")
        with contextlib.suppress(Exception):  # strict mode raises here: not the user's thread
            reporter.warn(
                "queue_full",
                "writer_full",
                f"dbglog: {exc}; values are dropped until it catches up (other work keeps it off the CPUs, "
                "or the middleware does not take the messages)",
                exc,
            )

    def _batch_failed(self, step: str, samples: int, exc: Exception) -> None:
        """Warn (once) that a batch could not be encoded or published: its samples go on their topics."""
        with contextlib.suppress(Exception):  # strict mode raises here: not the user's thread
            self.runtime.reporter.warn(
                "publish_failed",
                "batch",
                f"dbglog: {step} a batch of {samples} samples failed ({type(exc).__name__}: {exc}); "
                "the viewer misses them, ROS tools still get them",
                exc,
            )

    def _publish_pending(
        self, now: float, *, force: bool = False, only: set[Channel] | None = None, yield_gil: bool = False
    ) -> None:
        """Publish the pending newest values whose tag's last one went out `_NEWEST_EVERY` ago (or all, if
        `force`; or only those of `only`) on their topics (the batch carried and counted every sample)."""
        mark = time.perf_counter_ns()
        pending = self.pending
        due = [
            ch
            for ch in pending
            if (only is None or ch in only) and (force or now - ch.newest_sent >= _NEWEST_EVERY)
        ]
        for ch in due:
            value = pending.pop(ch)
            ch.newest_sent = now
            if not ch.alive:  # destroyed meanwhile (shutdown, init): the batch had it
                continue
            with contextlib.suppress(Exception):
                if ch.encode is not None:
                    ch.publish_raw(ch.encode(value))
                else:
                    ch.send(value, message=False)
            if yield_gil:
                mark = _breathe(mark)


def take_items(queue: deque[Item], limit: int) -> list[Item]:
    """Pop up to `limit` samples from the queue's left end (fewer if it empties meanwhile)."""
    popleft = queue.popleft
    items: list[Item] = []
    with contextlib.suppress(IndexError):  # emptied meanwhile (a reset)
        for _ in range(min(len(queue), limit)):
            items.append(popleft())
    return items


def pack_batch(
    items: list[Item], writer: int | None, seq: int, breathe_ns: int
) -> tuple[list[Channel], list[object], bytes | None]:
    """Return the samples' channels (first seen first), each one's last value, and the batch message.

    The message is `encode_batch`'s CDR bytes of the samples (None when `writer` is None). With
    `breathe_ns` the GIL is let go between chunks once held that long (`_breathe`). The compiled
    module's ``pack_batch`` returns the same, byte for byte (tests/test_flush_c.py).

    Raises:
        struct.error, TypeError, OverflowError, ValueError: a value does not fit its tag's slot.
    """
    mark = time.perf_counter_ns()
    chans: tuple[Channel, ...] = ()
    vals: tuple[object, ...] = ()
    times: tuple[int, ...] = ()
    if items:
        chans, vals, times = zip(*items, strict=True)
    last = dict(zip(chans, vals, strict=True))  # first seen first, the last value
    order = list(last)
    newest = list(last.values())
    if writer is None:
        return order, newest, None
    lookup = {c: i for i, c in enumerate(order)}
    codes = [c.code for c in order]
    index = array("H", map(lookup.__getitem__, chans))
    strings: list[bytes] = []
    numbers: Any = vals
    if _STRING in codes or _FLOAT32 in codes:  # texts become their number, Float32 values are rounded
        numbers = list(vals)
        for i, code in enumerate(map(codes.__getitem__, index)):
            if code == _STRING:
                strings.append(str(numbers[i]).encode("utf-8", "replace"))
                numbers[i] = len(strings) - 1
            elif code == _FLOAT32:
                numbers[i] = _float32(numbers[i])
    # Each value in its tag's slot (f64, i64 or u64: integers exact), packed by C loops.
    kinds = [SLOT_FORMATS[code] for code in codes]
    slots = kinds[0] * len(chans) if len(set(kinds)) == 1 else "".join(map(kinds.__getitem__, index))
    parts: list[bytes] = []
    for i in range(0, len(chans), _PACK_CHUNK):  # a backlog in pieces: `_breathe` between them
        if breathe_ns:
            mark = _breathe(mark, breathe_ns)
        parts.append(pack_values(slots[i : i + _PACK_CHUNK], numbers[i : i + _PACK_CHUNK]))
    tags = [(c.code, c.tag_bytes) for c in order]
    message = encode_batch(writer, seq, tags, index, array("q", times), b"".join(parts), strings)
    return order, newest, message


_pack_f = struct.Struct("<f").pack
_unpack_f = struct.Struct("<f").unpack


def _float32(value: Any) -> float:
    """Round to float32, as the tag's Float32 message holds it."""
    result: float = _unpack_f(_pack_f(value))[0]
    return result


_native = load()
take: Callable[[deque[Item], int], list[Item]] = take_items if _native is None else _native.take
"""`take_items`, in C when the compiled module is there."""
Packed = tuple[list[Channel], list[object], bytes | None]
pack_batch_of: Callable[[list[Item], int | None, int, int], Packed] = (
    pack_batch if _native is None else _native.pack_batch
)
"""`pack_batch`, in C when the compiled module is there."""
