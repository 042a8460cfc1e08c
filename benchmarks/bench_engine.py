"""Viewer engine ingest benchmark: the engine next to a plain rclpy executor, publishers in other processes.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_engine`` (``--help`` for options).
Every receiver and publisher is its own process; the script orchestrates them and prints Markdown
tables: flood ingest (50 topics and 1 topic, engine vs ``SingleThreadedExecutor``), loss and
publish-to-buffer latency at a fixed rate, RSS over a soak run, and (``--only take``) messages per take
against fast and slow publishers, the engine's gathering off and on side by side.
"""

from __future__ import annotations

import argparse
import json
import os
import random
import statistics
import struct
import subprocess
import sys
import threading
import time
from pathlib import Path
from typing import Any

_ROOT = Path(__file__).resolve().parent.parent
if str(_ROOT) not in sys.path:
    sys.path.insert(0, str(_ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402

_PREFIX = "/bench/engine/t"
_SAMPLE_S = 0.1


# --- child roles -------------------------------------------------------------------------------------


def _publisher(args: argparse.Namespace) -> None:
    """Publish pre-serialised Float64 messages round-robin over the topics, paced or flat out."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from rclpy.qos import DurabilityPolicy, HistoryPolicy, QoSProfile, ReliabilityPolicy
    from std_msgs.msg import Float64

    context = Context()
    rclpy.init(context=context)
    node = Node("bench_publisher", context=context)
    if args.pub_qos == "tag":
        from dbglog._ros._qos import tag_qos

        qos = tag_qos()  # what dbglog.logfloat's publishers use: reliable, transient-local, depth 100
    else:
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1000,
            reliability=ReliabilityPolicy.RELIABLE,
            durability=DurabilityPolicy.VOLATILE,
        )
    pubs = [node.create_publisher(Float64, f"{args.prefix}{i}", qos) for i in range(args.topics)]
    deadline = time.monotonic() + 30
    while time.monotonic() < deadline and not all(p.get_subscription_count() > 0 for p in pubs):
        time.sleep(0.02)
    matched = all(p.get_subscription_count() > 0 for p in pubs)
    time.sleep(0.3)
    header = b"\x00\x01\x00\x00"
    pack = struct.Struct("<d").pack
    n_topics = args.topics
    rate = args.rate
    sent = 0
    start = time.monotonic()
    end = start + args.duration
    while args.even and rate > 0:  # one message at a time, each at its own due time (busy between them)
        now = time.monotonic()
        if now >= end:
            break
        due = start + sent / rate
        while now < due:
            now = time.monotonic()
        pubs[sent % n_topics].publish(header + pack(float(sent)))
        sent += 1
    while not args.even:
        now = time.monotonic()
        if now >= end:
            break
        if rate > 0:
            due = int((now - start) * rate)
            if sent >= due:
                time.sleep(min(0.001, (sent + 1) / rate - (now - start)))
                continue
            burst = min(due - sent, 1000)
        else:
            burst = 500
        for _ in range(burst):
            pubs[sent % n_topics].publish(header + pack(float(sent)))
            sent += 1
    stop = time.monotonic()
    print(json.dumps({"matched": matched, "start": start, "end": stop, "sent": sent}), flush=True)
    time.sleep(2.0)  # keep reliable writers alive while the receiver drains
    node.destroy_node()
    rclpy.shutdown(context=context)


def _rss_bytes() -> int:
    with open("/proc/self/statm") as f:
        return int(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")


def _receiver(args: argparse.Namespace) -> None:
    """Count messages with the engine or a plain executor; report samples when stdin says stop."""
    topics = [f"{args.prefix}{i}" for i in range(args.topics)]
    samples: list[tuple[float, ...]] = []
    stop = threading.Event()
    result: dict[str, Any] = {}

    def watch_stdin() -> None:
        sys.stdin.readline()
        stop.set()

    threading.Thread(target=watch_stdin, daemon=True).start()
    if args.role == "engine":
        from dbglog.viewer._data._engine import Engine
        from dbglog.viewer._data._model import Binding

        kwargs = {name: getattr(args, name) for name in _ENGINE_OPTIONS if getattr(args, name) is not None}
        engine = Engine(measure_latency=bool(args.latency), history=args.history, **kwargs)
        engine.start()
        bindings = [Binding(t) for t in topics]
        for b in bindings:
            engine.bind(b)
        print("ready", flush=True)
        while not stop.wait(_SAMPLE_S):
            stats = engine.stats()
            now, cpu = time.monotonic(), time.process_time()
            samples.append(
                (now, stats.taken, cpu, _rss_bytes(), stats.thread_cpu_s, stats.cycles, stats.takes)
            )
        snaps = [engine.snapshot(b) for b in bindings]
        lat = engine.latencies()
        result["landed"] = sum(s.count for s in snaps)
        result["statuses"] = sorted({str(s.status) for s in snaps})
        if len(lat):
            result["lat_p50"] = float(statistics.quantiles(lat, n=100)[49]) if len(lat) > 1 else float(lat[0])
            result["lat_p99"] = float(statistics.quantiles(lat, n=100)[98]) if len(lat) > 1 else float(lat[0])
        engine.stop()
    else:
        import rclpy
        from rclpy.context import Context
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.qos import HistoryPolicy, QoSProfile
        from std_msgs.msg import Float64

        context = Context()
        rclpy.init(context=context)
        node = Node("bench_executor", context=context)
        count = [0]

        def callback(_msg: Any) -> None:
            count[0] += 1

        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=1000)
        for t in topics:
            node.create_subscription(Float64, t, callback, qos)
        executor = SingleThreadedExecutor(context=context)
        executor.add_node(node)

        def sample() -> None:
            while not stop.wait(_SAMPLE_S):
                samples.append((time.monotonic(), count[0], time.process_time(), _rss_bytes()))

        sampler = threading.Thread(target=sample, daemon=True)
        sampler.start()
        print("ready", flush=True)
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
        sampler.join()
        result["landed"] = count[0]
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
    result["samples"] = samples
    print(json.dumps(result), flush=True)


# --- orchestration -------------------------------------------------------------------------------


_CHILD_ARGS: list[str] = []
"""Options every receiver child gets (set from the command line)."""
_ENGINE_OPTIONS = ("queue_budget", "queue_depth", "min_cycle", "max_stretch", "max_gather")
"""Command-line options that are `Engine` settings of the same name (None: the engine's default)."""


def _child(role: str, *extra: str) -> subprocess.Popen[str]:
    return subprocess.Popen(
        [sys.executable, "-m", "benchmarks.bench_engine", "--role", role, *_CHILD_ARGS, *extra],
        cwd=_ROOT,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )


def _run_once(
    receiver: str,
    topics: int,
    rate: float,
    duration: float,
    *,
    latency: bool = True,
    even: bool = False,
    engine: tuple[str, ...] = (),
) -> dict[str, Any]:
    """Run one receiver against one publisher process; return both reports.

    `even`: the publisher sends each message at its own time (no bursts); `engine`: more engine options.
    """
    prefix = f"{_PREFIX}{random.randrange(1 << 30)}_"
    common = ["--topics", str(topics), "--prefix", prefix]
    rx = _child(receiver, *common, "--latency", "1" if latency else "0", *engine)
    assert rx.stdout is not None
    assert rx.stdin is not None
    if rx.stdout.readline().strip() != "ready":
        raise RuntimeError(f"{receiver} receiver did not start")
    pace = ["--even"] if even else []
    tx = _child("publisher", *common, "--rate", str(rate), "--duration", str(duration), *pace)
    out, _ = tx.communicate(timeout=duration + 60)
    pub = json.loads(out.strip().splitlines()[-1])
    time.sleep(1.5)  # let the receiver drain its queues
    out, _ = rx.communicate("stop\n", timeout=30)
    rec = json.loads(out.strip().splitlines()[-1])
    if not pub["matched"]:
        raise RuntimeError("the publisher never matched the receiver's subscriptions")
    return {"pub": pub, "rx": rec}


def _window(run: dict[str, Any]) -> dict[str, float]:
    """Return a run's figures inside the publishing window (from 0.5 s after its start).

    rate: messages/s taken; cpu: the receiver process's CPU µs a message (all threads); sent: messages/s
    published; lost: the share of the messages published that never reached the receiver (counted once it
    has drained); and for the engine, thread: its own thread's CPU µs a message, per_take: messages a take
    that found any, latency p50 / p99 (ms) when recorded.
    """
    pub, rx = run["pub"], run["rx"]
    nan = float("nan")
    figures = {
        "sent": pub["sent"] / (pub["end"] - pub["start"]),
        "lost": max(0.0, 1 - rx["landed"] / pub["sent"]) if pub["sent"] else nan,
        "rate": 0.0,
        "cpu": nan,
        "thread": nan,
        "per_take": nan,
        "p50": rx.get("lat_p50", nan) * 1e3,
        "p99": rx.get("lat_p99", nan) * 1e3,
    }
    lo, hi = pub["start"] + 0.5, pub["end"]
    inside = [s for s in rx["samples"] if lo <= s[0] <= hi]
    if len(inside) < 2:
        return figures
    first, last = inside[0], inside[-1]
    n = last[1] - first[1]
    figures["rate"] = n / (last[0] - first[0])
    if n:
        figures["cpu"] = (last[2] - first[2]) / n * 1e6
    if n and len(first) > 6:  # the engine's own counters
        figures["thread"] = (last[4] - first[4]) / n * 1e6
        takes = last[6] - first[6]
        figures["per_take"] = n / takes if takes else nan
    return figures


def _median(runs: list[dict[str, float]]) -> dict[str, float]:
    """Return each figure's median over runs."""
    return {key: statistics.median(r[key] for r in runs) for key in runs[0]}


def _flood(receiver: str, topics: int, duration: float, repeats: int) -> dict[str, float]:
    return _median([_window(_run_once(receiver, topics, 0, duration)) for _ in range(repeats)])


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (or one child role) and print the tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--role", choices=["main", "publisher", "engine", "executor"], default="main")
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--prefix", default=_PREFIX)
    parser.add_argument("--rate", type=float, default=0.0, help="total messages/s (0: flat out)")
    parser.add_argument(
        "--even",
        action="store_true",
        help="with --rate: send each message at its own time, none in bursts (a publisher slower than "
        "the engine)",
    )
    parser.add_argument("--duration", type=float, default=5.0, help="seconds per flood run")
    parser.add_argument("--history", type=int, default=10_000)
    parser.add_argument(
        "--pub-qos",
        choices=["tag", "deep"],
        default="tag",
        help="publishers' QoS: 'tag' = dbglog's tag QoS (reliable, transient-local, depth 100); "
        "'deep' = reliable, volatile, depth 1000 (Fast DDS then delays deliveries by 0.3-0.7 s now and then)",
    )
    parser.add_argument(
        "--queue-budget", type=int, default=None, help="the engine's queue_budget (default: the engine's)"
    )
    parser.add_argument(
        "--queue-depth", type=int, default=None, help="the engine's queue_depth (default: the engine's)"
    )
    parser.add_argument("--min-cycle", type=float, default=None, help="the engine's min_cycle in seconds")
    parser.add_argument(
        "--max-stretch",
        type=float,
        default=None,
        help="the engine's max_stretch in seconds (default: the engine's; 0 = rest only min_cycle)",
    )
    parser.add_argument(
        "--max-gather",
        type=float,
        default=None,
        help="the engine's max_gather in seconds (default: the engine's; 0 = every cycle min_cycle)",
    )
    parser.add_argument("--latency", type=int, choices=[0, 1], default=1, help=argparse.SUPPRESS)
    parser.add_argument(
        "--only",
        choices=["flood", "rate", "soak", "take"],
        default=None,
        help="run one part of the benchmark ('take' is run only when named)",
    )
    parser.add_argument(
        "--slow-rate",
        type=float,
        default=13_500.0,
        help="'take': the rate of the publisher slower than the engine (sent evenly, no bursts)",
    )
    parser.add_argument("--repeats", type=int, default=3, help="flood runs per figure (median)")
    parser.add_argument("--loss-rate", type=float, default=20_000.0)
    parser.add_argument("--loss-seconds", type=float, default=10.0)
    parser.add_argument("--soak-rate", type=float, default=10_000.0)
    parser.add_argument("--soak-seconds", type=float, default=60.0, help="600 for the 10-minute figure")
    parser.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (random by default)")
    args = parser.parse_args(argv)
    if args.role == "publisher":
        _publisher(args)
        return 0
    if args.role in ("engine", "executor"):
        _receiver(args)
        return 0

    local_ros_env(args.domain if args.domain is not None else random.randint(150, 230))
    _CHILD_ARGS[:] = ["--pub-qos", args.pub_qos]
    for name in _ENGINE_OPTIONS:  # the engine children get the same settings
        if getattr(args, name) is not None:
            _CHILD_ARGS.extend([f"--{name.replace('_', '-')}", str(getattr(args, name))])
    print(
        f"ROS_DOMAIN_ID={os.environ['ROS_DOMAIN_ID']}, {os.cpu_count()} CPUs, {args.repeats} repeats, "
        f"publisher QoS {args.pub_qos}"
    )
    if args.only in (None, "flood"):
        _flood_table(args)
    if args.only in (None, "rate"):
        _rate_table(args)
    if args.only in (None, "soak"):
        _soak_table(args)
    if args.only == "take":
        _take_table(args)
    return 0


def _flood_table(args: argparse.Namespace) -> None:
    n = args.topics
    rows = []
    for topics in (n, 1):
        engine = _flood("engine", topics, args.duration, args.repeats)
        executor = _flood("executor", topics, args.duration, args.repeats)
        for name, f, ratio in (
            ("dbglog engine", engine, f"{engine['rate'] / executor['rate']:.1f}×"),
            ("rclpy SingleThreadedExecutor", executor, "1.0×"),
        ):
            rows.append([name, topics, *_flood_cells(f), ratio])
    print_table(
        "Flood ingest (publisher flat out, Float64, median of repeats)",
        [
            "receiver",
            "topics",
            "sent msg/s",
            "msg/s",
            "lost",
            "msg a take",
            "CPU µs/msg",
            "thread µs/msg",
            "vs executor",
        ],
        rows,
    )


def _flood_cells(f: dict[str, float]) -> list[str]:
    """A flood row's figures: sent and taken rates, loss, messages a take, process and thread CPU."""
    return [
        f"{f['sent']:,.0f}",
        f"{f['rate']:,.0f}",
        f"{f['lost'] * 100:.1f} %",
        "-" if f["per_take"] != f["per_take"] else f"{f['per_take']:.1f}",
        f"{f['cpu']:.1f}",
        "-" if f["thread"] != f["thread"] else f"{f['thread']:.1f}",
    ]


def _take_table(args: argparse.Namespace) -> None:
    """Messages per take and CPU per message, the engine gathering off (``max_gather`` 0) and on,
    alternating run by run: publishers flat out, one slower than the engine (even, no bursts), and the
    rate table's 20,000 msg/s for latency."""
    n = args.topics
    scenarios = [
        (f"flood, {n} topics", n, 0.0, False),
        ("flood, 1 topic", 1, 0.0, False),
        (f"slow publisher {args.slow_rate:,.0f} msg/s even, {n} topics", n, args.slow_rate, True),
        (f"slow publisher {args.slow_rate:,.0f} msg/s even, 1 topic", 1, args.slow_rate, True),
        (f"{args.loss_rate:,.0f} msg/s, {n} topics", n, args.loss_rate, False),
    ]
    arms = {"off": ("--max-gather", "0"), "on": ()}
    rows = []
    for title, topics, rate, even in scenarios:
        runs: dict[str, list[dict[str, float]]] = {arm: [] for arm in arms}
        for _ in range(args.repeats):
            for arm, options in arms.items():
                run = _run_once("engine", topics, rate, args.duration, even=even, engine=options)
                runs[arm].append(_window(run))
        for arm in arms:
            f = _median(runs[arm])
            rows.append([title, arm, *_flood_cells(f), f"{f['p50']:.1f} / {f['p99']:.1f}"])
    print_table(
        f"Messages a take: gathering off (max_gather 0) and on, alternating, median of {args.repeats}",
        [
            "case",
            "gather",
            "sent msg/s",
            "msg/s",
            "lost",
            "msg a take",
            "CPU µs/msg",
            "thread µs/msg",
            "latency p50 / p99 (ms)",
        ],
        rows,
    )


def _rate_table(args: argparse.Namespace) -> None:
    n = args.topics
    loss_rows = []
    for receiver in ("engine", "executor"):
        run = _run_once(receiver, n, args.loss_rate, args.loss_seconds)
        sent, got = run["pub"]["sent"], run["rx"]["landed"]
        lat = (
            f"{run['rx']['lat_p50'] * 1e3:.1f} / {run['rx']['lat_p99'] * 1e3:.1f}"
            if "lat_p99" in run["rx"]
            else "n/a"
        )
        loss_rows.append(
            [
                receiver,
                f"{sent / (run['pub']['end'] - run['pub']['start']):,.0f}",
                sent,
                got,
                f"{max(0.0, 1 - got / sent) * 100:.2f} %",
                lat,
            ]
        )
    print_table(
        f"Fixed rate: {args.loss_rate:,.0f} msg/s over {n} topics for {args.loss_seconds:.0f} s",
        ["receiver", "sent msg/s", "sent", "landed", "loss", "latency p50 / p99 (ms)"],
        loss_rows,
    )


def _soak_table(args: argparse.Namespace) -> None:
    n = args.topics
    # The engine as the viewer runs it: no latency recording.
    run = _run_once("engine", n, args.soak_rate, args.soak_seconds, latency=False)
    samples = run["rx"]["samples"]
    pub = run["pub"]
    warm = pub["start"] + min(10.0, args.soak_seconds * 0.2)
    steady = [s[3] for s in samples if warm <= s[0] <= pub["end"]]
    first = steady[0] if steady else 0
    quarters = (
        [steady[min(len(steady) - 1, len(steady) * q // 4)] for q in (1, 2, 3)] if steady else [0, 0, 0]
    )
    print_table(
        f"Memory: {args.soak_rate:,.0f} msg/s over {n} topics for {args.soak_seconds:.0f} s",
        [
            "RSS after warm-up",
            "at 1/4",
            "at 1/2",
            "at 3/4",
            "at end",
            "growth (max - after warm-up)",
            "landed / sent",
        ],
        [
            [
                f"{first / 2**20:.1f} MB",
                *(f"{q / 2**20:.1f} MB" for q in quarters),
                f"{(steady[-1] if steady else 0) / 2**20:.1f} MB",
                f"{(max(steady, default=0) - first) / 2**20:.1f} MB",
                f"{run['rx']['landed']:,} / {pub['sent']:,}",
            ]
        ],
    )


if __name__ == "__main__":
    sys.exit(main())
