"""The viewer's pure maths, without a display: snapping, hit-testing, gauges, fills, decimation."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from dbglog.viewer._widgets._common import (
    format_value,
    knob_radii,
    knob_scale_radius,
    nonfinite_text,
    scale_label_inner,
)
from dbglog.viewer._widgets._geometry import (
    GAP_BLOCK,
    LONE_GAP_S,
    Part,
    Rect,
    arc_step,
    canvas_extent,
    compass_label,
    corner_fans,
    format_tick,
    free_spot,
    gap_mask,
    gauge_angle,
    hit_test,
    knob_value_at,
    led_on,
    minmax_decimate,
    nice_ticks,
    normalize_heading,
    overlapped,
    overlaps,
    panels_on_clear,
    polar,
    rects_around,
    rects_outside,
    scroll_target,
    simplify_line,
    snap,
    snap_rect,
    thermo_fill,
    uncovered,
    usual_intervals,
    value_fraction,
    window_slice,
)


def test_snap_rounds_to_nearest_multiple() -> None:
    """Values round to the nearest grid multiple; grid 0 leaves them alone."""
    assert snap(29, 20) == 20
    assert snap(31, 20) == 40
    assert snap(-11, 20) == -20
    assert snap(13.7, 0) == 13.7


def test_snap_rect_keeps_at_least_one_cell_and_minimum() -> None:
    """A snapped rectangle is on the grid, at least a cell and the widget minimum, never off-canvas."""
    r = snap_rect(Rect(-7, 33, 5, 101), 20, min_w=50, min_h=0)
    assert r == Rect(0, 40, 60, 100)
    assert snap_rect(Rect(3, 4, 5, 6), 0) == Rect(3, 4, 5, 6)


@given(st.floats(-1e4, 1e4), st.floats(-1e4, 1e4), st.floats(1, 1e4), st.floats(1, 1e4), st.integers(2, 200))
def test_snap_rect_lands_on_grid(x: float, y: float, w: float, h: float, grid: int) -> None:
    """Every coordinate of a snapped rectangle is a multiple of the grid."""
    r = snap_rect(Rect(x, y, w, h), grid)
    for v in (r.x, r.y, r.w, r.h):
        assert v % grid == pytest.approx(0, abs=1e-6) or v % grid == pytest.approx(grid)
    assert r.x >= 0
    assert r.y >= 0
    assert r.w >= grid
    assert r.h >= grid


def test_rect_move_and_resize_clamp() -> None:
    """Moving never goes above/left of the origin; resizing never goes below the minimum size."""
    r = Rect(10, 10, 100, 80)
    assert r.moved(-50, 5) == Rect(0, 15, 100, 80)
    assert r.resized(-90, 40, 60, 50) == Rect(10, 10, 60, 120)


def test_hit_test_finds_topmost_and_part() -> None:
    """The last rectangle wins where they overlap; title strip, resize corner and body are told apart."""
    rects = [Rect(0, 0, 100, 100), Rect(50, 50, 100, 100)]
    assert hit_test(rects, 10, 5, title_h=20, corner=10) == (0, Part.TITLE)
    assert hit_test(rects, 60, 55, title_h=20, corner=10) == (1, Part.TITLE)
    assert hit_test(rects, 145, 145, title_h=20, corner=10) == (1, Part.CORNER)
    assert hit_test(rects, 20, 60, title_h=20, corner=10) == (0, Part.BODY)
    assert hit_test(rects, 300, 300, title_h=20, corner=10) is None


def test_value_fraction_clamps_and_handles_bad_ranges() -> None:
    """The fraction is clamped to 0..1; NaN values and empty or infinite ranges give 0."""
    assert value_fraction(5, 0, 10) == 0.5
    assert value_fraction(-5, 0, 10) == 0.0
    assert value_fraction(50, 0, 10) == 1.0
    assert value_fraction(math.nan, 0, 10) == 0.0
    assert value_fraction(1, 3, 3) == 0.0
    assert value_fraction(1, 0, math.inf) == 0.0
    assert value_fraction(-2, 0, -4) == 0.5


def test_gauge_angle_maps_range_to_sweep() -> None:
    """Minimum, middle and maximum land at the start, centre and end of the sweep; outside values pin."""
    assert gauge_angle(-8, -8, 8, start_deg=-120, sweep_deg=240) == -120
    assert gauge_angle(0, -8, 8, start_deg=-120, sweep_deg=240) == 0
    assert gauge_angle(8, -8, 8, start_deg=-120, sweep_deg=240) == 120
    assert gauge_angle(99, -8, 8, start_deg=-120, sweep_deg=240) == 120


@given(st.floats(0.0, 1.0), st.floats(5.0, 300.0))
def test_knob_value_at_is_the_inverse_of_gauge_angle(fraction: float, radius: float) -> None:
    """A pointer where the knob's pointer stands for a value reads that value back, at any distance."""
    lo, hi = -2.0, 8.0
    value = lo + fraction * (hi - lo)
    x, y = polar(0.0, 0.0, radius, gauge_angle(value, lo, hi, start_deg=-135, sweep_deg=270))
    assert knob_value_at(x, y, lo, hi, start_deg=-135, sweep_deg=270) == pytest.approx(value, abs=1e-6)


