"""The timeline bar's maths without a display: time <-> pixels, round ticks, labels, value tags."""

from __future__ import annotations

import itertools
import math
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._ui._timescale import (
    MIN_SPAN_S,
    TICK_STEPS,
    TimeScale,
    format_ago,
    format_bytes,
    format_clock,
    format_duration,
    format_offset,
    history_text,
    label_left,
    tick_step,
)
from dbglog.viewer._widgets._common import clock_text
from dbglog.viewer._widgets._geometry import spread

T0 = 1_700_000_000.0


def test_scale_maps_the_span_onto_the_track_and_back() -> None:
    """The oldest time is the left end, the newest the right end; pixels map back to the same times."""
    scale = TimeScale.of((T0, T0 + 600), 10, 1210)
    assert scale.x_of(T0) == 10
    assert scale.x_of(T0 + 600) == 1210
    assert scale.x_of(T0 + 150) == pytest.approx(310)
    assert scale.t_of(310) == pytest.approx(T0 + 150)
    assert scale.seconds == 600


def test_scale_clamps_outside_the_span() -> None:
    """A time before the history sits at the left end; a pixel past the track reads as the newest time."""
    scale = TimeScale.of((T0, T0 + 60), 0, 600)
    assert scale.x_of(T0 - 100) == 0
    assert scale.x_of(T0 + 100) == 600
    assert scale.t_of(-50) == T0
    assert scale.t_of(5000) == T0 + 60


def test_a_single_sample_still_has_a_width() -> None:
    """A history of one instant is widened to MIN_SPAN_S to the left, so it maps without dividing by 0."""
    scale = TimeScale.of((T0, T0), 0, 100)
    assert scale.seconds == MIN_SPAN_S
    assert scale.x_of(T0) == 100
    assert scale.t_of(0) == T0 - MIN_SPAN_S


@given(
    span=st.floats(0.5, 86400 * 3),
    width=st.floats(120, 4000),
    x=st.floats(-100, 5000),
)
def test_pixel_time_round_trip(span: float, width: float, x: float) -> None:
    """x -> t -> x returns the pixel (clamped to the track) for any span and width."""
    scale = TimeScale.of((T0, T0 + span), 14, 14 + width)
    clamped = min(max(x, 14), 14 + width)
    assert scale.x_of(scale.t_of(x)) == pytest.approx(clamped, abs=1e-3)


@pytest.mark.parametrize(
    ("seconds", "width", "step"),
    [
        (60, 1200, 5),
        (600, 1200, 60),
        (1800, 1200, 120),
        (3600, 1000, 300),
        (10, 1000, 1),
        (86400, 800, 3 * 3600),
    ],
)
def test_tick_step_is_the_smallest_round_step_that_leaves_room(
    seconds: float, width: float, step: float
) -> None:
    """Ticks are 1/2/5/10/15/30 s, 1/2/5/10/15/30 min, hours: the smallest at least 70 px apart."""
    assert tick_step(seconds, width) == step
    assert step * width / seconds >= 70


@given(seconds=st.floats(0.1, 86400 * 30), width=st.floats(50, 5000))
def test_ticks_are_round_and_never_closer_than_the_minimum(seconds: float, width: float) -> None:
    """Every tick step is a round one (or whole days), and ticks are at least min_px apart."""
    step = tick_step(seconds, width, 70)
    assert step in TICK_STEPS or step % 86400 == 0
    assert step * width / seconds >= 70 - 1e-6


def test_ticks_count_back_from_the_newest_sample() -> None:
    """Ticks sit at whole steps before the newest sample, newest first, all within the track."""
    scale = TimeScale.of((T0, T0 + 300), 0, 1000)
    ticks = scale.ticks(min_px=100)
    step = tick_step(300, 1000, 100)
    assert step == 30
    assert [ago for _x, ago in ticks] == [30 * k for k in range(1, 11)]
    assert ticks[0][0] == pytest.approx(900)
    assert ticks[-1][0] == pytest.approx(0)
    xs = [x for x, _ in ticks]
    assert xs == sorted(xs, reverse=True)


def test_a_recordings_ticks_count_from_its_start() -> None:
    """A recording's ticks sit at whole steps after its first moment, oldest first, labelled m:ss."""
    scale = TimeScale.of((T0, T0 + 300), 0, 1000)
    ticks = scale.ticks_from_start(min_px=100)
    assert [after for _x, after in ticks] == [30 * k for k in range(1, 11)]
    assert ticks[0][0] == pytest.approx(100)
    assert ticks[-1][0] == pytest.approx(1000)
    assert [format_offset(after) for _x, after in ticks[:3]] == ["0:30", "1:00", "1:30"]


