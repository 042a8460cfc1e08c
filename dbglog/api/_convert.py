"""Values to ROS messages: type lookup, range checks, CDR bytes for scalars, dicts and arrays to messages.

Imports the ROS message packages lazily; only called once dbglog is enabled and a value arrives.
"""

from __future__ import annotations

import array
import importlib
import math
import operator
from collections.abc import Callable, Mapping
from copy import deepcopy
from dataclasses import dataclass
from typing import Any, Literal

from dbglog._ros._cdr import CDR_HEADER, SCALAR_FORMATS
from dbglog._ros._cdr import encode_scalar as _encode_cdr
from dbglog._ros._types import TypeGateError, is_message_class, message_class, type_name
from dbglog.api._errors import safe_repr

__all__ = [
    "CDR_HEADER",
    "NUL_REPLACEMENT",
    "ConversionError",
    "ScalarSpec",
    "build_message",
    "is_message",
    "multiarray_message",
    "resolve_type",
    "scalar_spec",
    "scrub_nul",
    "type_name",
]

MAX_STRING_CHARS = 65536
"""Longer strings are cut to this many characters (one warning), so a history of them stays small."""

NUL_REPLACEMENT = "\ufffd"
"""What a NUL character in a string becomes: ROS 2 strings are C strings and would end at the NUL."""

_FLT_MAX = 3.4028234663852886e38

ScalarKind = Literal["float", "int", "bool", "str"]
Reason = Literal["bad_value", "out_of_range", "bad_type"]


class ConversionError(Exception):
    """A value or type that cannot be published; `reason` says which counter it goes to."""

    def __init__(self, reason: Reason, message: str) -> None:
        super().__init__(message)
        self.reason: Reason = reason


@dataclass(frozen=True, slots=True)
class ScalarSpec:
    """A std_msgs type with one ``data`` field of a primitive type."""

    name: str
    kind: ScalarKind
    fmt: str
    """`struct` format of the CDR body, padded to 4 bytes ('' for String)."""
    low: int = 0
    high: int = 0


def _int_spec(name: str, bits: int, signed: bool) -> ScalarSpec:
    low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)
    return ScalarSpec(name, "int", SCALAR_FORMATS[name], low, high)


_SCALARS: dict[str, ScalarSpec] = {
    "Float64": ScalarSpec("Float64", "float", SCALAR_FORMATS["Float64"]),
    "Float32": ScalarSpec("Float32", "float", SCALAR_FORMATS["Float32"]),
    "Int8": _int_spec("Int8", 8, True),
    "Int16": _int_spec("Int16", 16, True),
    "Int32": _int_spec("Int32", 32, True),
    "Int64": _int_spec("Int64", 64, True),
    "UInt8": _int_spec("UInt8", 8, False),
    "UInt16": _int_spec("UInt16", 16, False),
    "UInt32": _int_spec("UInt32", 32, False),
    "UInt64": _int_spec("UInt64", 64, False),
    "Bool": ScalarSpec("Bool", "bool", SCALAR_FORMATS["Bool"]),
    "String": ScalarSpec("String", "str", ""),
}

KIND_DEFAULT: dict[ScalarKind, str] = {"float": "Float64", "int": "Int64", "bool": "Bool", "str": "String"}


def is_message(obj: object) -> bool:
    """True when `obj` is an instance of a generated ROS 2 message class."""
    cls = type(obj)
    return hasattr(cls, "get_fields_and_field_types") and hasattr(cls, "_TYPE_SUPPORT")


def resolve_type(spec: object) -> type:
    """Return the message class for a class or a ``"pkg/msg/Type"`` (or ``"pkg/Type"``) string.

    Raises:
        ConversionError: not a message class, or the name does not resolve to one.
    """
    if isinstance(spec, type):
        if is_message_class(spec):
            return spec
        raise ConversionError("bad_type", f"{spec.__qualname__} is not a ROS message type")
    if not isinstance(spec, str):
        raise ConversionError(
            "bad_type",
            f"msg_type must be a message class or a 'pkg/msg/Type' string, not {type(spec).__name__}",
        )
    try:
        cls: type = message_class(spec)  # the one type gate: imports only an installed interface package
        return cls
    except TypeGateError as exc:
        if exc.reason == "malformed":
            raise ConversionError(
                "bad_type", f"msg_type {spec!r} is not of the form 'pkg/msg/Type'"
            ) from None
        if exc.reason == "not_installed":
            raise ConversionError("bad_type", f"message type {spec!r} is not installed") from None
        raise ConversionError("bad_type", f"{spec!r} is not a ROS message type") from None


