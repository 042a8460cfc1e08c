"""The batch wire format: many tag samples with their source times in one ``UInt8MultiArray`` message.

The SDK's publisher thread sends one batch per flush on the hidden topic `BATCH_TOPIC`; the viewer's
engine reads every sample (in order, with its own source time) from it instead of one message per
sample on ``/rosdashboard/<tag>``. Version 2 layout, little-endian, in the message's ``data`` field::

    header   "DBGL" u8 version u8 flags u16 n_tags u32 n_samples u64 writer u64 seq u32 n_strings
    tags     n_tags x (u8 type code, u16 name length, name UTF-8); the sample tag index is the position
    pad      zero bytes to a multiple of 8 from the start of the payload
    index    u16 x n_samples, padded to 8
    times    i64 x n_samples (source time, ns since the epoch)
    values   8 bytes x n_samples, read as the sample's tag type says (`SLOT_FORMATS`): f64 for
             Float64/Float32, i64 for Int8..Int64, u64 for UInt8..UInt64 (so every integer is exact),
             u64 0/1 for Bool, u64 for String: the number of its text in `strings`
    strings  u32 x n_strings lengths, then the UTF-8 texts back to back

Version 1 (still read: an older SDK elsewhere on the network sends it) is the same but for the values:
f64 for every sample, integers beyond 2**53 rounded. `writer` is random per connection and `seq` counts
its batches from 0, so a reader sees lost batches. No import of rclpy or numpy at module level.
"""

from __future__ import annotations

import re
import struct
from array import array
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from dbglog._ros._cdr import CDR_HEADER

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = [
    "BATCH_DEPTH",
    "BATCH_TOPIC",
    "BATCH_TYPE",
    "SCALAR_TYPES",
    "SLOT_FORMATS",
    "BatchError",
    "DecodedBatch",
    "TagSamples",
    "batch_robot",
    "batch_topic",
    "decode_batch",
    "encode_batch",
    "is_reader_node",
    "is_sdk_node",
    "pack_values",
    "sdk_node_name",
    "type_code",
    "value_dtype",
]

BATCH_TOPIC = "/_dbglog/samples"
"""Hidden (``_``) topic of the batches: ``ros2 topic list`` leaves it out unless asked."""
BATCH_TYPE = "std_msgs/msg/UInt8MultiArray"
_BATCH_ROBOT = re.compile(r"((?:/[A-Za-z_][A-Za-z0-9_]*)*)" + re.escape(BATCH_TOPIC))


def batch_topic(robot: str) -> str:
    """Return the batch topic of a robot namespace (``/robot1/_dbglog/samples``; `BATCH_TOPIC` for ``""``).

    A batch carries its tags as in their topic names; the robot is the batch topic's namespace.
    """
    return robot + BATCH_TOPIC


def batch_robot(topic: str) -> str | None:
    """Return the robot namespace of a batch topic (``""`` for `BATCH_TOPIC`), None for any other topic."""
    if not topic.endswith(BATCH_TOPIC):
        return None
    match = _BATCH_ROBOT.fullmatch(topic)
    return match.group(1) if match is not None else None


_SDK_NODE = re.compile(r"dbglog_[0-9]+")


def sdk_node_name(pid: int) -> str:
    """Return the name of the SDK's own node in process `pid` (the node that writes the batches)."""
    return f"dbglog_{pid}"


def is_sdk_node(name: str) -> bool:
    """True for a node named by `sdk_node_name` (not the viewer's, the CLI's or a user's own node)."""
    return _SDK_NODE.fullmatch(name) is not None


_READER_NODE = re.compile(r"dbglog_(?:viewer|echo|tags|record_[0-9]+)")


def is_reader_node(name: str) -> bool:
    """True for the node of a dbglog reader of the batches: the viewer's engine (``dbglog_viewer``),
    ``dbglog echo`` and ``dbglog tags``, ``dbglog record`` (``dbglog_record_<pid>``)."""
    return _READER_NODE.fullmatch(name) is not None


BATCH_DEPTH = 1000
"""KEEP_LAST depth of the batch writer and reader: seconds of batches at a few ms per flush."""

SCALAR_TYPES: tuple[str, ...] = (
    "Float64",
    "Float32",
    "Int8",
    "Int16",
    "Int32",
    "Int64",
    "UInt8",
    "UInt16",
    "UInt32",
    "UInt64",
    "Bool",
    "String",
)
"""std_msgs types a batch carries, by type code (their index)."""