def test_knob_value_at_the_gap_and_the_centre() -> None:
    """Straight up is the middle; in the gap below the scale the nearer end stop; the centre has none."""
    kw = {"start_deg": -135.0, "sweep_deg": 270.0}
    assert knob_value_at(0, -10, 0, 10, **kw) == pytest.approx(5.0)
    assert knob_value_at(-10, 0, 0, 10, **kw) == pytest.approx(5 - 5 * 90 / 135)
    assert knob_value_at(1, 10, 0, 10, **kw) == 10.0  # just right of straight down: the maximum
    assert knob_value_at(-1, 10, 0, 10, **kw) == 0.0
    assert knob_value_at(0, 0, 0, 10, **kw) is None


def test_polar_zero_is_up_and_clockwise() -> None:
    """Angle 0 points up (negative screen y) and 90 points right."""
    x, y = polar(100, 100, 10, 0)
    assert (x, y) == pytest.approx((100, 90))
    x, y = polar(100, 100, 10, 90)
    assert (x, y) == pytest.approx((110, 100))


def test_nice_ticks_are_round_and_cover_range() -> None:
    """Ticks use round steps within the range."""
    assert nice_ticks(0, 100, 6) == [0, 20, 40, 60, 80, 100]
    assert nice_ticks(-8, 8, 5) == [-5, 0, 5]
    assert nice_ticks(1.625, 1.75, 2) == [1.625, 1.75]
    assert nice_ticks(0, 1, 5) == [0, 0.25, 0.5, 0.75, 1.0]
    assert nice_ticks(3, 3) == [3]
    assert nice_ticks(0, math.nan) == []


@given(st.floats(-1e6, 1e6), st.floats(1e-3, 1e6), st.integers(2, 12))
@settings(max_examples=200)
def test_nice_ticks_property(lo: float, span: float, n: int) -> None:
    """Ticks are ascending, inside the range, and never more than asked for."""
    ticks = nice_ticks(lo, lo + span, n)
    assert 1 <= len(ticks) <= n
    assert ticks == sorted(ticks)
    tol = span * 1e-6
    assert ticks[0] >= lo - tol
    assert ticks[-1] <= lo + span + tol


def test_format_tick_is_compact() -> None:
    """Tick labels are short."""
    assert format_tick(0) == "0"
    assert format_tick(2.5) == "2.5"
    assert format_tick(12000) == "12k"
    assert format_tick(-3e6) == "-3M"


def test_heading_normalization_and_labels() -> None:
    """Headings wrap into [0, 360), radians convert, and the nearest compass point is named."""
    assert normalize_heading(-90) == 270
    assert normalize_heading(725) == 5
    assert normalize_heading(math.pi, radians=True) == pytest.approx(180)
    assert normalize_heading(350, offset_deg=20) == pytest.approx(10)
    assert normalize_heading(math.inf) == 0
    assert compass_label(0) == "N"
    assert compass_label(44) == "NE"
    assert compass_label(181) == "S"
    assert compass_label(350) == "N"


