"""Watches in the window: "Watch a variable…", and the dashboard's watches kept armed with their state shown.

`WatchKeeper` owns the window's `WatchService` (made when first needed: a dashboard with a watch, or the
dialog). Once a frame (a frame hook) it hands the service the watches the widgets hold, so a watch is
armed when its dashboard opens or its widget is added, armed again in a process that restarts, and
disarmed when its last widget goes or the window closes; it puts each watch's `WatchReport` on its widgets
(their status pill and tooltip) and binds a widget to the topics its watch publishes on. Nothing here
waits on the network.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable
from pathlib import Path
from typing import Final, Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._data._model import Binding
from dbglog.viewer._document._canvas_doc import CanvasDoc
from dbglog.viewer._document._dashboard import WatchConfig, WidgetConfig
from dbglog.viewer._publishing._watches import WatchReport, WatchService
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._frame import CanvasItem
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._watchdialog import WatchDialog, WatchPlan
from dbglog.viewer._widgets._geometry import Rect
from dbglog.watch.client import DEFAULT_MAX_CPU, WatchSpec

__all__ = ["CODE_FONTS", "WatchKeeper", "watch_bindings", "watch_spec"]

CODE_FONTS: Final = (
    "/usr/share/fonts/truetype/dejavu/DejaVuSansMono.ttf",
    "/usr/share/fonts/TTF/DejaVuSansMono.ttf",
    "/usr/share/fonts/dejavu/DejaVuSansMono.ttf",
    "/System/Library/Fonts/Menlo.ttc",
    "C:/Windows/Fonts/consola.ttf",
)
"""Monospaced fonts for the source in the dialog (the first that exists; else the window's font)."""
OFF: Final = WatchReport("off", "not armed: a recording is shown (watches are armed by the live viewer)")


def watch_spec(watch: WatchConfig) -> WatchSpec:
    """The client's spec of a dashboard's watch."""
    return WatchSpec(
        watch.file,
        watch.line,
        watch.exprs,
        when=watch.when or None,
        throttle=watch.throttle,
        node=watch.node or None,
        max_cpu=DEFAULT_MAX_CPU if watch.max_cpu is None else watch.max_cpu / 100.0,
    )


def watch_bindings(topics: tuple[str, ...], max_bindings: int) -> tuple[Binding, ...]:
    """A widget's bindings to its watch's topics (as many as it shows)."""
    return tuple(Binding(topic, "data") for topic in topics[: max(1, max_bindings)])


def _watch_of(item: CanvasItem) -> WatchConfig | None:
    config = item.config
    return config.watch if isinstance(config, WidgetConfig) else None


class WidgetPlacer(Protocol):
    """Where the keeper puts a watched widget: the canvas."""

    def view_rect(self) -> Rect:
        """The part of the canvas in view (new widgets go there)."""
        ...

    def add_widget(self, type_name: str, x: float, y: float, *, name: str | None = None) -> CanvasItem | None:
        """Place a new widget of `type_name` near canvas point (x, y) with a name; return it (None: no such
        type)."""
        ...


class WatchKeeper:
    """The window's watches: the "Watch a variable…" command and each widget's watch kept armed.

    Args:
        doc: the dashboard (its widgets and their watches).
        dialogs: the window's dialogs.
        canvas: places the new widgets, in view.
        say: shows a message in the status bar.
        wake: asks the window for a frame (an answer came while nothing else changed).
        replay: True for a window on a recording (no ROS): its watches are not armed.
        service: the watch service (default: one of its own, started when first needed).
    """

    def __init__(
        self,
        doc: CanvasDoc[CanvasItem],
        dialogs: Dialogs,
        canvas: WidgetPlacer,
        *,
        say: Callable[[str], None],
        wake: Callable[[], None],
        replay: bool = False,
        service: WatchService[WatchConfig] | None = None,
    ) -> None:
        self.doc, self.dialogs = doc, dialogs
        self.canvas, self.say, self.wake = canvas, say, wake
        self.live = not replay
        self.service: WatchService[WatchConfig] = service if service is not None else WatchService()
        self._pairs: list[tuple[int, WatchConfig]] = []
        """The watched widgets (by identity) and their watches, as the service was last given them."""
        self._version = -1
        """The service's version the widgets' notes show."""
        self._shown: weakref.WeakKeyDictionary[CanvasItem, tuple[str, ...]] = weakref.WeakKeyDictionary()
        """Widget -> the watch topics last bound (a change of them binds again; a Topic setup stays)."""
        self._code_font: int | str | None = None
        self._font_tried = False

    def register(self, actions: Actions) -> None:
        """Register "Watch a variable…"."""
        actions.register(
            "watch.add",
            "Watch a variable\u2026",
            "Plot a variable of a running Python program at a line of its code",
            self.open_dialog,
            keys=("Ctrl+Shift+W",),
            scope="canvas",
        )

    def open_dialog(self) -> WatchDialog | None:
        """Open "Watch a variable…" (the service starts looking for processes)."""
        if not self.live:
            self.dialogs.message(
                "Watch a variable",
                "Watches need the live viewer: this window shows a recording (dbglog view --replay).",
            )
            return None
        self.dialogs.close()
        self.service.start()
        dialog = WatchDialog(self.service, self.add, self.dialogs.closed, code_font=self._font())
        return self.dialogs.open(dialog)

    def add(self, plan: WatchPlan) -> CanvasItem | None:
        """Add the widget the dialog asked for, in view, with its watch (armed at the next frame)."""
        view = self.canvas.view_rect()
        name = self.doc.unique_name(plan.name)
        item = self.canvas.add_widget(plan.type_name, view.x + 40, view.y + 40, name=name)
        if item is None:
            return None
        item.set_watch(plan.watch)
        item.note = WatchReport("starting", f"arming {plan.watch.title}")
        self.say(f"watching {plan.watch.title}: the widget fills as the line runs")
        return item

    # -- each frame -----------------------------------------------------------------------------------------

    def poll(self) -> None:
        """A frame hook: hand the service the widgets' watches, show their states, bind their topics."""
        watched = [(item, w) for item in self.doc.items if (w := _watch_of(item)) is not None]
        if not self.live:
            for item, _w in watched:
                if item.note != OFF:
                    item.note = OFF
            return
        dialog = self.dialogs.current
        if isinstance(dialog, WatchDialog) and dialog.news():
            self.wake()
        if not watched and not self.service.started:
            return
        pairs = [(id(item), w) for item, w in watched]
        if pairs != self._pairs:  # a widget came, went, or changed type: the service gets the new set
            self._pairs, self._version = pairs, -1
            self.service.keep({w: watch_spec(w) for _item, w in watched})
        if self.service.version == self._version:
            return
        self._version = self.service.version
        for item, w in watched:
            report = self.service.report(w)
            if item.note != report:
                item.note = report
            self._bind(item, report)

    def _bind(self, item: CanvasItem, report: WatchReport) -> None:
        """Bind a widget to its watch's topics when they change (the widget's own bindings stay otherwise)."""
        if not report.topics or self._shown.get(item) == report.topics or item.widget_cls is None:
            return
        self._shown[item] = report.topics
        bindings = watch_bindings(report.topics, item.widget_cls.max_bindings)
        if item.bindings != bindings and item in self.doc.items:  # derived from the watch: not an edit
            self.doc.set_bindings(item, bindings, edit=False)

    def close(self) -> None:
        """Disarm every watch and stop the service (the window closes)."""
        self.service.close()

    def _font(self) -> int | str | None:
        """The monospaced font for the source (loaded once, when the dialog first opens)."""
        if not self._font_tried:
            self._font_tried = True
            path = next((p for p in CODE_FONTS if Path(p).is_file()), None)
            if path is not None:
                with dpg.font_registry():
                    self._code_font = dpg.add_font(path, 14)
        return self._code_font
