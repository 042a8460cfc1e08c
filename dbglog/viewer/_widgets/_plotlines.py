"""A plot's lines as pure data (decimated, simplified, the y axis fitted), and the thread that computes them
while a frame renders.

A plot's lines are the largest Python cost of a frame in which the time cursor moves (a drag of the
timeline, a held arrow key, playback): every plot is redrawn at the new time. Rendering the frame
(`render_dearpygui_frame`) releases the GIL, and Python does nothing meanwhile. So while the cursor keeps
moving, a plot queues its lines (`LineWorker.submit`), the viewer starts them just before it renders
(`LineWorker.start`), and the plot takes them in the next frame (`LineTask.take`): the lines arrive one
frame late, shifted to that frame's axis, while the cursor line, values and axis are current. A still
frame computes its lines at once, as before. No Dear PyGui here: safe on any thread, testable without a
display.
"""

from __future__ import annotations

import threading
from collections.abc import Sequence
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from itertools import pairwise

import numpy as np

from dbglog.viewer._widgets._geometry import minmax_decimate, range_slice, simplify_line
from dbglog.viewer._widgets._timeaxis import Limits
from dbglog.viewer.widget_api import SeriesSnapshot

__all__ = ["LINE_WORKER", "LineJob", "LineTask", "LineWorker", "Lines", "plot_lines"]

Line = tuple[np.ndarray, np.ndarray]


@dataclass(frozen=True, slots=True)
class LineJob:
    """Everything a plot's lines are computed from: snapshots (read-only, safe on any thread) and numbers."""

    snaps: tuple[SeriesSnapshot, ...]
    older: tuple[Line | None, ...]
    """Per series, the history's envelope before its snapshot's first sample (zoomed out past it), or None."""
    start: float
    stop: float
    origin: float
    """The source time drawn at x = 0 (x values are seconds from it)."""
    max_points: int
    """Points per series after decimation: about the plot area's pixel columns."""
    fixed: Limits | None
    """The y limits of a fixed scale; None: fitted to what shows."""
    limits: Limits | None
    """The y limits shown now, kept when nothing finite shows."""
    width: int
    plot_h: int


@dataclass(frozen=True, slots=True)
class Lines:
    """A plot's lines, ready to hand to Dear PyGui."""

    lines: tuple[Line, ...]
    """Per series, x (seconds from `origin`) and y, contiguous float64."""
    origin: float
    limits: Limits | None
    """The y limits to show (None: keep those shown)."""
    drawn: int
    """Points over all series."""
    oldest: float | None
    """The source time of the oldest point drawn, None when none is."""
    newest: float | None
    """The source time of the newest point drawn, None when none is."""

    def moved_to(self, origin: float, until: float | None = None) -> Lines:
        """The same lines on an axis whose x = 0 is `origin` (a frame later, the cursor moved), without the
        points after source time `until` (the cursor, moved back: nothing is drawn past it)."""
        if origin == self.origin and (until is None or self.newest is None or self.newest <= until):
            return self
        shift = self.origin - origin
        lines = []
        for x, y in self.lines:
            end = len(x) if until is None else int(np.searchsorted(x, until - self.origin, side="right"))
            lines.append((x[:end] + shift, y[:end]))
        drawn = sum(len(x) for x, _ in lines)
        newest = max((float(x[-1]) + origin for x, _ in lines if len(x)), default=None)
        return Lines(tuple(lines), origin, self.limits, drawn, self.oldest if drawn else None, newest)


