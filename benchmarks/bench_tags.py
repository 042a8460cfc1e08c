"""Benchmark ``dbglog tags``: how long the command takes, as a user runs it, beside what is on the domain.

Run: ``.venv/bin/python -m benchmarks.bench_tags`` (``--runs 5``; ``--fleet`` adds the case of two robots
of 300 tags at 10 Hz, ``benchmarks/_fleet.py``). Each run is ``time dbglog tags`` in a fresh process, one
after another; cases:

* ``empty``: no other participant of the domain on this host (the table says there is no tag);
* ``plain``: one plain ROS node with five topics and no dbglog tag (``bench_discovery --peer``);
* ``fleet``: the two robots (every one of their 600 tags must be listed live).

It prints the median, the fastest and the slowest run of each, and how many runs gave the right table.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time

from benchmarks._common import local_ros_env, print_table, start_ready


def _run_tags() -> tuple[float, str]:
    """One ``dbglog tags``: its wall time from start to exit, and its table."""
    started = time.monotonic()
    out = subprocess.run(
        [sys.executable, "-m", "dbglog", "tags"], capture_output=True, text=True, timeout=60, check=True
    )
    return time.monotonic() - started, out.stdout


def _right(case: str, table: str, tags: int) -> bool:
    """Whether a run's table is what the case must give."""
    if case != "fleet":
        return "no dbglog tags" in table
    live = [line for line in table.splitlines()[2:] if line.rstrip().endswith(" live")]
    return len(live) == tags


def _case(case: str, runs: int, tags: int) -> list[object]:
    times, right = [], 0
    for _ in range(runs):
        took, table = _run_tags()
        times.append(took)
        right += _right(case, table, tags)
    return [
        case,
        runs,
        f"{statistics.median(times):.2f}",
        f"{min(times):.2f} – {max(times):.2f}",
        f"{right} of {runs}",
    ]


def main(argv: list[str] | None = None) -> int:
    """Time ``dbglog tags`` in each case and print the table."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--runs", type=int, default=5, help="runs of each case")
    parser.add_argument("--fleet", action="store_true", help="also beside two robots of 300 tags")
    parser.add_argument("--domain", type=int, default=None, help="ROS domain (default: the environment's)")
    args = parser.parse_args(argv)
    local_ros_env(args.domain)
    rows = [_case("empty", args.runs, 0)]
    peer = start_ready(["-m", "benchmarks.bench_discovery", "--peer", "bench_tags_peer"])
    try:
        time.sleep(1.0)  # found by the domain's other participants: the case is a node already running
        rows.append(_case("plain", args.runs, 0))
    finally:
        peer.kill()
        peer.wait(10)
    if args.fleet:
        robots = []
        try:
            for robot in ("robot1", "robot2"):
                os.environ["DBGLOG_NAMESPACE"] = robot
                robots.append(start_ready(["-m", "benchmarks._fleet", "--subsystems", "15", "--tags", "20"]))
            os.environ.pop("DBGLOG_NAMESPACE", None)
            time.sleep(2.0)
            rows.append(_case("fleet", args.runs, 600))
        finally:
            for proc in robots:
                proc.kill()
                proc.wait(10)
    print_table(
        "`dbglog tags`, a fresh process each run: seconds from its start to its exit",
        ["case", "runs", "median", "fastest – slowest", "right table"],
        rows,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