def scalar_spec(cls: type) -> ScalarSpec | None:
    """Return the scalar description of a std_msgs single-value type, or None for any other type."""
    if cls.__module__.split(".")[0] != "std_msgs":
        return None
    return _SCALARS.get(cls.__name__)


def check_float(value: object, spec: ScalarSpec) -> float:
    """Return `value` as a float that fits `spec` (NaN and infinities are valid floats)."""
    if isinstance(value, str | bytes | bytearray | complex):
        raise ConversionError("bad_value", f"expected a real number, got {type(value).__name__}")
    try:
        result = float(value)  # type: ignore[arg-type]
    except OverflowError:
        raise ConversionError("out_of_range", "the number is too large for a float") from None
    except (TypeError, ValueError) as exc:
        raise ConversionError("bad_value", f"cannot be read as a float ({exc})") from None
    if spec.name == "Float32" and math.isfinite(result) and abs(result) > _FLT_MAX:
        raise ConversionError("out_of_range", "the number is outside the float32 range")
    return result


def check_int(value: object, spec: ScalarSpec) -> int:
    """Return `value` as an int within `spec`'s range; floats are refused rather than silently cut."""
    try:
        result = operator.index(value)  # type: ignore[arg-type]
    except TypeError:
        raise ConversionError("bad_value", f"expected an integer, got {type(value).__name__}") from None
    if not spec.low <= result <= spec.high:
        raise ConversionError(
            "out_of_range", f"the integer is outside the {spec.name} range [{spec.low}, {spec.high}]"
        )
    return int(result)


def check_bool(value: object) -> bool:
    """Return `value` as a bool: bools (also numpy's) and the integers 0 and 1."""
    if isinstance(value, bool) or (
        type(value).__module__ == "numpy" and type(value).__name__ in ("bool", "bool_")
    ):
        return bool(value)
    if isinstance(value, int) and value in (0, 1):
        return bool(value)
    raise ConversionError("bad_value", f"expected a bool, got {type(value).__name__}")


def encode_scalar(spec: ScalarSpec, value: object) -> bytes:
    """Return the CDR bytes of a checked scalar value."""
    return _encode_cdr(spec.fmt, value)


def make_checker(spec: ScalarSpec) -> Callable[[object], object]:
    """Return the function that checks (and converts) a value for `spec`."""
    if spec.kind == "float":
        return lambda v: check_float(v, spec)
    if spec.kind == "int":
        return lambda v: check_int(v, spec)
    if spec.kind == "bool":
        return check_bool
    return check_str


def check_str(value: object) -> str:
    """Return `value` as a str (non-strings through ``str()``)."""
    text = value if isinstance(value, str) else str(value)
    try:
        text.encode("utf-8")
    except UnicodeEncodeError:
        raise ConversionError("bad_value", "the string is not valid UTF-8 (lone surrogates)") from None
    return text


# rosidl field type -> the scalar spec its values are checked against (rclpy checks none of them by
# default, so a bad value would only fail inside publish, counted as publish_failed).
_FIELD_SPECS: dict[str, ScalarSpec] = {
    "double": _SCALARS["Float64"],
    "float": _SCALARS["Float32"],
    "int8": _SCALARS["Int8"],
    "int16": _SCALARS["Int16"],
    "int32": _SCALARS["Int32"],
    "int64": _SCALARS["Int64"],
    "uint8": _SCALARS["UInt8"],
    "uint16": _SCALARS["UInt16"],
    "uint32": _SCALARS["UInt32"],
    "uint64": _SCALARS["UInt64"],
}


