"""The window's frame in Dear PyGui: the context with its font and theme, the viewport, the one window that
holds the menu bar, the body and the bottom bars, and the input handlers. The app fills it in."""

from __future__ import annotations

from collections.abc import Callable, Iterator
from contextlib import contextmanager

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui import _theme as theme

__all__ = ["install_input", "main_window", "open_viewport"]


def open_viewport(title: str, width: int, height: int, on_close: Callable[[], None]) -> None:
    """Create the Dear PyGui context (font, theme) and the viewport; its close button calls `on_close`.

    The close button only asks: the window closes when the app stops the loop (`dpg.stop_dearpygui`).
    """
    dpg.create_context()
    font = theme.load_font(15)
    if font is not None:
        dpg.bind_font(font)
    theme.apply_theme()
    dpg.create_viewport(
        title=title, width=width, height=height, min_width=640, min_height=400, disable_close=True
    )
    dpg.set_exit_callback(lambda *_: on_close())
    dpg.setup_dearpygui()


@contextmanager
def main_window(width: int, height: int) -> Iterator[int | str]:
    """The window everything is built in (``with``): a menu bar, then rows (the body, the bottom bars).

    Fill rate is what a software renderer (Mesa llvmpipe) pays for, ~9 ms per frame for one layer over the
    whole 1440x900 window. So this is not Dear PyGui's "primary window" (which always fills its
    background) but a window without one that follows the viewport's size (`CanvasPaint.fit_window`); the
    viewport is cleared to the canvas colour, the canvas and the toolbox (same colour) have no fill of their
    own, and the window colour is painted only around them (`CanvasPaint.draw_backdrop`).
    """
    with dpg.window(
        pos=(0, 0),
        width=width,
        height=height,
        no_title_bar=True,
        no_move=True,
        no_resize=True,
        no_collapse=True,
        menubar=True,
        no_scrollbar=True,
        no_background=True,
        no_bring_to_front_on_focus=True,
        no_saved_settings=True,
    ) as window:
        yield window
    dpg.bind_item_theme(window, theme.main_window_theme())


def install_input(on_wheel: Callable[[float], None]) -> None:
    """Add the window's input handlers: the wheel. The keys are read after each frame on the UI thread
    (`KeyBindings.after_frame`), which also keeps the loop rendering while Dear ImGui hands them out."""
    with dpg.handler_registry():
        dpg.add_mouse_wheel_handler(callback=lambda _s, delta: on_wheel(delta))
