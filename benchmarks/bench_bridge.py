"""Benchmark the regex bridge: per-line matching cost, the pathological line, end-to-end /rosout throughput.

Run: ``.venv/bin/python -m benchmarks.bench_bridge`` (``--quick`` for a short run, ``--skip-e2e`` to leave
ROS out). Every figure is a median of repeats, with its baseline measured side by side in the same run;
the output is Markdown tables.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import random
import re
import select
import signal
import statistics
import struct
import subprocess
import sys
import tempfile
import threading
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from benchmarks._common import local_ros_env, print_table, spawn_flood

_WORDS = (
    "battery",
    "voltage",
    "current",
    "temperature",
    "pressure",
    "distance",
    "speed",
    "heading",
    "latency",
    "queue",
    "load",
    "torque",
    "angle",
    "yaw",
    "pitch",
    "roll",
    "depth",
    "width",
    "height",
    "rate",
)
_BENCH_SEQ = "bench seq=(\\d+)"
_PROBE_BASE = 50_000_000
_SPAN = 100_000_000


# --------------------------------------------------------------------------------------- matching cost


def rules_yaml(n: int, *, extra: Sequence[tuple[str, str, str]] = ()) -> str:
    """Return a rules file with `n` realistic rules (distinct literal keys, a number capture each)."""
    lines = ["rules:"]
    for tag, pattern, kind in extra:
        lines += [f"  - tag: {tag}", f"    type: {kind}", f"    pattern: '{pattern}'"]
    for i in range(n - len(extra)):
        word = f"{_WORDS[i % len(_WORDS)]}_{i}"
        lines += [f"  - tag: bench/r{i}", f"    pattern: '{word}[=:] *([-+]?\\d+(?:\\.\\d+)?)'"]
    return "\n".join(lines) + "\n"


def sample_lines(count: int, match_share: float, rules: int, seed: int = 1) -> list[str]:
    """Return log-like lines; `match_share` of them match one rule (of the first 50), the rest none."""
    rnd = random.Random(seed)
    out = []
    for _ in range(count):
        if rnd.random() < match_share:
            j = rnd.randrange(min(rules, 50))
            out.append(f"status: {_WORDS[j % len(_WORDS)]}_{j}={rnd.uniform(-100, 100):.3f} units, nominal")
        else:
            out.append(
                f"planner: computed a path with {rnd.randrange(100)} waypoints in {rnd.random():.4f} s "
                f"({rnd.choice(_WORDS)} ok)"
            )
    return out


def _per_line_ns(fn: Callable[[Any], object], lines: Sequence[Any], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter_ns()
        for line in lines:
            fn(line)
        samples.append((time.perf_counter_ns() - start) / len(lines))
    return statistics.median(samples)


def _re_loop(patterns: Sequence[re.Pattern[str]]) -> Callable[[str], list[float]]:
    def run(line: str) -> list[float]:
        values = []
        for p in patterns:
            m = p.search(line)
            if m is not None:
                with contextlib.suppress(ValueError):
                    values.append(float(m.group(1)))
        return values

    return run


_BATCH = 256
"""Lines per `match_many` call in the batched figures: the bridge node's burst (``_node._BURST``)."""


def _interleaved(
    runs: dict[str, Callable[[int, int], object]], count: int, rounds: int, block: int
) -> dict[str, float]:
    """Median CPU ns per line of each run, over blocks of `block` lines, the runs taking turns on each block.

    ``run(lo, hi)`` handles lines ``lo`` to ``hi``. Matching is single-threaded CPU work, so this thread's
    CPU time is what it costs; unlike wall time it leaves out the time other processes on a shared machine
    take the CPU. Taking turns on short blocks, rather than timing one run's repeats then the next's,
    spreads what remains of the machine's load (caches, clock speed) over every run alike, and the order
    rotates from block to block.
    """
    samples: dict[str, list[float]] = {name: [] for name in runs}
    clock = time.thread_time_ns
    order = list(runs.items())
    for _ in range(rounds):
        for lo in range(0, count, block):
            hi = min(count, lo + block)
            order.append(order.pop(0))  # each run in turn goes first, so none always follows the same one
            for name, run in order:
                start = clock()
                run(lo, hi)
                samples[name].append((clock() - start) / (hi - lo))
    return {name: statistics.median(values) for name, values in samples.items()}


