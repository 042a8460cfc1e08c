"""What fits in a plot widget of a given size: where its legend goes, and which form of its header label.

Plain functions of pixel sizes and a text-measuring function (no Dear PyGui): a small plot keeps its lines
clear of the legend (a row above the plot area, short names, or a toggle) and shortens its header label
to a form that fits instead of letting it be cut.
"""

from __future__ import annotations

import enum
from collections.abc import Callable, Sequence
from dataclasses import dataclass

__all__ = [
    "LegendMode",
    "LegendPlan",
    "Measure",
    "fit_text",
    "info_forms",
    "keep_within",
    "legend_plan",
    "short_labels",
    "tag_columns",
    "tag_digits",
]

Measure = Callable[[str], float]
"""The width in pixels of a text in the viewer's font."""

LINE_H = 15.0
"""Height of a legend row (the font's line)."""
ENTRY_EXTRA = 15.0
"""Pixels of a legend entry besides its text: its colour square, a line high (ImPlot's layout)."""
BOX_PAD = 5.0
"""ImPlot's padding inside the legend box, on each side."""
ENTRY_GAP = 5.0
"""Pixels between two entries of a legend laid out in a row."""
ROW_MARGIN = 4.0
"""Pixels between a legend row and the plot's left and right edges (its compact LegendPadding)."""
ROW_H = 26.0
"""Plot height a legend row above the plot area takes (the box and its padding, compact)."""
Y_TICKS_W = 40.0
"""Plot width the y tick labels and paddings take (an upper bound for values like ``-12.5``)."""
X_TICKS_H = 30.0
"""Plot height the time tick labels and paddings take."""
INSIDE_COVER = 0.2
"""A legend may sit over the data when it covers at most this fraction of the plot area ..."""
INSIDE_W, INSIDE_H = 0.5, 0.6
"""... and at most these fractions of its width and of its height (a narrow list of five names is fine)."""
VALUE_SAMPLE = "  -0.000000"
"""What a value adds to a legend entry (two spaces and six significant digits), to size the box with it."""
MIN_AREA_H = 50.0
"""A legend row above the plot area is used only when this much height is left for the data."""
NARROW_W = 360.0
"""A plot narrower than this shows shorter value tags (`tag_digits`)."""
SEPARATORS = "/."
"""Characters a label's common prefix may end on when the labels are shortened."""


class LegendMode(enum.Enum):
    """Where a plot's legend goes."""

    INSIDE = "inside"
    """In the plot area's top left corner, over the data (a big plot: small against the area)."""
    ROW = "row"
    """One row above the plot area, outside it: the lines are never covered."""
    COLLAPSED = "collapsed"
    """Hidden behind a toggle in the header (its tooltip names every series); the plot is too small."""
    OFF = "off"
    """No legend (the ``legend`` property is off)."""


@dataclass(frozen=True)
class LegendPlan:
    """The legend's place and the names it shows (full, or with their common prefix cut)."""

    mode: LegendMode
    labels: tuple[str, ...]
    values_in_legend: bool = False
    """Whether the legend entries carry each series' value (paused or hovered): only inside, and only when
    the box grown by the values still covers little of the data; else the tags at the cursor show them."""


def short_labels(labels: Sequence[str]) -> tuple[str, ...]:
    """Return the labels without the prefix they all share, cut after a ``/`` or ``.``.

    ``/bench/ui/t0, /bench/ui/t1`` become ``t0, t1``; one label keeps its last part. Labels that would become
    empty, or that share no such prefix, are returned as they are.

    Args:
        labels: the series' legend labels (`series_label`).
    """
    if not labels:
        return ()
    first = labels[0]
    common = len(first)
    for label in labels[1:]:
        n = 0
        while n < min(common, len(label)) and label[n] == first[n]:
            n += 1
        common = n
    if len(labels) == 1:
        common = len(first) - 1  # one label: its last part (not all of it)
    cut = max((i + 1 for i in range(common) if first[i] in SEPARATORS), default=0)
    short = tuple(label[cut:] for label in labels)
    return short if all(short) else tuple(labels)


def _inside_fits(labels: Sequence[str], area_w: float, area_h: float, measure: Measure) -> bool:
    box_w = 2 * BOX_PAD + ENTRY_EXTRA + max(measure(label) for label in labels)
    box_h = 2 * BOX_PAD + LINE_H * len(labels)
    return (
        box_w * box_h <= INSIDE_COVER * area_w * area_h
        and box_w <= INSIDE_W * area_w
        and box_h <= INSIDE_H * area_h
    )


def _row_fits(labels: Sequence[str], plot_w: float, measure: Measure) -> bool:
    entries = sum(measure(label) + ENTRY_EXTRA for label in labels)
    row_w = 2 * BOX_PAD + entries + ENTRY_GAP * (len(labels) - 1)
    return row_w <= plot_w - 2 * ROW_MARGIN


