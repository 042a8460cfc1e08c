"""One binding's series: a bounded numpy ring of (source time, value), its last value, rate and status.

The engine's ROS thread pushes whole batches; any thread takes a snapshot. Both hold the series' own
lock only for array copies, never across ROS calls. The ring is ordered by source time, whatever the
arrival order (two publishers of one tag, a late batch): a batch older than the newest sample held is
merged in place (docs/history.md, "The live ring"). With a `History` (the engine's), every value the
series takes is also kept there under the series' own key, time-indexed within the viewer's history
budget: that is what `snapshot_at` answers from when the dashboard travels back in time.
"""

from __future__ import annotations

import itertools
import math
import threading
import time
from collections import deque
from collections.abc import Sequence
from dataclasses import replace

import numpy as np
import numpy.typing as npt

from dbglog.viewer._data._fields import Scalar
from dbglog.viewer._data._history import History, HistoryStats
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind, judge_age
from dbglog.viewer._data._timeline import NOT_YET, cut_at, typed_like

__all__ = ["NO_MESSAGE_YET", "RATE_WINDOW_S", "Series", "SeriesTimes"]

RATE_WINDOW_S = 5.0
"""The message rate is measured over at most this many recent seconds."""
NO_MESSAGE_YET = "subscribed; no message yet"
"""A subscribed series' waiting reason until its first value (the engine refines it from DDS matching)."""
_CHECKPOINT_EVERY_S = 0.1
_RATE_SETTLE_S = 0.2
"""The rate ignores the first moments of a series: a latched history arrives as one burst."""
_MAX_TEXTS = 1000
_SMALL = 128
"""A batch up to this size is checked for order in plain Python (cheaper than numpy calls)."""
_MIN_WINDOW_S = 60.0
"""A series at a past time carries at least this many seconds of samples before it (plots need a past)."""


def _in_order(times: npt.NDArray[np.float64], newest: float) -> bool:
    """Whether a batch is sorted and not older than `newest` (the common case: appended as it is)."""
    if len(times) <= _SMALL:
        tl: list[float] = times.tolist()
        return tl[0] >= newest and tl == sorted(tl)
    return bool(times[0] >= newest) and not bool((times[1:] < times[:-1]).any())


def _unsorted(times: npt.NDArray[np.float64]) -> bool:
    """Whether a batch's source times go back somewhere."""
    if len(times) <= _SMALL:
        tl: list[float] = times.tolist()
        return tl != sorted(tl)
    return bool((times[1:] < times[:-1]).any())