def plot_lines(job: LineJob) -> Lines:
    """Decimate each series over [start, stop] to the plot's width, fit the y axis to what shows, and drop
    the points a straight segment passes within a fraction of a pixel of (`simplify_line`)."""
    lo, hi = np.inf, -np.inf
    oldest, newest = np.inf, -np.inf
    lines: list[Line] = []
    for snap, older in zip(job.snaps, job.older, strict=True):
        n = min(len(snap.times), len(snap.values))
        times, values = snap.times[len(snap.times) - n :], snap.values[len(snap.values) - n :]
        inside, drawn_part = range_slice(times, job.start, job.stop)
        x, y = minmax_decimate(times[drawn_part] - job.origin, values[drawn_part], job.max_points)
        if older is not None and len(older[0]):  # zoomed out past the snapshot: the history's envelope
            x = np.concatenate((older[0] - job.origin, x))
            y = np.concatenate((older[1], y))
            seen = older[1][older[0] >= job.start]
            seen = seen[np.isfinite(seen)]
            if len(seen):
                lo, hi = min(lo, float(seen.min())), max(hi, float(seen.max()))
        lines.append((x, y))
        if len(x):
            oldest = min(oldest, float(x[0]) + job.origin)
            newest = max(newest, float(x[-1]) + job.origin)
        shown = values[inside]
        finite = shown[np.isfinite(shown)]
        if len(finite):
            lo, hi = min(lo, float(finite.min())), max(hi, float(finite.max()))
    limits = job.fixed
    if limits is None and np.isfinite(lo):
        pad = (hi - lo) * 0.08 or max(abs(hi) * 0.1, 0.5)
        limits = (lo - pad, hi + pad)
    simple = _simplified(lines, job, limits if limits is not None else job.limits)
    out = tuple((np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)) for x, y in simple)
    drawn = sum(len(x) for x, _ in out)
    if not drawn:
        return Lines(out, job.origin, limits, 0, None, None)
    return Lines(out, job.origin, limits, drawn, float(oldest), float(newest))


def _simplified(lines: Sequence[Line], job: LineJob, limits: Limits | None) -> Sequence[Line]:
    """The lines less the points a straight segment passes within a fraction of a pixel of (see
    `simplify_line`; every series in one call), scaled by upper bounds of the plot area's pixels."""
    seconds = job.stop - job.start
    if limits is None or len(lines) == 0 or sum(len(x) for x, _ in lines) < 3:
        return lines
    y_lo, y_hi = limits
    x_scale = job.width / seconds if seconds > 0 else 0.0
    y_scale = job.plot_h / (y_hi - y_lo) if y_hi > y_lo else 0.0
    ids = np.repeat(np.arange(len(lines)), [len(x) for x, _ in lines])
    x, y, kept = simplify_line(
        np.concatenate([x for x, _ in lines]),
        np.concatenate([y for _, y in lines]),
        x_scale,
        y_scale,
        groups=ids,
    )
    if kept is None:
        return lines
    cuts = [0, *np.searchsorted(kept, np.arange(1, len(lines))).tolist(), len(kept)]
    return [(x[a:b], y[a:b]) for a, b in pairwise(cuts)]


class LineTask:
    """One plot's lines being computed: by the worker once started, or by whoever takes them first."""

    def __init__(self, job: LineJob) -> None:
        self.job = job
        self._claimed = False
        self._lock = threading.Lock()
        self._done = threading.Event()
        self._lines: Lines | None = None
        self._error: BaseException | None = None

    def run(self) -> None:
        """Compute the lines unless someone already is (the worker, or `take` on the UI thread)."""
        with self._lock:
            if self._claimed:
                return
            self._claimed = True
        try:
            self._lines = plot_lines(self.job)
        except BaseException as exc:  # re-raised where the lines are taken (the widget is disabled there)
            self._error = exc
        finally:
            self._done.set()

    def take(self) -> Lines:
        """The lines: computed here when the worker has not begun them, else waited for."""
        self.run()
        self._done.wait()
        if self._error is not None:
            raise self._error
        assert self._lines is not None
        return self._lines


class LineWorker:
    """The thread that computes queued plot lines while the viewer renders a frame (one for the viewer)."""

    def __init__(self) -> None:
        self._queued: list[LineTask] = []
        self._pool: ThreadPoolExecutor | None = None

    def submit(self, job: LineJob) -> LineTask:
        """Queue `job` until `start` (the frame's render); its task can be taken at any time."""
        task = LineTask(job)
        self._queued.append(task)
        return task

    def start(self) -> None:
        """Begin the queued tasks on the worker thread (call just before rendering: the GIL is free then)."""
        if not self._queued:
            return
        tasks, self._queued = self._queued, []
        if self._pool is None:
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="dbglog-lines")
        self._pool.submit(_run_all, tasks)


def _run_all(tasks: Sequence[LineTask]) -> None:
    for task in tasks:
        task.run()


LINE_WORKER = LineWorker()
"""The viewer's one line worker: plots queue on it, the app starts it before each render (UI thread only)."""
