"""The one widget registry: built-ins and plugins both arrive through the ``dbglog.widgets`` entry points.

A plugin that cannot be imported, or whose class does not declare a usable widget, is recorded in
`WidgetRegistry.problems` (shown in the viewer's toolbox and printed by ``dbglog view``) and left out;
it never raises into the viewer.
"""

from __future__ import annotations

import importlib
import importlib.metadata
import inspect
import re
from collections.abc import Iterator

from dbglog.viewer.widget_api import Property, PropertyError, PropKind, ValueKind, Widget

__all__ = ["BUILTIN_WIDGETS", "ENTRY_POINT_GROUP", "MAX_BINDINGS", "WidgetRegistry", "declaration_problem"]

ENTRY_POINT_GROUP = "dbglog.widgets"

BUILTIN_WIDGETS: dict[str, str] = {
    "plot": "dbglog.viewer._widgets._plot:PlotWidget",
    "dial": "dbglog.viewer._widgets._gauges:DialWidget",
    "knob": "dbglog.viewer._widgets._gauges:KnobWidget",
    "compass": "dbglog.viewer._widgets._gauges:CompassWidget",
    "thermo": "dbglog.viewer._widgets._gauges:ThermoWidget",
    "string": "dbglog.viewer._widgets._text:StringWidget",
    "led": "dbglog.viewer._widgets._text:LedWidget",
    "states": "dbglog.viewer._widgets._states:StatesWidget",
    "log": "dbglog.viewer._widgets._log:LogWidget",
    "toggle": "dbglog.viewer._widgets._controls:ToggleWidget",
    "slider": "dbglog.viewer._widgets._controls:SliderWidget",
    "button": "dbglog.viewer._widgets._controls:ButtonWidget",
    "text_field": "dbglog.viewer._widgets._controls:TextFieldWidget",
    "publish": "dbglog.viewer._widgets._controls:PublishWidget",
}
"""Entry-point name -> ``module:Class`` of the built-in widgets (mirrored in pyproject.toml)."""

_TYPE_NAME = re.compile(r"[a-z][a-z0-9_.-]{0,63}")
_PROP_NAME = re.compile(r"[a-z_][a-z0-9_]{0,63}")
MAX_BINDINGS = 16
"""The most series one widget may declare (`Widget.max_bindings`)."""


class WidgetRegistry:
    """Widget classes by type name, in toolbox order; problems with plugins are collected, never raised."""

    def __init__(self) -> None:
        self._classes: dict[str, type[Widget]] = {}
        self.origins: dict[str, str] = {}
        """Type name -> where the class came from (``builtin`` or the distribution's name)."""
        self.problems: list[str] = []
        """One message per plugin that could not be registered, for the UI to show."""
        self.failed: dict[str, str] = {}
        """Type name -> why an installed plugin of that name is unusable (for placeholders)."""

    def register(self, cls: object, *, name: str | None = None, origin: str = "builtin") -> bool:
        """Add a widget class; return False (and record why) when it is not a usable widget."""
        label = str(name or getattr(cls, "type_name", repr(cls)))
        if not (isinstance(cls, type) and issubclass(cls, Widget)):
            return self._reject(label, origin, f"{cls!r} is not a dbglog Widget class")
        type_name = getattr(cls, "type_name", None)
        if not isinstance(type_name, str) or not _TYPE_NAME.fullmatch(type_name):
            return self._reject(label, origin, f"type_name {type_name!r} is not a valid name")
        if name is not None and name != type_name:
            return self._reject(label, origin, f"entry point name differs from type_name {type_name!r}")
        problem = declaration_problem(cls)
        if problem:
            return self._reject(label, origin, problem)
        if type_name in self._classes:
            self.problems.append(
                f"widget {type_name!r} from {origin}: already provided by {self.origins[type_name]}; ignored"
            )
            return False
        self._classes[type_name] = cls
        self.origins[type_name] = origin
        return True

    def _reject(self, label: str, origin: str, problem: str) -> bool:
        self.problems.append(f"widget {label!r} from {origin}: {problem}")
        self.failed.setdefault(label, f"{origin}: {problem}")
        return False

    def missing_reason(self, type_name: str) -> str:
        """Say why `type_name` has no widget class: a plugin that failed, or none installed."""
        if type_name in self._classes:
            return ""
        if type_name in self.failed:
            return f"the plugin providing {type_name!r} is installed but unusable: {self.failed[type_name]}"
        return (
            f"no installed package provides the widget type {type_name!r} "
            f"(entry point {type_name!r} in the group {ENTRY_POINT_GROUP!r}); install its plugin"
        )

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
        try:
            entry_points = sorted(importlib.metadata.entry_points(group=group), key=lambda e: e.name)
        except Exception as exc:  # broken package metadata on sys.path must not stop the viewer
            registry.problems.append(f"cannot list the {group!r} entry points: {exc!r}")
            entry_points = []
        for ep in entry_points:
            builtin = ep.name in BUILTIN_WIDGETS and ep.value == BUILTIN_WIDGETS[ep.name]
            dist = ep.dist.name if ep.dist is not None else None
            origin = "builtin" if builtin else (dist or ep.value)
            try:
                obj = ep.load()
            except Exception as exc:  # a broken plugin must not take the viewer down
                reason = f"{ep.value} failed to import: {type(exc).__name__}: {exc}"
                registry.problems.append(f"widget plugin {ep.name!r} from {origin}: {reason}")
                registry.failed.setdefault(ep.name, f"{origin}: {reason}")
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


