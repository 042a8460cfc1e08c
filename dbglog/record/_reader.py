"""Load an MCAP recording into per-topic arrays: source times, CDR payloads and, for scalars, values.

Indexed files are read through their summary (the ``mcap`` library's `SeekingReader`): every chunk is
decompressed once and its message indexes give each channel's record offsets, so times, payloads and
scalar values (``std_msgs`` Float64, Int32, Bool, ...) are gathered with numpy, never one Python
object per message. A file whose summary cannot find every message (no summary: a killed recording or
a streaming writer; no chunk index; channels or chunks missing from it; a truncated copy) is scanned
from the start instead, keeping every record that is whole, as the MCAP specification allows; one
problem in `Recording.problems` says so, with what the scan found and how long it took. The file is
opened read-only (memory-mapped).
"""

from __future__ import annotations

import contextlib
import io
import mmap
import os
import struct
import time
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field
from typing import Any, TypeAlias

import numpy as np
import numpy.typing as npt

from dbglog._ros._batch import value_dtype
from dbglog.record._writer import MAGIC, RecordingError

__all__ = [
    "SCALAR_DTYPES",
    "Recording",
    "ScalarValues",
    "TopicData",
    "read_recording",
    "recording_span",
    "scalar_dtype",
]

SCALAR_DTYPES: dict[str, str] = {
    "std_msgs/msg/Float64": "<f8",
    "std_msgs/msg/Float32": "<f4",
    "std_msgs/msg/Int8": "i1",
    "std_msgs/msg/Int16": "<i2",
    "std_msgs/msg/Int32": "<i4",
    "std_msgs/msg/Int64": "<i8",
    "std_msgs/msg/UInt8": "u1",
    "std_msgs/msg/UInt16": "<u2",
    "std_msgs/msg/UInt32": "<u4",
    "std_msgs/msg/UInt64": "<u8",
    "std_msgs/msg/Bool": "u1",
    "std_msgs/msg/Byte": "u1",
    "std_msgs/msg/Char": "u1",
}
"""Single-value std_msgs types whose value sits right after the 4-byte CDR header."""

ScalarValues: TypeAlias = npt.NDArray[np.float64 | np.int64 | np.uint64 | np.bool_]
"""A single-value topic's values as its type holds them (`value_dtype`: exact integers, bools)."""

_SUPPORTED_ENCODINGS = {"cdr"}
_U64 = struct.Struct("<Q")
_REC = struct.Struct("<BQ")


@dataclass
class TopicData:
    """One topic's messages, oldest first."""

    topic: str
    msg_type: str
    times_ns: npt.NDArray[np.int64]
    """Source time of each message (the MCAP publish time; the log time where that is 0)."""
    values: ScalarValues | None = None
    """For single-value std_msgs types: the values as the type holds them (`scalar_dtype`): int64 for
    Int8..Int64, uint64 for UInt8..UInt64, Byte and Char (every integer exact), float64 for Float32 and
    Float64, bool for Bool."""
    definition: str = ""
    """The ``ros2msg`` schema text stored in the file."""
    _data: npt.NDArray[np.uint8] = field(default_factory=lambda: np.empty(0, np.uint8), repr=False)
    _offsets: npt.NDArray[np.int64] = field(default_factory=lambda: np.zeros(1, np.int64), repr=False)

    def __len__(self) -> int:
        return len(self.times_ns)

    def payload(self, i: int) -> bytes:
        """The CDR bytes of message `i` (as a raw subscription takes them)."""
        return self._data[self._offsets[i] : self._offsets[i + 1]].tobytes()

    def payloads(self) -> Iterator[bytes]:
        """Every message's CDR bytes, oldest first."""
        data = self._data
        bounds = self._offsets.tolist()
        for i in range(len(bounds) - 1):
            yield data[bounds[i] : bounds[i + 1]].tobytes()


