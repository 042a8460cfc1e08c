"""Pure maths of the viewer: snapping, hit-testing, gauge angles and ticks, fills, plot decimation.

No Dear PyGui here: everything is tested without a display.
"""

from __future__ import annotations

import enum
import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

__all__ = [
    "Part",
    "Rect",
    "arc_step",
    "canvas_extent",
    "compass_label",
    "corner_fans",
    "format_tick",
    "free_spot",
    "gap_mask",
    "gauge_angle",
    "hit_test",
    "knob_value_at",
    "led_on",
    "minmax_decimate",
    "minmax_indices",
    "nice_ticks",
    "normalize_heading",
    "overlapped",
    "overlaps",
    "panels_on_clear",
    "polar",
    "range_slice",
    "rects_around",
    "rects_outside",
    "scroll_target",
    "simplify_line",
    "snap",
    "snap_rect",
    "spread",
    "thermo_fill",
    "uncovered",
    "usual_intervals",
    "value_fraction",
    "window_slice",
]

FloatArray = npt.NDArray[np.float64]

GAP_FACTOR = 10.0
"""An interval between two samples is a gap when it is longer than this many times the usual interval."""
GAP_BLOCK = 32
"""The usual interval is judged over blocks of this many consecutive intervals (see `usual_intervals`)."""
GAP_QUANTILE = 0.9
"""... as this quantile of a block's intervals: a silence one interval in ten or more often is usual."""
GAP_MIN_INTERVALS = 8
"""A block with fewer intervals than this (a series' first samples) does not judge."""
LONE_GAP_S = 2.0
"""Where no block judges: an interval longer than this (the viewer's default stale time) is a gap."""


@dataclass(frozen=True, slots=True)
class Rect:
    """An axis-aligned rectangle in canvas pixels (y grows downwards)."""

    x: float
    y: float
    w: float
    h: float

    def contains(self, px: float, py: float) -> bool:
        """Return True when the point lies inside (edges included)."""
        return self.x <= px <= self.x + self.w and self.y <= py <= self.y + self.h

    def moved(self, dx: float, dy: float) -> Rect:
        """Return the rectangle shifted by (dx, dy), never left of or above the origin."""
        return Rect(max(0.0, self.x + dx), max(0.0, self.y + dy), self.w, self.h)

    def resized(self, dw: float, dh: float, min_w: float, min_h: float) -> Rect:
        """Return the rectangle grown by (dw, dh) from its top-left corner, at least min_w x min_h."""
        return Rect(self.x, self.y, max(min_w, self.w + dw), max(min_h, self.h + dh))


def rects_around(outer: Rect, hole: Rect) -> list[Rect]:
    """Return at most four rectangles that cover `outer` except where `hole` lies (no overlaps, none empty).

    The viewer paints its window background this way, around the canvas, instead of under it.
    """
    x0, y0 = max(outer.x, hole.x), max(outer.y, hole.y)
    x1 = min(outer.x + outer.w, hole.x + hole.w)
    y1 = min(outer.y + outer.h, hole.y + hole.h)
    if x1 <= x0 or y1 <= y0:
        return [outer] if outer.w > 0 and outer.h > 0 else []
    pieces = (
        Rect(outer.x, outer.y, outer.w, y0 - outer.y),  # above, full width
        Rect(outer.x, y1, outer.w, outer.y + outer.h - y1),  # below, full width
        Rect(outer.x, y0, x0 - outer.x, y1 - y0),  # left of the hole
        Rect(x1, y0, outer.x + outer.w - x1, y1 - y0),  # right of the hole
    )
    return [r for r in pieces if r.w > 0 and r.h > 0]


def rects_outside(outer: Rect, holes: Sequence[Rect]) -> list[Rect]:
    """Return rectangles that cover `outer` except where any of `holes` lies (no overlaps, none empty)."""
    pieces = [outer] if outer.w > 0 and outer.h > 0 else []
    for hole in holes:
        pieces = [part for piece in pieces for part in rects_around(piece, hole)]
    return pieces


