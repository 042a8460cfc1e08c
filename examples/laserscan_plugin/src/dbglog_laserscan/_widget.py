"""The laser-scan widget: a polar view of ``sensor_msgs/msg/LaserScan`` ranges around the robot."""

from __future__ import annotations

import math
from collections.abc import Sequence

import dearpygui.dearpygui as dpg
import numpy as np

from dbglog.viewer.widget_api import (
    Color,
    Property,
    PropKind,
    SeriesSnapshot,
    Status,
    ValueKind,
    Widget,
)
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

__all__ = ["LaserScanWidget"]

_FACE: Color = (24, 27, 33, 255)
_EDGE: Color = (70, 77, 90, 255)
_RING: Color = (52, 57, 68, 255)
_DIM: Color = (138, 146, 158, 255)
_TEXT: Color = (222, 226, 232, 255)
_ROBOT: Color = (86, 166, 240, 255)
_STALE: Color = (120, 126, 136, 255)
_NONE: Color = (0, 0, 0, 0)
_READOUT_H = 20.0


class LaserScanWidget(Widget):
    """Polar plot of a LaserScan: points or a filled free-space fan, range rings, the robot in the middle.

    Bind the ``ranges[]`` field of the scan topic. The angles come from the properties (degrees) unless
    ``angle_min`` and ``angle_increment`` (or ``angle_max``) of the same topic are bound too, in which
    case the message's own values are used.
    """

    type_name = "laserscan"
    label = "Laser scan"
    description = "Polar view of sensor_msgs/msg/LaserScan ranges"
    accepts = frozenset({ValueKind.ARRAY, ValueKind.NUMBER})
    max_bindings = 4
    properties = (
        Property(
            "max_range",
            PropKind.NUMBER,
            10.0,
            label="Max range (m, 0 = auto)",
            minimum=0.0,
            maximum=10_000.0,
            help="radius of the outer ring; 0 fits the farthest reading",
        ),
        Property("min_range", PropKind.NUMBER, 0.0, label="Min range (m)", minimum=0.0, maximum=10_000.0),
        Property(
            "angle_min",
            PropKind.NUMBER,
            -180.0,
            label="First angle (deg)",
            minimum=-360.0,
            maximum=360.0,
            help="used unless the angle_min field is bound",
        ),
        Property(
            "angle_max",
            PropKind.NUMBER,
            180.0,
            label="Last angle (deg)",
            minimum=-360.0,
            maximum=360.0,
            help="used unless angle_increment or angle_max is bound",
        ),
        Property("style", PropKind.CHOICE, "both", choices=("points", "polygon", "both")),
        Property("forward", PropKind.CHOICE, "up", label="Robot forward", choices=("up", "right")),
        Property("rings", PropKind.NUMBER, 4.0, label="Range rings", minimum=0, maximum=10, integer=True),
        Property("point_size", PropKind.NUMBER, 2.0, label="Point size (px)", minimum=1, maximum=8),
        Property(
            "max_points", PropKind.NUMBER, 720.0, label="Max points", minimum=16, maximum=4096, integer=True
        ),
        Property("color", PropKind.COLOR, "#56d68cff", label="Point colour"),
        Property("show_robot", PropKind.BOOL, True, label="Robot marker"),
    )
    default_size = (300, 320)
    min_size = (140, 150)

    def __init__(self, props: dict[str, float | str | bool] | None = None) -> None:
        super().__init__(props)
        self.points_drawn = 0
        """Readings drawn in the last update (tests read this)."""
        self.display_range = self.num("max_range") or 10.0
        """Radius of the outer ring in metres."""
        self.closest: tuple[float, float] | None = None
        """(range m, angle rad) of the nearest drawn reading in the last update."""

    # -- building -----------------------------------------------------------------------------------

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build the drawlist: face and rings, the free-space polygon, the points image, robot and readout.

        The points are drawn into a texture the size of the body (one upload per scan, however many
        readings) and the free space is one polygon: a scan costs a few draw calls, not one per reading.
        """
        self._size = (max(1, width), max(1, height))
        self._pixels = np.zeros((self._size[1], self._size[0], 4), dtype=np.float32)
        self._textures = dpg.add_texture_registry()
        self._texture = dpg.add_dynamic_texture(
            self._size[0], self._size[1], self._pixels.ravel(), parent=self._textures
        )
        self.drawlist = dpg.add_drawlist(width, height, parent=parent)
        self._layout = lay = layout(width, height, top=_READOUT_H)
        # Bottom to top: the face, the free-space polygon, rings and labels, the points, robot and readout.
        back = dpg.add_draw_layer(parent=self.drawlist)
        dpg.draw_circle((lay.cx, lay.cy), lay.radius, color=_EDGE, fill=_FACE, thickness=1, parent=back)
        self._polygon = dpg.draw_polygon(
            [[lay.cx, lay.cy]] * 3, color=_NONE, fill=_NONE, show=False, parent=self.drawlist
        )
        self._grid = dpg.add_draw_layer(parent=self.drawlist)
        dpg.draw_image(self._texture, (0, 0), self._size, parent=self.drawlist)
        top = dpg.add_draw_layer(parent=self.drawlist)
        self._readout = dpg.draw_text((4, 2), "waiting for a scan", size=14, color=_DIM, parent=top)
        self._draw_grid()
        if self.prop("show_robot"):
            self._draw_robot(top)

    def destroy(self) -> None:
        """Delete the drawlist and the texture that holds the points."""
        super().destroy()
        if dpg.does_item_exist(self._textures):
            dpg.delete_item(self._textures)

    def _draw_grid(self) -> None:
        lay, layer = self._layout, self._grid
        dpg.delete_item(layer, children_only=True)
        scale = lay.radius / self.display_range
        for radius in ring_radii(self.display_range, int(self.num("rings"))):
            r_px = radius * scale
            if r_px < lay.radius - 0.5:
                dpg.draw_circle((lay.cx, lay.cy), r_px, color=_RING, thickness=1, parent=layer)
            label_x = lay.cx + r_px * math.cos(math.radians(45)) + 2
            label_y = lay.cy - r_px * math.sin(math.radians(45)) - 14
            dpg.draw_text((label_x, label_y), format_metres(radius), size=12, color=_DIM, parent=layer)
        dpg.draw_line((lay.cx - lay.radius, lay.cy), (lay.cx + lay.radius, lay.cy), color=_RING, parent=layer)
        dpg.draw_line((lay.cx, lay.cy - lay.radius), (lay.cx, lay.cy + lay.radius), color=_RING, parent=layer)

    def _draw_robot(self, layer: int | str) -> None:
        lay = self._layout
        size = max(6.0, min(12.0, lay.radius / 12))
        # A triangle pointing along +x (forward), placed with the same mapping as the scan points.
        xs = np.array([size * 1.4, -size * 0.8, -size * 0.8])
        ys = np.array([0.0, size * 0.8, -size * 0.8])
        sx, sy = to_screen(xs, ys, cx=lay.cx, cy=lay.cy, scale=1.0, forward=str(self.prop("forward")))
        points = [[float(a), float(b)] for a, b in zip(sx, sy, strict=True)]
        dpg.draw_triangle(*points, color=_ROBOT, fill=_ROBOT, parent=layer)

    # -- drawing ------------------------------------------------------------------------------------

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Draw the latest scan: readings as points and/or the free space as a polygon, plus a readout."""
        scan = read_scan(snapshots)
        self._pixels.fill(0.0)
        self.points_drawn = 0
        if scan is None or not len(scan.ranges):
            dpg.configure_item(self._polygon, show=False)
            dpg.set_value(self._texture, self._pixels.ravel())
            status = snapshots[0].status if snapshots else Status.WAITING
            text = "waiting for a scan" if status is not Status.ERROR else "no scan"
            dpg.configure_item(self._readout, text=text, color=_DIM)
            self.closest = None
            return
        angle_min, increment = resolve_angles(
            len(scan.ranges),
            scan.bound,
            angle_min_deg=self.num("angle_min"),
            angle_max_deg=self.num("angle_max"),
        )
        angles = scan_angles(len(scan.ranges), angle_min, increment)
        range_min = self.num("min_range")
        wanted = self.num("max_range") or auto_range(scan.ranges, range_min=range_min)
        if wanted != self.display_range:
            self.display_range = wanted
            self._draw_grid()
        ranges, angles = decimate_closest(scan.ranges, angles, int(self.num("max_points")))
        lay = self._layout
        scale = lay.radius / self.display_range
        forward = str(self.prop("forward"))
        color = self.color("color") if scan.status is not Status.STALE else _STALE
        style = str(self.prop("style"))
        with np.errstate(invalid="ignore"):
            hits = np.isfinite(ranges) & (ranges >= range_min)
        if style in ("polygon", "both"):
            x, y = to_xy(np.minimum(np.where(hits, ranges, 0.0), self.display_range), angles)
            sx, sy = to_screen(x, y, cx=lay.cx, cy=lay.cy, scale=scale, forward=forward)
            fill = _blend(_FACE, color, 0.22)
            outline = _blend(_FACE, color, 0.45)
            points = fan_polygon(sx, sy, hits, cx=lay.cx, cy=lay.cy)
            dpg.configure_item(self._polygon, points=points, fill=fill, color=outline, show=True)
        else:
            dpg.configure_item(self._polygon, show=False)
        mask = visible(ranges, range_min=range_min, range_max=self.display_range)
        if style in ("points", "both"):
            x, y = to_xy(ranges[mask], angles[mask])
            sx, sy = to_screen(x, y, cx=lay.cx, cy=lay.cy, scale=scale, forward=forward)
            rows, cols = raster_indices(
                sx, sy, width=self._size[0], height=self._size[1], size=round(self.num("point_size"))
            )
            self._pixels[rows, cols] = np.asarray(color, dtype=np.float32) / 255.0
            self.points_drawn = len(sx)
        dpg.set_value(self._texture, self._pixels.ravel())
        self.closest = closest_reading(ranges, angles, mask)
        if self.closest is None:
            text = f"{len(scan.ranges)} readings, none in range"
        else:
            dist, ang = self.closest
            shown = int(mask.sum())
            text = f"{shown} pts   closest {format_metres(round(dist, 2))} at {math.degrees(ang):+.0f}\u00b0"
        dpg.configure_item(self._readout, text=text, color=_TEXT)


def _blend(base: Color, top: Color, alpha: float) -> Color:
    """Mix `top` over `base` (opaque result, so a filled polygon shows no seams)."""
    mixed = [round(b + (t - b) * alpha) for b, t in zip(base[:3], top[:3], strict=True)]
    return (mixed[0], mixed[1], mixed[2], 255)