SLOT_FORMATS = "ddqqqqQQQQQQ"
"""`struct` code of the 8-byte value slot of each type code in a version-2 batch (f64, i64 or u64)."""

_MAGIC = b"DBGL"
_VERSION = 2
_READS = (1, 2)
"""Versions `decode_batch` reads."""
_SLOT_DTYPES = {"d": "<f8", "q": "<i8", "Q": "<u8"}
_FLOAT_TYPES = frozenset(("Float64", "Float32"))
_HEADER = struct.Struct("<4sBBHIQQI")
_TAG = struct.Struct("<BH")
_CDR_PREFIX = struct.Struct("<4sIII")
_CDR_PREFIX_SIZE = _CDR_PREFIX.size


class BatchError(ValueError):
    """A batch message that does not follow the layout (truncated, unknown version, bad index)."""


def type_code(std_type: str) -> int:
    """Return the code of a std_msgs scalar type name (``Float64`` ...), as the tag table stores it."""
    return SCALAR_TYPES.index(std_type)


def _pad8(n: int) -> int:
    return (-n) % 8


def pack_values(slots: str, values: Sequence[float]) -> bytes:
    """Return the values column of a version-2 batch: each value packed as its slot's code says.

    Args:
        slots: one `SLOT_FORMATS` code (``d``, ``q`` or ``Q``) per sample.
        values: each sample's number (a float, an int in its slot's range; a bool for Bool, the text's
            number for String).

    Raises:
        struct.error, TypeError, OverflowError: a value does not fit its slot.
    """
    if not slots:
        return b""
    if slots.count(slots[0]) == len(slots):  # one kind (the usual batch): one C loop, no format to parse
        return array(slots[0], values).tobytes()  # native order: little-endian, as `index` and `times`
    return struct.pack("<" + slots, *values)


def encode_batch(
    writer: int,
    seq: int,
    tags: Sequence[tuple[int, bytes]],
    index: array[int],
    times: array[int],
    values: array[float] | bytes,
    strings: Sequence[bytes],
) -> bytes:
    """Return the full CDR message (``UInt8MultiArray``) of one batch.

    Args:
        writer: the writer's id (u64).
        seq: the batch's sequence number (u64).
        tags: (type code, tag UTF-8) per tag; samples refer to them by position.
        index: ``array('H')``: each sample's tag position.
        times: ``array('q')``: each sample's source time in ns.
        values: the values column (`pack_values`; an ``array('d')`` when every tag is a float tag).
        strings: the texts of String samples, numbered in order.
    """
    n = len(index)
    parts = [_HEADER.pack(_MAGIC, _VERSION, 0, len(tags), n, writer, seq, len(strings))]
    size = _HEADER.size
    for code, name in tags:
        parts.append(_TAG.pack(code, len(name)))
        parts.append(name)
        size += _TAG.size + len(name)
    parts.append(bytes(_pad8(size)))
    idx = index.tobytes()
    parts.append(idx)
    parts.append(bytes(_pad8(len(idx))))
    parts.append(times.tobytes())
    parts.append(values.tobytes() if isinstance(values, array) else bytes(values))
    if strings:
        parts.append(array("I", [len(s) for s in strings]).tobytes())
        parts.extend(strings)
    payload = b"".join(parts)
    return _CDR_PREFIX.pack(CDR_HEADER, 0, 0, len(payload)) + payload


@dataclass(frozen=True, slots=True)
class TagSamples:
    """One tag's samples in a batch, in the order they were logged."""

    tag: str
    std_type: str
    """``Float64``, ``Int32``, ``String`` ... (the per-tag topic's std_msgs type)."""
    times_ns: npt.NDArray[np.int64]
    values: npt.NDArray[Any] | list[str]
    """The numbers as the tag's type holds them (`value_dtype`: float64, int64, uint64 or bool), or the
    texts of a String tag."""


@dataclass(frozen=True, slots=True)
class DecodedBatch:
    """A decoded batch: who wrote it, its number, and its samples grouped by tag."""

    writer: int
    seq: int
    samples: int
    tags: list[TagSamples]


def value_dtype(std_type: str) -> str:
    """Return the numpy dtype of a numeric tag type's decoded values (``float64``, ``int64`` ...)."""
    if std_type in _FLOAT_TYPES:
        return "float64"
    if std_type == "Bool":
        return "bool"
    return "uint64" if std_type.startswith("UInt") else "int64"