def test_thermo_fill() -> None:
    """The bar fills in proportion to the value and clamps at both ends."""
    assert thermo_fill(25, 0, 100, 200) == 50
    assert thermo_fill(-5, 0, 100, 200) == 0
    assert thermo_fill(500, 0, 100, 200) == 200


def test_led_on_for_bools_numbers_and_text() -> None:
    """Bools light as they are, numbers against the threshold, text when truthy; invert flips."""
    assert led_on(True, 0.5)
    assert not led_on(False, 0.5)
    assert led_on(0.7, 0.5)
    assert not led_on(0.3, 0.5)
    assert not led_on(math.nan, 0.5)
    assert led_on("ON", 0.5)
    assert not led_on("idle", 0.5)
    assert led_on(None, 0.5, invert=True)


def test_window_slice_keeps_recent_points() -> None:
    """Only points within the window before now are kept."""
    t = np.arange(0.0, 10.0)
    assert t[window_slice(t, 9.0, 3.0)].tolist() == [6.0, 7.0, 8.0, 9.0]


def test_minmax_decimate_keeps_spikes() -> None:
    """A single spike in a long flat line survives decimation to a few points."""
    x = np.arange(10000, dtype=np.float64)
    y = np.zeros(10000)
    y[4321] = 50.0
    y[777] = -20.0
    dx, dy = minmax_decimate(x, y, 100)
    assert len(dx) <= 100
    assert dy.max() == 50.0
    assert dy.min() == -20.0
    assert 4321.0 in dx.tolist()
    assert np.all(np.diff(dx) >= 0)


def test_minmax_decimate_short_input_unchanged() -> None:
    """Lines already short enough are returned as they are."""
    x = np.arange(5, dtype=np.float64)
    dx, dy = minmax_decimate(x, x * 2, 100)
    assert dx is x
    assert dy.tolist() == [0, 2, 4, 6, 8]


@given(
    st.lists(st.floats(-1e9, 1e9, allow_nan=False), min_size=1, max_size=3000),
    st.integers(2, 400),
)
@settings(max_examples=150)
def test_minmax_decimate_property(values: list[float], max_points: int) -> None:
    """Never more points than asked, x stays ordered, and the global min and max are kept."""
    y = np.array(values)
    x = np.arange(len(y), dtype=np.float64)
    dx, dy = minmax_decimate(x, y, max_points)
    assert len(dx) == len(dy) <= max(max_points, 1) or len(y) <= max_points
    assert np.all(np.diff(dx) >= 0)
    assert dy.max() == y.max()
    assert dy.min() == y.min()


def test_minmax_decimate_nan_bucket_and_uneven_length() -> None:
    """NaNs never hide a bucket's real extremes; a length that does not divide evenly still fits."""
    y = np.arange(1001, dtype=np.float64)
    y[10:20] = np.nan
    y[500] = -5.0
    x = np.arange(1001, dtype=np.float64)
    dx, dy = minmax_decimate(x, y, 64)
    assert len(dx) <= 64
    assert dy[np.isfinite(dy)].min() == -5.0
    assert dy.max() == 1000.0
    assert np.all(np.diff(dx) >= 0)


def _gaps_at(times: np.ndarray, first_index: int = 0, at_least: float = 0.0) -> list[int]:
    """The intervals `gap_mask` calls gaps (index i: between sample i and i + 1)."""
    return np.flatnonzero(gap_mask(times, first_index, at_least=at_least)).tolist()


def test_a_publisher_killed_for_twenty_seconds_is_one_gap() -> None:
    """100 Hz with jitter, 20 s of nothing, 100 Hz again: the silence is the only gap."""
    rng = np.random.default_rng(1)
    before = np.cumsum(rng.uniform(0.006, 0.014, 500))
    after = before[-1] + 20.0 + np.cumsum(rng.uniform(0.006, 0.014, 500))
    assert _gaps_at(np.concatenate((before, after))) == [499]


def test_a_change_of_rate_is_not_a_gap() -> None:
    """100 Hz, then 1 Hz (a mode change): the first long interval is the new usual one, not a gap."""
    fast = np.arange(300) * 0.01
    slow = fast[-1] + 1.0 + np.arange(60) * 1.0
    assert _gaps_at(np.concatenate((fast, slow))) == []