def _matching_runs(n: int, lines: list[str]) -> dict[str, Callable[[int, int], object]]:
    """Every way of matching `lines` with `n` rules, plus the ``re.search`` loop baseline."""
    from dbglog.regex_bridge import Matcher, parse_rules

    rules = parse_rules(rules_yaml(n))
    matcher = Matcher(rules)
    baseline = _re_loop([re.compile(r.pattern) for r in rules.rules])
    data = [line.encode() for line in lines]
    match, match_bytes = matcher.match, matcher.match_bytes
    match_many, match_many_bytes = matcher.match_many, matcher.match_many_bytes
    # Each run is a plain loop calling the API as a user would (no functools.partial, whose own cost,
    # ~0.2 µs a call, the earlier figures charged to the engine only).

    def one_str(lo: int, hi: int) -> None:
        for line in lines[lo:hi]:
            match(line, logger="planner", level=20)

    def one_bytes(lo: int, hi: int) -> None:
        for line in data[lo:hi]:
            match_bytes(line, "planner", 20)

    def many_str(lo: int, hi: int) -> None:
        for i in range(lo, hi, _BATCH):
            match_many(lines[i : min(hi, i + _BATCH)], logger="planner", level=20)

    def many_bytes(lo: int, hi: int) -> None:
        for i in range(lo, hi, _BATCH):
            match_many_bytes(data[i : min(hi, i + _BATCH)], "planner", 20)

    def re_loop(lo: int, hi: int) -> None:
        for line in lines[lo:hi]:
            baseline(line)

    return {"str": one_str, "bytes": one_bytes, "many": many_str, "many_bytes": many_bytes, "re": re_loop}


def bench_matching(quick: bool) -> None:
    """Per-line cost of the engine, line by line and batched, vs a loop of ``re.search``; 50 and 200 rules."""
    count, rounds = (2048, 5) if quick else (5120, 9)
    rows = []
    results: dict[tuple[int, str], dict[str, float]] = {}
    for share, label in ((0.1, "10% match"), (0.0, "none match"), (1.0, "all match")):
        lines = sample_lines(count, share, 200)
        for n in (50, 200):
            got = results[n, label] = _interleaved(_matching_runs(n, lines), count, rounds, 2 * _BATCH)
            rows.append(
                [
                    f"{n}",
                    label,
                    f"{got['str'] / 1000:.2f}",
                    f"{got['bytes'] / 1000:.2f}",
                    f"{got['many'] / 1000:.2f}",
                    f"{got['many_bytes'] / 1000:.2f}",
                    f"{got['re'] / 1000:.2f}",
                    f"{got['re'] / got['str']:.1f}x",
                    f"{got['re'] / got['many']:.1f}x",
                ]
            )
    print_table(
        f"Matching cost per line (CPU time, median over blocks of {2 * _BATCH} lines, {rounds} interleaved "
        f"rounds, {count} lines of ~75 bytes; batched = match_many over batches of {_BATCH} lines, "
        "cost per line)",
        [
            "rules",
            "lines",
            "match(str) µs/line",
            "match_bytes µs/line",
            "match_many (batched) µs/line",
            "match_many_bytes (batched) µs/line",
            "re.search loop µs/line",
            "speed-up, line by line (str)",
            "speed-up, batched (str)",
        ],
        rows,
    )
    r50, r200 = results[50, "10% match"], results[200, "10% match"]
    print(
        f"\n200 rules cost {r200['str'] / r50['str']:.2f}x 50 rules line by line, "
        f"{r200['many'] / r50['many']:.2f}x batched (10% match mix; target <= 2x)."
    )
    bench_batch_sizes(quick)
    bench_floor(quick)


