"""Benchmark the viewer's history store: bytes per sample, append rate, seek and plot redraw, a flood.

Run: ``.venv/bin/python -m benchmarks.bench_history`` (a 10-minute-equivalent fill of 50 topics x 100 Hz;
``--minutes 60`` for the 1-hour, 18 M-sample figure; ``--only memory|append|seek|flood|span`` for one
part; ``span``: the whole history's span and stats reads at 60, 600 and 3000 topics).
Memory and flood run each in a fresh process so RSS is theirs alone. Timings are medians (and p95) of
repeats. The output is Markdown tables.
"""

from __future__ import annotations

import argparse
import gc
import itertools
import os
import statistics
import subprocess
import sys
import time
import tracemalloc
from collections.abc import Callable

import numpy as np

from benchmarks._common import median_ns_per_call, print_table
from dbglog.viewer._data._history import History

_T0 = 1_700_000_000.0
_PAGE = os.sysconf("SC_PAGE_SIZE")


def _rss() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * _PAGE


def _fill(h: History, topics: int, rate: int, seconds: int, *, batch_s: float = 1.0) -> int:
    """Append `seconds` of `topics` x `rate` Hz sine-ish data in batches of `batch_s`; return samples."""
    per = max(1, int(rate * batch_s))
    names = [f"/rosdashboard/t{k}" for k in range(topics)]
    base = np.arange(per) / rate
    n = 0
    for b in range(int(seconds / batch_s)):
        t = _T0 + b * batch_s + base
        for k, name in enumerate(names):
            h.append_numbers(name, t, np.sin(t * (0.1 + k * 0.01)))
            n += per
    return n


def _memory(args: argparse.Namespace) -> None:
    gc.collect()
    rss0 = _rss()
    tracemalloc.start()
    h = History(clock=None, max_seconds=7200, max_bytes=2**40)
    start = time.perf_counter()
    n = _fill(h, args.topics, args.rate, args.minutes * 60)
    took = time.perf_counter() - start
    traced, _ = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    rss = _rss() - rss0
    print_table(
        f"Memory: {args.topics} topics × {args.rate} Hz × {args.minutes} min ({n:,} samples)",
        ["measure", "bytes", "bytes/sample"],
        [
            ["history.bytes_used()", f"{h.bytes_used():,}", f"{h.bytes_used() / n:.2f}"],
            ["tracemalloc (all Python + numpy allocations)", f"{traced:,}", f"{traced / n:.2f}"],
            ["RSS growth of the process", f"{rss:,}", f"{rss / n:.2f}"],
        ],
    )
    print(f"\nfill: {n / took:,.0f} samples/s in 1 s batches ({took:.1f} s)")