def test_a_bursty_tag_is_drawn_through_its_pauses() -> None:
    """Five samples 1 ms apart every second (silences one interval in five): no gaps; a tag stopped for a
    minute among its bursts: that minute is one."""
    bursts = (np.arange(60)[:, None] + np.arange(5)[None, :] * 0.001).ravel()
    assert _gaps_at(bursts) == []
    stopped = np.concatenate((bursts, bursts + 120.0))
    assert _gaps_at(stopped) == [299]


def test_a_tag_logged_again_minutes_later() -> None:
    """A regular tag that stops, then one sample minutes later: a gap (the median of recent intervals,
    not the last one); two samples alone minutes apart: a gap; a few a second apart: joined."""
    regular = np.arange(100) * 0.1
    assert _gaps_at(np.append(regular, regular[-1] + 180.0)) == [99]
    assert _gaps_at(np.array([0.0, 180.0])) == [0]
    assert LONE_GAP_S < 180.0
    assert _gaps_at(np.array([0.0, 1.0, 2.0, 3.0])) == []


def test_samples_sharing_a_time_do_not_make_every_interval_a_gap() -> None:
    """Ten samples per stamp every 10 ms (zero intervals left out of the usual one): no gaps."""
    times = np.repeat(np.arange(200) * 0.01, 10)
    assert _gaps_at(times) == []


def test_gaps_too_narrow_to_see_are_not_drawn() -> None:
    """`at_least`: a gap shorter than it (two pixel columns of a plot) is not one."""
    times = np.concatenate((np.arange(100) * 0.01, 1.5 + np.arange(100) * 0.01))
    assert _gaps_at(times) == [99]
    assert _gaps_at(times, at_least=0.4) == [99]  # (the gap: 0.51 s)
    assert _gaps_at(times, at_least=0.6) == []


def test_the_usual_interval_stays_put_as_a_series_slides() -> None:
    """Blocks aligned on the samples' numbers: any slice with two blocks of context either side judges its
    middle as the whole series does (a plot following live data does not flicker)."""
    rng = np.random.default_rng(7)
    d = rng.choice([0.01, 0.01, 0.01, 0.012, 0.3, 0.05], size=2000)
    d[rng.integers(0, 2000, 20)] = 2.0
    times = np.cumsum(d)
    whole = gap_mask(times)
    usual = usual_intervals(times)
    for a in (0, 17, 64, 333, 1000):
        b = a + 500
        ca, cb = max(0, a - 2 * GAP_BLOCK), min(len(times), b + 2 * GAP_BLOCK)
        part = gap_mask(times[ca:cb], ca)[a - ca : b - ca - 1]
        assert part.tolist() == whole[a : b - 1].tolist(), a
        alone = usual_intervals(times[ca:cb], ca)[a - ca : b - ca - 1]
        np.testing.assert_array_equal(alone, usual[a : b - 1])


def test_numbers_that_are_not_finite_read_as_such() -> None:
    """Every widget's readout says NaN, +inf, -inf (not a dash, not 'nan'); a dash is for no value."""
    assert [nonfinite_text(v) for v in (math.nan, math.inf, -math.inf, 0.0)] == ["NaN", "+inf", "-inf", None]
    assert format_value(math.nan, 1, "m") == "NaN"
    assert format_value(math.inf, 2) == "+inf"
    assert format_value(-math.inf, 0, "m/s") == "-inf"
    assert format_value(None, 1) == "\u2014"
    assert format_value(1.25, 1, "m") == "1.2 m"


def test_rects_around_cover_outer_minus_hole() -> None:
    """The pieces around a hole cover the outer rectangle exactly once outside the hole, never inside it."""
    outer, hole = Rect(0, 0, 100, 60), Rect(20, 10, 50, 30)
    pieces = rects_around(outer, hole)
    assert len(pieces) == 4
    assert sum(r.w * r.h for r in pieces) == outer.w * outer.h - hole.w * hole.h
    for px, py in ((5, 5), (95, 55), (10, 30), (80, 30), (45, 5), (45, 50)):
        assert sum(r.contains(px, py) for r in pieces) >= 1
    assert not any(r.contains(45, 25) for r in pieces), "nothing is painted inside the hole"
    assert rects_around(outer, Rect(200, 200, 5, 5)) == [outer]
    assert rects_around(outer, Rect(-10, -10, 200, 200)) == []


