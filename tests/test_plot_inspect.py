"""The pure logic of inspecting plots: the shared `TimeRange`, reading ImPlot's zoom and pan back, ticks."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._widgets._geometry import range_slice
from dbglog.viewer._widgets._plot import span_text
from dbglog.viewer._widgets._timeaxis import (
    FAR,
    AxisSync,
    HoverTracker,
    close,
    is_zoom,
    remap,
    sample_at,
    tick_format,
    time_ticks,
    user_moved,
    zoom_about,
)
from dbglog.viewer.widget_api import TimeRange, WidgetContext

T = 1_795_000_000.0
"""A source time of today's order (epoch seconds)."""


def following(rng: TimeRange) -> bool:
    """Whether `rng` follows (read through a call: mypy would keep an earlier assert's narrowing)."""
    return rng.following


# -- TimeRange: following, held, reset, linking ------------------------------------------------------------


def test_a_new_range_follows_with_each_plot_own_window() -> None:
    """Following, a range ends at the end given and lasts the plot's own window until a zoom sets one."""
    rng = TimeRange()
    assert following(rng)
    assert rng.window(10.0, T) == (T - 10.0, T)
    assert rng.window(30.0, T) == (T - 30.0, T), "each plot its own window"


def test_end_is_the_cursor_paused_else_the_newest_else_the_fallback() -> None:
    """`end`: the cursor while paused, else the newest time the viewer holds, else what the plot knows."""
    rng = TimeRange()
    assert rng.end(5.0) == 5.0
    rng.sync(T, None)
    assert rng.end(5.0) == T
    rng.sync(T + 1, T - 3)
    assert rng.end(5.0) == T - 3


def test_follow_hold_and_reset_change_the_version() -> None:
    """Every change a plot must show bumps `version`; the same state again does not."""
    rng = TimeRange()
    v0 = rng.version
    rng.follow(4.0)
    assert following(rng)
    assert rng.window(10.0, T) == (T - 4.0, T), "the zoomed length wins over the plot's"
    rng.follow(4.0)
    assert rng.version == v0 + 1
    rng.hold(T - 20, T - 12)
    assert not following(rng)
    assert rng.window(10.0, T + 50) == (T - 20, T - 12), "held: whatever arrives"
    rng.hold(T - 20, T - 12)
    assert rng.version == v0 + 2
    rng.reset()
    assert following(rng)
    assert rng.length is None
    assert rng.version == v0 + 3


def test_hold_orders_and_bounds_the_length() -> None:
    """A held range runs forwards; one too short or too long is resized about its middle; NaN is ignored."""
    rng = TimeRange()
    rng.hold(T, T - 5)
    assert rng.held == (T - 5, T)
    rng.hold(T, T + 1e-6)
    assert rng.held is not None
    assert rng.held[1] - rng.held[0] == pytest.approx(TimeRange.MIN_LENGTH, rel=1e-3)
    assert sum(rng.held) / 2 == pytest.approx(T + 5e-7, abs=1e-6)
    before = rng.held
    rng.hold(math.nan, T)
    assert rng.held == before
    rng.follow(1e9)
    assert rng.length == TimeRange.MAX_LENGTH


def test_going_live_resets_and_is_counted() -> None:
    """Back to live (the cursor let go, End, a data source going back in time) follows again, counted."""
    rng = TimeRange()
    rng.sync(T, None)
    rng.hold(T - 20, T - 10)
    rng.sync(T + 1, T - 5)  # paused: still held
    assert not following(rng)
    rng.sync(T + 2, None)  # live again
    assert following(rng)
    assert rng.lives == 1
    rng.hold(T - 20, T - 10)
    rng.go_live()  # End
    assert following(rng)
    assert rng.lives == 2
    rng.follow(3.0)
    rng.sync(T - 500, None)  # a recording opened: older data
    assert rng.length is None
    assert rng.lives == 3


def test_a_cursor_moved_out_of_a_held_range_brings_it_along() -> None:
    """Paused and held, stepping the cursor past an edge shifts the range (length kept); inside, it stays."""
    rng = TimeRange()
    rng.sync(T, T - 15)
    rng.hold(T - 20, T - 10)
    rng.sync(T, T - 12)  # inside: nothing moves
    assert rng.held == (T - 20, T - 10)
    rng.sync(T, T - 5)  # past the end: the cursor lands a margin inside
    assert rng.held is not None
    margin = 10 * TimeRange.KEEP_MARGIN
    assert rng.held == pytest.approx((T - 15 + margin, T - 5 + margin))
    rng.sync(T, T - 40)  # before the start
    assert rng.held == pytest.approx((T - 40 - margin, T - 30 - margin))


