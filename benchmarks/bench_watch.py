"""What a watch costs the watched program (docs/watch.md, *Cost*), side by side in one run.

Run: ``.venv/bin/python benchmarks/bench_watch.py [--repeats 5]`` (and with ``.venv-3.12``); prints
Markdown tables. A child process (this file, ``--child``, with ``DBGLOG_WATCH=1``) is the program; this
process is the watcher (a `WatchClient` that receives every value, as ``dbglog watch`` does) and tells
the child, over its stdin, which state the watch is in. Three measurements, each with the watch not yet
armed, armed, and removed again, in alternation:

* **per hit**: bursts of 1000 calls of a function whose watched line reads one local (the value queued,
  ``--throttle 0`` so every hit is sent, the CPU limit raised to its most); ns per call, the median
  burst. Armed minus not armed is the cost of a hit; removed minus not armed must be ~0.
* **per Python call elsewhere**: bursts of calls of an empty function while the watch is on a line that
  does not run; on 3.11 every call pays the global trace function's call event, on 3.12 nothing.
* **1 kHz loop**: a loop with ~25 µs of work that sleeps to its next 1 ms deadline and runs the watched
  line once an iteration (the default rate cap: every hit sent); period p50/p99 per state, medians over
  the state's segments, and the watcher's received count against the hits.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

_BURST = 1000
_GAP_S = 0.02
_WORK_S = 25e-6


# ----- the child: the watched program ---------------------------------------------------------------------


def target(i: int) -> float:
    x = i * 0.5
    return x + 1.0  # WATCH:hit


def empty() -> None:
    return None


def never() -> int:
    y = 1
    return y + 1  # WATCH:never


def control_step(k: int) -> int:
    k += 1
    return k  # WATCH:loop


def _bursts(fn: Any, count: int) -> list[float]:
    per_call = []
    for _ in range(count):
        start = time.perf_counter_ns()
        for i in range(_BURST):
            fn(i)
        per_call.append((time.perf_counter_ns() - start) / _BURST)
        time.sleep(_GAP_S)
    return per_call


def _empty_bursts(count: int) -> list[float]:
    per_call = []
    for _ in range(count):
        start = time.perf_counter_ns()
        for _ in range(_BURST):
            empty()
        per_call.append((time.perf_counter_ns() - start) / _BURST)
        time.sleep(_GAP_S)
    return per_call


def _loop(seconds: float, modes: dict[str, list[list[float]]], state: list[str]) -> int:
    """The 1 kHz loop: periods (µs) per segment of each state; returns the watched line's hits."""
    period = 1e-3
    nxt = time.perf_counter() + period
    last = time.perf_counter()
    end = last + seconds
    k = 0
    current = state[0]
    segment: list[float] = []
    modes.setdefault(current, []).append(segment)
    while last < end:
        spin = time.perf_counter() + _WORK_S
        while time.perf_counter() < spin:
            pass
        k = control_step(k)
        delay = nxt - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        now = time.perf_counter()
        if state[0] != current:
            current = state[0]
            segment = []
            modes.setdefault(current, []).append(segment)
        else:
            segment.append((now - last) * 1e6)
        last = now
        nxt += period
        if nxt < now:
            nxt = now + period
    return k


def child() -> None:
    import dbglog  # noqa: F401  (DBGLOG_WATCH=1: the agent starts)

    state = ["none"]
    out = sys.stdout
    for line in sys.stdin:
        cmd, _, arg = line.strip().partition(" ")
        if cmd == "hits":
            result: Any = statistics.median(_bursts(target, int(arg)))
        elif cmd == "calls":
            result = statistics.median(_empty_bursts(int(arg)))
        elif cmd == "loop":
            modes: dict[str, list[list[float]]] = {}

            def read_modes() -> None:
                for mode_line in sys.stdin:
                    if mode_line.strip() == "end":
                        return
                    state[0] = mode_line.strip()

            reader = threading.Thread(target=read_modes, daemon=True)
            reader.start()
            hits = _loop(float(arg), modes, state)
            reader.join()
            result = {"hits": hits, "modes": modes}
        elif cmd == "quit":
            return
        else:
            result = None
        out.write(json.dumps(result) + "\n")
        out.flush()


# ----- the parent: the watcher ----------------------------------------------------------------------------


def _line(marker: str) -> int:
    for number, text in enumerate(Path(__file__).read_text().splitlines(), 1):
        if text.endswith(f"# WATCH:{marker}"):
            return number
    raise LookupError(marker)


class _Program:
    def __init__(self) -> None:
        env = {**os.environ, "DBGLOG_WATCH": "1"}
        self.proc = subprocess.Popen(
            [sys.executable, __file__, "--child"],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            text=True,
            env=env,
        )

    def ask(self, line: str) -> Any:
        assert self.proc.stdin is not None
        assert self.proc.stdout is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return json.loads(self.proc.stdout.readline())

    def say(self, line: str) -> None:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()

    def close(self) -> None:
        self.say("quit")
        self.proc.wait(30)


