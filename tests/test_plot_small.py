"""What fits in a small plot: the legend's place and names, the header's label form, the value tags."""

from __future__ import annotations

import math
from itertools import combinations, pairwise

from hypothesis import given
from hypothesis import strategies as st

from dbglog.viewer._widgets._common import SERIES_COLORS
from dbglog.viewer._widgets._plot import series_colors
from dbglog.viewer._widgets._plotfit import (
    BOX_PAD,
    ENTRY_EXTRA,
    ENTRY_GAP,
    INSIDE_COVER,
    LINE_H,
    MIN_AREA_H,
    ROW_H,
    ROW_MARGIN,
    VALUE_SAMPLE,
    X_TICKS_H,
    Y_TICKS_W,
    LegendMode,
    fit_text,
    info_forms,
    keep_within,
    legend_plan,
    short_labels,
    tag_columns,
    tag_digits,
)

CHAR_W = 7.0
"""About the width of a character of the viewer's 15 px DejaVu Sans."""


def measure(text: str) -> float:
    """A text's width at `CHAR_W` a character."""
    return CHAR_W * len(text)


BENCH = [f"/bench/ui/t{i}" for i in range(25, 30)]
"""The five series of a plot of benchmarks/bench_ui.py's 20-widget dashboard."""


def clock(t: float, millis: bool) -> str:
    """A stand-in local clock: seconds after midnight as ``00:00:SS.mmm`` or ``00:00:SS``."""
    return f"00:00:{t:06.3f}" if millis else f"00:00:{int(t):02d}"


def forms(*, following: bool, paused: bool, hover: float | None) -> tuple[str, ...]:
    """The header's label forms for a 10 s range ending at 42.5 s, the newest time (or cursor) at 40 s."""
    return info_forms(
        following=following,
        paused=paused,
        span="10 s",
        span_to_end="8 s",
        clock=clock,
        stop=42.5,
        end=40.0,
        hover=hover,
    )


# -- short names -----------------------------------------------------------------------------------------


def test_short_labels_cut_the_common_path() -> None:
    """The prefix all labels share is cut after its last ``/`` or ``.``, never inside a name."""
    assert short_labels(BENCH) == ("t25", "t26", "t27", "t28", "t29")
    assert short_labels(["/odom.twist.linear.x", "/odom.twist.angular.z"]) == ("linear.x", "angular.z")
    assert short_labels(["/robot/speed", "/robot/steer"]) == ("speed", "steer"), "not 'eed' and 'eer'"


def test_short_labels_keep_names_they_cannot_shorten() -> None:
    """Only a shared path is cut; when a name would vanish the labels stay; one label keeps its last part."""
    assert short_labels(["/a/x", "/b/y"]) == ("a/x", "b/y")
    assert short_labels(["speed", "steer"]) == ("speed", "steer")
    assert short_labels(["/a/b", "/a/b"]) == ("b", "b")
    assert short_labels(["/a/", "/a/b"]) == ("/a/", "/a/b"), "an empty name is no name"
    assert short_labels(["/robot/battery"]) == ("battery",)
    assert short_labels([]) == ()


# -- the legend's place ------------------------------------------------------------------------------------


def test_a_big_plot_keeps_its_legend_inside_with_full_names() -> None:
    """A default-sized plot (420 x 212 px) shows its legend over the data, full names, as it always did; five
    long names with their values would cover a quarter of the data, so the values stay in the tags."""
    plan = legend_plan(BENCH, 420, 212, measure)
    assert plan.mode is LegendMode.INSIDE
    assert plan.labels == tuple(BENCH)
    assert not plan.values_in_legend
    assert legend_plan(BENCH, 640, 300, measure).values_in_legend, "a bigger plot has room for them"


def test_the_bench_cell_puts_short_names_in_a_row_above_the_lines() -> None:
    """A plot of the 20-widget bench dashboard (224 x 126 px, five series) gets a row above its area with
    the short names (its full legend covered most of the plot), and leaves values to the tags."""
    plan = legend_plan(BENCH, 224, 126, measure)
    assert plan.mode is LegendMode.ROW
    assert plan.labels == ("t25", "t26", "t27", "t28", "t29")
    assert not plan.values_in_legend


def test_a_row_of_full_names_when_they_fit() -> None:
    """A wide, short plot keeps full names in the row when they fit its width."""
    plan = legend_plan(["/speed", "/steer", "/brake"], 600, 110, measure)
    assert plan.mode is LegendMode.ROW
    assert plan.labels == ("/speed", "/steer", "/brake")


def test_a_plot_too_small_for_a_row_collapses_its_legend() -> None:
    """Too low for a row and the data, or too narrow for the names: the legend goes behind the toggle."""
    assert legend_plan(BENCH, 224, 90, measure).mode is LegendMode.COLLAPSED
    names = ["/left_wheel.velocity", "/right_wheel.velocity", "/odom.twist.linear.x"]
    collapsed = legend_plan(names, 200, 140, measure)
    assert collapsed.mode is LegendMode.COLLAPSED
    assert collapsed.labels == tuple(short_labels(names))


