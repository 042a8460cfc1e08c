"""An MCAP writer in the ROS 2 profile: CDR payloads, ``ros2msg`` schemas, zstd chunks, indexes, summary.

The hot path packs message records into the open chunk with one ``struct`` call; a chunk is closed,
compressed and written with its message indexes once it holds `chunk_bytes` or when `flush` is called
(the recorder flushes at least every second, so a killed recording loses at most that much). `close`
writes the summary (schemas, channels, statistics, chunk indexes, summary offsets) and the footer.
The non-hot records are built with the ``mcap`` library's own record classes.
"""

from __future__ import annotations

import os
import struct
import zlib
from array import array
from collections.abc import Mapping
from typing import IO, TYPE_CHECKING

from mcap.data_stream import RecordBuilder
from mcap.records import (
    Channel,
    ChunkIndex,
    DataEnd,
    Footer,
    Header,
    Schema,
    Statistics,
    SummaryOffset,
)

from dbglog.record._msgdef import message_definition

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

__all__ = ["MAGIC", "McapWriter", "RecordingError"]

MAGIC = b"\x89MCAP0\r\n"
_MESSAGE = struct.Struct("<BQHIQQ")
_MESSAGE_OP = 0x05
_CHUNK_OP = 0x06
_INDEX_OP = 0x07
_INDEX_HEAD = struct.Struct("<BQHI")
_CHUNK_HEAD = struct.Struct("<BQQQQI")


class RecordingError(Exception):
    """A recording that cannot be written or read; the message names the file and what is wrong."""


class _Open:
    """The chunk being filled: its records and, per message, channel, log time and offset."""

    __slots__ = ("bulk", "channels", "offsets", "records", "times")

    def __init__(self) -> None:
        self.records = bytearray()
        self.channels = array("H")
        self.times = array("q")
        self.offsets = array("q")
        self.bulk: list[tuple[int | npt.NDArray[np.int64], npt.NDArray[np.int64], npt.NDArray[np.int64]]] = []
        """Entries of `write_fixed`: (channel or channel per message, log times, offsets)."""

    @property
    def count(self) -> int:
        return len(self.channels) + sum(len(t) for _, t, _ in self.bulk)