def declaration_problem(cls: type[Widget]) -> str:
    """Return what is wrong with a widget class's declarations, or ``""`` when it is usable.

    Checks what the viewer relies on before it ever constructs the widget: the abstract methods are
    implemented, `label` is text, `accepts` is a set of value kinds, `properties` are valid `Property`
    declarations with unique names whose defaults pass their own validation, `max_bindings` is
    1..16, and the sizes are pairs of positive whole numbers.
    """
    if inspect.isabstract(cls):
        missing = ", ".join(sorted(getattr(cls, "__abstractmethods__", ()))) or "?"
        return f"does not implement {missing}"
    label = getattr(cls, "label", None)
    if not isinstance(label, str) or not label.strip():
        return "missing a 'label' string"
    accepts = getattr(cls, "accepts", None)
    if (
        not isinstance(accepts, frozenset | set)
        or not accepts
        or not all(isinstance(k, ValueKind) for k in accepts)
    ):
        return f"'accepts' must be a non-empty set of ValueKind, got {accepts!r}"[:200]
    problem = _properties_problem(getattr(cls, "properties", None))
    if problem:
        return problem
    max_bindings = getattr(cls, "max_bindings", None)
    if isinstance(max_bindings, bool) or not isinstance(max_bindings, int):
        return f"'max_bindings' must be a whole number, got {max_bindings!r}"
    if not 1 <= max_bindings <= MAX_BINDINGS:
        return f"'max_bindings' must be within 1..{MAX_BINDINGS}, got {max_bindings}"
    for attr in ("default_size", "min_size"):
        size = getattr(cls, attr, None)
        if not (
            isinstance(size, tuple)
            and len(size) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) and 1 <= v <= 10_000 for v in size)
        ):
            return f"'{attr}' must be (width, height) in whole pixels 1..10000, got {size!r}"[:200]
    return ""


def _properties_problem(properties: object) -> str:
    if not isinstance(properties, tuple | list):
        return f"'properties' must be a tuple of Property, got {type(properties).__name__}"
    seen: set[str] = set()
    for i, prop in enumerate(properties):
        if not isinstance(prop, Property):
            return f"properties[{i}] is not a Property: {prop!r}"[:200]
        if not isinstance(prop.name, str) or not _PROP_NAME.fullmatch(prop.name):
            return f"properties[{i}]: name {prop.name!r} is not [a-z_][a-z0-9_]*"
        if prop.name in seen:
            return f"property {prop.name!r} is declared twice"
        seen.add(prop.name)
        kind: object = prop.kind  # a plugin's dataclass field can hold anything at run time
        if not isinstance(kind, PropKind):
            return f"property {prop.name!r}: kind {kind!r} is not a PropKind"
        if prop.kind is PropKind.CHOICE and not prop.choices:
            return f"property {prop.name!r}: a choice needs 'choices'"
        try:
            prop.validate(prop.default)
        except PropertyError as exc:
            return f"default of {exc}"
    return ""
