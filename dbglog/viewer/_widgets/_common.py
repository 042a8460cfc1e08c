"""Shared look and small helpers of the built-in widgets: the palette, value extraction, gauge scales, and a
widget's binding to a node's parameter (`ParamLink`)."""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer._widgets._geometry import arc_step, format_tick, nice_ticks, polar
from dbglog.viewer.widget_api import (
    DEFAULT_RATE_LIMIT_HZ,
    Color,
    ParamState,
    ParamType,
    SeriesSnapshot,
    Status,
    Widget,
)

TEXT: Color = (222, 226, 232, 255)
DIM: Color = (138, 146, 158, 255)
FACE: Color = (30, 33, 40, 255)
FACE_EDGE: Color = (70, 77, 90, 255)
TRACK: Color = (52, 57, 68, 255)
ACCENT: Color = (86, 166, 240, 255)
NEEDLE: Color = (246, 102, 72, 255)
HUB: Color = (200, 205, 212, 255)
ERROR: Color = (236, 96, 110, 255)
"""A problem written in a widget's body (a rejected set, a value of the wrong type)."""

SERIES_COLORS: tuple[Color, ...] = (
    (86, 166, 240, 255),
    (246, 160, 60, 255),
    (110, 210, 120, 255),
    (236, 96, 110, 255),
    (180, 130, 240, 255),
    (90, 210, 210, 255),
    (232, 210, 90, 255),
    (240, 130, 200, 255),
    (238, 202, 184, 255),
    (40, 238, 40, 255),
    (238, 58, 238, 255),
    (184, 238, 40, 255),
    (130, 148, 94, 255),
    (130, 148, 166, 255),
    (238, 94, 40, 255),
    (202, 238, 184, 255),
)
"""A plot's series colours, 16 of them: each second eight picked as far (CIELAB) from the others as the
first eight are from each other, light enough to read on the plot's dark background."""


def latest_number(snap: SeriesSnapshot | None) -> float | None:
    """Return the snapshot's latest value as a float (bools as 0/1), or None when it has none."""
    if snap is None:
        return None
    last = snap.last
    if isinstance(last, bool):
        return 1.0 if last else 0.0
    if isinstance(last, int | float):
        return float(last)
    if isinstance(last, str):
        try:
            return float(last)
        except ValueError:
            return None
    if len(snap.values):
        return float(snap.values[-1])
    return None


def clock_text(t: float) -> str:
    """Return a source time (epoch seconds) as the local clock with milliseconds: ``12:03:04.512``."""
    seconds, millis = divmod(round(t * 1000), 1000)
    return time.strftime("%H:%M:%S", time.localtime(seconds)) + f".{millis:03d}"


def nonfinite_text(value: float) -> str | None:
    """Return how a number that is not finite reads everywhere in the viewer: ``NaN``, ``+inf``, ``-inf``;
    None for a finite one."""
    if math.isnan(value):
        return "NaN"
    if math.isinf(value):
        return "+inf" if value > 0 else "-inf"
    return None


def format_value(value: float | None, decimals: int, unit: str = "") -> str:
    """Format a gauge readout: fixed decimals, the unit after a space; a dash when there is no value,
    ``NaN`` / ``+inf`` / ``-inf`` (without the unit) for a value that is not a finite number."""
    if value is None:
        return "\u2014"
    odd = nonfinite_text(value)
    if odd is not None:
        return odd
    text = f"{value:.{max(0, decimals)}f}"
    return f"{text} {unit}".rstrip()


def text_size(text: str, size: float) -> tuple[float, float]:
    """Approximate the pixel size of `text` drawn at font `size` (proportional font, no display needed)."""
    return (len(text) * size * 0.55, size)


def fit_line(text: str, width: float, measure: Callable[[str], float]) -> str:
    """Return the first line of `text`, cut to `width` pixels (by `measure`) and ended with an ellipsis."""
    line = text.split("\n", 1)[0]
    if measure(line) <= width:
        return line
    lo, hi = 0, len(line)  # the longest prefix that fits with the ellipsis: binary search
    while lo < hi:
        mid = (lo + hi + 1) // 2
        if measure(line[:mid].rstrip() + "\u2026") <= width:
            lo = mid
        else:
            hi = mid - 1
    return line[:lo].rstrip() + "\u2026"


def draw_centered_text(
    text: str, x: float, y: float, size: float, color: Color, parent: int | str
) -> int | str:
    """Draw text centred on (x, y) and return the item."""
    w, h = text_size(text, size)
    item: int | str = dpg.draw_text((x - w / 2, y - h / 2), text, size=size, color=color, parent=parent)
    return item


_DISC_MIN_RADIUS = 10.0
"""Below this radius a plain circle is as cheap as the textured quad."""


