"""The Plot widget: several series over a time range you can zoom, pan and hover, live or paused.

By default the range follows: it ends at the newest sample (paused at a time, the viewer's timeline: at the
cursor, drawn as a vertical line with each series' value there) and lasts the plot's window. The wheel
zooms (following on, with a new length), a drag pans and a right drag zooms to a box (both hold the range
where the user put it while data arrive), a double click follows again; hovering shows a line and each
series' value under the pointer. The range is the dashboard's shared `TimeRange`, so every linked plot
shows the same one (the header's *Link* box, saved as the ``link`` property, unlinks a plot). ImPlot does
the zoom and pan; `_timeaxis` reads them back and keeps the axis and the range in step. The parameter
changes and user markers of the range are thin labelled lines (`_eventlines`: close ones share a line).
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer._widgets._common import SERIES_COLORS, clock_text, latest_number, nonfinite_text, text_size
from dbglog.viewer._widgets._eventlines import EventLine, event_lines
from dbglog.viewer._widgets._geometry import spread
from dbglog.viewer._widgets._plotfit import (
    ROW_H,
    ROW_MARGIN,
    LegendMode,
    LegendPlan,
    fit_text,
    info_forms,
    keep_within,
    legend_plan,
    tag_columns,
    tag_digits,
)
from dbglog.viewer._widgets._plotlines import LINE_WORKER, LineJob, Lines, LineTask, plot_lines
from dbglog.viewer._widgets._timeaxis import (
    AxisSync,
    HoverTracker,
    Limits,
    remap,
    sample_at,
    time_ticks,
    user_moved,
)
from dbglog.viewer.widget_api import (
    Binding,
    Property,
    PropKind,
    SeriesSnapshot,
    TimeRange,
    ValueKind,
    Widget,
    capture_name,
    tag_of,
)

__all__ = [
    "CURSOR_COLOR",
    "CURSOR_MARGIN",
    "HOVER_COLOR",
    "PLOT_MARGIN",
    "PlotWidget",
    "reading",
    "series_colors",
    "series_label",
    "tag_height",
]

PLOT_MARGIN = 48
"""Pixels of the plot widget's width outside the plot area (y tick labels, padding): an upper bound."""
CURSOR_MARGIN = 0.06
"""Paused, the time axis runs on past the cursor by this fraction of the window, so its line shows."""
CURSOR_COLOR = (240, 176, 64, 255)
"""The cursor line: the timeline bar's PAUSED colour."""
HOVER_COLOR = (220, 226, 236, 190)
"""The hover line: a light, thin grey that reads over every series colour."""
SELECT_COLOR = (86, 166, 240, 255)
"""A box zoom being dragged (the viewer's accent blue)."""
LONE_SIZE = 2.5
"""The radius of the dot marking a sample alone between gaps (the line is 2 px wide)."""
EDGE_SIZE = 4.0
"""The size of the triangle marking a +inf (at the top) or -inf (at the bottom) sample."""
EDGE_INSET = 0.03
"""The infinity marks stand this fraction of the y range inside the edge (a whole triangle shows)."""
TAG_GAP = 18
"""Pixels between two value tags at the cursor (close values are spread apart to stay readable)."""
TAG_SIDE = 6
"""Pixels between the cursor (or hover) line and the value tags beside it."""
TAG_PAD = 2
"""ImPlot's padding around a tag's text (AnnotationPadding), on each side."""
PAST_MARGIN = 1.5
"""Paused, a plot reads this many times the seconds its range shows before the cursor (see `past_needed`)."""
HEADER_H = 28
"""The row above the plot: Pause, Link and what the plot shows."""
NO_BUTTON = 4
"""A mouse button nobody presses (ImGui's last): ImPlot's double-click fit goes there; ours resets."""
HEADER_FIXED = 150
"""Pixels of the header before its range label (Pause, Link) until the first frame measures them."""
SWATCH_W, SWATCH_GAP = 6, 2
"""The collapsed legend: a colour swatch per series in the header, this wide, this far apart."""
CHANGE_LINE = (90, 210, 210, 150)
"""A parameter change's line (the timeline bar's diamonds' colour, lighter)."""
MARKER_LINE = (246, 160, 60, 190)
"""A user's marker's line (the timeline bar's flags' colour)."""
EVENT_LABEL_BG = {False: (28, 70, 72, 235), True: (96, 62, 26, 235)}
"""An event label's box: a change's, a marker's (dark: ImPlot writes light text on it)."""
EVENT_ROW_PX = 18
"""Pixels from one row of event labels to the next, from the plot area's bottom."""
DIM = (138, 146, 158, 255)
"""Secondary text (the header's range label, notes in tooltips): the viewer's dim grey."""
TEXT_WIDTHS_KEPT = 512
"""Measured text widths kept per plot (labels and header forms)."""
GESTURES_TIP = (
    "Wheel: zoom the time axis (following the newest data while live); while the wheel scrolls the canvas,\n"
    "a plot sliding under the pointer zooms once the wheel rests or the mouse moves, or with Ctrl\n"
    "Drag: pan \u00b7 right drag: zoom to a box (both hold the range)\n"
    "Double click: follow the newest data again (End does it for every plot)\n"
    "Hover: the value of each series under the pointer"
)


def reading(value: float | None, digits: int = 6) -> str:
    """Return a series' value at the cursor as the legend and the value tag show it (6 significant digits;
    ``NaN``, ``+inf``, ``-inf`` as such; a dash for no value)."""
    if value is None:
        return "\u2014"
    odd = nonfinite_text(value)
    return odd if odd is not None else f"{value:.{digits}g}"


