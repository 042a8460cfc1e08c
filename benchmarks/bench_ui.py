"""Viewer frame time: 20 widgets bound to 50 topics published at 100 Hz each (real publishers, real engine).

Run under a virtual display::

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python -m benchmarks.bench_ui

Each measurement runs in a fresh process (Dear PyGui allows one context per process): the same
dashboard is measured idle (a static source, no updates: the cost of drawing the window) and live
(the engine fed by a publisher process sending 50 x 100 Hz Float64). Prints a Markdown table of
frame-time percentiles (median over repeats) and the messages the engine took.
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from benchmarks._common import local_ros_env, print_table

_ROOT = Path(__file__).resolve().parent.parent
_PREFIX = "/bench/ui/t"


def _publisher(args: argparse.Namespace) -> None:
    """Publish Float64 sine values on every topic at the given rate, paced, for the given duration."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from std_msgs.msg import Float64

    context = Context()
    rclpy.init(context=context)
    node = Node("bench_ui_publisher", context=context)
    pubs = [node.create_publisher(Float64, f"{_PREFIX}{i}", 100) for i in range(args.topics)]
    period = 1.0 / args.rate
    start = time.monotonic()
    end = start + args.duration
    ticks = 0
    msg = Float64()
    while time.monotonic() < end:
        due = start + ticks * period
        delay = due - time.monotonic()
        if delay > 0:
            time.sleep(delay)
        t = time.time()
        for i, pub in enumerate(pubs):
            msg.data = 10.0 * math.sin(t * (0.5 + i * 0.05)) + i
            pub.publish(msg)
        ticks += 1
    print(json.dumps({"sent": ticks * len(pubs), "seconds": time.monotonic() - start}), flush=True)
    node.destroy_node()
    rclpy.shutdown(context=context)


def _layout() -> list[tuple[str, list[int]]]:
    """20 widgets over 50 topics: 8 plots of 5 series (topics 0-39) and 12 single-value widgets."""
    widgets: list[tuple[str, list[int]]] = [("plot", list(range(5 * k, 5 * k + 5))) for k in range(8)]
    singles = [
        "dial",
        "dial",
        "knob",
        "knob",
        "compass",
        "compass",
        "thermo",
        "thermo",
        "string",
        "led",
        "led",
        "dial",
    ]
    for j, kind in enumerate(singles):
        widgets.append((kind, [40 + j % 10]))
    return widgets