def uncovered(start: float, end: float, covers: Sequence[tuple[float, float]]) -> list[tuple[float, float]]:
    """Return, in order, the parts of the span start..end that none of the (a, b) spans `covers` covers.

    The canvas grid is drawn only where no widget hides it: a line under a widget still costs a software
    renderer its fill.
    """
    gaps = []
    pos = start
    for a, b in sorted(covers):
        if b <= pos:
            continue
        if a >= end:
            break
        if a > pos:
            gaps.append((pos, a))
        pos = b
        if pos >= end:
            break
    if pos < end:
        gaps.append((pos, end))
    return gaps


def snap(value: float, grid: float) -> float:
    """Round `value` to the nearest multiple of `grid` (no change when grid <= 0)."""
    if grid <= 0:
        return value
    return float(round(value / grid) * grid)


def snap_rect(rect: Rect, grid: float, *, min_w: float = 0.0, min_h: float = 0.0) -> Rect:
    """Snap a rectangle's corner and size to the grid; the size never drops below one cell or the minimum."""
    if grid <= 0:
        return rect
    w = max(snap(rect.w, grid), grid, math.ceil(min_w / grid) * grid)
    h = max(snap(rect.h, grid), grid, math.ceil(min_h / grid) * grid)
    return Rect(max(0.0, snap(rect.x, grid)), max(0.0, snap(rect.y, grid)), w, h)


def overlaps(a: Rect, b: Rect) -> bool:
    """Whether two rectangles share any area (touching edges do not)."""
    return a.x < b.x + b.w and b.x < a.x + a.w and a.y < b.y + b.h and b.y < a.y + a.h


def overlapped(rects: Sequence[Rect]) -> list[bool]:
    """For each rectangle, whether another one of `rects` shares some of its area."""
    return [any(i != j and overlaps(a, b) for j, b in enumerate(rects)) for i, a in enumerate(rects)]


def panels_on_clear(extent: Rect, panels: Sequence[Rect], filled: Sequence[bool], extra: float = 0.0) -> bool:
    """Whether clearing the canvas to the panels' colour shades fewer pixels than filling each panel.

    A software renderer pays for every pixel of every layer, and a clear costs almost nothing. With the
    canvas cleared to the panels' colour, only what no panel covers is painted in the canvas colour, plus
    `extra` (the toolbox) and the panels that must stay `filled` (one over another, one being dragged);
    a dashboard of close panels shades far less this way, a few panels on a large canvas far more.
    """
    covered = sum(r.w * r.h for r in panels)
    gaps = sum(r.w * r.h for r in rects_outside(extent, panels))
    still = sum(r.w * r.h for r, f in zip(panels, filled, strict=True) if f)
    return gaps + extra + still < covered


def corner_fans(r: Rect, radius: float, segments: int = 4) -> list[tuple[tuple[float, float], ...]]:
    """Return triangles that fill the corners of `r` outside its rounding of `radius` (a fan per corner).

    A panel without a fill of its own, over a canvas cleared to its colour, has square corners; these
    paint the canvas colour back where the rounded frame leaves them.
    """
    if not radius > 0 or r.w < 2 * radius or r.h < 2 * radius:
        return []
    x0, y0, x1, y1 = r.x, r.y, r.x + r.w, r.y + r.h
    out: list[tuple[tuple[float, float], ...]] = []
    # (corner, arc centre, start angle): the arc runs a quarter turn from the start angle, clockwise on screen
    for corner, centre, start in (
        ((x0, y0), (x0 + radius, y0 + radius), 180.0),
        ((x1, y0), (x1 - radius, y0 + radius), 270.0),
        ((x1, y1), (x1 - radius, y1 - radius), 0.0),
        ((x0, y1), (x0 + radius, y1 - radius), 90.0),
    ):
        arc = [
            (
                centre[0] + radius * math.cos(math.radians(start + 90.0 * k / segments)),
                centre[1] + radius * math.sin(math.radians(start + 90.0 * k / segments)),
            )
            for k in range(segments + 1)
        ]
        out.extend((corner, a, b) for a, b in itertools.pairwise(arc))
    return out


