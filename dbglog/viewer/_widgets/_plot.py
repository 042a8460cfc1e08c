"""The Plot widget: several series over a sliding time window, auto or fixed scale, pause, decimation.

Live, the window ends at the newest sample. Paused at a time (the viewer's timeline), it ends at the
cursor: the snapshots hold the samples up to the cursor, so the plot shows what it showed live at that
moment, with the cursor as a vertical line at its right edge and each series' value there.
"""

from __future__ import annotations

from collections.abc import Sequence

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer._widgets._common import SERIES_COLORS, clock_text, latest_number
from dbglog.viewer._widgets._geometry import minmax_decimate, spread, window_slice
from dbglog.viewer.widget_api import Binding, Property, PropKind, SeriesSnapshot, ValueKind, Widget, tag_of

__all__ = ["CURSOR_COLOR", "CURSOR_MARGIN", "PLOT_MARGIN", "PlotWidget", "reading", "series_label"]

PLOT_MARGIN = 48
"""Pixels of the plot widget's width outside the plot area (y tick labels, padding): an upper bound."""
CURSOR_MARGIN = 0.06
"""Paused, the time axis runs on past the cursor by this fraction of the window, so its line shows."""
CURSOR_COLOR = (240, 176, 64, 255)
"""The cursor line: the timeline bar's PAUSED colour."""
TAG_GAP = 18
"""Pixels between two value tags at the cursor (close values are spread apart to stay readable)."""


def reading(value: float | None) -> str:
    """Return a series' value at the cursor as the legend and the value tag show it (6 significant digits)."""
    if value is None or not np.isfinite(value):
        return "\u2014"
    return f"{value:.6g}"


def series_label(binding: Binding) -> str:
    """Return a short legend label for a binding: the tag or topic, plus the field."""
    topic = tag_of(binding.topic) or binding.topic
    return f"{topic}.{binding.field}" if binding.field and binding.field != "data" else topic


