"""Installed ROS message types, found without importing anything, and message values checked against them.

Type names go through the one type gate (``dbglog._ros._types``: only an installed interface package's
``msg`` module is ever imported), so a file cannot make the viewer import an arbitrary module.
`fill_message` sets the fields of a message from JSON-like values with type and range checks (no eval).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any, Final

from dbglog._ros import _types
from dbglog._ros._types import TypeGateError, installed_types, primitive

__all__ = [
    "FormField",
    "InterfaceError",
    "fill_message",
    "form_fields",
    "installed_types",
    "message_type",
    "normalize_type",
    "value_kind",
]

MAX_FORM_FIELDS: Final = 200
MAX_DEPTH: Final = 8


class InterfaceError(ValueError):
    """A message type that is not installed or malformed, or a value that does not fit a field."""


def normalize_type(name: str) -> str:
    """Return ``pkg/msg/Name`` for ``pkg/Name`` or ``pkg/msg/Name``.

    Raises:
        InterfaceError: the text is not a message type name.
    """
    try:
        return _types.normalize_type(name)
    except TypeGateError as exc:
        raise InterfaceError(str(exc)) from None


def message_type(name: str) -> Any:
    """Return the message class of an installed type (through the one type gate, ``dbglog._ros._types``).

    Raises:
        InterfaceError: the name is malformed or no installed package provides it.
    """
    try:
        return _types.message_class(name)
    except TypeGateError as exc:
        raise InterfaceError(str(exc)) from None


def _members(cls: Any) -> list[tuple[str, str, Any]]:
    names = cls.get_fields_and_field_types()
    return [(n, s, slot) for (n, s), slot in zip(names.items(), cls.SLOT_TYPES, strict=True)]


def _nested(slot: Any) -> Any | None:
    """Return the class of a nested message slot, or None for a primitive/array slot."""
    from rosidl_parser.definition import NamespacedType

    if isinstance(slot, NamespacedType):
        return _types.message_class("/".join([*slot.namespaces, slot.name]))
    return None


def value_kind(type_str: str) -> str | None:
    """Return ``bool``, ``int``, ``float`` or ``string`` for a primitive field type string, else None."""
    found = primitive(type_str)
    return None if found is None else found.kind


@dataclass(frozen=True, slots=True)
class FormField:
    """One primitive field of a message type, as a form shows it."""

    path: str
    """e.g. ``linear.x``."""
    type_name: str
    """The ROS type string, e.g. ``double``."""
    kind: str
    """``bool``, ``int``, ``float`` or ``string``."""


def form_fields(cls: Any) -> list[FormField]:
    """Return the primitive fields of a message class, nested ones flattened (arrays are left out)."""
    out: list[FormField] = []

    def walk(c: Any, prefix: str, depth: int) -> None:
        for name, type_str, slot in _members(c):
            path = f"{prefix}{name}"
            nested = _nested(slot)
            if nested is not None:
                if depth < MAX_DEPTH:
                    walk(nested, path + ".", depth + 1)
                continue
            kind = value_kind(type_str)
            if kind is not None and len(out) < MAX_FORM_FIELDS:
                out.append(FormField(path, type_str, kind))

    walk(cls, "", 0)
    return out


def _bounds(type_str: str) -> tuple[Any, Any]:
    found = primitive(type_str)
    return (None, None) if found is None else (found.low, found.high)


def _convert(value: object, type_str: str, where: str) -> object:
    kind = value_kind(type_str)
    if kind == "bool":
        if not isinstance(value, bool):
            raise InterfaceError(f"{where} is a boolean; got {value!r}")
        return value
    if kind == "int":
        if isinstance(value, float) and value.is_integer():
            value = int(value)
        if isinstance(value, bool) or not isinstance(value, int):
            raise InterfaceError(f"{where} is {type_str}, a whole number; got {value!r}")
        low, high = _bounds(type_str)
        if not low <= value <= high:
            raise InterfaceError(f"{where} is {type_str}: {value} is outside {low}..{high}")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InterfaceError(f"{where} is {type_str}, a number; got {value!r}")
        number = float(value)
        high = _bounds(type_str)[1]
        if not math.isfinite(number) or (high is not None and abs(number) > high):
            raise InterfaceError(f"{where} is {type_str}: {value!r} is out of range")
        return number
    if kind == "string":
        if not isinstance(value, str):
            raise InterfaceError(f"{where} is a string; got {value!r}")
        return value
    raise InterfaceError(f"{where} has type {type_str}, which a dashboard cannot set")


def _flatten(values: Mapping[str, object], prefix: str, out: dict[str, object], depth: int) -> None:
    if depth > MAX_DEPTH:
        raise InterfaceError(f"values nested deeper than {MAX_DEPTH} levels")
    for key, value in values.items():
        if not isinstance(key, str):
            raise InterfaceError(f"field names must be text, got {key!r}")
        path = f"{prefix}{key}"
        if isinstance(value, Mapping):
            _flatten(value, path + ".", out, depth + 1)
        else:
            out[path] = value


def fill_message(cls: Any, values: Mapping[str, object]) -> Any:
    """Build a message of class `cls` with `values` set (nested objects or dotted paths); others default.

    Args:
        cls: the message class.
        values: e.g. ``{"linear": {"x": 0.5}, "angular.z": 1.0}``.

    Raises:
        InterfaceError: a path names no field, or a value does not fit its field; the message says which.
    """
    flat: dict[str, object] = {}
    _flatten(values, "", flat, 0)
    msg = cls()
    type_label = f"{cls.__module__.split('.')[0]}/msg/{cls.__name__}"
    for path, value in flat.items():
        target = msg
        target_cls = cls
        steps = path.split(".")
        for i, step in enumerate(steps):
            members = {n: (s, slot) for n, s, slot in _members(target_cls)}
            if step not in members:
                known = ", ".join(members) or "(none)"
                at = ".".join(steps[:i]) or type_label
                raise InterfaceError(f"{type_label} has no field {path!r} ({at} has: {known})")
            type_str, slot = members[step]
            nested = _nested(slot)
            if i == len(steps) - 1:
                if nested is not None:
                    raise InterfaceError(f"{type_label}: {path!r} is a message ({type_str}); set its fields")
                setattr(target, step, _convert(value, type_str, f"{type_label} field {path!r}"))
            else:
                if nested is None:
                    raise InterfaceError(
                        f"{type_label}: {'.'.join(steps[: i + 1])!r} is {type_str}, not a message"
                    )
                target = getattr(target, step)
                target_cls = nested
    return msg