def free_spot(want: Rect, others: Sequence[Rect], view: Rect, grid: float) -> Rect:
    """Return `want` moved to the nearest place where it overlaps none of `others` and lies inside `view`.

    `want` itself is kept when it already fits. Otherwise the candidates are the grid points (every
    `grid` pixels, or 10 without a grid) inside the view; when the view is full, the search goes on below
    it, where there is always room. A rectangle wider than the view starts at its left edge.
    """
    step = grid if grid > 0 else 10.0
    x0, y0 = view.x, view.y
    max_x = max(x0, view.x + view.w - want.w)
    max_y = max(y0, view.y + view.h - want.h)
    if grid > 0:  # stay on the grid: the first and last grid lines that keep the rectangle in view
        x0, y0 = math.ceil(view.x / grid) * grid, math.ceil(view.y / grid) * grid
        max_x = max(x0, math.floor(max_x / grid) * grid)
        max_y = max(y0, math.floor(max_y / grid) * grid)
    inside = Rect(min(max(want.x, x0), max_x), min(max(want.y, y0), max_y), want.w, want.h)
    if not any(overlaps(inside, o) for o in others):
        return inside
    bottom = max([max_y, *(o.y + o.h for o in others)])
    xs = np.arange(x0, max_x + 1e-9, step)  # never past `max_x`: the rectangle stays within the view's width
    if xs[-1] < max_x:  # without a grid, the right edge is a place too
        xs = np.append(xs, max_x)
    ys = np.arange(y0, math.ceil(bottom / step) * step + step / 2, step)
    gx, gy = np.meshgrid(xs, ys)
    free = np.ones(gx.shape, dtype=bool)
    for o in others:
        free &= ~((gx < o.x + o.w) & (o.x < gx + want.w) & (gy < o.y + o.h) & (o.y < gy + want.h))
    cost = np.where(free, (gx - want.x) ** 2 + (gy - want.y) ** 2, np.inf)
    index = np.unravel_index(int(np.argmin(cost)), cost.shape)
    return Rect(float(gx[index]), float(gy[index]), want.w, want.h)


def canvas_extent(
    view_w: float, view_h: float, rects: Sequence[Rect], scrollbar: float
) -> tuple[float, float]:
    """Return the size of the canvas's scrolled area: the view, grown to hold every rectangle.

    A scrollbar takes `scrollbar` pixels from the view on its side when the other direction overflows,
    so the area never overflows by the scrollbar alone.
    """
    content_w = max((r.x + r.w for r in rects), default=0.0)
    content_h = max((r.y + r.h for r in rects), default=0.0)
    v_bar = content_h > view_h
    h_bar = content_w > view_w - (scrollbar if v_bar else 0.0)
    v_bar = content_h > view_h - (scrollbar if h_bar else 0.0)
    w = max(content_w, view_w - (scrollbar if v_bar else 0.0))
    h = max(content_h, view_h - (scrollbar if h_bar else 0.0))
    return max(1.0, w), max(1.0, h)


def scroll_target(current: float, wheel: float, maximum: float, step: float) -> float:
    """Return the scroll offset after turning the wheel by `wheel` notches (up is positive), clamped."""
    return float(min(max(0.0, maximum), max(0.0, current - wheel * step)))


class Part(enum.Enum):
    """Which part of a widget frame a point hits."""

    TITLE = "title"
    """The title strip: dragging it moves the widget."""
    CORNER = "corner"
    """The bottom-right grip: dragging it resizes the widget."""
    BODY = "body"


