"""The viewer window: builds the concerns and wires them, one object each, handed what it needs.

`Canvas` (the widgets on the canvas), `PointerInput` (the mouse), `TimeControl` (the cursor, play, speed),
`FileCommands` and `RecordingCommands` (the File menu), `Dialogs` (the one open dialog), `StatusBar`,
`FrameLoop` (when a frame renders) and `Actions` (every command by name, with its keys: the menus, the
buttons and the keys run them). Only the thread that created the `ViewerApp` calls Dear PyGui.
docs/viewer.md ("Where things live") says where a new panel, dialog, command or button goes.
"""

from __future__ import annotations

import os
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import TYPE_CHECKING, Self

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Binding, DataSource
from dbglog.viewer._data._robots import Fleet
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._document._canvas_doc import CanvasDoc
from dbglog.viewer._document._dashboard import LoadResult
from dbglog.viewer._publishing._publish import PublishService
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._bindings import KeyBindings, MenuBar, keys_hint
from dbglog.viewer._ui._canvas import Canvas
from dbglog.viewer._ui._chrome import PAYLOAD_TYPE
from dbglog.viewer._ui._dialogs import Dialog
from dbglog.viewer._ui._eventlist import EventsPanel
from dbglog.viewer._ui._files import FileCommands, FileDialogs
from dbglog.viewer._ui._frame import CanvasItem, FrameSnapshots
from dbglog.viewer._ui._host import AppHost
from dbglog.viewer._ui._loop import FrameLoop, keep_freed_memory
from dbglog.viewer._ui._menus import MENUS
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._pacing import DEFAULT_DATA_FPS, DEFAULT_FPS
from dbglog.viewer._ui._pointer import PointerInput
from dbglog.viewer._ui._recordings import RecordingCommands
from dbglog.viewer._ui._robotbar import RobotSwitcher
from dbglog.viewer._ui._status import StatusBar
from dbglog.viewer._ui._tagtree import TREE_W, TagTreePanel
from dbglog.viewer._ui._time import KEYS_HINT, TimeControl
from dbglog.viewer._ui._timebar import TIMEBAR_H, TimeBar
from dbglog.viewer._ui._watches import WatchKeeper
from dbglog.viewer._ui._window import install_input, main_window, open_viewport
from dbglog.viewer._widgets import WidgetRegistry
from dbglog.viewer.widget_api import TimeRange

if TYPE_CHECKING:
    from dbglog._ros._paramclient import ParamClient

__all__ = ["PAYLOAD_TYPE", "ViewerApp", "keep_freed_memory"]