def test_pausing_does_not_move_a_held_range() -> None:
    """Pausing (the cursor appears at the newest sample) leaves the range the user held where it is."""
    rng = TimeRange()
    rng.sync(T, None)
    rng.hold(T - 30, T - 20)
    rng.sync(T, T)
    assert rng.held == (T - 30, T - 20)


def test_the_pointer_over_one_plot_is_shown_by_the_others() -> None:
    """`point`: the plot under the pointer sets the hover time; only that plot clears it."""
    rng = TimeRange()
    a, b = object(), object()
    rng.point(T - 3, a)
    assert rng.hover == T - 3
    rng.point(None, b)
    assert rng.hover == T - 3, "b was not pointed at"
    rng.point(None, a)
    assert rng.hover is None


def test_copy_is_independent() -> None:
    """An unlinked plot's copy starts where the shared range was and then goes its own way."""
    rng = TimeRange()
    rng.sync(T, None)
    rng.follow(5.0)
    own = rng.copy()
    assert own.window(10.0, T) == rng.window(10.0, T)
    own.hold(T - 50, T - 40)
    assert following(rng)
    assert own.lives == rng.lives


def test_widget_context_carries_the_time_range() -> None:
    """The app's range reaches widgets through `WidgetContext.time_range` (None outside a viewer)."""
    rng = TimeRange()
    assert WidgetContext().time_range is None
    assert WidgetContext((), None, None, rng).time_range is rng


# -- the user's gestures --------------------------------------------------------------------------------


def test_a_wheel_zoom_while_following_keeps_following_with_the_new_length() -> None:
    """Zooming a following range about the pointer only changes the length: it stays at the newest data."""
    rng = TimeRange()
    before = (T - 10, T)
    after = zoom_about(before, T - 7, 1 - 0.1 / 1.2)
    user_moved(rng, before, after)
    assert following(rng)
    assert rng.length == pytest.approx(10 * (1 - 0.1 / 1.2))
    assert rng.window(10.0, T + 3)[1] == T + 3


def test_paused_the_margin_past_the_cursor_is_not_counted_in_the_length() -> None:
    """Paused, a plot shows a little past the cursor; a zoom's new length leaves that part out."""
    rng = TimeRange()
    user_moved(rng, (T - 10, T + 0.6), (T - 5, T + 0.3), extra=0.06)
    assert rng.length == pytest.approx(5.3 / 1.06)


def test_a_pan_holds_and_a_box_holds_the_box() -> None:
    """A pan of a following range holds it, a box zoom holds the box, a zoom of a held range holds."""
    rng = TimeRange()
    user_moved(rng, (T - 10, T), (T - 14, T - 4))
    assert rng.held == (T - 14, T - 4)
    rng.reset()
    user_moved(rng, (T - 10, T), (T - 6, T - 3), box=True)
    assert rng.held == (T - 6, T - 3)
    user_moved(rng, (T - 6, T - 3), zoom_about((T - 6, T - 3), T - 5, 0.5))
    assert rng.held == pytest.approx((T - 5.5, T - 4.0))


def test_zoom_about_keeps_the_anchor_in_place() -> None:
    """`zoom_about` scales the range about the anchor: the anchor's fraction across stays the same."""
    view = (0.0, 10.0)
    for factor in (0.5, 1.1, 3.0):
        new = zoom_about(view, 2.5, factor)
        assert (2.5 - new[0]) / (new[1] - new[0]) == pytest.approx(0.25)
        assert new[1] - new[0] == pytest.approx(10 * factor)


def test_is_zoom_tells_a_pan_from_a_zoom_despite_float32() -> None:
    """A pan read back through 32-bit floats is no zoom; a one-notch zoom is."""
    before = (-10.0, 0.0)
    pan = (float(np.float32(-12.3456)), float(np.float32(-2.3456)))
    assert not is_zoom(before, pan)
    assert is_zoom(before, zoom_about(before, -3.0, 1 - 0.1 / 1.2))


# -- reading ImPlot back --------------------------------------------------------------------------------