def hit_test(
    rects: Sequence[Rect], px: float, py: float, *, title_h: float, corner: float
) -> tuple[int, Part] | None:
    """Return the index of the topmost rectangle under the point and the part hit (later = on top)."""
    for index in range(len(rects) - 1, -1, -1):
        r = rects[index]
        if not r.contains(px, py):
            continue
        if px >= r.x + r.w - corner and py >= r.y + r.h - corner:
            return index, Part.CORNER
        if py <= r.y + title_h:
            return index, Part.TITLE
        return index, Part.BODY
    return None


def value_fraction(value: float, lo: float, hi: float) -> float:
    """Return where `value` sits between lo and hi as 0..1, clamped (NaN and an empty range give 0)."""
    if not (math.isfinite(lo) and math.isfinite(hi)) or hi == lo or math.isnan(value):
        return 0.0
    frac = (value - lo) / (hi - lo)
    return min(1.0, max(0.0, frac))


def gauge_angle(value: float, lo: float, hi: float, *, start_deg: float, sweep_deg: float) -> float:
    """Return the needle angle in degrees for a gauge whose scale starts at `start_deg` and turns `sweep_deg`.

    Angles are compass-like on screen: 0 points up, positive turns clockwise. Values outside the
    range pin the needle at the end stops.
    """
    return start_deg + sweep_deg * value_fraction(value, lo, hi)


def knob_value_at(
    dx: float, dy: float, lo: float, hi: float, *, start_deg: float, sweep_deg: float
) -> float | None:
    """Return the value a knob points at when the pointer is (`dx`, `dy`) pixels from its centre (screen
    axes: y down): the inverse of `gauge_angle`. A pointer in the gap below the scale takes the nearer end
    stop; None at the very centre (no direction)."""
    if math.hypot(dx, dy) < 1e-9:
        return None
    angle = math.degrees(math.atan2(dx, -dy))  # 0 up, clockwise
    end = start_deg + sweep_deg
    while angle < start_deg:
        angle += 360.0
    while angle > start_deg + 360.0:
        angle -= 360.0
    if angle > end:  # in the gap: the end stop it is nearer to
        angle = end if angle - end < start_deg + 360.0 - angle else start_deg
    return lo + (hi - lo) * (angle - start_deg) / sweep_deg


def polar(cx: float, cy: float, radius: float, angle_deg: float) -> tuple[float, float]:
    """Return the screen point at `radius` from the centre in direction `angle_deg` (0 = up, clockwise)."""
    a = math.radians(angle_deg)
    return (cx + radius * math.sin(a), cy - radius * math.cos(a))


def nice_ticks(lo: float, hi: float, max_ticks: int = 6) -> list[float]:
    """Return round tick values (steps of 1, 2, 2.5 or 5 x 10^n) within [lo, hi], at most `max_ticks`.

    When no two round values fit, the ends themselves are returned.
    """
    if not (math.isfinite(lo) and math.isfinite(hi)) or max_ticks < 2:
        return []
    if hi < lo:
        lo, hi = hi, lo
    if hi == lo:
        return [lo]
    raw = (hi - lo) / (max_ticks - 1)
    magnitude = 10 ** math.floor(math.log10(raw))
    step = magnitude * 10
    for mult in (1.0, 2.0, 2.5, 5.0, 10.0):
        if mult * magnitude >= raw * (1 - 1e-9):
            step = mult * magnitude
            break
    first = math.ceil(lo / step - 1e-9) * step
    ticks = []
    k = 0
    while True:
        t = first + k * step
        if t > hi + step * 1e-9:
            break
        ticks.append(0.0 if abs(t) < step * 1e-9 else round(t, 12))
        k += 1
    if len(ticks) < 2:
        return [lo, hi]
    return ticks


def format_tick(value: float) -> str:
    """Format a tick label compactly: ``5``, ``2.5``, ``1.2k``, ``-3M``."""
    a = abs(value)
    for limit, unit, suffix in ((1e9, 1e9, "G"), (1e6, 1e6, "M"), (1e4, 1e3, "k")):
        if a >= limit:
            return f"{value / unit:.3g}{suffix}"
    if a == 0:
        return "0"
    return f"{value:.3g}"