STATUS_H = 34
BOTTOM_H = STATUS_H + TIMEBAR_H + 8
"""The window's height below the canvas: the timeline bar and the status bar."""


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
        params: the parameter client widgets bound to a node's parameter use (``dbglog view`` makes one
            when live); None: parameters are only read from the events, as in a recording.
        robot: the robot (namespace: ``/robot1``, ``""``) the robot-relative widgets show at start; None: the
            first robot seen.
        tag_tree: show the tag tree panel at start (View \u203a Tag tree shows and hides it).
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
        params: ParamClient | None = None,
        robot: str | None = None,
        tag_tree: bool = False,
    ) -> None:
        self.registry = registry if registry is not None else WidgetRegistry.discover()
        self.width, self.height, self.title = width, height, title
        stale = float(getattr(source, "stale_after", 2.0))
        self.timeline = Timeline(source, stale_after=stale, recording=recording)
        """The time cursor: every widget's snapshots come through it (live, or as they stood at a time)."""
        self.fleet = Fleet(robot)
        """The robots seen and the one selected (robot-relative bindings resolve to its topics)."""
        self.doc: CanvasDoc[CanvasItem] = CanvasDoc(self.timeline, self._update_title, fleet=self.fleet)
        """What is on the canvas: widgets, their bindings, selection, the file and whether it is modified."""
        self.time_range = TimeRange()
        """The time range the time plots share (zoomed, panned, following the newest data), one for all."""
        self.publisher = PublishService()
        """The controls' publishing service: this app's own, handed to every widget at mount."""
        self.frame_hooks: list[Callable[[], None]] = []
        """Called on the UI thread at every turn of the loop, rendered or not, before the widgets refresh
        (the auto-dashboard, test probes)."""
        self.cursor_hooks: list[Callable[[], None]] = []
        """Called on the UI thread at every turn of the loop, right after playback moved the cursor to now
        (``--republish`` hands the cursor over there)."""
        self.actions = Actions()
        """Every command of the window by name, with its keys (menus, buttons and keys run them)."""
        self.loop = FrameLoop(self, fps=fps, data_fps=data_fps)
        self.pacer, self.frame_times = self.loop.pacer, self.loop.frame_times
        self.dialogs = Dialogs(self.doc, self.set_status)
        self.canvas = Canvas(
            self.doc,
            self.registry,
            self.dialogs,
            self.set_status,
            FrameSnapshots(self.timeline),
            publisher=self.publisher,
            time_range=self.time_range,
        )
        self.time = TimeControl(self.timeline, self.canvas, self.set_status, self.time_range)
        self.host = AppHost(
            self.timeline,
            seek=self.time.seek,
            registry=self.registry,
            dialogs=self.dialogs,
            add_plan=self.canvas.add_plan,
            params=params,
        )
        """What widgets get besides their series: log stores, the time cursor, "plot this number", node
        parameters and the events."""
        self.frame_hooks.append(self.host.tick)
        self.dialogs.parameters = self.host.parameter_list  # Topic setup suggests them
        self.events_panel = EventsPanel(
            self.host, self.dialogs, self.set_status, self.actions.call_soon, self.canvas.room_for("events")
        )
        """View › Events list beside the canvas, and File › Add marker…."""
        self.frame_hooks.append(self.events_panel.poll)
        self.canvas.host = self.host
        self.pointer_input = PointerInput(
            self.canvas,
            self.actions,
            dialog_open=lambda: self.dialogs.current is not None,
            file_open=lambda: self.files.request is not None,
            held=self.loop.held,
            rendered=lambda: self.loop.rendered,
        )
        prompts = FileDialogs(self.dialogs, self.pointer_input.hide_menu)
        self.files = FileCommands(self.doc, self.registry, self.canvas, self, prompts)
        self.recordings = RecordingCommands(
            self.time,
            self.canvas,
            self.dialogs,
            close_file_dialog=self.files.close_dialog,
            use_source=lambda source, recording: self.use_source(source, recording=recording),
            say=self.set_status,
            wake=self.pacer.request,
        )
        """File \u203a Open recording, Save history as recording, Export CSV, Back to live."""
        self.frame_hooks.append(self.recordings.poll)
        self.robots: RobotSwitcher[CanvasItem] = RobotSwitcher(
            self.doc, self.timeline, say=self.set_status, wake=self.pacer.request
        )
        """The Robot menu: the robots seen, their status, the selected one."""
        self.tree = TagTreePanel(
            self.doc,
            self.timeline,
            self.canvas,
            self.actions,
            say=self.set_status,
            wake=self.pacer.request,
            shown=tag_tree,
            on_show=self._tree_room,
            on_robot=self.robots.select,
            robot_states=lambda: self.robots.states,
        )
        """The tag tree beside the canvas: robots, groups, tags and topics to drag onto it."""
        self.canvas.drop_handlers.append(self.tree.drop)
        say, wake = self.set_status, self.pacer.request
        self.watches = WatchKeeper(self.doc, self.dialogs, self.canvas, say=say, wake=wake, replay=recording)
        """Watch a variable…, and the dashboard's watches kept armed with their state on their widgets."""
        self.frame_hooks += [self.robots.poll, self.tree.poll, self.watches.poll]
        self.status = StatusBar(self.time, self.doc.summary, self.loop)
        self.keys = KeyBindings(self.actions, keyboard_taken=self._keys_blocked)
        self.menus = MenuBar(self.actions, MENUS)
        self.started = False
        """Whether the window exists (between `start` and `close`)."""
        self.quitting = False
        """True once the window is closing (`quit` was called): the render loop ends."""
        self._register()

    def _register(self) -> None:
        """Register every command once: each concern its own, then the window's."""
        for concern in (
            self.time,
            self.canvas,
            self.recordings,
            self.dialogs,
            self.events_panel,
            self.robots,
            self.tree,
            self.watches,
        ):
            concern.register(self.actions)
        self.files.register(self.actions, modal=lambda: self.dialogs.current is not None)
        self.actions.register(
            "window.cancel", "Cancel", "Close the menu or cancel the dialog", self.cancel, keys=("Escape",)
        )

    # -- lifecycle ----------------------------------------------------------------------------------

    @property
    def running(self) -> bool:
        """Whether the window is open and not closing."""
        return self.started and not self.quitting

    def start(self, *, visible: bool = True) -> None:
        """Create the Dear PyGui context, the window and its contents."""
        keep_freed_memory()
        open_viewport(self.title, self.width, self.height, self._on_close_request)
        self.started = True
        with main_window(self.width, self.height) as self.main:
            self.menus.build()
            # A child window reports no position; the group that starts with the toolbox does. A side panel
            # goes in this group too, before or after the canvas.
            with dpg.group(horizontal=True) as self.body_group:
                self.canvas.build(height=-BOTTOM_H)
                self.events_panel.build(height=-BOTTOM_H)
                self.tree.build(height=-BOTTOM_H)
            self._tree_room(self.tree.shown)
            actions, control = self.actions, self.time
            self.timebar = TimeBar(
                self.timeline,
                control.time_span,
                control.seek,
                lambda: actions.soon("time.toggle_live"),
                on_play=lambda: actions.run("time.play"),
                on_speed=control.set_speed,
                on_loop=lambda: actions.run("time.loop"),
                marks=self.host.mark_columns,  # the Log console's warnings and errors
                keys=keys_hint(actions, KEYS_HINT),
                events=self.host,  # parameter changes and user markers
            )
            self.status.build()
        self.canvas.finish()
        self.robots.build(dpg.get_item_parent(self.menus.menus["File"]))
        self.robots.discover()
        self.pointer_input.build_menu()
        install_input(self.pointer_input.on_wheel)
        self._update_title()
        if self.timeline.recording:
            self.timeline.pause()  # at the recording's end, what it showed last; Space plays from the start
        if visible:
            dpg.show_viewport()
            self.loop.listen_to_x()
        for _ in range(2):
            self.frame()

    def close(self) -> None:
        """Unbind every series and destroy the context."""
        if not self.started:
            return
        self.quitting = True  # Dear PyGui calls the exit callback once more while destroying the context
        self.dialogs.close()
        self.watches.close()
        self.doc.release_all()
        self.publisher.stop()
        self.started = False
        dpg.destroy_context()

    def __enter__(self) -> Self:
        self.start()
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()

    def request_quit(self) -> object | None:
        """Close the window as the user asked (close button, File \u203a Quit, Ctrl+Q).

        With nothing unsaved the window closes at once; otherwise the quit prompt opens and is returned.
        """
        return self.files.request_quit()

    def quit(self) -> None:
        """Close the window now, whatever is unsaved: the render loop (`run`) ends."""
        if not self.started:
            return
        self.quitting = True
        dpg.stop_dearpygui()

    def _on_close_request(self) -> None:
        # Dear PyGui's exit callback: the window's close button (the viewport was made with disable_close).
        if self.running:
            self.actions.soon("file.quit")

    # -- the frame (`FrameSteps`) -------------------------------------------------------------------

    def frame(self) -> float:
        """Poll input, refresh changed widgets, render one frame; return the frame's duration in seconds."""
        return self.loop.frame()

    def run(self, *, seconds: float | None = None) -> None:
        """Render until the window closes (or for `seconds`): `FrameLoop.run`."""
        self.loop.run(seconds=seconds)

    def screenshot(self, path: str | os.PathLike[str], *, timeout: float = 10.0) -> Path:
        """Write a PNG of the window to `path` and return it (`FrameLoop.screenshot`)."""
        return self.loop.screenshot(path, timeout=timeout)

    def look(self) -> bool:
        """Between frames: the hooks, playback, and whether a widget's series or the bars would change."""
        for hook in self.frame_hooks:
            hook()
        playing = self.timeline.playing
        if playing:  # the cursor moves with the clock: every drawn frame shows a later moment
            self.timeline.tick()
        for hook in self.cursor_hooks:
            hook()
        span = self.time.time_span()
        self.time_range.sync(span[1] if span is not None else None, self.timeline.cursor)
        changed = self.canvas.changed(self.timeline.cursor) or self.pointer_input.wheel_due(time.monotonic())
        return changed or playing or self.actions.pending or self.status.bar_moved(self.timebar.stale)

    def work(self) -> None:
        """Everything of a frame but rendering: input, commands, widget updates, dialogs, chrome."""
        self.pointer_input.poll()
        self.pointer_input.apply_wheel()
        self.actions.run_queued()
        left = bool(dpg.is_mouse_button_down(dpg.mvMouseButton_Left))
        busy = self.dialog_open() or self.pointer_input.menu_shown() or self.pointer_input.drag is not None
        self.timebar.poll(self.canvas.pointer(), left, blocked=busy)
        at = self.timeline.cursor
        self.canvas.refresh(time.time() if at is None else at, at)  # the moment the widgets show
        self.dialogs.tick(self.files.request.dialog if self.files.request is not None else None)
        # What this changes is drawn by the frame rendered right after (`look` asked for it already).
        drag = self.pointer_input.drag
        self.canvas.draw(self.body_group, self.main, drag.item if drag is not None else None)
        self.timebar.fit(self.canvas.paint.window_size[0])
        self.timebar.draw()
        self.menus.sync()
        self.status.update(self.canvas.paint.window_size[0])

    def view_state(self) -> tuple[object, ...]:
        """What, when it changes, means the user is at work: widgets, selection, dialogs, drags, the file."""
        items, timeline = self.doc.items, self.timeline
        return (
            len(items),
            id(items[-1]) if items else 0,
            id(self.doc.selected),
            id(self.dialogs.current),
            id(self.files.request),
            self.pointer_input.drag is not None,
            self.doc.dirty,
            self.doc.path,
            self.canvas.paint.window_size,
            # Playback moves the cursor by itself: drawn at the data rate (`--data-fps`), not the input cap.
            None if timeline.playing else timeline.cursor,
            timeline.playing,
        )

    def dragging(self) -> bool:
        """Whether a widget is being moved or resized."""
        return self.pointer_input.drag is not None

    def dialog_open(self) -> bool:
        """Whether a dialog or the file dialog is open."""
        return self.dialogs.current is not None or self.files.request is not None

    def after_render(self) -> None:
        """After a rendered frame: the actions of the keys it saw pressed are queued (UI thread); a frame
        that used a key event keeps the loop rendering (Dear ImGui may hold more)."""
        if self.keys.after_frame():
            self.loop.note_key()

    # -- what the commands and the window share -----------------------------------------------------

    def _keys_blocked(self) -> bool:
        """Whether the keys belong to something else: a dialog, the context menu, a field being typed in."""
        typing = self.canvas.typing() or self.tree.typing()
        return self.dialog_open() or self.pointer_input.menu_shown() or typing

    def cancel(self) -> None:
        """Escape: close the context menu, or cancel the open dialog as its Cancel button would."""
        if self.pointer_input.menu_shown():
            self.pointer_input.hide_menu()
        elif self.files.request is not None:
            self.files.cancelled()
        elif self.dialogs.current is not None:
            self.dialogs.current.close()

    def use_source(self, source: DataSource, *, recording: bool) -> None:
        """Show `source` in place of the current data source: a recording opened, or live again."""
        self.time.use_source(source, recording=recording, bound=list(self.doc.refs))
        self._update_title()

    def _tree_room(self, shown: bool) -> None:
        """The tag tree shown or hidden: the canvas leaves room for it, or takes it back."""
        self.canvas.room_for("tree")(TREE_W + 8 if shown else 0)

    def set_status(self, text: str) -> None:
        """Show a message in the status bar."""
        self.status.say(text)

    def _update_title(self) -> None:
        if self.started:
            replay = self.time.replay_name
            base = self.title if replay is None else f"{self.title} \u2014 replay of {replay}"
            dpg.set_viewport_title(self.doc.title(base))

    # -- the document and the time cursor, as scripts and tests use them -----------------------------

    @property
    def source(self) -> DataSource:
        """The data source shown (the live engine, or a recording)."""
        return self.timeline.source

    @property
    def items(self) -> list[CanvasItem]:
        """The widgets in drawing order (last on top)."""
        return self.doc.items

    @property
    def dialog(self) -> Dialog | None:
        """The open dialog, or None."""
        return self.dialogs.current

    def add_widget(self, type_name: str, x: float, y: float, *, name: str | None = None) -> CanvasItem | None:
        """Place a new widget near (x, y) on the canvas (`Canvas.add_widget`)."""
        return self.canvas.add_widget(type_name, x, y, name=name)

    def apply_bindings(self, item: CanvasItem, bindings: tuple[Binding, ...]) -> None:
        """Point a widget at new series (see `CanvasDoc.set_bindings`: a topic may rename it)."""
        self.doc.set_bindings(item, bindings)

    def select(self, item: CanvasItem | None) -> None:
        """Highlight `item` (or nothing)."""
        self.canvas.select(item)

    def set_snap(self, on: bool) -> None:
        """Switch snap-to-grid on or off."""
        self.canvas.set_snap(on)

    def load(self, result: LoadResult, path: Path | None = None) -> None:
        """Replace the canvas with a loaded dashboard."""
        self.files.load(result, path)
