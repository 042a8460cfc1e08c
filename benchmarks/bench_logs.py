"""Benchmark "logs as data": the Log console's store, proposing a pattern, previewing it over 100,000 lines.

Run: ``.venv/bin/python -m benchmarks.bench_logs`` (``--quick`` for fewer repeats and a 10 s flood;
``--seconds 60`` is the issue's flood). Times are medians of repeats (wall clock, the machine's load
included). Two calibration figures come first so that runs on different machines compare: an empty CPython
loop and one call into the google-re2 binding. The output is Markdown tables.

The flood: five child processes, one rclpy node each, log 20,000 lines/s in all through the real /rosout
(rcutils' logging call, as a node's logger makes it); the viewer's engine takes them into its `LogStore`,
whose worker decodes them, while a thread takes the answers 20 times a second as the console does; every
sequence number must arrive.

``--viewer`` (under a display) times the real viewer's frames during that flood in three arms, rotated each
round: a dashboard without the console; the same while another process takes and decodes /rosout (what
receiving the flood costs this machine with no console in the viewer); the dashboard with the console.
``--before DIR`` adds a fourth arm, in the same rotation: the console on the dbglog of source tree DIR (the
viewer child runs this script with ``PYTHONPATH=DIR``). Besides the frame times, each viewer child reports
the UI thread's CPU time per frame (``time.thread_time``), the part of it spent in the console's own
methods (the Log widget's ``update``, ``redraw_key`` and ``status``, and the host's timeline ``marks``) and
the part spent drawing the timeline bar (which draws the console's marks), how a frame's wall time splits
into the UI thread's CPU, its wait for a CPU (``/proc/thread-self/schedstat``) and the rest, blocked (the
GIL, the GPU, X), and the CPU of the viewer's other threads (the engine's, the log store's worker).
"""

from __future__ import annotations

import argparse
import gc
import itertools
import math
import os
import random
import re
import select
import statistics
import subprocess
import sys
import threading
import time
import tracemalloc
from collections.abc import Callable
from pathlib import Path

import numpy as np
import re2

from benchmarks._common import local_ros_env, print_table, spawn_flood
from dbglog._regex._propose import MAX_LINE, Proposal, match_joined, preview, propose
from dbglog.viewer._data._logstore import LogFilter, LogStore

N_LINES = 100_000
_NODES = ("planner_local", "planner_global", "driver", "power_monitor", "camera")


