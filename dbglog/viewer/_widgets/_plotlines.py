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
from dataclasses import dataclass, field
from itertools import pairwise

import numpy as np

from dbglog.viewer._widgets._geometry import (
    GAP_BLOCK,
    GAP_FACTOR,
    LONE_GAP_S,
    gap_mask,
    minmax_indices,
    range_slice,
    simplify_line,
    usual_intervals,
)
from dbglog.viewer._widgets._timeaxis import Limits
from dbglog.viewer.widget_api import SeriesSnapshot, ValueKind

__all__ = ["LINE_WORKER", "LineJob", "LineTask", "LineWorker", "Lines", "Marks", "plot_lines", "stepped"]

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
class Marks:
    """What a series' line alone cannot show: samples with no neighbour to join, infinities at the edges."""

    lone: Line = field(default_factory=lambda: (np.empty(0), np.empty(0)))
    """Samples drawn alone (a gap or NaN on both sides): x and y, to mark with a dot."""
    above: np.ndarray = field(default_factory=lambda: np.empty(0))
    """x of +inf samples: the line runs to the top edge there (y clipped to the limits), marked."""
    below: np.ndarray = field(default_factory=lambda: np.empty(0))
    """x of -inf samples, at the bottom edge."""

    def moved(self, shift: float, until: float | None) -> Marks:
        """The marks shifted by `shift` seconds, without those after x = `until`."""

        def keep(x: np.ndarray) -> np.ndarray:
            return np.ones(len(x), dtype=bool) if until is None else x <= until

        lx, ly = self.lone
        lone_kept = keep(lx)
        return Marks(
            (lx[lone_kept] + shift, ly[lone_kept]),
            self.above[keep(self.above)] + shift,
            self.below[keep(self.below)] + shift,
        )


@dataclass(frozen=True, slots=True)
class Lines:
    """A plot's lines, ready to hand to Dear PyGui."""

    lines: tuple[Line, ...]
    """Per series, x (seconds from `origin`) and y, contiguous float64; NaN in y where the line breaks."""
    origin: float
    limits: Limits | None
    """The y limits to show (None: keep those shown)."""
    drawn: int
    """Points over all series."""
    oldest: float | None
    """The source time of the oldest point drawn, None when none is."""
    newest: float | None
    """The source time of the newest point drawn, None when none is."""
    marks: tuple[Marks, ...] = ()
    """Per series, its lone samples and infinities (empty: none anywhere)."""

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
        last = None if until is None else until - self.origin
        marks = tuple(m.moved(shift, last) for m in self.marks)
        return Lines(tuple(lines), origin, self.limits, drawn, self.oldest if drawn else None, newest, marks)


def stepped(snap: SeriesSnapshot) -> bool:
    """Whether a series is drawn as steps: bools, and numbers of an integer field (a counter, a state, an
    Int32 tag: ``last`` keeps the field's type), which hold their value until the next sample; floats
    (and anything transformed or matched by a regex, which are floats) are drawn as lines."""
    if snap.kind is ValueKind.BOOL:
        return True
    return snap.kind is ValueKind.NUMBER and isinstance(snap.last, int)


@dataclass(slots=True)
class _Part:
    """One series' drawn points before the y axis is fitted: absolute times, values, run numbers."""

    t: np.ndarray
    v: np.ndarray
    run: np.ndarray
    """Points of one run are joined; a new run starts after a gap or a NaN."""


def _breaks(t: np.ndarray, v: np.ndarray, gaps: np.ndarray) -> np.ndarray:
    """Run numbers of samples `t`, `v`: a run ends at a gap (`gaps`, per interval) and around a NaN."""
    nan = np.isnan(v)
    if not gaps.any() and not nan.any():
        return np.zeros(len(t), dtype=np.intp)
    new = np.zeros(len(t), dtype=bool)
    new[1:] = gaps | nan[1:] | nan[:-1]
    return np.cumsum(new)


