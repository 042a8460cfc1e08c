"""Shared helpers for the benchmark scripts: local-only DDS, medians of repeats, a printed table."""

from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
from collections.abc import Callable, Sequence

__all__ = ["local_ros_env", "median_ns_per_call", "print_table", "spawn_flood", "start_ready"]


def local_ros_env(domain: int | None = None) -> None:
    """Keep DDS on loopback and (optionally) pick the domain; call before importing rclpy."""
    os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
    if domain is not None:
        os.environ["ROS_DOMAIN_ID"] = str(domain)


def median_ns_per_call(fn: Callable[[], object], *, calls: int, repeats: int) -> float:
    """Return the median over `repeats` of the mean nanoseconds per call of `fn` over `calls` calls."""
    samples = []
    for _ in range(repeats):
        start = time.perf_counter_ns()
        for _ in range(calls):
            fn()
        samples.append((time.perf_counter_ns() - start) / calls)
    return statistics.median(samples)


def print_table(title: str, header: Sequence[str], rows: Sequence[Sequence[object]]) -> None:
    """Print a Markdown table, so a run's output pastes straight into the README."""
    print(f"\n### {title}\n")
    print("| " + " | ".join(header) + " |")
    print("|" + "|".join("---" for _ in header) + "|")
    for row in rows:
        print("| " + " | ".join(str(c) for c in row) + " |")


def spawn_flood(
    module: str, publishers: int, rate: float, per_pub: int, span: int, *extra: str
) -> list[subprocess.Popen[str]]:
    """Start `publishers` flood children of `module` (``--publisher [extra] --rate --count --offset``).

    Each sends `per_pub` numbered lines at its share of `rate`, numbers starting at ``i * span``; their
    stdin and stdout are pipes (they report, then wait for a line before they exit).
    """
    return [
        subprocess.Popen(
            [
                *(sys.executable, "-m", module, "--publisher", *extra),
                *("--rate", str(rate / publishers), "--count", str(per_pub), "--offset", str(i * span)),
            ],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        for i in range(publishers)
    ]


def start_ready(argv: Sequence[str]) -> subprocess.Popen[str]:
    """Start ``python ARGV`` and wait for its first line, ``publishing`` (a fleet robot, a plain peer)."""
    proc = subprocess.Popen([sys.executable, *argv], stdout=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    if proc.stdout.readline().strip() != "publishing":
        raise RuntimeError(f"{list(argv)} did not start")
    return proc