def test_rects_outside_leave_every_hole_empty() -> None:
    """Painting around two holes covers the rest of the outer rectangle and neither hole."""
    outer = Rect(0, 0, 100, 50)
    holes = (Rect(5, 5, 20, 40), Rect(30, 5, 65, 40))
    pieces = rects_outside(outer, holes)
    area = sum(r.w * r.h for r in pieces)
    assert area == outer.w * outer.h - sum(h.w * h.h for h in holes)
    for hole in holes:
        cx, cy = hole.x + hole.w / 2, hole.y + hole.h / 2
        assert not any(r.contains(cx, cy) for r in pieces)
    assert any(r.contains(27, 20) for r in pieces), "the gap between the holes is painted"


def test_overlapped_names_each_rectangle_another_one_covers_in_part() -> None:
    """A pair that shares area is flagged both ways; touching edges and far ones are not."""
    rects = [Rect(0, 0, 100, 100), Rect(100, 0, 50, 50), Rect(90, 90, 20, 20), Rect(300, 300, 10, 10)]
    assert overlapped(rects) == [True, False, True, False]
    assert overlapped([]) == []


def test_panels_on_clear_pays_for_a_full_canvas_not_for_a_sparse_one() -> None:
    """Close panels: painting the gaps costs less than filling the panels; a few small ones, more."""
    area = Rect(0, 0, 1000, 600)
    full = [Rect(x, y, 230, 280) for x in (10, 250, 490, 730) for y in (10, 300)]
    assert panels_on_clear(area, full, [False] * len(full))
    assert not panels_on_clear(area, full, [False] * len(full), extra=450_000), "a toolbox that large"
    assert not panels_on_clear(area, full, [True] * len(full)), "panels that keep their fill anyway"
    sparse = [Rect(10, 10, 200, 200), Rect(400, 10, 200, 200)]
    assert not panels_on_clear(area, sparse, [False, False])
    assert not panels_on_clear(area, [], [])


def test_corner_fans_fill_exactly_outside_the_rounding() -> None:
    """The four fans cover each corner square less its quarter disc, and nothing inside the rounding."""
    r, radius = Rect(10, 20, 100, 60), 6.0
    fans = corner_fans(r, radius, segments=32)
    assert len(fans) == 4 * 32
    square_less_disc = radius * radius * (1 - math.pi / 4)

    def area(t: tuple[tuple[float, float], ...]) -> float:
        (ax, ay), (bx, by), (cx, cy) = t
        return abs((bx - ax) * (cy - ay) - (cx - ax) * (by - ay)) / 2

    assert sum(area(t) for t in fans) == pytest.approx(4 * square_less_disc, rel=0.01)
    for t in fans:
        for px, py in t:
            assert r.contains(px, py), "inside the frame"
            inner_x = min(max(px, r.x + radius), r.x + r.w - radius)
            inner_y = min(max(py, r.y + radius), r.y + r.h - radius)
            assert math.hypot(px - inner_x, py - inner_y) >= radius - 1e-9 or (px, py) in (
                (r.x, r.y),
                (r.x + r.w, r.y),
                (r.x, r.y + r.h),
                (r.x + r.w, r.y + r.h),
            ), "on the rounding or at a corner"
    assert corner_fans(Rect(0, 0, 8, 8), radius) == [], "too small for its rounding"
    assert corner_fans(r, 0) == []


def test_uncovered_returns_the_gaps_between_covers() -> None:
    """Overlapping, unsorted and out-of-range covers leave exactly the uncovered gaps, in order."""
    assert uncovered(0, 100, []) == [(0, 100)]
    assert uncovered(0, 100, [(50, 60), (10, 20), (15, 30)]) == [(0, 10), (30, 50), (60, 100)]
    assert uncovered(0, 100, [(-5, 40), (90, 200)]) == [(40, 90)]
    assert uncovered(0, 100, [(0, 100)]) == []
    assert uncovered(0, 100, [(120, 130)]) == [(0, 100)]