def _median_ms(fn: Callable[[], object], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        samples.append((time.perf_counter() - start) * 1e3)
    return statistics.median(samples)


def _calibration(repeats: int) -> list[list[object]]:
    def loop() -> None:
        for _ in range(1_000_000):
            pass

    rx = re2.compile("x")
    match = rx._regexp.Match
    anchor = re2._Anchor.UNANCHORED
    text = b"abc"

    def calls() -> None:
        for _ in range(100_000):
            match(anchor, text, 0, 3)

    return [
        ["empty CPython loop, 1,000,000 iterations", f"{_median_ms(loop, repeats):.1f} ms"],
        ["google-re2 binding, one Match call (no text)", f"{_median_ms(calls, repeats) / 100:.2f} µs"],
    ]


def _lines(match_every: int) -> list[str]:
    """Stored lines: one in `match_every` is "that kind of line", the others are other lines."""
    return [
        f"distance to wall: {i * 0.01:.2f} m (angle {-(i % 90)} deg)"
        if i % match_every == 0
        else f"tick {i}: state=RUNNING load {i % 7}.{i % 10} queue={i % 13}"
        for i in range(N_LINES)
    ]


def _propose_rows(repeats: int) -> list[list[object]]:
    short = "distance to wall: 0.42 m (angle -12.5 deg)"
    array = "ranges: [" + ", ".join(f"{i * 0.013:.3f}" for i in range(600)) + "]"
    big = " ".join(f"key{i}={i * 0.5}" for i in range(10_000))
    rows: list[list[object]] = []
    for name, line, index in (
        ("typical line (42 chars, 2 numbers), 2nd number", short, 1),
        (f"array dump ({len(array):,} chars, 600 numbers), 300th", array, 299),
        (f"100 kB line ({len(big):,} chars; read to {MAX_LINE} bytes), 200th", big, 199),
    ):

        def once(line: str = line, index: int = index) -> object:
            return propose(line, index)

        ms = _median_ms(once, repeats * 20)
        rows.append([name, f"{ms:.2f}"])
    return rows


def _preview_rows(repeats: int) -> list[list[object]]:
    rows: list[list[object]] = []
    for label, every in (("1 %", 100), ("10 %", 10), ("100 %", 1)):
        lines = _lines(every)
        proposal = propose(lines[0], 0)
        count = preview(proposal, lines)[0]
        store, starts = _columnar_messages(lines)

        def from_list_run(lines: list[str] = lines, proposal: Proposal = proposal) -> object:
            return preview(proposal, lines)

        def from_store_run(
            proposal: Proposal = proposal, store: bytes = store, starts: np.ndarray = starts
        ) -> object:
            return match_joined(proposal, store, starts)

        from_list = _median_ms(from_list_run, repeats)
        from_store = _median_ms(from_store_run, repeats)
        rows.append([label, f"{count:,}", f"{from_list:.0f}", f"{from_store:.0f}"])
    return rows


def _columnar_messages(lines: list[str]) -> tuple[bytes, np.ndarray]:
    data = ("\x00" + "\x01\x00".join(lines) + "\x01").encode()
    starts = np.flatnonzero(np.frombuffer(data, dtype=np.uint8) == 0)
    return data, starts


def _memory_rows() -> list[list[object]]:
    lines = _lines(10)
    n = len(lines)
    stamps = [1_795_000_000.0 + i * 1e-3 for i in range(n)]
    levels = [(10, 20, 20, 30, 40)[i % 5] for i in range(n)]

    def tuples() -> object:
        # As a callback would store them: a fresh node-name str per line (as deserialized), the message str.
        return [(stamps[i], levels[i], "".join(_NODES[i % 5]), "".join(lines[i])) for i in range(n)]

    def columnar() -> object:
        data, starts = _columnar_messages(lines)
        table = {name: k for k, name in enumerate(_NODES)}
        return (
            np.asarray(stamps, dtype=np.float64),
            np.asarray(levels, dtype=np.uint8),
            np.asarray([table[_NODES[i % 5]] for i in range(n)], dtype=np.uint16),
            starts.astype(np.int64),
            data,
        )

    rows: list[list[object]] = []
    text_bytes = sum(len(s) for s in lines) / n
    for name, build in (
        ("list of (stamp, level, node, message) tuples", tuples),
        (
            "columnar: float64 stamps, uint8 levels, uint16 node ids, int64 offsets, one UTF-8 buffer",
            columnar,
        ),
    ):
        gc.collect()
        tracemalloc.start()
        kept = build()
        size, _peak = tracemalloc.get_traced_memory()
        tracemalloc.stop()
        del kept
        rows.append([name, f"{size / n:.0f}"])
    rows.append(["(the message text itself, average)", f"{text_bytes:.0f}"])
    return rows


# --- the Log console's store -----------------------------------------------------------------------------


def _store(lines: list[str]) -> LogStore:
    """A store holding `lines` from five nodes, a millisecond apart, with a realistic mix of levels."""
    store = LogStore(capacity=len(lines))
    n = len(lines)
    store.append(
        1_795_000_000.0 + np.arange(n) * 1e-3,
        [(10, 20, 20, 30, 40)[i % 5] for i in range(n)],
        [_NODES[i % 5] for i in range(n)],
        lines,
    )
    return store


_FILTERS: tuple[tuple[str, LogFilter], ...] = (
    ("minimum level warn", LogFilter(min_level=30)),
    ("one node hidden", LogFilter(hidden=frozenset({"driver"}))),
    ("text search 'wall' (10 % of lines)", LogFilter(text="wall")),
    ("text search 'e' (every line)", LogFilter(text="e")),
    ("include 'RUNNING' (plain text, 90 %)", LogFilter(include="RUNNING")),
    ("include 'wall|queue=12' (plain alternatives)", LogFilter(include="wall|queue=12")),
    ("include regex 'queue=1[02]$' (alternatives)", LogFilter(include=r"queue=1[02]$")),
    ("include regex '^distance.*deg\\)$' (every 10th line)", LogFilter(include=r"^distance.*deg\)$")),
    ("include regex 'queue=[0-5]$' (46 %, scattered)", LogFilter(include=r"queue=[0-5]$")),
    ("include regex 'load [0-3]\\.' (51 %, scattered)", LogFilter(include=r"load [0-3]\.")),
    ("exclude 'tick' (plain text)", LogFilter(exclude="tick")),
)


def _filter_rows(repeats: int) -> list[list[object]]:
    """Changing the filter over 100,000 stored lines: the whole answer, and the console's first answer."""
    store = _store(_lines(10))
    rows: list[list[object]] = []
    for name, filt in _FILTERS:

        def whole(filt: LogFilter = filt) -> object:
            store._own.sel = None  # a filter changed: nothing about it cached
            store._masks.clear()
            return store.select(filt)

        def first(filt: LogFilter = filt) -> object:
            store._own.sel = None
            store._masks.clear()
            return store.select_within(filt, budget=0.03)

        shown = len(store.select(filt))
        rows.append(
            [name, f"{shown:,}", f"{_median_ms(whole, repeats):.1f}", f"{_median_ms(first, repeats):.1f}"]
        )
    return rows


def _store_rows(repeats: int) -> list[list[object]]:
    """Decoding Log messages into the store, a new line's cost per filter, and the store's preview."""
    from rcl_interfaces.msg import Log
    from rclpy.serialization import serialize_message

    n = 20_000
    payloads = []
    for i in range(n):
        msg = Log()
        msg.level, msg.name = 20, _NODES[i % 5]
        msg.msg = f"distance to wall: {i * 0.01:.2f} m (angle {-(i % 90)} deg)"
        msg.file, msg.function, msg.line = "/ws/src/planner/planner.cpp", "on_timer", 120 + i % 3
        payloads.append(serialize_message(msg))
    times = 1_795_000_000.0 + np.arange(n) * 1e-3

    def decode() -> object:
        store = LogStore(capacity=n)
        store.push("rcl_interfaces/msg/Log", times, payloads)
        return store.sync()

    rows: list[list[object]] = [
        [
            "decode serialized Log messages into the store (push + sync)",
            f"{_median_ms(decode, repeats) / n * 1e3:.2f} µs/line",
        ]
    ]
    store = _store(_lines(10))
    filt = LogFilter(min_level=20, include=r"queue=[0-5]$", text="state")
    store.select(filt)
    batch = [f"tick {i}: state=RUNNING load {i % 7}.{i % 10} queue={i % 13}" for i in range(1000)]
    start = [store.span() or (0.0, 0.0)][0][1]

    def grow() -> object:
        nonlocal start
        start += 1.0
        store.append(start + np.arange(1000) * 1e-4, [20] * 1000, ["driver"] * 1000, batch)
        return store.select(filt)

    rows.append(
        [
            "1,000 new lines with a level + regex + text filter cached (append + select)",
            f"{_median_ms(grow, repeats * 3):.1f} ms",
        ]
    )
    for label, every in (("1 %", 100), ("10 %", 10), ("100 %", 1)):
        lines = _lines(every)
        proposal = propose(lines[0], 0)
        kept = _store(lines)

        def run(proposal: Proposal = proposal, kept: LogStore = kept) -> object:
            return kept.preview(proposal, node="*")

        rows.append(
            [
                f"LogStore.preview over 100,000 lines, {label} of that kind",
                f"{_median_ms(run, repeats):.0f} ms",
            ]
        )
    return rows


def _store_memory_rows() -> list[list[object]]:
    """Bytes per stored line, all-in (tracemalloc), and what the store counts itself."""
    lines = _lines(10)
    gc.collect()
    tracemalloc.start()
    store = _store(lines)
    store.select(LogFilter(text="wall"))  # one filter cached, as a console has
    size, _peak = tracemalloc.get_traced_memory()
    tracemalloc.stop()
    text = sum(len(s) for s in lines) / len(lines)
    return [
        ["LogStore, 100,000 lines, one text filter cached (tracemalloc)", f"{size / len(lines):.0f}"],
        ["the same, as the store counts it (bytes_used)", f"{store.bytes_used() / len(lines):.0f}"],
        ["(the message text itself, average)", f"{text:.0f}"],
    ]


# --- the flood: real /rosout into the engine's store --------------------------------------------------------

_SPAN = 10_000_000
"""Each publisher's sequence numbers start at its index times this."""
_SEQ = re.compile(r"seq=(\d+) ")


def _publisher_main(rate: float, count: int, offset: int) -> int:
    """Child process: one node logging `count` lines at `rate`/s through rcutils (its /rosout), when told."""
    import rclpy
    from rclpy.context import Context
    from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy
    from rclpy.node import Node

    context = Context()
    rclpy.init(context=context)
    node = Node(f"flood_{offset // _SPAN}", context=context, start_parameter_services=False)
    name = node.get_logger().name
    log = _rclpy.rclpy_logging_rcutils_log
    while not select.select([sys.stdin], [], [], 0.1)[0]:
        log(20, name, "flood probe", "flood", __file__, 1)
    if sys.stdin.readline().strip() == "quiet":  # no more probes: wait for the start
        sys.stdin.readline()
    start = time.perf_counter()
    sent = 0
    while sent < count:
        due = min(count, int((time.perf_counter() - start) * rate) + 1)
        while sent < due:
            level = 40 if sent % 97 == 0 else 30 if sent % 31 == 0 else 20
            log(
                level,
                name,
                f"seq={offset + sent} planner: path cost {sent % 1000 * 0.01:.2f} ok",
                "plan",
                __file__,
                7,
            )
            sent += 1
        if sent < count:
            time.sleep(0.0005)
    print(f"sent {sent} {time.perf_counter() - start:.4f}", flush=True)
    sys.stdin.readline()  # keep the rosout writer until the parent has counted
    node.destroy_node()
    rclpy.shutdown(context=context)
    return 0


def bench_flood(rate: float, seconds: float, publishers: int = 5) -> list[list[object]]:
    """`publishers` nodes log `rate` lines/s in all for `seconds`; count what reaches the console's store."""
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding

    per_pub = int(rate * seconds / publishers)
    capacity = per_pub * publishers + 10_000
    with Engine(node_name="bench_logs_engine") as engine:
        engine.bind(Binding("/rosout"))
        store = engine.log_store("/rosout")
        store.capacity = capacity
        stop = threading.Event()
        syncs: list[float] = []
        reader = store.reader()
        reader.ask(LogFilter())

        def console() -> None:  # the UI thread's part: take the newest answer and its last rows, 20 a second
            while not stop.is_set():
                t0 = time.perf_counter()
                store.step()
                shown = reader.shown()
                if shown is not None:
                    store.window(shown, shown.ids[-40:])
                syncs.append(time.perf_counter() - t0)
                stop.wait(0.05)

        ui = threading.Thread(target=console, daemon=True)
        ui.start()
        pubs = spawn_flood("benchmarks.bench_logs", publishers, rate, per_pub, _SPAN)
        try:
            deadline = time.monotonic() + 60
            while (
                len(store.select(LogFilter(text="flood probe", hidden=frozenset()))) == 0
                or len(set(store.nodes()) & {f"flood_{i}" for i in range(publishers)}) < publishers
            ):
                if time.monotonic() > deadline:
                    raise RuntimeError("the publishers never reached the engine")
                time.sleep(0.1)
            for p in pubs:
                assert p.stdin is not None
                p.stdin.write("go\n")
                p.stdin.flush()
            sent, elapsed = 0, 0.0
            for p in pubs:
                assert p.stdout is not None
                _word, n, secs = p.stdout.readline().split()
                sent, elapsed = sent + int(n), max(elapsed, float(secs))
            last, quiet = -1, time.monotonic()
            while time.monotonic() - quiet < 3.0:  # until nothing new arrived for 3 s
                now = store.added + store.pending
                if now != last:
                    last, quiet = now, time.monotonic()
                time.sleep(0.1)
            stop.set()
            ui.join(5)
            store.sync()
            ids = store.select(LogFilter(include="^seq="))
            seen = {int(m.group(1)) for m in map(_SEQ.match, store.messages(ids)) if m is not None}
        finally:
            stop.set()
            for p in pubs:
                if p.stdin is not None and p.poll() is None:
                    p.stdin.write("exit\n")
                    p.stdin.close()
            for p in pubs:
                p.wait(timeout=30)
                if p.stdout is not None:
                    p.stdout.close()
        taken = engine.stats().per_topic.get("/rosout", 0)
    lost = sent - len(seen)
    sync_ms = sorted(syncs)
    p95 = sync_ms[int(0.95 * (len(sync_ms) - 1))] * 1e3 if sync_ms else 0.0
    return [
        [
            str(publishers),
            f"{rate:,.0f}",
            f"{seconds:g}",
            f"{sent / elapsed:,.0f}",
            f"{sent:,}",
            f"{len(seen):,}",
            f"{lost:,} ({100 * lost / max(sent, 1):.3f} %)",
            f"{taken:,}",
            f"{p95:.1f}",
            str(store.evicted),
        ]
    ]


# --- the viewer: frame times with and without the console during the flood ---------------------------------

_DATA_PREFIX = "/bench/ui/t"
"""The topics of bench_ui's publisher (the dashboard's live plots and dials)."""
_DATA_TOPICS = 10
_DATA_RATE = 50.0


def _dashboard(console: bool) -> dict[str, object]:
    """The dashboard measured: 2 plots of 5 live series, 4 dials; with `console`, a Log widget on /rosout."""

    def binding(topic: str, field: str = "data") -> dict[str, str]:
        return {"topic": topic, "field": field, "regex": ""}

    widgets: list[dict[str, object]] = [
        {
            "type": "plot",
            "name": f"plot {k}",
            "x": 20 + 560 * k,
            "y": 380,
            "width": 540,
            "height": 300,
            "bindings": [binding(f"{_DATA_PREFIX}{5 * k + i}") for i in range(5)],
        }
        for k in range(2)
    ]
    widgets += [
        {
            "type": "dial",
            "name": f"dial {k}",
            "x": 20 + 280 * k,
            "y": 700,
            "width": 260,
            "height": 160,
            "bindings": [binding(f"{_DATA_PREFIX}{k}")],
        }
        for k in range(4)
    ]
    if console:
        widgets.append(
            {
                "type": "log",
                "name": "/rosout",
                "x": 20,
                "y": 20,
                "width": 1120,
                "height": 340,
                "bindings": [binding("/rosout", "")],
            }
        )
    return {
        "format": "dbglog-dashboard",
        "version": 1,
        "grid": {"size": 20, "snap": True},
        "widgets": widgets,
    }


class _CpuMeter:
    """The UI thread's CPU time, per frame and in the console's own methods (`time.thread_time`), and the
    CPU of the viewer's other threads by name: set up by the viewer child, around the code it measures.

    The console's methods are the Log widget's `update`, `redraw_key` and `status` and the host's `marks`
    (the timeline's marks come from the console's store): the same names in the code before the worker,
    so ``--before`` measures that code alike.
    """

    def __init__(self) -> None:
        self.spent = {"console": 0.0, "bar": 0.0}
        """CPU seconds the UI thread spent so far in the console's methods and in drawing the timeline bar."""
        self.frames: list[tuple[float, float, float]] = []
        """(UI thread CPU, console, bar) at the end of each frame's work."""
        self.inside: list[tuple[float, float, float]] = []
        """Each frame's (wall, UI thread CPU, waiting for a CPU) seconds, from the start of its work to the
        end of its render: for the rest of the wall time the thread was blocked (the GIL, a lock, GPU, X)."""
        self.on = False
        self._start: tuple[float, float, float] | None = None
        self._schedstat = os.open("/proc/thread-self/schedstat", os.O_RDONLY)

    def _waited(self) -> float:
        """Seconds this thread has been runnable but not running (the kernel's schedstat)."""
        return int(os.pread(self._schedstat, 128, 0).split()[1]) * 1e-9

    def frame_start(self) -> None:
        """Note the wall clock, the UI thread's CPU and its wait for a CPU as a frame's work starts."""
        self._start = (time.perf_counter(), time.thread_time(), self._waited())

    def rendered(self) -> None:
        """Note how the frame begun at `frame_start` spent its wall time, once it is rendered."""
        if self.on and self._start is not None:
            wall, cpu, waited = self._start
            self.inside.append(
                (time.perf_counter() - wall, time.thread_time() - cpu, self._waited() - waited)
            )
        self._start = None

    def wrap(self, cls: type, name: str, what: str = "console") -> None:
        """Count the UI thread's CPU time in ``cls.name`` as `what` (not nested calls twice)."""
        inner = getattr(cls, name)
        spent = self.spent
        depth = [0]

        def counted(*args: object, **kwargs: object) -> object:
            if depth[0]:
                return inner(*args, **kwargs)
            depth[0] += 1
            t0 = time.thread_time()
            try:
                return inner(*args, **kwargs)
            finally:
                depth[0] -= 1
                spent[what] += time.thread_time() - t0

        setattr(cls, name, counted)

    def frame_end(self) -> None:
        """Note the UI thread's CPU and the console's share of it at the end of a frame's work."""
        if self.on:
            self.frames.append((time.thread_time(), self.spent["console"], self.spent["bar"]))

    @staticmethod
    def threads() -> dict[str, float]:
        """CPU seconds of the process's named threads (the engine's, the log store's worker), by name."""
        out: dict[str, float] = {}
        for t in threading.enumerate():
            if t.ident is None or not t.name.startswith("dbglog-"):
                continue
            try:
                cpu = time.clock_gettime(time.pthread_getcpuclockid(t.ident))
            except OSError:  # ended meanwhile
                continue
            out[t.name] = out.get(t.name, 0.0) + cpu
        return out


def _viewer_main(dashboard: str, seconds: float, warmup: float, nodes: int) -> int:
    """Child process: the viewer as ``dbglog view DASHBOARD`` builds it; its frame times, as JSON.

    Protocol on stdin/stdout: prints ``ready`` (warmed up; with a console, every flood node seen), waits for
    ``go``, prints ``measuring``, runs the viewer's own loop for `seconds`, waits for ``done`` (running on),
    lets the console take every waiting line, prints one JSON line.
    """
    import collections
    import json

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._document._dashboard import load_dashboard
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._host import AppHost
    from dbglog.viewer._ui._timebar import TimeBar
    from dbglog.viewer._widgets import WidgetRegistry
    from dbglog.viewer._widgets._log import LogWidget

    meter = _CpuMeter()
    for name in ("update", "redraw_key", "status"):
        meter.wrap(LogWidget, name)
    meter.wrap(AppHost, "marks")
    meter.wrap(TimeBar, "draw", "bar")  # (it draws the console's marks: one item per pixel column marked)
    try:  # a frame's work and render: the frame loop's (before it, the app's own `_work`, `_render`)
        from dbglog.viewer._ui._loop import FrameLoop

        loop: type = FrameLoop
        names = ("work", "render")
    except ImportError:
        loop, names = ViewerApp, ("_work", "_render")
    work, render = (getattr(loop, name) for name in names)

    def work_then_note(self: object) -> None:
        meter.frame_start()
        work(self)
        meter.frame_end()

    def render_then_note(self: object, now: float) -> None:
        render(self, now)
        meter.rendered()

    setattr(loop, names[0], work_then_note)
    setattr(loop, names[1], render_then_note)

    registry = WidgetRegistry.discover()
    result = load_dashboard(dashboard, registry.get)
    engine = Engine(stale_after=2.0, history_seconds=1800.0, history_bytes=512 * 2**20)  # dbglog view's
    engine.start()
    app = ViewerApp(engine, registry, width=1440, height=900, fps=60.0, data_fps=20.0)
    console = any(w.get("type") == "log" for w in json.loads(Path(dashboard).read_text())["widgets"])

    def run_until(done: Callable[[], bool], limit: float) -> None:
        deadline = time.monotonic() + limit
        while not done():
            if time.monotonic() > deadline:
                raise RuntimeError("the viewer child timed out")
            app.run(seconds=0.1)

    def line_ready() -> bool:
        return bool(select.select([sys.stdin], [], [], 0)[0])

    try:
        app.start()
        app.load(result, None)
        store = engine.log_store("/rosout") if console else None
        app.run(seconds=warmup)
        if store is not None:
            want = {f"flood_{i}" for i in range(nodes)}
            run_until(lambda: want <= set(store.nodes()), 60.0)
        print("ready", flush=True)
        run_until(line_ready, 120.0)
        sys.stdin.readline()
        added0 = store.added if store is not None else 0
        dropped0 = getattr(store, "dropped", 0)  # (a checkout from before the count: 0)
        timed = getattr(app, "loop", app)  # the frame loop keeps the frame times (before it, the app)
        timed.frame_times = collections.deque()  # (unbounded: the loop's own keeps the last 600)
        print("measuring", flush=True)
        meter.on = True
        meter.frame_end()
        threads0 = meter.threads()
        cpu0, t0 = time.process_time(), time.perf_counter()
        app.run(seconds=seconds)
        cpu, elapsed = time.process_time() - cpu0, time.perf_counter() - t0
        meter.on = False
        threads = {k: v - threads0.get(k, 0.0) for k, v in meter.threads().items()}
        totals = list(timed.frame_times)
        marks = meter.frames
        ui_cpu = [b[0] - a[0] for a, b in itertools.pairwise(marks)]
        console_cpu = [b[1] - a[1] for a, b in itertools.pairwise(marks)]
        bar_cpu = [b[2] - a[2] for a, b in itertools.pairwise(marks)]
        inside = list(meter.inside)
        run_until(line_ready, seconds + 120.0)
        sys.stdin.readline()
        out: dict[str, object] = {
            "totals": totals,
            "elapsed": elapsed,
            "cpu": cpu,
            "ui_cpu": ui_cpu,
            "console_cpu": console_cpu,
            "bar_cpu": bar_cpu,
            "inside": inside,
            "threads": threads,
        }
        if store is not None:
            last, quiet = -1, time.monotonic()
            while time.monotonic() - quiet < 2.0 or store.pending:  # every waiting line taken
                now = store.added + store.pending
                if now != last:
                    last, quiet = now, time.monotonic()
                app.run(seconds=0.1)
            ids = store.select(LogFilter(include="^seq="))
            held: dict[int, list[int]] = {}
            for m in map(_SEQ.match, store.messages(ids)):
                if m is not None:
                    seq = int(m.group(1))
                    held.setdefault(seq // _SPAN, []).append(seq)
            out |= {
                "reached": store.added - added0 - (getattr(store, "dropped", 0) - dropped0),
                "evicted": store.evicted,
                "dropped": getattr(store, "dropped", 0) - dropped0,
                "held_gaps": sum(max(s) - min(s) + 1 - len(set(s)) for s in held.values()),
                "held": sum(len(s) for s in held.values()),
                "taken": engine.stats().per_topic.get("/rosout", 0),
            }
        print(json.dumps(out), flush=True)
    finally:
        app.close()
        engine.stop()
    return 0


def _tap_main() -> int:
    """Child process: /rosout taken and decoded as the console does, outside the viewer; counts flood lines.

    The third arm of ``--viewer``: the viewer runs the dashboard without the console while this process
    receives the flood, so the table shows what receiving 20,000 lines/s costs the machine by itself.
    """
    from rcl_interfaces.msg import Log

    from dbglog._ros._cdr import read_log
    from dbglog._ros._node import PrivateNode, WaitSet, no_callback, take_batch
    from dbglog._ros._qos import LOG_DEPTH, subscription_qos

    ros = PrivateNode("bench_log_tap")
    sub = ros.node.create_subscription(
        Log,
        "/rosout",
        no_callback,
        subscription_qos(max(LOG_DEPTH, 20_000), reliable=True, transient=True),
        raw=True,
    )
    wait_set = WaitSet(ros, ros.guard())
    taken = 0
    print("ready", flush=True)
    while not select.select([sys.stdin], [], [], 0)[0]:
        if wait_set.wait([sub], 100_000_000):
            buffers, _stamps = take_batch(sub.handle.take_message, Log, True, 5_000)
            for raw in buffers:
                line = read_log(raw)
                taken += line is not None and line[2].startswith(b"seq=")  # the flood's lines, not its probes
        time.sleep(0.005)  # as the engine's minimum cycle
    print(f"taken {taken}", flush=True)
    ros.close([lambda: ros.node.destroy_subscription(sub)])
    return 0


def _expect(proc: subprocess.Popen[str], word: str) -> str:
    """Read the child's stdout up to a line starting with `word` (other lines are skipped)."""
    assert proc.stdout is not None
    while True:
        line = proc.stdout.readline()
        if not line:
            raise RuntimeError(f"the viewer child ended before {word!r} (exit {proc.wait()})")
        if line.startswith(word):
            return line


ROOT = Path(__file__).resolve().parent.parent


def _viewer_run(
    dashboard: Path,
    console: bool,
    rate: float,
    seconds: float,
    warmup: float,
    publishers: int,
    tap: bool = False,
    tree: Path = ROOT,
) -> dict[str, float]:
    """One measured run: the data publisher, the flood's nodes and a viewer child on `dashboard`.

    With `tap`, a separate process (not the viewer) receives and decodes /rosout during the flood. The
    viewer child runs this script on the dbglog of source tree `tree` (``--before``: the code before).
    """
    import json

    per_pub = int(rate * seconds / publishers)
    me = [sys.executable, "-m", "benchmarks.bench_logs"]
    data = subprocess.Popen(
        [
            *(sys.executable, "-m", "benchmarks.bench_ui", "--role", "publisher"),
            *("--topics", str(_DATA_TOPICS), "--rate", str(_DATA_RATE)),
            *("--duration", str(warmup + seconds + 240)),
        ],
        stdout=subprocess.DEVNULL,
    )
    taps = (
        [subprocess.Popen([*me, "--tap"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)]
        if tap
        else []
    )
    pubs = spawn_flood("benchmarks.bench_logs", publishers, rate, per_pub, _SPAN)
    ui = subprocess.Popen(
        [
            *(sys.executable, str(Path(__file__).resolve())),
            *("--viewer-child", str(dashboard), "--seconds", str(seconds)),
            *("--warmup", str(warmup), "--nodes", str(publishers)),
        ],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        env={**os.environ, "PYTHONPATH": str(tree)},
        cwd=tree,
    )
    assert ui.stdin is not None

    def tell(proc: subprocess.Popen[str], word: str) -> None:
        assert proc.stdin is not None
        proc.stdin.write(word + "\n")
        proc.stdin.flush()

    try:
        for t in taps:
            _expect(t, "ready")
        _expect(ui, "ready")
        for p in pubs:
            tell(p, "quiet")
        time.sleep(1.0)  # the last probes arrive before the count starts
        tell(ui, "go")
        _expect(ui, "measuring")
        load0 = os.getloadavg()[0]
        for p in pubs:
            tell(p, "go")
        sent, elapsed = 0, 0.0
        for p in pubs:
            assert p.stdout is not None
            _word, n, secs = p.stdout.readline().split()
            sent, elapsed = sent + int(n), max(elapsed, float(secs))
        load1 = os.getloadavg()[0]
        tell(ui, "done")
        out = json.loads(_expect(ui, "{"))
        for t in taps:
            time.sleep(2.0)  # the last lines arrive
            tell(t, "count")
            out["tap_taken"] = int(_expect(t, "taken").split()[1])
    finally:
        for t in taps:
            if t.poll() is None:
                t.kill()
            t.wait()
        for p in pubs:
            if p.stdin is not None and p.poll() is None:
                p.stdin.write("exit\n")
                p.stdin.close()
        for p in pubs:
            try:
                p.wait(timeout=30)
            except subprocess.TimeoutExpired:  # (after a failure: the flood may still run) keep its error
                p.kill()
                p.wait()
            if p.stdout is not None:
                p.stdout.close()
        data.kill()
        data.wait()
        if ui.poll() is None:
            ui.kill()
        ui.wait()
    totals = sorted(t * 1e3 for t in out["totals"])
    console_ms = sorted(t * 1e3 for t in out["console_cpu"])
    ui_ms = sorted(t * 1e3 for t in out["ui_cpu"])

    def pct(q: float, values: list[float] = totals) -> float:
        return values[min(len(values) - 1, int(q * len(values)))] if values else math.nan

    threads: dict[str, float] = out["threads"]
    res = {
        "frames": float(len(totals)),
        "p50": pct(0.50),
        "p95": pct(0.95),
        "p99": pct(0.99),
        "console_p50": pct(0.50, console_ms),
        "console_p95": pct(0.95, console_ms),
        "console_mean": statistics.fmean(console_ms) if console_ms else math.nan,
        "ui_p50": pct(0.50, ui_ms),
        "ui_mean": statistics.fmean(ui_ms) if ui_ms else math.nan,
        "bar_mean": 1e3 * statistics.fmean(out["bar_cpu"]) if out["bar_cpu"] else math.nan,
        **{
            key: 1e3 * statistics.fmean(f[k] for f in out["inside"]) if out["inside"] else math.nan
            for k, key in enumerate(("in_wall", "in_cpu", "in_waited"))
        },
        "worker_cpu": 100 * threads.get("dbglog-logs", 0.0) / out["elapsed"],
        "engine_cpu": 100 * threads.get("dbglog-engine", 0.0) / out["elapsed"],
        "cpu": 100 * out["cpu"] / out["elapsed"],
        "rate": sent / max(elapsed, 1e-9),
        "sent": float(sent),
        "load0": load0,
        "load1": load1,
    }
    if console:
        res |= {k: float(out[k]) for k in ("reached", "held_gaps", "held", "taken", "evicted", "dropped")}
        res["lost"] = res["sent"] - res["reached"]
    if tap:
        res["tap_taken"] = float(out["tap_taken"])
    arm = "with the console" if console else "another process takes /rosout" if tap else "without"
    if tree != ROOT:
        arm += f" ({tree})"
    print(
        f"  {arm}: p50 {res['p50']:.1f} ms, "
        f"p95 {res['p95']:.1f} ms, {res['frames']:.0f} frames, load {load0:.1f}-{load1:.1f}, "
        f"console's UI CPU {res['console_p50']:.2f} / {res['console_p95']:.2f} ms a frame (p50 / p95), "
        f"UI {res['ui_mean']:.1f}, bar {res['bar_mean']:.2f} ms a frame; in a frame {res['in_wall']:.1f} ms: "
        f"CPU {res['in_cpu']:.1f}, waiting for a CPU {res['in_waited']:.1f}, "
        f"blocked {res['in_wall'] - res['in_cpu'] - res['in_waited']:.1f}; "
        f"worker {res['worker_cpu']:.0f} %, engine {res['engine_cpu']:.0f} %"
        + (
            f", lost {res['lost']:.0f} (dropped waiting {res['dropped']:.0f}), gaps {res['held_gaps']:.0f}, "
            f"engine took {res['taken']:.0f}"
            if console
            else f", it took {res['tap_taken']:.0f}"
            if tap
            else ""
        ),
        file=sys.stderr,
        flush=True,
    )
    return res


_ARMS = ("without", "elsewhere", "with")
"""The ``--viewer`` arms: the dashboard without the console; the same while another process receives and
decodes /rosout (what the flood costs the machine with no console in the viewer); with the console; and
with ``--before DIR``, with the console on DIR's code ("before")."""

_ARM_NAMES = {
    "without": "without (the same dashboard)",
    "elsewhere": "without, /rosout taken and decoded by another process",
    "with": "with the Log console on /rosout",
    "before": "with the Log console, the code before (--before)",
}


def bench_viewer(
    rate: float,
    seconds: float,
    repeats: int,
    warmup: float = 5.0,
    publishers: int = 5,
    before: Path | None = None,
) -> tuple[list[list[object]], list[list[object]]]:
    """The viewer's frame times on one dashboard without and with a Log console on /rosout during the flood,
    and without it while another process takes /rosout (and with it on the `before` source tree); the arms
    run in a new rotation each round, `repeats` times each. Returns the table's rows and each round's rows."""
    import json
    import tempfile

    arms = (*_ARMS, "before") if before is not None else _ARMS
    runs: dict[str, list[dict[str, float]]] = {arm: [] for arm in arms}
    rounds: list[list[object]] = []
    with tempfile.TemporaryDirectory() as tmp:
        paths = {}
        for console in (False, True):
            paths[console] = Path(tmp) / f"{'with' if console else 'without'}.json"
            paths[console].write_text(json.dumps(_dashboard(console)))
        for r in range(repeats):
            k = r % len(arms)
            for arm in arms[k:] + arms[:k]:
                console = arm in ("with", "before")
                tree = before if arm == "before" and before is not None else ROOT
                one = _viewer_run(
                    paths[console],
                    console,
                    rate,
                    seconds,
                    warmup,
                    publishers,
                    tap=arm == "elsewhere",
                    tree=tree,
                )
                runs[arm].append(one)
            last = {arm: runs[arm][-1] for arm in arms}
            base = last["without"]["p95"]
            rounds.append(
                [
                    str(r + 1),
                    *(f"{last[arm]['p50']:.1f} / {last[arm]['p95']:.1f}" for arm in arms),
                    *(f"{100 * (last[arm]['p95'] / base - 1):+.0f} %" for arm in arms[1:]),
                    *(f"{last[arm]['lost']:,.0f}" for arm in arms if arm in ("with", "before")),
                    f"{min(x['load0'] for x in last.values()):.1f}-"
                    f"{max(x['load1'] for x in last.values()):.1f}",
                ]
            )
    rows: list[list[object]] = []
    base95 = statistics.median(x["p95"] for x in runs["without"])
    for arm in arms:
        got = runs[arm]
        sent = sum(x["sent"] for x in got)

        def med(key: str, got: list[dict[str, float]] = got) -> float:
            return statistics.median(x[key] for x in got)

        loads = [x[k] for x in got for k in ("load0", "load1")]
        console = arm in ("with", "before")
        rows.append(
            [
                _ARM_NAMES[arm],
                f"{med('frames') / seconds:.1f}",
                f"{med('p50'):.1f}",
                f"{med('p95'):.1f}",
                f"{med('p99'):.1f}",
                "" if arm == "without" else f"{100 * (med('p95') / base95 - 1):+.1f} %",
                f"{med('console_mean'):.2f} / {med('console_p50'):.2f} / {med('console_p95'):.2f}"
                if console
                else "-",
                f"{med('ui_mean'):.1f}",
                f"{med('bar_mean'):.2f}",
                f"{med('in_wall'):.1f} = {med('in_cpu'):.1f} + {med('in_waited'):.1f} + "
                f"{med('in_wall') - med('in_cpu') - med('in_waited'):.1f}",
                f"{med('worker_cpu'):.0f} %" if console else "-",
                f"{med('engine_cpu'):.0f} %",
                f"{med('cpu'):.0f} %",
                f"{med('rate'):,.0f}",
                f"{sum(x['lost'] for x in got):,.0f} of {sent:,.0f}"
                if console
                else f"{sum(x['sent'] - x['tap_taken'] for x in got):,.0f} of {sent:,.0f}"
                if arm == "elsewhere"
                else "-",
                f"{sum(x['held_gaps'] for x in got):,.0f}" if console else "-",
                f"{min(loads):.1f}-{max(loads):.1f}",
            ]
        )
    return rows, rounds


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print its tables (or, with --publisher, be one flooding child process)."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer repeats, a 10 s flood")
    parser.add_argument("--rate", type=float, default=20_000.0, help="flood: lines/s in all")
    parser.add_argument("--seconds", type=float, default=60.0, help="flood: how long")
    parser.add_argument("--skip-flood", action="store_true", help="no ROS: only the store and the proposals")
    parser.add_argument(
        "--viewer",
        action="store_true",
        help="only the viewer's frame times without and with a Log console during the flood, and without it "
        "while another process takes /rosout (needs a "
        'display: xvfb-run -a -s "-screen 0 1600x1000x24")',
    )
    parser.add_argument("--repeats", type=int, default=3, help="--viewer: runs each way (alternating)")
    parser.add_argument(
        "--before",
        type=Path,
        default=None,
        help="--viewer: another source tree (e.g. git worktree add /tmp/dbglog-before main) whose console "
        "runs as a fourth arm, alternating with the others",
    )
    parser.add_argument("--warmup", type=float, default=5.0, help=argparse.SUPPRESS)
    parser.add_argument("--nodes", type=int, default=5, help=argparse.SUPPRESS)
    parser.add_argument("--viewer-child", default="", help=argparse.SUPPRESS)
    parser.add_argument("--publisher", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--tap", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--count", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--offset", type=int, default=0, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.publisher:
        return _publisher_main(args.rate, args.count, args.offset)
    if args.tap:
        return _tap_main()
    if args.viewer_child:
        return _viewer_main(args.viewer_child, args.seconds, args.warmup, args.nodes)
    if args.viewer:
        local_ros_env(random.SystemRandom().randint(1, 100) if "ROS_DOMAIN_ID" not in os.environ else None)
        seconds = 10.0 if args.quick else args.seconds
        print(f"python {sys.version.split()[0]}; load average before: {os.getloadavg()}", flush=True)
        rows, pairs = bench_viewer(args.rate, seconds, args.repeats, args.warmup, args.nodes, args.before)
        arms = (*_ARMS, "before") if args.before is not None else _ARMS
        print_table(
            f"The viewer during the flood ({args.nodes} nodes, {args.rate:,.0f} lines/s, {seconds:g} s; "
            f"as dbglog view runs: 60 fps cap, data 20 fps; medians of {args.repeats} runs of each arm, "
            "in a new rotation each round)",
            [
                "dashboard",
                "frames/s",
                "frame p50 ms",
                "frame p95 ms",
                "frame p99 ms",
                "p95 vs without",
                "console's UI-thread CPU a frame, mean / p50 / p95 ms",
                "UI thread CPU a frame, mean ms",
                "of it the timeline bar, mean ms",
                "a frame's wall time = UI thread CPU + waiting for a CPU + blocked (GIL, GPU, X), mean ms",
                "log worker CPU",
                "engine thread CPU",
                "viewer CPU",
                "sent lines/s",
                "lost (not in the store)",
                "gaps in the held lines",
                "load average",
            ],
            rows,
        )
        print_table(
            "Each round",
            [
                "round",
                *(f"{arm}: p50 / p95 ms" for arm in arms),
                *(f"p95 {arm} vs without" for arm in arms[1:]),
                *(f"lost ({arm})" for arm in arms if arm in ("with", "before")),
                "load",
            ],
            pairs,
        )
        return 0
    repeats = 3 if args.quick else 7
    print(f"python {sys.version.split()[0]}, google-re2, numpy {np.__version__}")
    print_table("Calibration (this machine, this run)", ["what", "time"], _calibration(repeats))
    print_table("Proposing a pattern (median)", ["line", "ms"], _propose_rows(repeats))
    print_table(
        f"Preview over {N_LINES:,} stored lines (median)",
        ["lines of that kind", "matched", "ms, from a list of str", "ms, from a columnar buffer"],
        _preview_rows(repeats),
    )
    print_table(
        f"Memory per stored Log line ({N_LINES:,} lines, all-in, tracemalloc)",
        ["store", "bytes/line"],
        _memory_rows(),
    )
    print_table(
        f"The console's store: changing the filter over {N_LINES:,} lines (median; target 50 ms)",
        ["filter", "lines shown", "whole answer, ms", "first answer (newest lines), ms"],
        _filter_rows(repeats),
    )
    print_table(
        "The console's store: decoding, growing, previews (median)", ["what", "time"], _store_rows(repeats)
    )
    print_table(
        f"The console's store: memory per line ({N_LINES:,} lines, all-in)",
        ["what", "bytes/line"],
        _store_memory_rows(),
    )
    if not args.skip_flood:
        local_ros_env(random.SystemRandom().randint(1, 100) if "ROS_DOMAIN_ID" not in os.environ else None)
        seconds = 10.0 if args.quick else args.seconds
        print_table(
            "Flood: nodes logging through real /rosout into the engine's log store (its worker decodes "
            "them; a thread takes the answers at 20 Hz, as the console does)",
            [
                "nodes",
                "target lines/s",
                "seconds",
                "sent lines/s",
                "sent",
                "in the store",
                "lost",
                "engine took",
                "console's take p95 ms",
                "evicted",
            ],
            bench_flood(args.rate, seconds),
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
