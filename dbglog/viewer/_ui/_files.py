"""File commands of the viewer window: New, Open, Save, Save As, and the quit prompt for unsaved changes.

`FileCommands` is the logic over the dashboard document, handed the window's few services (`FileWindow`)
and its prompts (`FilePrompts`): it runs without a window. `FileDialogs` is the prompts in Dear PyGui.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import dearpygui.dearpygui as dpg

from dbglog.viewer._document._canvas_doc import CanvasDoc
from dbglog.viewer._document._dashboard import DashboardError, LoadResult, load_dashboard, save_dashboard
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._dialogs import SaveAsDialog
from dbglog.viewer._ui._modal import Dialogs
from dbglog.viewer._ui._quit import QuitDialog
from dbglog.viewer._widgets import WidgetRegistry

__all__ = [
    "Chosen",
    "FileCanvas",
    "FileCommands",
    "FileDialogs",
    "FilePrompts",
    "FileRequest",
    "FileWindow",
    "Opened",
]

Chosen = Callable[[str | None], None]
"""A file dialog's OK: called with the path chosen."""
Opened = tuple[int | str, SaveAsDialog | None]
"""A file dialog opened: its Dear PyGui item, and the Save As dialog (None for Open)."""


@dataclass
class FileRequest:
    """An open file dialog (Open or Save As) and what to do after it."""

    item: int | str
    save: bool
    then: Callable[[], object] | None
    """Called after a successful Save As (the quit prompt's Save: then quit)."""
    dialog: SaveAsDialog | None = None
    """The Save As dialog (Open uses Dear PyGui's file dialog)."""


class FileWindow(Protocol):
    """What the file commands need of the window."""

    @property
    def running(self) -> bool:
        """Whether the window is open and not closing."""
        ...

    def set_status(self, text: str) -> None:
        """Show a message in the status bar."""
        ...

    def quit(self) -> None:
        """Close the window now, whatever is unsaved."""
        ...


class FileCanvas(Protocol):
    """What the file commands need of the canvas (`Canvas`)."""

    def load(self, result: LoadResult) -> None:
        """Put a loaded dashboard's widgets on the canvas in place of every widget there."""
        ...

    def clear(self) -> None:
        """Remove every widget."""
        ...

    def show_grid_settings(self) -> None:
        """Show the document's grid settings (after a dashboard was opened)."""
        ...


class FilePrompts(Protocol):
    """The file dialog, the quit prompt and messages (`FileDialogs` in the window)."""

    def message(self, title: str, message: str) -> object:
        """Show a message in a dialog (why a file could not be opened or saved)."""
        ...

    def ask_path(
        self, save: bool, start: Path | None, chosen: Chosen, cancelled: Callable[[], None]
    ) -> Opened:
        """Open the Open (or, with `save`, the Save As) dialog at the file `start` (None: untitled)."""
        ...

    def close_path(self, request: FileRequest) -> None:
        """Remove a file dialog."""
        ...

    def open_quit_prompt(self) -> object | None:
        """The quit prompt when it is open, else None."""
        ...

    def ask_quit(
        self, name: str | None, on_save: Callable[[], object], on_discard: Callable[[], object]
    ) -> object:
        """Open the quit prompt for the dashboard file `name` (one modal at a time: others close)."""
        ...