@given(st.lists(st.tuples(st.integers(-20, 120), st.integers(0, 60)), max_size=8))
def test_uncovered_property(spans: list[tuple[int, int]]) -> None:
    """Every point of 0..100 is either in a gap or under a cover, never both."""
    covers = [(a, a + n) for a, n in spans]
    gaps = uncovered(0, 100, covers)
    for p in range(100):
        x = p + 0.5
        in_gap = any(a <= x < b for a, b in gaps)
        covered = any(a <= x < b for a, b in covers)
        assert in_gap != covered


VIEW = Rect(0, 0, 800, 600)


def test_free_spot_keeps_a_rect_that_fits() -> None:
    """A drop on free canvas inside the view lands exactly where asked."""
    want = Rect(100, 100, 200, 160)
    assert free_spot(want, [Rect(400, 100, 200, 200)], VIEW, 20) == want


def test_free_spot_moves_off_an_overlapped_widget_to_the_nearest_grid_spot() -> None:
    """A drop onto a widget moves to the nearest grid spot beside it, touching but not overlapping."""
    other = Rect(100, 100, 200, 200)
    spot = free_spot(Rect(120, 120, 200, 200), [other], VIEW, 20)
    assert not overlaps(spot, other)
    assert (spot.x % 20, spot.y % 20) == (0, 0)
    assert spot == Rect(300, 120, 200, 200)  # 180 px right or down: a tie goes to the higher spot


def test_free_spot_pulls_a_drop_back_inside_the_view() -> None:
    """A drop near the right or bottom edge is pulled in so the whole widget is on the visible canvas."""
    spot = free_spot(Rect(760, 560, 220, 240), [], VIEW, 20)
    assert spot == Rect(580, 360, 220, 240)
    scrolled = Rect(0, 400, 800, 600)  # scrolled down by 400
    assert free_spot(Rect(20, 20, 100, 100), [], scrolled, 20) == Rect(20, 400, 100, 100)


def test_free_spot_without_grid_keeps_exact_position_or_steps_by_10() -> None:
    """With snapping off a free drop keeps its pixel position; a blocked one moves in 10 px steps."""
    assert free_spot(Rect(13, 17, 50, 50), [], VIEW, 0) == Rect(13, 17, 50, 50)
    spot = free_spot(Rect(13, 17, 50, 50), [Rect(0, 0, 100, 100)], VIEW, 0)
    assert not overlaps(spot, Rect(0, 0, 100, 100))
    assert spot.x % 10 == 0


def test_free_spot_goes_below_a_full_view() -> None:
    """When the view is full, the widget goes to the nearest free place below everything."""
    full = [Rect(0, 0, 800, 600)]
    spot = free_spot(Rect(100, 100, 200, 200), full, VIEW, 20)
    assert spot == Rect(100, 600, 200, 200)


@settings(max_examples=200, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(0, 700), st.integers(0, 500), st.integers(40, 300), st.integers(40, 300)),
        max_size=8,
    ),
    st.tuples(st.integers(-100, 900), st.integers(-100, 700), st.integers(40, 300), st.integers(40, 300)),
    st.sampled_from([0, 10, 20]),
)
@example(others=[(241, 0, 300, 40)], want=(505, -5, 251, 40), grid=0)  # once placed 1 px past the right edge
def test_free_spot_never_overlaps(
    others: list[tuple[int, int, int, int]], want: tuple[int, int, int, int], grid: int
) -> None:
    """Whatever is on the canvas, the spot overlaps nothing, starts inside the view, and is on the grid."""
    rects = [Rect(*map(float, o)) for o in others]
    x, y, w, h = map(float, want)
    asked = Rect(snap(x, grid), snap(y, grid), w, h)  # the viewer snaps a drop before looking for room
    spot = free_spot(asked, rects, VIEW, grid)
    assert not any(overlaps(spot, r) for r in rects)
    assert spot.x >= 0
    assert spot.y >= 0
    assert spot.x + spot.w <= VIEW.w or spot.x == 0
    if grid:
        assert (spot.x % grid, spot.y % grid) == (0, 0)


