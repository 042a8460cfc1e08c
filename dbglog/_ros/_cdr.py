"""CDR, the ROS 2 wire format: the encapsulation header, scalar std_msgs encoding, and fast readers.

A serialized ROS 2 message is a 4-byte encapsulation header (``00 01 00 00`` = plain CDR little endian,
as every ROS 2 DDS middleware writes it) followed by the payload, where each primitive sits at an
offset aligned to its size. `decode_fixed` reads fixed-offset fields of many same-length messages as
one strided numpy view; `read_log` and `read_string` read a Log's or a String's text without rclpy.
No import of rclpy or numpy at module level.
"""

from __future__ import annotations

import functools
import struct
from collections.abc import Callable, Sequence
from typing import TYPE_CHECKING, Final

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = [
    "CDR_HEADER",
    "HEADER_SIZE",
    "SCALAR_FORMATS",
    "decode_fixed",
    "encode_scalar",
    "read_log",
    "read_string",
    "scalar_encoder",
    "string_payload",
]

CDR_HEADER: Final = b"\x00\x01\x00\x00"
"""Encapsulation header of little-endian plain CDR (representation id, options)."""
HEADER_SIZE: Final = 4
_CDR_LE: Final = CDR_HEADER[:2]
_LE_FIRST, _LE_SECOND = _CDR_LE[:1], _CDR_LE[1:2]
_CDR_BE: Final = b"\x00\x00"
SCALAR_FORMATS: Final[dict[str, str]] = {
    "Float64": "<d",
    "Float32": "<f",
    "Int8": "<bxxx",
    "Int16": "<hxx",
    "Int32": "<i",
    "Int64": "<q",
    "UInt8": "<Bxxx",
    "UInt16": "<Hxx",
    "UInt32": "<I",
    "UInt64": "<Q",
    "Bool": "<?xxx",
}
"""`struct` format of the CDR body of each one-field std_msgs scalar type, padded to 4 bytes."""
_STRUCT_CODES = {"?": "?", "u1": "B", "i1": "b", "<i2": "<h", "<u2": "<H", "<i4": "<i", "<u4": "<I"}
_STRUCT_CODES |= {"<i8": "<q", "<u8": "<Q", "<f4": "<f", "<f8": "<d"}
_LE: Final = struct.Struct("<I")
_BE: Final = struct.Struct(">I")
_LOG_LEVEL_AT: Final = 4 + 8
"""After the header: builtin_interfaces/Time stamp (int32 sec, uint32 nanosec), then uint8 level."""
_LOG_NAME_AT: Final = 4 + 12
"""The name's uint32 length, aligned to 4 after the level byte."""


def encode_scalar(fmt: str, value: object) -> bytes:
    """Return the CDR bytes (header included) of a checked value with body format `fmt` (`SCALAR_FORMATS`)."""
    return CDR_HEADER + struct.pack(fmt, value)


def scalar_encoder(fmt: str) -> Callable[[object], bytes]:
    """Return value -> CDR bytes for body format `fmt` as one C call (`encode_scalar`'s bytes)."""
    return functools.partial(struct.Struct("<4s" + fmt[1:]).pack, CDR_HEADER)


def _lengths(raw: bytes) -> struct.Struct | None:
    head = raw[:2]
    if head == _CDR_LE:
        return _LE
    if head == _CDR_BE:
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


def string_payload(text: str) -> bytes:
    """Return the CDR bytes of a std_msgs/msg/String holding `text` (what `read_string` reads back)."""
    data = text.encode("utf-8", "replace")
    return CDR_HEADER + struct.pack("<I", len(data) + 1) + data + b"\x00"


def decode_fixed(
    buffers: Sequence[bytes], fields: Sequence[tuple[int, str]]
) -> list[npt.NDArray[np.float64]] | None:
    """Read each (payload offset, dtype) field from every buffer as float64 arrays.

    Returns None when a buffer is not little-endian CDR or is too short, so the caller can fall back
    to full deserialization for that batch.
    """
    import numpy as np

    n = len(buffers)
    if n == 0:
        return [np.empty(0) for _ in fields]
    first_len = len(buffers[0])
    same = all(len(b) == first_len for b in buffers)
    if same and n > 8:
        joined = b"".join(buffers)
        # Every message's first two bytes, as byte strings: cheaper than numpy for the batches that come.
        if first_len < HEADER_SIZE or not (
            joined[0::first_len] == _LE_FIRST * n and joined[1::first_len] == _LE_SECOND * n
        ):
            return None
        out = []
        for offset, dtype in fields:
            dt = np.dtype(dtype)
            start = HEADER_SIZE + offset
            if start + dt.itemsize > first_len:
                return None
            view: npt.NDArray[np.generic] = np.ndarray(
                shape=(n,), dtype=dt, buffer=joined, offset=start, strides=(first_len,)
            )
            out.append(view.astype(np.float64))
        return out
    # Few or uneven messages: struct per message is cheaper than numpy's per-call overhead.
    columns: list[list[float]] = [[] for _ in fields]
    unpackers = [(HEADER_SIZE + offset, struct.Struct(_STRUCT_CODES[dtype])) for offset, dtype in fields]
    for buf in buffers:
        if buf[:2] != _CDR_LE:
            return None
        for column, (start, unpacker) in zip(columns, unpackers, strict=True):
            if start + unpacker.size > len(buf):
                return None
            column.append(unpacker.unpack_from(buf, start)[0])
    return [np.asarray(c, dtype=np.float64) for c in columns]
