"""Needle and bar widgets drawn with Dear PyGui draw items: Dial, Knob, Compass, Thermo.

The Knob may also bind to a node's number parameter (``/pid_node:kp``, `ParamLink`): its scale is the
descriptor's range, it shows the node's value (the one it had at the time cursor while paused), and a drag
round it sets the parameter: rate limited while dragged, the value let go at once.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import dearpygui.dearpygui as dpg

from dbglog.viewer._widgets._common import (
    DIM,
    ERROR,
    FACE,
    FACE_EDGE,
    HUB,
    NUMBER_TYPES,
    TEXT,
    TRACK,
    ParamLink,
    arc_points,
    draw_centered_text,
    draw_disc,
    draw_scale,
    format_value,
    knob_radii,
    knob_scale_radius,
    latest_number,
    nonfinite_text,
    param_bounds,
    param_kind_problem,
    scale_ticks,
    text_size,
    value_at_cursor_only,
)
from dbglog.viewer._widgets._geometry import (
    compass_label,
    format_tick,
    gauge_angle,
    knob_value_at,
    nice_ticks,
    normalize_heading,
    polar,
    thermo_fill,
)
from dbglog.viewer.widget_api import (
    DEFAULT_RATE_LIMIT_HZ,
    ParamState,
    Property,
    PropKind,
    SeriesSnapshot,
    Status,
    ValueKind,
    Widget,
    WidgetContext,
)

__all__ = ["CompassWidget", "DialWidget", "KnobWidget", "ThermoWidget"]

_RANGE = (
    Property("minimum", PropKind.NUMBER, 0.0, minimum=-1e12, maximum=1e12),
    Property("maximum", PropKind.NUMBER, 100.0, minimum=-1e12, maximum=1e12),
)
_UNIT = Property("unit", PropKind.TEXT, "", help="shown after the value")
_DECIMALS = Property("decimals", PropKind.NUMBER, 1.0, minimum=0, maximum=9, integer=True)


def _needle_points(cx: float, cy: float, r: float, angle: float) -> list[list[float]]:
    tip = polar(cx, cy, r, angle)
    left = polar(cx, cy, r * 0.07, angle - 90)
    right = polar(cx, cy, r * 0.07, angle + 90)
    tail = polar(cx, cy, r * 0.16, angle + 180)
    return [list(tip), list(left), list(tail), list(right), list(tip)]


class DialWidget(Widget):
    """A needle gauge over a 240 degree scale with round tick labels and a digital readout."""

    type_name = "dial"
    label = "Dial"
    description = "Needle gauge with a scale and a digital readout"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL})
    properties = (
        *_RANGE,
        _UNIT,
        _DECIMALS,
        Property("color", PropKind.COLOR, "#f66648ff", label="Needle colour"),
    )
    default_size = (220, 220)
    min_size = (120, 120)
    START, SWEEP = -120.0, 240.0

    def _layout(self, width: int, height: int) -> tuple[float, float, float]:
        r = max(20.0, min(width / 2 - 8, height / 2 - 8))
        cx = width / 2
        cy = height / 2
        return cx, cy, r

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Draw the face and scale once; the needle and readout are updated in place."""
        lo, hi = self.num("minimum"), self.num("maximum")
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        cx, cy, r = self._layout(width, height)
        self._geom = (cx, cy, r)
        dl = self.drawlist
        draw_disc(dl, (cx, cy), r + 4, FACE, outline=FACE_EDGE, thickness=2)
        dpg.draw_polyline(
            arc_points(cx, cy, r - 2, self.START, self.START + self.SWEEP),
            color=TRACK,
            thickness=4,
            parent=dl,
        )
        self._arc = dpg.draw_polyline([[cx, cy], [cx, cy]], color=self.color("color"), thickness=4, parent=dl)
        draw_scale(
            dl,
            cx,
            cy,
            r - 6,
            lo,
            hi,
            start=self.START,
            sweep=self.SWEEP,
            label_size=max(11, r / 7),
            max_ticks=scale_ticks(r - 6),
        )
        self._needle = dpg.draw_polygon(
            _needle_points(cx, cy, r - 14, self.START),
            color=self.color("color"),
            fill=self.color("color"),
            parent=dl,
        )
        draw_disc(dl, (cx, cy), max(4, r * 0.09), HUB)
        self._size = max(14.0, min(28.0, r / 3.2))
        self._readout = draw_centered_text("\u2014", cx, cy + r * 0.55, self._size, TEXT, dl)

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Turn the needle to the latest value (±inf: at an end stop; NaN: no needle, the readout says it)."""
        value = latest_number(snapshots[0] if snapshots else None)
        cx, cy, r = self._geom
        lo, hi = self.num("minimum"), self.num("maximum")
        known = value is not None and not math.isnan(value)
        angle = gauge_angle(
            value if known and value is not None else lo, lo, hi, start_deg=self.START, sweep_deg=self.SWEEP
        )
        dpg.configure_item(self._needle, points=_needle_points(cx, cy, r - 14, angle), show=known)
        dpg.configure_item(self._arc, points=arc_points(cx, cy, r - 2, self.START, angle), show=known)
        text = format_value(value, int(self.num("decimals")), str(self.prop("unit")))
        w, h = text_size(text, self._size)
        dpg.configure_item(self._readout, text=text, pos=(cx - w / 2, cy + r * 0.55 - h / 2))

    past_needed = value_at_cursor_only


class KnobWidget(DialWidget):
    """A rotary knob over 270 degrees: a filled value arc and a pointer on a round cap; bound to a node's
    number parameter, a drag round it sets the parameter."""

    type_name = "knob"
    label = "Knob"
    description = "Rotary knob with a value arc over 270 degrees; sets a node's parameter when bound to one"
    properties = (
        *_RANGE,
        _UNIT,
        _DECIMALS,
        Property("color", PropKind.COLOR, "#56a6f0ff", label="Arc colour"),
    )
    START, SWEEP = -135.0, 270.0
    parameters = True

    def __init__(self, props: dict[str, float | str | bool] | None = None) -> None:
        super().__init__(props)
        self.link = ParamLink(self)
        """The node's parameter the knob shows and sets, when bound to one."""
        self.dragged: float | None = None
        """The value the pointer points at while the knob is dragged (bound to a parameter), else None."""
        self._let_go: float | None = None
        self._left_was = False
        self._drawn: tuple[float, float] = (0.0, 0.0)
        self._sent: float | None = None
        self._note_shown: tuple[str, bool] | None = None

    def _bounds(self) -> tuple[float, float]:
        """The scale: a parameter's range (its descriptor's), else the minimum and maximum properties."""
        lo, hi = self.num("minimum"), self.num("maximum")
        if self.link.target:
            lo, hi, _step, _integer = param_bounds(self.link.state(), lo, hi)
        return lo, hi

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Draw the scale and cap once; the arc, pointer and readout are updated in place."""
        self.link.retarget()
        lo, hi = self._drawn = self._bounds()
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        dl = self.drawlist
        r = knob_scale_radius(width, height)
        cx, cy = width / 2, 8 + r
        self._geom = (cx, cy, r)
        label_size = max(11, r / 7)
        draw_scale(
            dl,
            cx,
            cy,
            r,
            lo,
            hi,
            start=self.START,
            sweep=self.SWEEP,
            label_size=label_size,
            max_ticks=scale_ticks(r),
        )
        self._arc_r, ring = knob_radii(r, lo, hi, label_size)
        dpg.draw_polyline(
            arc_points(cx, cy, self._arc_r, self.START, self.START + self.SWEEP),
            color=TRACK,
            thickness=6,
            parent=dl,
        )
        self._arc = dpg.draw_polyline([[cx, cy], [cx, cy]], color=self.color("color"), thickness=6, parent=dl)
        draw_disc(dl, (cx, cy), ring, (44, 48, 57, 255), outline=FACE_EDGE, thickness=2)
        draw_disc(dl, (cx, cy), ring * 0.82, (38, 42, 50, 255), outline=(60, 66, 78, 255))
        self._ring = ring
        self._needle = dpg.draw_line((cx, cy), (cx, cy), color=HUB, thickness=4, parent=dl)
        self._size = max(14.0, min(26.0, r / 3.4))
        self._readout = draw_centered_text("\u2014", cx, cy + r * 0.9, self._size, TEXT, dl)
        self._note: int | str = 0
        self._note_chars = max(8, int(width / 6.6))
        if self.link.target:  # the parameter's note (read-only, a rejection) in the top left corner
            self._note = dpg.draw_text((2, 0), "", size=12, color=DIM, parent=dl)
        self._note_shown = None

    def set_context(self, context: WidgetContext) -> None:
        """Take new bindings: a parameter bound (or unbound) redraws the scale."""
        super().set_context(context)
        if self.link.retarget():
            self.dragged = self._let_go = self._sent = None
            self.resize(self.width, self.height)

    def status(self) -> tuple[Status, str] | None:
        """Bound to a parameter: the parameter's status (asked, answered, the node's error)."""
        if not self.link.target:
            return None
        state = self.link.state()
        return state.status, state.reason

    def redraw_key(self) -> object:
        """Bound to a parameter: its state, and the pointer dragging the knob."""
        if not self.link.target:
            return None
        self._poll_pointer()
        return (self.link.state().version, self.dragged, self._let_go)

    def _poll_pointer(self) -> None:
        """A press on the knob starts a drag (when the parameter may be set); the pointer's direction from
        the centre is the value; letting go ends it."""
        if not dpg.does_item_exist(self.drawlist):
            return
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        pressed = left and not self._left_was
        self._left_was = left
        if not left:
            if self.dragged is not None:
                self._let_go, self.dragged = self.dragged, None
            return
        if not pressed and self.dragged is None:
            return
        (x0, y0) = dpg.get_item_rect_min(self.drawlist)
        mx, my = dpg.get_mouse_pos(local=False)
        cx, cy, r = self._geom
        dx, dy = float(mx) - (float(x0) + cx), float(my) - (float(y0) + cy)
        if pressed:
            state = self.link.state()
            hovered = bool(dpg.is_item_hovered(self.drawlist))
            if not (hovered and math.hypot(dx, dy) <= r + 6 and state.editable):
                return
        lo, hi = self._drawn
        value = knob_value_at(dx, dy, lo, hi, start_deg=self.START, sweep_deg=self.SWEEP)
        if value is not None:
            self.dragged = value
        elif pressed:
            self.dragged = self.link.state().number

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Turn the pointer and grow the arc to the latest value (±inf: at the end stop; NaN: neither); bound
        to a parameter, send the dragged value and show the node's."""
        if self.link.target:
            self._update_parameter()
            return
        self._show(latest_number(snapshots[0] if snapshots else None))

    def _update_parameter(self) -> None:
        state = self.link.state()
        if self._bounds() != self._drawn:  # the descriptor's range arrived: a new scale
            self.resize(self.width, self.height)
        problem = param_kind_problem(state, NUMBER_TYPES, "Knob", "numbers")
        editable = state.editable and not problem
        shown = state.number
        if self._let_go is not None:
            last, self._let_go, self._sent = self._let_go, None, None
            if editable:
                self.link.set(last, final=True, rate_hz=DEFAULT_RATE_LIMIT_HZ)
                shown = self._snapped(state, last)
        elif self.dragged is not None and editable:
            if self.dragged != self._sent:
                self._sent = self.dragged
                self.link.set(self.dragged, final=False, rate_hz=DEFAULT_RATE_LIMIT_HZ)
            shown = self._snapped(state, self.dragged)
        self._show(shown)
        note, bad = (problem, True) if problem else (state.note, state.problem)
        if len(note) > self._note_chars:
            note = note[: self._note_chars - 1] + "\u2026"
        if self._note and (note, bad) != self._note_shown:
            self._note_shown = (note, bad)
            dpg.configure_item(self._note, text=note, color=ERROR if bad else DIM)

    @staticmethod
    def _snapped(state: ParamState, value: float) -> float:
        """`value` on the parameter's grid, as the node would take it (what the readout shows)."""
        try:
            typed = state.typed(value).value
        except ValueError:
            return value
        return float(typed) if isinstance(typed, int | float) else value

    def _show(self, value: float | None) -> None:
        cx, cy, r = self._geom
        lo, hi = self._drawn
        known = value is not None and not math.isnan(value)
        angle = gauge_angle(
            value if known and value is not None else lo, lo, hi, start_deg=self.START, sweep_deg=self.SWEEP
        )
        ring = self._ring
        dpg.configure_item(self._arc, points=arc_points(cx, cy, self._arc_r, self.START, angle), show=known)
        dpg.configure_item(
            self._needle,
            p1=polar(cx, cy, ring * 0.3, angle),
            p2=polar(cx, cy, ring * 0.78, angle),
            show=known,
        )
        text = format_value(value, int(self.num("decimals")), str(self.prop("unit")))
        w, h = text_size(text, self._size)
        dpg.configure_item(self._readout, text=text, pos=(cx - w / 2, cy + r * 0.9 - h / 2))