def _element_type(field_type: str) -> tuple[str, bool]:
    """Return (element type, is a sequence or array) of a rosidl field type such as ``sequence<int64, 3>``."""
    collection = False
    if field_type.startswith("sequence<"):
        field_type = field_type[len("sequence<") : -1].split(",")[0].strip()
        collection = True
    if field_type.endswith("]") and "[" in field_type:
        field_type = field_type[: field_type.index("[")]
        collection = True
    return field_type, collection


def _check_field(cls: type, key: str, field_type: str, value: object) -> object:
    """Return `value` checked for a primitive numeric field (type and range), else unchanged."""
    spec = _FIELD_SPECS.get(field_type)
    if spec is None or isinstance(value, Mapping):
        return value
    try:
        return make_checker(spec)(value)
    except ConversionError as exc:
        raise ConversionError(
            exc.reason, f"field {key!r} of {type_name(cls)} ({field_type}): {safe_repr(value)}: {exc}"
        ) from None


def build_message(cls: type, data: object) -> Any:
    """Return an instance of `cls` from an instance (as is) or a dict of its fields (recursively).

    Numeric fields are checked here (type, and range: ``2**80`` for an ``int64`` field is out of range).

    Raises:
        ConversionError: unknown field, or a field value of the wrong type or range.
    """
    if isinstance(data, cls):
        return data
    if not isinstance(data, Mapping):
        raise ConversionError(
            "bad_value",
            f"data for {type_name(cls)} must be a {cls.__name__} or a dict, not {type(data).__name__}",
        )
    msg = cls()
    fields: dict[str, str] = cls.get_fields_and_field_types()  # type: ignore[attr-defined]
    for key, value in data.items():
        if not isinstance(key, str) or key not in fields:
            raise ConversionError("bad_value", f"{type_name(cls)} has no field {key!r}")
        current = getattr(msg, key)
        if isinstance(value, Mapping) and is_message(current):
            value = build_message(type(current), value)
        value = _check_field(cls, key, fields[key], value)
        try:
            setattr(msg, key, value)
        except (AssertionError, TypeError, ValueError, OverflowError) as exc:
            detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            element, collection = _element_type(fields[key])
            spec = _FIELD_SPECS.get(element)
            if isinstance(exc, OverflowError) and collection and spec is not None:
                bounds = f"[{spec.low}, {spec.high}]" if spec.kind == "int" else "the float32 range"
                raise ConversionError(
                    "out_of_range",
                    f"field {key!r} of {type_name(cls)} ({fields[key]}) holds a value outside {bounds}",
                ) from None
            raise ConversionError(
                "bad_value", f"field {key!r} of {type_name(cls)} does not accept that value ({detail})"
            ) from None
    return msg


_StringPlan = tuple[tuple[str, bool, bool, "type | None"], ...]
"""Per message class: (field, is a string field (else a nested message), is a collection, nested class)."""
_STRING_PLANS: dict[type, _StringPlan] = {}


def _string_plan(cls: type) -> _StringPlan:
    """Return where `cls` (transitively) holds strings; cached per class, empty when it holds none."""
    plan = _STRING_PLANS.get(cls)
    if plan is not None:
        return plan
    entries: list[tuple[str, bool, bool, type | None]] = []
    fields: dict[str, str] = cls.get_fields_and_field_types()  # type: ignore[attr-defined]
    for name, field_type in fields.items():
        element, collection = _element_type(field_type)
        if element.startswith(("string", "wstring")):
            entries.append((name, True, collection, None))
        elif "/" in element:
            try:
                sub = resolve_type(element)
            except ConversionError:
                continue
            if _string_plan(sub):
                entries.append((name, False, collection, sub))
    plan = tuple(entries)
    _STRING_PLANS[cls] = plan
    return plan


def _find_nul(msg: Any, prefix: str, found: list[str], fix: bool) -> None:
    """Append the paths of string fields of `msg` that hold a NUL; with `fix`, replace the NULs."""
    for name, is_string, collection, _sub in _string_plan(type(msg)):
        value: Any = getattr(msg, name, None)
        if value is None:
            continue
        path = prefix + name
        if is_string:
            if collection:
                if any(isinstance(s, str) and "\x00" in s for s in value):
                    found.append(path)
                    if fix:
                        setattr(msg, name, [_replace_nul(s) for s in value])
            elif isinstance(value, str) and "\x00" in value:
                found.append(path)
                if fix:
                    setattr(msg, name, value.replace("\x00", NUL_REPLACEMENT))
        elif collection:
            for i, item in enumerate(value):
                if is_message(item):
                    _find_nul(item, f"{path}[{i}].", found, fix)
        elif is_message(value):
            _find_nul(value, path + ".", found, fix)


