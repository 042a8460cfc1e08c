"""Reading a recording without an index: the linear scan against the indexed read of the same data.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_scan`` (``--mb 20`` for a quick
run). One file of 50 ``std_msgs/Float64`` topics at 100 Hz (~100 MB, dbglog's writer: zstd chunks,
message indexes, summary) is rewritten, record by record, into the layouts a reader meets without an
index: a recording killed before its summary (chunks and message indexes, no summary, no footer), a
finished file whose writer wrote no index (chunks only, an empty summary), and an unchunked file
(every message a top-level record; uncompressed, so several times bigger). Each is loaded whole by
``read_recording``, interleaved with the others, ``--repeats`` times; the table gives the median and
the spread, and checks every layout reads every message. For reference, the ``mcap`` library's own
non-seeking readers on the index-less file: its `StreamReader` walking the top-level records (chunks
not opened), and its `NonSeekingReader` yielding every message as a Python object (once; ``--no-library``
leaves them out).
"""

from __future__ import annotations

import argparse
import contextlib
import os
import statistics
import struct
import tempfile
import time
from pathlib import Path

from benchmarks._common import print_table

_REC = struct.Struct("<BQ")
_HZ = 100.0
_TOPICS = 50
_BYTES_PER_MESSAGE = 28.0
"""Roughly what dbglog's writer spends per Float64 message (to size the file from --mb)."""


def _write_indexed(path: Path, seconds: float) -> int:
    """Write `_TOPICS` Float64 topics at `_HZ` for `seconds` with dbglog's writer; return the messages."""
    import numpy as np

    from dbglog.record import McapWriter

    rng = np.random.default_rng(1)
    t0 = 1_790_000_000_000_000_000
    period = int(1e9 / _HZ)
    n = int(_HZ * seconds)
    block = int(_HZ * 10)
    with McapWriter(path, force=True) as w:
        chans = [w.add_channel(f"/rosdashboard/big/t{i}", "std_msgs/msg/Float64") for i in range(_TOPICS)]
        level = rng.normal(size=_TOPICS)
        for lo in range(0, n, block):
            hi = min(n, lo + block)
            k = np.arange(lo, hi)
            for i, ch in enumerate(chans):
                values = np.round(level[i] + np.sin(k * 0.01 + i) + rng.normal(0, 0.01, hi - lo), 4)
                payload = np.empty((hi - lo, 12), dtype=np.uint8)
                payload[:, :4] = (0, 1, 0, 0)
                payload[:, 4:] = values.astype("<f8").view(np.uint8).reshape(-1, 8)
                times = (t0 + k * period + i * 1000 + rng.integers(0, 200_000, hi - lo)).astype(np.int64)
                w.write_fixed(ch, times, payload)
    return _TOPICS * n


def _records(data: bytes) -> list[tuple[int, int, int]]:
    """(opcode, start, end) of every top-level record after the magic."""
    out = []
    pos = 8
    while pos + 9 <= len(data):
        op, length = _REC.unpack_from(data, pos)
        out.append((op, pos, pos + 9 + length))
        pos += 9 + length
        if op == 0x02:  # footer
            break
    return out


def _footer() -> bytes:
    """A data end, an empty summary's footer and the closing magic (a finished file with no summary)."""
    data_end = _REC.pack(0x0F, 4) + struct.pack("<I", 0)
    footer = _REC.pack(0x02, 20) + struct.pack("<QQI", 0, 0, 0)
    return data_end + footer + b"\x89MCAP0\r\n"


def _layouts(indexed: Path) -> dict[str, Path]:
    """Rewrite `indexed` into the index-less layouts (beside it); return name -> path."""
    import zstandard

    data = indexed.read_bytes()
    records = _records(data)
    data_end = next(start for op, start, _ in records if op == 0x0F)
    head = [(op, s, e) for op, s, e in records if s < data_end]
    killed = indexed.with_name("killed.mcap")
    killed.write_bytes(data[:data_end])  # chunks + message indexes, cut where the summary would start
    no_index = indexed.with_name("no_index.mcap")
    with no_index.open("wb") as f:
        f.write(data[:8])
        for op, s, e in head:
            if op != 0x07:  # every record but the message indexes
                f.write(data[s:e])
        f.write(_footer())
    unchunked = indexed.with_name("unchunked.mcap")
    dctx = zstandard.ZstdDecompressor()
    with unchunked.open("wb") as f:
        f.write(data[:8])
        for op, s, e in head:
            if op == 0x06:  # a chunk's records are top-level records once uncompressed
                _t0, _t1, usize, _crc = struct.unpack_from("<QQQI", data, s + 9)
                comp_len = struct.unpack_from("<I", data, s + 9 + 28)[0]
                at = s + 9 + 28 + 4 + comp_len
                (size,) = struct.unpack_from("<Q", data, at)
                f.write(dctx.decompress(data[at + 8 : at + 8 + size], max_output_size=usize))
            elif op != 0x07:
                f.write(data[s:e])
        f.write(_footer())
    return {
        "indexed (summary + indexes)": indexed,
        "killed: no summary": killed,
        "no index, no summary": no_index,
        "unchunked, no index": unchunked,
    }