def test_values_join_the_legend_only_where_they_still_leave_the_lines_clear() -> None:
    """Paused, a default-sized plot's legend carries the values; a 200 px plot keeps its small legend of
    names over the data and leaves the values to the tags (its grown box covered the lines)."""
    three = ["/t0", "/t1", "/t2"]
    big = legend_plan(three, 420, 212, measure)
    assert big.mode is LegendMode.INSIDE
    assert big.values_in_legend
    small = legend_plan(three, 200, 160, measure)
    assert small.mode is LegendMode.INSIDE
    assert small.labels == tuple(three)
    assert not small.values_in_legend


def test_no_legend_property_no_legend() -> None:
    """The ``legend`` property off (or no series): no legend, whatever the size."""
    assert legend_plan(BENCH, 900, 600, measure, enabled=False).mode is LegendMode.OFF
    assert legend_plan([], 900, 600, measure).mode is LegendMode.OFF


sizes = st.integers(min_value=120, max_value=1600)
names = st.lists(st.text(alphabet="/._abcxyz0123456789", min_size=1, max_size=40), min_size=1, max_size=6)


@given(names, sizes, sizes)
def test_a_legend_over_the_data_is_small_and_a_row_fits(labels: list[str], w: int, h: int) -> None:
    """Whatever the names and size: a legend inside covers at most `INSIDE_COVER` of the plot area; a row
    fits the plot's width and leaves the data `MIN_AREA_H` pixels; the names are full or short."""
    plan = legend_plan(labels, w, h, measure)
    assert plan.labels in (tuple(labels), short_labels(labels))
    area_w, area_h = w - Y_TICKS_W, h - X_TICKS_H
    if plan.mode is LegendMode.INSIDE:
        box_h = 2 * BOX_PAD + LINE_H * len(plan.labels)
        for shown in (
            plan.labels,
            [f"{n}{VALUE_SAMPLE}" for n in plan.labels] if plan.values_in_legend else [],
        ):
            if shown:  # the names alone, and with the values when the legend carries them
                box_w = 2 * BOX_PAD + ENTRY_EXTRA + max(map(measure, shown))
                assert box_w * box_h <= INSIDE_COVER * area_w * area_h + 1e-6
    elif plan.mode is LegendMode.ROW:
        row = sum(measure(n) + ENTRY_EXTRA for n in plan.labels) + ENTRY_GAP * (len(plan.labels) - 1)
        assert 2 * BOX_PAD + row <= w - 2 * ROW_MARGIN + 1e-6
        assert area_h - ROW_H >= MIN_AREA_H
    else:
        assert plan.mode is LegendMode.COLLAPSED
    if plan.mode is not LegendMode.INSIDE:
        assert not plan.values_in_legend


@given(names, sizes, sizes)
def test_a_bigger_plot_never_gets_a_smaller_legend(labels: list[str], w: int, h: int) -> None:
    """Growing a plot never moves its legend from inside to a row or a toggle, nor from a row to a toggle."""
    rank = {LegendMode.INSIDE: 0, LegendMode.ROW: 1, LegendMode.COLLAPSED: 2}
    small = legend_plan(labels, w, h, measure)
    big = legend_plan(labels, w + 200, h + 200, measure)
    if small.mode is not LegendMode.OFF:
        assert rank[big.mode] <= rank[small.mode], (small, big)


# -- the header's label ------------------------------------------------------------------------------------


def test_fit_text_takes_the_longest_form_that_fits() -> None:
    """The first form that fits the width; none fitting: nothing (never a form cut mid-word)."""
    forms = ("held: 8.2 s to 12:03:04.512", "held 8.2 s to 12:03:04", "held 8.2 s", "held")
    assert fit_text(forms, 400, measure) == forms[0]
    assert fit_text(forms, measure(forms[1]), measure) == forms[1]
    assert fit_text(forms, measure(forms[2]) + 3, measure) == forms[2]
    assert fit_text(forms, 30, measure) == "held"
    assert fit_text(forms, 20, measure) == ""


def test_info_forms_start_with_the_full_label_and_get_shorter() -> None:
    """Each state's label in full first (what a wide plot shows), then shorter forms for narrow plots."""
    live = forms(following=True, paused=False, hover=None)
    assert live == ("10 s window", "10 s")
    paused = forms(following=True, paused=True, hover=None)
    assert paused == ("8 s to 00:00:40.000", "8 s to 00:00:40", "8 s")
    held = forms(following=False, paused=False, hover=None)
    assert held == ("held: 10 s to 00:00:42.500", "held 10 s to 00:00:42", "held 10 s", "held")
    hover = forms(following=True, paused=False, hover=37.5)
    assert hover == ("00:00:37.500  -2.5 s", "00:00:37.500", "00:00:37", "-2.5 s")
    hover_held = forms(following=False, paused=False, hover=37.5)
    assert hover_held == ("00:00:37.500 \u00b7 held", "00:00:37.500", "00:00:37")
    for each in (live, paused, held, hover, hover_held):
        widths = [measure(f) for f in each]
        assert widths == sorted(widths, reverse=True), each


