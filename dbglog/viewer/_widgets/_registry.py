"""The one widget registry: built-ins and plugins both arrive through the ``dbglog.widgets`` entry points."""

from __future__ import annotations

import importlib
import importlib.metadata
import re
from collections.abc import Iterator

from dbglog.viewer.widget_api import Widget

__all__ = ["BUILTIN_WIDGETS", "ENTRY_POINT_GROUP", "WidgetRegistry"]

ENTRY_POINT_GROUP = "dbglog.widgets"

BUILTIN_WIDGETS: dict[str, str] = {
    "plot": "dbglog.viewer._widgets._plot:PlotWidget",
    "dial": "dbglog.viewer._widgets._gauges:DialWidget",
    "knob": "dbglog.viewer._widgets._gauges:KnobWidget",
    "compass": "dbglog.viewer._widgets._gauges:CompassWidget",
    "thermo": "dbglog.viewer._widgets._gauges:ThermoWidget",
    "string": "dbglog.viewer._widgets._text:StringWidget",
    "led": "dbglog.viewer._widgets._text:LedWidget",
}
"""Entry-point name -> ``module:Class`` of the built-in widgets (mirrored in pyproject.toml)."""

_TYPE_NAME = re.compile(r"[a-z][a-z0-9_.-]{0,63}")


class WidgetRegistry:
    """Widget classes by type name, in toolbox order; problems with plugins are collected, never raised."""

    def __init__(self) -> None:
        self._classes: dict[str, type[Widget]] = {}
        self.origins: dict[str, str] = {}
        """Type name -> where the class came from (``builtin`` or the distribution's name)."""
        self.problems: list[str] = []
        """One message per plugin that could not be registered, for the UI to show."""

    def register(self, cls: object, *, name: str | None = None, origin: str = "builtin") -> bool:
        """Add a widget class; return False (and record why) when it is not a usable widget."""
        label = name or getattr(cls, "type_name", repr(cls))
        if not (isinstance(cls, type) and issubclass(cls, Widget)):
            self.problems.append(f"widget {label!r} from {origin}: {cls!r} is not a dbglog Widget class")
            return False
        type_name = getattr(cls, "type_name", None)
        if not isinstance(type_name, str) or not _TYPE_NAME.fullmatch(type_name):
            self.problems.append(
                f"widget {label!r} from {origin}: type_name {type_name!r} is not a valid name"
            )
            return False
        if name is not None and name != type_name:
            self.problems.append(
                f"widget {name!r} from {origin}: entry point name differs from type_name {type_name!r}"
            )
            return False
        if not isinstance(getattr(cls, "label", None), str):
            self.problems.append(f"widget {type_name!r} from {origin}: missing a 'label' string")
            return False
        if type_name in self._classes:
            self.problems.append(
                f"widget {type_name!r} from {origin}: already provided by {self.origins[type_name]}; ignored"
            )
            return False
        self._classes[type_name] = cls
        self.origins[type_name] = origin
        return True

    def get(self, type_name: str) -> type[Widget] | None:
        """Return the class registered as `type_name`, or None."""
        return self._classes.get(type_name)

    def names(self) -> list[str]:
        """Return the registered type names: built-ins in their fixed order, then plugins by name."""
        builtin = [n for n in BUILTIN_WIDGETS if n in self._classes]
        rest = sorted(n for n in self._classes if n not in BUILTIN_WIDGETS)
        return builtin + rest

    def __contains__(self, type_name: object) -> bool:
        return type_name in self._classes

    def __iter__(self) -> Iterator[type[Widget]]:
        return (self._classes[n] for n in self.names())

    def __len__(self) -> int:
        return len(self._classes)

    @classmethod
    def discover(cls, group: str = ENTRY_POINT_GROUP) -> WidgetRegistry:
        """Load every widget declared under the entry-point `group`; a failing plugin is recorded, not raised.

        Built-ins normally arrive through their own entry points; when dbglog runs from a source tree
        that was never installed they are loaded from `BUILTIN_WIDGETS` directly.
        """
        registry = cls()
        for ep in sorted(importlib.metadata.entry_points(group=group), key=lambda e: e.name):
            origin = (
                "builtin"
                if ep.name in BUILTIN_WIDGETS and ep.value == BUILTIN_WIDGETS[ep.name]
                else (ep.dist.name if ep.dist is not None else ep.value)
            )
            try:
                obj = ep.load()
            except Exception as exc:  # a broken plugin must not take the viewer down
                registry.problems.append(f"widget plugin {ep.name!r} ({ep.value}) failed to load: {exc!r}")
                continue
            registry.register(obj, name=ep.name, origin=origin)
        for name, target in BUILTIN_WIDGETS.items():
            if name not in registry:
                registry.register(_load_target(target), name=name)
        return registry

    @classmethod
    def builtin(cls) -> WidgetRegistry:
        """Return a registry of the built-in widgets only (no plugin discovery)."""
        registry = cls()
        for name, target in BUILTIN_WIDGETS.items():
            registry.register(_load_target(target), name=name)
        return registry


def _load_target(target: str) -> object:
    module, _, attr = target.partition(":")
    return getattr(importlib.import_module(module), attr)