def normalize_heading(value: float, *, radians: bool = False, offset_deg: float = 0.0) -> float:
    """Return a heading in [0, 360) degrees from a value in degrees (or radians), plus an offset."""
    if not math.isfinite(value):
        return 0.0
    deg = math.degrees(value) if radians else value
    return (deg + offset_deg) % 360.0


_POINTS = ("N", "NE", "E", "SE", "S", "SW", "W", "NW")


def compass_label(heading_deg: float) -> str:
    """Return the nearest of the eight compass points for a heading in degrees."""
    return _POINTS[round(normalize_heading(heading_deg) / 45.0) % 8]


def thermo_fill(value: float, lo: float, hi: float, length: float) -> float:
    """Return how many pixels of a bar of `length` are filled for `value` on the scale lo..hi."""
    return value_fraction(value, lo, hi) * max(0.0, length)


def led_on(value: float | bool | str | None, threshold: float, *, invert: bool = False) -> bool:
    """Return whether an LED is lit: a bool as is, a number when >= threshold, text when truthy."""
    if value is None:
        lit = False
    elif isinstance(value, bool):
        lit = value
    elif isinstance(value, int | float):
        lit = not math.isnan(value) and value >= threshold
    else:
        lit = value.strip().lower() in {"1", "true", "yes", "on", "high", "ok"}
    return lit != invert


def window_slice(times: FloatArray, now: float, window_s: float) -> slice:
    """Return the slice of sorted `times` that falls within the last `window_s` seconds before `now`."""
    start = int(np.searchsorted(times, now - window_s, side="left"))
    return slice(start, len(times))


def range_slice(times: FloatArray, start: float, end: float) -> tuple[slice, slice]:
    """Return the slices of sorted `times` within [start, end]: inside only, and with one sample more on each
    side (drawn, so that the line runs on to the plot's edges)."""
    lo = int(np.searchsorted(times, start, side="left"))
    hi = int(np.searchsorted(times, end, side="right"))
    return slice(lo, hi), slice(max(0, lo - 1), min(len(times), hi + 1))


