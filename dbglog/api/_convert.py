"""Values to ROS messages: type lookup, range checks, CDR bytes for scalars, dicts and arrays to messages.

Imports the ROS message packages lazily; only called once dbglog is enabled and a value arrives.
"""

from __future__ import annotations

import array
import importlib
import math
import operator
import struct
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from typing import Any, Literal

__all__ = [
    "CDR_HEADER",
    "ConversionError",
    "ScalarSpec",
    "build_message",
    "is_message",
    "multiarray_message",
    "resolve_type",
    "scalar_spec",
    "type_name",
]

CDR_HEADER = b"\x00\x01\x00\x00"
"""Encapsulation header of little-endian plain CDR, as every ROS 2 DDS middleware writes it."""

MAX_STRING_CHARS = 65536
"""Longer strings are cut to this many characters (one warning), so a history of them stays small."""

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


def _int_spec(name: str, code: str, bits: int, signed: bool) -> ScalarSpec:
    pad = "x" * ((4 - bits // 8 % 4) % 4)
    low, high = (-(2 ** (bits - 1)), 2 ** (bits - 1) - 1) if signed else (0, 2**bits - 1)
    return ScalarSpec(name, "int", "<" + code + pad, low, high)


_SCALARS: dict[str, ScalarSpec] = {
    "Float64": ScalarSpec("Float64", "float", "<d"),
    "Float32": ScalarSpec("Float32", "float", "<f"),
    "Int8": _int_spec("Int8", "b", 8, True),
    "Int16": _int_spec("Int16", "h", 16, True),
    "Int32": _int_spec("Int32", "i", 32, True),
    "Int64": _int_spec("Int64", "q", 64, True),
    "UInt8": _int_spec("UInt8", "B", 8, False),
    "UInt16": _int_spec("UInt16", "H", 16, False),
    "UInt32": _int_spec("UInt32", "I", 32, False),
    "UInt64": _int_spec("UInt64", "Q", 64, False),
    "Bool": ScalarSpec("Bool", "bool", "<?xxx"),
    "String": ScalarSpec("String", "str", ""),
}

KIND_DEFAULT: dict[ScalarKind, str] = {"float": "Float64", "int": "Int64", "bool": "Bool", "str": "String"}


def type_name(cls: type) -> str:
    """Return ``pkg/msg/Type`` for a generated ROS message class."""
    package = cls.__module__.split(".")[0]
    return f"{package}/msg/{cls.__name__}"


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
        if hasattr(spec, "get_fields_and_field_types") and hasattr(spec, "__slots__"):
            return spec
        raise ConversionError("bad_type", f"{spec.__qualname__} is not a ROS message type")
    if not isinstance(spec, str):
        raise ConversionError(
            "bad_type",
            f"msg_type must be a message class or a 'pkg/msg/Type' string, not {type(spec).__name__}",
        )
    parts = spec.split("/")
    if len(parts) == 2:
        parts = [parts[0], "msg", parts[1]]
    if len(parts) != 3 or parts[1] != "msg" or not all(p.isidentifier() for p in parts):
        raise ConversionError("bad_type", f"msg_type {spec!r} is not of the form 'pkg/msg/Type'")
    try:
        module = importlib.import_module(f"{parts[0]}.msg")
        cls = getattr(module, parts[2])
    except (ImportError, AttributeError):
        raise ConversionError("bad_type", f"message type {spec!r} is not installed") from None
    if not isinstance(cls, type):
        raise ConversionError("bad_type", f"{spec!r} is not a ROS message type")
    return resolve_type(cls)


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
        raise ConversionError("out_of_range", f"the integer is outside the {spec.name} range")
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
    return CDR_HEADER + struct.pack(spec.fmt, value)


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


def build_message(cls: type, data: object) -> Any:
    """Return an instance of `cls` from an instance (as is) or a dict of its fields (recursively).

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
        try:
            setattr(msg, key, value)
        except (AssertionError, TypeError, ValueError, OverflowError) as exc:
            detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise ConversionError(
                "bad_value", f"field {key!r} of {type_name(cls)} does not accept that value ({detail})"
            ) from None
    return msg


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
