"""Where dbglog's publisher thread spends its CPU per flush: the GIL time a 1 kHz loop can run into.

Run: ``.venv/bin/python benchmarks/bench_flush.py [--seconds 14]`` (prints a Markdown table).

The process logs 10 tags at 1 kHz as ``bench_probe.py``'s loop does (8 floats and an int per
iteration, a string throttled to 10 Hz; the loop sleeps 1 ms between iterations), no subscriber. After
the tags' first 5 s (when every sample also goes on its tag's topic) it sums the publisher thread's CPU
time (``time.thread_time_ns``) in each step of a flush. Everything but the batch's DDS write (which
runs without the GIL, ``dbglog/_ros/_nogil.py``) holds the GIL: a loop that wakes at a random moment
finds the thread holding it for that share of the time, and a loop period's p99 cannot stay clear of a
share above 1 %.
"""

from __future__ import annotations

import argparse
import collections
import functools
import os
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


def main() -> None:
    """Log, measure the flushes, print the table."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=14.0, help="run time, the first 7 s unmeasured")
    args = parser.parse_args()
    local_ros_env(int.from_bytes(os.urandom(1)) % 100 + 101)
    import dbglog
    from dbglog.api import _pipe
    from dbglog.api._public import RUNTIME, hot_path
    from dbglog.api._runtime import Channel

    meter = _Meter()
    meter.wrap(_pipe.Pipe, "_flush_once", "a whole flush")
    meter.wrap(_pipe.Pipe, "_publish_batch", "building and publishing the batch")
    meter.wrap(_pipe, "encode_batch", "  its CDR encoding (encode_batch)")
    meter.wrap(_pipe, "pack_values", "  its values packed (pack_values)")
    meter.wrap(_pipe.Pipe, "_publish_pending", "each unwatched tag's newest value on its topic")
    meter.wrap(Channel, "listened", "subscriber counts (Channel.listened)")
    dbglog.init()
    meter.wrap(RUNTIME, "batch_publish", "  its DDS write (without the GIL)")
    floats = [f"bench_flush/f{i}" for i in range(8)]
    start = time.monotonic()
    k = 0
    while (now := time.monotonic()) < start + args.seconds:
        meter.on = now - start > _SETTLE_S
        for tag in floats:
            dbglog.logfloat(tag, float(k))
        dbglog.logint("bench_flush/i", k)
        dbglog.logstring("bench_flush/s", f"k{k}", throttle=0.1)
        k += 1
        time.sleep(0.001)
    meter.on = False
    flushes = meter.calls["a whole flush"]
    measured = args.seconds - _SETTLE_S
    rows = [
        [label, f"{ns / flushes / 1e3:.1f}", f"{meter.calls[label] / flushes:.2f}"]
        for label, ns in meter.ns.most_common()
    ]
    held = meter.ns["a whole flush"] - meter.ns["  its DDS write (without the GIL)"]
    print_table(
        f"dbglog's publisher thread, 10 tags at 1 kHz, no subscriber ({hot_path} hot path): "
        f"{flushes} flushes in {measured:.0f} s; the GIL held {held / flushes / 1e3:.0f} µs a flush, "
        f"{held / (measured * 1e9):.2%} of the time",
        ["step", "thread CPU µs per flush", "calls per flush"],
        rows,
    )
    dbglog.shutdown()


if __name__ == "__main__":
    main()