def test_canvas_extent_grows_to_hold_widgets_and_minds_scrollbars() -> None:
    """The scrolled area is the view, or larger to hold every widget, less a scrollbar where one shows."""
    assert canvas_extent(800, 600, [], 14) == (800, 600)
    assert canvas_extent(800, 600, [Rect(0, 0, 100, 100)], 14) == (800, 600)
    assert canvas_extent(800, 600, [Rect(0, 900, 100, 100)], 14) == (786, 1000)  # vertical bar only
    assert canvas_extent(800, 600, [Rect(1000, 900, 100, 100)], 14) == (1100, 1000)


def test_scroll_target_steps_and_clamps() -> None:
    """A wheel notch down scrolls one step further; the offset stays within 0..maximum."""
    assert scroll_target(0, -1, 500, 60) == 60
    assert scroll_target(100, 2, 500, 60) == 0
    assert scroll_target(480, -1, 500, 60) == 500
    assert scroll_target(0, -1, 0, 60) == 0


def _off_line(x: np.ndarray, y: np.ndarray, kx: np.ndarray, ky: np.ndarray) -> float:
    """The largest distance from a point (x, y) to the polyline (kx, ky)."""
    ax, ay, bx, by = kx[:-1, None], ky[:-1, None], kx[1:, None], ky[1:, None]
    dx, dy = bx - ax, by - ay
    t = np.clip(((x - ax) * dx + (y - ay) * dy) / np.maximum(dx * dx + dy * dy, 1e-300), 0.0, 1.0)
    return float(np.max(np.min(np.hypot(ax + t * dx - x, ay + t * dy - y), axis=0)))


def test_simplify_line_thins_a_smooth_curve_within_the_tolerance() -> None:
    """A sine decimated to a point per pixel loses most of its points; the line moves by < 2 x 0.2 px."""
    t = np.arange(1000) / 100.0
    x, y = minmax_decimate(t, np.sin(t * 1.3), 180)
    sx, sy = 18.0, 40.0
    kx, ky, _ = simplify_line(x, y, sx, sy)
    assert len(kx) < len(x) / 2
    assert (kx[0], kx[-1]) == (x[0], x[-1])
    assert _off_line(x * sx, y * sy, kx * sx, ky * sy) <= 2 * 0.2 + 1e-9


def test_simplify_line_keeps_noise_spikes_and_gaps() -> None:
    """Noise keeps nine points in ten or more; a spike and the points either side of a NaN gap stay."""
    rng = np.random.default_rng(3)
    x = np.arange(200, dtype=np.float64)
    y = rng.normal(size=200)
    kx, _, _ = simplify_line(x, y, 1.0, 20.0)
    assert len(kx) > 180
    flat = np.zeros(50)
    flat[20], flat[35] = 5.0, np.nan
    fx, fy, _ = simplify_line(np.arange(50.0), flat, 1.0, 20.0)
    assert 20.0 in fx
    assert 5.0 in fy
    assert {34.0, 35.0, 36.0} <= set(fx.tolist())


def test_simplify_line_keeps_each_groups_ends() -> None:
    """Two straight lines in one array: each keeps only its first and last point, with its group id."""
    x = np.concatenate((np.arange(10.0), np.arange(10.0)))
    y = np.concatenate((np.arange(10.0), 5.0 - np.arange(10.0)))
    groups = np.repeat(np.arange(2), 10)
    kx, ky, kept = simplify_line(x, y, 1.0, 1.0, groups=groups, passes=8)
    assert kept is not None
    assert kx.tolist() == [0.0, 9.0, 0.0, 9.0]
    assert ky.tolist() == [0.0, 9.0, 5.0, -4.0]
    assert kept.tolist() == [0, 0, 1, 1]


def test_simplify_line_keeps_the_farthest_point_of_a_column() -> None:
    """Samples with equal times (a vertical run): the extreme one lies on the chord's line but past its end,
    so it stays; the one between its neighbours goes."""
    x = np.array([0.0, 1.0, 1.0, 1.0, 2.0])
    y = np.array([0.0, 0.0, 10.0, 5.0, 5.0])
    kx, ky, _ = simplify_line(x, y, 1.0, 1.0)
    assert 10.0 in ky.tolist()
    assert _off_line(x, y, kx, ky) <= 2 * 0.2 + 1e-9