def _plot_theme() -> int | str:
    """The plot's dark colours (bound per plot, not globally)."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvPlot):
        dpg.add_theme_color(dpg.mvPlotCol_PlotBg, (24, 26, 32, 255), category=dpg.mvThemeCat_Plots)
        # The frame around the plot area is the widget panel itself: leaving it transparent looks the same
        # and saves a fill of the whole plot (fill rate is what a software renderer pays for).
        dpg.add_theme_color(dpg.mvPlotCol_FrameBg, (0, 0, 0, 0), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_PlotBorder, (58, 63, 76, 255), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_color(dpg.mvPlotCol_LegendBg, (33, 36, 44, 200), category=dpg.mvThemeCat_Plots)
        dpg.add_theme_style(dpg.mvPlotStyleVar_PlotPadding, 4, 4, category=dpg.mvThemeCat_Plots)
    result: int | str = theme
    return result


class PlotWidget(Widget):
    """A time plot of up to six series; it never sends more points to the GPU than it has pixels."""

    type_name = "plot"
    label = "Plot"
    description = "Time plot of one or more series"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL})
    max_bindings = 6
    properties = (
        Property("window", PropKind.NUMBER, 10.0, minimum=0.5, maximum=3600, label="Time window (s)"),
        Property("scale", PropKind.CHOICE, "auto", choices=("auto", "fixed")),
        Property("y_min", PropKind.NUMBER, 0.0, minimum=-1e12, maximum=1e12, label="Fixed minimum"),
        Property("y_max", PropKind.NUMBER, 100.0, minimum=-1e12, maximum=1e12, label="Fixed maximum"),
        Property("legend", PropKind.BOOL, True, label="Show legend"),
    )
    default_size = (420, 240)
    min_size = (200, 140)

    def __init__(self, props: dict[str, float | str | bool] | None = None) -> None:
        super().__init__(props)
        self.paused = False
        self.points_drawn = 0
        """Points sent to the plot in the last update (for tests and the benchmark)."""
        self._limits: tuple[float, float] | None = None
        self._x_limits: tuple[float, float] | None = None
        self._info_text = ""
        self.cursor_values: list[float | None] = []
        """Paused: each series' value at the cursor (what the legend and the value tags show); else empty."""

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the plot, its axes and a pause toggle."""
        self._series: list[int | str] = []
        self._notes: list[int | str] = []
        self._labels: list[str] = []
        self._shown_labels: list[str] = []
        self._limits = None
        self._x_limits = None
        self._info_text = ""
        with dpg.group(parent=parent, horizontal=True):
            self._pause = dpg.add_checkbox(label="Pause", default_value=self.paused, callback=self._on_pause)
            self._info = dpg.add_text("", color=(138, 146, 158, 255))
        self.plot = dpg.add_plot(
            width=width,
            height=max(60, height - 28),
            parent=parent,
            no_menus=True,
            no_box_select=True,
            no_mouse_pos=True,
        )
        dpg.bind_item_theme(self.plot, _plot_theme())
        if self.prop("legend"):
            dpg.add_plot_legend(parent=self.plot, location=dpg.mvPlot_Location_NorthWest)
        self.x_axis = dpg.add_plot_axis(
            dpg.mvXAxis, parent=self.plot, label="", no_menus=True, no_highlight=True
        )
        self.y_axis = dpg.add_plot_axis(dpg.mvYAxis, parent=self.plot, no_menus=True, no_highlight=True)
        window = self.num("window")
        self._set_x_limits((-window, 0.0))
        if self.prop("scale") == "fixed":
            dpg.set_axis_limits(self.y_axis, self.num("y_min"), self.num("y_max"))
        # The time cursor while paused: a vertical line at x = 0 (the cursor time), out of the legend.
        self._cursor_line = dpg.add_inf_line_series([0.0], label="##cursor", parent=self.y_axis, show=False)
        with dpg.theme() as cursor_theme, dpg.theme_component(dpg.mvInfLineSeries):
            dpg.add_theme_color(dpg.mvPlotCol_Line, CURSOR_COLOR, category=dpg.mvThemeCat_Plots)
            dpg.add_theme_style(dpg.mvPlotStyleVar_LineWeight, 1.5, category=dpg.mvThemeCat_Plots)
        dpg.bind_item_theme(self._cursor_line, cursor_theme)

    def _set_x_limits(self, limits: tuple[float, float]) -> None:
        if limits != self._x_limits:
            dpg.set_axis_limits(self.x_axis, *limits)
            self._x_limits = limits

    def _on_pause(self, sender: int | str, value: bool) -> None:
        self.paused = bool(value)

    def set_paused(self, paused: bool) -> None:
        """Freeze or resume the plot (the checkbox does the same)."""
        self.paused = paused
        dpg.set_value(self._pause, paused)

    def _ensure_series(self, snapshots: Sequence[SeriesSnapshot]) -> None:
        labels = [series_label(s.binding) for s in snapshots]
        if labels == self._labels:
            return
        for tag in (*self._series, *self._notes):
            dpg.delete_item(tag)
        self._series, self._notes = [], []
        for i, label in enumerate(labels):
            tag = dpg.add_line_series([], [], label=label, parent=self.y_axis)
            with dpg.theme() as theme, dpg.theme_component(dpg.mvLineSeries):
                dpg.add_theme_color(
                    dpg.mvPlotCol_Line, SERIES_COLORS[i % len(SERIES_COLORS)], category=dpg.mvThemeCat_Plots
                )
                dpg.add_theme_style(dpg.mvPlotStyleVar_LineWeight, 2.0, category=dpg.mvThemeCat_Plots)
            dpg.bind_item_theme(tag, theme)
            self._series.append(tag)
            color = SERIES_COLORS[i % len(SERIES_COLORS)]
            # Paused: the value at the cursor, tagged on the line's end in the series' colour.
            note = dpg.add_plot_annotation(
                parent=self.plot, label="", offset=(-6, 0), color=color, clamped=True, show=False
            )
            self._notes.append(note)
        self._labels = labels
        self._shown_labels = list(labels)

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Redraw every series over the window ending at the newest sample (paused: at the cursor)."""
        if self.paused:
            return
        self._ensure_series(snapshots)
        window = self.num("window")
        at = self.paused_at
        if at is None:
            latest = [float(s.times[-1]) for s in snapshots if len(s.times)]
            ref = max(latest) if latest else now
        else:
            ref = at
        # Min-max decimation to the plot area's width: never more points than pixel columns.
        max_points = max(2, self.width - PLOT_MARGIN)
        lo, hi = np.inf, -np.inf
        drawn = 0
        for tag, snap in zip(self._series, snapshots, strict=True):
            n = min(len(snap.times), len(snap.values))
            times, values = (
                snap.times[-n:] if n else snap.times[:0],
                snap.values[-n:] if n else snap.values[:0],
            )
            sl = window_slice(times, ref, window)
            x, y = minmax_decimate(times[sl] - ref, values[sl], max_points)
            # Contiguous float64 arrays go to Dear PyGui through the buffer protocol, without lists.
            dpg.set_value(tag, [np.ascontiguousarray(x, np.float64), np.ascontiguousarray(y, np.float64)])
            drawn += len(x)
            finite = y[np.isfinite(y)]
            if len(finite):
                lo, hi = min(lo, float(finite.min())), max(hi, float(finite.max()))
        self.points_drawn = drawn
        limits: tuple[float, float] | None = None
        if self.prop("scale") == "fixed":
            limits = (self.num("y_min"), self.num("y_max"))
        elif np.isfinite(lo):
            pad = (hi - lo) * 0.08 or max(abs(hi) * 0.1, 0.5)
            limits = (lo - pad, hi + pad)
        if limits is not None and limits != self._limits:
            dpg.set_axis_limits(self.y_axis, *limits)
            self._limits = limits
        self._show_cursor(snapshots, at, window)
        info = f"{window:g} s window" if at is None else f"{window:g} s to {clock_text(at)}"
        if info != self._info_text:
            dpg.set_value(self._info, info)
            self._info_text = info

    def _show_cursor(self, snapshots: Sequence[SeriesSnapshot], at: float | None, window: float) -> None:
        """Paused: the cursor line, each series' value at it (legend and value tag); live: none of them."""
        paused = at is not None
        self._set_x_limits((-window, window * CURSOR_MARGIN) if paused else (-window, 0.0))
        dpg.configure_item(self._cursor_line, show=paused)
        self.cursor_values = [latest_number(s) for s in snapshots] if paused else []
        labels = list(self._labels)
        shown = [i for i, v in enumerate(self.cursor_values) if v is not None and np.isfinite(v)]
        shifts = self._tag_offsets([self.cursor_values[i] or 0.0 for i in shown])
        offsets = dict(zip(shown, shifts, strict=True))
        for i, note in enumerate(self._notes):
            if i in offsets:
                value = self.cursor_values[i] or 0.0
                dpg.configure_item(
                    note, show=True, label=reading(value), default_value=(0.0, value), offset=(-6, offsets[i])
                )
            else:
                dpg.configure_item(note, show=False)
            if paused:
                labels[i] = f"{labels[i]}  {reading(self.cursor_values[i])}"
        if labels != self._shown_labels:
            for tag, label in zip(self._series, labels, strict=True):
                dpg.configure_item(tag, label=label)
            self._shown_labels = labels

    def _tag_offsets(self, values: Sequence[float]) -> list[float]:
        """Vertical pixel offsets that keep the value tags of close values from covering each other."""
        if self._limits is None or len(values) < 2:
            return [0.0] * len(values)
        lo, hi = self._limits
        area_h = max(20.0, dpg.get_item_height(self.plot) or 100) - 34  # less the paddings and time labels
        ys = [(hi - v) / ((hi - lo) or 1.0) * area_h for v in values]
        return [new - old for new, old in zip(spread(ys, TAG_GAP), ys, strict=True)]