def _library_rows(layouts: dict[str, Path], total: int, base: float) -> list[list[str]]:
    """Time the ``mcap`` library's non-seeking readers on the index-less layouts (for reference)."""
    from mcap.exceptions import EndOfFile
    from mcap.reader import NonSeekingReader
    from mcap.stream_reader import StreamReader

    rows = []
    for name in ("killed: no summary", "no index, no summary", "unchunked, no index"):
        path = layouts[name]
        with path.open("rb") as f:
            start = time.perf_counter()
            records = 0
            with contextlib.suppress(EndOfFile):  # the killed file ends without a footer
                for _record in StreamReader(f, emit_chunks=True).records:
                    records += 1
            took = time.perf_counter() - start
        rows.append(
            [f"mcap StreamReader, top-level records only: {name}", f"{os.path.getsize(path) / 1e6:.0f} MB",
             f"{took:.2f} s", "once", f"{took / base:.1f}x", f"{took / total * 1e9:.0f} ns",
             f"{records:,} records; no message read"]
        )  # fmt: skip
    path = layouts["no index, no summary"]
    with path.open("rb") as f:
        start = time.perf_counter()
        count = sum(1 for _ in NonSeekingReader(f).iter_messages(log_time_order=False))
        took = time.perf_counter() - start
    rows.append(
        ["mcap NonSeekingReader.iter_messages: no index, no summary", f"{os.path.getsize(path) / 1e6:.0f} MB",
         f"{took:.2f} s", "once", f"{took / base:.1f}x", f"{took / total * 1e9:.0f} ns",
         f"{count:,} messages, one Python object each (not decoded)"]
    )  # fmt: skip
    return rows


def main(argv: list[str] | None = None) -> int:
    """Write the files, load each layout `--repeats` times (interleaved) and print the table."""
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--mb", type=float, default=100.0, help="size of the indexed file (MB)")
    parser.add_argument("--repeats", type=int, default=5, help="loads of each layout (interleaved)")
    parser.add_argument("--no-library", action="store_true", help="leave out the mcap library's readers")
    args = parser.parse_args(argv)
    from dbglog.record import read_recording

    with tempfile.TemporaryDirectory(prefix="bench_scan_") as tmp:
        indexed = Path(tmp) / "indexed.mcap"
        seconds = args.mb * 1e6 / _BYTES_PER_MESSAGE / _TOPICS / _HZ
        total = _write_indexed(indexed, seconds)
        layouts = _layouts(indexed)
        times: dict[str, list[float]] = {name: [] for name in layouts}
        notes: dict[str, str] = {}
        for _ in range(args.repeats):
            for name, path in layouts.items():
                start = time.perf_counter()
                rec = read_recording(path, keep_payloads=False)
                times[name].append(time.perf_counter() - start)
                got = sum(len(t) for t in rec.topics.values())
                if got != total:
                    raise SystemExit(f"{name}: read {got:,} of {total:,} messages ({rec.problems})")
                notes[name] = "; ".join(p.split(": ", 1)[1] for p in rec.problems) or "-"
                del rec
        base = statistics.median(times["indexed (summary + indexes)"])
        rows = []
        for name, path in layouts.items():
            med = statistics.median(times[name])
            rows.append(
                [
                    name,
                    f"{os.path.getsize(path) / 1e6:.0f} MB",
                    f"{med:.2f} s",
                    f"{min(times[name]):.2f}-{max(times[name]):.2f} s",
                    f"{med / base:.1f}x",
                    f"{med / total * 1e9:.0f} ns",
                    notes[name],
                ]
            )
        if not args.no_library:
            rows += _library_rows(layouts, total, base)
        load = os.getloadavg()[0]
        print_table(
            f"read_recording, {total:,} Float64 messages on {_TOPICS} topics, median of {args.repeats} "
            f"(interleaved), {os.cpu_count()} CPUs, load avg {load:.1f}",
            ["layout", "file", "median", "range", "vs indexed", "per message", "said on stderr"],
            rows,
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
