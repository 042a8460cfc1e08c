"""Valid plugin classes that raise at run time: in update, in create, or in resize."""

from __future__ import annotations

from collections.abc import Sequence

import dearpygui.dearpygui as dpg

from dbglog.viewer.widget_api import SeriesSnapshot, ValueKind, Widget


class RaisesInUpdateWidget(Widget):
    """Shows the first value, then raises on the next update (a bug that shows up with live data)."""

    type_name = "raises_update"
    label = "Raises in update"
    accepts = frozenset({ValueKind.NUMBER})

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Show a text."""
        self.text = dpg.add_text("raises soon", parent=parent)
        self.calls = 0

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Raise from the second call on."""
        self.calls += 1
        if self.calls > 1:
            raise ZeroDivisionError("plugin bug in update")
        dpg.set_value(self.text, f"value {snapshots[0].last if snapshots else None}")


class RaisesInCreateWidget(Widget):
    """Raises while building its items."""

    type_name = "raises_create"
    label = "Raises in create"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Add one item, then raise."""
        dpg.add_text("half built", parent=parent)
        raise KeyError("plugin bug in create")

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Never reached."""


class RaisesInResizeWidget(Widget):
    """Draws fine, raises when resized."""

    type_name = "raises_resize"
    label = "Raises in resize"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Show a text."""
        dpg.add_text("resize me", parent=parent)

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Draw nothing."""

    def resize(self, width: int, height: int) -> None:
        """Raise."""
        raise ValueError("plugin bug in resize")
