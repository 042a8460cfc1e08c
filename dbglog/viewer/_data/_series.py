"""One binding's series: a bounded numpy ring of (source time, value), its last value, rate and status.

The engine's ROS thread pushes whole batches; any thread takes a snapshot. Both hold the series' own
lock only for array copies, never across ROS calls.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

from dbglog.viewer._data._fields import Scalar
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status, ValueKind, judge_age

__all__ = ["RATE_WINDOW_S", "Series"]

RATE_WINDOW_S = 5.0
"""The message rate is measured over at most this many recent seconds."""
_CHECKPOINT_EVERY_S = 0.1
_RATE_SETTLE_S = 0.2
"""The rate ignores the first moments of a series: a latched history arrives as one burst."""
_MAX_TEXTS = 1000


class Series:
    """The bounded history and live state of one binding."""

    def __init__(self, binding: Binding, capacity: int) -> None:
        if capacity < 1:
            raise ValueError(f"history must hold at least one value, not {capacity}")
        self.binding = binding
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
            self._kind = kind
            self._msg_type = msg_type
            self._error = error
            self._fresh = 0

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
        """Append a batch of numeric (or 0/1 bool) values with their source times."""
        n = len(values)
        if n == 0:
            return
        with self._lock:
            if n >= self._capacity:
                self._times[:] = times[-self._capacity :]
                self._values[:] = values[-self._capacity :]
                self._pos = 0
                self._filled = self._capacity
            else:
                end = self._pos + n
                if end <= self._capacity:
                    self._times[self._pos : end] = times
                    self._values[self._pos : end] = values
                else:
                    first = self._capacity - self._pos
                    self._times[self._pos :] = times[:first]
                    self._values[self._pos :] = values[:first]
                    self._times[: n - first] = times[first:]
                    self._values[: n - first] = values[first:]
                self._pos = end % self._capacity
                self._filled = min(self._filled + n, self._capacity)
            self._landed(n, last, float(times[-1]), now)

    def push_texts(self, times: Sequence[float], texts: Sequence[str], now: float) -> None:
        """Append a batch of text values."""
        if not texts:
            return
        with self._lock:
            self._texts.extend(texts)
            self._text_times.extend(times)
            self._landed(len(texts), texts[-1], times[-1], now)

    def push_array(self, count: int, last: tuple[float, ...], last_time: float, now: float) -> None:
        """Record `count` array messages; only the latest array is kept."""
        if count:
            with self._lock:
                self._landed(count, last, last_time, now)

    def _landed(self, n: int, last: Scalar, last_time: float, now: float) -> None:
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