def test_axis_sync_following_never_pushes_limits_as_data_arrive() -> None:
    """Following, the end is x = 0: new data move the origin, not the limits, so ImPlot keeps its input."""
    sync = AxisSync()
    assert sync.place((T - 10, T), T, frame=1) == (-10.0, 0.0), "first: pushed"
    assert sync.due(2)
    assert sync.release(2)
    for k in range(1, 5):
        assert sync.place((T - 10 + k, T + k), T + k, frame=2 + k) is None
        assert sync.origin == T + k
    assert not sync.forcing


def test_axis_sync_waits_for_a_frame_before_letting_go() -> None:
    """Pushed limits are kept until a later frame drew them; meanwhile ImPlot's limits are no user change."""
    sync = AxisSync()
    sync.place((T - 10, T), T, frame=7)
    assert not sync.release(7), "not drawn yet"
    assert sync.observe((0.0, 1.0)) is None, "ImPlot took no input while pushed"
    assert sync.release(8)
    assert not sync.release(9)


def test_axis_sync_sees_the_user_change_in_source_times() -> None:
    """A change of ImPlot's limits it was not told is the user's: returned as source times, remembered."""
    sync = AxisSync()
    sync.place((T - 10, T), T, frame=1)
    sync.release(2)
    assert sync.observe((-10.0, 0.0)) is None
    assert sync.before() == (T - 10, T)
    moved = sync.observe((-12.0, -2.0))
    assert moved == (T - 12, T - 2)
    assert sync.observe((-12.0, -2.0)) is None, "once"
    # Held there: the origin stays, nothing is pushed.
    assert sync.place(moved) is None
    assert sync.origin == T


def test_axis_sync_moves_a_far_origin_to_the_range() -> None:
    """A held range far (in its own lengths) from the origin gets a new origin, for float32's sake."""
    sync = AxisSync()
    sync.place((T - 10, T), T, frame=1)
    sync.release(2)
    far = (T - 10 - FAR * 20, T - FAR * 20)
    assert sync.place(far, frame=3) is None, "the same limits about the new origin: nothing to push"
    assert sync.origin == far[1]
    near = (far[1] - 40, far[1] - 30)  # within reach of the origin: it stays, the new limits are pushed
    assert sync.place(near, frame=4) == (-40.0, -30.0)
    assert sync.origin == far[1]


def test_close_tolerates_float32_and_not_a_pixel() -> None:
    """`close` ignores float32 rounding of limits; a shift of a pixel of a 500 px axis is a change."""
    a = (-10.0, 0.0)
    assert close(a, (float(np.float32(-10.0000001)), float(np.float32(1e-7))))
    assert not close(a, (-10.0 + 10 / 500, 10 / 500))


def test_remap_keeps_the_screen_fraction() -> None:
    """A pointer's x under one axis range maps to the same place on screen under another."""
    assert remap(2.5, (0.0, 10.0), (100.0, 120.0)) == 105.0
    assert remap(1.0, (1.0, 1.0), (3.0, 4.0)) == 3.0


# -- hover ----------------------------------------------------------------------------------------------


def test_hover_tracker_tells_the_plot_area_from_its_axes() -> None:
    """Over the area the shared plot position changes with the pointer; over an axis it does not."""
    h = HoverTracker()
    assert h.see(1, False, (10, 10), (0.0, 0.0)) is None
    assert h.see(2, True, (100, 100), (-3.0, 5.0)) == -3.0, "entered the area"
    assert h.see(2, True, (101, 100), (-9.0, 5.0)) == -3.0, "counted once per frame"
    assert h.see(3, True, (100, 100), (-3.0, 5.0)) == -3.0, "still: unchanged"
    assert h.see(4, True, (40, 100), (-3.0, 5.0)) is None, "moved, position stale: over the y axis"
    assert h.see(5, True, (120, 100), (-2.0, 5.0)) == -2.0
    assert h.see(6, False, (120, 100), (-2.0, 5.0)) is None, "off the item"


def test_sample_at_is_the_last_sample_at_or_before() -> None:
    """The state at t is the series' last sample at or before t (time and value); none before the first."""
    times = np.array([1.0, 2.0, 3.0])
    values = np.array([10.0, 20.0, 30.0])
    assert sample_at(times, values, 0.5) is None
    assert sample_at(times, values, 1.0) == (1.0, 10.0)
    assert sample_at(times, values, 2.999) == (2.0, 20.0)
    assert sample_at(times, values, 99.0) == (3.0, 30.0)
    assert sample_at(times[:0], values[:0], 1.0) is None


