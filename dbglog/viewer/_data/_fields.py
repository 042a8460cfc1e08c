"""Field paths into ROS messages: parse ``pose.position.z`` / ``ranges[3]`` once, resolve against a type.

Resolution walks the message class's ``SLOT_TYPES`` (no instance needed), so a bad path is reported at
bind time with the fields that do exist. The result is a fast accessor for typed messages and, when
every field before the value has a fixed size, the value's byte offset in the CDR payload (see
``_cdr``). No rclpy import here; message classes come from their Python packages.
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from rosidl_parser import definition as rd

from dbglog._ros import _types
from dbglog._ros._types import PRIMITIVES, TypeGateError
from dbglog.viewer._data._model import FieldInfo, ValueKind

__all__ = [
    "FieldPathError",
    "Resolved",
    "Scalar",
    "fixed_size",
    "list_fields",
    "message_class",
    "parse_path",
    "resolve",
    "whole_message_path",
]

Scalar = float | int | bool | str | tuple[float, ...]
"""A value as it is stored: numbers and bools keep their Python type, arrays are tuples."""

_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_INDEX = re.compile(r"\[(\d*)\]")
_FLOATS = frozenset(name for name, p in PRIMITIVES.items() if p.kind == "float")
_INTS = frozenset(name for name, p in PRIMITIVES.items() if p.kind == "int")
_TIME_TYPES = frozenset({("builtin_interfaces", "Time"), ("builtin_interfaces", "Duration")})
_MAX_LISTED = 2000
_MAX_DEPTH = 10

Step = str | int
"""One step of a parsed path: an attribute name, or an index into an array or sequence."""


class FieldPathError(ValueError):
    """A field path that is malformed or does not fit the message type; the message says why."""


def parse_path(path: str) -> tuple[tuple[Step, ...], bool]:
    """Split `path` into steps; the flag is True when it ends in ``[]`` (the whole sequence).

    Raises:
        FieldPathError: the path is not ``name(.name|[index])*`` (an optional ``[]`` only at the end).
    """
    text = path.strip()
    steps: list[Step] = []
    whole = False
    pos = 0
    while pos < len(text):
        if steps and text[pos] == ".":
            pos += 1
        elif steps:
            raise FieldPathError(f"field path {path!r}: expected '.' or '[' at position {pos}")
        name = _NAME.match(text, pos)
        if name is None:
            raise FieldPathError(
                f"field path {path!r}: expected a field name at position {pos} "
                "(names are letters, digits and '_', e.g. pose.position.z or ranges[3])"
            )
        steps.append(name.group(0))
        pos = name.end()
        while (index := _INDEX.match(text, pos)) is not None:
            if whole:
                raise FieldPathError(f"field path {path!r}: '[]' (the whole sequence) must come last")
            if index.group(1) == "":
                whole = True
            else:
                steps.append(int(index.group(1)))
            pos = index.end()
        if whole and pos < len(text):
            raise FieldPathError(f"field path {path!r}: '[]' (the whole sequence) must come last")
    return tuple(steps), whole


def message_class(type_name: str) -> Any:
    """Return the Python class of a ROS type such as ``std_msgs/msg/Float64`` (through the type gate).

    Raises:
        FieldPathError: the name is malformed or its package is not installed here.
    """
    try:
        return _types.message_class(type_name)
    except TypeGateError as exc:
        if exc.reason == "malformed":
            raise FieldPathError(f"{type_name!r} is not a ROS message type (expected pkg/msg/Name)") from None
        raise FieldPathError(
            f"message type {type_name} is not installed on this machine (install its package to view it)"
        ) from None


def _type_label(cls: Any) -> str:
    module = cls.__module__.split(".")
    return f"{module[0]}/{module[1]}/{cls.__name__}"


def _members(cls: Any) -> list[tuple[str, Any, str]]:
    """Return (name, rosidl type, type string) for every field of a message class, in order."""
    names = cls.get_fields_and_field_types()
    return [(n, t, s) for (n, s), t in zip(names.items(), cls.SLOT_TYPES, strict=True)]


def _nested_class(slot: Any) -> Any:
    return message_class("/".join([*slot.namespaces, slot.name]))


def _is_time(slot: Any) -> bool:
    return isinstance(slot, rd.NamespacedType) and (slot.namespaces[0], slot.name) in _TIME_TYPES


def _leaves(cls: Any, prefix: str, depth: int = 0) -> list[str]:
    """Return the value paths under a message (Time/Duration count as one value)."""
    out: list[str] = []
    if depth > _MAX_DEPTH:
        return out
    for name, slot, _ in _members(cls):
        path = f"{prefix}{name}"
        if isinstance(slot, rd.NamespacedType) and not _is_time(slot):
            out.extend(_leaves(_nested_class(slot), path + ".", depth + 1))
        else:
            out.append(path)
    return out


def whole_message_path(cls: Any) -> str | None:
    """Return the one value path of a single-valued message type (``data`` for Float64), else None."""
    leaves = _leaves(cls, "")
    return leaves[0] if len(leaves) == 1 else None


@dataclass(frozen=True, slots=True)
class Resolved:
    """A field path checked against a message type, ready to extract values."""

    path: str
    """The path actually read (``data`` when the binding's path was empty)."""
    kind: ValueKind
    leaf_type: str
    """The ROS type of the value, e.g. ``double`` or ``sequence<float>``."""
    get: Callable[[Any], Scalar]
    """Read the value from a typed message; may raise IndexError for a short sequence."""
    cdr: tuple[int, str] | None
    """(byte offset after the 4-byte encapsulation header, numpy dtype) when the offset is fixed."""


def _choices(cls: Any, prefix: str) -> str:
    leaves = _leaves(cls, prefix)
    shown = ", ".join(leaves[:8]) + (", ..." if len(leaves) > 8 else "")
    return shown or "(no fields)"


def resolve(cls: Any, path: str) -> Resolved:
    """Check `path` against message class `cls` and build its accessor.

    An empty path means the message's single value (``data`` of ``std_msgs/msg/Float64``).

    Raises:
        FieldPathError: the path is malformed, names a missing field, indexes something that is not
            an array, or ends on a message with several values; the message lists the valid choices.
    """
    type_label = _type_label(cls)
    if not path.strip():
        single = whole_message_path(cls)
        if single is None:
            raise FieldPathError(
                f"{type_label} has several fields, so the binding needs a field path: "
                f"one of {_choices(cls, '')}"
            )
        path = single
    steps, whole = parse_path(path)
    current_cls = cls
    slot: Any = None
    walked = ""
    for i, step in enumerate(steps):
        if isinstance(step, str):
            if slot is not None:  # descend into the previous nested message
                if isinstance(slot, rd.AbstractNestedType):
                    example = f"{walked}[0]" + (
                        f".{step}" if isinstance(slot.value_type, rd.NamespacedType) else ""
                    )
                    raise FieldPathError(
                        f"{type_label} has no field {path.strip()!r}: {walked!r} is a "
                        f"{_nested_label(slot)}; index one element first, e.g. {example}"
                    )
                if not isinstance(slot, rd.NamespacedType):
                    raise FieldPathError(
                        f"{type_label} has no field {path.strip()!r}: {walked!r} is a {_slot_label(slot)}, "
                        f"not a message (fields: {_choices(cls, '')})"
                    )
                current_cls = _nested_class(slot)
            fields = {name: (t, s) for name, t, s in _members(current_cls)}
            if step not in fields:
                raise FieldPathError(
                    f"field {step!r} is not in {_type_label(current_cls)}"
                    + (f" (at {walked})" if walked else "")
                    + f"; its fields are: {', '.join(fields) or '(none)'}"
                )
            slot = fields[step][0]
            walked = f"{walked}.{step}" if walked else step
        else:
            if not isinstance(slot, rd.AbstractNestedType):
                raise FieldPathError(
                    f"{walked!r} is not an array or sequence, so it cannot be indexed [{step}]"
                )
            if isinstance(slot, rd.Array) and step >= slot.size:
                raise FieldPathError(f"index [{step}] is out of range: {walked!r} has {slot.size} elements")
            slot = slot.value_type
            walked = f"{walked}[{step}]"
        if isinstance(slot, rd.NamespacedType) and i == len(steps) - 1 and not whole and not _is_time(slot):
            nested = _nested_class(slot)
            single = whole_message_path(nested)
            if single is None:
                raise FieldPathError(
                    f"{walked!r} is a {_type_label(nested)} message, not a value; "
                    f"pick one of its fields: {_choices(nested, walked + '.')}"
                )
            return resolve(cls, f"{path}.{single}")
    if whole and not isinstance(slot, rd.AbstractNestedType):
        raise FieldPathError(f"{walked!r} is not an array or sequence, so '[]' does not apply")
    kind, leaf_type, convert = _leaf(slot, walked)
    getter = _getter(steps)
    get: Callable[[Any], Scalar] = getter if convert is None else _compose(getter, convert)
    offset = _cdr_offset(cls, steps) if kind in (ValueKind.NUMBER, ValueKind.BOOL) else None
    return Resolved(path, kind, leaf_type, get, offset)


def _compose(getter: Callable[[Any], Any], convert: Callable[[Any], Scalar]) -> Callable[[Any], Scalar]:
    return lambda msg: convert(getter(msg))


def _getter(steps: tuple[Step, ...]) -> Callable[[Any], Any]:
    """Build the fastest accessor: one attrgetter per run of names, item access for indexes."""
    parts: list[Callable[[Any], Any]] = []
    names: list[str] = []
    for step in steps:
        if isinstance(step, str):
            names.append(step)
            continue
        if names:
            parts.append(operator.attrgetter(".".join(names)))
            names = []
        parts.append(operator.itemgetter(step))
    if names:
        parts.append(operator.attrgetter(".".join(names)))
    if len(parts) == 1:
        return parts[0]

    def chain(msg: Any) -> Any:
        value = msg
        for part in parts:
            value = part(value)
        return value

    return chain


def _to_tuple(value: Any) -> tuple[float, ...]:
    if hasattr(value, "tolist"):
        return tuple(value.tolist())
    return tuple(value)


def _bools_tuple(value: Any) -> tuple[float, ...]:
    return tuple(float(bool(v)) for v in value)


def _octet(value: Any) -> int:
    return value[0] if isinstance(value, bytes | bytearray) else int(value)


def _time_seconds(value: Any) -> float:
    return float(value.sec) + float(value.nanosec) * 1e-9


def _leaf(slot: Any, walked: str) -> tuple[ValueKind, str, Callable[[Any], Scalar] | None]:
    """Return the kind, type label and value conversion of the field a path ends on."""
    if isinstance(slot, rd.BasicType):
        name = slot.typename
        if name == "boolean":
            return ValueKind.BOOL, name, bool
        if name in _FLOATS:
            return ValueKind.NUMBER, name, float
        if name == "octet":
            return ValueKind.NUMBER, name, _octet
        if name in _INTS:
            return ValueKind.NUMBER, name, int
        raise FieldPathError(f"{walked!r} has type {name}, which the viewer cannot show")
    if isinstance(slot, rd.AbstractGenericString):
        return ValueKind.TEXT, "string", str
    if _is_time(slot):
        return ValueKind.NUMBER, f"{slot.namespaces[0]}/{slot.name} (seconds)", _time_seconds
    if isinstance(slot, rd.AbstractNestedType):
        inner = slot.value_type
        label = _nested_label(slot)
        if isinstance(inner, rd.BasicType) and inner.typename == "boolean":
            return ValueKind.ARRAY, label, _bools_tuple
        if isinstance(inner, rd.BasicType) and (inner.typename in _FLOATS or inner.typename in _INTS):
            return ValueKind.ARRAY, label, _to_tuple
        raise FieldPathError(
            f"{walked!r} is a {label}, not numbers; index one element, e.g. {walked}[0]"
            + (".<field>" if isinstance(inner, rd.NamespacedType) else "")
        )
    raise FieldPathError(f"{walked!r} has a type the viewer cannot show")


def _slot_label(slot: Any) -> str:
    """Name the type of a value field for a message: ``double``, ``string``."""
    if isinstance(slot, rd.BasicType):
        return str(slot.typename)
    if isinstance(slot, rd.AbstractGenericString):
        return "string"
    return "value"


def _nested_label(slot: Any) -> str:
    inner = slot.value_type
    inner_label = (
        inner.typename
        if isinstance(inner, rd.BasicType)
        else "string"
        if isinstance(inner, rd.AbstractGenericString)
        else f"{inner.namespaces[0]}/{inner.name}"
        if isinstance(inner, rd.NamespacedType)
        else "?"
    )
    if isinstance(slot, rd.Array):
        return f"{inner_label}[{slot.size}]"
    return f"sequence<{inner_label}>"


# --- fixed CDR offsets (XCDR1, little endian: the encapsulation ROS 2 publishers use) ---------------

_CDR_SIZES = {name: (p.size, p.dtype) for name, p in PRIMITIVES.items() if p.size}


class _VariableSizeError(Exception):
    """A field of variable size: offsets after it are not fixed."""


def _skip(slot: Any, start: int) -> int:
    """Return the CDR offset just after a whole field of fixed size starting at `start`."""
    if isinstance(slot, rd.BasicType):
        size, _ = _CDR_SIZES.get(slot.typename, (0, ""))
        if not size:
            raise _VariableSizeError
        return -(-start // size) * size + size
    if isinstance(slot, rd.Array) and isinstance(slot.value_type, rd.BasicType):
        size, _ = _CDR_SIZES.get(slot.value_type.typename, (0, ""))
        if not size:
            raise _VariableSizeError
        return int(-(-start // size) * size + size * slot.size)
    if isinstance(slot, rd.Array) and isinstance(slot.value_type, rd.NamespacedType):
        for _ in range(slot.size):
            start = _skip(slot.value_type, start)
        return start
    if isinstance(slot, rd.NamespacedType):
        for _, member, _ in _members(_nested_class(slot)):
            start = _skip(member, start)
        return start
    raise _VariableSizeError


def fixed_size(cls: Any) -> int | None:
    """Return the CDR payload size of a message type whose every field has a fixed size, else None."""
    offset = 0
    try:
        for _, member, _ in _members(cls):
            offset = _skip(member, offset)
    except _VariableSizeError:
        return None
    return offset


def _cdr_offset(cls: Any, steps: tuple[Step, ...]) -> tuple[int, str] | None:
    """Return the fixed payload offset and dtype of a scalar path, or None when it is not fixed."""
    offset = 0
    try:
        current = cls
        slot: Any = None
        for step in steps:
            if isinstance(step, int):
                if not isinstance(slot, rd.Array) or not isinstance(slot.value_type, rd.BasicType):
                    return None
                size, _ = _CDR_SIZES[slot.value_type.typename]
                offset = -(-offset // size) * size + size * step
                slot = slot.value_type
                continue
            if slot is not None:
                if not isinstance(slot, rd.NamespacedType):
                    return None
                current = _nested_class(slot)
            for name, member, _ in _members(current):
                if name == step:
                    slot = member
                    break
                offset = _skip(member, offset)
        if not isinstance(slot, rd.BasicType) or slot.typename not in _CDR_SIZES:
            return None
        size, dtype = _CDR_SIZES[slot.typename]
        return -(-offset // size) * size, dtype
    except (_VariableSizeError, KeyError):
        return None


# --- the field tree for the setup dialog ------------------------------------------------------------


def list_fields(cls: Any) -> list[FieldInfo]:
    """List every field path of a message type, parents before children (``ranges[]`` for sequences)."""
    out: list[FieldInfo] = []
    _walk(cls, "", out, 0)
    return out


def _walk(cls: Any, prefix: str, out: list[FieldInfo], depth: int) -> None:
    if depth > _MAX_DEPTH:
        return
    for name, slot, type_str in _members(cls):
        if len(out) >= _MAX_LISTED:
            return
        path = prefix + name
        if isinstance(slot, rd.NamespacedType):
            out.append(FieldInfo(path, type_str, _is_time(slot)))  # Time/Duration read as seconds
            _walk(_nested_class(slot), path + ".", out, depth + 1)
        elif isinstance(slot, rd.AbstractNestedType):
            inner = slot.value_type
            numeric = isinstance(inner, rd.BasicType) and (
                inner.typename in _FLOATS or inner.typename in _INTS or inner.typename == "boolean"
            )
            out.append(FieldInfo(path + "[]", type_str, numeric))
            if isinstance(inner, rd.NamespacedType) and not _is_time(inner):
                _walk(_nested_class(inner), path + "[].", out, depth + 1)
        else:
            numeric = isinstance(slot, rd.BasicType) and slot.typename in (_FLOATS | _INTS | {"boolean"})
            out.append(FieldInfo(path, type_str, numeric))