def _append(args: argparse.Namespace) -> None:
    rows = []
    for batch in (1, 5, 20, 100):
        rates = []
        cpus = []
        for _ in range(args.repeats):
            h = History(clock=None)
            total = 200_000 if batch > 1 else 100_000
            calls = total // batch
            names = [f"/rosdashboard/t{k}" for k in range(50)]
            t = _T0 + np.arange(batch) / 1000  # every topic at 1 kHz
            v = np.sin(t)
            start, cpu = time.perf_counter(), time.process_time()
            for c in range(calls):
                h.append_numbers(names[c % 50], t + (c // 50) * batch / 1000, v)
            rates.append(calls * batch / (time.perf_counter() - start))
            cpus.append((time.process_time() - cpu) / calls * 1e6)
        payload_rates = []
        for _ in range(args.repeats):
            h = History(clock=None)
            calls = 100_000 // batch
            names = [f"/s{k}" for k in range(50)]
            t = _T0 + np.arange(batch) / 1000
            blobs = [b"\x00\x01\x00\x00" + b"x" * 60] * batch
            start = time.perf_counter()
            for c in range(calls):
                h.append_payloads(names[c % 50], t + (c // 50) * batch / 1000, blobs)
            payload_rates.append(calls * batch / (time.perf_counter() - start))
        med, pmed = statistics.median(rates), statistics.median(payload_rates)
        cpu_us = statistics.median(cpus)
        rows.append([batch, f"{med:,.0f}", f"{1e6 / med * batch:.1f}", f"{cpu_us:.1f}", f"{pmed:,.0f}"])
    print_table(
        f"Append throughput, 50 topics round robin (median of {args.repeats})",
        [
            "batch size",
            "numbers samples/s",
            "µs per numbers call",
            "CPU µs per call",
            "64 B payloads samples/s",
        ],
        rows,
    )


def _percentiles(samples: list[float]) -> tuple[float, float]:
    arr = np.asarray(samples) * 1e3
    return float(np.percentile(arr, 50)), float(np.percentile(arr, 95))


def _seek(args: argparse.Namespace) -> None:
    minutes = max(args.minutes, 60)
    topics = 50 if args.minutes >= 60 else 20
    h = History(clock=None, max_seconds=7200, max_bytes=2**40)
    n = _fill(h, topics, args.rate, minutes * 60)
    span = h.span()
    assert span is not None
    lo, hi = span
    names = [f"/rosdashboard/t{k}" for k in range(20)]
    rng = np.random.default_rng(1)
    seeks = []
    for cursor in rng.uniform(lo, hi, 2000):
        start = time.perf_counter()
        for name in names:
            h.at(name, cursor)
        seeks.append(time.perf_counter() - start)
    steps = []
    for cursor in rng.uniform(lo, hi, 2000):
        start = time.perf_counter()
        for name in names:
            h.prev_time(name, cursor)
            h.next_time(name, cursor)
        steps.append(time.perf_counter() - start)
    rows = [
        ["at() × 20 topics (cursor anywhere)", *_percentiles(seeks)],
        ["prev_time + next_time × 20 topics", *_percentiles(steps)],
    ]
    for label, window, pixels in (
        ("20 plots, whole hour, 800 px", hi - lo, 800),
        ("20 plots, whole hour, 1920 px", hi - lo, 1920),
        ("20 plots, 60 s window, 800 px", 60.0, 800),
        ("20 plots, 10 min window, 800 px", 600.0, 800),
    ):
        redraws = []
        for _ in range(args.plot_repeats):
            t1 = float(rng.uniform(lo + window, hi)) if window < hi - lo else hi
            start = time.perf_counter()
            for name in names:
                h.decimate(name, t1 - window, t1, pixels)
            redraws.append(time.perf_counter() - start)
        rows.append([label, *_percentiles(redraws)])
    backfill = []
    for _ in range(args.plot_repeats):
        start = time.perf_counter()
        h.range(names[0], hi - 600, hi)
        backfill.append(time.perf_counter() - start)
    rows.append(["back-fill: range() of the last 10 min of one topic (60k samples)", *_percentiles(backfill)])
    twist = b"\x00\x01\x00\x00" + bytes(48)  # a geometry_msgs/Twist in CDR: 52 bytes
    t = lo + np.arange(int((hi - lo) * args.rate)) / args.rate
    for k in range(0, len(t), 1000):
        h.append_payloads("/cmd_vel", t[k : k + 1000], [twist] * len(t[k : k + 1000]))
    fills = []
    for _ in range(args.plot_repeats):
        start = time.perf_counter()
        _, payloads = h.payloads("/cmd_vel", hi - 600, hi)
        joined = np.frombuffer(b"".join(payloads), dtype=np.uint8).reshape(len(payloads), len(twist))
        joined[:, 44:52].copy().view(np.float64)  # angular.z, as the engine's fixed-offset decoder reads it
        fills.append(time.perf_counter() - start)
    rows.append(["back-fill: payloads() of 10 min of a 100 Hz Twist + column decode", *_percentiles(fills)])
    print_table(
        f"Seek and redraw over {minutes} min of {topics} topics × {args.rate} Hz ({n:,} samples)",
        ["operation", "p50 ms", "p95 ms"],
        [[r[0], f"{r[1]:.3f}", f"{r[2]:.3f}"] for r in rows],
    )


def _flood(args: argparse.Namespace) -> None:
    cap = args.flood_mb * 1024 * 1024
    h = History(clock=None, max_seconds=1800, max_bytes=cap)
    rate = args.flood_rate
    seconds = args.flood_seconds
    numeric, texts = 45, 5
    per_topic = rate // (numeric + texts)
    base = np.arange(per_topic) / per_topic
    names = [f"/rosdashboard/n{k}" for k in range(numeric)]
    text_names = [f"/rosdashboard/s{k}" for k in range(texts)]
    blobs = [b"\x00\x01\x00\x00" + b"warning: something %03d" % i + b"\x00" * 4 for i in range(per_topic)]
    rss0 = _rss()
    rows = []
    marks = {int(seconds * q / 4) for q in (1, 2, 3, 4)}
    start = time.perf_counter()
    for s in range(1, seconds + 1):
        t = _T0 + s + base
        for name in names:
            h.append_numbers(name, t, np.cos(t))
        for name in text_names:
            h.append_payloads(name, t, blobs)
        if s in marks:
            st = h.stats()
            rows.append(
                [
                    f"{s} s of data",
                    f"{(st.newest or 0) - (st.oldest or 0):.0f} s",
                    f"{st.samples:,}",
                    f"{st.bytes_used / 2**20:.1f}",
                    f"{(_rss() - rss0) / 2**20:.1f}",
                ]
            )
    took = time.perf_counter() - start
    print_table(
        f"Flood: {rate:,} msg/s ({numeric} numeric + {texts} text topics) for {seconds} s of source time, "
        f"budget {args.flood_mb} MiB / 30 min (fed at {seconds * rate / took:,.0f} msg/s)",
        ["point", "span held", "samples held", "bytes_used MiB", "RSS growth MiB"],
        rows,
    )


def _small_appends(h: History, names: list[str]) -> Callable[[], None]:
    """Return a call that appends 2 samples to the next of `names`, each call later than the one before."""
    two = np.ones(2)
    step = itertools.count()

    def append() -> None:
        i = next(step)
        h.append_numbers(names[i % len(names)], _T0 + 20 + i * 1e-3 + np.array([0.0, 1e-4]), two)

    return append


def _span(args: argparse.Namespace) -> None:
    """Time the whole history's span and stats reads (the time bar and status bar read both each frame),
    and the small append that keeps them (2 samples to one of the topics, the engine's usual batch)."""
    rows = []
    for topics in (60, 600, 3000):
        h = History(clock=None)
        names = [f"/rosdashboard/t{k}" for k in range(topics)]
        for k, name in enumerate(names):
            h.append_numbers(name, _T0 + np.arange(100) / 10 + k * 1e-3, np.arange(100.0))
        span_ns = median_ns_per_call(h.span, calls=200, repeats=args.repeats * 5)
        stats_ns = median_ns_per_call(h.stats, calls=200, repeats=args.repeats * 5)
        append = _small_appends(h, names)
        append_ns = median_ns_per_call(append, calls=2000, repeats=args.repeats * 3)
        rows.append([topics, f"{span_ns / 1e3:.2f}", f"{stats_ns / 1e3:.2f}", f"{append_ns / 1e3:.2f}"])
    print_table(
        "Whole-history reads and the appends that keep them (medians)",
        ["topics", "span() µs", "stats() µs", "2-sample append µs"],
        rows,
    )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark parts; memory and flood each in a fresh process."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--minutes", type=int, default=10, help="fill length (60: 1 hour, 18 M samples)")
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--rate", type=int, default=100, help="Hz per topic")
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--plot-repeats", type=int, default=40)
    parser.add_argument("--flood-rate", type=int, default=50_000, help="messages per second of source time")
    parser.add_argument("--flood-seconds", type=int, default=600)
    parser.add_argument("--flood-mb", type=int, default=128, help="the flood's memory cap")
    parser.add_argument("--only", choices=["memory", "append", "seek", "flood", "span"])
    args = parser.parse_args(argv)
    if args.only == "memory":
        _memory(args)
    elif args.only == "append":
        _append(args)
    elif args.only == "seek":
        _seek(args)
    elif args.only == "flood":
        _flood(args)
    elif args.only == "span":
        _span(args)
    else:
        rest = [a for a in (argv if argv is not None else sys.argv[1:]) if not a.startswith("--only")]
        for part in ("memory", "flood"):
            subprocess.run(
                [sys.executable, "-m", "benchmarks.bench_history", *rest, "--only", part], check=True
            )
        _append(args)
        _seek(args)
        _span(args)
    return 0


if __name__ == "__main__":
    sys.exit(main())