def _ui(args: argparse.Namespace) -> None:
    """Build the dashboard, render for the warm-up plus the measured time, print frame times as JSON."""
    from dbglog.viewer._geometry import Rect
    from dbglog.viewer._model import Binding
    from dbglog.viewer._model import DataSource as _DataSource
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    engine: Any = None
    source: _DataSource
    if args.source == "engine":
        from dbglog.viewer._engine import Engine

        engine = Engine(stale_after=2.0)
        engine.start()
        source = engine
    else:
        static = StaticSource()
        now = time.time()
        for i in range(args.topics):
            for k in range(200):
                static.push(f"{_PREFIX}{i}", "data", math.sin(k / 10 + i), now - 2 + k * 0.01)
        source = static
    width, height = args.width, args.height
    app = ViewerApp(source, WidgetRegistry.builtin(), width=width, height=height)
    app.start()
    app.set_snap(False)
    cell_w, cell_h = (width - 220) // 5, (height - 90) // 4
    for n, (kind, topics) in enumerate(_layout() if args.source != "empty" else []):
        item = app.add_widget(kind, 0, 0)
        assert item is not None
        item.place(Rect(8 + cell_w * (n % 5), 8 + cell_h * (n // 5), cell_w - 8, cell_h - 8), rebuild=True)
        app.apply_bindings(item, tuple(Binding(f"{_PREFIX}{t}", "data") for t in topics))
    warm_end = time.monotonic() + args.warmup
    while time.monotonic() < warm_end:
        app.frame()
    taken0 = engine.stats().taken if engine is not None else 0
    times = []
    end = time.monotonic() + args.duration
    t0 = time.monotonic()
    while time.monotonic() < end:
        times.append(app.frame())
    elapsed = time.monotonic() - t0
    taken = (engine.stats().taken - taken0) if engine is not None else 0
    live = sum(1 for i in app.items if i.status.value == "live")
    if args.shot:
        app.screenshot(args.shot)
    app.close()
    if engine is not None:
        engine.stop()
    print(json.dumps({"times": times, "elapsed": elapsed, "taken": taken, "live": live}), flush=True)


def _pct(values: list[float], q: float) -> float:
    ordered = sorted(values)
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _measure(source: str, args: argparse.Namespace, shot: str = "") -> dict[str, float]:
    pub = None
    if source == "engine":
        pub = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "benchmarks.bench_ui",
                "--role",
                "publisher",
                "--topics",
                str(args.topics),
                "--rate",
                str(args.rate),
                "--duration",
                str(args.warmup + args.duration + 6),
            ],
            cwd=_ROOT,
            stdout=subprocess.PIPE,
            text=True,
        )
        time.sleep(1.0)
    ui = subprocess.run(
        [
            sys.executable,
            "-m",
            "benchmarks.bench_ui",
            "--role",
            "ui",
            "--source",
            source,
            "--topics",
            str(args.topics),
            "--duration",
            str(args.duration),
            "--warmup",
            str(args.warmup),
            "--shot",
            shot,
        ],
        cwd=_ROOT,
        capture_output=True,
        text=True,
        timeout=args.warmup + args.duration + 120,
        check=False,
    )
    if pub is not None:
        pub.kill()
        pub.wait()
    if ui.returncode != 0:
        raise RuntimeError(f"ui child failed:\n{ui.stderr}")
    data = json.loads(ui.stdout.strip().splitlines()[-1])
    times_ms = [t * 1000 for t in data["times"]]
    return {
        "frames": len(times_ms),
        "fps": len(times_ms) / data["elapsed"],
        "p50": _pct(times_ms, 0.50),
        "p95": _pct(times_ms, 0.95),
        "p99": _pct(times_ms, 0.99),
        "msgs": data["taken"] / data["elapsed"],
        "live": data["live"],
    }


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (or one of its child roles)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--role", choices=("main", "publisher", "ui"), default="main")
    parser.add_argument("--source", choices=("empty", "static", "engine"), default="engine")
    parser.add_argument("--width", type=int, default=1440)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--rate", type=float, default=100.0, help="messages per second per topic")
    parser.add_argument("--duration", type=float, default=8.0, help="measured seconds per repeat")
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--shot", default="", help="write a PNG of the live dashboard at the end")
    args = parser.parse_args(argv)
    local_ros_env()
    if args.role == "publisher":
        _publisher(args)
        return 0
    if args.role == "ui":
        _ui(args)
        return 0
    rows = []
    scenarios = (
        ("empty", "empty window (Xvfb + Mesa fixed cost)"),
        ("static", "20 widgets idle (drawing only)"),
        ("engine", "20 widgets live: 50 topics x 100 Hz"),
    )
    for source, label in scenarios:
        runs = [
            _measure(source, args, args.shot if (source == "engine" and r == args.repeats - 1) else "")
            for r in range(args.repeats)
        ]
        med = {k: statistics.median(r[k] for r in runs) for k in runs[0]}
        rows.append(
            [
                label,
                f"{med['frames']:.0f}",
                f"{med['fps']:.0f}",
                f"{med['p50']:.1f}",
                f"{med['p95']:.1f}",
                f"{med['p99']:.1f}",
                f"{med['msgs']:.0f}",
                f"{med['live']:.0f}",
            ]
        )
    print_table(
        f"Viewer frame time at {args.width}x{args.height}, {args.topics} topics "
        f"(median of {args.repeats} x {args.duration:g} s)",
        ["scenario", "frames", "fps", "p50 ms", "p95 ms", "p99 ms", "engine msgs/s", "widgets live"],
        rows,
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