def _replace_nul(value: object) -> object:
    return value.replace("\x00", NUL_REPLACEMENT) if isinstance(value, str) else value


def scrub_nul(msg: Any) -> tuple[Any, list[str]]:
    """Return `msg`, or a copy with every NUL in its strings replaced by U+FFFD, and the fields that held one.

    A ROS 2 string is a C string: a NUL would silently end it. The caller's message is never changed.
    """
    found: list[str] = []
    if not _string_plan(type(msg)):
        return msg, found
    _find_nul(msg, "", found, fix=False)
    if not found:
        return msg, found
    copy = deepcopy(msg)
    _find_nul(copy, "", [], fix=True)
    return copy, found


# numpy dtype name -> (std_msgs MultiArray type, array typecode)
_ARRAY_TYPES: dict[str, tuple[str, str]] = {
    "float64": ("Float64MultiArray", "d"),
    "float32": ("Float32MultiArray", "f"),
    "float16": ("Float32MultiArray", "f"),
    "int8": ("Int8MultiArray", "b"),
    "int16": ("Int16MultiArray", "h"),
    "int32": ("Int32MultiArray", "i"),
    "int64": ("Int64MultiArray", "q"),
    "uint8": ("UInt8MultiArray", "B"),
    "uint16": ("UInt16MultiArray", "H"),
    "uint32": ("UInt32MultiArray", "I"),
    "uint64": ("UInt64MultiArray", "Q"),
    "bool": ("UInt8MultiArray", "B"),
}

# numpy scalar dtype name -> std_msgs scalar type
SCALAR_DTYPES: dict[str, str] = {
    "float64": "Float64",
    "float32": "Float32",
    "float16": "Float32",
    "int8": "Int8",
    "int16": "Int16",
    "int32": "Int32",
    "int64": "Int64",
    "uint8": "UInt8",
    "uint16": "UInt16",
    "uint32": "UInt32",
    "uint64": "UInt64",
    "bool": "Bool",
}


def multiarray_message(data: object) -> Any:
    """Return the std_msgs ``*MultiArray`` holding a numpy array or a (nested) sequence of numbers.

    Python ints become Int64 (or Float64 when mixed with floats); bools become UInt8; the layout
    lists one dimension per array axis.

    Raises:
        ConversionError: not rectangular, not numeric, or integers outside int64.
    """
    import numpy as np

    try:
        if isinstance(data, bytes | bytearray):
            arr = np.frombuffer(bytes(data), dtype=np.uint8)
        else:
            arr = data if isinstance(data, np.ndarray) else np.asarray(data)
    except (ValueError, TypeError, OverflowError) as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ConversionError("bad_value", f"cannot be read as a numeric array ({detail})") from None
    if arr.dtype.kind == "O" and not isinstance(data, np.ndarray):
        raise ConversionError("out_of_range", "the sequence holds values outside int64/float64")
    entry = _ARRAY_TYPES.get(arr.dtype.name)
    if entry is None:
        raise ConversionError("bad_value", f"arrays of {arr.dtype.name} cannot be published")
    type_, code = entry
    std_msgs = importlib.import_module("std_msgs.msg")
    msg = getattr(std_msgs, type_)()
    flat = np.ascontiguousarray(arr, dtype=np.dtype(code)).ravel()
    values = array.array(code)
    values.frombytes(flat.tobytes())
    msg.data = values
    dims = []
    stride = int(arr.size)
    for axis, size in enumerate(arr.shape):
        dim = std_msgs.MultiArrayDimension()
        dim.label = f"dim{axis}"
        dim.size = int(size)
        dim.stride = stride
        stride = stride // int(size) if size else 0
        dims.append(dim)
    msg.layout.dim = dims
    return msg