@given(
    st.lists(st.tuples(st.integers(0, 3), st.floats(-1e3, 1e3)), min_size=3, max_size=200),
    st.floats(0.01, 100),
)
@settings(max_examples=60, deadline=None)
def test_simplify_line_property_with_equal_times(steps: list[tuple[int, float]], y_scale: float) -> None:
    """Non-decreasing times with repeats (columns of equal x): no point drawn moves more than 2 x 0.2 px."""
    x = np.cumsum([float(dx) for dx, _ in steps])
    y = np.asarray([v for _, v in steps])
    kx, ky, _ = simplify_line(x, y, 1.0, y_scale)
    assert _off_line(x, y * y_scale, kx, ky * y_scale) <= 2 * 0.2 + 1e-6


@given(st.lists(st.floats(-1e3, 1e3), min_size=3, max_size=300), st.floats(0.01, 100))
@settings(max_examples=60, deadline=None)
def test_simplify_line_property(values: list[float], y_scale: float) -> None:
    """Any line: the points kept are a subsequence with both ends, none further than 2 x 0.2 px."""
    y = np.asarray(values)
    x = np.arange(len(y), dtype=np.float64)
    kx, ky, _ = simplify_line(x, y, 1.0, y_scale)
    assert (kx[0], kx[-1]) == (0.0, len(y) - 1.0)
    assert np.all(np.diff(kx) > 0)
    assert np.array_equal(ky, y[kx.astype(int)])
    assert _off_line(x, y * y_scale, kx, ky * y_scale) <= 2 * 0.2 + 1e-6


@pytest.mark.parametrize("radius", [5.0, 20.0, 60.0, 150.0, 1000.0])
def test_arc_step_keeps_chords_within_a_tenth_of_a_pixel(radius: float) -> None:
    """A gauge arc's points are as far apart as a chord 0.1 px off the circle allows, 2 to 10 degrees."""
    step = arc_step(radius)
    assert 2.0 <= step <= 10.0
    sagitta = radius * (1 - math.cos(math.radians(step / 2)))
    assert sagitta <= 0.1 + 1e-9 or step == 2.0


@pytest.mark.parametrize(
    ("r", "lo", "hi"), [(40.0, 0, 100), (58.0, 0, 100), (85.0, 0, 100), (150.0, 0, 100), (150.0, -1000, 1000)]
)
def test_a_knobs_value_arc_stays_inside_its_scale_labels(r: float, lo: float, hi: float) -> None:
    """The knob's arc (6 px thick) ends 2 px inside the widest label, the cap 8 px inside the arc; a large
    knob keeps its usual proportions (cap half the scale, arc 8 px outside it)."""
    label_size = max(11.0, r / 7)
    arc, cap = knob_radii(r, lo, hi, label_size)
    assert arc + 3 <= scale_label_inner(r, lo, hi, label_size) - 2 + 1e-9 or cap == 6.0
    assert cap <= arc - 8 + 1e-9
    assert cap <= r * 0.5
    if (r, hi) == (150.0, 100):
        assert (arc, cap) == (r * 0.5 + 8, r * 0.5)


def test_scale_labels_reach_in_by_half_the_widest_label() -> None:
    """The widest label of -1000..1000 at 20 px, sideways at 9 o'clock, reaches in by half its width."""
    widest = max(len(format_tick(t)) for t in nice_ticks(-1000, 1000, 6))
    inner = scale_label_inner(150.0, -1000, 1000, 20.0)
    assert inner == pytest.approx(150 - 10 - 0.95 * 20 - widest * 20 * 0.55 / 2)
    assert scale_label_inner(150.0, 5, 5, 20.0) == 140.0, "no scale, no labels"


@pytest.mark.parametrize(("w", "h"), [(220, 186), (340, 306), (600, 600), (160, 116)])
def test_a_knobs_readout_fits_below_its_scale(w: float, h: float) -> None:
    """The readout, 0.9 radius below the centre (8 px + radius from the top), ends inside the body."""
    r = knob_scale_radius(w, h)
    size = max(14.0, min(26.0, r / 3.4))
    assert 8 + r + 0.9 * r + size / 2 <= h or r == 20.0
    assert r <= w / 2 - 8 or r == 20.0