def bench_batch_sizes(quick: bool) -> None:
    """Batched cost per line against the batch size, and with a logger and level per line (the node)."""
    from dbglog.regex_bridge import Matcher, parse_rules

    count, rounds = (2048, 5) if quick else (5120, 9)
    lines = sample_lines(count, 0.1, 50)
    data = [line.encode() for line in lines]
    matcher = Matcher(parse_rules(rules_yaml(50)))
    rnd = random.Random(3)
    loggers = [rnd.choice(("planner", "controller", "driver", "camera")) for _ in lines]
    levels = [rnd.choice((20, 20, 20, 30)) for _ in lines]

    def batched(size: int, mixed: bool) -> Callable[[int, int], object]:
        def run(lo: int, hi: int) -> None:
            for i in range(lo, hi, size):
                j = min(hi, i + size)
                if mixed:
                    matcher.match_many_bytes(data[i:j], loggers[i:j], levels[i:j])
                else:
                    matcher.match_many_bytes(data[i:j], "planner", 20)

        return run

    def line_by_line(lo: int, hi: int) -> None:
        for line, logger, level in zip(data[lo:hi], loggers[lo:hi], levels[lo:hi], strict=True):
            matcher.match_bytes(line, logger, level)

    runs: dict[str, Callable[[int, int], object]] = {"line by line (match_bytes)": line_by_line}
    for size in (1, 4, 16, 64, 256, 1024):
        runs[f"batches of {size}"] = batched(size, False)
    runs[f"batches of {_BATCH}, a logger and level per line"] = batched(_BATCH, True)
    got = _interleaved(runs, count, rounds, 1024)
    print_table(
        "Batch size (50 rules, 10% match, match_many_bytes; loggers and levels vary per line in the first "
        "and last rows, like /rosout)",
        ["how", "µs/line (median)"],
        [[name, f"{ns / 1000:.2f}"] for name, ns in got.items()],
    )


def bench_floor(quick: bool) -> None:
    """What the google-re2 binding itself costs per line: the floor under the engine, and rejected designs."""
    from re2 import _re2

    from dbglog._regex._compile import re2_options
    from dbglog.regex_bridge import parse_rules

    count, rounds = (2048, 5) if quick else (5120, 9)
    data = [line.encode() for line in sample_lines(count, 0.1, 50)]
    patterns = [r.pattern.encode() for r in parse_rules(rules_yaml(50)).rules]
    anchor = _re2.RE2.Anchor.UNANCHORED
    rule_set = _re2.Set(anchor, re2_options(64 << 20))
    multi_set = _re2.Set(anchor, re2_options(64 << 20))
    for p in patterns:
        rule_set.Add(p)
        multi_set.Add(b"(?m)" + p)
    rule_set.Compile()
    multi_set.Compile()
    one = _re2.RE2(patterns[0], re2_options()).Match
    combined = _re2.RE2(b"|".join(b"(" + p + b")" for p in patterns), re2_options(64 << 20)).Match
    grouping = b"|".join(b"(?:" + p + b")" for p in patterns)
    no_capture_options = re2_options(64 << 20)
    no_capture_options.never_capture = True
    combined_no_capture = _re2.RE2(grouping, no_capture_options).Match

    def each(call: Callable[[bytes], object]) -> Callable[[int, int], object]:
        def run(lo: int, hi: int) -> None:
            for line in data[lo:hi]:
                call(line)

        return run

    def joined(lo: int, hi: int) -> None:
        for i in range(lo, hi, _BATCH):
            multi_set.Match(b"\n".join(data[i : min(hi, i + _BATCH)]))

    empty = b""
    runs: dict[str, Callable[[int, int], object]] = {
        "Set.Match(b'') — one call into the binding, no text": each(lambda _line: rule_set.Match(empty)),
        "Set.Match(line), 50 rules": each(lambda line: rule_set.Match(line)),
        "RE2.Match(line) of one rule (groups)": each(lambda line: one(anchor, line, 0, len(line))),
        "one alternation of the 50 rules, each a group (one call gives rule and groups)": each(
            lambda line: combined(anchor, line, 0, len(line))
        ),
        "one alternation of the 50 rules, no groups": each(
            lambda line: combined_no_capture(anchor, line, 0, len(line))
        ),
        f"Set.Match over {_BATCH} lines joined, (?m) rules, per line": joined,
    }
    got = _interleaved(runs, count, rounds, 2 * _BATCH)
    print_table(
        "The google-re2 binding's own cost (50 rules, 10% match; no engine code, each call through a lambda)",
        ["call", "µs/line (median)"],
        [[name, f"{ns / 1000:.2f}"] for name, ns in got.items()],
    )