def _sample_part(snap: SeriesSnapshot, job: LineJob, column: float) -> tuple[_Part, np.ndarray, slice, slice]:
    """The snapshot's samples over the range, decimated, with their runs; the gaps between the drawn
    samples (per interval); the slices of the samples inside the range and of those drawn."""
    n = min(len(snap.times), len(snap.values))
    times, values = snap.times[len(snap.times) - n :], snap.values[len(snap.values) - n :]
    inside, drawn = range_slice(times, job.start, job.stop)
    a, b = drawn.start, drawn.stop
    ca, cb = max(0, a - 2 * GAP_BLOCK), min(n, b + 2 * GAP_BLOCK)  # two blocks either side judge too
    # Narrower than two pixel columns, a gap is not seen: not drawn (no dashed lines)
    gaps = gap_mask(times[ca:cb], max(0, snap.count - n) + ca, at_least=2 * column)
    gaps = gaps[a - ca : max(a - ca, b - ca - 1)]
    t, v = times[a:b], values[a:b]
    run = _breaks(t, v, gaps)
    nan = np.isnan(v)
    if nan.any():
        keep = ~nan
        t, v, run = t[keep], v[keep], run[keep]
    picked = minmax_indices(v, job.max_points)
    return _Part(t[picked], v[picked], run[picked]), gaps, inside, drawn


def _older_part(older: Line, usual: float, column: float) -> _Part:
    """The history's envelope before the snapshot: its points, with a new run where it has a hole longer
    than two pixel columns and `GAP_FACTOR` usual intervals (the envelope has no intervals of its own)."""
    t, v = older
    gaps = np.diff(t) > max(2 * column, GAP_FACTOR * usual)
    run = _breaks(t, v, gaps)
    keep = ~np.isnan(v)
    return _Part(t[keep], v[keep], run[keep])


def _typical(snap: SeriesSnapshot) -> float:
    """The series' usual interval over its snapshot (median of `usual_intervals`), `LONE_GAP_S` / 10
    when it cannot tell."""
    n = min(len(snap.times), len(snap.values), 4 * GAP_BLOCK)
    usual = usual_intervals(snap.times[len(snap.times) - n :], max(0, snap.count - n))
    usual = usual[~np.isnan(usual)]
    return float(np.median(usual)) if len(usual) else LONE_GAP_S / GAP_FACTOR


def _joined(older: _Part | None, part: _Part, usual: float, column: float) -> _Part:
    """The envelope and the snapshot's points as one line (a new run where a gap lies between them)."""
    if older is None or not len(older.t):
        return part
    if not len(part.t):
        return older
    gap = float(part.t[0] - older.t[-1]) > max(2 * column, GAP_FACTOR * usual)
    offset = int(older.run[-1]) + (1 if gap else 0) - int(part.run[0])
    return _Part(
        np.concatenate((older.t, part.t)),
        np.concatenate((older.v, part.v)),
        np.concatenate((older.run, part.run + offset)),
    )


def _edge_value(
    times: np.ndarray, values: np.ndarray, breaks: np.ndarray, at: float, steps: bool
) -> float | None:
    """The value the drawn line has at time `at` between two samples (interpolated; held for steps), None
    where no line crosses it (before the first sample, after the last, across a gap or a NaN)."""
    i = int(np.searchsorted(times, at, side="right")) - 1
    if i < 0 or i + 1 >= len(times) or breaks[i]:
        return None
    v0, v1 = float(values[i]), float(values[i + 1])
    if steps:
        value = v0
    else:
        t0, t1 = float(times[i]), float(times[i + 1])
        value = v0 if t1 <= t0 else v0 + (v1 - v0) * (at - t0) / (t1 - t0)
    return value if np.isfinite(value) and np.isfinite(v1) else None


def _line(part: _Part, steps: bool, origin: float) -> Line:
    """The points as a line: steps hold each value until the next point of the run, a NaN between runs."""
    x, y, run = part.t - origin, part.v, part.run
    if len(x) < 2:
        return x, y
    same = run[1:] == run[:-1]
    if steps:  # after each point but the last: the hold (next x, this y), or the break (this x, NaN)
        out_x, out_y = np.empty(2 * len(x) - 1), np.empty(2 * len(x) - 1)
        out_x[0::2], out_y[0::2] = x, y
        out_x[1::2] = np.where(same, x[1:], x[:-1])
        out_y[1::2] = np.where(same, y[:-1], np.nan)
        return out_x, out_y
    cut = np.flatnonzero(~same)
    if not len(cut):
        return x, y
    return np.insert(x, cut + 1, x[cut]), np.insert(y, cut + 1, np.nan)