class CompassWidget(Widget):
    """A 360 degree compass rose with a heading needle and a numeric heading."""

    type_name = "compass"
    label = "Compass"
    description = "Heading on a 360 degree compass rose"
    accepts = frozenset({ValueKind.NUMBER})
    properties = (
        Property("units", PropKind.CHOICE, "degrees", choices=("degrees", "radians")),
        Property("offset", PropKind.NUMBER, 0.0, minimum=-360, maximum=360, label="Offset (deg)"),
        Property("color", PropKind.COLOR, "#f66648ff", label="Needle colour"),
    )
    default_size = (220, 240)
    min_size = (120, 130)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Draw the rose once; the needle and heading are updated in place."""
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        dl = self.drawlist
        r = max(20.0, min(width / 2 - 8, (height - 34) / 2))
        cx, cy = width / 2, 6 + r
        self._geom = (cx, cy, r)
        draw_disc(dl, (cx, cy), r, FACE, outline=FACE_EDGE, thickness=2)
        for deg in range(0, 360, 10):
            major = deg % 30 == 0
            p1 = polar(cx, cy, r - 3, deg)
            p2 = polar(cx, cy, r - (12 if major else 7), deg)
            dpg.draw_line(p1, p2, color=TEXT if major else DIM, thickness=2 if major else 1, parent=dl)
        size = max(11.0, r / 6.5)
        for deg, label in ((0, "N"), (90, "E"), (180, "S"), (270, "W")):
            lx, ly = polar(cx, cy, r - 14 - size * 0.7, deg)
            draw_centered_text(label, lx, ly, size * 1.15, (246, 102, 72, 255) if deg == 0 else TEXT, dl)
        for deg in (30, 60, 120, 150, 210, 240, 300, 330):
            lx, ly = polar(cx, cy, r - 14 - size * 0.7, deg)
            draw_centered_text(str(deg), lx, ly, size * 0.8, DIM, dl)
        color = self.color("color")
        self._north = dpg.draw_polygon(self._half(0, 1), color=color, fill=color, parent=dl)
        self._south = dpg.draw_polygon(self._half(0, -1), color=HUB, fill=(120, 126, 136, 255), parent=dl)
        draw_disc(dl, (cx, cy), max(3, r * 0.06), HUB)
        self._size = max(14.0, min(24.0, r / 3.5))
        self._readout = draw_centered_text("\u2014", cx, height - self._size / 2 - 2, self._size, TEXT, dl)

    def _half(self, heading: float, sign: int) -> list[list[float]]:
        cx, cy, r = self._geom
        length = (r - 30) if sign > 0 else (r - 30) * 0.8
        tip = polar(cx, cy, length, heading if sign > 0 else heading + 180)
        left = polar(cx, cy, r * 0.08, heading - 90)
        right = polar(cx, cy, r * 0.08, heading + 90)
        return [list(tip), list(left), list(right), list(tip)]

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Point the needle to the latest heading (a heading that is not a finite number: no needle, the
        readout says ``NaN`` or ``+inf``; no value, at the cursor say: no needle, a dash)."""
        value = latest_number(snapshots[0] if snapshots else None)
        odd = "\u2014" if value is None else nonfinite_text(value)  # no value (yet, at the cursor): a dash
        heading = (
            0.0
            if value is None
            else normalize_heading(
                value, radians=self.prop("units") == "radians", offset_deg=self.num("offset")
            )
        )
        dpg.configure_item(self._north, points=self._half(heading, 1), show=odd is None)
        dpg.configure_item(self._south, points=self._half(heading, -1), show=odd is None)
        text = odd if odd is not None else f"{heading:5.1f}\u00b0 {compass_label(heading)}"
        w, _h = text_size(text, self._size)
        cx, _, _ = self._geom
        dpg.configure_item(self._readout, text=text, pos=(cx - w / 2, self.height - self._size - 2))

    past_needed = value_at_cursor_only