def disc_texture(diameter: float) -> int | str:
    """Return a white, anti-aliased disc texture at least `diameter` pixels wide (made once per context).

    Sizes are powers of two from 32 to 1024, so a disc is never drawn more than twice smaller than its
    texture (bilinear filtering keeps the edge smooth).
    """
    size = 32
    while size < diameter and size < 1024:
        size *= 2
    tag = f"dbglog-disc-{size}"
    if not dpg.does_item_exist(tag):
        centre = size / 2
        yy, xx = np.mgrid[0:size, 0:size].astype(np.float32) + 0.5
        # Radius centre - 1 leaves a clear texel at the border; coverage gives a one-texel soft edge.
        coverage = np.clip(centre - 1 - np.hypot(xx - centre, yy - centre) + 0.5, 0.0, 1.0)
        rgba = np.ones((size, size, 4), dtype=np.float32)
        rgba[..., 3] = coverage
        with dpg.texture_registry():
            dpg.add_static_texture(size, size, rgba.ravel(), tag=tag)
    return tag


def draw_disc(
    parent: int | str,
    center: tuple[float, float],
    radius: float,
    fill: Color,
    *,
    outline: Color | None = None,
    thickness: float = 1.0,
) -> int | str:
    """Draw a filled circle (and an optional outline) and return the fill item; recolour it with `color=`.

    The fill is one textured quad, not a triangle fan: a software renderer (Mesa llvmpipe) draws a large
    fan several times slower than a quad of the same size. Small discs stay plain circles.
    """
    cx, cy = center
    item: int | str
    if radius < _DISC_MIN_RADIUS:
        item = dpg.draw_circle(center, radius, color=fill, fill=fill, parent=parent)
    else:
        texture = disc_texture(2 * radius)
        size = dpg.get_item_width(texture) or 32
        half = radius * (size / 2) / (size / 2 - 1)  # the texture's disc stops a texel short of its edge
        item = dpg.draw_image(
            texture, (cx - half, cy - half), (cx + half, cy + half), color=fill, parent=parent
        )
    if outline is not None:
        dpg.draw_circle(center, radius, color=outline, thickness=thickness, parent=parent)
    return item


def set_disc_color(item: int | str, color: Color) -> None:
    """Recolour a disc made by `draw_disc` (a textured quad or, when small, a plain circle)."""
    if dpg.get_item_type(item).endswith("mvDrawImage"):
        dpg.configure_item(item, color=color)
    else:
        dpg.configure_item(item, color=color, fill=color)


def value_at_cursor_only(self: object, at: float) -> float | None:
    """A widget's ``past_needed``: paused, it shows the value at the cursor, so no samples before it."""
    return 0.0


def arc_points(
    cx: float, cy: float, r: float, start: float, end: float, step: float | None = None
) -> list[list[float]]:
    """Return polyline points of an arc from angle `start` to `end` degrees (0 = up, clockwise), `step`
    degrees apart at most (default: chords within 0.1 px of the circle, `arc_step`; a software renderer
    pays for every segment of a thick line)."""
    step = arc_step(r) if step is None else step
    n = max(2, math.ceil(abs(end - start) / step) + 1)
    return [list(polar(cx, cy, r, start + (end - start) * i / (n - 1))) for i in range(n)]


def draw_scale(
    parent: int | str,
    cx: float,
    cy: float,
    r: float,
    lo: float,
    hi: float,
    *,
    start: float,
    sweep: float,
    label_size: float,
    max_ticks: int = 6,
) -> None:
    """Draw a gauge scale: major ticks with labels on round values, minor ticks between."""
    if hi == lo:
        return
    ticks: Sequence[float] = nice_ticks(min(lo, hi), max(lo, hi), max_ticks)
    span = hi - lo
    minor_step = (ticks[1] - ticks[0]) / 5 if len(ticks) > 1 else 0.0
    if minor_step > 0:
        k = math.ceil(min(lo, hi) / minor_step)
        while k * minor_step <= max(lo, hi) + 1e-9 * abs(span):
            angle = start + sweep * (k * minor_step - lo) / span
            p1 = polar(cx, cy, r, angle)
            p2 = polar(cx, cy, r - 5, angle)
            dpg.draw_line(p1, p2, color=DIM, thickness=1, parent=parent)
            k += 1
    for t in ticks:
        angle = start + sweep * (t - lo) / span
        p1 = polar(cx, cy, r, angle)
        p2 = polar(cx, cy, r - 10, angle)
        dpg.draw_line(p1, p2, color=TEXT, thickness=2, parent=parent)
        lx, ly = polar(cx, cy, r - 10 - label_size * 0.95, angle)
        draw_centered_text(format_tick(t), lx, ly, label_size, DIM, parent)