def plot_lines(job: LineJob) -> Lines:
    """Decimate each series over [start, stop] to the plot's width, fit the y axis to what shows, and drop
    the points a straight segment passes within a fraction of a pixel of (`simplify_line`).

    Lines break at a gap in the data (`gap_mask`, at least two pixel columns wide) and at a NaN; integer
    and bool series are drawn as steps (`stepped`); the y axis fits the samples in the range and where the
    lines cross its edges; ±inf is drawn at the top or bottom edge and marked (`Marks`), as are samples
    left alone between gaps.
    """
    lo, hi = np.inf, -np.inf
    oldest, newest = np.inf, -np.inf
    column = (job.stop - job.start) / max(1, job.max_points)
    parts: list[tuple[_Part, bool]] = []
    for snap, older in zip(job.snaps, job.older, strict=True):
        steps = stepped(snap)
        part, gaps, inside, drawn = _sample_part(snap, job, column)
        n = min(len(snap.times), len(snap.values))
        times, values = snap.times[len(snap.times) - n :], snap.values[len(snap.values) - n :]
        shown = values[inside]
        t, v = times[drawn], values[drawn]
        breaks = gaps | np.isnan(v[1:]) | np.isnan(v[:-1])
        # Where the lines cross the range's edges (the segment to a sample just outside shows too).
        edges = [_edge_value(t, v, breaks, job.stop, steps)]
        if older is not None and len(older[0]):  # zoomed out past the snapshot: the history's envelope
            usual = _typical(snap)
            before = _older_part(older, usual, column)
            part = _joined(before, part, usual, column)
            seen = older[1][older[0] >= job.start]
            shown = np.concatenate((shown, seen))
            old_breaks = np.diff(before.run) > 0
            edges.append(_edge_value(before.t, before.v, old_breaks, job.start, steps))
        else:
            edges.append(_edge_value(t, v, breaks, job.start, steps))
        shown = np.concatenate((shown, [e for e in edges if e is not None]))
        finite = shown[np.isfinite(shown)]
        if len(finite):
            lo, hi = min(lo, float(finite.min())), max(hi, float(finite.max()))
        if len(part.t):
            oldest, newest = min(oldest, float(part.t[0])), max(newest, float(part.t[-1]))
        parts.append((part, steps))
    limits = job.fixed
    if limits is None and np.isfinite(lo):
        pad = (hi - lo) * 0.08 or max(abs(hi) * 0.1, 0.5)
        limits = (lo - pad, hi + pad)
    edge = limits if limits is not None else job.limits
    lines: list[Line] = []
    marks: list[Marks] = []
    for part, steps in parts:
        mark = _marks(part)
        if len(mark.above) or len(mark.below):
            part = _clipped(part, edge)
        lines.append(_line(part, steps, job.origin))
        marks.append(
            Marks((mark.lone[0] - job.origin, mark.lone[1]), mark.above - job.origin, mark.below - job.origin)
        )
    simple = _simplified(lines, job, edge)
    out = tuple((np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)) for x, y in simple)
    drawn_n = sum(len(x) for x, _ in out)
    if not drawn_n:
        return Lines(out, job.origin, limits, 0, None, None, tuple(marks))
    return Lines(out, job.origin, limits, drawn_n, float(oldest), float(newest), tuple(marks))


def _marks(part: _Part) -> Marks:
    """A part's lone points (a run of one, finite) and its infinities (absolute times)."""
    if not len(part.run):
        return Marks()
    infinite = np.isinf(part.v)
    if infinite.any():
        above, below = part.t[part.v == np.inf], part.t[part.v == -np.inf]
    else:
        above = below = part.t[:0]
    if part.run[-1] == part.run[0]:  # one run: only a single point is alone
        lone = np.full(len(part.t), len(part.t) == 1) & ~infinite
        return Marks((part.t[lone], part.v[lone]), above, below)
    sizes = np.bincount(part.run - part.run[0])
    lone = (sizes[part.run - part.run[0]] == 1) & np.isfinite(part.v)
    return Marks((part.t[lone], part.v[lone]), above, below)


def _clipped(part: _Part, limits: Limits | None) -> _Part:
    """The part with ±inf at the limits' ends (NaN, a break, when there are no limits yet)."""
    v = part.v.copy()
    top, bottom = (np.nan, np.nan) if limits is None else (limits[1], limits[0])
    v[v == np.inf] = top
    v[v == -np.inf] = bottom
    return _Part(part.t, v, part.run)


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