class Series:
    """The bounded history and live state of one binding."""

    def __init__(self, binding: Binding, capacity: int, store: History | None = None) -> None:
        if capacity < 1:
            raise ValueError(f"history must hold at least one value, not {capacity}")
        self.binding = binding
        self.store = store
        """Where every value is also kept by time (None: the ring is all there is)."""
        self.own_key = f"\x00series:{id(self):x}"
        """This series' own name in the store (never a topic name: those start with '/')."""
        self.key = self.own_key
        """Where its past is read: its own key, or its topic's when its values are the topic's own."""
        self._lock = threading.Lock()
        self._capacity = capacity
        self._times = np.full(capacity, np.nan)  # touch the pages now: RSS stays flat later
        self._values = np.full(capacity, np.nan)
        self._pos = 0
        self._filled = 0
        self._texts: deque[str] = deque(maxlen=min(capacity, _MAX_TEXTS))
        self._text_times: deque[float] = deque(maxlen=min(capacity, _MAX_TEXTS))
        self._kind: ValueKind | None = None
        self._msg_type: str | None = None
        self._last: Scalar | None = None
        self._last_time: float | None = None
        self._last_rx: float | None = None
        self._first_rx: float | None = None
        self._count = 0
        self._fresh = 0
        """Values since the type was last set (0 = waiting for the first one)."""
        self._error = ""
        self._waiting = "topic is not on the ROS graph yet"
        self._checkpoints: deque[tuple[float, int]] = deque(
            maxlen=int(RATE_WINDOW_S / _CHECKPOINT_EVERY_S) + 8
        )

    # --- writer side (the engine's ROS thread) ----------------------------------------------------

    def set_type(self, msg_type: str, kind: ValueKind, *, error: str = "") -> None:
        """Record the type now bound; a different value kind clears the history."""
        with self._lock:
            if self._kind is not None and kind != self._kind:
                self._clear()
                if self.store is not None:
                    self.store.drop(self.own_key)
            self._kind = kind
            self._msg_type = msg_type
            self._error = error
            self._fresh = 0

    def share(self, topic: str | None) -> None:
        """Read the past from `topic`'s history (its values are the topic's own); None: from its own key."""
        key = self.own_key if topic is None else topic
        if key == self.key:
            return
        with self._lock:
            if self.store is not None and topic is not None:
                self.store.drop(self.own_key)
            self.key = key

    def set_error(self, reason: str, *, msg_type: str | None = None) -> None:
        """Put the series in ERROR with `reason` until the next good value."""
        with self._lock:
            self._error = reason
            if msg_type is not None:
                self._msg_type = msg_type

    def set_waiting(self, reason: str) -> None:
        """Say why no value has arrived yet (shown while the series is WAITING)."""
        with self._lock:
            self._waiting = reason

    def push_numbers(
        self, times: npt.NDArray[np.float64], values: npt.NDArray[np.float64], last: Scalar, now: float
    ) -> None:
        """Take a batch of numeric (or 0/1 bool) values with their source times, in arrival order.

        `last` is the batch's last value with its type kept (an int stays exact). The ring stays ordered
        by source time: a sorted batch not older than the newest sample held is appended; any other is
        merged in place (`_merge`). The series' value is that of its newest sample by source time.
        """
        n = len(values)
        if n == 0:
            return
        with self._lock:
            newest = self._newest_number()
            if _in_order(times, newest):
                self._write(times, values)
                self._landed(n, last, float(times[-1]), now)
            else:
                at = self._merge(times, values)
                if at is None:  # older than the newest held: the value shown stays
                    self._landed(n, self._last, self._last_time, now)
                else:
                    value = last if at == n - 1 else typed_like(last, float(values[at]))
                    self._landed(n, value, float(times[at]), now)
        store = self.store
        if store is not None and self.key is self.own_key:
            store.append_numbers(self.key, times, values)

    def _newest_number(self) -> float:
        """The source time of the ring's newest sample (-inf when empty)."""
        if not self._filled:
            return -math.inf
        return float(self._times[self._pos - 1])  # (index -1 when pos is 0: the ring's last slot)

    def _write(self, times: npt.NDArray[np.float64], values: npt.NDArray[np.float64]) -> None:
        """Append sorted samples after the newest (the oldest beyond the capacity go)."""
        n = len(values)
        cap = self._capacity
        if n >= cap:
            self._times[:] = times[-cap:]
            self._values[:] = values[-cap:]
            self._pos = 0
            self._filled = cap
            return
        end = self._pos + n
        if end <= cap:
            self._times[self._pos : end] = times
            self._values[self._pos : end] = values
        else:
            first = cap - self._pos
            self._times[self._pos :] = times[:first]
            self._values[self._pos :] = values[:first]
            self._times[: n - first] = times[first:]
            self._values[: n - first] = values[first:]
        self._pos = end % cap
        self._filled = min(self._filled + n, cap)

    def _merge(self, times: npt.NDArray[np.float64], values: npt.NDArray[np.float64]) -> int | None:
        """Sort a batch into the ring: only the held samples newer than its oldest are rewritten.

        Returns the batch index of its newest sample when that is the newest of the series now (ties: the
        later arrival), None when the series' newest sample is one held before.
        """
        newest_at = len(times) - 1
        if _unsorted(times):
            order = np.argsort(times, kind="stable")  # ties keep arrival order
            times, values, newest_at = times[order], values[order], int(order[-1])
        cap, filled = self._capacity, self._filled
        start = self._pos if filled == cap else 0
        if filled == cap:  # a full ring: what is older than all it holds would fall off at once
            old = int(np.searchsorted(times, self._times[start], side="left"))
            if old == len(times):
                return None
            times, values = times[old:], values[old:]
        # The held samples after the batch's oldest (those at its time stay first): the ring's logical
        # positions j.. (physical: from start + j, wrapping past the end).
        t0 = times[0]
        if start and t0 >= self._times[0]:
            j = cap - start + int(np.searchsorted(self._times[: self._pos], t0, side="right"))
        else:
            j = int(np.searchsorted(self._times[start : start + filled], t0, side="right"))
        k = filled - j
        p = (start + j) % cap
        if p + k <= cap:
            held_t, held_v = self._times[p : p + k], self._values[p : p + k]
        else:
            held_t = np.concatenate((self._times[p:], self._times[: p + k - cap]))
            held_v = np.concatenate((self._values[p:], self._values[: p + k - cap]))
        newest = k == 0 or times[-1] >= held_t[-1]
        merged_t = np.concatenate((held_t, times))
        keep = np.argsort(merged_t, kind="stable")  # what was held first stays first for equal times
        merged_v = np.concatenate((held_v, values))[keep]
        self._pos, self._filled = p, j  # drop the held tail, write it back merged
        self._write(merged_t[keep], merged_v)
        return newest_at if newest else None

    def push_texts(self, times: Sequence[float], texts: Sequence[str], now: float) -> None:
        """Take a batch of text values (arrival order); the texts held stay ordered by source time."""
        if not texts:
            return
        with self._lock:
            held_t, held = self._text_times, self._texts
            ordered = all(a <= b for a, b in itertools.pairwise(times))
            if ordered and (not held_t or times[0] >= held_t[-1]):
                held.extend(texts)
                held_t.extend(times)
                self._landed(len(texts), texts[-1], times[-1], now)
            else:
                order = sorted(range(len(times)), key=times.__getitem__)  # stable: ties in arrival order
                late_t, late = [times[i] for i in order], [texts[i] for i in order]
                back_t: list[float] = []
                back: list[str] = []
                while held_t and held_t[-1] > late_t[0]:  # the held texts newer than the batch's oldest
                    back_t.append(held_t.pop())
                    back.append(held.pop())
                back_t.reverse()
                back.reverse()
                pairs = sorted(zip(back_t + late_t, back + late, strict=True), key=lambda p: p[0])
                held_t.extend(t for t, _ in pairs)
                held.extend(x for _, x in pairs)
                if not back_t or late_t[-1] >= back_t[-1]:  # the batch has the newest (ties: it came later)
                    self._landed(len(texts), late[-1], late_t[-1], now)
                else:
                    self._landed(len(texts), self._last, self._last_time, now)
        store = self.store
        if store is not None and self.key is self.own_key:
            store.append_payloads(self.key, times, [t.encode("utf-8", "replace") for t in texts])

    def push_array(self, count: int, last: tuple[float, ...], last_time: float, now: float) -> None:
        """Record `count` array messages; only the latest array is kept."""
        if count:
            with self._lock:
                if self._last_time is not None and last_time < self._last_time:  # an older array: not shown
                    self._landed(count, self._last, self._last_time, now)
                else:
                    self._landed(count, last, last_time, now)
            store = self.store
            if store is not None and self.key is self.own_key:
                blob = np.asarray(last, dtype=np.float64).tobytes()  # only the latest array is kept
                store.append_payloads(self.key, [last_time], [blob])

    def _landed(self, n: int, last: Scalar | None, last_time: float | None, now: float) -> None:
        if self._first_rx is None:
            self._first_rx = now
        if now - self._first_rx >= _RATE_SETTLE_S and (
            not self._checkpoints or now - self._checkpoints[-1][0] >= _CHECKPOINT_EVERY_S
        ):
            self._checkpoints.append((now, self._count + n))
        self._count += n
        self._fresh += n
        self._last = last
        self._last_time = last_time
        self._last_rx = now
        self._error = ""

    def _clear(self) -> None:
        self._pos = self._filled = 0
        self._texts.clear()
        self._text_times.clear()
        self._last = self._last_time = None

    # --- reader side (any thread) -----------------------------------------------------------------

    @property
    def count(self) -> int:
        """Values taken into this series so far."""
        return self._count

    def snapshot(self, stale_after: float, now: float | None = None) -> SeriesSnapshot:
        """Return a consistent copy of the series as it stands."""
        now = time.monotonic() if now is None else now
        with self._lock:
            if self._kind == ValueKind.TEXT:
                times = np.fromiter(self._text_times, dtype=np.float64, count=len(self._text_times))
                values = np.empty(0)
                texts = tuple(self._texts)
            elif self._kind == ValueKind.ARRAY:
                times = values = np.empty(0)
                texts = ()
            elif self._filled < self._capacity:
                times = self._times[: self._filled].copy()
                values = self._values[: self._filled].copy()
                texts = ()
            else:
                times = np.concatenate((self._times[self._pos :], self._times[: self._pos]))
                values = np.concatenate((self._values[self._pos :], self._values[: self._pos]))
                texts = ()
            age = None if self._last_rx is None else max(0.0, now - self._last_rx)
            if self._error:
                status, reason = Status.ERROR, self._error
            elif self._fresh == 0 or age is None:
                status, reason = Status.WAITING, self._waiting
            else:
                status, reason = judge_age(age, stale_after)
            return SeriesSnapshot(
                binding=self.binding,
                status=status,
                reason=reason,
                kind=self._kind,
                msg_type=self._msg_type,
                times=times,
                values=values,
                texts=texts,
                last=self._last,
                last_time=self._last_time,
                rate_hz=self._rate(now),
                age_s=age,
                count=self._count,
            )

    def snapshot_at(self, t: float, stale_after: float, past: float | None = None) -> SeriesSnapshot:
        """Return the series as it stood at source time `t` (from the store; without one, from the ring).

        Numbers: the samples of the window the ring spans live (at least `_MIN_WINDOW_S`, at most the
        ring's capacity) that end at `t`; text: the texts up to `t`; the value, age and status at `t`.
        With `past` (seconds), numbers stop at the last `past` seconds before `t` and the sample just before
        them (a line drawn from them reaches the window's edge): a gauge asks for 0 (the sample at `t`
        alone), a plot for its visible range; every other field is the same.
        """
        store = self.store
        if store is None:
            return cut_at(self.snapshot(stale_after), t, stale_after)
        with self._lock:
            kind, msg_type, error, last_live = self._kind, self._msg_type, self._error, self._last
            if self._filled:
                newest = self._times[self._pos - 1] if self._pos else self._times[self._capacity - 1]
                oldest = self._times[self._pos] if self._filled == self._capacity else self._times[0]
                span = float(newest - oldest)
            else:
                span = float(self._text_times[-1] - self._text_times[0]) if self._text_times else 0.0
        base = SeriesSnapshot(self.binding, Status.WAITING, NOT_YET, kind=kind, msg_type=msg_type)
        if error and self._count == 0:
            return replace(base, status=Status.ERROR, reason=error)
        sample = store.at(self.key, t)
        if sample is None:
            return base
        window = max(span, _MIN_WINDOW_S)
        times: npt.NDArray[np.float64] = np.empty(0)
        values: npt.NDArray[np.float64] = np.empty(0)
        texts: tuple[str, ...] = ()
        last: Scalar
        if kind == ValueKind.TEXT:
            times, payloads = store.payloads(self.key, t - window, t)
            times, payloads = times[-_MAX_TEXTS:], payloads[-_MAX_TEXTS:]
            texts = tuple(p.decode("utf-8", "replace") for p in payloads)
            last = texts[-1] if texts else bytes(sample.value).decode("utf-8", "replace")  # type: ignore[arg-type]
        elif kind == ValueKind.ARRAY:
            assert isinstance(sample.value, bytes)
            last = tuple(np.frombuffer(sample.value, dtype=np.float64).tolist())
        else:
            t0 = t - window
            if past is not None and past < window:  # from the sample at or before t - past (or `sample`)
                edge = store.at(self.key, t - past) if past > 0 else sample
                t0 = max(t0, edge.time if edge is not None else t - past)  # never more than without `past`
            times, raw = store.range(self.key, t0, t)
            times, values = times[-self._capacity :], raw[-self._capacity :].astype(np.float64, copy=False)
            stored = sample.value
            last = typed_like(last_live, stored if isinstance(stored, int) else float(stored))
        age = t - sample.time
        status, reason = (Status.ERROR, error) if error else judge_age(age, stale_after)
        before = store.at(self.key, t - RATE_WINDOW_S)  # the rate over the window before t, as live
        recent = sample.index - (before.index if before is not None else -1)
        rate = recent / RATE_WINDOW_S if recent > 1 else 0.0
        return SeriesSnapshot(
            self.binding,
            status,
            reason,
            kind=kind,
            msg_type=msg_type,
            times=times,
            values=values,
            texts=texts,
            last=last,
            last_time=sample.time,
            rate_hz=rate,
            age_s=age,
            count=sample.index + 1,
        )

    def between(self, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return this series' samples with ``t0 <= time <= t1``: times and values (numbers or texts)."""
        store = self.store
        kind = self._kind
        if store is None:
            snap = self.snapshot(1e9)
            keep = (snap.times >= t0) & (snap.times <= t1)
            if kind == ValueKind.TEXT:
                return snap.times[keep], [x for x, k in zip(snap.texts, keep.tolist(), strict=False) if k]
            return snap.times[keep], list(snap.values[keep].tolist())
        if kind == ValueKind.TEXT:
            times, payloads = store.payloads(self.key, t0, t1)
            return times, [p.decode("utf-8", "replace") for p in payloads]
        if kind == ValueKind.ARRAY:
            times, payloads = store.payloads(self.key, t0, t1)
            return times, [tuple(np.frombuffer(p, dtype=np.float64).tolist()) for p in payloads]
        times, values = store.range(self.key, t0, t1)
        if kind == ValueKind.BOOL:
            return times, [bool(v) for v in values.tolist()]
        return times, list(values.tolist())

    def envelope(
        self, t0: float, t1: float, pixels: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
        """Return a min/max envelope of this series' numbers over ``[t0, t1]`` for a plot `pixels` wide.

        From the store, far beyond the ring a snapshot holds (see `History.decimate`); None without a
        store or for text and arrays.
        """
        store = self.store
        if store is None or self._kind not in (ValueKind.NUMBER, ValueKind.BOOL) or not store.count(self.key):
            return None
        return store.decimate(self.key, t0, t1, pixels)

    def held(self) -> int:
        """Return how many of this series' samples its store holds (the ring's size without a store)."""
        if self.store is not None:
            return self.store.count(self.key)
        with self._lock:
            return self._filled if self._kind not in (ValueKind.TEXT,) else len(self._texts)

    def neighbour_time(self, t: float, direction: int) -> float | None:
        """Return the time of this series' previous (-1) or next (+1) sample strictly around `t`."""
        if self.store is None:
            return None
        if direction < 0:
            return self.store.prev_time(self.key, t)
        return self.store.next_time(self.key, t)

    def _rate(self, now: float) -> float:
        """Messages per second over the recent window; decays once messages stop."""
        if self._last_rx is None:
            return 0.0
        start = next(((t, c) for t, c in self._checkpoints if now - t <= RATE_WINDOW_S), None)
        if start is None:
            return 0.0
        t0, c0 = start
        n = self._count - c0
        if n <= 0 or self._last_rx <= t0:
            return 0.0
        span = self._last_rx - t0
        if now - self._last_rx > span / n:  # quieter than usual: count the silence too
            span = now - t0
        return n / span


class SeriesTimes:
    """The `TimeSource` half of a data source whose bindings are `Series` over one `History`.

    The engine (live) and a replay (a recording) answer "the state at time t" the same way: from each
    binding's series and the store they share. Subclasses set ``store``, ``stale_after`` and ``_series``.
    """

    store: History
    stale_after: float
    _series: dict[Binding, Series]

    def snapshot_at(self, binding: Binding, t: float) -> SeriesSnapshot:
        """Return the series for `binding` as it stood at source time `t` (epoch seconds)."""
        series = self._series.get(binding)
        if series is None:
            return SeriesSnapshot(binding, Status.ERROR, reason="not bound (call bind() first)")
        if series.count == 0:  # nothing to travel through yet: say why (not published, a bad field ...)
            return series.snapshot(self.stale_after)
        return series.snapshot_at(t, self.stale_after)

    def snapshot_recent(self, binding: Binding, t: float, past: float) -> SeriesSnapshot:
        """Return `snapshot_at`'s answer with only the last `past` seconds of samples before `t` (see
        `Series.snapshot_at`): what a widget that shows a value, or a short range, needs."""
        series = self._series.get(binding)
        if series is None or series.count == 0:
            return self.snapshot_at(binding, t)
        return series.snapshot_at(t, self.stale_after, past)

    def time_span(self) -> tuple[float, float] | None:
        """Return (oldest, newest) source time the history holds, None while it is empty."""
        stats = self.store.stats()
        if stats.oldest is None or stats.newest is None:
            return None
        return stats.oldest, stats.newest

    def neighbour_time(self, binding: Binding, t: float, direction: int) -> float | None:
        """Return the time of the binding's previous (-1) or next (+1) sample strictly around `t`."""
        series = self._series.get(binding)
        return None if series is None else series.neighbour_time(t, direction)

    def between(self, binding: Binding, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return the binding's samples with ``t0 <= time <= t1`` (times and values), for an export."""
        series = self._series.get(binding)
        return (np.empty(0), []) if series is None else series.between(t0, t1)

    def envelope(
        self, binding: Binding, t0: float, t1: float, pixels: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
        """Return a min/max envelope of the binding's numbers over ``[t0, t1]`` for a plot `pixels` wide."""
        series = self._series.get(binding)
        return None if series is None else series.envelope(t0, t1, pixels)

    def history_stats(self) -> HistoryStats:
        """Return what the history holds (span, samples, bytes)."""
        return self.store.stats()

    def samples_held(self, binding: Binding) -> int:
        """Return how many samples of `binding`'s series the history holds."""
        series = self._series.get(binding)
        return 0 if series is None else series.held()