def tag_height(value: float, limits: Limits | None) -> float:
    """Where a value's tag stands on the y axis: at the value; +inf at the top, -inf at the bottom and NaN
    half way (with the limits shown; else 0)."""
    if np.isfinite(value):
        return value
    if limits is None:
        return 0.0
    lo, hi = limits
    if np.isnan(value):
        return (lo + hi) / 2
    return hi if value > 0 else lo


def series_label(binding: Binding) -> str:
    """Return a short legend label for a binding: its regex's capture name (a number taken from log lines,
    ``(?P<x>…)``: ``x``), else the tag or topic, plus the field."""
    named = capture_name(binding.regex) if binding.regex else None
    if named:
        return named
    topic = tag_of(binding.topic) or binding.topic
    return f"{topic}.{binding.field}" if binding.field and binding.field != "data" else topic


def series_colors(labels: Sequence[str], kept: dict[str, int]) -> list[int]:
    """The palette index (`SERIES_COLORS`) of each series: a series keeps the colour it had (a robot keeps
    its colour in an overlay as robots come and go), a new one takes the first colour no other series has.

    Args:
        labels: the series' legend labels, in order.
        kept: label -> the colour it had; updated to the series given (a second series of one label is
            ``label#2``).
    """
    keys = [
        f"{label}#{labels[:i].count(label) + 1}" if label in labels[:i] else label
        for i, label in enumerate(labels)
    ]
    old = {key: kept[key] for key in keys if key in kept}
    taken = set(old.values())
    free = (i for i in itertools.count() if i not in taken)
    kept.clear()
    for key in keys:
        kept[key] = old[key] if key in old else next(free)
    return [kept[key] % len(SERIES_COLORS) for key in keys]


def span_text(seconds: float) -> str:
    """Return a time range's length for the header: ``10 s``, ``2.5 s``, ``120 ms``, ``5 min``."""
    if seconds < 1:
        return f"{seconds * 1000:.3g} ms"
    if seconds >= 120:
        return f"{seconds / 60:.3g} min"
    return f"{seconds:.3g} s"


def _clock(t: float, millis: bool) -> str:
    """A source time as the local clock, with milliseconds (``12:03:04.512``) or without (``12:03:04``)."""
    text = clock_text(t)
    return text if millis else text.rsplit(".", 1)[0]


def _plot_theme(*, compact_legend: bool = False) -> int | str:
    """The plot's dark colours (bound per plot, not globally); a compact legend box for a legend row."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvPlot):
        dpg.add_theme_color(dpg.mvPlotCol_PlotBg, (24, 26, 32, 255), category=dpg.mvThemeCat_Plots)
        # The frame around the plot area is the widget panel itself: leaving it transparent looks the same
        # and saves a fill of the whole plot (fill rate is what a software renderer pays for).
        dpg.add_theme_color(dpg.mvPlotCol_FrameBg, (0, 0, 0, 0), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_PlotBorder, (58, 63, 76, 255), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_LegendBg, (33, 36, 44, 200), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_Selection, SELECT_COLOR, category=dpg.mvThemeCat_Plots)
        dpg.add_theme_style(dpg.mvPlotStyleVar_PlotPadding, 4, 4, category=dpg.mvThemeCat_Plots)
        if compact_legend:  # a row above the plot area: as little height as the names need
            dpg.add_theme_style(
                dpg.mvPlotStyleVar_LegendPadding, ROW_MARGIN, 3, category=dpg.mvThemeCat_Plots
            )
            dpg.add_theme_style(dpg.mvPlotStyleVar_LegendInnerPadding, 5, 2, category=dpg.mvThemeCat_Plots)
    result: int | str = theme
    return result


def _mark_series(
    axis: int | str, label: str, color: tuple[int, int, int, int], marker: int, size: float
) -> int | str:
    """A hidden scatter series of markers in a series' colour (its lone samples, its infinities)."""
    item = dpg.add_scatter_series([], [], label=label, parent=axis, show=False)
    with dpg.theme() as theme, dpg.theme_component(dpg.mvScatterSeries):
        dpg.add_theme_color(dpg.mvPlotCol_MarkerFill, color, category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_MarkerOutline, color, category=dpg.mvThemeCat_Plots)
        dpg.add_theme_style(dpg.mvPlotStyleVar_Marker, marker, category=dpg.mvThemeCat_Plots)
        dpg.add_theme_style(dpg.mvPlotStyleVar_MarkerSize, size, category=dpg.mvThemeCat_Plots)
    dpg.bind_item_theme(item, theme)
    result: int | str = item
    return result


def _line_theme(color: tuple[int, int, int, int], weight: float) -> int | str:
    with dpg.theme() as theme, dpg.theme_component(dpg.mvInfLineSeries):
        dpg.add_theme_color(dpg.mvPlotCol_Line, color, category=dpg.mvThemeCat_Plots)
        dpg.add_theme_style(dpg.mvPlotStyleVar_LineWeight, weight, category=dpg.mvThemeCat_Plots)
    result: int | str = theme
    return result


