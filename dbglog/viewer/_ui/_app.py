"""The viewer window: toolbox, free-form canvas, menus, status bar, and the render loop wiring them together.

What is on the canvas lives in a headless document (`CanvasDoc`); the mouse on the canvas is `PointerInput`,
open/save/quit are `FileCommands`. Only the thread that created the `ViewerApp` calls Dear PyGui; data
comes from a `DataSource` whose snapshots are read once per frame, and a widget is redrawn only when one
of its series changed.
"""

from __future__ import annotations

import collections
import ctypes
import math
import os
import sys
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any, Self

import dearpygui.dearpygui as dpg

from dbglog._sched import CpuWaitMeter, cpu_times_ns, in_background
from dbglog.viewer._data._model import Binding, DataSource
from dbglog.viewer._data._timeline import Timeline, TimeSource
from dbglog.viewer._document._canvas_doc import CanvasDoc, TopicSetup
from dbglog.viewer._document._dashboard import Dashboard, LoadResult, RawWidget, WidgetConfig
from dbglog.viewer._publishing._publish import PublishService
from dbglog.viewer._publishing._republish import Republisher
from dbglog.viewer._ui import _theme as theme
from dbglog.viewer._ui._chrome import PAYLOAD_TYPE, CanvasPaint, Toolbox
from dbglog.viewer._ui._dialogs import (
    Dialog,
    MessageDialog,
    PropertiesDialog,
    RenameDialog,
    TopicDialog,
)
from dbglog.viewer._ui._files import FileCommands, FileRequest
from dbglog.viewer._ui._frame import TITLE_H, CanvasItem, FrameSnapshots
from dbglog.viewer._ui._host import AppHost
from dbglog.viewer._ui._pacing import (
    DEFAULT_DATA_FPS,
    DEFAULT_FPS,
    DIALOG_IDLE_RENDER_S,
    IDLE_RENDER_S,
    Pacer,
    XInput,
    cpu_wait_text,
    wait_readable,
    x_connection_fd,
)
from dbglog.viewer._ui._pointer import PointerInput
from dbglog.viewer._ui._quit import QuitDialog
from dbglog.viewer._ui._recordings import RecordingCommands
from dbglog.viewer._ui._timebar import TIMEBAR_H, TimeBar
from dbglog.viewer._ui._timescale import history_text
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer._widgets._geometry import (
    Rect,
    free_spot,
    snap_rect,
)
from dbglog.viewer._widgets._plotlines import LINE_WORKER
from dbglog.viewer.widget_api import TimeRange, Widget

__all__ = ["PAYLOAD_TYPE", "ViewerApp", "keep_freed_memory"]

SETTLE_FRAMES = 3
"""Frames rendered before a screenshot is captured, so that the last update is fully on screen."""
STATUS_H = 34
BOTTOM_H = STATUS_H + TIMEBAR_H + 8
"""The window's height below the canvas: the timeline bar and the status bar."""
TEXT_ENTRY_TYPES = ("mvInputText", "mvInputInt", "mvInputFloat", "mvInputDouble")
"""Dear PyGui item types that take typed text: while one is being edited, the time keys are its own."""
CHORD_S = 0.15
"""How long after a rendered frame saw Ctrl or Shift down a shortcut's key still counts it as held."""


def keep_freed_memory() -> bool:
    """Let glibc keep freed heap memory between frames instead of returning it to the OS; True if done.

    The GL driver allocates and frees megabytes of vertex data every frame. With glibc's defaults the top
    of the heap is trimmed each time and every page is faulted in again on the next frame: about a tenth
    of a frame's CPU with Mesa's software renderer. Kept memory is reused, so it never grows past the peak.
    """
    if not sys.platform.startswith("linux"):
        return False
    try:
        mallopt = ctypes.CDLL(None).mallopt
    except (OSError, AttributeError):  # not glibc
        return False
    m_trim_threshold, m_top_pad, m_mmap_threshold = -1, -2, -3
    results = [
        mallopt(m_trim_threshold, 64 << 20),
        mallopt(m_top_pad, 16 << 20),
        mallopt(m_mmap_threshold, 32 << 20),
    ]
    return all(r == 1 for r in results)


