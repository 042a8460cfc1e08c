"""Viewer frame time: 20 widgets bound to 50 topics published at 100 Hz each (real publishers, real engine).

Run under a virtual display::

    xvfb-run -a -s "-screen 0 1920x1080x24" .venv/bin/python -m benchmarks.bench_ui

What is measured, per frame, with vsync OFF (a vsync-capped loop measures the display, not the viewer):

- *frame production*: ``ViewerApp.frame()`` from start to end: input polling, reading snapshots, widget
  updates, then ``render_dearpygui_frame`` (Dear ImGui/ImPlot drawing, software GL rasterising, buffer swap);
- of which *app work* (everything before ``render_dearpygui_frame``) and *render* (that call alone);
- *frame interval*: from the start of one frame to the start of the next (what the user sees as frame rate).

Each measurement runs in a fresh process (Dear PyGui allows one context per process): an empty window (the
fixed cost of the GL stack), the dashboard idle (a static source: drawing only, no updates), the dashboard
live (the real engine fed by a publisher process sending 50 x 100 Hz Float64), and the live dashboard with
vsync on for reference. Percentiles are the median over repeats. The GL renderer, the X screen depth and the
load average are printed, since all of them move the figures.

A second table (``--loop run``, the default ``--scenarios`` include it) runs the viewer as ``dbglog view``
does, through ``ViewerApp.run`` with its frame cap (``--fps``) and its idle skipping, and reports the viewer
process's CPU: empty and idle, empty and idle beside a graph of ``--crowd`` topics (its engine polls the
graph; measured once it has seen them all), the same with the tag tree shown (``tree-run``; with
``--crowd-names robots`` the crowd is dbglog tags of 4 robots, ``/robotN/rosdashboard/groupG/tagT``, as the
tree groups them, and the row also times the tree's filter on them; ``--crowd-rate`` Hz makes each crowd
topic send, which an engine holding every tag takes), 20 widgets idle, 20 widgets paused in a
replay's history (``--replay-minutes`` of 50 topics x 100 Hz; the *replay* rows), 20 widgets live.
``--compare TREE`` runs the same rows, with the same caps, with the ``dbglog`` package of another checkout
(e.g. ``git worktree add /tmp/old HEAD~1``) beside this one (for ``tree-run``, one with the tag tree).

The *fleet* rows (``--scenarios fleet,fleet-run``) start two robot processes (`benchmarks/_fleet.py`,
``--fleet-tags`` tags each in subsystems of 20, at ``--fleet-rate`` Hz, through the dbglog SDK, in
``/robot1`` and ``/robot2``) and let the automatic dashboard build itself on the live graph; the frames are
measured once every tag is placed and every widget live (the first screen in view, the rest below it),
and the time that took is printed with the widget count. ``--compare TREE`` runs them with the other
checkout too (its own automatic dashboard).
"""

from __future__ import annotations

import argparse
import ctypes
import ctypes.util
import itertools
import json
import math
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

from benchmarks._common import local_ros_env, print_table

_ROOT = Path(__file__).resolve().parent.parent
_PREFIX = "/bench/ui/t"
_GL_RENDERER = 0x1F01
_GL_VERSION = 0x1F02


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


