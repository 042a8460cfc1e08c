"""The window's one open dialog (one modal at a time), and opening the widget dialogs and messages.

A new dialog is a `Dialog` subclass (in `_dialogs`, or a module of its own like `_plotnumber`), opened by
a command through `Dialogs.open`; its close callback is `Dialogs.closed`.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import TypeVar

from dbglog._ros._params import ParamValue
from dbglog.viewer._document._canvas_doc import CanvasDoc, TopicSetup
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._dialogs import Dialog, MessageDialog, PropertiesDialog, RenameDialog, TopicDialog
from dbglog.viewer._ui._frame import CanvasItem

__all__ = ["Dialogs"]

D = TypeVar("D", bound=Dialog)


class Dialogs:
    """The open dialog of one window, and the dialogs of its widgets.

    Args:
        doc: the dashboard (a dialog's edits change it: topic setup, properties, rename).
        say: shows a message in the status bar (a dialog's error while it runs).
    """

    def __init__(self, doc: CanvasDoc[CanvasItem], say: Callable[[str], None]) -> None:
        self.doc = doc
        self.say = say
        self.current: Dialog | None = None
        """The open dialog, or None."""
        self.parameters: Callable[[], list[tuple[str, ParamValue]]] = list
        """The nodes' parameters known (``/pid_node:kp`` and value), for Topic setup's suggestions."""

    def open(self, dialog: D) -> D:
        """Make `dialog` the open one (one modal at a time: open it after `close`)."""
        self.current = dialog
        return dialog

    def closed(self, dialog: Dialog) -> None:
        """A dialog's close callback: it is no longer the open one."""
        if self.current is dialog:
            self.current = None

    def close(self) -> None:
        """Cancel the open dialog, if any (as its Cancel button would)."""
        if self.current is not None:
            self.current.close()

    def close_of(self, item: CanvasItem) -> None:
        """Cancel the open dialog if it edits `item` (a widget deleted or replaced)."""
        if self.current is not None and getattr(self.current, "item", None) is item:
            self.current.close()

    def tick(self, *dialogs: Dialog | None) -> None:
        """Once a frame: let the open dialog (and `dialogs`, such as a file dialog) do their work."""
        for dialog in (self.current, *dialogs):
            if dialog is None:
                continue
            try:
                dialog.tick()
            except Exception as exc:  # a dialog must never stop the render loop
                self.say(f"dialog error: {exc!r}")

    # -- the dialogs ----------------------------------------------------------------------------------

    def message(self, title: str, message: str) -> MessageDialog:
        """Show a message in a modal dialog."""
        self.close()
        return self.open(MessageDialog(title, message, self.closed))

    def load_messages(self) -> MessageDialog:
        """Show what could not be loaded from the current dashboard as it was."""
        text = "\n".join(self.doc.load_messages) or "The dashboard loaded without problems."
        return self.message("Load messages", text)

    def topic(self, item: CanvasItem) -> TopicDialog | None:
        """Open the topic setup for `item` (placeholders have none)."""
        if item.widget_cls is None:
            return None
        self.close()
        return self.open(TopicDialog(item, TopicSetup(self.doc, item), self.closed, self.parameters))

    def properties(self, item: CanvasItem) -> PropertiesDialog | None:
        """Open the properties dialog for `item`."""
        if item.widget_cls is None:
            return None
        self.close()
        return self.open(PropertiesDialog(item, self._closed_dirty))

    def rename(self, item: CanvasItem) -> RenameDialog:
        """Open the rename dialog for `item`."""
        self.close()
        return self.open(RenameDialog(item, self._closed_dirty))

    def _closed_dirty(self, dialog: Dialog) -> None:
        self.closed(dialog)
        self.doc.mark_dirty()

    def move_highlight(self, step: int) -> None:
        """Up/Down in Topic setup or Watch a variable: the previous/next suggestion (Enter takes it)."""
        move = getattr(self.current, "move_highlight", None)
        if callable(move):
            move(step)

    def register(self, actions: Actions) -> None:
        """Register the commands of the dialogs (Load messages; the arrow keys in Topic setup)."""
        add = actions.register
        add("view.load_messages", "Load messages\u2026", "What could not be loaded", self.load_messages)
        for name, where, step in (("topic.up", "Up", -1), ("topic.down", "Down", 1)):
            move = functools.partial(self.move_highlight, step)
            add(
                name,
                f"Topic {where.lower()}",
                f"Topic setup: the suggestion {where.lower()}",
                move,
                keys=(where,),
            )
