"""One time cursor for every widget: a `DataSource` that answers "the state at time t".

`Timeline` wraps the viewer's data source. Live, it passes snapshots through untouched; paused at a
time `t` (source time, epoch seconds), every snapshot it hands out is the series *as it stood at t*:
samples up to `t`, the last value at `t`, the status judged by the age at `t`. Widgets, built-in or
from plugins, read snapshots as they always did and so travel in time without knowing it.

A source with a history implements `TimeSource` (the engine does: it answers from its time-indexed
store, far beyond a series' ring); any other source is cut by `cut_at`. Pure logic: no ROS, no Dear
PyGui; the UI thread owns a `Timeline`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterable
from dataclasses import replace
from typing import Protocol, runtime_checkable

import numpy as np
import numpy.typing as npt

from dbglog._ros._numbers import NumberType, as_number
from dbglog.viewer._data._fields import Scalar
from dbglog.viewer._data._history import HistoryStats
from dbglog.viewer._data._model import (
    Binding,
    DataSource,
    FieldInfo,
    SeriesSnapshot,
    Status,
    TopicInfo,
    ValueKind,
    judge_age,
)

__all__ = ["NOT_YET", "TimeSource", "Timeline", "cut_at", "typed_like"]

NOT_YET = "no value yet at the cursor time"
"""The reason a series shows WAITING when the cursor is before its first sample."""


@runtime_checkable
class TimeSource(Protocol):
    """A data source that remembers: snapshots at any time it still holds."""

    def snapshot_at(self, binding: Binding, t: float) -> SeriesSnapshot:
        """Return the series of `binding` as it stood at source time `t`."""

    def time_span(self) -> tuple[float, float] | None:
        """Return (oldest, newest) source time held over every series, None when empty."""

    def neighbour_time(self, binding: Binding, t: float, direction: int) -> float | None:
        """Return the time of the binding's previous (-1) or next (+1) sample strictly around `t`."""

    def history_stats(self) -> HistoryStats:
        """Return what the history holds (span, samples, bytes) for the status bar."""

    def between(self, binding: Binding, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return the binding's samples with ``t0 <= time <= t1`` (times and values), for an export."""


def cut_at(snapshot: SeriesSnapshot, t: float, stale_after: float) -> SeriesSnapshot:
    """Return `snapshot` as it stood at time `t`: its samples up to `t`, its value and status then.

    Works on any snapshot (a source without a history of its own): what the snapshot holds is all
    there is, so a time older than its oldest sample reads as "no value yet".
    """
    if snapshot.status is Status.ERROR and snapshot.count == 0:
        return snapshot
    times = snapshot.times
    n = int(np.searchsorted(times, t, side="right"))
    if snapshot.kind is ValueKind.ARRAY or not len(times):
        if snapshot.last_time is None or snapshot.last_time > t:
            return _not_yet(snapshot)
        age = t - snapshot.last_time
        status, reason = judge_age(age, stale_after)
        return replace(snapshot, status=status, reason=reason, age_s=age)
    if n == 0:
        return _not_yet(snapshot)
    last_time = float(times[n - 1])
    if snapshot.kind is ValueKind.TEXT:
        texts = snapshot.texts[: n - (len(times) - len(snapshot.texts))] if snapshot.texts else ()
        last: object = texts[-1] if texts else snapshot.last
        values = snapshot.values
    else:
        values = snapshot.values[:n]
        last = typed_like(snapshot.last, float(values[-1]))
        texts = snapshot.texts
    age = t - last_time
    status, reason = judge_age(age, stale_after)
    if snapshot.status is Status.ERROR:
        status, reason = snapshot.status, snapshot.reason
    return replace(
        snapshot,
        status=status,
        reason=reason,
        times=times[:n],
        values=values,
        texts=texts,
        last=last,  # type: ignore[arg-type]
        last_time=last_time,
        age_s=age,
        rate_hz=_rate(times[:n], t),
        count=snapshot.count - (len(times) - n),
    )


def _not_yet(snapshot: SeriesSnapshot) -> SeriesSnapshot:
    """The series before its first sample."""
    return replace(
        snapshot,
        status=Status.WAITING,
        reason=NOT_YET,
        times=np.empty(0),
        values=np.empty(0),
        texts=(),
        last=None,
        last_time=None,
        age_s=None,
        rate_hz=0.0,
        count=0,
    )


def typed_like(example: object, value: float | int) -> float | int | bool:
    """Give a stored number the Python type the live series' last value has (`as_number`: an integer
    stays exact, beyond 2**53 too); without a number there, the stored number keeps its own."""
    want: NumberType
    if isinstance(example, bool):
        want = bool
    elif isinstance(example, float):
        want = float
    else:
        want = int if isinstance(example, int) or isinstance(value, int) else float
    return as_number(value, want)


def _rate(times: np.ndarray, t: float, window: float = 5.0) -> float:
    """Messages per second over the `window` seconds before `t`."""
    if len(times) < 2:
        return 0.0
    k = int(np.searchsorted(times, t - window, side="left"))
    n = len(times) - k
    if n < 2:
        return 0.0
    span = max(t - float(times[k]), float(times[-1]) - float(times[k]))
    return (n - 1) / span if span > 0 else 0.0


class Timeline:
    """The viewer's time cursor over a data source: live, paused at a source time, or playing.

    Live, widgets follow the newest data (for a recording: its end). Paused, they show the state at the
    cursor. Playing, the cursor advances with the wall clock times `speed` from where it was, up to the
    newest data (a recording loops back to its start with `loop`); playing a live history up to now
    returns to live.

    Args:
        source: the data source (the engine, a replay, a `StaticSource`).
        stale_after: seconds without a sample that make a series STALE at the cursor time.
        clock: wall clock (epoch seconds); pausing with no history pauses at its time.
        ticks: a monotonic clock (seconds) that drives playback.
        recording: the source is a recording: nothing new arrives, Space plays and pauses, and
            playback stops (or loops) at its end instead of going live.
    """

    SPEEDS = (0.1, 0.25, 0.5, 1.0, 2.0, 5.0, 10.0)
    """The playback speeds offered (any in [0.1, 10] is accepted)."""

    def __init__(
        self,
        source: DataSource,
        *,
        stale_after: float = 2.0,
        clock: Callable[[], float] = time.time,
        ticks: Callable[[], float] = time.monotonic,
        recording: bool = False,
    ) -> None:
        self._source = source
        self._timed: TimeSource | None = source if isinstance(source, TimeSource) else None
        """The source when it has a history (a protocol check is slow: made once, not per snapshot)."""
        self.recording = recording
        self.stale_after = stale_after
        self._clock = clock
        self._ticks = ticks
        self.cursor: float | None = None
        """The source time shown (epoch seconds), or None while live."""
        self.playing = False
        """True while the cursor advances by itself."""
        self.speed = 1.0
        self.loop = False
        """Playing past the end starts again at the start (recordings)."""
        self._anchor = (0.0, 0.0)
        """(ticks, cursor) when playback last started or was re-anchored."""

    @property
    def source(self) -> DataSource:
        """The data source the cursor travels through."""
        return self._source

    @source.setter
    def source(self, source: DataSource) -> None:
        self._source = source
        self._timed = source if isinstance(source, TimeSource) else None

    # --- state --------------------------------------------------------------------------------------

    @property
    def live(self) -> bool:
        """True while the widgets follow the newest data."""
        return self.cursor is None

    def span(self) -> tuple[float, float] | None:
        """Return (oldest, newest) source time the source holds, None when it holds nothing."""
        if self._timed is not None:
            return self._timed.time_span()
        return None

    def stats(self) -> HistoryStats | None:
        """Return what the source's history holds, None for a source without one."""
        if self._timed is not None:
            return self._timed.history_stats()
        return None

    def pause(self, at: float | None = None) -> None:
        """Stop following the data and stop playing: the cursor holds `at` (default: where it is now)."""
        self.playing = False
        if at is None:
            if self.cursor is not None:
                return
            span = self.span()
            at = span[1] if span is not None else float(self._clock())
        self.cursor = float(at)

    def resume(self) -> None:
        """Follow the newest data again."""
        self.playing = False
        self.cursor = None

    def play(self, speed: float | None = None) -> None:
        """Advance the cursor by itself from where it is (from the start when it is at the end)."""
        if speed is not None:
            self.set_speed(speed)
        span = self.span()
        if self.cursor is None or (span is not None and self.cursor >= span[1]):
            self.cursor = span[0] if span is not None else float(self._clock())
        self.playing = True
        self._anchor = (self._ticks(), self.cursor)

    def set_speed(self, speed: float) -> None:
        """Set the playback speed (0.1 to 10 times real time).

        Raises:
            ValueError: a speed outside [0.1, 10].
        """
        if not 0.1 <= speed <= 10.0:
            raise ValueError(f"playback speed must be from 0.1 to 10 times real time, not {speed:g}")
        if self.playing and self.cursor is not None:
            self._anchor = (self._ticks(), self.cursor)
        self.speed = float(speed)

    def tick(self) -> None:
        """Advance a playing cursor to now (once per frame)."""
        if not self.playing or self.cursor is None:
            return
        started, at = self._anchor
        t = at + (self._ticks() - started) * self.speed
        span = self.span()
        if span is not None and t >= span[1]:
            if self.loop:
                self.cursor = span[0]
                self._anchor = (self._ticks(), span[0])
                return
            if not self.recording:
                self.resume()  # caught up with the present
                return
            self.playing = False
            t = span[1]
        self.cursor = t

    def toggle(self) -> None:
        """Space: live, pause at the newest sample or resume; a recording, play or pause."""
        if self.recording:
            if self.playing:
                self.pause()
            else:
                self.play()
        elif self.live:
            self.pause()
        else:
            self.resume()

    def seek(self, t: float) -> None:
        """Move the cursor to `t`, clamped to the span held (a playing cursor plays on from there)."""
        span = self.span()
        if span is not None:
            t = min(max(t, span[0]), span[1])
        self.cursor = float(t)
        if self.playing:
            self._anchor = (self._ticks(), self.cursor)

    def shift(self, seconds: float) -> None:
        """Move the cursor by `seconds` (pausing first when live)."""
        if self.cursor is None:
            self.pause()
        assert self.cursor is not None
        self.seek(self.cursor + seconds)

    def step(self, bindings: Iterable[Binding], direction: int) -> bool:
        """Move the cursor to the previous (-1) or next (+1) sample of any of `bindings`.

        Returns False when there is none that way (the cursor stays).
        """
        self.pause()
        assert self.cursor is not None
        found: list[float] = []
        for binding in bindings:
            t = self._neighbour(binding, self.cursor, direction)
            if t is not None:
                found.append(t)
        if not found:
            return False
        self.cursor = max(found) if direction < 0 else min(found)
        return True

    def between(self, binding: Binding, t0: float, t1: float) -> tuple[npt.NDArray[np.float64], list[Scalar]]:
        """Return the binding's samples with ``t0 <= time <= t1`` (from the live series without a history)."""
        if self._timed is not None:
            return self._timed.between(binding, t0, t1)
        snap = self.source.snapshot(binding)
        keep = (snap.times >= t0) & (snap.times <= t1)
        if snap.kind is ValueKind.TEXT:
            return snap.times[keep], [x for x, k in zip(snap.texts, keep.tolist(), strict=False) if k]
        return snap.times[keep], list(snap.values[keep].tolist())

    def envelope(
        self, binding: Binding, t0: float, t1: float, pixels: int
    ) -> tuple[npt.NDArray[np.float64], npt.NDArray[np.float64]] | None:
        """Return a min/max envelope of the binding's numbers over ``[t0, t1]`` (up to the cursor when paused)
        for a plot `pixels` wide, from the source's history; None when the source keeps no history of it.

        A plot zoomed out beyond the samples a snapshot carries draws this instead: every sample the
        history holds in the range shows, at about two points per pixel column.
        """
        make = getattr(self._timed, "envelope", None)
        if make is None:
            return None
        cursor = self.cursor
        if cursor is not None:
            t1 = min(t1, cursor)
        if not t0 <= t1:
            return np.empty(0), np.empty(0)
        found = make(binding, t0, t1, max(1, pixels))
        if found is None:
            return None
        times, values = found
        if cursor is not None and len(times) and times[-1] > cursor:  # the sample after the range: not yet
            keep = int(np.searchsorted(times, cursor, side="right"))
            times, values = times[:keep], values[:keep]
        return times, values

    def _neighbour(self, binding: Binding, t: float, direction: int) -> float | None:
        if self._timed is not None:
            return self._timed.neighbour_time(binding, t, direction)
        times = self.source.snapshot(binding).times
        if direction < 0:
            i = int(np.searchsorted(times, t, side="left")) - 1
            return float(times[i]) if i >= 0 else None
        j = int(np.searchsorted(times, t, side="right"))
        return float(times[j]) if j < len(times) else None

    # --- DataSource ---------------------------------------------------------------------------------

    def snapshot(self, binding: Binding, past: float | None = None) -> SeriesSnapshot:
        """Return the series live, or as it stood at the cursor time.

        Args:
            binding: the series.
            past: paused, the seconds of samples before the cursor the caller needs (0: the value at the
                cursor alone), when its source can answer with less (`snapshot_recent`); None: all it
                gives. Live, ignored.
        """
        t = self.cursor
        if t is None:
            return self.source.snapshot(binding)
        if self._timed is not None:
            recent = getattr(self._timed, "snapshot_recent", None) if past is not None else None
            if recent is not None:
                snap: SeriesSnapshot = recent(binding, t, past)
                return snap
            return self._timed.snapshot_at(binding, t)
        return cut_at(self.source.snapshot(binding), t, self.stale_after)

    def bind(self, binding: Binding) -> None:
        """Bind on the source."""
        self.source.bind(binding)

    def unbind(self, binding: Binding) -> None:
        """Unbind on the source."""
        self.source.unbind(binding)

    def topics(self) -> list[TopicInfo]:
        """The source's topics."""
        return self.source.topics()

    def fields(self, topic: str) -> list[FieldInfo]:
        """The source's fields of `topic`."""
        return self.source.fields(topic)
