"""The laser-scan example plugin's pure geometry: angles, polar to screen, decimation, rings, rasterising."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

# The example plugin is its own package (examples/laserscan_plugin); its pure maths is tested from source.
sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "examples" / "laserscan_plugin" / "src"))

from dbglog_laserscan._polar import (
    auto_range,
    closest_reading,
    decimate_closest,
    fan_polygon,
    format_metres,
    layout,
    raster_indices,
    read_scan,
    resolve_angles,
    ring_radii,
    scan_angles,
    to_screen,
    to_xy,
    visible,
)

from dbglog.viewer.widget_api import Binding, SeriesSnapshot, Status, ValueKind


def snap(field: str, last: object, status: Status = Status.LIVE) -> SeriesSnapshot:
    """A snapshot of `field` on /scan whose latest value is `last`."""
    kind = ValueKind.ARRAY if isinstance(last, tuple) else ValueKind.NUMBER
    return SeriesSnapshot(Binding("/scan", field), status, kind=kind, last=last, count=1)  # type: ignore[arg-type]


def test_read_scan_takes_first_array_and_bound_angle_fields() -> None:
    """Ranges are the first array series; angle fields are recognised by the last part of their path."""
    scan = read_scan(
        [
            snap("scan.angle_increment", 0.5),
            snap("ranges[]", (1.0, 2.0)),
            snap("intensities[]", (9.0, 9.0)),
            snap("angle_min", -1.0),
            snap("range_max", 30.0),
        ]
    )
    assert scan is not None
    assert scan.ranges.tolist() == [1.0, 2.0]
    assert dict(scan.bound) == {"angle_increment": 0.5, "angle_min": -1.0}
    assert scan.status is Status.LIVE


def test_read_scan_without_ranges_is_none_and_ignores_bad_angle_values() -> None:
    """No array yet gives None; a non-finite or boolean angle value is not taken."""
    assert read_scan([snap("angle_min", 0.1)]) is None
    assert read_scan([]) is None
    scan = read_scan(
        [snap("ranges[]", (1.0,), Status.STALE), snap("angle_min", math.nan), snap("angle_max", True)]
    )
    assert scan is not None
    assert scan.bound == {}
    assert scan.status is Status.STALE


def test_resolve_angles_prefers_bound_fields_over_properties() -> None:
    """Bound angle_increment is used as is; else readings spread from angle_min to angle_max."""
    assert resolve_angles(
        5, {"angle_min": -1.0, "angle_increment": 0.1}, angle_min_deg=0, angle_max_deg=9
    ) == (
        -1.0,
        0.1,
    )
    lo, inc = resolve_angles(5, {}, angle_min_deg=-90, angle_max_deg=90)
    assert lo == pytest.approx(-math.pi / 2)
    assert inc == pytest.approx(math.pi / 4)
    lo, inc = resolve_angles(3, {"angle_max": 1.0}, angle_min_deg=0, angle_max_deg=90)
    assert (lo, inc) == (0.0, 0.5)
    lo, inc = resolve_angles(1, {}, angle_min_deg=10, angle_max_deg=20)
    assert lo == pytest.approx(math.radians(10))
    assert inc == 0.0


def test_scan_angles_and_xy_follow_rep103() -> None:
    """Angle 0 is +x (forward), +90 degrees is +y (left)."""
    angles = scan_angles(3, 0.0, math.pi / 2)
    assert angles == pytest.approx([0.0, math.pi / 2, math.pi])
    x, y = to_xy(np.array([1.0, 2.0, 3.0]), angles)
    assert x == pytest.approx([1.0, 0.0, -3.0], abs=1e-12)
    assert y == pytest.approx([0.0, 2.0, 0.0], abs=1e-12)
    assert len(scan_angles(0, 0.0, 1.0)) == 0


def test_to_screen_forward_up_and_right() -> None:
    """Forward up: ahead is above the centre and left is left; forward right: a map view, x right, y up."""
    x, y = np.array([1.0, 0.0]), np.array([0.0, 1.0])
    sx, sy = to_screen(x, y, cx=100, cy=50, scale=10)
    assert sx.tolist() == [100.0, 90.0]
    assert sy.tolist() == [40.0, 50.0]
    sx, sy = to_screen(x, y, cx=100, cy=50, scale=10, forward="right")
    assert sx.tolist() == [110.0, 100.0]
    assert sy.tolist() == [50.0, 40.0]


def test_visible_drops_nonfinite_and_out_of_range() -> None:
    """Only finite readings within [min, max] are drawn."""
    ranges = np.array([0.05, 1.0, math.inf, math.nan, 12.0, 10.0])
    assert visible(ranges, range_min=0.1, range_max=10.0).tolist() == [False, True, False, False, False, True]


def test_decimate_keeps_closest_of_each_group() -> None:
    """Thinning keeps the nearest reading of each run, so a small close obstacle survives."""
    ranges = np.array([5.0, 5.0, 0.7, 5.0, math.inf, math.inf, 3.0, math.nan])
    angles = np.arange(8, dtype=np.float64)
    r, a = decimate_closest(ranges, angles, 4)
    assert r.tolist()[:2] == [5.0, 0.7]
    assert a.tolist()[:2] == [0.0, 2.0]
    assert math.isinf(r[2])
    assert a[2] == 4.0
    assert (r[3], a[3]) == (3.0, 6.0)
    same_r, same_a = decimate_closest(ranges, angles, 100)
    assert same_r is ranges
    assert same_a is angles


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.one_of(st.floats(0.0, 50.0), st.just(math.inf), st.just(math.nan)), min_size=1, max_size=300),
    st.integers(1, 64),
)
def test_decimate_never_grows_and_never_loses_the_closest(values: list[float], max_points: int) -> None:
    """At most max_points readings remain, and the overall closest finite reading is always among them."""
    ranges = np.array(values)
    r, a = decimate_closest(ranges, np.arange(len(values), dtype=np.float64), max_points)
    assert len(r) == len(a) <= max(max_points, 1) or len(values) <= max_points
    finite = ranges[np.isfinite(ranges)]
    if len(finite):
        assert float(np.nanmin(np.where(np.isfinite(r), r, np.inf))) == float(finite.min())


def test_fan_polygon_returns_to_sensor_at_gaps() -> None:
    """The free-space outline starts and ends at the sensor and dips to it where there is no return."""
    sx, sy = np.array([10.0, 20.0, 30.0]), np.array([1.0, 2.0, 3.0])
    points = fan_polygon(sx, sy, np.array([True, False, True]), cx=5, cy=6)
    assert points == [[5, 6], [10.0, 1.0], [5.0, 6.0], [30.0, 3.0], [5, 6]]


def test_closest_reading_and_empty() -> None:
    """The nearest drawable reading with its angle; None when nothing is drawable."""
    ranges, angles = np.array([3.0, 0.5, 0.2]), np.array([0.0, 1.0, 2.0])
    assert closest_reading(ranges, angles, np.array([True, True, False])) == (0.5, 1.0)
    assert closest_reading(ranges, angles, np.zeros(3, dtype=bool)) is None


def test_ring_radii_are_round_and_within_range() -> None:
    """Rings use 1-2-2.5-5 steps up to the max range and never exceed the count."""
    assert ring_radii(10.0, 4) == [2.5, 5.0, 7.5, 10.0]
    assert ring_radii(8.0, 4) == [2.0, 4.0, 6.0, 8.0]
    assert ring_radii(30.0, 3) == [10.0, 20.0, 30.0]
    assert ring_radii(1.0, 0) == []
    assert ring_radii(math.inf, 4) == []


@settings(max_examples=80, deadline=None)
@given(st.floats(0.01, 5000.0), st.integers(1, 10))
def test_ring_radii_properties(max_range: float, rings: int) -> None:
    """Ring radii increase in equal steps, stay within the range, and number at most `rings`."""
    radii = ring_radii(max_range, rings)
    assert 1 <= len(radii) <= rings
    assert radii[-1] <= max_range * (1 + 1e-9)
    steps = np.diff([0.0, *radii])
    assert np.allclose(steps, steps[0])


def test_auto_range_rounds_up_above_farthest() -> None:
    """Auto range is a round number just above the farthest finite reading, or the fallback."""
    assert auto_range(np.array([1.0, 3.7, math.inf])) == 4.0
    assert auto_range(np.array([18.0])) == 20.0
    assert auto_range(np.array([math.inf, math.nan]), fallback=7.0) == 7.0
    assert auto_range(np.array([0.05, 9.0]), range_min=10.0, fallback=3.0) == 3.0


def test_layout_centres_circle_below_readout() -> None:
    """The circle fits the body below the readout strip with a margin."""
    lay = layout(300, 220, top=20, margin=8)
    assert (lay.cx, lay.cy, lay.radius) == (150.0, 120.0, 92.0)
    assert layout(10, 10).radius == 10.0


def test_raster_indices_cover_squares_and_clip() -> None:
    """Each point covers a size x size square; pixels outside the image are dropped."""
    rows, cols = raster_indices(np.array([1.0, 9.6]), np.array([1.0, 0.2]), width=10, height=10, size=2)
    pixels = set(zip(rows.tolist(), cols.tolist(), strict=True))
    assert {(0, 0), (0, 1), (1, 0), (1, 1)} <= pixels
    assert {(0, 9)} <= pixels
    assert all(0 <= r < 10 and 0 <= c < 10 for r, c in pixels)
    rows, cols = raster_indices(np.array([3.0]), np.array([4.0]), width=10, height=10, size=1)
    assert (rows.tolist(), cols.tolist()) == ([4], [3])


def test_format_metres() -> None:
    """Ring labels: whole metres without decimals, others trimmed."""
    assert format_metres(2.0) == "2 m"
    assert format_metres(2.5) == "2.5 m"
    assert format_metres(0.25) == "0.25 m"
    assert format_metres(120.4) == "120 m"