class FileCommands:
    """Open, save and quit for one window's dashboard document.

    Args:
        doc: the dashboard document.
        registry: the widget types (a dashboard file is read against them).
        canvas: the widgets on the canvas.
        window: the window's services.
        prompts: its file dialog, quit prompt and messages.
    """

    def __init__(
        self,
        doc: CanvasDoc[Any],
        registry: WidgetRegistry,
        canvas: FileCanvas,
        window: FileWindow,
        prompts: FilePrompts,
    ) -> None:
        self.doc, self.registry, self.canvas, self.window, self.prompts = (
            doc,
            registry,
            canvas,
            window,
            prompts,
        )
        self.request: FileRequest | None = None
        """The open file dialog (Open or Save As), or None."""

    # -- the file dialogs ---------------------------------------------------------------------------

    def ask(self, *, save: bool, then: Callable[[], object] | None = None) -> None:
        """Open the file dialog; after a successful Save As, call `then` (cancelling calls nothing)."""
        self.close_dialog()
        item, dialog = self.prompts.ask_path(save, self.doc.path, self.chosen, self.cancelled)
        self.request = FileRequest(item, save, then, dialog)

    def chosen(self, path: str | None) -> None:
        """The file dialog's OK: open or save `path` (then go on as asked, e.g. quit after saving)."""
        request = self.request
        self.close_dialog()
        if request is None or not path:
            return
        if not request.save:
            self.open_path(path)
        elif self.save(path) and request.then is not None:
            request.then()

    def cancelled(self) -> None:
        """The file dialog's Cancel: nothing happens (after the quit prompt's Save, the viewer stays open)."""
        request = self.request
        self.close_dialog()
        if request is not None and request.then is not None:
            self.window.set_status("not saved: the viewer stays open")

    def close_dialog(self) -> None:
        """Remove the file dialog, if one is open, doing nothing else."""
        request, self.request = self.request, None
        if request is not None:
            self.prompts.close_path(request)

    # -- commands -----------------------------------------------------------------------------------

    def load(self, result: LoadResult, path: Path | None = None) -> None:
        """Replace the canvas with a loaded dashboard."""
        self.canvas.load(result)
        # Widgets were left out (too many, too deep, unsafe text): saving over the file would lose them,
        # so it opens untitled and Save asks for a name (docs/viewer.md, Dashboard files).
        self.doc.opened(result.dashboard, path if result.complete else None, result.messages)
        self.canvas.show_grid_settings()
        kind = "legacy ROSDashboard file" if result.legacy else "dashboard"
        note = f"; {len(result.messages)} problem(s): View \u203a Load messages" if result.messages else ""
        if not result.complete:
            note += f"; {result.left_out} widget(s) left out, so it is untitled: Save asks for a name"
        self.window.set_status(f"opened {kind} {path.name if path else ''}{note}")

    def open_path(self, path: str | os.PathLike[str]) -> bool:
        """Open a dashboard file; on failure show why and keep the current dashboard."""
        p = Path(path)
        try:
            result = load_dashboard(p, self.registry.get)
        except DashboardError as exc:
            self.prompts.message("Cannot open dashboard", str(exc))
            self.window.set_status(f"open failed: {exc}")
            return False
        self.load(result, p)
        return True

    def save(self, path: str | os.PathLike[str] | None = None) -> bool:
        """Save to `path` (or the current file; with neither, ask for one)."""
        doc = self.doc
        if path is None and doc.path is None:
            self.ask(save=True)
            return False
        target = Path(path) if path is not None else doc.path
        assert target is not None
        try:
            save_dashboard(doc.dashboard(), target)
        except DashboardError as exc:
            self.prompts.message("Cannot save dashboard", str(exc))
            self.window.set_status(f"save failed: {exc}")
            return False
        doc.saved(target)
        self.window.set_status(f"saved {target}")
        return True

    def new(self, path: Path | None = None) -> None:
        """Start an empty dashboard (that Save writes to `path`, when given)."""
        self.canvas.clear()
        self.doc.renew(path)

    # -- quitting -----------------------------------------------------------------------------------

    def request_quit(self) -> object | None:
        """Close the window as the user asked: at once with nothing unsaved, else open the quit prompt (and
        return it)."""
        if not self.window.running:
            return None
        if not self.doc.dirty:
            self.window.quit()
            return None
        open_prompt = self.prompts.open_quit_prompt()
        if open_prompt is not None:
            return open_prompt
        self.close_dialog()
        path = self.doc.path
        return self.prompts.ask_quit(path.name if path else None, self._save_and_quit, self.window.quit)

    def _save_and_quit(self) -> None:
        if self.doc.path is None:
            self.ask(save=True, then=self.window.quit)  # Save As; cancelling it keeps the viewer open
        elif self.save():
            self.window.quit()

    def register(self, actions: Actions, *, modal: Callable[[], bool]) -> None:
        """Register the file commands (Save and Save As not while a dialog is open: `modal`)."""

        def unless_modal(command: Callable[[], object]) -> Callable[[], None]:
            def run() -> None:
                if not modal() and self.request is None:
                    command()

            return run

        add = actions.register
        add("file.new", "New", "Start an empty dashboard", self.new)
        add("file.open", "Open\u2026", "Open a dashboard file", lambda: self.ask(save=False))
        add(
            "file.save",
            "Save",
            "Save the dashboard (Save As for a new one)",
            unless_modal(self.save),
            keys=("Ctrl+S",),
        )
        add(
            "file.save_as",
            "Save As\u2026",
            "Save the dashboard to a file you name",
            unless_modal(lambda: self.ask(save=True)),
            keys=("Ctrl+Shift+S",),
        )
        add(
            "file.quit",
            "Quit",
            "Close the viewer (asks first about unsaved changes)",
            self.request_quit,
            keys=("Ctrl+Q",),
        )


class FileDialogs:
    """The file dialogs and the quit prompt in Dear PyGui (`FilePrompts`).

    Args:
        dialogs: the window's dialogs (the quit prompt is one; it closes the others).
        hide_menus: hides the context menu (a modal takes the window).
    """

    def __init__(self, dialogs: Dialogs, hide_menus: Callable[[], None]) -> None:
        self.dialogs = dialogs
        self.hide_menus = hide_menus

    def message(self, title: str, message: str) -> object:
        """Show a message in a dialog."""
        return self.dialogs.message(title, message)

    def ask_path(
        self, save: bool, start: Path | None, chosen: Chosen, cancelled: Callable[[], None]
    ) -> Opened:
        """Open Save As (the viewer's own dialog) or Open (Dear PyGui's file dialog)."""
        folder = start.parent if start else Path.cwd()
        if save:
            # Closed by its Cancel or close button, or Escape: cancelled (choosing a file forgets the
            # request before closing it, so that cancelling then does nothing).
            dialog = SaveAsDialog(
                folder,
                start.name if start else "dashboard.json",
                lambda p: chosen(str(p)),
                lambda _d: cancelled(),
            )
            return dialog.window, dialog
        with dpg.file_dialog(
            label="Open dashboard",
            width=700,
            height=450,
            modal=True,
            callback=lambda _, a, *__: chosen(a.get("file_path_name") if isinstance(a, dict) else None),
            cancel_callback=lambda *_: cancelled(),
            default_path=str(folder),
        ) as item:
            dpg.add_file_extension(".json", color=(86, 166, 240, 255))
            dpg.add_file_extension(".*")
        return item, None

    def close_path(self, request: FileRequest) -> None:
        """Remove a file dialog."""
        if request.dialog is not None:
            request.dialog.close()
        elif dpg.does_item_exist(request.item):
            dpg.delete_item(request.item)

    def open_quit_prompt(self) -> QuitDialog | None:
        """The quit prompt when it is open."""
        current = self.dialogs.current
        return current if isinstance(current, QuitDialog) else None

    def ask_quit(
        self, name: str | None, on_save: Callable[[], object], on_discard: Callable[[], object]
    ) -> QuitDialog:
        """Open the quit prompt; an open dialog is cancelled as by its Cancel (one modal at a time)."""
        self.dialogs.close()
        self.hide_menus()
        return self.dialogs.open(QuitDialog(name, on_save, on_discard, self.dialogs.closed))
