"""The quit prompt, asked before the window closes with unsaved changes: Save, Don't save, Cancel."""

from __future__ import annotations

from collections.abc import Callable

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui._dialogs import Dialog
from dbglog.viewer._ui._theme import DIM

__all__ = ["QuitDialog", "quit_question"]

WIDTH = 440
BUTTON_W = 120


def quit_question(name: str | None) -> str:
    """The prompt's question for a dashboard file named `name` (None: not saved to a file yet)."""
    return f"Save changes to {name} before closing?" if name else "Save the new dashboard before closing?"


class QuitDialog(Dialog):
    """Asks whether to save before closing; Cancel, Escape and the title bar's close keep the viewer open.

    Args:
        name: the dashboard file's name, or None when it has none yet.
        on_save: called after the dialog closed when the user picks Save.
        on_discard: called after the dialog closed when the user picks Don't save.
        on_close: called whenever the dialog closes (with the dialog), as for every `Dialog`.
    """

    def __init__(
        self,
        name: str | None,
        on_save: Callable[[], object],
        on_discard: Callable[[], object],
        on_close: Callable[[Dialog], None],
    ) -> None:
        super().__init__("Unsaved changes", WIDTH, on_close)
        self.question = quit_question(name)
        self.choice = ""
        """What the user picked: "save", "discard", "cancel", or empty while the prompt is open."""
        dpg.add_text(self.question, parent=self.window, wrap=WIDTH - 30)
        dpg.add_text(
            "Your changes are lost if you don't save them.", parent=self.window, wrap=WIDTH - 30, color=DIM
        )
        dpg.add_spacer(height=6, parent=self.window)
        with dpg.group(horizontal=True, parent=self.window):
            self.save_button = dpg.add_button(
                label="Save", width=BUTTON_W, callback=lambda *_: self._pick("save", on_save)
            )
            self.discard_button = dpg.add_button(
                label="Don't save", width=BUTTON_W, callback=lambda *_: self._pick("discard", on_discard)
            )
            self.cancel_button = dpg.add_button(
                label="Cancel", width=BUTTON_W, callback=lambda *_: self.close()
            )

    def _pick(self, choice: str, action: Callable[[], object]) -> None:
        if self.closed:
            return
        self.choice = choice
        self.close()
        action()

    def close(self) -> None:
        """Remove the prompt; closing it without a choice (Cancel, Escape, its close button) cancels."""
        if not self.choice:
            self.choice = "cancel"
        super().close()