# -- the value tags ----------------------------------------------------------------------------------------


def test_tags_pushed_past_an_end_come_back_inside_gap_apart() -> None:
    """Tags spread past the bottom are pulled back in, their neighbours moved along, gaps and order kept."""
    out = keep_within([50.0, 68.0, 86.0], 18.0, 9.0, 75.0)
    assert out == [39.0, 57.0, 75.0]
    out = keep_within([-10.0, 8.0, 40.0], 18.0, 9.0, 75.0)
    assert out == [9.0, 27.0, 45.0]
    assert keep_within([30.0], 18.0, 9.0, 75.0) == [30.0]
    assert keep_within([], 18.0, 9.0, 75.0) == []


def test_too_many_tags_share_the_room_evenly_in_their_order() -> None:
    """More tags than fit `gap` apart: evenly from end to end, in their order (no tag outside)."""
    out = keep_within([40.0, 10.0, 20.0, 30.0], 18.0, 0.0, 30.0)
    assert out == [30.0, 0.0, 10.0, 20.0]


@given(st.lists(st.floats(min_value=-200, max_value=300), min_size=1, max_size=8), st.floats(20, 300))
def test_kept_tags_are_inside_ordered_and_apart_when_they_fit(ys: list[float], room: float) -> None:
    """Every tag ends inside [lo, hi], in the order given; when they can, at least `gap` apart."""
    gap = 18.0
    out = keep_within(ys, gap, 9.0, 9.0 + room)
    assert all(9.0 - 1e-9 <= y <= 9.0 + room + 1e-9 for y in out)
    order = sorted(range(len(ys)), key=lambda i: ys[i])
    placed = [out[i] for i in order]
    assert placed == sorted(placed)
    if (len(ys) - 1) * gap <= room:
        assert all(b - a >= gap - 1e-6 for a, b in pairwise(placed))


def test_tags_too_many_for_one_column_alternate_between_two() -> None:
    """Tags that fit stay in one column; more, by rank from the top, alternately in two."""
    assert tag_columns([10.0, 50.0, 30.0], 18.0, 60.0) == [0, 0, 0]
    assert tag_columns([10.0, 50.0, 30.0, 20.0, 40.0], 18.0, 48.0) == [0, 0, 0, 1, 1]
    assert tag_columns([5.0], 18.0, 0.0) == [0]


def test_narrow_plots_show_shorter_values_in_tags() -> None:
    """Value tags carry 6 significant digits, 4 in a narrow plot."""
    assert tag_digits(480) == 6
    assert tag_digits(224) == 4


def _lab(color: tuple[int, ...]) -> tuple[float, float, float]:
    """CIELAB (D65) of an sRGB colour."""

    def linear(u: float) -> float:
        u /= 255
        return u / 12.92 if u <= 0.04045 else ((u + 0.055) / 1.055) ** 2.4

    r, g, b = (linear(c) for c in color[:3])
    xyz = (
        (0.4124 * r + 0.3576 * g + 0.1805 * b) / 0.95047,
        0.2126 * r + 0.7152 * g + 0.0722 * b,
        (0.0193 * r + 0.1192 * g + 0.9505 * b) / 1.08883,
    )
    fx, fy, fz = (t ** (1 / 3) if t > 216 / 24389 else (24389 / 27 * t + 16) / 116 for t in xyz)
    return 116 * fy - 16, 500 * (fx - fy), 200 * (fy - fz)


def test_sixteen_series_colours_far_apart_and_light_on_the_dark_plot() -> None:
    """The plot's 16 colours differ pairwise by at least 30 (CIELAB distance) and are light (L >= 55)."""
    assert len(SERIES_COLORS) >= 16
    labs = [_lab(c) for c in SERIES_COLORS]
    assert min(math.dist(a, b) for a, b in combinations(labs, 2)) >= 30
    assert min(lab[0] for lab in labs) >= 55


def test_series_keep_their_colours_and_twelve_robots_get_twelve() -> None:
    """Twelve robots' series get twelve colours; a robot joining takes a free colour and the others keep
    theirs; one leaving frees its colour for the next; a label twice is two series."""
    kept: dict[str, int] = {}
    robots = [f"robot{n}:speed" for n in (1, 2, 4, 5, 6, 7, 8, 9, 10, 11, 12)]
    first = series_colors(robots, kept)
    assert first == list(range(11))
    joined = sorted([*robots, "robot3:speed"])
    colours = dict(zip(joined, series_colors(joined, kept), strict=True))
    assert len(set(colours.values())) == 12
    assert all(colours[label] == c for label, c in zip(robots, first, strict=True))
    assert colours["robot3:speed"] == 11
    left = [label for label in joined if label != "robot1:speed"]
    assert series_colors([*left, "robot13:speed"], kept)[-1] == 0, "robot1's colour, free again"
    assert series_colors(["a", "a"], {}) == [0, 1]