def bench_pathological(quick: bool) -> None:
    """100 kB of 'a' then '!' against ``(a+)+$``: through the engine, raw RE2 on the full line, and `re`."""
    from dbglog.regex_bridge import Matcher, compile_regex, parse_rules

    line = "a" * 100_000 + "!"
    repeats = 5 if quick else 11
    matcher = Matcher(parse_rules("rules: [{tag: slow, pattern: '(a+)+$'}]"))
    compiled = compile_regex("(a+)+$")
    rows = [
        ["engine (line truncated to MAX_LINE)", f"{_per_line_ns(matcher.match, [line], repeats) / 1e6:.3f}"],
        [
            "RE2 on the full 100 kB line",
            f"{_per_line_ns(compiled.compiled.search, [line], repeats) / 1e6:.3f}",
        ],
    ]
    for pattern in ("(a|aa)+$", "(\\w+\\s?)+$", "(.*a){20}"):
        m = Matcher(parse_rules(f"rules: [{{tag: slow, pattern: '{pattern}'}}]"))
        rows.append([f"engine, {pattern}", f"{_per_line_ns(m.match, [line], repeats) / 1e6:.3f}"])
    # Batched: the same line among ordinary log lines, and a batch of nothing but such lines.
    ordinary = sample_lines(_BATCH - 1, 0.1, 50)
    for pattern in ("(a+)+$", "(a|aa)+$", "(\\w+\\s?)+$", "(.*a){20}"):
        m = Matcher(parse_rules(f"rules: [{{tag: slow, pattern: '{pattern}'}}]"))
        mixed = _per_line_ns(m.match_many, [[line, *ordinary]], repeats) / 1e6
        only = _per_line_ns(m.match_many, [[line] * 16], repeats) / 1e6 / 16
        rows.append(
            [
                f"engine batched, {pattern}: the line among {_BATCH - 1} ordinary lines (whole batch); "
                "16 such lines (per line)",
                f"{mixed:.3f}; {only:.3f}",
            ]
        )
    backtracking = re.compile("(a+)+$")
    for n in (16, 20):
        short = "a" * n + "!"
        rows.append(
            [
                f"Python re, only {n} 'a' then '!'",
                f"{_per_line_ns(backtracking.search, [short], 1) / 1e6:.3f}",
            ]
        )
    print_table("Pathological line: 100 kB of 'a' then '!'", ["what", "ms per line (median)"], rows)


# ------------------------------------------------------------------------------------------ end to end


def _publisher_main(args: argparse.Namespace) -> int:
    """Child process: log `count` lines at `rate`/s after the parent says go (probes until then)."""
    import rclpy
    from rclpy.context import Context
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.node import Node

    context = Context()
    rclpy.init(context=context)
    node = Node(f"bench_pub_{args.offset // _SPAN}", context=context, start_parameter_services=False)
    logger = node.get_logger()
    name = logger.name
    if args.mode == "logger":

        def log(text: str) -> None:
            logger.info(text)

    else:

        def log(text: str) -> None:
            _rclpy.rclpy_logging_rcutils_log(20, name, text, "bench", __file__, 1)

    probe = 0
    while not select.select([sys.stdin], [], [], 0.1)[0]:
        log(f"bench seq={args.offset + _PROBE_BASE + probe}")
        probe += 1
    sys.stdin.readline()
    start = time.perf_counter()
    sent = 0
    while sent < args.count:
        due = min(args.count, int((time.perf_counter() - start) * args.rate) + 1)
        while sent < due:
            log(f"bench seq={args.offset + sent} planner: path cost 12.5 ok")
            sent += 1
        if sent < args.count:
            time.sleep(0.0005)
    elapsed = time.perf_counter() - start
    print(f"sent {sent} {elapsed:.4f}", flush=True)
    sys.stdin.readline()  # stay alive (and keep the rosout writer) until the parent has counted
    node.destroy_node()
    rclpy.shutdown(context=context)
    return 0


class _Counter:
    """Counts distinct Int64 values on a topic, taking raw messages in a tight loop (like the bridge)."""

    def __init__(self, topic: str) -> None:
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
        from std_msgs.msg import Int64

        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node("bench_counter", context=self.context, start_parameter_services=False)
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=100_000,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
        self.sub = self.node.create_subscription(Int64, topic, lambda _m: None, qos, raw=True)
        self.seen: set[int] = set()
        self.last_arrival = time.monotonic()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

        unpack = struct.Struct("<q").unpack_from
        wait_set = _rclpy.WaitSet(1, 0, 0, 0, 0, 0, self.context.handle)
        handle, msg_type = self.sub.handle, self.sub.msg_type
        while not self._stop.is_set():
            taken = handle.take_message(msg_type, True)
            if taken is None:
                wait_set.clear_entities()
                wait_set.add_subscription(handle)
                wait_set.wait(50_000_000)
                continue
            self.seen.add(unpack(taken[0], 4)[0])
            self.last_arrival = time.monotonic()

    def close(self) -> None:
        import rclpy

        self._stop.set()
        self._thread.join(timeout=5)
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def _count_in(seen: set[int], low: int, high: int) -> int:
    # copy() runs in C under the GIL, so the counting thread cannot change the set mid-iteration.
    return sum(1 for s in seen.copy() if low <= s < high)