def legend_plan(
    labels: Sequence[str], plot_w: float, plot_h: float, measure: Measure, *, enabled: bool = True
) -> LegendPlan:
    """Choose where a plot of `plot_w` x `plot_h` pixels shows the legend of `labels`.

    In order: inside over the data with the full names when the box is small against the plot area (a big
    plot looks as it always did; paused or hovered, each series' value is added to its entry when the box
    stays small with it, else the value tags show them); inside with short names (`short_labels`) on the
    same terms; a row above
    the plot area, full then short names, when it fits the width and leaves the data `MIN_AREA_H` pixels;
    else collapsed to the header's toggle.

    Args:
        labels: the series' legend labels, in order.
        plot_w / plot_h: the plot item's size in pixels (axes included).
        measure: the width of a text in pixels.
        enabled: the ``legend`` property (off: `LegendMode.OFF`).
    """
    full = tuple(labels)
    if not enabled or not full:
        return LegendPlan(LegendMode.OFF, full)
    short = short_labels(full)
    area_w, area_h = plot_w - Y_TICKS_W, plot_h - X_TICKS_H
    if area_w > 0 and area_h > 0:
        for names in (full, short):
            if _inside_fits(names, area_w, area_h, measure):
                valued = [f"{name}{VALUE_SAMPLE}" for name in names]
                return LegendPlan(LegendMode.INSIDE, names, _inside_fits(valued, area_w, area_h, measure))
    if area_h - ROW_H >= MIN_AREA_H:
        for names in (full, short):
            if _row_fits(names, plot_w, measure):
                return LegendPlan(LegendMode.ROW, names)
    return LegendPlan(LegendMode.COLLAPSED, short)


def fit_text(forms: Sequence[str], width: float, measure: Measure) -> str:
    """Return the first (longest) of `forms` that fits in `width` pixels, or "" when none does.

    A label is shortened to a form made for it (fewer words, seconds without milliseconds), never cut
    mid-word.
    """
    for form in forms:
        if measure(form) <= width:
            return form
    return ""


def info_forms(
    *,
    following: bool,
    paused: bool,
    span: str,
    span_to_end: str,
    clock: Callable[[float, bool], str],
    stop: float,
    end: float,
    hover: float | None,
) -> tuple[str, ...]:
    """Return the header's range label in its forms, longest first: what the plot shows or the time under
    the pointer (the first form is the full one).

    Args:
        following: the range follows the newest data (or the cursor), else it is held.
        paused: the viewer is paused at a cursor (`end`).
        span: the range's length as text (`span_text`); `span_to_end`: from its start to `end`.
        clock: a source time as the local clock, with milliseconds or not.
        stop / end: where the range ends; the newest time (live) or the cursor (paused).
        hover: the time under the pointer, or None.
    """
    if hover is not None and not following:
        return (f"{clock(hover, True)} \u00b7 held", clock(hover, True), clock(hover, False))
    if hover is not None:  # following: the time before the newest sample (the cursor) stays put
        offset = f"{hover - end:+.3g} s"
        return (f"{clock(hover, True)}  {offset}", clock(hover, True), clock(hover, False), offset)
    if not following:
        return (
            f"held: {span} to {clock(stop, True)}",
            f"held {span} to {clock(stop, False)}",
            f"held {span}",
            "held",
        )
    if not paused:
        return (f"{span} window", span)
    return (f"{span_to_end} to {clock(end, True)}", f"{span_to_end} to {clock(end, False)}", span_to_end)


def tag_digits(plot_w: float) -> int:
    """Return the significant digits of the value tags at the cursor: 6, or 4 in a plot narrower than
    `NARROW_W` pixels (a tag there would cover a good part of the lines; 4 digits still beat a pixel)."""
    return 6 if plot_w >= NARROW_W else 4


def keep_within(positions: Sequence[float], gap: float, lo: float, hi: float) -> list[float]:
    """Move labels `gap` apart (see `spread`'s result) into [lo, hi], keeping their order and gaps.

    Labels pushed past an end by `spread` are pulled back in, the ones beside them moved along; when they
    cannot all fit `gap` apart, they share the room evenly (overlapping a little, none outside it).

    Args:
        positions: the labels' centres, already spread `gap` apart.
        gap: the least distance between two labels' centres.
        lo / hi: the first and the last centre allowed.
    """
    n = len(positions)
    if n == 0:
        return []
    order = sorted(range(n), key=lambda i: positions[i])
    if n > 1 and (n - 1) * gap > hi - lo:
        step = (hi - lo) / (n - 1)
        placed = [lo + k * step for k in range(n)]
    else:
        placed = [float(positions[i]) for i in order]
        for k in range(n - 1, -1, -1):  # from the bottom: none below hi, each gap kept
            limit = hi if k == n - 1 else placed[k + 1] - gap
            placed[k] = min(placed[k], limit)
        for k in range(n):  # from the top: none above lo
            limit = lo if k == 0 else placed[k - 1] + gap
            placed[k] = max(placed[k], limit)
    out = [0.0] * n
    for k, i in enumerate(order):
        out[i] = placed[k]
    return out


def tag_columns(positions: Sequence[float], gap: float, room: float) -> list[int]:
    """Return each label's column: all in column 0 when they fit `gap` apart in `room` pixels, else by rank
    (top to bottom) alternately in columns 0 and 1, so each column holds half of them.

    Args:
        positions: the labels' wanted centres along the axis.
        gap: the least distance between two labels' centres in one column.
        room: the length the centres may spread over.
    """
    n = len(positions)
    if n < 2 or (n - 1) * gap <= room:
        return [0] * n
    columns = [0] * n
    for rank, i in enumerate(sorted(range(n), key=lambda i: positions[i])):
        columns[i] = rank % 2
    return columns