class ViewerApp:
    """The whole viewer window; create, `start`, call `frame` (or `run`), then `close`.

    Widgets read their series through `timeline`, the window's time cursor over `source`: live, or
    paused at a moment of the past, or playing (the timeline bar, Space, the arrow keys, End).

    Args:
        source: where series come from (the engine, or any `DataSource`).
        registry: the widget types (default: built-ins plus installed plugins).
        width / height: the window size in pixels.
        fps: the frame cap of `run` (which also skips frames while nothing changes).
        data_fps: how often `run` draws new data at most while the user does nothing.
        recording: `source` is a recording (a `ReplaySource`): it opens paused at its end, Space plays.
    """

    def __init__(
        self,
        source: DataSource,
        registry: WidgetRegistry | None = None,
        *,
        width: int = 1440,
        height: int = 900,
        title: str = "dbglog viewer",
        fps: float = DEFAULT_FPS,
        data_fps: float = DEFAULT_DATA_FPS,
        recording: bool = False,
    ) -> None:
        self.source = source
        self.timeline = Timeline(
            source, stale_after=float(getattr(source, "stale_after", 2.0)), recording=recording
        )
        """The time cursor: every widget's snapshots come through it (live, or as they stood at a time)."""
        self._snaps = FrameSnapshots(self.timeline)
        """The frame's snapshots: each series read once per look, however many widgets and passes ask."""
        self.registry = registry if registry is not None else WidgetRegistry.discover()
        self.width, self.height, self.title = width, height, title
        self.doc: CanvasDoc[CanvasItem] = CanvasDoc(self.timeline, self._update_title)
        """What is on the canvas: widgets, their bindings, selection, the file and whether it is modified."""
        self.dialog: Dialog | None = None
        self.pointer_override: tuple[float, float] | None = None
        """When set, used instead of the real mouse position (scripted sessions and tests)."""
        self.frame_times: collections.deque[float] = collections.deque(maxlen=600)
        self.frame_hooks: list[Callable[[], None]] = []
        """Called on the UI thread at every turn of the loop, rendered or not, before the widgets refresh
        (the auto-dashboard, test probes)."""
        self.cursor_hooks: list[Callable[[], None]] = []
        """Called on the UI thread at every turn of the loop, right after playback moved the cursor to now
        (``--republish`` hands the cursor over there)."""
        self.republisher: Republisher | None = None
        """``--republish``'s, set before `start`: View \u203a Republish on ROS 2 switches it off and on."""
        self.last_work_s = 0.0
        """Seconds the last frame spent before `render_dearpygui_frame` (input, snapshots, widget updates)."""
        self.pacer = Pacer(fps, min(fps, data_fps))
        """When `run` renders: the frame cap, and no frames while nothing changes."""
        self.idle_render_s = IDLE_RENDER_S
        """Seconds between two frames while nothing changes and no dialog is open (a safety net)."""
        self.rendered = 0
        """Frames rendered so far (the benchmark and the CPU test read this)."""
        self._x_fd: int | None = None
        self._x_input: XInput | None = None
        self._input_now = False
        """Whether the last rendered frame saw the user at work (`_input_seen`)."""
        self._mouse_seen: tuple[float, float] = (-1.0, -1.0)
        self._key_at = 0.0
        """When Dear PyGui last reported a key going down or up (its callback thread writes it)."""
        self._key_poked = 0.0
        """The `_key_at` the loop last answered with a burst of frames."""
        self._mods_seen: dict[int, float] = {}
        """Modifier key -> when a rendered frame last saw it down (`held`)."""
        self._view_key: tuple[object, ...] = ()
        self._render_starts: collections.deque[float] = collections.deque(maxlen=240)
        self._fps_text = ""
        self._cpu_wait = CpuWaitMeter()
        self._cpu_wait_text = ""
        self._fps_at = -1.0
        self.publisher = PublishService()
        """The controls' publishing service: this app's own, handed to every widget at mount."""
        self.pointer_input = PointerInput(self)
        self.files = FileCommands(self)
        self.host = AppHost(self)
        """What widgets get besides their series: log stores, the time cursor, "plot this number"."""
        self.time_range = TimeRange()
        """The time range the time plots share (zoomed, panned, following the newest data), one for all."""
        self.recordings = RecordingCommands(self)
        """File › Open recording, Save history as recording, Export CSV, Back to live."""
        self._started = False
        self._status_text = ""
        self._status_left = ""
        self._history_text = ""
        self._history_at = -1.0
        self._history_next = ""
        self._quitting = False
        self._time_commands: collections.deque[Callable[[], object]] = collections.deque()
        """Time keys and the bar's button, queued by Dear PyGui's callback thread, run by `_work`."""
        self._held_keys: set[int] = set()
        """Keys whose press was taken and that have not been seen up since (their repeats are ignored)."""
        self._fallback_span: tuple[float, float] | None = None
        self._span_checked = -1.0

    # -- the document, as the window shows it ------------------------------------------------------

    @property
    def items(self) -> list[CanvasItem]:
        """The widgets in drawing order (last on top)."""
        return self.doc.items

    @property
    def selected(self) -> CanvasItem | None:
        """The highlighted widget."""
        return self.doc.selected

    @property
    def path(self) -> Path | None:
        """The dashboard's file (None: untitled)."""
        return self.doc.path

    @property
    def dirty(self) -> bool:
        """Whether there are unsaved changes."""
        return self.doc.dirty

    @property
    def load_messages(self) -> list[str]:
        """What could not be loaded from the dashboard as it was."""
        return self.doc.load_messages

    @property
    def file_request(self) -> FileRequest | None:
        """The open file dialog (Open or Save As), or None."""
        return self.files.request

    @property
    def started(self) -> bool:
        """Whether the window exists (between `start` and `close`)."""
        return self._started

    # -- lifecycle ----------------------------------------------------------------------------------

    def start(self, *, visible: bool = True) -> None:
        """Create the Dear PyGui context, the window and its contents."""
        keep_freed_memory()
        dpg.create_context()
        self._started = True
        font = theme.load_font(15)
        if font is not None:
            dpg.bind_font(font)
        theme.apply_theme()
        self.frame_theme = theme.frame_theme()
        self._frame_themes = {
            (False, True): self.frame_theme,
            (False, False): theme.frame_theme(filled=False),
            (True, True): theme.selected_frame_theme(),
            (True, False): theme.selected_frame_theme(filled=False),
        }
        """(selected, filled) -> the theme of a widget frame."""
        # The close button only asks (`request_quit`): the window closes when `quit` stops the loop.
        dpg.create_viewport(
            title=self.title,
            width=self.width,
            height=self.height,
            min_width=640,
            min_height=400,
            disable_close=True,
        )
        dpg.set_exit_callback(lambda *_: self._on_close_request())
        dpg.setup_dearpygui()
        self._build()
        if self.timeline.recording:
            self.timeline.pause()  # at the recording's end, what it showed last; Space plays from the start
        if visible:
            dpg.show_viewport()
            self._x_input = XInput.of_glfw(dpg.internal_dpg.__file__)
            self._x_fd = self._x_input.fd if self._x_input is not None else x_connection_fd()
        for _ in range(2):
            self.frame()

    def close(self) -> None:
        """Unbind every series and destroy the context."""
        if not self._started:
            return
        self._quitting = True  # Dear PyGui calls the exit callback once more while destroying the context
        self.close_dialog()
        self.doc.release_all()
        self.publisher.stop()
        self._started = False
        dpg.destroy_context()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    # -- building -----------------------------------------------------------------------------------

    def _build(self) -> None:
        # Fill rate is what a software renderer (Mesa llvmpipe) pays for, ~9 ms per frame for one layer over
        # the whole 1440x900 window. So this is not Dear PyGui's "primary window" (which always fills its
        # background) but a window without one that follows the viewport's size (`CanvasPaint.fit_window`);
        # the viewport is cleared to the canvas colour, the canvas and the toolbox (same colour) have no fill
        # of their own, and the window colour is painted only around them (`CanvasPaint.draw_backdrop`).
        with dpg.window(
            pos=(0, 0),
            width=self.width,
            height=self.height,
            no_title_bar=True,
            no_move=True,
            no_resize=True,
            no_collapse=True,
            menubar=True,
            no_scrollbar=True,
            no_background=True,
            no_bring_to_front_on_focus=True,
            no_saved_settings=True,
        ) as self.main:
            self._build_menus()
            # A child window reports no position; the group that starts with the toolbox does.
            with dpg.group(horizontal=True) as self.body_group:
                self.tools = Toolbox(
                    self.registry,
                    snap=self.doc.snap,
                    grid_size=self.doc.grid_size,
                    height=-BOTTOM_H,
                    on_snap=self.set_snap,
                    on_grid_size=self.set_grid_size,
                )
                self.toolbox, self.toolbox_buttons = self.tools.window, self.tools.buttons
                # Scrollbars appear when widgets lie beyond the view; the wheel scrolls it too, but through
                # `PointerInput.apply_wheel` (not Dear ImGui's own wheel scrolling), which leaves the wheel
                # to plots.
                self.canvas = dpg.add_child_window(
                    width=-1,
                    height=-BOTTOM_H,
                    border=False,
                    horizontal_scrollbar=True,
                    no_scroll_with_mouse=True,
                    drop_callback=self.on_drop,
                    payload_type=PAYLOAD_TYPE,
                )
                # In a group placed at (0, 0), so that the layout cursor it leaves behind does not make
                # the scrolled area taller than the grid (a drawlist ignores `pos` itself).
                self.grid_group = dpg.add_group(parent=self.canvas, pos=(0, 0))
                self.grid_layer = dpg.add_drawlist(1, 1, parent=self.grid_group)
            self.timebar = TimeBar(
                self.timeline,
                self.time_span,
                self.seek,
                lambda: self.queue_time(self.toggle_live),
                on_play=self.toggle_play,
                on_speed=lambda speed: self.queue_time(self.set_speed, speed),
                on_loop=self.toggle_loop,
                marks=self.host.mark_columns,  # the Log console's warnings and errors
            )
            with dpg.group(horizontal=True):
                self.status_left = dpg.add_text("", color=theme.DIM)
                self.status_msg = dpg.add_text("")
        dpg.bind_item_theme(self.main, theme.main_window_theme())
        unfilled = theme.unfilled_child_theme()
        dpg.bind_item_theme(self.canvas, unfilled)
        dpg.bind_item_theme(self.tools.window, unfilled)
        self.paint = CanvasPaint(dpg.add_viewport_drawlist(front=False), self.grid_layer)
        self.overlay = dpg.add_viewport_drawlist(front=True)
        self.pointer_input.build_menu()
        self.menu = self.pointer_input.menu
        with dpg.handler_registry():
            dpg.add_key_press_handler(dpg.mvKey_Delete, callback=lambda *_: self.on_delete_key())
            dpg.add_key_press_handler(dpg.mvKey_Q, callback=lambda *_: self.on_quit_key())
            dpg.add_key_press_handler(dpg.mvKey_S, callback=lambda *_: self.on_save_key())
            dpg.add_key_press_handler(dpg.mvKey_Down, callback=lambda *_: self.on_arrow_key(1))
            dpg.add_key_press_handler(dpg.mvKey_Up, callback=lambda *_: self.on_arrow_key(-1))
            dpg.add_key_press_handler(dpg.mvKey_Escape, callback=lambda *_: self.on_escape_key())
            # Time keys run on the UI thread: queued here (Dear PyGui's callback thread), run by `_work`.
            queue = self.queue_time
            dpg.add_key_press_handler(dpg.mvKey_Spacebar, callback=lambda *_: queue(self.on_space_key))
            dpg.add_key_press_handler(dpg.mvKey_Left, callback=lambda *_: queue(self.on_time_arrow, -1))
            dpg.add_key_press_handler(dpg.mvKey_Right, callback=lambda *_: queue(self.on_time_arrow, 1))
            dpg.add_key_press_handler(dpg.mvKey_End, callback=lambda *_: queue(self.on_end_key))
            dpg.add_key_press_handler(dpg.mvKey_Home, callback=lambda *_: queue(self.on_home_key))
            dpg.add_mouse_wheel_handler(callback=lambda _s, delta: self.pointer_input.on_wheel(delta))
            # Any key (key 0): Dear ImGui hands typed keys to a frame one event at a time (its input
            # trickling), so keys read from X in one go are used over several frames: see `_look`.
            dpg.add_key_press_handler(0, callback=lambda *_: self._note_key())
            dpg.add_key_release_handler(0, callback=lambda *_: self._note_key())
        self._update_title()

    def _build_menus(self) -> None:
        with dpg.menu_bar():
            with dpg.menu(label="File"):
                dpg.add_menu_item(label="New", callback=lambda *_: self.new_dashboard())
                dpg.add_menu_item(label="Open\u2026", callback=lambda *_: self.files.ask(save=False))
                dpg.add_menu_item(label="Save", shortcut="Ctrl+S", callback=lambda *_: self.save())
                self.save_as_menu = dpg.add_menu_item(
                    label="Save As\u2026",
                    shortcut="Ctrl+Shift+S",
                    callback=lambda *_: self.files.ask(save=True),
                )
                dpg.add_separator()
                self.recordings.build_menu()
                dpg.add_separator()
                self.quit_menu = dpg.add_menu_item(
                    label="Quit", shortcut="Ctrl+Q", callback=lambda *_: self.request_quit()
                )
            with dpg.menu(label="View") as self.view_menu:
                self.snap_menu = dpg.add_menu_item(
                    label="Snap to grid",
                    check=True,
                    default_value=self.doc.snap,
                    callback=lambda s, a: self.set_snap(bool(a)),
                )
                dpg.add_menu_item(label="Load messages\u2026", callback=lambda *_: self.show_load_messages())
                self.log_menu = dpg.add_menu_item(
                    label="Log console", callback=lambda *_: self.queue_time(self.open_log_console)
                )
                self.republish_menu = dpg.add_menu_item(
                    label="Republish on ROS 2",
                    check=True,
                    default_value=True,
                    show=self.republisher is not None,
                    callback=lambda _s, on: self.queue_time(self.set_republish, bool(on)),
                )

    # -- frame loop ---------------------------------------------------------------------------------

    def frame(self) -> float:
        """Poll input, refresh changed widgets, render one frame; return the frame's duration in seconds."""
        t0 = time.perf_counter()
        self._look()
        self._work()
        self.last_work_s = time.perf_counter() - t0
        self._render(time.monotonic())
        elapsed = time.perf_counter() - t0
        self.frame_times.append(elapsed)
        return elapsed

    def run(self, *, seconds: float | None = None) -> None:
        """Render until the window closes (or for `seconds`), at most `fps` frames a second.

        A frame is rendered only when something changed (new data for a widget, an edit, a dialog), while
        the user is doing something (and for a second after), or now and then while idle; in between the
        loop sleeps, woken early by input on the X connection.

        Dear ImGui takes at most about one key event a frame (a key down, its character, its release:
        three frames a typed letter), so the keys GLFW read from X together are used over many frames, with
        nothing left on the X connection to wake the loop. Each key a frame uses keeps the loop at the cap
        (`_note_key`, `_look`): at 15 frames a second, a word typed at 60 ms a key had its last letters
        waiting 20 s for the idle frames before.
        """
        deadline = None if seconds is None else time.monotonic() + seconds
        pacer = self.pacer
        while dpg.is_dearpygui_running():
            now = time.monotonic()
            if deadline is not None and now >= deadline:
                break
            t0 = time.perf_counter()
            self._look()
            if pacer.due(now):
                self._work()  # widgets take the newest data only for a frame that shows it
                self.last_work_s = time.perf_counter() - t0
                self._render(now)
                self.frame_times.append(time.perf_counter() - t0)
                if self._input_now:
                    pacer.poke(now)
            now = time.monotonic()
            wait = pacer.wait(now)
            if deadline is not None:
                wait = min(wait, max(0.0, deadline - now))
            if pacer.active(now):
                if wait > 0:
                    time.sleep(wait)
            elif (self._x_input is not None and self._x_input.pending()) or wait_readable(self._x_fd, wait):
                pacer.poke(time.monotonic())  # input for the window: render it at once, and keep up

    def _note_key(self) -> None:
        """Dear PyGui's callback thread: a frame used a key event (no Dear PyGui call here)."""
        self._key_at = time.monotonic()

    def _look(self) -> None:
        """Between frames: run the hooks and see whether anything on screen would change (no drawing)."""
        key_at = self._key_at
        if key_at != self._key_poked:  # a key was used: Dear ImGui may hold more of them
            self._key_poked = key_at
            self.pacer.poke(time.monotonic())
        for hook in self.frame_hooks:
            hook()
        playing = self.timeline.playing
        if playing:  # the cursor moves with the clock: every drawn frame shows a later moment
            self.timeline.tick()
        for hook in self.cursor_hooks:
            hook()
        at = self.timeline.cursor
        span = self.time_span()
        self.time_range.sync(span[1] if span is not None else None, at)
        self._snaps.begin()
        changed = any(item.changed(self._snaps, paused_at=at) for item in self.items)
        if changed or playing or self._time_commands or self._bar_moved():
            self.pacer.request(time.monotonic())
        self._poke_if_view_changed()

    def _work(self) -> None:
        """Everything of a frame but rendering: input, snapshots, widget updates, dialogs, chrome."""
        self.pointer_input.poll()
        self.pointer_input.apply_wheel()
        self._run_time_commands()
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        busy = self._modal_open() or self.pointer_input.drag is not None
        self.timebar.poll(self.pointer(), left, blocked=busy)
        at = self.timeline.cursor
        now = time.time() if at is None else at  # the moment the widgets show
        for item in self.items:
            item.refresh(self._snaps, now, paused_at=at)
            if item.edited:  # a control changed its own saved value (a toggle switched, a slider moved)
                item.edited = False
                self.doc.mark_dirty()
        for dialog in (self.dialog, self.file_request.dialog if self.file_request is not None else None):
            if dialog is None:
                continue
            try:
                dialog.tick()
            except Exception as exc:  # a dialog must never stop the render loop
                self.set_status(f"dialog error: {exc!r}")
        # What this changes is drawn by the frame rendered right after (`_look` asked for it already).
        self._draw_chrome()
        self.timebar.fit(self.paint.window_size[0])
        self.timebar.draw()
        self._update_status()
        # With a dialog open a text cursor may blink: idle frames come more often then.
        dialog_open = self.dialog is not None or self.file_request is not None
        self.pacer.idle_render_s = DIALOG_IDLE_RENDER_S if dialog_open else self.idle_render_s
        self._poke_if_view_changed()

    def _poke_if_view_changed(self) -> None:
        """The user's doing (or a dialog's) changed what the window shows: render at the cap for a while."""
        key = self._view_state()
        if key != self._view_key:
            self._view_key = key
            self.pacer.poke(time.monotonic())

    def _view_state(self) -> tuple[object, ...]:
        """What, when it changes, means the user is at work: widgets, selection, dialogs, drags, the file."""
        return (
            len(self.items),
            id(self.items[-1]) if self.items else 0,
            id(self.selected),
            id(self.dialog),
            id(self.file_request),
            self.pointer_input.drag is not None,
            self.dirty,
            self.path,
            self.paint.window_size,
            # Playback moves the cursor by itself: drawn at the data rate (`--data-fps`), not the input cap.
            None if self.timeline.playing else self.timeline.cursor,
            self.timeline.playing,
        )

    def _render(self, now: float) -> None:
        self._render_starts.append(now)
        t0 = time.perf_counter()
        LINE_WORKER.start()  # plots' lines queued while the cursor moves: computed while this frame renders
        dpg.render_dearpygui_frame()
        self.rendered += 1
        self.pacer.rendered(now, time.perf_counter() - t0)
        self._input_now = self._input_seen()
        for key in (dpg.mvKey_ModCtrl, dpg.mvKey_ModShift):
            if dpg.is_key_down(key):
                self._mods_seen[key] = now
        self._held_keys = {key for key in self._held_keys if dpg.is_key_down(key)}

    def held(self, modifier: int) -> bool:
        """Whether a modifier key (Ctrl, Shift) is down, or was until a moment ago, for a shortcut's key.

        Dear ImGui takes the events of a frame together: a quick Ctrl+S can arrive with Ctrl already
        released in the frame that sees S, more often when frames are far apart (the loop idles).
        """
        return (
            bool(dpg.is_key_down(modifier))
            or time.monotonic() - self._mods_seen.get(modifier, -1e9) < CHORD_S
        )

    def _input_seen(self) -> bool:
        """Whether the user moved the mouse or holds a button (checked after each rendered frame)."""
        pos = dpg.get_mouse_pos(local=False)
        mouse = (float(pos[0]), float(pos[1]))
        moved = mouse != self._mouse_seen
        self._mouse_seen = mouse
        held = any(
            dpg.is_mouse_button_down(b)
            for b in (dpg.mvMouseButton_Left, dpg.mvMouseButton_Right, dpg.mvMouseButton_Middle)
        )
        return moved or held or self.pointer_input.drag is not None

    def screenshot(self, path: str | os.PathLike[str], *, timeout: float = 10.0) -> Path:
        """Write a PNG of the window to `path` and return it.

        Raises:
            TimeoutError: the frame buffer was not written in time.
        """
        target = Path(path).resolve()
        target.parent.mkdir(parents=True, exist_ok=True)
        if target.exists():
            target.unlink()
        # Settle first: texture uploads (plugins may draw into dynamic textures) reach the screen a frame
        # late, and the capture reads the previous buffer; without this a fresh update can be missing.
        for _ in range(SETTLE_FRAMES):
            self.frame()
        dpg.output_frame_buffer(file=str(target))
        deadline = time.monotonic() + timeout
        while time.monotonic() < deadline:
            self.frame()
            if target.exists() and target.stat().st_size > 0:
                return target
        raise TimeoutError(f"{target}: the window was not captured within {timeout:g} s")

    # -- coordinates and input ----------------------------------------------------------------------

    def pointer(self) -> tuple[float, float]:
        """The mouse position in window pixels."""
        if self.pointer_override is not None:
            return self.pointer_override
        x, y = dpg.get_mouse_pos(local=False)
        return float(x), float(y)

    def canvas_origin(self) -> tuple[float, float]:
        """The canvas's top-left corner in window pixels."""
        # A child window reports no screen rectangle; its first item, the grid layer at (0, 0), does.
        x, y = dpg.get_item_rect_min(self.grid_layer)
        return float(x), float(y)

    def canvas_size(self) -> tuple[int, int]:
        """The canvas's size in pixels."""
        w, h = dpg.get_item_rect_size(self.canvas)
        return int(w), int(h)

    def to_canvas(self, pos: tuple[float, float]) -> tuple[float, float]:
        """Convert window pixels to canvas pixels."""
        ox, oy = self.canvas_origin()
        return pos[0] - ox, pos[1] - oy

    def to_window(self, pos: tuple[float, float]) -> tuple[float, float]:
        """Convert canvas pixels to window pixels."""
        ox, oy = self.canvas_origin()
        return pos[0] + ox, pos[1] + oy

    def trash_rect(self) -> Rect:
        """The delete zone in window pixels."""
        return self.tools.trash_rect()

    def press(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Press the left button at `pos` (window pixels): select, and start a move or resize on a handle."""
        return self.pointer_input.press(pos)

    def drag_to(self, pos: tuple[float, float]) -> None:
        """Move the pointer with the button held: the widget follows, the outline shows where it will land."""
        self.pointer_input.drag_to(pos)

    def release(self, pos: tuple[float, float]) -> None:
        """Let go: the widget lands on the outline, or is deleted over the delete zone."""
        self.pointer_input.release(pos)

    def context_menu(self, pos: tuple[float, float]) -> CanvasItem | None:
        """Open the widget's context menu at `pos` (right click)."""
        return self.pointer_input.context_menu(pos)

    def on_delete_key(self) -> None:
        """Delete key: remove the selected widget (not while a dialog is open)."""
        if self.dialog is None and self.selected is not None:
            self.delete_item(self.selected)

    def on_quit_key(self) -> None:
        """Q key: with Ctrl held, as File \u203a Quit."""
        if self.held(dpg.mvKey_ModCtrl):
            self.request_quit()

    def on_save_key(self) -> None:
        """S key: with Ctrl held, File \u203a Save (Save As without a file); with Shift too, Save As."""
        if not self.held(dpg.mvKey_ModCtrl) or self.dialog is not None or self.file_request is not None:
            return
        if self.held(dpg.mvKey_ModShift):
            self.files.ask(save=True)
        else:
            self.save()

    def on_arrow_key(self, step: int) -> None:
        """Up/Down keys: in Topic setup, highlight the previous/next suggested topic (Enter takes it)."""
        if isinstance(self.dialog, TopicDialog):
            self.dialog.move_highlight(step)

    def on_escape_key(self) -> None:
        """Escape key: close the context menu, or cancel the open dialog as its Cancel button would."""
        if dpg.is_item_shown(self.menu):
            dpg.hide_item(self.menu)
        elif self.file_request is not None:
            self.files.cancelled()
        elif self.dialog is not None:
            self.dialog.close()

    def view_rect(self) -> Rect:
        """The part of the canvas in view, in canvas pixels (scrolling moves it)."""
        w, h = self.canvas_size()
        x, y = dpg.get_x_scroll(self.canvas), dpg.get_y_scroll(self.canvas)
        bar_w = theme.SCROLLBAR if dpg.get_y_scroll_max(self.canvas) > 0 else 0
        bar_h = theme.SCROLLBAR if dpg.get_x_scroll_max(self.canvas) > 0 else 0
        return Rect(float(x), float(y), float(max(1, w - bar_w)), float(max(1, h - bar_h)))

    # -- drop from the toolbox ----------------------------------------------------------------------

    def on_drop(self, sender: int | str, app_data: Any, user_data: Any = None) -> None:
        """Drop callback of the canvas: add the dragged widget type where the pointer is."""
        if isinstance(app_data, str):
            self.drop_widget(app_data, self.pointer())

    def drop_widget(self, type_name: str, pos: tuple[float, float]) -> CanvasItem | None:
        """Add a widget of `type_name` at `pos` (window pixels) and open its topic setup."""
        item = self.add_widget(type_name, *self.to_canvas(pos))
        if item is not None:
            self.open_topic_dialog(item)
        return item

    def add_widget(self, type_name: str, x: float, y: float, *, name: str | None = None) -> CanvasItem | None:
        """Place a new widget with its top-left corner near (x, y) on the canvas."""
        cls = self.registry.get(type_name)
        if cls is None:
            self.set_status(f"unknown widget type {type_name!r}")
            return None
        w, h = cls.default_size[0], cls.default_size[1] + TITLE_H
        rect = Rect(max(0.0, x - 20), max(0.0, y - TITLE_H / 2), float(w), float(h))
        doc = self.doc
        if doc.snap:
            rect = snap_rect(rect, doc.grid_size, min_w=cls.min_size[0], min_h=cls.min_size[1] + TITLE_H)
        # Never on top of another widget, nor off the visible canvas: the nearest free grid spot.
        rect = free_spot(
            rect, [i.rect for i in doc.items], self.view_rect(), doc.grid_size if doc.snap else 0
        )
        name = doc.unique_name(cls.label) if name is None else name
        bindings = (Binding(cls.default_topic),) if cls.default_topic else ()  # a console starts on /rosout
        props = cls.default_properties()
        config = WidgetConfig(type_name, name, rect.x, rect.y, rect.w, rect.h, bindings, props)
        item = doc.add(self._canvas_item(config, cls))
        self.select(item)
        doc.mark_dirty()
        return item

    # -- widget operations --------------------------------------------------------------------------

    def select(self, item: CanvasItem | None) -> None:
        """Highlight `item` (or nothing)."""
        before = self.selected
        self.doc.selected = item
        for changed in (before, item):
            if changed is not None and changed in self.items:  # the fill stays: `_draw_chrome` decides it
                self._bind_frame(changed, filled=changed.frame_look[1])

    def bring_to_front(self, item: CanvasItem) -> None:
        """Draw `item` above the others."""
        if self.doc.to_front(item):
            dpg.move_item(item.window, parent=self.canvas)

    def delete_item(self, item: CanvasItem) -> None:
        """Remove a widget and release its series."""
        if not self.doc.remove(item):
            return
        self._close_dialog_of(item)
        item.destroy()
        self.set_status(f"deleted {item.name!r}")

    def add_config(self, config: WidgetConfig) -> CanvasItem:
        """Place a ready-made widget (bindings and properties set) on the canvas and bind its series."""
        cls = self.registry.get(config.type)
        return self.doc.add(self._canvas_item(config, cls))

    def change_type(self, item: CanvasItem, type_name: str) -> CanvasItem | None:
        """Swap `item` for a widget of another kind with the same name, place and bindings."""
        from dbglog.viewer._document._autodash import retype

        cls = self.registry.get(type_name)
        config = item.config.editable
        if cls is None or config is None or item not in self.items:
            return None
        if type_name == config.type:
            return item
        config = retype(config, cls, min_frame=(cls.min_size[0], cls.min_size[1] + TITLE_H))
        new = self._canvas_item(config, cls)
        self.doc.replace(item, new)
        self._close_dialog_of(item)
        item.destroy()
        self.select(new)
        self.set_status(f"{new.name!r} is now a {cls.label}")
        return new

    def rename(self, item: CanvasItem, name: str) -> None:
        """Give a widget a new title."""
        self.doc.rename(item, name)

    def apply_bindings(self, item: CanvasItem, bindings: tuple[Binding, ...]) -> None:
        """Point a widget at new series (see `CanvasDoc.set_bindings`: a topic may rename it)."""
        self.doc.set_bindings(item, bindings)

    def set_snap(self, on: bool) -> None:
        """Switch snap-to-grid on or off."""
        self.doc.set_snap(on)
        self.show_grid_settings()

    def set_grid_size(self, size: int) -> None:
        """Change the grid spacing in pixels (5-400)."""
        self.doc.set_grid_size(size)
        self.show_grid_settings()

    def show_grid_settings(self) -> None:
        """Show the document's grid settings in the toolbox and the View menu."""
        self.tools.show_grid(self.doc.snap, self.doc.grid_size)
        dpg.set_value(self.snap_menu, self.doc.snap)

    # -- dialogs ------------------------------------------------------------------------------------

    def close_dialog(self) -> None:
        """Cancel the open dialog, if any (as its Cancel button would)."""
        if self.dialog is not None:
            self.dialog.close()

    def _close_dialog_of(self, item: CanvasItem) -> None:
        if self.dialog is not None and getattr(self.dialog, "item", None) is item:
            self.dialog.close()

    def open_dialog(self, dialog: Dialog) -> Dialog:
        """Make `dialog` the open one (one modal at a time)."""
        self.dialog = dialog
        return dialog

    def dialog_closed(self, dialog: Dialog) -> None:
        """A dialog's close callback: it is no longer the open one."""
        if self.dialog is dialog:
            self.dialog = None

    def open_topic_dialog(self, item: CanvasItem) -> TopicDialog | None:
        """Open the topic setup for `item` (placeholders have none)."""
        if item.widget_cls is None:
            return None
        self.close_dialog()
        dialog = TopicDialog(item, TopicSetup(self.doc, item), self.dialog_closed)
        self.open_dialog(dialog)
        return dialog

    def open_properties_dialog(self, item: CanvasItem) -> PropertiesDialog | None:
        """Open the properties dialog for `item`."""
        if item.widget_cls is None:
            return None
        self.close_dialog()
        dialog = PropertiesDialog(item, self._closed_dirty)
        self.open_dialog(dialog)
        return dialog

    def open_rename_dialog(self, item: CanvasItem) -> RenameDialog:
        """Open the rename dialog for `item`."""
        self.close_dialog()
        dialog = RenameDialog(item, self._closed_dirty)
        self.open_dialog(dialog)
        return dialog

    def _closed_dirty(self, dialog: Dialog) -> None:
        self.dialog_closed(dialog)
        self.doc.mark_dirty()

    def show_message(self, title: str, message: str) -> MessageDialog:
        """Show a message in a modal dialog."""
        self.close_dialog()
        dialog = MessageDialog(title, message, self.dialog_closed)
        self.open_dialog(dialog)
        return dialog

    def _canvas_item(self, config: WidgetConfig | RawWidget, cls: type[Widget] | None) -> CanvasItem:
        """A widget's frame on the canvas, with the app's publisher and host."""
        return CanvasItem(
            config,
            cls,
            self.canvas,
            self.frame_theme,
            publisher=self.publisher,
            host=self.host,
            time_range=self.time_range,
        )

    def set_republish(self, on: bool) -> None:
        """View \u203a Republish on ROS 2: the replay follows the cursor on the graph again, or stops."""
        if self.republisher is not None:
            self.republisher.set_enabled(on)
            self.set_status("republishing on ROS 2 at the cursor" if on else "republishing on ROS 2 stopped")

    def open_log_console(self) -> CanvasItem | None:
        """View \u203a Log console: a Log widget on /rosout, in view where there is room."""
        view = self.view_rect()
        item = self.add_widget("log", view.x + 40, view.y + 40)
        if item is not None:
            self.set_status("a Log console on /rosout: its title's menu \u203a Topic setup for another topic")
        return item

    def show_load_messages(self) -> None:
        """Show what could not be loaded from the current dashboard as it was."""
        text = "\n".join(self.load_messages) or "The dashboard loaded without problems."
        self.show_message("Load messages", text)

    # -- files and quitting (`FileCommands`) --------------------------------------------------------

    def file_cancelled(self) -> None:
        """The file dialog's Cancel: nothing happens (after the quit prompt's Save, the viewer stays open)."""
        self.files.cancelled()

    def dashboard(self) -> Dashboard:
        """The current dashboard as it would be saved."""
        return self.doc.dashboard()

    def load(self, result: LoadResult, path: Path | None = None) -> None:
        """Replace the canvas with a loaded dashboard."""
        self.files.load(result, path)

    def open_path(self, path: str | os.PathLike[str]) -> bool:
        """Open a dashboard file; on failure show why and keep the current dashboard."""
        return self.files.open_path(path)

    def save(self, path: str | os.PathLike[str] | None = None) -> bool:
        """Save to `path` (or the current file; with neither, ask for one)."""
        return self.files.save(path)

    def new_dashboard(self, path: Path | None = None) -> None:
        """Start an empty dashboard (that Save writes to `path`, when given)."""
        self.files.new(path)

    def clear(self) -> None:
        """Remove every widget."""
        self.close_dialog()
        for item in self.doc.clear():
            item.destroy()

    @property
    def quitting(self) -> bool:
        """True once the window is closing (`quit` was called): the render loop ends."""
        return self._quitting

    def request_quit(self) -> QuitDialog | None:
        """Close the window as the user asked (close button, File \u203a Quit, Ctrl+Q).

        With nothing unsaved the window closes at once; otherwise the quit prompt opens and is returned.
        """
        return self.files.request_quit()

    def quit(self) -> None:
        """Close the window now, whatever is unsaved: the render loop (`run`) ends."""
        if not self._started:
            return
        self._quitting = True
        dpg.stop_dearpygui()

    def _on_close_request(self) -> None:
        # Dear PyGui's exit callback: the window's close button (the viewport was made with disable_close).
        if self._started and not self._quitting:
            self.request_quit()

    # -- time travel --------------------------------------------------------------------------------

    @property
    def live(self) -> bool:
        """Whether the widgets follow the newest data (not paused at a moment of the past)."""
        return self.timeline.live

    def time_span(self) -> tuple[float, float] | None:
        """Return the (oldest, newest) source time the dashboard can show, None while nothing is held.

        The source's history when it has one (`TimeSource`), else what the widgets' series hold.
        """
        if isinstance(self.source, TimeSource):
            return self.timeline.span()
        now = time.monotonic()
        if now - self._span_checked >= 0.1:
            self._span_checked = now
            self._fallback_span = self._series_span()
        return self._fallback_span

    def _series_span(self) -> tuple[float, float] | None:
        lo, hi = math.inf, -math.inf
        for binding in self.step_bindings(all_widgets=True):
            snap = self.source.snapshot(binding)
            if len(snap.times):
                lo, hi = min(lo, float(snap.times[0])), max(hi, float(snap.times[-1]))
            elif snap.last_time is not None:
                lo, hi = min(lo, snap.last_time), max(hi, snap.last_time)
        return (lo, hi) if hi >= lo else None

    def step_bindings(self, *, all_widgets: bool = False) -> list[Binding]:
        """The series the arrow keys step through: the selected widget's, or every widget's."""
        selected = self.selected
        if not all_widgets and selected is not None and selected in self.items and selected.series:
            return list(selected.series)
        return list(dict.fromkeys(b for item in self.items for b in item.series))

    def pause(self, at: float | None = None) -> None:
        """Hold every widget at source time `at` (default: the newest sample held)."""
        if at is None:
            span = self.time_span()
            at = span[1] if span is not None else time.time()
        self.seek(at)

    def seek(self, t: float) -> None:
        """Move the time cursor to `t` (pausing), kept within the span held."""
        span = self.time_span()
        if span is not None:
            t = min(max(t, span[0]), span[1])
        self.timeline.seek(t)

    def go_live(self) -> None:
        """Follow the newest data again (a recording: go to its end, paused)."""
        if self.timeline.recording:
            span = self.time_span()
            self.timeline.pause()
            if span is not None:
                self.timeline.seek(span[1])
            return
        self.timeline.resume()

    def toggle_live(self) -> None:
        """Pause at the newest sample, or go back to live; a recording, or playback: play or pause."""
        if self.timeline.recording or self.timeline.playing:
            self.toggle_play()
        elif self.live:
            self.pause()
        else:
            self.go_live()

    def toggle_play(self) -> None:
        """Play from the cursor, or pause playback (live: from a paused cursor, until it catches up)."""
        timeline = self.timeline
        if timeline.playing:
            timeline.pause()
        elif timeline.recording or not timeline.live:
            timeline.play()
        else:
            self.set_status("pause or click on the timeline first: playback starts from the cursor")

    def set_speed(self, speed: float) -> None:
        """Set the playback speed (`Timeline.SPEEDS`) and close the speed menu."""
        self.timebar.close_speed_menu()
        self.timeline.set_speed(speed)
        self.set_status(f"playback speed {speed:g}\u00d7")

    def toggle_loop(self) -> None:
        """Switch looping (a recording plays again from its start at the end) on or off."""
        self.timeline.loop = not self.timeline.loop
        self.set_status("loop on: playback starts again at the end" if self.timeline.loop else "loop off")

    def use_source(self, source: DataSource, *, recording: bool) -> None:
        """Show `source` in place of the current data source: a recording opened, or live again.

        Every binding moves to it (widgets keep their bindings, fields, regex and transforms); a recording
        opens paused at its end, a live source live.
        """
        old, bound = self.source, list(self.doc.refs)
        for binding in bound:
            old.unbind(binding)
        self.source = source
        timeline = self.timeline
        timeline.source = source
        timeline.recording = recording
        timeline.loop = False
        timeline.stale_after = float(getattr(source, "stale_after", timeline.stale_after))
        timeline.resume()
        for binding in bound:
            source.bind(binding)
        if recording:
            timeline.pause()
        self._fallback_span, self._span_checked = None, -1.0
        self._history_at = -1.0
        self._update_title()

    @property
    def replay_name(self) -> str | None:
        """The recording shown (its file name), or None for a live source."""
        if not self.timeline.recording:
            return None
        return Path(str(getattr(self.source, "name", "recording"))).name

    def shift_time(self, seconds: float) -> None:
        """Move the cursor `seconds` later (negative: earlier), pausing first when live."""
        if self.timeline.cursor is None:
            self.pause()
        assert self.timeline.cursor is not None
        self.seek(self.timeline.cursor + seconds)

    def step_time(self, direction: int) -> bool:
        """Move the cursor to the previous (-1) or next (+1) message of `step_bindings`; False if none."""
        bindings = self.step_bindings()
        if self.timeline.cursor is None:
            self.pause()
        if not bindings or not self.timeline.step(bindings, direction):
            whose = self.selected.name if self.selected is not None and self.selected.series else "any widget"
            self.set_status(f"no {'earlier' if direction < 0 else 'later'} message of {whose}")
            return False
        return True

    def queue_time(self, action: Callable[..., object], *args: object) -> None:
        """Run `action(*args)` on the UI thread at the next frame (key and button callbacks run elsewhere)."""
        self._time_commands.append(lambda: action(*args))

    def _run_time_commands(self) -> None:
        while self._time_commands:
            self._time_commands.popleft()()

    def on_space_key(self) -> None:
        """Space: pause at the newest sample, or go back to live (not while typing or in a dialog).

        Held down it toggles once (the key's repeats are ignored), unlike the arrows, which repeat to scrub.
        """
        if self._keys_blocked() or dpg.mvKey_Spacebar in self._held_keys:
            return
        self._held_keys.add(dpg.mvKey_Spacebar)
        self.toggle_live()

    def on_time_arrow(self, direction: int) -> None:
        """Left/Right: the previous/next message of the selected widget (or all); with Shift, 1 s."""
        if self._keys_blocked():
            return
        if self.held(dpg.mvKey_ModShift):
            self.shift_time(float(direction))
        else:
            self.step_time(direction)

    def on_end_key(self) -> None:
        """End: back to live (a recording: to its end); plots follow the newest data again."""
        if not self._keys_blocked():
            self.go_live()
            self.time_range.go_live()

    def on_home_key(self) -> None:
        """Home: to the oldest moment held (a recording's start), paused."""
        span = self.time_span()
        if not self._keys_blocked() and span is not None:
            self.timeline.pause()
            self.seek(span[0])

    def _modal_open(self) -> bool:
        """Whether a dialog, the file dialog or the context menu has the input."""
        return self.dialog is not None or self.file_request is not None or bool(dpg.is_item_shown(self.menu))

    def _keys_blocked(self) -> bool:
        """Whether the keys belong to something else: a dialog, the context menu, a field being typed in."""
        return self._modal_open() or self.typing()

    def typing(self) -> bool:
        """Whether a text field on the canvas (a control's, say) is being edited and so has the keyboard."""
        stack: list[int | str] = [item.window for item in self.items]
        while stack:
            node = stack.pop()
            children = dpg.get_item_children(node, 1) or []
            stack.extend(children)
            kind = dpg.get_item_type(node)
            if kind.endswith(TEXT_ENTRY_TYPES) and dpg.is_item_active(node):
                return not (kind.endswith("mvInputText") and dpg.get_item_configuration(node).get("readonly"))
        return False

    def _bar_moved(self) -> bool:
        """Twice a second: whether the timeline bar or the history figures would show something new."""
        now = time.monotonic()
        if now - self._history_at < 0.5:
            return False
        return self.timebar.stale() or self._history_status(now) != self._history_text

    def _history_status(self, now: float) -> str:
        if now - self._history_at >= 0.5:
            self._history_at = now
            stats = self.timeline.stats()
            if stats is None:
                self._history_next = ""
            else:
                span = None if stats.oldest is None or stats.newest is None else (stats.oldest, stats.newest)
                self._history_next = history_text(span, stats.bytes_used, stats.samples)
        return self._history_next

    # -- chrome -------------------------------------------------------------------------------------

    def set_status(self, text: str) -> None:
        """Show a message in the status bar."""
        self._status_text = text
        if self._started:
            dpg.set_value(self.status_msg, text)

    def _update_title(self) -> None:
        if self._started:
            replay = self.replay_name
            base = self.title if replay is None else f"{self.title} \u2014 replay of {replay}"
            dpg.set_viewport_title(self.doc.title(base))

    def _update_status(self) -> None:
        """Refresh the status bar's left part (content at once, fps twice a second)."""
        now = time.monotonic()
        if now - self._fps_at >= 0.5 and self._render_starts:
            self._fps_at = now
            recent = sum(1 for t in self._render_starts if t > now - 1.0)
            if now - self._render_starts[0] < 1.0:
                self._fps_text = ""  # not measured yet
            elif recent < 5 and not self.pacer.active(now):
                self._fps_text = "idle"
            else:
                self._fps_text = f"{min(recent, 999)} fps"
            times = cpu_times_ns()  # (this is the window's thread: the one whose frames come late)
            share = None if times is None else self._cpu_wait.add(now, *times)
            self._cpu_wait_text = cpu_wait_text(share, in_background())
        parts = self.doc.summary()
        replay = self.replay_name
        if replay is not None:
            loading = " (loading the rest\u2026)" if getattr(self.source, "loading", False) else ""
            parts.insert(0, f"replay of {replay}{loading}")
        self._history_text = self._history_status(now)
        if self._history_text:
            parts.append(self._history_text)
        if self._fps_text:
            parts.append(self._fps_text)
        if self._cpu_wait_text:  # first: it says why everything else comes late
            parts.insert(0, self._cpu_wait_text)
        text = "  " + "   \u00b7   ".join(parts) + "   "
        if text != self._status_left:
            self._status_left = text
            dpg.set_value(self.status_left, text)

    def _draw_chrome(self) -> None:
        """Fit the window to the viewport, paint around the canvas, draw the grid (each only if changed)."""
        self.paint.fit_window(self.main)
        ox, oy = self.canvas_origin()
        w, h = self.canvas_size()
        (tx, ty), (tw, th) = dpg.get_item_rect_min(self.body_group), dpg.get_item_rect_size(self.toolbox)
        drag = self.pointer_input.drag  # widgets are opaque: no grid under them (the dragged one aside)
        moving = drag.item if drag is not None else None
        still = [i for i in self.items if i is not moving]
        covers = tuple(i.rect for i in still)
        rects = [i.rect for i in self.items]
        self.paint.draw_grid(
            (w, h),
            rects,
            covers,
            self.doc.grid_size,
            self.doc.snap,
            toolbox_area=tw * th,
            settled=drag is None,
        )
        self.paint.draw_backdrop(Rect(ox, oy, w, h), Rect(tx, ty, tw, th))
        bare = {id(i) for i, b in zip(still, self.paint.bare, strict=True) if b}
        for item in self.items:
            self._bind_frame(item, filled=id(item) not in bare)

    def _bind_frame(self, item: CanvasItem, *, filled: bool) -> None:
        """Give `item`'s frame its theme: selected or not, with a fill of its own or none (`CanvasPaint`)."""
        look = (item is self.selected, filled)
        if item.frame_look != look:
            item.frame_look = look
            dpg.bind_item_theme(item.window, self._frame_themes[look])
