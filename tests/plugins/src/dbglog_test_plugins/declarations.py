"""Plugin classes with bad declarations: the registry must reject each with a clear reason."""

from __future__ import annotations

from collections.abc import Sequence

from dbglog.viewer.widget_api import Property, PropKind, SeriesSnapshot, Widget


class NotAWidget:
    """Not a subclass of `Widget` at all."""

    type_name = "not_a_widget"
    label = "Not a widget"


class _Drawn(Widget):
    """A minimal valid body, so that only the declaration is wrong in the subclasses."""

    type_name = "drawn"
    label = "Drawn"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build nothing."""

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Draw nothing."""


class WrongNameWidget(_Drawn):
    """Its type_name differs from the entry point's name."""

    type_name = "something_else"
    label = "Wrong name"


class BadDefaultWidget(_Drawn):
    """A property whose default is outside its own bounds."""

    type_name = "bad_default"
    label = "Bad default"
    properties = (Property("level", PropKind.NUMBER, 50.0, minimum=0, maximum=10),)


class NoUpdateWidget(Widget):
    """Forgets to implement `update`."""

    type_name = "no_update"
    label = "No update"

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Build nothing."""
