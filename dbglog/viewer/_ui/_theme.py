"""The viewer's look: a dark theme, a readable font, and the status colours."""

from __future__ import annotations

from pathlib import Path

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Status
from dbglog.viewer.widget_api import Color

__all__ = [
    "STATUS_COLORS",
    "apply_theme",
    "frame_theme",
    "load_font",
    "main_window_theme",
    "unfilled_child_theme",
]

STATUS_COLORS: dict[Status, Color] = {
    Status.WAITING: (240, 160, 40, 255),
    Status.LIVE: (60, 200, 100, 255),
    Status.STALE: (130, 136, 146, 255),
    Status.ERROR: (232, 72, 72, 255),
}
"""Waiting orange, live green, stale grey, error red."""

BG: Color = (19, 21, 26, 255)
CANVAS: Color = (24, 26, 32, 255)
PANEL: Color = (33, 36, 44, 255)
HEADER: Color = (42, 46, 56, 255)
BORDER: Color = (58, 63, 76, 255)
TEXT: Color = (222, 226, 232, 255)
DIM: Color = (138, 146, 158, 255)
ACCENT: Color = (86, 166, 240, 255)
GRID: Color = (40, 44, 53, 255)
NO_FILL: Color = (0, 0, 0, 0)
"""A fill Dear ImGui skips altogether (fully transparent)."""
FRAME_ROUNDING = 6
"""Corner radius of a widget frame in pixels."""
SCROLLBAR = 14
"""Width of a scrollbar in pixels (the canvas keeps its grid clear of them)."""

_FONT_CANDIDATES = (
    "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf",
    "/usr/share/fonts/TTF/DejaVuSans.ttf",
    "/usr/share/fonts/dejavu/DejaVuSans.ttf",
    "/System/Library/Fonts/Supplemental/Arial.ttf",
    "C:/Windows/Fonts/segoeui.ttf",
)


def load_font(size: int = 15) -> int | str | None:
    """Load a proportional TrueType font if the system has one (else Dear PyGui's built-in font is used)."""
    for candidate in _FONT_CANDIDATES:
        if Path(candidate).is_file():
            with dpg.font_registry():
                font = dpg.add_font(candidate, size)  # Dear PyGui 2 loads glyph ranges on demand
                result: int | str = font
                return result
    return None


