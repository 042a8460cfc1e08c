"""Benchmark a series' live ring kept in source time order: in-order batches against out-of-order ones.

Run: ``.venv/bin/python -m benchmarks.bench_series`` (``--repeats``, ``--batches``, ``--capacity``).

A `Series` (the ring a widget reads, 10,000 samples by default, full and wrapping) takes batches as the
engine pushes them, a few to ~100 samples of one topic per cycle. Side by side in one run, per batch
size:

* **in order**: one publisher, every batch newer than the last (appended as it is);
* **two publishers**: two writers of the tag at the same rate, their batches half a batch apart in
  source time, arriving alternately, so every batch is older than the newest sample held and is merged
  in place with the half batch it overlaps;
* **one clock 1 s behind**: as two publishers, but the second one's source times run a second (1,000
  samples) behind the first's: each of its batches is merged 1,000 samples deep into the ring.

Each figure is the median over repeats of the mean time per `push_numbers` call; "+ history" is the same
with the engine's `History` behind the series (a transformed binding keeps its values there too). The
output is a Markdown table.
"""

from __future__ import annotations

import argparse
import statistics
import time
from collections.abc import Callable

import numpy as np

from benchmarks._common import print_table
from dbglog.viewer._data._history import History
from dbglog.viewer._data._model import Binding, ValueKind
from dbglog.viewer._data._series import Series

_T0 = 1_700_000_000.0
_RATE = 1000.0
"""Samples per second of each publisher (their batch size sets the batch's span)."""

Feed = Callable[[int], tuple[np.ndarray, np.ndarray]]


def _series(capacity: int, history: bool) -> Series:
    store = History(clock=None, max_seconds=1e9, max_bytes=1 << 40) if history else None
    series = Series(Binding("/bench/series"), capacity, store)
    series.set_type("std_msgs/msg/Float64", ValueKind.NUMBER)
    return series


def _in_order(n: int) -> Feed:
    def batch(k: int) -> tuple[np.ndarray, np.ndarray]:
        t = _T0 + (k * n + np.arange(n)) / _RATE
        return t, np.sin(t)

    return batch


def _two_publishers(n: int) -> Feed:
    def batch(k: int) -> tuple[np.ndarray, np.ndarray]:
        i, writer = divmod(k, 2)  # A0 B0 A1 B1 ...: B's batch starts half a batch after A's
        t = _T0 + (i * n + writer * n / 2 + np.arange(n)) / _RATE
        return t, np.full(n, float(writer))

    return batch


def _behind(n: int, seconds: float) -> Feed:
    def batch(k: int) -> tuple[np.ndarray, np.ndarray]:
        i, writer = divmod(k, 2)  # A0 B0 A1 B1 ...: B's clock runs `seconds` behind A's
        t = _T0 + (i * n + np.arange(n)) / _RATE - writer * seconds
        return t, np.full(n, float(writer))

    return batch


def _measure(feed: Feed, *, capacity: int, batches: int, repeats: int, history: bool) -> float:
    """Median over `repeats` of the mean µs per push, on a ring filled to capacity first."""
    per_push = []
    for r in range(repeats):
        series = _series(capacity, history)
        warm = _in_order(capacity)(-1)  # a full ring just before the batches' times
        series.push_numbers(warm[0] - 10 * capacity / _RATE, warm[1], float(warm[1][-1]), 0.0)
        pushes = [feed(r * batches + k) for k in range(batches)]
        start = time.perf_counter_ns()
        for times, values in pushes:
            series.push_numbers(times, values, float(values[-1]), 1.0)
        per_push.append((time.perf_counter_ns() - start) / batches / 1000)
        snap = series.snapshot(1e9, now=1.0)
        assert not (np.diff(snap.times) < 0).any(), "the ring left source time order"
    return statistics.median(per_push)


def main() -> None:
    """Print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=7)
    parser.add_argument("--batches", type=int, default=2000)
    parser.add_argument("--capacity", type=int, default=10_000)
    args = parser.parse_args()
    rows = []
    for n in (1, 5, 20, 100):
        cells: list[object] = [n]
        for history in (False, True):
            for feed in (_in_order(n), _two_publishers(n), _behind(n, 1.0)):
                us = _measure(
                    feed, capacity=args.capacity, batches=args.batches, repeats=args.repeats, history=history
                )
                cells.append(f"{us:.1f}")
        rows.append(cells)
    print_table(
        f"Series.push_numbers, µs per batch (median of {args.repeats} × {args.batches} batches, ring of "
        f"{args.capacity:,})",
        [
            "batch",
            "in order",
            "two publishers",
            "one clock 1 s behind",
            "+ history: in order",
            "+ history: two publishers",
            "+ history: one clock 1 s behind",
        ],
        rows,
    )


if __name__ == "__main__":
    main()