class ThermoWidget(Widget):
    """A vertical thermometer bar with a bulb, a labelled scale and a readout."""

    type_name = "thermo"
    label = "Thermo"
    description = "Thermometer bar with a scale"
    accepts = frozenset({ValueKind.NUMBER, ValueKind.BOOL})
    properties = (
        *_RANGE,
        _UNIT,
        _DECIMALS,
        Property("color", PropKind.COLOR, "#ec606eff", label="Fill colour"),
    )
    default_size = (140, 260)
    min_size = (100, 140)

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Draw the tube and scale once; the fill and readout are updated in place."""
        lo, hi = self.num("minimum"), self.num("maximum")
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        dl = self.drawlist
        size = 13.0
        tube_w = max(12.0, min(22.0, width / 7))
        bulb_r = tube_w * 0.95
        x0 = width * 0.42 - tube_w / 2
        top = 10.0
        bottom = height - 30 - bulb_r * 2
        self._geom = (x0, tube_w, top, bottom, bulb_r)
        color = self.color("color")
        dpg.draw_rectangle(
            (x0 - 3, top - 3),
            (x0 + tube_w + 3, bottom + bulb_r),
            color=FACE_EDGE,
            fill=FACE,
            rounding=tube_w / 2 + 3,
            thickness=2,
            parent=dl,
        )
        draw_disc(dl, (x0 + tube_w / 2, bottom + bulb_r), bulb_r + 3, FACE, outline=FACE_EDGE, thickness=2)
        self._fill = dpg.draw_rectangle(
            (x0, bottom),
            (x0 + tube_w, bottom + bulb_r),
            color=color,
            fill=color,
            rounding=tube_w / 2,
            parent=dl,
        )
        draw_disc(dl, (x0 + tube_w / 2, bottom + bulb_r), bulb_r - 1, color)
        span = hi - lo
        for t in nice_ticks(min(lo, hi), max(lo, hi), 6) if span else []:
            y = bottom - (bottom - top) * (t - lo) / span
            dpg.draw_line((x0 + tube_w + 5, y), (x0 + tube_w + 13, y), color=TEXT, thickness=2, parent=dl)
            dpg.draw_text((x0 + tube_w + 17, y - size / 2), format_tick(t), size=size, color=DIM, parent=dl)
        self._size = 16.0
        self._readout = draw_centered_text("\u2014", width / 2, height - 10, self._size, TEXT, dl)

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Fill the tube to the latest value (+inf: full, -inf and NaN: empty; the readout says which)."""
        value = latest_number(snapshots[0] if snapshots else None)
        x0, tube_w, top, bottom, bulb_r = self._geom
        lo, hi = self.num("minimum"), self.num("maximum")
        fill = thermo_fill(value if value is not None else lo, lo, hi, bottom - top)
        dpg.configure_item(self._fill, pmin=(x0, bottom - fill), pmax=(x0 + tube_w, bottom + bulb_r))
        text = format_value(value, int(self.num("decimals")), str(self.prop("unit")))
        w, h = text_size(text, self._size)
        dpg.configure_item(self._readout, text=text, pos=(self.width / 2 - w / 2, self.height - 10 - h / 2))

    past_needed = value_at_cursor_only
