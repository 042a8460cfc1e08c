"""Where dbglog's publisher thread spends its CPU per flush: the GIL time a 1 kHz loop can run into.

Run: ``.venv/bin/python benchmarks/bench_flush.py [--seconds 14] [--repeats 3]`` (prints Markdown tables).

Each run is a child process that logs 10 tags at 1 kHz as ``bench_probe.py``'s loop does (8 floats and
an int per iteration, a string throttled to 10 Hz; the loop sleeps 1 ms between iterations), no
subscriber. After the tags' first 5 s (when every sample also goes on its tag's topic) it sums the
publisher thread's CPU time (``time.thread_time_ns``) in each step of a flush. Everything but the
batch's DDS write holds the GIL: a loop that wakes at a random moment finds the thread holding it for
that share of the time. With the compiled module the DDS writes happen on the writer thread
(``dbglog/api/_writer.c``, no GIL, an ordinary thread): the "DDS write" step is then only the hand-over of a
copy, and the writer thread's own CPU time is a row of its own.

Runs alternate the compiled flush (``dbglog/api/_flush.c``) and its Python version (the child under
``DBGLOG_PURE_PYTHON=1``, what an install without a C compiler runs); the tables give each step's
median over the repeats, side by side.
"""

from __future__ import annotations

import argparse
import collections
import functools
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

_SETTLE_S = 7.0
"""Seconds before measuring: the tags' first 5 s publish every sample on their own topics too."""
_WHOLE = "a whole flush"
_WRITE = "  its DDS write (without the GIL), or its hand-over to the writer thread"
_WRITER = "the writer thread (no GIL): all DDS writes, per flush"
_IMPLS = {"C": "0", "Python": "1"}
"""Each flush implementation and the child's DBGLOG_PURE_PYTHON."""


class _Meter:
    """Thread CPU time summed per step, while `on`."""

    def __init__(self) -> None:
        self.on = False
        self.ns: collections.Counter[str] = collections.Counter()
        self.calls: collections.Counter[str] = collections.Counter()

    def wrap(self, owner: Any, name: str, label: str) -> None:
        """Replace `owner.name` by a wrapper that times it under `label`."""
        original: Callable[..., Any] = getattr(owner, name)

        @functools.wraps(original)
        def timed(*args: Any, **kwargs: Any) -> Any:
            start = time.thread_time_ns()
            try:
                return original(*args, **kwargs)
            finally:
                if self.on:
                    self.ns[label] += time.thread_time_ns() - start
                    self.calls[label] += 1

        setattr(owner, name, timed)


def _thread_cpu_ns(native_id: int) -> int:
    """CPU time of one thread of this process (``/proc``'s schedstat: ns on a CPU)."""
    with open(f"/proc/self/task/{native_id}/schedstat") as f:
        return int(f.read().split()[0])


def child(seconds: float) -> None:
    """Log, measure the flushes, print one JSON line: per step, CPU ns and calls; flushes; seconds."""
    local_ros_env(int.from_bytes(os.urandom(1)) % 100 + 101)
    import dbglog
    from dbglog.api import _pipe
    from dbglog.api._channel import Channel
    from dbglog.api._public import RUNTIME

    meter = _Meter()
    meter.wrap(_pipe.Pipe, "_flush_once", _WHOLE)
    meter.wrap(_pipe, "take", "taking the samples off the queue (take)")
    meter.wrap(_pipe, "pack_batch_of", "grouping and encoding the batch (pack_batch)")
    meter.wrap(_pipe.Pipe, "_publish_pending", "each unwatched tag's newest value on its topic")
    meter.wrap(Channel, "listened", "subscriber counts (Channel.listened)")
    dbglog.init()
    meter.wrap(RUNTIME, "batch_publish", _WRITE)
    floats = [f"bench_flush/f{i}" for i in range(8)]
    start = time.monotonic()
    k = 0
    writer_cpu = 0
    while (now := time.monotonic()) < start + seconds:
        if not meter.on and now - start > _SETTLE_S and RUNTIME._writer is not None:
            writer_cpu = _thread_cpu_ns(RUNTIME._writer.native_id)
        meter.on = now - start > _SETTLE_S
        for tag in floats:
            dbglog.logfloat(tag, float(k))
        dbglog.logint("bench_flush/i", k)
        dbglog.logstring("bench_flush/s", f"k{k}", throttle=0.1)
        k += 1
        time.sleep(0.001)
    meter.on = False
    writer = RUNTIME._writer
    if writer is not None:
        meter.ns[_WRITER] = _thread_cpu_ns(writer.native_id) - writer_cpu
        meter.calls[_WRITER] = meter.calls[_WHOLE]
    print(json.dumps({"ns": meter.ns, "calls": meter.calls, "seconds": seconds - _SETTLE_S}))
    dbglog.shutdown()


def _run(impl: str, seconds: float) -> dict[str, Any]:
    env = {**os.environ, "DBGLOG_PURE_PYTHON": _IMPLS[impl]}
    out = subprocess.run(
        [sys.executable, __file__, "--child", "--seconds", str(seconds)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
        timeout=seconds + 60,
    ).stdout
    result: dict[str, Any] = json.loads(out.strip().splitlines()[-1])
    return result


def main() -> None:
    """Alternate C and Python runs, print the per-step medians side by side."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=14.0, help="run time, the first 7 s unmeasured")
    parser.add_argument("--repeats", type=int, default=3, help="runs of each implementation, alternating")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.seconds)
        return
    runs: dict[str, list[dict[str, Any]]] = {impl: [] for impl in _IMPLS}
    for _ in range(args.repeats):
        for impl in _IMPLS:
            runs[impl].append(_run(impl, args.seconds))

    def per_flush(run: dict[str, Any], label: str, key: str) -> float:
        return float(run[key].get(label, 0)) / max(1, int(run["calls"][_WHOLE]))

    def held_share(run: dict[str, Any]) -> float:
        ns = run["ns"]
        return float(ns[_WHOLE] - (0 if _WRITER in ns else ns.get(_WRITE, 0))) / (float(run["seconds"]) * 1e9)

    labels = list(dict.fromkeys(label for impl in _IMPLS for run in runs[impl] for label in run["ns"]))
    labels.sort(key=lambda label: -statistics.median(per_flush(r, label, "ns") for r in runs["C"]))
    rows: list[list[object]] = []
    for label in labels:
        row: list[object] = [label]
        for impl in _IMPLS:
            row.append(f"{statistics.median(per_flush(r, label, 'ns') for r in runs[impl]) / 1e3:.1f}")
        row.append(f"{statistics.median(per_flush(r, label, 'calls') for r in runs['C']):.2f}")
        rows.append(row)
    flushes = {
        impl: statistics.median(r["calls"][_WHOLE] / r["seconds"] for r in runs[impl]) for impl in _IMPLS
    }
    held = {impl: [held_share(r) for r in runs[impl]] for impl in _IMPLS}
    rows.append(
        [
            "**the GIL held, share of the time** (whole flush, less a DDS write on this thread), each run",
            *(", ".join(f"{h:.2%}" for h in held[impl]) for impl in _IMPLS),
            "",
        ]
    )
    print_table(
        f"dbglog's publisher thread, 10 tags at 1 kHz, no subscriber: medians of {args.repeats} runs of "
        f"{args.seconds - _SETTLE_S:.0f} s measured, alternating ({flushes['C']:.0f} / "
        f"{flushes['Python']:.0f} flushes a second)",
        ["step", "thread CPU µs per flush, C", "Python", "calls per flush"],
        rows,
    )


if __name__ == "__main__":
    main()