@given(st.lists(st.floats(0, 1000), min_size=1, max_size=50), st.floats(-10, 1010))
def test_sample_at_matches_a_scan(raw: list[float], t: float) -> None:
    """`sample_at` is the last sorted sample not after t (brute force)."""
    times = np.sort(np.array(raw))
    values = np.arange(len(times), dtype=np.float64)
    before = [i for i, x in enumerate(times) if x <= t]
    found = sample_at(times, values, t)
    if not before:
        assert found is None
    else:
        assert found == (times[before[-1]], values[before[-1]])


def test_range_slice_has_the_inside_and_one_neighbour_each_side() -> None:
    """Inside [start, end] only, and with one sample more on each side for the line to reach the edges."""
    times = np.arange(10.0)
    inside, drawn = range_slice(times, 2.5, 6.0)
    assert times[inside].tolist() == [3.0, 4.0, 5.0, 6.0]
    assert times[drawn].tolist() == [2.0, 3.0, 4.0, 5.0, 6.0, 7.0]
    inside, drawn = range_slice(times, -5.0, 100.0)
    assert times[drawn].tolist() == times.tolist()


# -- clock ticks ----------------------------------------------------------------------------------------


def test_ticks_use_round_steps_that_fit_and_read_as_a_clock() -> None:
    """Ten seconds over 420 px: evenly spaced round ticks, on the clock, whose labels fit side by side."""
    start = 1_700_000_000.0  # 22:13:20 UTC
    ticks = time_ticks(start, start + 10, 420, offset=0.0)
    steps = np.diff([t for t, _ in ticks])
    assert len(set(np.round(steps, 6))) == 1
    assert ticks[0][1].startswith("22:13:2"), ticks
    half = 8 * 7.5 / 2 / 420 * 10  # half a label of 8 characters, in seconds: no label sticks out
    assert all(start + half <= t <= start + 10 - half for t, _ in ticks)
    assert steps[0] in (1.0, 2.0, 5.0)
    assert steps[0] * 420 / 10 >= 8 * 7.5 + 20, "labels of 8 characters fit between two ticks"


@pytest.mark.parametrize(
    ("span", "width", "pattern"),
    [
        (0.5, 500, "13:20.1"),
        (0.05, 500, "13:20.01"),
        (0.004, 500, "13:20.001"),
        (3600.0, 500, "22:30"),
    ],
)
def test_ticks_say_as_much_of_the_clock_as_the_step_needs(span: float, width: float, pattern: str) -> None:
    """Minutes for long ranges, seconds, then tenths to milliseconds as the range shrinks."""
    start = 1_700_000_000.0
    labels = [label for _, label in time_ticks(start, start + span, width, offset=0.0)]
    assert pattern in labels, labels


def test_ticks_follow_the_local_clock() -> None:
    """With a UTC offset (+5:30), an hour's ticks fall on the local clock's whole hours."""
    start = 1_700_000_000.0
    ticks = time_ticks(start, start + 6 * 3600, 600, offset=5.5 * 3600)
    assert all(label.endswith(":00") for _, label in ticks)
    assert all((t + 5.5 * 3600) % 3600 == 0 for t, _ in ticks)


def test_ticks_of_nothing_are_none() -> None:
    """An empty or reversed range, or no width, has no ticks."""
    assert time_ticks(T, T, 400) == []
    assert time_ticks(T, T - 1, 400) == []
    assert time_ticks(T, T + 1, 0) == []


def test_tick_format_by_step() -> None:
    """The label format grows finer with the step."""
    assert tick_format(86400)[0] == "%d %b"
    assert tick_format(300) == ("%H:%M", 0)
    assert tick_format(2) == ("%H:%M:%S", 0)
    assert tick_format(0.5) == ("%M:%S", 1)
    assert tick_format(0.02) == ("%M:%S", 2)
    assert tick_format(0.002) == ("%M:%S", 3)


def test_span_text() -> None:
    """The header's length of a range: ms, s or min."""
    assert span_text(10.0) == "10 s"
    assert span_text(2.5) == "2.5 s"
    assert span_text(0.12) == "120 ms"
    assert span_text(300.0) == "5 min"