@dataclass
class Recording:
    """What a file holds: readable topics, unreadable ones (with why) and the problems met."""

    path: str
    topics: dict[str, TopicData]
    unreadable: dict[str, str]
    """Topic -> why its messages cannot be read (unknown encoding, no definition ...)."""
    problems: list[str]
    """What is wrong with the file, each naming it (empty for a whole, indexed file)."""
    indexed: bool
    """True when the summary and indexes were used; False after a linear scan."""
    profile: str = ""


@dataclass
class _Chan:
    topic: str
    schema_id: int
    encoding: str


@dataclass
class _Acc:
    """Per channel: the pieces gathered chunk by chunk."""

    log: list[npt.NDArray[np.int64]] = field(default_factory=list)
    pub: list[npt.NDArray[np.int64]] = field(default_factory=list)
    data: list[npt.NDArray[np.uint8]] = field(default_factory=list)
    lengths: list[npt.NDArray[np.int64]] = field(default_factory=list)
    values: list[ScalarValues] = field(default_factory=list)
    """Scalar topics read without their payloads: the values, decoded chunk by chunk."""


class _Loader:
    def __init__(
        self,
        path: str,
        buf: mmap.mmap | bytes,
        keep_payloads: bool = True,
        span: tuple[int, int] | None = None,
    ) -> None:
        self.path = path
        self.span = span
        self.keep_payloads = keep_payloads
        self.buf = buf
        self.size = len(buf)
        self.schemas: dict[int, tuple[str, str, str]] = {}
        self.channels: dict[int, _Chan] = {}
        self.acc: dict[int, _Acc] = {}
        self.problems: list[str] = []
        self.profile = ""

    # ----- records ---------------------------------------------------------------------------------

    def record(self, op: int, body: Any, where: int) -> None:
        """Read a header, schema or channel record with the ``mcap`` library (a corrupt one is named)."""
        from mcap.data_stream import ReadDataStream
        from mcap.exceptions import McapError
        from mcap.records import Channel, Header, Schema

        stream = ReadDataStream(io.BytesIO(bytes(body)))
        kind = {0x01: "header", 0x03: "schema", 0x04: "channel"}[op]
        try:
            if op == 0x01:
                self.profile = Header.read(stream).profile
            elif op == 0x03:
                schema = Schema.read(stream)
                self.schemas[schema.id] = (schema.name, schema.encoding, schema.data.decode(errors="replace"))
            else:
                channel = Channel.read(stream)
                self.channels[channel.id] = _Chan(channel.topic, channel.schema_id, channel.message_encoding)
        except (McapError, struct.error, UnicodeDecodeError) as exc:
            self.problems.append(f"{self.path}: the {kind} record at byte {where} is corrupt ({_why(exc)})")

    # ----- chunks ----------------------------------------------------------------------------------

    def chunk(self, body: Any, where: int, index: dict[int, npt.NDArray[np.int64]] | None) -> None:
        """Decode one chunk record's body; `index`: channel -> record offsets, else walk the records."""
        _start_t, _end_t, usize, crc = struct.unpack_from("<QQQI", body, 0)
        (n,) = struct.unpack_from("<I", body, 28)
        compression = bytes(body[32 : 32 + n]).decode(errors="replace")
        pos = 32 + n
        (clen,) = struct.unpack_from("<Q", body, pos)
        data = body[pos + 8 : pos + 8 + clen]
        if len(data) != clen:
            self.problems.append(f"{self.path}: the chunk at byte {where} is cut short")
            return
        try:
            if compression == "zstd":
                import zstandard

                raw = zstandard.ZstdDecompressor().decompress(bytes(data), max_output_size=usize)
            elif compression == "lz4":
                import lz4.frame  # type: ignore[import-untyped]

                raw = lz4.frame.decompress(bytes(data))
            elif compression == "":
                raw = bytes(data)
            else:
                self.problems.append(
                    f"{self.path}: the chunk at byte {where} uses unknown compression {compression!r}"
                )
                return
        except Exception as exc:
            self.problems.append(f"{self.path}: the chunk at byte {where} is corrupt ({exc}); skipped")
            return
        if len(raw) != usize or (crc and zlib.crc32(raw) != crc):
            self.problems.append(f"{self.path}: the chunk at byte {where} is corrupt (bad checksum); skipped")
            return
        u = np.frombuffer(raw, dtype=np.uint8)
        if index is None:
            index = self._walk(raw, where)
        for cid, offsets in index.items():
            if len(offsets) == 0:
                continue
            if cid not in self.channels or int(offsets.max()) + 31 > len(raw):
                continue
            self._gather(u, cid, offsets)

    def _walk(self, raw: bytes, where: int) -> dict[int, npt.NDArray[np.int64]]:
        """Find each message record's offset in an uncompressed chunk, by channel."""
        found: dict[int, list[int]] = {}
        pos, end = 0, len(raw)
        unpack = _REC.unpack_from
        while pos + 9 <= end:
            op, length = unpack(raw, pos)
            if pos + 9 + length > end:
                self.problems.append(f"{self.path}: a record in the chunk at byte {where} is cut short")
                break
            if op == 0x05 and length >= 22:
                (cid,) = struct.unpack_from("<H", raw, pos + 9)
                found.setdefault(cid, []).append(pos)
            elif op in (0x03, 0x04):
                self.record(op, memoryview(raw)[pos + 9 : pos + 9 + length], where)
            pos += 9 + length
        return {cid: np.asarray(v, dtype=np.int64) for cid, v in found.items()}

    def _gather(self, u: npt.NDArray[np.uint8], cid: int, offsets: npt.NDArray[np.int64]) -> None:
        acc = self.acc.setdefault(cid, _Acc())
        eight = np.arange(8)
        lengths = u[offsets[:, None] + 1 + eight].copy().view("<u8").ravel().astype(np.int64) - 22
        log = u[offsets[:, None] + 15 + eight].copy().view("<i8").ravel()
        pub = u[offsets[:, None] + 23 + eight].copy().view("<i8").ravel()
        starts = offsets + 31
        if lengths.min() < 0 or int((starts + lengths).max()) > len(u):
            self.problems.append(f"{self.path}: a message record of {self.channels[cid].topic} is malformed")
            keep = (lengths >= 0) & (starts + lengths <= len(u))
            starts, lengths, log, pub = starts[keep], lengths[keep], log[keep], pub[keep]
        if len(lengths) == 0:
            return
        if not self.keep_payloads:
            chan = self.channels[cid]
            name = self.schemas.get(chan.schema_id, ("", "", ""))[0]
            offsets = np.zeros(len(lengths) + 1, dtype=np.int64)
            offsets[:-1] = starts
            values = _scalars(name, u, offsets, lengths)
            if values is not None:
                acc.log.append(log)
                acc.pub.append(pub)
                acc.values.append(values)
                return
        size = int(lengths[0])
        if np.all(lengths == size):
            block = u[starts[:, None] + np.arange(size)].ravel()
        else:
            total = int(lengths.sum())
            ends = np.cumsum(lengths)
            idx = np.arange(total) - np.repeat(ends - lengths - starts, lengths)
            block = u[idx]
        acc.log.append(log)
        acc.pub.append(pub)
        acc.data.append(block)
        acc.lengths.append(lengths)

    # ----- whole file --------------------------------------------------------------------------------

    def indexed(self) -> str | None:
        """Read through the summary; return why not (then scan the file) when it cannot find every message."""
        from mcap.exceptions import McapError
        from mcap.reader import SeekingReader

        if bytes(self.buf[-len(MAGIC) :]) != MAGIC:
            return (
                "no summary or index: the file does not end with an MCAP footer (the recording was not "
                "finished: killed, or still being written; or the file was cut short)"
            )
        try:
            reader = SeekingReader(_View(self.buf), validate_crcs=False)  # type: ignore[arg-type]
            summary = reader.get_summary()
            header = reader.get_header()
        except (McapError, struct.error, ValueError, EOFError, IndexError) as exc:
            return f"no readable summary or index ({_why(exc)})"
        if summary is None:
            return "no summary or index (its writer wrote none)"
        gap = _index_gap(summary)
        if gap is not None:
            return gap
        self.profile = header.profile
        for sid, s in summary.schemas.items():
            self.schemas[sid] = (s.name, s.encoding, s.data.decode(errors="replace"))
        for cid, c in summary.channels.items():
            self.channels[cid] = _Chan(c.topic, c.schema_id, c.message_encoding)
        for ci in sorted(summary.chunk_indexes, key=lambda c: c.chunk_start_offset):
            if self.span is not None and (
                ci.message_end_time < self.span[0] or ci.message_start_time > self.span[1]
            ):
                continue  # outside the time range asked for: not even decompressed
            where = ci.chunk_start_offset
            end = where + ci.chunk_length
            if end > self.size:
                self.problems.append(f"{self.path}: the chunk at byte {where} lies past the end of the file")
                continue
            op, length = _REC.unpack_from(self.buf, where)
            if op != 0x06 or where + 9 + length > self.size:
                self.problems.append(f"{self.path}: the index points at byte {where}, which is not a chunk")
                continue
            index: dict[int, npt.NDArray[np.int64]] | None = {}
            for cid, at in ci.message_index_offsets.items():
                got = self._message_index(at)
                if got is None or index is None:
                    index = None
                    continue
                index[cid] = got
            if not ci.message_index_offsets:
                index = None
            self.chunk(memoryview(self.buf)[where + 9 : where + 9 + length], where, index)
        stats = summary.statistics
        found = self.count()
        if stats is not None and self.span is None and not self.problems and found != stats.message_count:
            return f"the index finds {found:,} of the {stats.message_count:,} messages its statistics count"
        return None

    def count(self) -> int:
        """Messages gathered so far."""
        return sum(len(x) for acc in self.acc.values() for x in acc.log)

    def _message_index(self, at: int) -> npt.NDArray[np.int64] | None:
        if at + 15 > self.size:
            return None
        op, _length, _cid, nbytes = struct.unpack_from("<BQHI", self.buf, at)
        if op != 0x07 or at + 15 + nbytes > self.size or nbytes % 16:
            return None
        pairs = np.frombuffer(self.buf, dtype="<u8", count=nbytes // 8, offset=at + 15)
        return pairs[1::2].astype(np.int64)

    def scan(self) -> None:
        """Read every whole record from the start; stop at the first one cut short or malformed.

        A chunk followed by its message indexes (a killed recording's) is gathered through them; one
        without is walked record by record.
        """
        buf, size, pos = self.buf, self.size, len(MAGIC)
        unpack = _REC.unpack_from
        loose: dict[int, list[int]] = {}
        chunk: tuple[int, int] | None = None
        """The last chunk read (where, body length): gathered once the records after it are known."""
        index: dict[int, npt.NDArray[np.int64]] | None = {}

        def gather_chunk() -> None:
            nonlocal chunk, index
            if chunk is not None:
                where, n = chunk
                usable = index if index and index.keys() <= self.channels.keys() else None
                self.chunk(memoryview(buf)[where + 9 : where + 9 + n], where, usable)
            chunk, index = None, {}

        while pos < size:
            if pos + 9 > size:
                self.problems.append(f"{self.path}: truncated at byte {size} (a record header is cut short)")
                index = None  # the last chunk's message indexes may be cut: walk it
                break
            op, length = unpack(buf, pos)
            if op == 0 or length > size:
                self.problems.append(
                    f"{self.path}: corrupt at byte {pos} (not an MCAP record); stopped there"
                )
                index = None
                break
            if pos + 9 + length > size:
                self.problems.append(
                    f"{self.path}: truncated at byte {size} (the record at byte {pos} needs "
                    f"{9 + length} bytes); kept everything before it"
                )
                index = None
                break
            if op == 0x07:
                offsets = self._message_index(pos) if chunk is not None and length >= 6 else None
                if index is not None and offsets is not None:
                    index[struct.unpack_from("<H", buf, pos + 9)[0]] = offsets
                else:
                    index = None
                pos += 9 + length
                continue
            gather_chunk()
            if op == 0x05:
                if length >= 22:
                    (channel,) = struct.unpack_from("<H", buf, pos + 9)
                    loose.setdefault(channel, []).append(pos)
            elif op == 0x06:
                chunk = (pos, length)
            elif op in (0x01, 0x03, 0x04):
                self.record(op, memoryview(buf)[pos + 9 : pos + 9 + length], pos)
            elif op == 0x02:  # footer: what follows is the closing magic
                break
            pos += 9 + length
        gather_chunk()
        if loose:  # messages outside chunks: gathered like a chunk's, straight from the mapping
            u = np.frombuffer(buf, dtype=np.uint8)
            for cid, starts in loose.items():
                if cid in self.channels:
                    self._gather(u, cid, np.asarray(starts, dtype=np.int64))
            del u

    def result(self, indexed: bool, keep_payloads: bool) -> Recording:
        topics: dict[str, TopicData] = {}
        unreadable: dict[str, str] = {}
        for cid, chan in sorted(self.channels.items()):
            name, encoding, text = self.schemas.get(chan.schema_id, ("", "", ""))
            acc = self.acc.get(cid, _Acc())
            count = sum(len(x) for x in acc.log)
            if acc.values and acc.data:  # mixed (a scan that met the schema late): keep it simple
                acc.values = []
            if chan.encoding not in _SUPPORTED_ENCODINGS:
                unreadable[chan.topic] = f"message encoding {chan.encoding!r} is not CDR ({count} messages)"
                continue
            if not name:
                unreadable[chan.topic] = f"its schema (id {chan.schema_id}) is missing ({count} messages)"
                continue
            if chan.topic in topics:  # a second channel of the same topic: merge
                unreadable.setdefault(chan.topic, "")
            log = np.concatenate(acc.log) if acc.log else np.empty(0, np.int64)
            pub = np.concatenate(acc.pub) if acc.pub else np.empty(0, np.int64)
            lengths = np.concatenate(acc.lengths) if acc.lengths else np.empty(0, np.int64)
            data = np.concatenate(acc.data) if acc.data else np.empty(0, np.uint8)
            times = np.where(pub > 0, pub, log)
            offsets = np.zeros(len(lengths) + 1, dtype=np.int64)
            np.cumsum(lengths, out=offsets[1:])
            kept = np.concatenate(acc.values) if acc.values and len(lengths) == 0 else None
            pick: npt.NDArray[np.int64] | None = None
            if self.span is not None:
                pick = np.flatnonzero((log >= self.span[0]) & (log <= self.span[1]))
            if len(log) > 1 and np.any(np.diff(log if pick is None else log[pick]) < 0):
                base = np.arange(len(log)) if pick is None else pick
                pick = base[np.argsort(log[base], kind="stable")]
            if pick is not None:
                times = times[pick]
                if kept is not None:
                    kept = kept[pick]
                else:
                    starts = offsets[:-1][pick]
                    lengths = lengths[pick]
                    ends = np.cumsum(lengths)
                    data = data[np.arange(int(lengths.sum())) - np.repeat(ends - lengths - starts, lengths)]
                    offsets = np.zeros(len(lengths) + 1, dtype=np.int64)
                    np.cumsum(lengths, out=offsets[1:])
            values = kept if kept is not None else _scalars(name, data, offsets, lengths)
            if values is not None and not keep_payloads:
                data, offsets = np.empty(0, np.uint8), np.zeros(1, np.int64)
            topics[chan.topic] = TopicData(chan.topic, name, times, values, text, data, offsets)
            if encoding not in ("ros2msg", "ros2idl", ""):
                unreadable[chan.topic] = f"schema encoding {encoding!r} is not a ROS 2 one"
                del topics[chan.topic]
            elif values is None and not _type_known(name, text):
                unreadable[chan.topic] = (
                    f"type {name} has no definition in the file and is not installed here ({count} messages)"
                )
                del topics[chan.topic]
        for topic in [t for t, why in unreadable.items() if not why]:
            del unreadable[topic]
        return Recording(self.path, topics, unreadable, self.problems, indexed, self.profile)


class _View:
    """A read-only file object over the mapping, for the ``mcap`` library's readers."""

    def __init__(self, buf: Any) -> None:
        self.buf, self.pos = buf, 0

    def read(self, n: int = -1) -> bytes:
        end = len(self.buf) if n < 0 else min(len(self.buf), self.pos + n)
        out = bytes(self.buf[self.pos : end])
        self.pos = end
        return out

    def seek(self, pos: int, whence: int = 0) -> int:
        base = {0: 0, 1: self.pos, 2: len(self.buf)}[whence]
        self.pos = max(0, base + pos)
        return self.pos

    def tell(self) -> int:
        return self.pos

    def seekable(self) -> bool:
        return True


def _index_gap(summary: Any) -> str | None:
    """Why a summary cannot find every message of its file (then it is scanned); None when it can.

    The MCAP writers' options leave out any part of it: the chunk indexes (and with them every index),
    the schemas and channels repeated there, the statistics; messages outside chunks are never indexed.
    """
    stats = summary.statistics
    indexes = summary.chunk_indexes
    if not indexes:
        if stats is not None and stats.message_count == 0 and stats.channel_count == len(summary.channels):
            return None  # the statistics say the file holds no message: nothing to find
        return "no index (its summary has no chunk index)"
    if stats is not None and stats.chunk_count != len(indexes):
        return f"an incomplete index (its summary indexes {len(indexes)} of its {stats.chunk_count} chunks)"
    listed = {cid for ci in indexes for cid in ci.message_index_offsets}
    if (
        not summary.channels
        or not listed <= summary.channels.keys()
        or (stats is not None and stats.channel_count > len(summary.channels))
    ):
        return "an incomplete summary (it does not list every channel of its chunks)"
    if any(c.schema_id and c.schema_id not in summary.schemas for c in summary.channels.values()):
        return "an incomplete summary (it does not list the schemas of its channels)"
    return None


def _type_known(name: str, text: str) -> bool:
    if text.strip():
        return True
    from dbglog.record._msgdef import message_definition

    return message_definition(name) is not None


def _why(exc: BaseException) -> str:
    text = str(exc) or type(exc).__name__
    return text if len(text) < 120 else text[:117] + "..."


def scalar_dtype(msg_type: str) -> str | None:
    """Return the numpy dtype of a single-value std_msgs type's read values; None for any other type.

    As the batch format's `value_dtype`: ``float64``, ``int64``, ``uint64`` (also Byte and Char) or ``bool``.
    """
    if msg_type not in SCALAR_DTYPES:
        return None
    name = msg_type.rsplit("/", 1)[1]
    return "uint64" if name in ("Byte", "Char") else value_dtype(name)


def _scalars(
    name: str, data: npt.NDArray[np.uint8], offsets: npt.NDArray[np.int64], lengths: npt.NDArray[np.int64]
) -> ScalarValues | None:
    """Read single-value std_msgs payloads as `scalar_dtype` says (both CDR byte orders), vectorised."""
    dtype = SCALAR_DTYPES.get(name)
    out = scalar_dtype(name)
    if dtype is None or out is None:
        return None
    dt = np.dtype(dtype)
    n = len(lengths)
    if n == 0:
        return np.empty(0, out)
    starts = offsets[:-1]
    if int(lengths.min()) < 4 + dt.itemsize:
        return None
    cols = u8 = data[starts[:, None] + 4 + np.arange(dt.itemsize)]
    little = data[starts + 1] == 1
    if not np.all(little):
        u8 = cols.copy()
        u8[~little] = u8[~little, ::-1]
    raw = np.ascontiguousarray(u8).view(dt).ravel()
    values: ScalarValues = raw != 0 if out == "bool" else raw.astype(out)
    return values


def recording_span(path: str | os.PathLike[str]) -> tuple[int, int] | None:
    """Return (first, last) log time in ns from a file's summary statistics; None without a full index.

    Reads the footer and summary only (milliseconds, whatever the file's size), for a viewer that
    opens the end of a long recording first; None too when the file has no index that finds every
    message (a time range would be read by scanning the whole file anyway). A rosbag2 directory: its
    first ``.mcap`` file.
    """
    from mcap.exceptions import McapError
    from mcap.reader import SeekingReader

    path = os.fspath(path)
    if os.path.isdir(path):
        files = sorted(f for f in os.listdir(path) if f.endswith(".mcap"))
        if len(files) != 1:
            return None
        path = os.path.join(path, files[0])
    try:
        with open(path, "rb") as f:
            summary = SeekingReader(f, validate_crcs=False).get_summary()
    except (OSError, McapError, struct.error, ValueError, EOFError, IndexError):
        return None
    stats = None if summary is None else summary.statistics
    if stats is None or not stats.message_count or _index_gap(summary) is not None:
        return None
    return int(stats.message_start_time), int(stats.message_end_time)


def read_recording(
    path: str | os.PathLike[str],
    *,
    keep_payloads: bool = True,
    start_ns: int | None = None,
    end_ns: int | None = None,
) -> Recording:
    """Load every topic of the MCAP file at `path` (read-only; never modifies it).

    Args:
        path: an ``.mcap`` file, or a rosbag2 directory holding one (with its ``metadata.yaml``).
        keep_payloads: keep the CDR bytes of single-value topics too (their `values` are always read).
        start_ns: keep only messages logged at or after this time (ns since the epoch); with an index,
            chunks before it are not even decompressed (a first frame of a long file at once).
        end_ns: keep only messages logged at or before this time.

    Raises:
        RecordingError: the file cannot be opened or is not MCAP at all (the message names it).
    """
    path = os.fspath(path)
    if os.path.isdir(path):
        files = sorted(f for f in os.listdir(path) if f.endswith(".mcap"))
        if not files:
            raise RecordingError(f"{path}: a directory without an .mcap file (is it a rosbag2 bag?)")
        if len(files) > 1:
            parts = [
                read_recording(
                    os.path.join(path, f), keep_payloads=keep_payloads, start_ns=start_ns, end_ns=end_ns
                )
                for f in files
            ]
            return _merge(path, parts)
        path = os.path.join(path, files[0])
    try:
        with open(path, "rb") as f:
            size = os.fstat(f.fileno()).st_size
            if size == 0:
                raise RecordingError(f"{path}: the file is empty")
            buf: mmap.mmap | bytes = mmap.mmap(f.fileno(), 0, access=mmap.ACCESS_READ)
    except FileNotFoundError:
        raise RecordingError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise RecordingError(f"{path}: is a directory") from None
    except OSError as exc:
        raise RecordingError(f"{path}: cannot open it ({exc.strerror or exc})") from None
    if bytes(buf[: len(MAGIC)]) != MAGIC:
        raise RecordingError(f"{path}: not an MCAP file (it does not start with the MCAP magic bytes)")
    span = None
    if start_ns is not None or end_ns is not None:
        span = (start_ns if start_ns is not None else -(2**63), end_ns if end_ns is not None else 2**63 - 1)
    loader = _Loader(path, buf, keep_payloads, span)
    why = loader.indexed()
    if why is not None:
        loader.schemas.clear()
        loader.channels.clear()
        loader.acc.clear()
        loader.problems.clear()
        start = time.perf_counter()
        loader.scan()
        took = time.perf_counter() - start
        found = "no message" if not loader.count() else f"{loader.count():,} messages"
        loader.problems.insert(0, f"{path}: {why}; read by scanning the whole file: {found} in {took:.2f} s")
    recording = loader.result(why is None, keep_payloads)
    del loader
    if isinstance(buf, mmap.mmap):
        with contextlib.suppress(BufferError):  # a view still alive: the mapping goes with it
            buf.close()
    return recording


def _merge(path: str, parts: list[Recording]) -> Recording:
    topics: dict[str, TopicData] = {}
    for part in parts:
        for name, t in part.topics.items():
            topics.setdefault(name, t)
    return Recording(
        path,
        topics,
        {k: v for p in parts for k, v in p.unreadable.items()},
        [m for p in parts for m in p.problems],
        all(p.indexed for p in parts),
        parts[0].profile,
    )