class McapWriter:
    """Write one MCAP file (ROS 2 profile); never replaces an existing file unless `force`.

    The file gets mode 0666 less the umask, as any file the user creates.

    Example::

        with McapWriter("run.mcap") as out:
            ch = out.add_channel("/rosdashboard/speed", "std_msgs/msg/Float64")
            out.write(ch, log_time_ns, payload_cdr, publish_time_ns)
    """

    def __init__(
        self,
        path: str | os.PathLike[str],
        *,
        force: bool = False,
        atomic: bool = False,
        chunk_bytes: int = 1 << 20,
        level: int = 3,
        library: str = "dbglog",
    ) -> None:
        """Create the file and write its header.

        The file gets mode 0666 less the umask. It is written under a temporary name beside `path`
        and renamed onto it: at once, after the header (a recording: a killed recorder leaves a
        readable file at `path`, and `force` replaces an existing file only once the new one is
        created), or with `atomic` by `close` (a snapshot, a saved history: `path` appears whole or not
        at all, and `abandon` leaves nothing).

        Args:
            path: the file to create.
            force: replace an existing file.
            atomic: put the file at `path` only when `close` has written it whole.
            chunk_bytes: uncompressed bytes after which a chunk is closed.
            level: zstd compression level.
            library: written in the header.

        Raises:
            RecordingError: the file exists (without `force`) or cannot be created.
        """
        import zstandard

        from dbglog._files import create_temp, discard_temp

        self.path = os.fspath(path)
        self._force = force
        if os.path.isdir(self.path):
            raise RecordingError(f"cannot create {self.path}: it is a folder")
        if not force and os.path.lexists(self.path):
            raise RecordingError(f"{self.path} already exists (use --force to overwrite it)")
        try:
            fd, self._tmp = create_temp(self.path)
        except OSError as exc:
            raise RecordingError(f"cannot create {self.path}: {exc.strerror or exc}") from None
        self._file: IO[bytes] = os.fdopen(fd, "wb")
        self._placed = False
        self._zstd = zstandard.ZstdCompressor(level=level)
        self.chunk_bytes = chunk_bytes
        self._schemas: dict[str, Schema] = {}
        self._channels: dict[int, Channel] = {}
        self._by_topic: dict[tuple[str, str], int] = {}
        self._chunk_indexes: list[ChunkIndex] = []
        self._open = _Open()
        self._counts: dict[int, int] = {}
        self.messages = 0
        self._start = 0
        self._end = 0
        self._closed = False
        self.size = 0
        builder = RecordBuilder()
        Header(profile="ros2", library=library).write(builder)
        try:
            self._put(MAGIC + _end(builder))
            if not atomic:
                self._file.flush()
                self._place()
        except BaseException:
            self._file.close()
            discard_temp(self._tmp)
            raise

    def _place(self) -> None:
        """Rename the file being written onto `path` (RecordingError when it exists, without `force`)."""
        from dbglog._files import put_in_place

        try:
            put_in_place(self._tmp, self.path, replace=self._force)
        except FileExistsError:
            raise RecordingError(f"{self.path} already exists (use --force to overwrite it)") from None
        except OSError as exc:
            raise RecordingError(f"cannot create {self.path}: {exc.strerror or exc}") from None
        self._placed = True

    # ----- setup ---------------------------------------------------------------------------------

    def add_channel(
        self,
        topic: str,
        msg_type: str,
        *,
        definition: str | None = None,
        metadata: Mapping[str, str] | None = None,
    ) -> int:
        """Register a topic (once per topic and type) and return its channel id.

        The schema's text is `definition`, or the installed ``.msg`` files of `msg_type` (empty when
        the type is not installed here: readers then cannot decode it, the CDR bytes are still kept).
        """
        key = (topic, msg_type)
        if key in self._by_topic:
            return self._by_topic[key]
        builder = RecordBuilder()
        schema = self._schemas.get(msg_type)
        if schema is None:
            text = definition if definition is not None else message_definition(msg_type) or ""
            schema = Schema(id=len(self._schemas) + 1, name=msg_type, encoding="ros2msg", data=text.encode())
            self._schemas[msg_type] = schema
            schema.write(builder)
        channel = Channel(
            id=len(self._channels) + 1,
            topic=topic,
            message_encoding="cdr",
            schema_id=schema.id,
            metadata=dict(metadata or {}),
        )
        self._channels[channel.id] = channel
        self._by_topic[key] = channel.id
        self._counts[channel.id] = 0
        channel.write(builder)
        # Outside any chunk and before the first message that uses them: a truncated file keeps them.
        self._put(_end(builder))
        return channel.id

    # ----- messages ------------------------------------------------------------------------------

    def write(
        self, channel: int, log_time: int, data: bytes, publish_time: int = 0, sequence: int = 0
    ) -> None:
        """Append one message (times in ns since the epoch) to the open chunk."""
        chunk = self._open
        records = chunk.records
        offset = len(records)
        records += _MESSAGE.pack(_MESSAGE_OP, 22 + len(data), channel, sequence, log_time, publish_time)
        records += data
        chunk.channels.append(channel)
        chunk.times.append(log_time)
        chunk.offsets.append(offset)
        if offset > self.chunk_bytes:
            self.close_chunk()

    def write_fixed(
        self,
        channel: int | npt.NDArray[np.int64],
        log_times: npt.NDArray[np.int64],
        payloads: npt.NDArray[np.uint8],
        publish_times: npt.NDArray[np.int64] | None = None,
    ) -> None:
        """Append many same-size messages at once (`payloads` is n x size bytes).

        Vectorised with numpy: for generating large files, writing snapshots and the samples of SDK
        batches. `channel` is one channel for all, or one per message.
        """
        import numpy as np

        n, size = payloads.shape
        per_chunk = max(1, self.chunk_bytes // (31 + size))
        pub = log_times if publish_times is None else publish_times
        for lo in range(0, n, per_chunk):
            hi = min(n, lo + per_chunk)
            rows = np.zeros((hi - lo, 31 + size), dtype=np.uint8)
            rows[:, 0] = _MESSAGE_OP
            rows[:, 1:9] = np.full(hi - lo, 22 + size, dtype="<u8").view(np.uint8).reshape(-1, 8)
            chans = np.full(hi - lo, channel, dtype="<u2") if isinstance(channel, int) else channel[lo:hi]
            rows[:, 9:11] = chans.astype("<u2").view(np.uint8).reshape(-1, 2)
            rows[:, 15:23] = log_times[lo:hi].astype("<u8").view(np.uint8).reshape(-1, 8)
            rows[:, 23:31] = pub[lo:hi].astype("<u8").view(np.uint8).reshape(-1, 8)
            rows[:, 31:] = payloads[lo:hi]
            chunk = self._open
            base = len(chunk.records)
            chunk.records += rows.tobytes()
            offsets = base + np.arange(hi - lo, dtype=np.int64) * (31 + size)
            times = log_times[lo:hi]
            part = channel if isinstance(channel, int) else channel[lo:hi].astype(np.int64)
            chunk.bulk.append((part, times.astype(np.int64), offsets))
            if len(chunk.records) > self.chunk_bytes:
                self.close_chunk()

    def close_chunk(self) -> None:
        """Compress and write the open chunk and its message indexes (nothing when it is empty)."""
        import numpy as np

        chunk = self._open
        if not chunk.channels and not chunk.bulk:
            return
        self._open = _Open()
        channels = [np.frombuffer(chunk.channels, dtype=np.uint16).astype(np.int64)]
        times = [np.frombuffer(chunk.times, dtype=np.int64)]
        offsets = [np.frombuffer(chunk.offsets, dtype=np.int64)]
        for channel, t_part, o_part in chunk.bulk:
            channels.append(
                np.full(len(t_part), channel, dtype=np.int64) if isinstance(channel, int) else channel
            )
            times.append(t_part)
            offsets.append(o_part)
        ch = np.concatenate(channels)
        t = np.concatenate(times)
        o = np.concatenate(offsets)
        count = len(ch)
        start, end = int(t.min()), int(t.max())
        raw = bytes(chunk.records)
        compressed = self._zstd.compress(raw)
        compression = b"zstd"
        body_len = 8 + 8 + 8 + 4 + 4 + len(compression) + 8 + len(compressed)
        head = _CHUNK_HEAD.pack(_CHUNK_OP, body_len, start, end, len(raw), zlib.crc32(raw))
        head += struct.pack("<I", len(compression)) + compression + struct.pack("<Q", len(compressed))
        chunk_start = self.size
        chunk_length = len(head) + len(compressed)
        parts = [head, compressed]
        index_offsets: dict[int, int] = {}
        index_start = chunk_start + chunk_length
        pos = index_start
        order = np.lexsort((t, ch))  # by channel, then log time
        ch, t, o = ch[order], t[order], o[order]
        bounds = (np.flatnonzero(np.diff(ch)) + 1).tolist()
        for lo, hi in zip([0, *bounds], [*bounds, count], strict=True):
            channel = int(ch[lo])
            pairs_arr = np.empty((hi - lo, 2), dtype="<u8")
            pairs_arr[:, 0] = t[lo:hi]
            pairs_arr[:, 1] = o[lo:hi]
            pairs = pairs_arr.tobytes()
            record = _INDEX_HEAD.pack(_INDEX_OP, 2 + 4 + len(pairs), channel, len(pairs)) + pairs
            index_offsets[channel] = pos
            pos += len(record)
            parts.append(record)
            self._counts[channel] += hi - lo
        self._put(b"".join(parts))
        self._chunk_indexes.append(
            ChunkIndex(
                message_start_time=start,
                message_end_time=end,
                chunk_start_offset=chunk_start,
                chunk_length=chunk_length,
                message_index_offsets=index_offsets,
                message_index_length=pos - index_start,
                compression="zstd",
                compressed_size=len(compressed),
                uncompressed_size=len(raw),
            )
        )
        self._start = start if not self.messages else min(self._start, start)
        self._end = max(self._end, end)
        self.messages += count

    def flush(self, *, sync: bool = False) -> None:
        """Close the open chunk and hand everything to the OS (`sync`: to the disk too)."""
        self.close_chunk()
        self._file.flush()
        if sync:
            os.fsync(self._file.fileno())

    def fileno(self) -> int:
        """The file descriptor (to fsync from another thread)."""
        return self._file.fileno()

    @property
    def pending(self) -> int:
        """Messages in the open chunk (not yet in the file)."""
        return self._open.count

    # ----- end -----------------------------------------------------------------------------------

    def close(self) -> None:
        """Write the last chunk, the summary and the footer, and close the file.

        An `atomic` file is then put at `path`; on any failure it is removed and `path` left as it was.
        """
        if self._closed:
            return
        self._closed = True
        try:
            self._finish()
        except BaseException:
            self._file.close()
            if not self._placed:
                from dbglog._files import discard_temp

                discard_temp(self._tmp)
            raise
        self._file.close()
        if not self._placed:
            try:
                self._place()
            finally:
                if not self._placed:
                    from dbglog._files import discard_temp

                    discard_temp(self._tmp)

    def _finish(self) -> None:
        """Write the last chunk, the data end, the summary, the footer and the closing magic; sync."""
        self.close_chunk()
        builder = RecordBuilder()
        DataEnd(data_section_crc=0).write(builder)
        self._put(_end(builder))
        summary_start = self.size
        groups: list[tuple[int, bytes]] = []
        for opcode, records in (
            (0x03, list(self._schemas.values())),
            (0x04, list(self._channels.values())),
            (0x0B, [self._statistics()]),
            (0x08, self._chunk_indexes),
        ):
            if not records:
                continue
            builder = RecordBuilder()
            for record in records:
                record.write(builder)
            groups.append((opcode, _end(builder)))
        offsets_builder = RecordBuilder()
        pos = summary_start
        for opcode, data in groups:
            SummaryOffset(group_opcode=opcode, group_start=pos, group_length=len(data)).write(offsets_builder)
            pos += len(data)
        summary = b"".join(data for _, data in groups)
        offsets = _end(offsets_builder)
        summary_offset_start = summary_start + len(summary)
        footer_builder = RecordBuilder()
        Footer(
            summary_start=summary_start if summary else 0,
            summary_offset_start=summary_offset_start if offsets else 0,
            summary_crc=0,
        ).write(footer_builder)
        footer = _end(footer_builder)
        tail = summary + offsets + footer
        # The footer's CRC covers the summary up to its own crc field (mcap spec); 0 means "not set".
        crc = zlib.crc32(tail[: len(tail) - 4])
        tail = tail[:-4] + struct.pack("<I", crc)
        self._put(tail + MAGIC)
        self._file.flush()
        os.fsync(self._file.fileno())

    def abandon(self) -> None:
        """Close the file without a summary, as a crash leaves it (an `atomic` file is removed instead)."""
        if not self._closed:
            self._closed = True
            self._file.close()
            if not self._placed:
                from dbglog._files import discard_temp

                discard_temp(self._tmp)

    def __enter__(self) -> McapWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _statistics(self) -> Statistics:
        return Statistics(
            message_count=self.messages,
            schema_count=len(self._schemas),
            channel_count=len(self._channels),
            attachment_count=0,
            metadata_count=0,
            chunk_count=len(self._chunk_indexes),
            message_start_time=self._start,
            message_end_time=self._end,
            channel_message_counts=dict(self._counts),
        )

    def _put(self, data: bytes) -> None:
        self._file.write(data)
        self.size += len(data)


def _end(builder: RecordBuilder) -> bytes:
    """The bytes built so far (mcap's `RecordBuilder.end` is not annotated)."""
    return builder.end()  # type: ignore[no-untyped-call,no-any-return]
