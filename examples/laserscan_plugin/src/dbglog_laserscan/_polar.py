"""Pure maths of the laser-scan widget: scan angles, polar to screen, decimation, range rings.

No Dear PyGui here, so all of it is tested without a display. Angles follow ROS (REP 103): radians,
0 = straight ahead (+x), counter-clockwise positive (+y is left).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from dbglog.viewer.widget_api import SeriesSnapshot, Status

__all__ = [
    "ANGLE_FIELDS",
    "Layout",
    "Scan",
    "auto_range",
    "closest_reading",
    "decimate_closest",
    "fan_polygon",
    "format_metres",
    "layout",
    "raster_indices",
    "read_scan",
    "resolve_angles",
    "ring_radii",
    "scan_angles",
    "to_screen",
    "to_xy",
    "visible",
]

FloatArray = npt.NDArray[np.float64]
BoolArray = npt.NDArray[np.bool_]

ANGLE_FIELDS = ("angle_min", "angle_max", "angle_increment")
"""LaserScan fields that, when bound, override the widget's angle properties."""


@dataclass(frozen=True, slots=True)
class Scan:
    """One laser scan as the widget reads it from its snapshots."""

    ranges: FloatArray
    """Range readings in metres (``inf`` = no return, ``nan`` = invalid)."""
    bound: Mapping[str, float]
    """Angle fields taken from the messages (``angle_min`` ...), radians."""
    status: Status
    """Status of the ranges series."""


def read_scan(snapshots: Sequence[SeriesSnapshot]) -> Scan | None:
    """Pick the ranges (the first array-valued series) and any bound angle fields out of `snapshots`.

    A bound field is recognised by the last part of its path, so ``angle_min`` and ``scan.angle_min``
    both count. Returns None while no ranges have arrived.
    """
    ranges: FloatArray | None = None
    status = Status.WAITING
    bound: dict[str, float] = {}
    for snap in snapshots:
        last = snap.last
        name = snap.binding.field.rsplit(".", 1)[-1]
        if isinstance(last, tuple):
            if ranges is None:
                ranges = np.asarray(last, dtype=np.float64)
                status = snap.status
        elif (
            name in ANGLE_FIELDS
            and isinstance(last, int | float)
            and not isinstance(last, bool)
            and math.isfinite(float(last))
        ):
            bound[name] = float(last)
    if ranges is None:
        return None
    return Scan(ranges, bound, status)


def resolve_angles(
    count: int, bound: Mapping[str, float], *, angle_min_deg: float, angle_max_deg: float
) -> tuple[float, float]:
    """Return (angle_min, angle_increment) in radians for `count` readings.

    Bound message fields win over the properties: ``angle_increment`` is used as it is; otherwise the
    readings are spread evenly from ``angle_min`` to ``angle_max`` (bound or from the degree properties).
    """
    angle_min = bound.get("angle_min", math.radians(angle_min_deg))
    if "angle_increment" in bound:
        return angle_min, bound["angle_increment"]
    angle_max = bound.get("angle_max", math.radians(angle_max_deg))
    if count < 2:
        return angle_min, 0.0
    return angle_min, (angle_max - angle_min) / (count - 1)


def scan_angles(count: int, angle_min: float, angle_increment: float) -> FloatArray:
    """Return the angle of each of `count` readings: ``angle_min + i * angle_increment``."""
    return angle_min + np.arange(max(0, count), dtype=np.float64) * angle_increment


def visible(ranges: FloatArray, *, range_min: float, range_max: float) -> BoolArray:
    """Return which readings to draw: finite and within [range_min, range_max]."""
    with np.errstate(invalid="ignore"):
        mask: BoolArray = np.isfinite(ranges) & (ranges >= range_min) & (ranges <= range_max)
    return mask


