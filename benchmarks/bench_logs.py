"""Benchmark "logs as data": proposing a pattern, previewing it over 100,000 stored lines, memory per line.

Run: ``.venv/bin/python -m benchmarks.bench_logs`` (``--quick`` for fewer repeats). Times are medians of
repeats (wall clock, the machine's load included). Two calibration figures come first so that runs on
different machines compare: an empty CPython loop and one call into the google-re2 binding. The output is
Markdown tables.
"""

from __future__ import annotations

import argparse
import gc
import statistics
import sys
import time
import tracemalloc
from collections.abc import Callable

import numpy as np
import re2

from benchmarks._common import print_table
from dbglog._regex._propose import MAX_LINE, Proposal, match_joined, preview, propose

N_LINES = 100_000
_NODES = ("planner_local", "planner_global", "driver", "power_monitor", "camera")


def _median_ms(fn: Callable[[], object], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - start) * 1e3)
    return statistics.median(samples)


def _calibration(repeats: int) -> list[list[object]]:
    def loop() -> None:
        for _ in range(1_000_000):
            pass

    rx = re2.compile("x")
    match = rx._regexp.Match
    anchor = re2._Anchor.UNANCHORED
    text = b"abc"

    def calls() -> None:
        for _ in range(100_000):
            match(anchor, text, 0, 3)

    return [
        ["empty CPython loop, 1,000,000 iterations", f"{_median_ms(loop, repeats):.1f} ms"],
        ["google-re2 binding, one Match call (no text)", f"{_median_ms(calls, repeats) / 100:.2f} µs"],
    ]


def _lines(match_every: int) -> list[str]:
    """Stored lines: one in `match_every` is "that kind of line", the others are other lines."""
    return [
        f"distance to wall: {i * 0.01:.2f} m (angle {-(i % 90)} deg)"
        if i % match_every == 0
        else f"tick {i}: state=RUNNING load {i % 7}.{i % 10} queue={i % 13}"
        for i in range(N_LINES)
    ]


def _propose_rows(repeats: int) -> list[list[object]]:
    short = "distance to wall: 0.42 m (angle -12.5 deg)"
    array = "ranges: [" + ", ".join(f"{i * 0.013:.3f}" for i in range(600)) + "]"
    big = " ".join(f"key{i}={i * 0.5}" for i in range(10_000))
    rows: list[list[object]] = []
    for name, line, index in (
        ("typical line (42 chars, 2 numbers), 2nd number", short, 1),
        (f"array dump ({len(array):,} chars, 600 numbers), 300th", array, 299),
        (f"100 kB line ({len(big):,} chars; read to {MAX_LINE} bytes), 200th", big, 199),
    ):

        def once(line: str = line, index: int = index) -> object:
            return propose(line, index)

        ms = _median_ms(once, repeats * 20)
        rows.append([name, f"{ms:.2f}"])
    return rows


def _preview_rows(repeats: int) -> list[list[object]]:
    rows: list[list[object]] = []
    for label, every in (("1 %", 100), ("10 %", 10), ("100 %", 1)):
        lines = _lines(every)
        proposal = propose(lines[0], 0)
        count = preview(proposal, lines)[0]
        store, starts = _columnar_messages(lines)

        def from_list_run(lines: list[str] = lines, proposal: Proposal = proposal) -> object:
            return preview(proposal, lines)

        def from_store_run(
            proposal: Proposal = proposal, store: bytes = store, starts: np.ndarray = starts
        ) -> object:
            return match_joined(proposal, store, starts)

        from_list = _median_ms(from_list_run, repeats)
        from_store = _median_ms(from_store_run, repeats)
        rows.append([label, f"{count:,}", f"{from_list:.0f}", f"{from_store:.0f}"])
    return rows


def _columnar_messages(lines: list[str]) -> tuple[bytes, np.ndarray]:
    data = ("\x00" + "\x01\x00".join(lines) + "\x01").encode()
    starts = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 0)
    return data, starts


def _memory_rows() -> list[list[object]]:
    lines = _lines(10)
    n = len(lines)
    stamps = [1_795_000_000.0 + i * 1e-3 for i in range(n)]
    levels = [(10, 20, 20, 30, 40)[i % 5] for i in range(n)]

    def tuples() -> object:
        # As a callback would store them: a fresh node-name str per line (as deserialized), the message str.
        return [(stamps[i], levels[i], "".join(_NODES[i % 5]), "".join(lines[i])) for i in range(n)]

    def columnar() -> object:
        data, starts = _columnar_messages(lines)
        table = {name: k for k, name in enumerate(_NODES)}
        return (
            np.asarray(stamps, dtype=np.float64),
            np.asarray(levels, dtype=np.uint8),
            np.asarray([table[_NODES[i % 5]] for i in range(n)], dtype=np.uint16),
            starts.astype(np.int64),
            data,
        )

    rows: list[list[object]] = []
    text_bytes = sum(len(s) for s in lines) / n
    for name, build in (
        ("list of (stamp, level, node, message) tuples", tuples),
        (
            "columnar: float64 stamps, uint8 levels, uint16 node ids, int64 offsets, one UTF-8 buffer",
            columnar,
        ),
    ):
        gc.collect()
        tracemalloc.start()
        kept = build()
        size, _peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        del kept
        rows.append([name, f"{size / n:.0f}"])
    rows.append(["(the message text itself, average)", f"{text_bytes:.0f}"])
    return rows


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repeats")
    args = parser.parse_args(argv)
    repeats = 3 if args.quick else 7
    print(f"python {sys.version.split()[0]}, google-re2, numpy {np.__version__}")
    print_table("Calibration (this machine, this run)", ["what", "time"], _calibration(repeats))
    print_table("Proposing a pattern (median)", ["line", "ms"], _propose_rows(repeats))
    print_table(
        f"Preview over {N_LINES:,} stored lines (median)",
        ["lines of that kind", "matched", "ms, from a list of str", "ms, from a columnar buffer"],
        _preview_rows(repeats),
    )
    print_table(
        f"Memory per stored Log line ({N_LINES:,} lines, all-in, tracemalloc)",
        ["store", "bytes/line"],
        _memory_rows(),
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