def bench_end_to_end(mode: str, publishers: int, rate: float, seconds: float) -> list[str]:
    """Publishers log at `rate` lines/s in total through real /rosout; count what the bridge delivers."""
    per_pub = int(rate * seconds / publishers)
    with tempfile.TemporaryDirectory() as tmp:
        rules_path = Path(tmp) / "rules.yaml"
        rules_path.write_text(rules_yaml(50, extra=[("bench/seq", _BENCH_SEQ, "int")]), encoding="utf-8")
        bridge = subprocess.Popen(
            [sys.executable, "-m", "dbglog", "bridge", str(rules_path), "--name", "bench_bridge"],
            stdout=subprocess.PIPE,
            stderr=subprocess.DEVNULL,
            text=True,
        )
        assert bridge.stdout is not None
        ready = bridge.stdout.readline()
        if "running" not in ready:
            raise RuntimeError(f"the bridge did not start: {ready!r}")
        counter = _Counter("/rosdashboard/bench/seq")
        pubs = spawn_flood("benchmarks.bench_bridge", publishers, rate, per_pub, _SPAN, mode)
        try:
            deadline = time.monotonic() + 60
            while any(
                _count_in(counter.seen, i * _SPAN + _PROBE_BASE, (i + 1) * _SPAN) == 0
                for i in range(publishers)
            ):
                if time.monotonic() > deadline:
                    raise RuntimeError("publishers never reached the bridge")
                time.sleep(0.05)
            for p in pubs:
                assert p.stdin is not None
                p.stdin.write("go\n")
                p.stdin.flush()
            sent, elapsed = 0, 0.0
            for p in pubs:
                assert p.stdout is not None
                _word, n, secs = p.stdout.readline().split()
                sent, elapsed = sent + int(n), max(elapsed, float(secs))
            expected = sent
            while True:
                got = sum(
                    _count_in(counter.seen, i * _SPAN, i * _SPAN + _PROBE_BASE) for i in range(publishers)
                )
                if got >= expected or time.monotonic() - counter.last_arrival > 3.0:
                    break
                time.sleep(0.1)
        finally:
            for p in pubs:
                if p.stdin is not None and p.poll() is None:
                    p.stdin.write("exit\n")
                    p.stdin.close()
            for p in pubs:
                p.wait(timeout=30)
                if p.stdout is not None:
                    p.stdout.close()
            counter.close()
            bridge.send_signal(signal.SIGINT)
            tail = bridge.communicate(timeout=30)[0]
    lost = expected - got
    taken = re.search(r"stopped after (\d+) lines", tail)
    return [
        mode,
        str(publishers),
        f"{rate:,.0f}",
        f"{sent / elapsed:,.0f}",
        f"{sent:,}",
        f"{got:,}",
        f"{lost:,} ({100 * lost / max(sent, 1):.2f}%)",
        taken.group(1) if taken else "?",
        str(bridge.returncode),
    ]


def main(argv: Sequence[str] | None = None) -> int:
    """Run the benchmarks (or, with --publisher, be one log-publishing child process)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repeats, shorter end-to-end runs")
    parser.add_argument("--skip-e2e", action="store_true", help="only the pure matching benchmarks")
    parser.add_argument("--rate", type=float, default=20_000.0, help="end-to-end lines/s (total)")
    parser.add_argument("--seconds", type=float, default=5.0, help="end-to-end duration")
    parser.add_argument("--publisher", choices=["logger", "rcutils"], help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--offset", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.publisher:
        return _publisher_main(
            argparse.Namespace(mode=args.publisher, rate=args.rate, count=args.count, offset=args.offset)
        )
    local_ros_env(random.SystemRandom().randint(1, 100) if "ROS_DOMAIN_ID" not in os.environ else None)
    bench_matching(args.quick)
    bench_pathological(args.quick)
    if not args.skip_e2e:
        seconds = 2.0 if args.quick else args.seconds
        rows = [
            bench_end_to_end("rcutils", 2, args.rate, seconds),
            bench_end_to_end("logger", 4, args.rate, seconds),
        ]
        print_table(
            "End to end: log lines through real /rosout → dbglog bridge → Int64 topic → counting subscriber",
            [
                "publishers log via",
                "processes",
                "target lines/s",
                "sent lines/s",
                "sent",
                "received",
                "lost",
                "bridge took",
                "bridge exit",
            ],
            rows,
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