def _armed(watch: Any, timeout: float = 30.0) -> None:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if watch.armed:
            return
        time.sleep(0.02)
    raise SystemExit(f"the watch was not armed: {watch.status()}")


def _sent(watch: Any) -> int:
    """The hits the process sent for the watch (its counters, as its disarm answer gave them)."""
    return sum(int(s.stats.get("sent", 0)) for s in watch.status().values())


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="armed/removed rounds of each measurement")
    parser.add_argument("--bursts", type=int, default=15, help="bursts of 1000 calls per measurement")
    parser.add_argument("--loop-s", type=float, default=3.0, help="seconds of each 1 kHz loop segment")
    parser.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--domain", type=int, default=None)
    args = parser.parse_args()
    if args.child:
        child()
        return
    local_ros_env(args.domain)
    from dbglog.watch.client import WatchClient, WatchSpec

    program = _Program()
    here = Path(__file__).name
    hit_spec = WatchSpec(here, _line("hit"), ("x",), throttle=0, max_cpu=0.5)
    never_spec = WatchSpec(here, _line("never"), ("y",), max_cpu=0.5)
    loop_spec = WatchSpec(here, _line("loop"), ("k",))
    rows: dict[str, list[float]] = {}
    received = hits_sent = 0
    with WatchClient(values=True) as client:
        pid = program.proc.pid
        deadline = time.monotonic() + 60
        while pid not in {p.pid for p in client.processes()} and time.monotonic() < deadline:
            time.sleep(0.05)
        rows.setdefault("hit none", []).append(program.ask(f"hits {args.bursts}"))
        rows.setdefault("call none", []).append(program.ask(f"calls {args.bursts}"))
        for _ in range(args.repeats):
            watch = client.arm(hit_spec)
            _armed(watch)
            rows.setdefault("hit armed", []).append(program.ask(f"hits {args.bursts}"))
            watch.disarm()
            time.sleep(1.0)  # the last batches on their way
            received += len(watch.samples())
            hits_sent += _sent(watch)
            rows.setdefault("hit removed", []).append(program.ask(f"hits {args.bursts}"))
            watch = client.arm(never_spec)
            _armed(watch)
            rows.setdefault("call armed", []).append(program.ask(f"calls {args.bursts}"))
            watch.disarm()
            rows.setdefault("call removed", []).append(program.ask(f"calls {args.bursts}"))
        # The 1 kHz loop, one run: none, then armed / removed in turn.
        total = args.loop_s * (1 + 2 * args.repeats) + 2.0
        program.say(f"loop {total}")
        time.sleep(args.loop_s)
        loop_received = loop_sent = 0
        for _ in range(args.repeats):
            watch = client.arm(loop_spec)
            _armed(watch)
            program.say("armed")
            time.sleep(args.loop_s)
            watch.disarm()
            program.say("removed")
            time.sleep(args.loop_s)
            loop_received += len(watch.samples())
            loop_sent += _sent(watch)
        program.say("end")
        assert program.proc.stdout is not None
        loop = json.loads(program.proc.stdout.readline())
    program.close()
    per = {k: statistics.median(v) for k, v in rows.items()}
    version = ".".join(map(str, sys.version_info[:2]))
    print_table(
        f"Per hit and per call (Python {version}; ns a call, median of {args.repeats}x{args.bursts} bursts)",
        ["measure", "no watch", "armed", "removed", "armed - none", "removed - none"],
        [
            [
                "call of the watched function (1 hit, value queued)",
                f"{per['hit none']:.0f}",
                f"{per['hit armed']:.0f}",
                f"{per['hit removed']:.0f}",
                f"{per['hit armed'] - per['hit none']:.0f}",
                f"{per['hit removed'] - per['hit none']:.0f}",
            ],
            [
                "call of another function (the watched line not run)",
                f"{per['call none']:.0f}",
                f"{per['call armed']:.0f}",
                f"{per['call removed']:.0f}",
                f"{per['call armed'] - per['call none']:.0f}",
                f"{per['call removed'] - per['call none']:.0f}",
            ],
        ],
    )
    print(f"\nvalues received by the watcher: {received} of {hits_sent} hits sent")

    def stat(mode: str, q: float) -> str:
        segments = [s for s in loop["modes"].get(mode, []) if len(s) > 100]
        if not segments:
            return "-"
        return f"{statistics.median(statistics.quantiles(s, n=100)[int(q) - 1] for s in segments):.0f}"

    print_table(
        f"1 kHz loop period (Python {version}; µs, median over segments of {args.loop_s:g} s)",
        ["state", "p50", "p99", "segments"],
        [
            [mode, stat(mode, 50), stat(mode, 99), len(loop["modes"].get(mode, []))]
            for mode in ("none", "armed", "removed")
        ],
    )
    print(f"\n1 kHz loop: the watcher received {loop_received} of the {loop_sent} values sent")


if __name__ == "__main__":
    main()