def decode_batch(cdr: bytes) -> DecodedBatch:
    """Decode one batch message (version 1 or 2) from its CDR bytes (as a raw subscription takes them).

    Raises:
        BatchError: the bytes are not a batch of a version this dbglog reads.
    """
    import numpy as np

    buf = memoryview(cdr)
    if len(buf) < _CDR_PREFIX_SIZE + _HEADER.size:
        raise BatchError(f"a batch of {len(buf)} bytes is too short")
    _, dims, _, length = _CDR_PREFIX.unpack_from(buf, 0)
    if dims != 0 or _CDR_PREFIX_SIZE + length > len(buf):
        raise BatchError("not a dbglog batch (unexpected UInt8MultiArray layout)")
    data = buf[_CDR_PREFIX_SIZE : _CDR_PREFIX_SIZE + length]
    magic, version, _, n_tags, n, writer, seq, n_strings = _HEADER.unpack_from(data, 0)
    if magic != _MAGIC:
        raise BatchError("not a dbglog batch (bad magic)")
    if version not in _READS:
        raise BatchError(
            f"batch version {version} is not supported (this dbglog reads versions "
            f"{', '.join(map(str, _READS))}): the sender's dbglog is newer, update this one"
        )
    pos = _HEADER.size
    table: list[tuple[str, str]] = []
    try:
        for _ in range(n_tags):
            code, name_len = _TAG.unpack_from(data, pos)
            pos += _TAG.size
            name = bytes(data[pos : pos + name_len]).decode()
            pos += name_len
            table.append((name, SCALAR_TYPES[code]))
        pos += _pad8(pos)
        index = np.frombuffer(data, dtype="<u2", count=n, offset=pos)
        pos += 2 * n + _pad8(2 * n)
        times = np.frombuffer(data, dtype="<i8", count=n, offset=pos)
        pos += 8 * n
        raw = data[pos : pos + 8 * n]
        pos += 8 * n
        lengths = np.frombuffer(data, dtype="<u4", count=n_strings, offset=pos) if n_strings else None
        pos += 4 * n_strings
    except (struct.error, ValueError, IndexError, UnicodeDecodeError) as exc:
        raise BatchError(f"truncated or corrupt batch: {exc}") from exc
    if len(raw) != 8 * n or (n and int(index.max()) >= n_tags):
        raise BatchError("truncated or corrupt batch (sample section)")
    texts: list[str] = []
    if lengths is not None:
        for size in lengths.tolist():
            texts.append(bytes(data[pos : pos + size]).decode(errors="replace"))
            pos += size
    order = np.argsort(index, kind="stable")
    bounds = np.searchsorted(index[order], np.arange(n_tags + 1))
    columns: dict[str, npt.NDArray[Any]] = {}  # the values section read as f64, i64 or u64

    def column(slot: str) -> npt.NDArray[Any]:
        if slot not in columns:
            columns[slot] = np.frombuffer(raw, dtype=_SLOT_DTYPES[slot])
        return columns[slot]

    out: list[TagSamples] = []
    for i, (name, std_type) in enumerate(table):
        sel = order[bounds[i] : bounds[i + 1]]
        if not len(sel):
            continue
        slot = "d" if version == 1 else SLOT_FORMATS[SCALAR_TYPES.index(std_type)]
        got = column(slot)[sel]
        values: npt.NDArray[Any] | list[str]
        if std_type == "String":
            try:
                values = [texts[int(k)] for k in got.tolist()]
            except (IndexError, ValueError, OverflowError) as exc:
                raise BatchError("a String sample refers to a missing text") from exc
        elif std_type == "Bool":
            values = got != 0
        elif slot == "d" and std_type not in _FLOAT_TYPES:  # version 1: an integer sent as f64
            values = _float_to_int(got, np.dtype(value_dtype(std_type)))
        else:
            values = got
        out.append(TagSamples(name, std_type, times[sel], values))
    return DecodedBatch(writer, seq, n, out)


def _float_to_int(values: npt.NDArray[np.float64], dtype: np.dtype[Any]) -> npt.NDArray[Any]:
    """Return a version-1 batch's f64 integers as `dtype`, saturated (2**63 - 1 may have become 2**63)."""
    import numpy as np

    info = np.iinfo(dtype)
    top = float(info.max) + 1.0  # a power of 2, exact: the first float beyond the type's range
    clean = np.nan_to_num(values, nan=0.0, posinf=top, neginf=float(info.min))
    out = np.clip(clean, float(info.min), np.nextafter(top, 0.0)).astype(dtype)
    out[clean >= top] = info.max
    return out