class PlotWidget(Widget):
    """A time plot of up to eight series; it never sends more points to the GPU than it has pixels."""

    type_name = "plot"
    label = "Plot"
    description = "Time plot of one or more series"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL})
    max_bindings = 8
    properties = (
        Property("window", PropKind.NUMBER, 10.0, minimum=0.5, maximum=3600, label="Time window (s)"),
        Property("scale", PropKind.CHOICE, "auto", choices=("auto", "fixed")),
        Property("y_min", PropKind.NUMBER, 0.0, minimum=-1e12, maximum=1e12, label="Fixed minimum"),
        Property("y_max", PropKind.NUMBER, 100.0, minimum=-1e12, maximum=1e12, label="Fixed maximum"),
        Property("legend", PropKind.BOOL, True, label="Show legend"),
        Property(
            "link",
            PropKind.BOOL,
            True,
            label="Link time range",
            help="Zoom and pan together with the other linked plots (one time range for all of them)",
        ),
    )
    default_size = (420, 240)
    min_size = (200, 140)

    def __init__(self, props: dict[str, float | str | bool] | None = None) -> None:
        super().__init__(props)
        self.paused = False
        """The plot's own Pause: its picture (data and end) is frozen; zoom and pan still work on it."""
        self._wheel = False
        """Whether the plain wheel zooms the plot (`allow_wheel`); else only Ctrl+wheel does."""
        self.points_drawn = 0
        """Points sent to the plot in the last update (for tests and the benchmark)."""
        self.drawn_from: float | None = None
        """The source time of the oldest point drawn (any series), None when none is drawn."""
        self.drawn_to: float | None = None
        """The source time of the newest point drawn (any series), None when none is drawn."""
        self.lines_later = 0
        """Frames whose lines went to the line worker, shown a frame later (the cursor kept moving)."""
        self.cursor_values: list[float | None] = []
        """Paused: each series' value at the cursor (what the legend and the value tags show); else empty."""
        self.hover_time: float | None = None
        """The source time under the pointer over this plot's area, or a linked plot's, else None."""
        self.hover_values: list[float | None] = []
        """Each series' value at `hover_time` (its last sample then), while hovering; else empty."""
        self.pointer_over = False
        """Whether the pointer is over this plot's area (else `hover_time` comes from a linked plot)."""
        self.view: Limits | None = None
        """The source times the time axis shows (after the last update), None before it."""
        self.plot: int | str = 0
        self.event_lines: list[EventLine] = []
        """The event lines drawn over the range (with their labels as drawn), after the last update."""
        self._own: TimeRange | None = None
        self._lives_seen: int | None = None

    # -- building ------------------------------------------------------------------------------------

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the header (Pause, Link, what is shown), the plot, its axes, the cursor and hover lines."""
        self._series: list[int | str] = []
        self._dots: list[int | str] = []
        self._marks: list[tuple[int | str, ...]] = []
        """Per series: its lone samples, its +inf and its -inf marks (scatter series)."""
        self._notes: list[int | str] = []
        self._labels: list[str] = []
        self._color_of: dict[str, int] = {}
        """Series label -> its colour (`series_colors`: kept while the series is shown)."""
        self._colors: list[tuple[int, int, int, int]] = []
        """The series' colours, in order."""
        self._shown_labels: list[str] = []
        self.legend_plan = LegendPlan(LegendMode.OFF, ())
        """Where the legend is and the names it shows (`legend_plan`, for the plot's size and series)."""
        self._chip_texts: list[int | str] = []
        self._chip_named: list[str] = []
        self._legend: int | str = 0
        self._legend_shown: object = None
        self._widths: dict[str, float] = {}
        self._info_key: object = None
        self.info_full = ""
        """The header's range label in full (what `info` shortens to fit, shown in its tooltip)."""
        self._limits: Limits | None = None
        self._ticks: tuple[tuple[str, float], ...] | None = None
        self._info_text = ""
        self._data_key: object = None
        self._lines_task: LineTask | None = None
        self._older: dict[Binding, tuple[object, tuple[np.ndarray, np.ndarray] | None]] = {}
        """Each series' history envelope before its snapshot (zoomed out), with the key it was made for."""
        self._marks_drawn: object = ...  # (nothing drawn yet)
        self._snaps: list[SeriesSnapshot] = []
        self._at: float | None = None
        self._now = 0.0
        self._end: float | None = None
        self._sync = AxisSync()
        self._hover = HoverTracker()
        self._frame = -1
        self._visible = False
        self._actual: Limits | None = None
        self._doubles = 0
        self._doubles_seen = 0
        self._box_frame = -2
        self._configured: dict[int | str, dict[str, object]] = {}
        """The configuration last given to each mark item (cursor and hover lines, tags, dots)."""
        self._plot_h = max(60, height - HEADER_H)
        with dpg.group(parent=parent, horizontal=True):
            self._pause = dpg.add_checkbox(label="Pause", default_value=self.paused, callback=self._on_pause)
            self._link = dpg.add_checkbox(
                label="Link", default_value=bool(self.prop("link")), callback=self._on_link
            )
            with dpg.tooltip(self._link):
                dpg.add_text("Zoom and pan together with the other linked plots")
            # The collapsed legend: a swatch per series; hovered, it names them (with their values).
            with dpg.group(show=False) as self._chip_box:  # (a tooltip needs a group: not a drawlist)
                self._chip = dpg.add_drawlist(1, 16)
            with dpg.tooltip(self._chip_box):
                self._chip_tip = dpg.add_group()
            self._info = dpg.add_text("", color=DIM)
            with dpg.tooltip(self._info):
                self._info_tip = dpg.add_text("", show=False)
                dpg.add_text(GESTURES_TIP)
        self.plot = dpg.add_plot(
            width=width,
            height=self._plot_h,
            parent=parent,
            no_menus=True,
            no_mouse_pos=True,
            fit_button=NO_BUTTON,
            zoom_mod=0 if self._wheel else dpg.mvKey_ModCtrl,
            override_mod=dpg.mvKey_ModSuper,  # (ImPlot's default, Ctrl, would ignore Ctrl+wheel)
        )
        self._themes = {False: _plot_theme()}
        dpg.bind_item_theme(self.plot, self._themes[False])
        self.x_axis = dpg.add_plot_axis(
            dpg.mvXAxis, parent=self.plot, label="", no_menus=True, no_highlight=True, no_initial_fit=True
        )
        self.y_axis = dpg.add_plot_axis(dpg.mvYAxis, parent=self.plot, no_menus=True, no_highlight=True)
        window = self.num("window")
        self._sync.shown, self._sync.forcing = (-window, 0.0), True
        self._sync.forced_at = int(dpg.get_frame_count())  # let go once a frame drew them
        dpg.set_axis_limits(self.x_axis, -window, 0.0)
        # The y axis is always set by the plot (auto: to what the range shows; fixed): ImPlot's zoom, pan
        # and box then move the time axis only.
        if self.prop("scale") == "fixed":
            self._set_y_limits((self.num("y_min"), self.num("y_max")))
        else:
            self._set_y_limits((-1.0, 1.0))
        # The time cursor while paused, and the hover line: vertical lines, out of the legend.
        self._cursor_line = dpg.add_inf_line_series([0.0], label="##cursor", parent=self.y_axis, show=False)
        dpg.bind_item_theme(self._cursor_line, _line_theme(CURSOR_COLOR, 1.5))
        self._hover_line = dpg.add_inf_line_series([0.0], label="##hover", parent=self.y_axis, show=False)
        dpg.bind_item_theme(self._hover_line, _line_theme(HOVER_COLOR, 1.0))
        # Parameter changes and user markers: thin lines, labelled along the top (`_draw_events`).
        self._event_series = {
            marker: dpg.add_inf_line_series([0.0], label=f"##events{marker}", parent=self.y_axis, show=False)
            for marker in (False, True)
        }
        for marker, tag in self._event_series.items():
            dpg.bind_item_theme(tag, _line_theme(MARKER_LINE if marker else CHANGE_LINE, 1.0))
        self._event_notes: list[int | str] = []
        self._events_drawn: object = None

    def destroy(self) -> None:
        """Delete the plot's items; the pointer is no longer over it for the plots sharing its range."""
        if self.plot:
            self.time_range().point(None, self)
        super().destroy()

    def _set_y_limits(self, limits: Limits) -> None:
        if limits != self._limits:
            dpg.set_axis_limits(self.y_axis, *limits)
            self._limits = limits

    def _on_pause(self, sender: int | str, value: bool) -> None:
        self.paused = bool(value)

    def _on_link(self, sender: int | str, value: bool) -> None:
        self.save_property("link", bool(value))

    def set_paused(self, paused: bool) -> None:
        """Freeze or resume the plot (the checkbox does the same)."""
        self.paused = paused
        dpg.set_value(self._pause, paused)

    def set_linked(self, linked: bool) -> None:
        """Share the dashboard's time range, or keep one of this plot's own (the Link box does the same)."""
        self.save_property("link", linked)
        dpg.set_value(self._link, linked)

    def _ensure_series(self, snapshots: Sequence[SeriesSnapshot]) -> None:
        labels = [series_label(s.binding) for s in snapshots]
        if labels == self._labels:
            return
        for tag in (*self._series, *self._dots, *self._notes, *(m for ms in self._marks for m in ms)):
            dpg.delete_item(tag)
        self._series, self._dots, self._notes, self._marks = [], [], [], []
        plan = legend_plan(labels, self.width, self._plot_h, self._measure, enabled=bool(self.prop("legend")))
        self._colors = [SERIES_COLORS[c] for c in series_colors(labels, self._color_of)]
        for i, label in enumerate(plan.labels):
            color = self._colors[i]
            tag = dpg.add_line_series([], [], label=label, parent=self.y_axis)
            with dpg.theme() as theme, dpg.theme_component(dpg.mvLineSeries):
                dpg.add_theme_color(dpg.mvPlotCol_Line, color, category=dpg.mvThemeCat_Plots)
                dpg.add_theme_style(dpg.mvPlotStyleVar_LineWeight, 2.0, category=dpg.mvThemeCat_Plots)
            dpg.bind_item_theme(tag, theme)
            self._series.append(tag)
            # What the line alone does not show: samples alone between gaps, infinities at the edges.
            self._marks.append(
                tuple(
                    _mark_series(self.y_axis, f"##{what}{i}", color, marker, size)
                    for what, marker, size in (
                        ("lone", dpg.mvPlotMarker_Circle, LONE_SIZE),
                        ("above", dpg.mvPlotMarker_Up, EDGE_SIZE),
                        ("below", dpg.mvPlotMarker_Down, EDGE_SIZE),
                    )
                )
            )
            # Hovering: a dot where the hover line crosses the series.
            dot = dpg.add_scatter_series([0.0], [0.0], label=f"##dot{i}", parent=self.y_axis, show=False)
            with dpg.theme() as theme, dpg.theme_component(dpg.mvScatterSeries):
                dpg.add_theme_color(dpg.mvPlotCol_MarkerFill, color, category=dpg.mvThemeCat_Plots)
                dpg.add_theme_color(
                    dpg.mvPlotCol_MarkerOutline, (24, 26, 32, 255), category=dpg.mvThemeCat_Plots
                )
                dpg.add_theme_style(
                    dpg.mvPlotStyleVar_Marker, dpg.mvPlotMarker_Circle, category=dpg.mvThemeCat_Plots
                )
                dpg.add_theme_style(dpg.mvPlotStyleVar_MarkerSize, 4.0, category=dpg.mvThemeCat_Plots)
            dpg.bind_item_theme(dot, theme)
            self._dots.append(dot)
            # The value at the cursor (paused) or under the pointer, tagged on the line in the series' colour.
            note = dpg.add_plot_annotation(
                parent=self.plot, label="", offset=(-6, 0), color=color, clamped=True, show=False
            )
            self._notes.append(note)
        self._labels = labels
        self._shown_labels = list(plan.labels)
        self._data_key, self._marks_drawn = None, ...
        self._lines_task = None  # lines for the series as they were
        self._configured.clear()
        self.legend_plan = plan
        self._show_chip(labels)

    def _show_legend(self) -> None:
        """Place the legend as planned: over the data, or in a row above them; none when collapsed (the
        header's swatches name the series) or without the ``legend`` property."""
        mode = self.legend_plan.mode
        if mode == self._legend_shown:
            return
        self._legend_shown = mode
        if self._legend:
            dpg.delete_item(self._legend)
            self._legend = 0
        if mode in (LegendMode.OFF, LegendMode.COLLAPSED):
            pass
        elif mode is LegendMode.ROW:
            self._legend = dpg.add_plot_legend(
                parent=self.plot, location=dpg.mvPlot_Location_North, outside=True, horizontal=True
            )
        else:
            self._legend = dpg.add_plot_legend(parent=self.plot, location=dpg.mvPlot_Location_NorthWest)
        compact = mode is LegendMode.ROW
        if compact not in self._themes:
            self._themes[compact] = _plot_theme(compact_legend=compact)
        dpg.bind_item_theme(self.plot, self._themes[compact])
        self._marks_drawn = ...  # the legend's names with values, or without
        self._ticks = None  # (set again: the plot's items changed)

    def _show_chip(self, labels: Sequence[str]) -> None:
        """The collapsed legend: a colour swatch per series in the header, naming them all in its tooltip."""
        collapsed = self.legend_plan.mode is LegendMode.COLLAPSED
        dpg.configure_item(self._chip_box, show=collapsed)
        dpg.delete_item(self._chip, children_only=True)
        dpg.delete_item(self._chip_tip, children_only=True)
        self._chip_texts, self._chip_named = [], []
        if not collapsed:
            return
        width = len(labels) * (SWATCH_W + SWATCH_GAP) + SWATCH_GAP
        dpg.configure_item(self._chip, width=width)
        dpg.draw_rectangle((0, 0), (width, 16), color=(0, 0, 0, 0), fill=(44, 48, 58, 255), parent=self._chip)
        for i, label in enumerate(labels):
            color = self._colors[i]
            x = SWATCH_GAP + i * (SWATCH_W + SWATCH_GAP)
            dpg.draw_rectangle((x, 3), (x + SWATCH_W, 13), color=color, fill=color, parent=self._chip)
            self._chip_texts.append(dpg.add_text(f"\u25a0 {label}", color=color, parent=self._chip_tip))
        dpg.add_text("(too small a plot for a legend beside the lines)", color=DIM, parent=self._chip_tip)

    def _measure(self, text: str) -> float:
        """The width of `text` in pixels in the viewer's font (estimated until the font is measured)."""
        width = self._widths.get(text)
        if width is None:
            size = dpg.get_text_size(text)
            if not size or not size[0] > 0:
                return text_size(text, 13)[0]
            if len(self._widths) > TEXT_WIDTHS_KEPT:
                self._widths.clear()
            width = self._widths[text] = float(size[0])
        return width

    def _configure(self, tag: int | str, **config: object) -> None:
        """Configure a mark item, unless its last configuration was exactly this (each call costs)."""
        if self._configured.get(tag) != config:
            self._configured[tag] = config
            dpg.configure_item(tag, **config)

    # -- the time range ------------------------------------------------------------------------------

    def time_range(self) -> TimeRange:
        """Return the range this plot shows: the dashboard's shared one while linked, else its own."""
        shared = self.context.time_range
        if shared is not None and self.prop("link"):
            self._own = None
            return shared
        if self._own is None:  # unlinked: it goes on from what it showed, on its own
            self._own = shared.copy() if shared is not None else TimeRange()
            if shared is not None:
                shared.point(None, self)
        return self._own

    def visible_range(self) -> Limits | None:
        """Return the source times the plot shows (start, end), None before its first update."""
        return self.view

    def allow_wheel(self, on: bool) -> None:
        """Let the plain wheel zoom the plot (the viewer decides: not while the wheel scrolls the canvas
        past it), or only Ctrl+wheel."""
        self._wheel = on
        if self.plot and dpg.does_item_exist(self.plot):
            dpg.configure_item(self.plot, zoom_mod=0 if on else dpg.mvKey_ModCtrl)

    def owns_pointer(self, x: float, y: float) -> bool:
        """The plot area is the plot's: its wheel zooms, its right drag zooms to a box (no canvas menu)."""
        if not self.plot or not dpg.does_item_exist(self.plot):
            return False
        (px, py), (pw, ph) = dpg.get_item_rect_min(self.plot), dpg.get_item_rect_size(self.plot)
        return bool(px <= x < px + pw and py <= y < py + ph)

    def _poll(self) -> None:
        """Once a frame: what ImPlot did with the mouse (the x limits), the hover, a double click, a box."""
        frame = int(dpg.get_frame_count())
        if frame == self._frame:
            return
        self._frame = frame
        self._visible = bool(dpg.is_item_visible(self.plot))
        hovered = self._visible and bool(dpg.is_item_hovered(self.plot))
        mx, my = dpg.get_mouse_pos(local=False)
        ux, uy = dpg.get_plot_mouse_pos()
        self._hover.see(frame, hovered, (float(mx), float(my)), (float(ux), float(uy)))
        if hovered and dpg.is_mouse_button_double_clicked(dpg.mvMouseButton_Left):
            self._doubles += 1
        if dpg.is_mouse_button_released(dpg.mvMouseButton_Right):
            self._box_frame = frame
        if self._visible:
            lo, hi = dpg.get_axis_limits(self.x_axis)
            self._actual = (float(lo), float(hi))

    def redraw_key(self) -> object:
        """What, besides new data, redraws the plot: the range (zoom, pan, linked plots, the newest time while
        following), the pointer over it, a double click, limits still being pushed to ImPlot, lines from
        the line worker to show (the cursor stopped after moving: nothing else may change)."""
        if not self.plot or not dpg.does_item_exist(self.plot):
            return None
        self._poll()
        rng = self.time_range()
        shared = self.context.time_range
        return (
            rng.version,
            rng.newest if rng.following and not self.paused else None,
            shared.lives if shared is not None else 0,
            bool(self.prop("link")),
            self._actual,
            self._hover.x,
            rng.hover,
            self._doubles,
            self._sync.forcing,
            self._visible and self._sync.due(self._frame),
            self.paused,
            self.lines_later,  # a new task's lines, computed while the last frame rendered: shown in this one
            self.context.host.events_version() if self.context.host is not None else 0,
        )

    # -- drawing -------------------------------------------------------------------------------------

    def past_needed(self, at: float) -> float:
        """Paused at `at`, the seconds of samples before it the plot draws: its range, and half of it again
        (a zoom out by the wheel; further out, `_history_before` draws the history's envelope), or none
        while its own Pause keeps the picture it has."""
        if self.paused and getattr(self, "_snaps", None):
            return 0.0
        start, _stop = self.time_range().window(self.num("window"), at)
        return max(0.0, at - start) * PAST_MARGIN

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Take ImPlot's zoom and pan into the range, then draw every series over the range and the hover."""
        self._poll()
        if not self.paused or not self._snaps:
            self._snaps, self._at, self._now = list(snapshots), self.paused_at, now
        snaps, at = self._snaps, self._at
        self._ensure_series(snaps)
        self._show_legend()
        latest = [float(s.times[-1]) for s in snaps if len(s.times)]
        own_newest = max(latest) if latest else self._now
        rng = self.time_range()
        shared = self.context.time_range
        if rng is not shared:  # the newest held (the viewer's; paused, the snapshots end at the cursor)
            if shared is not None and shared.newest is not None:
                rng.sync(shared.newest, at)
            else:
                rng.sync(own_newest if at is None else rng.newest, at)
            if shared is not None and self._lives_seen is not None and shared.lives != self._lives_seen:
                rng.go_live()  # End: every plot follows the newest data again, linked or not
        if shared is not None:
            self._lives_seen = shared.lives
        newest = own_newest if rng.newest is None else max(own_newest, rng.newest)
        end = at if at is not None else newest
        if self.paused and self._end is not None:
            end = self._end
        self._end = end
        extra = CURSOR_MARGIN if at is not None else 0.0
        # What the user did with ImPlot since the last frame (a frame with limits pushed took no input).
        sync = self._sync
        if sync.forcing:  # ImPlot took no input while limits were pushed: let them go once drawn
            if self._visible and sync.release(self._frame):
                dpg.set_axis_limits_auto(self.x_axis)
        elif self._visible and self._actual is not None:
            before = sync.before()
            moved = sync.observe(self._actual)
            if moved is not None and before is not None:
                user_moved(rng, before, moved, box=self._box_frame == self._frame, extra=extra)
        if self._doubles != self._doubles_seen:
            self._doubles_seen = self._doubles
            rng.reset()
        start, stop = rng.window(self.num("window"), end)
        if rng.following:
            stop += (stop - start) * extra
        hover_x, hover_limits = self._hover.x, sync.shown
        limits = sync.place((start, stop), end if rng.following else None, frame=self._frame)
        if limits is not None:
            dpg.set_axis_limits(self.x_axis, *limits)
        origin = sync.origin if sync.origin is not None else end
        self.view = (start, stop)
        self._draw_series(snaps, start, stop, origin, at)
        self._draw_ticks(start, stop, origin)
        self._draw_events(start, stop, origin)
        mine = None
        if hover_x is not None and hover_limits is not None and sync.shown is not None:
            mine = remap(hover_x, hover_limits, sync.shown) + origin
        self.pointer_over = mine is not None
        rng.point(mine, self)  # plots sharing the range show the time under the pointer too
        hover = mine if mine is not None else rng.hover
        self._show_marks(snaps, at, hover, origin)
        self._show_info(rng, at, end, start, stop, hover)

    def _draw_series(
        self, snaps: Sequence[SeriesSnapshot], start: float, stop: float, origin: float, at: float | None
    ) -> None:
        """Decimate each series over [start, stop] to the plot's width; fit the y axis to what shows.

        While the shared cursor keeps moving (`TimeRange.moving`), the lines are computed on the viewer's
        line worker during the render and shown one frame later (`_plotlines`), never past the cursor
        `at`; else at once.
        """
        if self._lines_task is not None:  # the last frame's lines, computed while it rendered
            task, self._lines_task = self._lines_task, None
            self._show_lines(task.take().moved_to(origin, at))
        key = (tuple((s.count, s.last_time, len(s.times)) for s in snaps), start, stop, origin, self.width)
        if key == self._data_key:
            return
        self._data_key = key
        max_points = max(2, self.width - PLOT_MARGIN)
        older = []
        for snap in snaps:
            n = min(len(snap.times), len(snap.values))
            first = float(snap.times[len(snap.times) - n]) if n else stop
            older.append(self._history_before(snap, start, stop, first, max_points))
        fixed = (self.num("y_min"), self.num("y_max")) if self.prop("scale") == "fixed" else None
        job = LineJob(
            tuple(snaps),
            tuple(older),
            start,
            stop,
            origin,
            max_points,
            fixed,
            self._limits,
            self.width,
            self._plot_h,
        )
        shared = self.context.time_range
        if shared is not None and shared.moving:
            self._lines_task = LINE_WORKER.submit(job)
            self.lines_later += 1
        else:
            self._show_lines(plot_lines(job))

    def _show_lines(self, lines: Lines) -> None:
        """Hand the lines to ImPlot and the y limits with them."""
        if lines.limits is not None:
            self._set_y_limits(lines.limits)
        for tag, (x, y) in zip(self._series, lines.lines, strict=True):
            dpg.set_value(tag, [x, y])  # contiguous float64: through the buffer protocol, without lists
        lo, hi = self._limits if self._limits is not None else (0.0, 1.0)
        inset = (hi - lo) * EDGE_INSET
        for items, marks in zip(self._marks, lines.marks, strict=True):
            lone, above, below = items
            for item, x, y in (
                (lone, *marks.lone),
                (above, marks.above, np.full(len(marks.above), hi - inset)),
                (below, marks.below, np.full(len(marks.below), lo + inset)),
            ):
                if len(x) or self._configured.get(item, {}).get("show", False):
                    dpg.set_value(
                        item, [np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)]
                    )
                    self._configure(item, show=bool(len(x)))
        self.points_drawn = lines.drawn
        self.drawn_from, self.drawn_to = lines.oldest, lines.newest

    def _history_before(
        self, snap: SeriesSnapshot, start: float, stop: float, first: float, max_points: int
    ) -> tuple[np.ndarray, np.ndarray] | None:
        """The history's min/max envelope of `snap`'s series from `start` up to `first`, the snapshot's oldest
        sample: a plot zoomed out past what a snapshot carries draws the whole history, not just its end.

        None when the snapshot holds the series' every sample, the range starts after it, or no history
        answers. Kept while the range's ends move by less than a pixel column (a following plot slides).
        """
        host = self.context.host
        if (
            host is None
            or first <= start
            or snap.count <= len(snap.times)
            or snap.kind not in (ValueKind.NUMBER, ValueKind.BOOL)
        ):
            return None
        column = (stop - start) / max_points
        if not column > 0:
            return None
        key = (round(start / column), round(first / column), max_points)
        cached = self._older.get(snap.binding)
        if cached is not None and cached[0] == key:
            return cached[1]
        found = host.envelope(snap.binding, start, first, max(1, round((first - start) / column)))
        part = None
        if found is not None:
            keep = found[0] < first  # the snapshot draws from `first` on
            part = (found[0][keep], found[1][keep])
        if len(self._older) > 64:
            self._older.clear()
        self._older[snap.binding] = (key, part)
        return part

    def _draw_events(self, start: float, stop: float, origin: float) -> None:
        """The parameter changes and user markers from `start` to `stop`: a thin line each (close ones
        share one), labelled in two rows along the bottom where there is room (`event_lines`)."""
        host = self.context.host
        if host is None:
            return
        key = (host.events_version(), start, stop, origin, self.width, self._plot_h, self._limits)
        if key == self._events_drawn:
            return
        self._events_drawn = key
        area = max(40, self.width - PLOT_MARGIN)
        lines = event_lines(host.events(start, stop), start, stop, area, self._measure)
        self.event_lines = lines
        for marker, tag in self._event_series.items():
            xs = [line.time - origin for line in lines if line.marker is marker]
            if xs or self._configured.get(tag, {}).get("show", False):
                dpg.set_value(tag, [xs or [0.0]])
                self._configure(tag, show=bool(xs))
        labelled = [line for line in lines if line.label]
        while len(self._event_notes) < len(labelled):
            self._event_notes.append(
                dpg.add_plot_annotation(parent=self.plot, label="", clamped=True, show=False)
            )
        lo, hi = self._limits if self._limits is not None else (0.0, 1.0)
        per_px = ((hi - lo) or 1.0) / max(20.0, self._plot_h - 34)
        for i, note in enumerate(self._event_notes):
            if i >= len(labelled):
                self._configure(note, show=False)
                continue
            line = labelled[i]
            y = lo + (EVENT_ROW_PX * (line.row + 0.5) + 2) * per_px
            self._configure(
                note,
                show=True,
                label=line.label,
                default_value=(line.time - origin, y),
                offset=(-4 if line.left else 4, 0),
                color=EVENT_LABEL_BG[line.marker],
            )

    def _draw_ticks(self, start: float, stop: float, origin: float) -> None:
        """Label the time axis with the local clock (ticks move with the data; linked plots read alike); a
        plot too narrow for a clock label between its ends shows none (not ImPlot's seconds from the end)."""
        ticks = tuple(
            (label, t - origin) for t, label in time_ticks(start, stop, max(40, self.width - PLOT_MARGIN))
        )
        if ticks != self._ticks:
            if ticks:
                dpg.set_axis_ticks(self.x_axis, ticks)
            else:
                dpg.reset_axis_ticks(self.x_axis)
            self._configure(self.x_axis, no_tick_labels=not ticks)
            self._ticks = ticks

    def _show_marks(
        self, snaps: Sequence[SeriesSnapshot], at: float | None, hover: float | None, origin: float
    ) -> None:
        """The cursor line (paused), the hover line, and the values in tags and the legend: under the pointer
        each series' last sample then (a dot marks it), else at the cursor while paused."""
        paused = at is not None
        self.cursor_values = [latest_number(s) for s in snaps] if paused else []
        self.hover_time = hover
        samples = [sample_at(s.times, s.values, hover) for s in snaps] if hover is not None else []
        self.hover_values = [None if p is None else p[1] for p in samples]
        drawn: object = None  # live and not hovered: all hidden, wherever the data are
        if hover is not None or at is not None:
            drawn = (at, hover, origin, tuple(self.cursor_values), tuple(samples), self.view, self._limits)
        if drawn == self._marks_drawn and self._marks_drawn is not ...:
            return  # unchanged (live and not hovered: no Dear PyGui calls at the data rate)
        self._marks_drawn = drawn
        self._configure(self._cursor_line, show=paused)
        if at is not None:
            dpg.set_value(self._cursor_line, [[at - origin]])
        self._configure(self._hover_line, show=hover is not None)
        if hover is not None:
            dpg.set_value(self._hover_line, [[hover - origin]])
        if hover is not None:
            marks = [None if p is None else (p[0] - origin, p[1]) for p in samples]
        elif at is not None:
            marks = [None if v is None else (at - origin, v) for v in self.cursor_values]
        else:
            marks = [None] * len(snaps)
        shown = {i: m[1] for i, m in enumerate(marks) if m is not None}
        side = -1
        if hover is not None and self.view is not None:
            start, stop = self.view
            side = 1 if hover < (start + stop) / 2 else -1  # tags on the side with more room
        digits = tag_digits(self.width)
        texts = {i: reading(v, digits) for i, v in shown.items()}
        heights = [tag_height(v, self._limits) for v in shown.values()]
        places = dict(zip(shown, self._tag_places(heights, list(texts.values())), strict=True))
        labels = list(self.legend_plan.labels)
        valued = self.legend_plan.values_in_legend
        named = [f"\u25a0 {label}" for label in self._labels] if self._chip_texts else []
        for i, (note, dot) in enumerate(zip(self._notes, self._dots, strict=True)):
            mark = marks[i] if i in places else None
            dotted = mark is not None and hover is not None and bool(np.isfinite(mark[1]))
            self._configure(dot, show=dotted)
            if mark is None:
                self._configure(note, show=False)
            else:
                self._configure(
                    note,
                    show=True,
                    label=texts[i],
                    default_value=(mark[0], places[i][0]),
                    offset=(side * places[i][1], 0),
                )
                if dotted:
                    dpg.set_value(dot, [[mark[0]], [mark[1]]])
            if hover is not None or at is not None:
                value = reading(self.hover_values[i] if hover is not None else self.cursor_values[i])
                if valued:
                    labels[i] = f"{labels[i]}  {value}"
                if named:
                    named[i] = f"{named[i]}  {value}"
        if labels != self._shown_labels:
            for tag, label in zip(self._series, labels, strict=True):
                dpg.configure_item(tag, label=label)
            self._shown_labels = labels
        if named != self._chip_named:
            for tag, text in zip(self._chip_texts, named, strict=True):
                dpg.set_value(tag, text)
            self._chip_named = named

    def _show_info(
        self, rng: TimeRange, at: float | None, end: float, start: float, stop: float, hover: float | None
    ) -> None:
        """The header: the time under the pointer, else what the range is (following, or held), in the
        longest form that fits beside Pause and Link (the full one in its tooltip)."""
        forms = info_forms(
            following=rng.following,
            paused=at is not None,
            span=span_text(stop - start),
            span_to_end=span_text(end - start),
            clock=_clock,
            stop=stop,
            end=end,
            hover=hover,
        )
        room = self.width - self._info_offset()
        key = (forms, room)
        if key == self._info_key:
            return
        self._info_key = key
        info = fit_text(forms, room, self._measure)
        if info != self._info_text:
            dpg.set_value(self._info, info)
            self._info_text = info
        full = forms[0] if info != forms[0] else ""
        if full != self.info_full:
            dpg.configure_item(self._info_tip, show=bool(full))
            dpg.set_value(self._info_tip, full)
            self.info_full = full

    def _info_offset(self) -> float:
        """Pixels from the header's left to its range label (measured once drawn, else estimated)."""
        pause_w = dpg.get_item_rect_size(self._pause)[0]
        if pause_w > 0:
            return float(dpg.get_item_rect_min(self._info)[0] - dpg.get_item_rect_min(self._pause)[0])
        if self.legend_plan.mode is LegendMode.COLLAPSED:
            return HEADER_FIXED + float(dpg.get_item_width(self._chip) or 0)
        return HEADER_FIXED

    def _tag_places(self, values: Sequence[float], texts: Sequence[str]) -> list[tuple[float, float]]:
        """Where each value tag goes: its centre (data units) and its distance in pixels from the line.

        Beside its value, moved apart so that close values' tags do not cover each other, all inside the
        plot area; tags too many for the area's height stand in two columns (`tag_columns`).
        (A tag is drawn centred on its point: ImPlot puts a tag with a vertical offset above or below the
        point by the offset's sign, so an offset alone cannot centre it anywhere.)
        """
        if self._limits is None or not values:
            return [(v, TAG_SIDE) for v in values]
        lo, hi = self._limits
        area_h = max(20.0, self._plot_h) - 34  # less the paddings and time labels (a little less than drawn)
        if self.legend_plan.mode is LegendMode.ROW:
            area_h -= ROW_H
        per_px = ((hi - lo) or 1.0) / max(1.0, area_h)
        ys = [(hi - v) / per_px for v in values]
        room = max(0.0, area_h - TAG_GAP)
        columns = tag_columns(ys, TAG_GAP, room)
        first_w = max((self._measure(t) for t, c in zip(texts, columns, strict=True) if c == 0), default=0.0)
        places: list[tuple[float, float]] = [(0.0, 0.0)] * len(values)
        for column in (0, 1):
            mine = [i for i, c in enumerate(columns) if c == column]
            placed = keep_within(
                spread([ys[i] for i in mine], TAG_GAP), TAG_GAP, TAG_GAP / 2, TAG_GAP / 2 + room
            )
            away = TAG_SIDE if column == 0 else TAG_SIDE + first_w + 2 * TAG_PAD + TAG_SIDE / 2
            for i, y in zip(mine, placed, strict=True):
                places[i] = (hi - y * per_px, away)
        return places