def apply_theme() -> None:
    """Bind the global dark theme."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvAll):
        for col, value in (
            (dpg.mvThemeCol_WindowBg, BG),
            (dpg.mvThemeCol_ChildBg, CANVAS),
            (dpg.mvThemeCol_PopupBg, PANEL),
            (dpg.mvThemeCol_Border, BORDER),
            (dpg.mvThemeCol_Text, TEXT),
            (dpg.mvThemeCol_TextDisabled, DIM),
            (dpg.mvThemeCol_FrameBg, (44, 48, 58, 255)),
            (dpg.mvThemeCol_FrameBgHovered, (54, 60, 72, 255)),
            (dpg.mvThemeCol_FrameBgActive, (62, 70, 86, 255)),
            (dpg.mvThemeCol_Button, (48, 53, 64, 255)),
            (dpg.mvThemeCol_ButtonHovered, (62, 92, 130, 255)),
            (dpg.mvThemeCol_ButtonActive, (70, 120, 180, 255)),
            (dpg.mvThemeCol_Header, (52, 58, 70, 255)),
            (dpg.mvThemeCol_HeaderHovered, (62, 92, 130, 255)),
            (dpg.mvThemeCol_HeaderActive, (70, 120, 180, 255)),
            (dpg.mvThemeCol_MenuBarBg, (28, 30, 37, 255)),
            (dpg.mvThemeCol_TitleBg, (28, 30, 37, 255)),
            (dpg.mvThemeCol_TitleBgActive, (40, 56, 80, 255)),
            (dpg.mvThemeCol_CheckMark, ACCENT),
            (dpg.mvThemeCol_SliderGrab, ACCENT),
            (dpg.mvThemeCol_SliderGrabActive, (120, 190, 250, 255)),
            (dpg.mvThemeCol_Separator, BORDER),
            (dpg.mvThemeCol_ScrollbarBg, (24, 26, 32, 255)),
            (dpg.mvThemeCol_ScrollbarGrab, (58, 63, 76, 255)),
            (dpg.mvThemeCol_DragDropTarget, ACCENT),
            (dpg.mvThemeCol_ModalWindowDimBg, (0, 0, 0, 110)),
            (dpg.mvThemeCol_TextSelectedBg, (62, 92, 130, 255)),
        ):
            dpg.add_theme_color(col, value, category=dpg.mvThemeCat_Core)
        for var, a, b in (
            (dpg.mvStyleVar_WindowPadding, 10, 10),
            (dpg.mvStyleVar_FramePadding, 8, 5),
            (dpg.mvStyleVar_ItemSpacing, 8, 7),
            (dpg.mvStyleVar_ItemInnerSpacing, 6, 4),
        ):
            dpg.add_theme_style(var, a, b, category=dpg.mvThemeCat_Core)
        for var, v in (
            (dpg.mvStyleVar_FrameRounding, 4),
            (dpg.mvStyleVar_ChildRounding, 6),
            (dpg.mvStyleVar_WindowRounding, 6),
            (dpg.mvStyleVar_PopupRounding, 4),
            (dpg.mvStyleVar_GrabRounding, 4),
            (dpg.mvStyleVar_ScrollbarRounding, 4),
            (dpg.mvStyleVar_ScrollbarSize, SCROLLBAR),
            (dpg.mvStyleVar_ChildBorderSize, 1),
        ):
            dpg.add_theme_style(var, v, category=dpg.mvThemeCat_Core)
        # Plot colours are bound per plot (the widget does it): an mvPlot component in the global
        # theme makes Dear PyGui 2.3 crash when a later context loads a font.
    dpg.bind_theme(theme)


def main_window_theme() -> int | str:
    """Return the main window's theme: no border and square corners, as it fills the viewport."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvWindowAppItem):
        dpg.add_theme_style(dpg.mvStyleVar_WindowBorderSize, 0, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_WindowRounding, 0, category=dpg.mvThemeCat_Core)
    result: int | str = theme
    return result


def unfilled_child_theme() -> int | str:
    """Return a theme for the canvas: no fill of its own (the viewport is cleared to its colour)."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvChildWindow):
        dpg.add_theme_color(dpg.mvThemeCol_ChildBg, NO_FILL, category=dpg.mvThemeCat_Core)
    result: int | str = theme
    return result


def frame_theme(*, filled: bool = True) -> int | str:
    """Return the theme of a widget frame on the canvas: a raised panel with no inner padding.

    Unfilled, the frame paints no background: the canvas is then cleared to the panel colour
    (`CanvasPaint`), which costs a software renderer nothing, instead of every panel shading its pixels.
    """
    with dpg.theme() as theme, dpg.theme_component(dpg.mvChildWindow):
        fill = PANEL if filled else NO_FILL
        dpg.add_theme_color(dpg.mvThemeCol_ChildBg, fill, category=dpg.mvThemeCat_Core)
        dpg.add_theme_color(dpg.mvThemeCol_Border, BORDER, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_WindowPadding, 0, 0, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_ItemSpacing, 6, 4, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_ChildRounding, FRAME_ROUNDING, category=dpg.mvThemeCat_Core)
    result: int | str = theme
    return result


def selected_frame_theme(*, filled: bool = True) -> int | str:
    """Return the frame theme of the selected widget (accent border), filled or not (see `frame_theme`)."""
    with dpg.theme() as theme, dpg.theme_component(dpg.mvChildWindow):
        fill = PANEL if filled else NO_FILL
        dpg.add_theme_color(dpg.mvThemeCol_ChildBg, fill, category=dpg.mvThemeCat_Core)
        dpg.add_theme_color(dpg.mvThemeCol_Border, ACCENT, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_WindowPadding, 0, 0, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_ItemSpacing, 6, 4, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_ChildRounding, FRAME_ROUNDING, category=dpg.mvThemeCat_Core)
        dpg.add_theme_style(dpg.mvStyleVar_ChildBorderSize, 2, category=dpg.mvThemeCat_Core)
    result: int | str = theme
    return result
