"""Installed ROS message types, found without importing anything, and message values checked against them.

Types come from the ament index (``rosidl_interfaces`` resources, when a ROS prefix is sourced) and from a
scan of the Python path for ``<package>/msg/__init__.py`` (the PyPI wheels). A type name from a dashboard
is only ever imported when it is on that list, so a file cannot make the viewer import an arbitrary module.
`fill_message` sets the fields of a message from JSON-like values with type and range checks (no eval).
"""

from __future__ import annotations

import functools
import importlib
import math
import re
import sys
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

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

_TYPE = re.compile(r"([a-z][a-z0-9_]*)/(?:msg/)?([A-Z][A-Za-z0-9]*)")
_IMPORT = re.compile(r"^from\s+[\w.]+\._\w+\s+import\s+(\w+)", re.MULTILINE)
_INTS: Final = {
    "int8": (-(2**7), 2**7 - 1),
    "uint8": (0, 2**8 - 1),
    "byte": (0, 2**8 - 1),
    "octet": (0, 2**8 - 1),
    "char": (0, 2**8 - 1),
    "int16": (-(2**15), 2**15 - 1),
    "uint16": (0, 2**16 - 1),
    "int32": (-(2**31), 2**31 - 1),
    "uint32": (0, 2**32 - 1),
    "int64": (-(2**63), 2**63 - 1),
    "uint64": (0, 2**64 - 1),
}
_FLOATS: Final = {"float", "double", "float32", "float64"}
_FLOAT32_MAX: Final = 3.4028234663852886e38
MAX_FORM_FIELDS: Final = 200
MAX_DEPTH: Final = 8


class InterfaceError(ValueError):
    """A message type that is not installed or malformed, or a value that does not fit a field."""


def normalize_type(name: str) -> str:
    """Return ``pkg/msg/Name`` for ``pkg/Name`` or ``pkg/msg/Name``.

    Raises:
        InterfaceError: the text is not a message type name.
    """
    match = _TYPE.fullmatch(name.strip()) if isinstance(name, str) else None
    if match is None:
        raise InterfaceError(
            f"{name!r} is not a message type name (expected pkg/msg/Name, e.g. std_msgs/msg/Bool)"
        )
    return f"{match.group(1)}/msg/{match.group(2)}"


def _scan_python_path(paths: Iterable[str]) -> set[str]:
    found: set[str] = set()
    for entry in paths:
        try:
            root = Path(entry)
            if not root.is_dir():
                continue
            for init in root.glob("*/msg/__init__.py"):
                package = init.parent.parent.name
                if not re.fullmatch(r"[a-z][a-z0-9_]*", package):
                    continue
                try:
                    text = init.read_text(encoding="utf-8", errors="replace")[:200_000]
                except OSError:
                    continue
                found.update(f"{package}/msg/{n}" for n in _IMPORT.findall(text) if n[:1].isupper())
        except OSError:
            continue
    return found


def _scan_ament_index() -> set[str]:
    try:
        from ament_index_python import get_resource, get_resources
    except ImportError:
        return set()
    found: set[str] = set()
    try:
        packages = get_resources("rosidl_interfaces")
        for package in packages:
            content, _ = get_resource("rosidl_interfaces", package)
            for line in content.splitlines():
                if line.startswith("msg/") and line.endswith(".msg"):
                    found.add(f"{package}/msg/{line[4:-4]}")
    except (OSError, LookupError, ValueError):  # no ROS prefix sourced, or a broken index entry
        return set()
    return found


@functools.cache
def installed_types() -> tuple[str, ...]:
    """Return every installed message type as ``pkg/msg/Name``, sorted (scanned once, nothing imported)."""
    return tuple(sorted(_scan_python_path(sys.path) | _scan_ament_index()))


def message_type(name: str) -> Any:
    """Return the message class of an installed type (imported only when `installed_types` lists it).

    Raises:
        InterfaceError: the name is malformed or no installed package provides it.
    """
    full = normalize_type(name)
    if full not in installed_types():
        raise InterfaceError(f"message type {full} is not installed on this machine")
    package, _, type_name = full.split("/")
    try:
        return getattr(importlib.import_module(f"{package}.msg"), type_name)
    except (ImportError, AttributeError) as exc:
        raise InterfaceError(f"message type {full} cannot be loaded: {exc}") from None


def _members(cls: Any) -> list[tuple[str, str, Any]]:
    names = cls.get_fields_and_field_types()
    return [(n, s, slot) for (n, s), slot in zip(names.items(), cls.SLOT_TYPES, strict=True)]


def _nested(slot: Any) -> Any | None:
    """Return the class of a nested message slot, or None for a primitive/array slot."""
    from rosidl_parser.definition import NamespacedType

    if isinstance(slot, NamespacedType):
        return getattr(importlib.import_module(".".join(slot.namespaces)), slot.name)
    return None


def value_kind(type_str: str) -> str | None:
    """Return ``bool``, ``int``, ``float`` or ``string`` for a primitive field type string, else None."""
    if type_str == "boolean":
        return "bool"
    if type_str in _INTS:
        return "int"
    if type_str in _FLOATS:
        return "float"
    if type_str == "string" or type_str.startswith("string<"):
        return "string"
    return None


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
        low, high = _INTS[type_str]
        if not low <= value <= high:
            raise InterfaceError(f"{where} is {type_str}: {value} is outside {low}..{high}")
        return value
    if kind == "float":
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise InterfaceError(f"{where} is {type_str}, a number; got {value!r}")
        number = float(value)
        if not math.isfinite(number) or (type_str in ("float", "float32") and abs(number) > _FLOAT32_MAX):
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