def usual_intervals(times: FloatArray, first_index: int = 0) -> FloatArray:
    """Return, for each interval between consecutive sorted `times`, the series' usual interval there.

    The intervals are cut into blocks of `GAP_BLOCK` (aligned on the samples' absolute numbers, the first
    being `first_index`, so a block stays the same as the series slides); a block's usual interval is its
    `GAP_QUANTILE` quantile, zero intervals (samples sharing a time) left out. An interval's usual interval
    is the largest of its block's and the two neighbouring blocks': a change of rate is not a gap, and a
    silence that recurs one interval in ten or more often (a bursty tag) is usual. NaN where none of the
    three blocks holds `GAP_MIN_INTERVALS` intervals.
    """
    d = np.diff(times)
    n = len(d)
    if n == 0:
        return np.empty(0)
    lead = first_index % GAP_BLOCK
    blocks = -(-(lead + n) // GAP_BLOCK)
    buf = np.full(blocks * GAP_BLOCK, np.nan)
    buf[lead : lead + n] = np.where(d > 0, d, np.nan)
    ordered = np.sort(buf.reshape(blocks, GAP_BLOCK), axis=1)  # NaN last
    counts = GAP_BLOCK - np.count_nonzero(np.isnan(ordered), axis=1)
    pick = np.maximum(0, np.floor(GAP_QUANTILE * (counts - 1))).astype(np.intp)
    q = ordered[np.arange(blocks), pick]
    q[counts < GAP_MIN_INTERVALS] = np.nan
    usual = q.copy()
    usual[1:] = np.fmax(usual[1:], q[:-1])  # fmax: NaN (no judgement) never wins
    usual[:-1] = np.fmax(usual[:-1], q[1:])
    return np.repeat(usual, GAP_BLOCK)[lead : lead + n]


def gap_mask(times: FloatArray, first_index: int = 0, *, at_least: float = 0.0) -> npt.NDArray[np.bool_]:
    """Return, for each interval between consecutive sorted `times`, whether it is a gap in the data.

    A gap is an interval longer than `GAP_FACTOR` times the usual interval there (`usual_intervals`);
    where too few samples tell the usual interval, longer than `LONE_GAP_S`; and in any case longer than
    `at_least` seconds (a plot: two pixel columns, so that a gap it draws is seen). A plot draws a gap as
    a gap, not as a line across it (the widget was STALE meanwhile).
    """
    d = np.diff(times)
    if not len(d):
        return np.zeros(0, dtype=bool)
    top = float(d.max())
    if top <= at_least:  # the common case, cheaply: nothing long enough to be drawn as a gap
        return np.zeros(len(d), dtype=bool)
    low = float(np.min(d, where=d > 0, initial=np.inf))  # every usual interval is at least this
    if top <= GAP_FACTOR * low and top <= LONE_GAP_S:
        return np.zeros(len(d), dtype=bool)
    usual = usual_intervals(times, first_index)
    known = ~np.isnan(usual)
    gaps = np.where(known, d > GAP_FACTOR * np.where(known, usual, 0.0), d > LONE_GAP_S)
    return gaps & (d > at_least)


def minmax_decimate(x: FloatArray, y: FloatArray, max_points: int) -> tuple[FloatArray, FloatArray]:
    """Reduce a line to at most `max_points` points, keeping each bucket's minimum and maximum in order.

    With one bucket per pair of output points, spikes survive decimation (unlike taking every n-th
    point), so a plot whose ``max_points`` is its width in pixels looks the same as the full data.
    Buckets are equal runs of consecutive samples; NaNs never win a bucket unless it holds nothing else.
    """
    if len(x) <= max_points or max_points < 2:
        return x, y
    order = minmax_indices(y, max_points)
    return x[order], y[order]


def minmax_indices(y: FloatArray, max_points: int) -> npt.NDArray[np.intp]:
    """Return the indices of the points `minmax_decimate` keeps (all of them when they fit), in order."""
    n = len(y)
    if n <= max_points or max_points < 2:
        return np.arange(n)
    size = -(-n // (max_points // 2))  # samples per bucket, rounded up: at most max_points // 2 buckets
    buckets = -(-n // size)
    pad = buckets * size - n
    if math.isnan(float(np.min(y))):  # a NaN (the minimum is then NaN): hide them, pad with losers
        nan = np.isnan(y)
        low_src = np.concatenate((np.where(nan, np.inf, y), np.full(pad, np.inf)))
        high_src = np.concatenate((np.where(nan, -np.inf, y), np.full(pad, -np.inf)))
        lows, highs = low_src.reshape(buckets, size), high_src.reshape(buckets, size)
    else:  # the common case, one array for both: padded with copies of the last sample, which come after
        # it and so never win (argmin and argmax take the first of equal values)
        src = np.asarray(y, dtype=np.float64)
        if pad:
            src = np.concatenate((src, np.full(pad, src[-1])))
        lows = highs = src.reshape(buckets, size)
    base = np.arange(0, buckets * size, size)
    i_min = base + lows.argmin(axis=1)
    i_max = base + highs.argmax(axis=1)
    order = np.empty(buckets * 2, dtype=np.intp)
    np.minimum(i_min, i_max, out=order[0::2])
    np.maximum(i_min, i_max, out=order[1::2])
    np.minimum(order, n - 1, out=order)
    return order


def arc_step(radius: float, max_error: float = 0.1) -> float:
    """Return the angle in degrees between an arc's points so that its chords stay within `max_error` pixels
    of the circle (between 2 and 10 degrees): a 60 px dial needs 6.6, not a point every 4."""
    if not radius > max_error:
        return 10.0
    return float(min(10.0, max(2.0, math.degrees(2 * math.acos(1 - max_error / radius)))))


def simplify_line(
    x: FloatArray,
    y: FloatArray,
    x_scale: float,
    y_scale: float,
    *,
    tolerance: float = 0.2,
    passes: int = 2,
    groups: npt.NDArray[np.int64] | None = None,
) -> tuple[FloatArray, FloatArray, npt.NDArray[np.int64] | None]:
    """Drop the points of a line that lie within `tolerance` pixels of the chord between their neighbours.

    A software renderer pays for every segment of a plot line (Mesa llvmpipe: about a microsecond each);
    a smooth stretch decimated to a point per pixel column is mostly points that a straight segment
    passes within a fraction of a pixel of. Each pass looks at every other point (its neighbours stay),
    so the line drawn never moves by more than ``passes * tolerance`` pixels; spikes, steps, gaps (NaN)
    and the ends are kept. `x` is non-decreasing (a time axis); `x_scale` and `y_scale` are pixels per
    data unit (an overestimate is safe: it keeps more points). `groups` (non-decreasing ids, one per
    point) holds several lines in one array: the first and last point of each group are kept, and the
    ids come back with the points kept.
    """
    n = len(x)
    if n < 3 or not (x_scale > 0 and y_scale > 0) or not (math.isfinite(x_scale) and math.isfinite(y_scale)):
        return x, y, groups
    p = x * x_scale + 1j * (y * y_scale)  # the points in pixels, as complex numbers: fewer array passes
    free = np.ones(n, dtype=bool)  # may go: not an end of the line or of a group
    free[0] = free[-1] = False
    if groups is not None:
        change = groups[1:] != groups[:-1]
        free[1:] &= ~change
        free[:-1] &= ~change
    idx = np.arange(n)
    for parity in range(passes):
        if len(p) < 3:
            break
        a = p[:-2]
        chord = p[2:] - a
        along = chord.conjugate() * (p[1:-1] - a)  # real: how far along the chord; imag: |chord| x the offset
        with np.errstate(invalid="ignore"):  # NaN (a gap) compares False: kept
            close = np.abs(along.imag) < tolerance * np.abs(chord)
            # ... and between its neighbours: in a column of equal x the farthest point is not on the chord
            close &= (along.real >= 0) & (along.real <= (chord * chord.conjugate()).real)
        close &= free[1:-1]
        close[(parity + 1) % 2 :: 2] = False  # every other point: a dropped point's neighbours stay
        if not close.any():
            if parity:
                break
            continue
        keep = np.ones(len(p), dtype=bool)
        keep[1:-1] = ~close
        p, idx, free = p[keep], idx[keep], free[keep]
    if len(idx) == n:
        return x, y, groups
    return x[idx], y[idx], None if groups is None else groups[idx]


def spread(positions: Sequence[float], gap: float) -> list[float]:
    """Move labels along one axis so that no two are closer than `gap`, each as little as it can.

    Labels keep their order; a run of labels that would overlap is laid out `gap` apart and centred
    on where its labels wanted to be (a plot's value tags at the cursor, two series with close values).
    Returns the new positions in the order given.
    """
    order = sorted(range(len(positions)), key=lambda i: positions[i])
    clusters: list[tuple[float, list[int]]] = []  # (first label's position, the labels, in order)
    for i in order:
        top, members = float(positions[i]), [i]
        while clusters and clusters[-1][0] + len(clusters[-1][1]) * gap > top:
            _, prev = clusters.pop()
            members = prev + members
            top = sum(positions[m] - k * gap for k, m in enumerate(members)) / len(members)
        clusters.append((top, members))
    out = [0.0] * len(positions)
    for top, members in clusters:
        for k, m in enumerate(members):
            out[m] = top + k * gap
    return out
