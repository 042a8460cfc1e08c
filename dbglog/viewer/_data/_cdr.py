"""Bulk decoding of raw CDR payloads: many messages' fixed-offset values in one numpy call.

A serialized ROS 2 message is a 4-byte encapsulation header (``00 01 00 00`` = CDR little endian)
followed by the payload, where each primitive sits at an offset aligned to its size. For a field
whose offset is fixed (every field before it has a fixed size, see ``_fields``) a batch of
same-length messages is one strided numpy view; messages of varying length fall back to ``struct``.
"""

from __future__ import annotations

import struct
from collections.abc import Sequence

import numpy as np
import numpy.typing as npt

__all__ = ["HEADER_SIZE", "decode_fixed"]

HEADER_SIZE = 4
_CDR_LE = b"\x00\x01"
_STRUCT_CODES = {"?": "?", "u1": "B", "i1": "b", "<i2": "<h", "<u2": "<H", "<i4": "<i", "<u4": "<I"}
_STRUCT_CODES |= {"<i8": "<q", "<u8": "<Q", "<f4": "<f", "<f8": "<d"}


def decode_fixed(
    buffers: Sequence[bytes], fields: Sequence[tuple[int, str]]
) -> list[npt.NDArray[np.float64]] | None:
    """Read each (payload offset, dtype) field from every buffer as float64 arrays.

    Returns None when a buffer is not little-endian CDR or is too short, so the caller can fall back
    to full deserialization for that batch.
    """
    n = len(buffers)
    if n == 0:
        return [np.empty(0) for _ in fields]
    first_len = len(buffers[0])
    same = all(len(b) == first_len for b in buffers)
    if same and n > 8:
        joined = b"".join(buffers)
        raw = np.frombuffer(joined, dtype=np.uint8).reshape(n, first_len)
        if first_len < HEADER_SIZE or not (
            np.all(raw[:, 0] == _CDR_LE[0]) and np.all(raw[:, 1] == _CDR_LE[1])
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