def _crowd(args: argparse.Namespace) -> None:
    """Hold `--crowd` topics on the graph, as a robot's many nodes do: sending nothing, or each at
    `--crowd-rate` Hz."""
    import rclpy
    from rclpy.context import Context
    from rclpy.node import Node
    from std_msgs.msg import Float64

    context = Context()
    rclpy.init(context=context)
    nodes = [Node(f"bench_ui_crowd_{n}", context=context) for n in range(max(1, args.crowd // 10))]
    pubs = [
        nodes[i % len(nodes)].create_publisher(Float64, _crowd_topic(i, args.crowd_names), 10)
        for i in range(args.crowd)
    ]
    print("up", flush=True)
    end = time.monotonic() + args.duration
    if args.crowd_rate <= 0:
        time.sleep(args.duration)
    ticks = 20  # a slice of the topics at each of 20 ticks a period: the messages spread over it
    period = 1.0 / args.crowd_rate if args.crowd_rate > 0 else 0.0
    tick = 0
    next_at = time.monotonic()
    while args.crowd_rate > 0 and time.monotonic() < end:
        for pub in pubs[tick % ticks :: ticks]:
            pub.publish(Float64(data=float(tick)))
        tick += 1
        next_at += period / ticks
        time.sleep(max(0.0, next_at - time.monotonic()))
    for node in nodes:
        node.destroy_node()
    rclpy.shutdown(context=context)


def _crowd_topic(i: int, names: str) -> str:
    """The crowd's topic `i`: ``/bench/crowd/t{i}``, or a robot's tag (4 robots, groups of 20 tags)."""
    if names == "robots":
        return f"/robot{i % 4 + 1}/rosdashboard/group{i // 80}/tag{i // 4 % 20}"
    return f"/bench/crowd/t{i}"


TREE_QUERIES = ("tag1", "robot3:group2*", "group7/tag19", "robot", "*tag?", "")
"""What the tree-run row types into the tag tree's filter (each answered three times, timed)."""


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


def _gl_info() -> str:
    """Return the current GL renderer and version strings (the context is current on this thread)."""
    try:
        gl = ctypes.CDLL(ctypes.util.find_library("GL") or "libGL.so.1")
        gl.glGetString.restype = ctypes.c_char_p
        gl.glGetString.argtypes = [ctypes.c_uint]
        renderer = (gl.glGetString(_GL_RENDERER) or b"?").decode()
        version = (gl.glGetString(_GL_VERSION) or b"?").decode()
    except OSError as exc:
        return f"unknown ({exc})"
    return f"{renderer}; {version}"


def _x_depth() -> str:
    """Return the default depth of the X screen in use, or why it is unknown."""
    try:
        x11 = ctypes.CDLL(ctypes.util.find_library("X11") or "libX11.so.6")
    except OSError as exc:
        return f"unknown ({exc})"
    x11.XOpenDisplay.restype = ctypes.c_void_p
    x11.XOpenDisplay.argtypes = [ctypes.c_char_p]
    x11.XDefaultScreen.argtypes = [ctypes.c_void_p]
    x11.XDefaultDepth.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XDisplayWidth.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XDisplayHeight.argtypes = [ctypes.c_void_p, ctypes.c_int]
    x11.XCloseDisplay.argtypes = [ctypes.c_void_p]
    display = x11.XOpenDisplay(None)
    if not display:
        return "no X display"
    screen = x11.XDefaultScreen(display)
    text = (
        f"{x11.XDisplayWidth(display, screen)}x{x11.XDisplayHeight(display, screen)}"
        f"x{x11.XDefaultDepth(display, screen)}"
    )
    x11.XCloseDisplay(display)
    return text


def _ui(args: argparse.Namespace) -> None:
    """Build the dashboard, render for the warm-up plus the measured time, print frame times as JSON."""
    if args.code:
        sys.path.insert(0, args.code)  # measure another checkout's viewer (dbglog is not imported yet)
    import dearpygui.dearpygui as dpg

    # Only names that older checkouts had too (`--compare`): the public data types, the UI's entry points.
    from dbglog.viewer import Binding
    from dbglog.viewer import DataSource as _DataSource
    from dbglog.viewer._ui import StaticSource, ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    engine: Any = None
    source: _DataSource
    recording = False
    auto: Any = None
    if args.source == "replay":  # a recording's history, paused in its middle: nothing changes
        import numpy as np

        from dbglog.viewer._data._history import History
        from dbglog.viewer._data._replay import ReplaySource

        store = History(clock=None, max_seconds=7200, max_bytes=2**40)
        names = [f"{_PREFIX}{i}" for i in range(args.topics)]
        base = np.arange(int(args.rate)) / args.rate
        t0 = time.time() - args.replay_minutes * 60
        for b in range(args.replay_minutes * 60):
            t = t0 + b + base
            for k, name in enumerate(names):
                store.append_numbers(name, t, np.sin(t * (0.1 + k * 0.01)))
        source = ReplaySource(store, dict.fromkeys(names, "std_msgs/msg/Float64"))
        recording = True
    elif args.source in ("engine", "crowd", "fleet", "tree"):
        from dbglog.viewer import Engine

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
    # (a viewer without a cap takes neither option)
    options: dict[str, Any] = {"fps": args.fps, "data_fps": args.data_fps} if args.fps else {}
    if recording:
        options["recording"] = True
    if args.tree:  # (older checkouts have no tag tree: only the tree rows ask for it)
        options["tag_tree"] = True
    app = ViewerApp(source, WidgetRegistry.builtin(), width=width, height=height, **options)
    app.start()
    dpg.set_viewport_vsync(args.vsync)
    app.set_snap(False)
    ready_s = math.nan
    if args.source == "fleet":  # the automatic dashboard builds itself; measured once every tag is live
        from dbglog.viewer._ui._auto import AutoDashboard, all_live

        auto = AutoDashboard(app)
        auto.install()
        begun = time.monotonic()
        expected = 2 * args.fleet_tags

        def placed() -> bool:
            return bool(len({b.topic for i in app.items for b in i.bindings}) >= expected)

        while time.monotonic() - begun < 120 and (auto.pending or not placed() or not all_live(app)):
            app.frame()
        ready_s = time.monotonic() - begun if placed() and all_live(app) else math.nan
    cell_w, cell_h = (width - 220) // 5, (height - 90) // 4
    for n, (kind, topics) in enumerate(
        _layout() if args.source not in ("empty", "crowd", "fleet", "tree") else []
    ):
        item = app.add_widget(kind, 0, 0)
        assert item is not None
        rect = type(item.rect)  # the viewer's Rect, wherever this checkout keeps it
        item.place(rect(8 + cell_w * (n % 5), 8 + cell_h * (n // 5), cell_w - 8, cell_h - 8), rebuild=True)
        app.apply_bindings(item, tuple(Binding(f"{_PREFIX}{t}", "data") for t in topics))
    app.select(None)
    if recording:
        span = app.timeline.span()
        assert span is not None
        app.timeline.seek((span[0] + span[1]) / 2)
    warm_end = time.monotonic() + args.warmup
    while time.monotonic() < warm_end:
        app.frame()
    if args.source in ("crowd", "tree"):
        # The whole crowd discovered before measuring, with and without the tree alike (2,000 topics take a
        # while, and discovering them is no idle viewer's work); the tree then holds them all.
        seen_by = time.monotonic() + 60
        while time.monotonic() < seen_by and (
            len(source.topics()) < args.crowd or (args.tree and app.tree.model.total < args.crowd)
        ):
            app.frame()
            time.sleep(0.05)
        warm_end = time.monotonic() + args.warmup
        while time.monotonic() < warm_end:
            app.frame()
    taken0 = engine.stats().taken if engine is not None else 0
    updates0 = sum(i.updates for i in app.items)
    totals: list[float] = []
    works: list[float] = []
    starts: list[float] = []
    cpu0 = time.process_time()
    t0 = time.perf_counter()
    end = t0 + args.duration
    if args.loop == "run":
        # As `dbglog view` runs: the app's own loop decides when to render; count what it renders.
        render = dpg.render_dearpygui_frame

        def counted() -> None:
            starts.append(time.perf_counter())
            render()

        dpg.render_dearpygui_frame = counted
        app.frame_times.clear()
        app.run(seconds=args.duration)
        dpg.render_dearpygui_frame = render
        totals = list(app.frame_times)
        works = [float("nan")] * len(totals)
    while args.loop == "frames":
        start = time.perf_counter()
        if start >= end:
            break
        starts.append(start)
        totals.append(app.frame())
        works.append(getattr(app, "last_work_s", float("nan")))
    elapsed = time.perf_counter() - t0
    cpu = time.process_time() - cpu0
    filter_ms: list[float] = []
    if args.tree:  # each query typed three times (the median kept), a frame drawn after each
        for query in TREE_QUERIES:
            times = []
            for _ in range(3):
                app.tree.set_filter("\x00")  # something else first: the query is answered afresh
                app.tree.set_filter(query)
                times.append(app.tree.filter_s * 1000)
                app.frame()
            filter_ms.append(statistics.median(times))
    taken = (engine.stats().taken - taken0) if engine is not None else 0
    updates = sum(i.updates for i in app.items) - updates0
    live = sum(1 for i in app.items if i.status.value == "live")
    app_items = list(app.items)
    info = {"gl": _gl_info(), "screen": _x_depth()}
    if args.shot:
        app.screenshot(args.shot)
    app.close()
    if engine is not None:
        engine.stop()
    intervals = [b - a for a, b in itertools.pairwise(starts)]
    out = {
        "rendered": len(starts),
        "totals": totals,
        "works": works,
        "intervals": intervals,
        "elapsed": elapsed,
        "cpu": cpu,
        "taken": taken,
        "updates": updates,
        "live": live,
        "widgets": len(app_items),
        "ready_s": ready_s,
        "tree": app.tree.model.total if args.tree else None,
        "filter_ms": filter_ms,
        **info,
    }
    print(json.dumps(out), flush=True)


def _pct(values: list[float], q: float) -> float:
    """Return the q-quantile of `values` (nearest rank); NaN when there are none."""
    ordered = sorted(v for v in values if not math.isnan(v))
    if not ordered:
        return math.nan
    return ordered[min(len(ordered) - 1, int(q * len(ordered)))]


def _role(role: str, *options: object) -> subprocess.Popen[str]:
    """Start this benchmark as a child in `role` with `options` (its output piped)."""
    cmd = [sys.executable, "-m", "benchmarks.bench_ui", "--role", role, *map(str, options)]
    return subprocess.Popen(cmd, cwd=_ROOT, stdout=subprocess.PIPE, text=True)


def _measure(
    source: str,
    args: argparse.Namespace,
    *,
    vsync: bool,
    shot: str = "",
    loop: str = "frames",
    code: str = "",
) -> dict[str, Any]:
    """Run one UI child (and a publisher for the live source); return its frame statistics."""
    pub = None
    if source == "engine":
        duration = args.warmup + args.duration + 8
        pub = _role("publisher", "--topics", args.topics, "--rate", args.rate, "--duration", duration)
        time.sleep(1.0)
    elif source in ("crowd", "tree"):
        pub = _role(
            "crowd",
            "--crowd",
            args.crowd,
            "--crowd-names",
            args.crowd_names,
            "--crowd-rate",
            args.crowd_rate,
            "--duration",
            args.warmup + args.duration + 90,
        )
        assert pub.stdout is not None
        pub.stdout.readline()  # "up": every publisher exists
    robots = _fleet(args) if source == "fleet" else []
    cmd = [
        sys.executable,
        "-m",
        "benchmarks.bench_ui",
        "--role",
        "ui",
        "--loop",
        loop,
        "--code",
        code,
        "--fps",
        str(args.fps if loop == "run" else 0),
        "--data-fps",
        str(args.data_fps),
        "--source",
        source,
        "--topics",
        str(args.topics),
        "--rate",
        str(args.rate),
        "--replay-minutes",
        str(args.replay_minutes),
        "--width",
        str(args.width),
        "--height",
        str(args.height),
        "--duration",
        str(args.duration),
        "--warmup",
        str(args.warmup),
        "--shot",
        shot,
        "--fleet-tags",
        str(args.fleet_tags),
        "--crowd",
        str(args.crowd),
    ]
    if vsync:
        cmd.append("--vsync")
    if source == "tree":
        cmd.append("--tree")
    try:
        ui = subprocess.run(
            cmd,
            cwd=_ROOT,
            capture_output=True,
            text=True,
            timeout=args.warmup + args.duration + 120,
            check=False,
        )
    finally:
        for proc in [pub, *robots]:
            if proc is not None:
                proc.kill()
                proc.wait()
    if ui.returncode != 0:
        raise RuntimeError(f"ui child failed:\n{ui.stderr}")
    data = json.loads(ui.stdout.strip().splitlines()[-1])
    filters = data.get("filter_ms") or []
    totals = [t * 1000 for t in data["totals"]]
    works = [t * 1000 for t in data["works"]]
    renders = [t - w for t, w in zip(totals, works, strict=True)]
    intervals = [t * 1000 for t in data["intervals"]]
    return {
        "frames": data["rendered"],
        "fps": data["rendered"] / data["elapsed"],
        "p50": _pct(totals, 0.50),
        "p95": _pct(totals, 0.95),
        "p99": _pct(totals, 0.99),
        "work50": _pct(works, 0.50),
        "work95": _pct(works, 0.95),
        "render50": _pct(renders, 0.50),
        "render95": _pct(renders, 0.95),
        "int50": _pct(intervals, 0.50),
        "int95": _pct(intervals, 0.95),
        "int99": _pct(intervals, 0.99),
        "cpu": 100 * data["cpu"] / data["elapsed"],
        "cpu_ms": 1000 * data["cpu"] / max(1, len(totals)),
        "msgs": data["taken"] / data["elapsed"],
        "ups": data["updates"] / data["elapsed"],
        "live": data["live"],
        "widgets": data.get("widgets", math.nan),
        "ready_s": data.get("ready_s", math.nan),
        "filter": max(filters) if filters else math.nan,
        "tree": data.get("tree") or 0,
        "gl": data["gl"],
        "screen": data["screen"],
    }


def _fleet(args: argparse.Namespace) -> list[subprocess.Popen[str]]:
    """Start the two robots of the fleet rows; return once both have logged every tag."""
    robots = []
    for namespace in ("robot1", "robot2"):
        options = [
            "--subsystems",
            str(max(1, args.fleet_tags // 20)),
            "--tags",
            "20",
            "--rate",
            str(args.fleet_rate),
        ]
        proc = subprocess.Popen(
            [sys.executable, "-m", "benchmarks._fleet", *options],
            cwd=_ROOT,
            stdout=subprocess.PIPE,
            text=True,
            env={**os.environ, "DBGLOG_NAMESPACE": namespace},
        )
        assert proc.stdout is not None
        assert proc.stdout.readline().strip() == "publishing", f"the {namespace} process did not start"
        robots.append(proc)
    return robots


def _fmt(value: float, spec: str = ".1f") -> str:
    return "n/a" if math.isnan(value) else format(value, spec)


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark (or one of its child roles)."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0] if __doc__ else None)
    parser.add_argument("--role", choices=("main", "publisher", "crowd", "ui"), default="main")
    parser.add_argument(
        "--source",
        choices=("empty", "static", "engine", "replay", "crowd", "fleet", "tree"),
        default="engine",
    )
    parser.add_argument("--width", type=int, default=1440)
    parser.add_argument("--height", type=int, default=900)
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--rate", type=float, default=100.0, help="messages per second per topic")
    parser.add_argument(
        "--crowd", type=int, default=300, help="topics on the graph beside the crowd-run row (default 300)"
    )
    parser.add_argument("--fleet-tags", type=int, default=300, help="tags of each robot of the fleet rows")
    parser.add_argument("--fleet-rate", type=float, default=10.0, help="Hz of each tag of the fleet rows")
    parser.add_argument(
        "--crowd-names",
        choices=("plain", "robots"),
        default="plain",
        help="the crowd's topics: /bench/crowd/tN, or dbglog tags of 4 robots in groups (for the tree rows)",
    )
    parser.add_argument(
        "--crowd-rate",
        type=float,
        default=0.0,
        help="Hz of each crowd topic (default 0: the crowd sends nothing)",
    )
    parser.add_argument("--tree", action="store_true", help="(ui role) show the tag tree")
    parser.add_argument("--duration", type=float, default=8.0, help="measured seconds per repeat")
    parser.add_argument("--warmup", type=float, default=3.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--vsync", action="store_true", help="(ui role) keep vsync on")
    parser.add_argument(
        "--replay-minutes", type=int, default=10, help="minutes of history of the replay rows (default 10)"
    )
    parser.add_argument(
        "--scenarios",
        default="empty,static,replay,engine,engine-vsync,empty-run,crowd-run,static-run,replay-run,engine-run",
        help="comma-separated subset of empty, static, replay, engine, engine-vsync (frames rendered back to "
        "back) and empty-run, crowd-run, tree-run, static-run, replay-run, engine-run (the viewer's own "
        "loop, as `dbglog view` runs it)",
    )
    parser.add_argument("--fps", type=float, default=60.0, help="frame cap of the -run rows (default 60)")
    parser.add_argument(
        "--data-fps", type=float, default=20.0, help="data redraw cap of the -run rows (default 20)"
    )
    parser.add_argument(
        "--compare",
        default="",
        metavar="TREE",
        help="also run the -run rows with the dbglog package of this checkout (e.g. a worktree of HEAD~1; it "
        "must take the --fps and --data-fps caps)",
    )
    parser.add_argument("--loop", choices=("frames", "run"), default="frames", help=argparse.SUPPRESS)
    parser.add_argument("--code", default="", help=argparse.SUPPRESS)
    parser.add_argument("--shot", default="", help="write a PNG of the live dashboard at the end")
    args = parser.parse_args(argv)
    local_ros_env()
    if args.role == "publisher":
        _publisher(args)
        return 0
    if args.role == "crowd":
        _crowd(args)
        return 0
    if args.role == "ui":
        _ui(args)
        return 0
    labels = {
        "empty": ("empty", False, "empty window, vsync off (GL stack fixed cost)"),
        "static": ("static", False, "20 widgets idle, vsync off (drawing only)"),
        "replay": ("replay", False, "20 widgets paused in a replay's history, vsync off"),
        "engine": ("engine", False, "20 widgets live: 50 topics x 100 Hz, vsync off"),
        "engine-vsync": ("engine", True, "20 widgets live, vsync on (for reference)"),
        "empty-run": ("empty", False, "empty dashboard, nothing changing"),
        "crowd-run": ("crowd", False, f"empty dashboard beside a {args.crowd}-topic graph, nothing changing"),
        "tree-run": ("tree", False, f"the same with the tag tree shown ({args.crowd} topics in it)"),
        "static-run": ("static", False, "20 widgets, nothing changing"),
        "replay-run": ("replay", False, "20 widgets paused in a replay's history, nothing changing"),
        "engine-run": ("engine", False, "20 widgets live: 50 topics x 100 Hz"),
        "fleet": ("fleet", False, f"automatic dashboard, 2 robots x {args.fleet_tags} tags, vsync off"),
        "fleet-run": ("fleet", False, f"automatic dashboard, 2 robots x {args.fleet_tags} tags"),
    }
    chosen = [s.strip() for s in args.scenarios.split(",") if s.strip()]
    unknown = [s for s in chosen if s not in labels]
    if unknown:
        parser.error(f"unknown scenario(s) {', '.join(unknown)}; choose from {', '.join(labels)}")
    load_before = os.getloadavg()
    rows = []
    run_rows = []
    notes: list[str] = []
    env_line = ""
    for name in chosen:
        source, vsync, label = labels[name]
        loop = "run" if name.endswith("-run") else "frames"
        codes = [""] + ([args.compare] if args.compare and (loop == "run" or source == "fleet") else [])
        for code in codes:
            runs = [
                _measure(
                    source,
                    args,
                    vsync=vsync,
                    shot=args.shot if (name == "engine" and r == args.repeats - 1) else "",
                    loop=loop,
                    code=code,
                )
                for r in range(args.repeats)
            ]
            env_line = f"GL: {runs[0]['gl']}; X screen {runs[0]['screen']}"
            med = {k: statistics.median(r[k] for r in runs) for k in runs[0] if k not in ("gl", "screen")}
            if source == "fleet":
                label = f"{labels[name][2]} ({code or 'this checkout'})"
                notes.append(
                    f"{label}: {med['widgets']:.0f} widgets, every one live "
                    f"{_fmt(med['ready_s'])} s after the dashboard started (median of {args.repeats})"
                )
            if loop == "run":
                run_rows.append(
                    [
                        label,
                        code or "this checkout",
                        f"{med['fps']:.1f}",
                        f"{med['cpu']:.1f}%",
                        _fmt(med["cpu_ms"]),
                        f"{_fmt(med['p50'])} / {_fmt(med['p95'])}",
                        f"{med['msgs']:.0f}",
                        f"{med['live']:.0f}",
                        f"{med['tree']:.0f} / {_fmt(med['filter'])}" if source == "tree" else "",
                    ]
                )
                continue
            rows.append(
                [
                    f"{label} [{code}]" if code else label,
                    f"{med['frames']:.0f}",
                    _fmt(med["p50"]),
                    _fmt(med["p95"]),
                    _fmt(med["p99"]),
                    f"{_fmt(med['work50'])} / {_fmt(med['work95'])}",
                    f"{_fmt(med['render50'])} / {_fmt(med['render95'])}",
                    f"{_fmt(med['int50'])} / {_fmt(med['int95'])} / {_fmt(med['int99'])}",
                    f"{med['fps']:.0f}",
                    f"{med['cpu']:.0f}% / {med['cpu_ms']:.1f}",
                    f"{med['msgs']:.0f}",
                    f"{med['ups']:.0f}",
                    f"{med['live']:.0f}",
                ]
            )
    load_after = os.getloadavg()
    if run_rows:
        print_table(
            f"Viewer process CPU as `dbglog view` runs, {args.width}x{args.height}, caps {args.fps:g} fps, "
            f"data {args.data_fps:g} fps "
            f"(median of {args.repeats} x {args.duration:g} s)",
            [
                "dashboard",
                "viewer code",
                "frames/s",
                "CPU, % of one core",
                "CPU ms per frame",
                "frame production p50 / p95 ms",
                "engine msgs/s",
                "widgets live",
                "tree topics / slowest filter ms",
            ],
            run_rows,
        )
    if rows:
        print_table(
            f"Viewer frame time at {args.width}x{args.height}, {args.topics} topics "
            f"(median of {args.repeats} x {args.duration:g} s)",
            [
                "scenario",
                "frames",
                "production p50 ms",
                "p95 ms",
                "p99 ms",
                "app work p50 / p95",
                "render p50 / p95",
                "interval p50 / p95 / p99 ms",
                "fps",
                "UI process CPU / ms per frame",
                "engine msgs/s",
                "widget updates/s",
                "widgets live",
            ],
            rows,
        )
    for note in notes:
        print(f"\n{note}")
    env = {
        k: os.environ.get(k, "unset") for k in ("LIBGL_ALWAYS_SOFTWARE", "GALLIUM_DRIVER", "LP_NUM_THREADS")
    }
    print(
        f"\n{env_line}; {', '.join(f'{k}={v}' for k, v in env.items())}; {os.cpu_count()} CPUs; "
        f"load average {load_before[0]:.2f} before, {load_after[0]:.2f} after.\n"
        "Production = ViewerApp.frame() (input, snapshots, widget updates, render_dearpygui_frame); "
        "app work = the part before render_dearpygui_frame; interval = start to start of consecutive frames; "
        "UI process CPU counts every thread of the viewer process (Mesa's rasterizer threads, and the "
        "engine's ingest thread in the live rows) and is the figure least moved by other load."
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
