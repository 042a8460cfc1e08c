"""File commands of the viewer window: New, Open, Save, Save As, and the quit prompt for unsaved changes."""

from __future__ import annotations

import os
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import dearpygui.dearpygui as dpg

from dbglog.viewer._document._dashboard import (
    DashboardError,
    LoadResult,
    RawWidget,
    load_dashboard,
    save_dashboard,
)
from dbglog.viewer._ui._dialogs import Dialog, SaveAsDialog
from dbglog.viewer._ui._frame import CanvasItem
from dbglog.viewer._ui._quit import QuitDialog

if TYPE_CHECKING:
    from dbglog.viewer._ui._app import ViewerApp

__all__ = ["FileCommands", "FileRequest"]


@dataclass
class FileRequest:
    """An open file dialog (Open or Save As) and what to do after it."""

    item: int | str
    save: bool
    then: Callable[[], object] | None
    """Called after a successful Save As (the quit prompt's Save: then quit)."""
    dialog: SaveAsDialog | None = None
    """The Save As dialog (Open uses Dear PyGui's file dialog)."""


class FileCommands:
    """Open, save and quit for one window; the document is the window's `doc`."""

    def __init__(self, app: ViewerApp) -> None:
        self.app = app
        self.request: FileRequest | None = None
        """The open file dialog (Open or Save As), or None."""

    # -- the file dialogs ---------------------------------------------------------------------------

    def ask(self, *, save: bool, then: Callable[[], object] | None = None) -> None:
        """Open the file dialog; after a successful Save As, call `then` (cancelling calls nothing)."""
        self.close_dialog()
        path = self.app.doc.path
        if save:
            dialog = SaveAsDialog(
                path.parent if path else Path.cwd(),
                path.name if path else "dashboard.json",
                lambda p: self.chosen(str(p)),
                self._save_as_closed,
            )
            self.request = FileRequest(dialog.window, save, then, dialog)
            return
        with dpg.file_dialog(
            label="Open dashboard",
            width=700,
            height=450,
            modal=True,
            callback=lambda _, a, *__: self.chosen(a.get("file_path_name") if isinstance(a, dict) else None),
            cancel_callback=lambda *_: self.cancelled(),
            default_path=str(path.parent if path else Path.cwd()),
        ) as item:
            dpg.add_file_extension(".json", color=(86, 166, 240, 255))
            dpg.add_file_extension(".*")
        self.request = FileRequest(item, save, then)

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
            self.app.set_status("not saved: the viewer stays open")

    def _save_as_closed(self, dialog: Dialog) -> None:
        # Closed by its Cancel or close button, or Escape (choosing a file forgets the request first).
        if self.request is not None and self.request.dialog is dialog:
            self.cancelled()

    def close_dialog(self) -> None:
        """Remove the file dialog, if one is open, doing nothing else."""
        request, self.request = self.request, None
        if request is None:
            return
        if request.dialog is not None:
            request.dialog.close()
        elif dpg.does_item_exist(request.item):
            dpg.delete_item(request.item)

    # -- commands -----------------------------------------------------------------------------------

    def load(self, result: LoadResult, path: Path | None = None) -> None:
        """Replace the canvas with a loaded dashboard."""
        app, doc = self.app, self.app.doc
        app.clear()
        for config in result.dashboard.widgets:
            cls = app.registry.get(config.type) if config.editable is not None else None
            if isinstance(config, RawWidget) and not result.legacy and config.type != "?":
                # The placeholder says what is missing: a plugin that failed to load, or none installed.
                config = RawWidget(config.data, app.registry.missing_reason(config.type))
            doc.add(
                CanvasItem(
                    config,
                    cls,
                    app.canvas,
                    app.frame_theme,
                    publisher=app.publisher,
                    host=app.host,
                    time_range=app.time_range,
                )
            )
        # Widgets were left out (too many, too deep, unsafe text): saving over the file would lose them,
        # so it opens untitled and Save asks for a name (docs/viewer.md, Dashboard files).
        doc.opened(result.dashboard, path if result.complete else None, result.messages)
        app.show_grid_settings()
        kind = "legacy ROSDashboard file" if result.legacy else "dashboard"
        note = f"; {len(result.messages)} problem(s): View \u203a Load messages" if result.messages else ""
        if not result.complete:
            note += f"; {result.left_out} widget(s) left out, so it is untitled: Save asks for a name"
        app.set_status(f"opened {kind} {path.name if path else ''}{note}")

    def open_path(self, path: str | os.PathLike[str]) -> bool:
        """Open a dashboard file; on failure show why and keep the current dashboard."""
        p = Path(path)
        try:
            result = load_dashboard(p, self.app.registry.get)
        except DashboardError as exc:
            self.app.show_message("Cannot open dashboard", str(exc))
            self.app.set_status(f"open failed: {exc}")
            return False
        self.load(result, p)
        return True

    def save(self, path: str | os.PathLike[str] | None = None) -> bool:
        """Save to `path` (or the current file; with neither, ask for one)."""
        doc = self.app.doc
        if path is None and doc.path is None:
            self.ask(save=True)
            return False
        target = Path(path) if path is not None else doc.path
        assert target is not None
        try:
            save_dashboard(doc.dashboard(), target)
        except DashboardError as exc:
            self.app.show_message("Cannot save dashboard", str(exc))
            self.app.set_status(f"save failed: {exc}")
            return False
        doc.saved(target)
        self.app.set_status(f"saved {target}")
        return True

    def new(self, path: Path | None = None) -> None:
        """Start an empty dashboard (that Save writes to `path`, when given)."""
        self.app.clear()
        self.app.doc.renew(path)

    # -- quitting -----------------------------------------------------------------------------------

    def request_quit(self) -> QuitDialog | None:
        """Close the window as the user asked: at once with nothing unsaved, else open the quit prompt."""
        app = self.app
        if not app.started or app.quitting:
            return None
        if not app.doc.dirty:
            app.quit()
            return None
        if isinstance(app.dialog, QuitDialog):
            return app.dialog
        app.close_dialog()  # one modal at a time: an open dialog is cancelled as by its Cancel
        self.close_dialog()
        if dpg.does_item_exist(app.menu):
            dpg.hide_item(app.menu)
        path = app.doc.path
        dialog = QuitDialog(path.name if path else None, self._save_and_quit, app.quit, app.dialog_closed)
        app.open_dialog(dialog)
        return dialog

    def _save_and_quit(self) -> None:
        if self.app.doc.path is None:
            self.ask(save=True, then=self.app.quit)  # Save As; cancelling it keeps the viewer open
        elif self.save():
            self.app.quit()
