"""Read the few fields the bridge needs straight from serialized (CDR) messages, and write typed values.

Taking ``/rosout`` messages raw and reading ``level``, ``name`` and ``msg`` here skips building a Python
``Log`` object per line (most of rclpy's per-message cost). Anything unexpected returns None and the
caller falls back to rclpy's own deserializer. Pure: no rclpy import.
"""

from __future__ import annotations

import struct
from typing import Final

from dbglog._regex._compile import NumberKind

__all__ = ["encode_value", "read_log", "read_string"]

_LE: Final = struct.Struct("<I")
_BE: Final = struct.Struct(">I")
# Encapsulation header (representation id, options): plain CDR big- or little-endian.
_HEADER_LE: Final = b"\x00\x01\x00\x00"
_FLOAT64: Final = struct.Struct("<d")
_INT64: Final = struct.Struct("<q")
_BOOL: Final = {True: _HEADER_LE + b"\x01\x00\x00\x00", False: _HEADER_LE + b"\x00\x00\x00\x00"}
_LOG_LEVEL_AT: Final = 4 + 8
"""After the header: builtin_interfaces/Time stamp (int32 sec, uint32 nanosec), then uint8 level."""
_LOG_NAME_AT: Final = 4 + 12
"""The name's uint32 length, aligned to 4 after the level byte."""


def _lengths(raw: bytes) -> struct.Struct | None:
    head = raw[:2]
    if head == b"\x00\x01":
        return _LE
    if head == b"\x00\x00":
        return _BE
    return None


def read_log(raw: bytes) -> tuple[int, bytes, bytes] | None:
    """Return ``(level, name, msg)`` (name and msg as UTF-8 bytes) of a serialized Log, or None if unsure."""
    u32 = _lengths(raw)
    if u32 is None or len(raw) < _LOG_NAME_AT + 4:
        return None
    level = raw[_LOG_LEVEL_AT]
    (n,) = u32.unpack_from(raw, _LOG_NAME_AT)
    name_end = _LOG_NAME_AT + 4 + n
    # Strings carry a trailing NUL, counted in their length; the next field is aligned to 4 (from byte 4).
    msg_at = 4 + ((name_end - 4 + 3) & ~3)
    if n < 1 or msg_at + 4 > len(raw):
        return None
    (m,) = u32.unpack_from(raw, msg_at)
    msg_end = msg_at + 4 + m
    if m < 1 or msg_end > len(raw):
        return None
    return level, raw[_LOG_NAME_AT + 4 : name_end - 1], raw[msg_at + 4 : msg_end - 1]


def read_string(raw: bytes) -> bytes | None:
    """Return ``data`` (UTF-8 bytes) of a serialized std_msgs/msg/String, or None if unsure."""
    u32 = _lengths(raw)
    if u32 is None or len(raw) < 8:
        return None
    (n,) = u32.unpack_from(raw, 4)
    if n < 1 or 8 + n > len(raw):
        return None
    return raw[8 : 8 + n - 1]


def encode_value(kind: NumberKind, value: float | int | bool) -> bytes:
    """Serialize `value` as a little-endian CDR std_msgs Float64, Int64 or Bool."""
    if kind == "float":
        return _HEADER_LE + _FLOAT64.pack(value)
    if kind == "int":
        return _HEADER_LE + _INT64.pack(value)
    return _BOOL[bool(value)]