def scale_label_inner(r: float, lo: float, hi: float, label_size: float, max_ticks: int = 6) -> float:
    """Return the radius inside which `draw_scale`'s labels leave a gauge's face free (pure: no display).

    A label is centred `r - 10 - 0.95 * label_size` from the centre; the widest one, lying sideways at
    the 9 or 3 o'clock position, reaches in by half its width.
    """
    if hi == lo:
        return r - 10
    ticks = nice_ticks(min(lo, hi), max(lo, hi), max_ticks)
    half = max((text_size(format_tick(t), label_size)[0] / 2 for t in ticks), default=0.0)
    return r - 10 - label_size * 0.95 - max(half, label_size / 2)


def knob_scale_radius(width: float, height: float) -> float:
    """Return the radius of a knob's scale in a body of `width` x `height` pixels, centred 8 px below its
    top: the 270 degree scale and, 0.9 radius below the centre, the readout (at most 26 px high) fit."""
    scale_fits = (height - 34) / (1 + math.cos(math.radians(45))) - 4
    readout_fits = (height - 8 - 13 - 4) / 1.9
    return max(20.0, min(width / 2 - 8, scale_fits, readout_fits))


def scale_ticks(r: float) -> int:
    """Return how many labelled ticks a gauge scale of radius `r` gets at most: 6, or 3 on a small one
    (where six labels would touch each other)."""
    return 6 if r >= 50 else 3


def knob_radii(r: float, lo: float, hi: float, label_size: float) -> tuple[float, float]:
    """Return a knob's value-arc radius and its cap's radius inside a scale of radius `r`: the arc (6 px
    thick) stays 2 px inside the scale's labels, the cap 8 px inside the arc (half the scale at most)."""
    arc = min(r * 0.5 + 8, scale_label_inner(r, lo, hi, label_size, scale_ticks(r)) - 5)
    cap = max(6.0, min(r * 0.5, arc - 8))
    return max(arc, cap + 8), cap


def draw_title(parent: int | str, text: str, x: float, y: float, size: float) -> None:
    """Draw a small dim caption (used for units and labels)."""
    if text:
        draw_centered_text(text, x, y, size, DIM, parent)


class ParamLink:
    """A widget's binding to a node's parameter (``/pid_node:kp``; `Widget.parameters`): which one, what
    the viewer says of it now (`WidgetHost.parameter`), and the sets it sends (`WidgetHost.set_parameter`).

    Args:
        widget: the widget; its context's first binding to a parameter is the target.
    """

    def __init__(self, widget: Widget) -> None:
        self.widget = widget
        self.target = ""
        """The parameter, as bound (``/pid_node:kp``), "" when the widget is bound to a topic (or nothing)."""

    def retarget(self) -> bool:
        """Take the target from the widget's context (at mount, and when its bindings change); True when it
        changed."""
        target = next((b.topic for b in self.widget.context.targets if b.parameter is not None), "")
        changed = target != self.target
        self.target = target
        return changed

    def state(self) -> ParamState:
        """What the viewer says of the parameter now (cheap: asked every frame)."""
        host = self.widget.context.host
        if host is None:
            return ParamState(self.target, Status.ERROR, "mounted outside a viewer: no parameters")
        return host.parameter(self.target)

    def set(self, value: object, *, final: bool, rate_hz: float = DEFAULT_RATE_LIMIT_HZ) -> None:
        """Send a value (rate limited while dragged; at once when `final`: released, clicked, Enter)."""
        host = self.widget.context.host
        if host is not None and self.target:
            host.set_parameter(self.target, value, final=final, rate_hz=rate_hz)


NUMBER_TYPES = (ParamType.INTEGER, ParamType.DOUBLE)
"""The parameter types a slider or a knob sets."""


def param_bounds(state: ParamState, low: float, high: float) -> tuple[float, float, float, bool]:
    """The (low, high, step, integer) a slider or knob shows for a parameter: its descriptor's range and step,
    else `low` to `high` (the widget's own minimum and maximum) with no step."""
    span = state.range
    integer = state.type is ParamType.INTEGER
    if span is not None:
        lo, hi = sorted((float(span.low), float(span.high)))
        return lo, hi, float(span.step), integer
    return min(low, high), max(low, high), 1.0 if integer else 0.0, integer


def param_kind_problem(state: ParamState, wanted: tuple[ParamType, ...], widget: str, use: str) -> str:
    """Why a widget cannot set a parameter of this type (``a Slider sets numbers; frame is a string: use a
    Text field``), "" when it can or the type is not known yet."""
    ptype = state.type
    if ptype is ParamType.NOT_SET or ptype in wanted:
        return ""
    return f"a {widget} sets {use}; {state.name} is {ptype.article}: use a Text field"