def to_xy(ranges: FloatArray, angles: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Return the readings as points in the sensor frame: x forward, y left (metres)."""
    return ranges * np.cos(angles), ranges * np.sin(angles)


def to_screen(
    x: FloatArray, y: FloatArray, *, cx: float, cy: float, scale: float, forward: str = "up"
) -> tuple[FloatArray, FloatArray]:
    """Map sensor-frame points to screen pixels (y grows downwards) around the centre (cx, cy).

    Args:
        x / y: metres, x forward and y left.
        cx / cy: where the sensor is drawn.
        scale: pixels per metre.
        forward: ``"up"`` (forward is up, left is left) or ``"right"`` (a map view: x right, y up).
    """
    if forward == "right":
        return cx + x * scale, cy - y * scale
    return cx - y * scale, cy - x * scale


def decimate_closest(
    ranges: FloatArray, angles: FloatArray, max_points: int
) -> tuple[FloatArray, FloatArray]:
    """Reduce to at most `max_points` readings, keeping the closest valid reading of each group.

    Consecutive readings are grouped in equal runs; the nearest obstacle of each run survives (a
    missing return only when the whole run has none), so thinning never hides something close.
    """
    n = len(ranges)
    if max_points <= 0 or n <= max_points:
        return ranges, angles
    group = math.ceil(n / max_points)
    pad = (-n) % group
    r = np.concatenate((ranges, np.full(pad, np.nan))).reshape(-1, group)
    a = np.concatenate((angles, np.full(pad, np.nan))).reshape(-1, group)
    finite = np.where(np.isfinite(r), r, np.inf)
    pick = np.argmin(finite, axis=1)
    rows = np.arange(len(r))
    out_r = r[rows, pick]
    out_a = a[rows, pick]
    # A run without any finite reading keeps its first entry (inf or nan) at the run's first angle.
    return out_r, np.where(np.isnan(out_a), a[:, 0], out_a)


def fan_polygon(
    sx: FloatArray, sy: FloatArray, hits: BoolArray, *, cx: float, cy: float
) -> list[list[float]]:
    """Return the closed outline of the free space seen by a scan, as screen points.

    The outline runs from reading to reading in angle order; a reading without a return (`hits` False)
    pulls it back to the sensor at (cx, cy), so the fill never claims space the scan did not see. The
    result is one concave polygon (Dear PyGui fills those), starting and ending at the sensor.
    """
    xs = np.where(hits, sx, cx)
    ys = np.where(hits, sy, cy)
    points = [[cx, cy]]
    points.extend([float(x), float(y)] for x, y in zip(xs.tolist(), ys.tolist(), strict=True))
    points.append([cx, cy])
    return points


def raster_indices(
    sx: FloatArray, sy: FloatArray, *, width: int, height: int, size: int
) -> tuple[npt.NDArray[np.intp], npt.NDArray[np.intp]]:
    """Return (rows, cols) of the pixels covered by a `size` x `size` square at each screen point.

    Points partly outside the `width` x `height` image keep only their pixels inside it.
    """
    size = max(1, int(size))
    left = np.floor(np.asarray(sx, dtype=np.float64) - (size - 1) / 2).astype(np.intp)
    top = np.floor(np.asarray(sy, dtype=np.float64) - (size - 1) / 2).astype(np.intp)
    offsets = np.arange(size, dtype=np.intp)
    cols = (left[:, None, None] + offsets[None, None, :]).repeat(size, axis=1).reshape(-1)
    rows = (top[:, None, None] + offsets[None, :, None]).repeat(size, axis=2).reshape(-1)
    inside = (cols >= 0) & (cols < width) & (rows >= 0) & (rows < height)
    return rows[inside], cols[inside]


def closest_reading(ranges: FloatArray, angles: FloatArray, mask: BoolArray) -> tuple[float, float] | None:
    """Return (range, angle) of the nearest drawable reading, or None when there is none."""
    if not mask.any():
        return None
    idx = np.flatnonzero(mask)
    best = idx[int(np.argmin(ranges[idx]))]
    return float(ranges[best]), float(angles[best])


def _nice_step(raw: float) -> float:
    magnitude = 10.0 ** math.floor(math.log10(raw))
    for mult in (1.0, 2.0, 2.5, 5.0, 10.0):
        if mult * magnitude >= raw * (1 - 1e-9):
            return mult * magnitude
    return 10 * magnitude


def _nice_floor(value: float) -> float:
    magnitude = 10.0 ** math.floor(math.log10(value))
    for mult in (5.0, 2.5, 2.0, 1.0):
        if mult * magnitude <= value * (1 + 1e-9):
            return mult * magnitude
    return magnitude


def ring_radii(max_range: float, max_rings: int) -> list[float]:
    """Return round ring radii (1, 2, 2.5, 5 x 10^n metres) up to `max_range`, at most `max_rings`."""
    if max_rings <= 0 or not math.isfinite(max_range) or max_range <= 0:
        return []
    step = _nice_step(max_range / max_rings)
    if step > max_range * (1 + 1e-9):
        step = _nice_floor(max_range)  # the round step up would not fit: one ring a round step below
    count = int(max_range / step + 1e-9)
    return [round(step * k, 9) for k in range(1, count + 1)]


def auto_range(ranges: FloatArray, *, range_min: float = 0.0, fallback: float = 10.0) -> float:
    """Return a round display radius just above the farthest finite reading (`fallback` with none)."""
    with np.errstate(invalid="ignore"):
        finite = ranges[np.isfinite(ranges) & (ranges >= range_min)]
    if not len(finite) or float(finite.max()) <= 0:
        return fallback
    far = float(finite.max()) * 1.05
    step = _nice_step(far / 4)
    return math.ceil(far / step - 1e-9) * step


@dataclass(frozen=True, slots=True)
class Layout:
    """Where the polar view sits in the widget body."""

    cx: float
    cy: float
    radius: float
    """Pixels from the centre to the outer ring."""


def layout(width: float, height: float, *, top: float = 0.0, margin: float = 8.0) -> Layout:
    """Centre the largest circle that fits below a `top` strip (for the readout) with `margin` around it."""
    usable_h = max(1.0, height - top)
    radius = max(10.0, min(width, usable_h) / 2 - margin)
    return Layout(width / 2, top + usable_h / 2, radius)


def format_metres(value: float) -> str:
    """Format a ring label or distance: ``2 m``, ``2.5 m``, ``0.25 m``, ``120 m``."""
    if value >= 100 or float(value).is_integer():
        return f"{value:.0f} m"
    text = f"{value:.2f}".rstrip("0").rstrip(".")
    return f"{text} m"