def test_offsets_read_as_a_media_player() -> None:
    """Times into a recording: m:ss (h:mm:ss past an hour); the cursor's with tenths, never 0:60."""
    assert format_offset(0) == "0:00"
    assert format_offset(7.4) == "0:07"
    assert format_offset(7.44, precise=True) == "0:07.4"
    assert format_offset(59.96, precise=True) == "1:00.0"
    assert format_offset(3723.24, precise=True) == "1:02:03.2"
    assert format_offset(-1) == "0:00"


def test_durations_read_as_a_clock() -> None:
    """Under a minute in seconds, then m:ss, then h:mm:ss."""
    assert format_duration(0) == "0 s"
    assert format_duration(45.4) == "45 s"
    assert format_duration(60) == "1:00"
    assert format_duration(312) == "5:12"
    assert format_duration(3723) == "1:02:03"


def test_ago_labels() -> None:
    """Tick labels: "now", then minus the time before the newest; the cursor label has a tenth of a second."""
    assert format_ago(0) == "now"
    assert format_ago(30) == "\u221230 s"
    assert format_ago(312) == "\u22125:12"
    assert format_ago(2.04, precise=True) == "\u22122.0 s"
    assert format_ago(0.01, precise=True) == "now"
    assert format_ago(75.2, precise=True) == "\u22121:15"


def test_clock_labels_round_to_the_millisecond() -> None:
    """A source time reads as the local clock; .9996 s rounds up into the next second, not to .000."""
    t = time.mktime((2024, 5, 1, 12, 3, 4, 0, 0, -1))
    assert format_clock(t + 0.512) == "12:03:04.512"
    assert format_clock(t + 0.9996) == "12:03:05.000"
    assert format_clock(t + 0.512, millis=False) == "12:03:04"
    assert clock_text(t + 0.2) == "12:03:04.200"


def test_sizes_and_the_status_bar_text() -> None:
    """Bytes in powers of 1024; the status bar says the span held, the samples and the memory."""
    assert format_bytes(512) == "512 B"
    assert format_bytes(3.4 * 1024) == "3.4 kB"
    assert format_bytes(34.2 * 2**20) == "34.2 MB"
    assert format_bytes(1.5 * 2**30) == "1.5 GB"
    assert (
        history_text((T0, T0 + 312), 34 * 2**20, 12345) == "history 5:12 \u00b7 12,345 samples \u00b7 34.0 MB"
    )
    assert history_text(None, 0, 0) == "history empty \u00b7 0 samples \u00b7 0 B"
    assert history_text(None, None) == ""


def test_cursor_label_stays_on_the_track() -> None:
    """The cursor's label is centred on it, but never runs off either end."""
    assert label_left(500, 100, 0, 1000) == 450
    assert label_left(10, 100, 0, 1000) == 0
    assert label_left(990, 100, 0, 1000) == 900


def test_spread_leaves_apart_labels_alone() -> None:
    """Value tags already far enough apart do not move."""
    assert spread([10, 50, 100], 18) == [10, 50, 100]
    assert spread([], 18) == []


def test_spread_centres_a_crowd_and_keeps_order() -> None:
    """Two tags at the same height move apart evenly around it; the order given is the order kept."""
    assert spread([100, 100], 20) == [90, 110]
    out = spread([60, 50, 55], 18)
    assert sorted(out) == [37, 55, 73]
    assert out[1] < out[2] < out[0]


@given(st.lists(st.floats(-1000, 1000), max_size=8), st.floats(1, 40))
def test_spread_never_leaves_two_tags_closer_than_the_gap(positions: list[float], gap: float) -> None:
    """Whatever the positions, the result keeps the order and every neighbour at least `gap` away."""
    out = spread(positions, gap)
    order = sorted(range(len(positions)), key=lambda i: positions[i])
    ys = [out[i] for i in order]
    assert all(b - a >= gap - 1e-6 for a, b in itertools.pairwise(ys))
    # Nothing moves further than the crowd it is part of needs.
    assert all(abs(o - p) <= gap * len(positions) for o, p in zip(out, positions, strict=True))


def test_export_ranges_read_plainly() -> None:
    """A plot's window ends at the cursor (live: its newest sample); file names say what and when."""
    from dbglog.viewer._ui._recordings import ExportRange, default_name, plot_window

    assert plot_window(10.0, T0 + 50, T0 + 60) == (T0 + 40, T0 + 50)
    assert plot_window(10.0, None, T0 + 60) == (T0 + 50, T0 + 60)
    assert plot_window(10.0, None, None) is None
    whole = ExportRange(T0, T0 + 312, "Everything held", whole=True)
    assert whole.bounds == (-math.inf, math.inf)  # what arrives until the file is written too
    part = ExportRange(T0, T0 + 2, "What the plots show")
    assert part.bounds == (T0, T0 + 2)
    assert part.label.startswith("What the plots show: 2 s, ")
    assert whole.label.startswith("Everything held: 5:12, ")
    name = default_name("history", ".mcap", T0)
    assert name == time.strftime("history-%Y%m%d-%H%M%S.mcap", time.localtime(T0))
