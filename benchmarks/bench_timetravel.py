"""Time travel benchmark (issue 16): moving the cursor through a long history, and back-filling a new widget.

Run from the repository root: ``.venv/bin/python -m benchmarks.bench_timetravel`` (``--help`` for options).

* **cursor**: 50 topics x 100 Hz for ``--minutes`` (60: 18 M samples) held in the viewer's history, 20 of
  them bound (each binding's values kept too, as the engine keeps them). One cursor move = every bound
  series answering "the state at t" (`Series.snapshot_at`, what the engine's `snapshot_at` runs), at random
  times over the span; also one step (previous/next sample of all 20). Medians and p95 of the moves; the
  widgets' drawing is measured by ``bench_ui``.
* **redraw** (under a display: ``xvfb-run -a -s "-screen 0 1920x1080x24" ...``): the real viewer with
  ``bench_ui``'s 20 widgets (8 plots of 5 series, 12 gauges) over a 50 topics x 100 Hz history of
  ``--minutes`` served by a `ReplaySource`; one cursor move = seek to a random time + one frame (every
  widget redrawn at that time); a drag = the cursor moved by 0.1 s per frame, frames per second. Each
  row splits a frame into the app's work (the seek, snapshots, widget updates: Python) and the render
  (``render_dearpygui_frame``: Dear ImGui/ImPlot and the GL rasteriser), with the process's CPU time per
  frame and the load average, since a shared machine moves the wall-clock figures. Last, the drag again in
  1 s blocks alternating the two looks of a dense dashboard (every widget frame filled, as before; the
  canvas cleared to the panel colour, now), then alternating the plots' lines computed at once on the UI
  thread (before) and on the line worker while the frame renders (now): fps, the app's work and CPU per
  frame side by side in this process. Seeks are clicks (drawn whole at once); only the drag moves the
  cursor frame after frame. To compare another checkout, copy this file into it and run it from there.
* **open**: a recording of 50 topics x 100 Hz for ``--minutes`` (written by ``bench_record``'s writer),
  opened for replay: the time until the first frame can be drawn (the end of the file, 20 bindings
  filled) and until the whole file is seekable, against loading it whole first.
* **backfill**: a real viewer engine and a real dbglog SDK child that logs ``--backfill-samples`` values of
  a tag (10 minutes of a 100 Hz tag = 60,000) before anything binds it; then a binding is made and timed
  until its series holds every one of them (repeats, each on a new tag).
"""

from __future__ import annotations

import argparse
import os
import random
import statistics
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np

_ROOT = Path(__file__).resolve().parent.parent
if str(_ROOT) not in sys.path:
    sys.path.insert(0, str(_ROOT))

from benchmarks._common import local_ros_env, print_table  # noqa: E402
from dbglog.viewer._data._history import History  # noqa: E402
from dbglog.viewer._data._model import Binding  # noqa: E402
from dbglog.viewer._data._series import Series  # noqa: E402
from dbglog.viewer._data._timeline import Timeline  # noqa: E402

_T0 = 1_700_000_000.0


def _p(samples: list[float], q: float) -> float:
    return float(np.percentile(np.asarray(samples), q))


class _SeriesSource:
    """The engine's TimeSource answers, without ROS: bound series over one history."""

    def __init__(self, store: History, series: dict[Binding, Series]) -> None:
        self.store, self.series = store, series

    def snapshot_at(self, binding: Binding, t: float) -> object:
        return self.series[binding].snapshot_at(t, 2.0)

    def time_span(self) -> tuple[float, float] | None:
        s = self.store.stats()
        return None if s.oldest is None or s.newest is None else (s.oldest, s.newest)

    def neighbour_time(self, binding: Binding, t: float, direction: int) -> float | None:
        return self.series[binding].neighbour_time(t, direction)

    def history_stats(self) -> object:
        return self.store.stats()

    def between(self, binding: Binding, t0: float, t1: float) -> object:
        return self.series[binding].between(t0, t1)

    def snapshot(self, binding: Binding) -> object:
        return self.series[binding].snapshot(2.0)

    def bind(self, binding: Binding) -> None:
        """Bindings are made up front."""

    def unbind(self, binding: Binding) -> None:
        """Bindings are made up front."""

    def topics(self) -> list[object]:
        return []

    def fields(self, topic: str) -> list[object]:
        return []


def _cursor(args: argparse.Namespace) -> None:
    store = History(clock=None, max_seconds=7200, max_bytes=2**40)
    names = [f"/rosdashboard/t{k}" for k in range(args.topics)]
    bound = {Binding(n): Series(Binding(n), 10_000, store) for n in names[: args.widgets]}
    per = args.rate
    base = np.arange(per) / args.rate
    start = time.perf_counter()
    for b in range(args.minutes * 60):
        t = _T0 + b + base
        now = time.monotonic()
        for k, name in enumerate(names):
            v = np.sin(t * (0.1 + k * 0.01))
            store.append_numbers(name, t, v)
            series = bound.get(Binding(name))
            if series is not None:
                series.push_numbers(t, v, float(v[-1]), now)
    fill_s = time.perf_counter() - start
    stats = store.stats()
    source = _SeriesSource(store, bound)
    timeline = Timeline(source)  # type: ignore[arg-type]
    span = timeline.span()
    assert span is not None
    rng = random.Random(7)
    moves: list[float] = []
    steps: list[float] = []
    for _ in range(args.moves):
        t = rng.uniform(*span)
        begin = time.perf_counter()
        timeline.seek(t)
        snaps = [timeline.snapshot(b) for b in bound]
        moves.append((time.perf_counter() - begin) * 1e3)
        assert all(s.last is not None for s in snaps)
        begin = time.perf_counter()
        timeline.step(list(bound), +1)
        snaps = [timeline.snapshot(b) for b in bound]
        steps.append((time.perf_counter() - begin) * 1e3)
    print_table(
        f"Cursor: {args.topics} topics × {args.rate} Hz × {args.minutes} min = "
        f"{stats.samples:,} samples held ({stats.bytes_used / 2**20:,.0f} MiB, filled in {fill_s:.0f} s); "
        f"{args.widgets} bound series; {args.moves} moves",
        ["operation", "p50 ms", "p95 ms", "max ms", "target"],
        [
            [
                f"seek to a random time, {args.widgets} series at t",
                f"{statistics.median(moves):.2f}",
                f"{_p(moves, 95):.2f}",
                f"{max(moves):.2f}",
                "p95 ≤ 50 ms with the redraw",
            ],
            [
                f"step to the next sample of {args.widgets} series, then read them",
                f"{statistics.median(steps):.2f}",
                f"{_p(steps, 95):.2f}",
                f"{max(steps):.2f}",
                "",
            ],
        ],
    )


_CHILD = """
import time, dbglog
dbglog.init()
time.sleep(2.0)
for i in range({n}):
    dbglog.logfloat({tag!r}, float(i))
    if i % 500 == 499:
        time.sleep(0.002)
assert dbglog.flush(10.0)
time.sleep(3.0)  # the batch writer stays: a viewer that discovers it late gets them all
"""


def _backfill(args: argparse.Namespace) -> None:
    from dbglog._ros._tags import topic_for_tag
    from dbglog.viewer._data._engine import Engine

    env = {**os.environ, "PYTHONPATH": str(_ROOT)}
    took: list[float] = []
    counts: list[int] = []
    with Engine(node_name="bench_timetravel") as engine:
        for r in range(args.repeats):
            tag = f"bench/backfill/r{r}_{os.getpid()}"
            topic = topic_for_tag(tag)
            code = textwrap.dedent(_CHILD.format(n=args.backfill_samples, tag=tag))
            subprocess.run([sys.executable, "-c", code], env=env, check=True, timeout=300)
            deadline = time.monotonic() + 30
            while engine.store.count(topic) < args.backfill_samples and time.monotonic() < deadline:
                time.sleep(0.01)
            held = engine.store.count(topic)
            binding = Binding(topic)
            begin = time.perf_counter()
            engine.bind(binding)
            while engine.snapshot(binding).count < held and time.perf_counter() - begin < 30:
                time.sleep(0.0005)
            took.append((time.perf_counter() - begin) * 1e3)
            counts.append(engine.snapshot(binding).count)
            engine.unbind(binding)
    print_table(
        f"Back-fill: a binding made after {args.backfill_samples:,} samples of its tag were logged "
        f"(real engine, SDK child), {args.repeats} repeats",
        ["samples back-filled", "p50 ms", "max ms", "target"],
        [
            [
                f"{min(counts):,}–{max(counts):,} of {args.backfill_samples:,}",
                f"{statistics.median(took):.1f}",
                f"{max(took):.1f}",
                "≤ 100 ms for 10 min of a 100 Hz tag",
            ]
        ],
    )


def _redraw(args: argparse.Namespace) -> None:
    import dearpygui.dearpygui as dpg

    from benchmarks.bench_ui import _layout
    from dbglog.viewer._data._replay import ReplaySource
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry
    from dbglog.viewer.widget_api import TimeRange

    store = History(clock=None, max_seconds=7200, max_bytes=2**40)
    names = [f"/bench/tt/t{k}" for k in range(args.topics)]
    base = np.arange(args.rate) / args.rate
    for b in range(args.minutes * 60):
        t = _T0 + b + base
        for k, name in enumerate(names):
            store.append_numbers(name, t, np.sin(t * (0.1 + k * 0.01)))
    source = ReplaySource(store, dict.fromkeys(names, "std_msgs/msg/Float64"))
    width, height = 1440, 900
    app = ViewerApp(source, WidgetRegistry.builtin(), width=width, height=height)
    app.start()
    dpg.set_viewport_vsync(False)
    app.set_snap(False)
    cell_w, cell_h = (width - 220) // 5, (height - 150) // 4
    for n, (kind, topics) in enumerate(_layout()):
        item = app.add_widget(kind, 0, 0)
        assert item is not None
        item.place(
            type(item.rect)(8 + cell_w * (n % 5), 8 + cell_h * (n // 5), cell_w - 8, cell_h - 8), rebuild=True
        )
        app.apply_bindings(item, tuple(Binding(names[t], "data") for t in topics))
    app.select(None)
    span = app.timeline.span()
    assert span is not None
    for _ in range(30):
        app.frame()
    rows: list[list[str]] = []
    load_before = os.getloadavg()

    def measure(label: str, target: str, moves: list[float] | None = None) -> None:
        """Frames (one per entry of `moves`: seek there first, or stay): total, app work, render, CPU ms."""
        out: list[list[float]] = [[], [], [], []]
        for t in moves if moves is not None else [None] * args.moves:
            cpu0 = time.process_time()
            begin = time.perf_counter()
            if t is not None:
                app.timeline.seek(t)
            app.frame()
            frame_ms = (time.perf_counter() - begin) * 1e3
            render_ms = (app.frame_times[-1] - app.loop.last_work_s) * 1e3  # the seek counts as app work
            values = (frame_ms, frame_ms - render_ms, render_ms, (time.process_time() - cpu0) * 1e3)
            for column, value in zip(out, values, strict=True):
                column.append(value)
        total, work, render, cpu = out
        rows.append(
            [
                label,
                f"{statistics.median(total):.1f}",
                f"{_p(total, 95):.1f}",
                f"{max(total):.1f}",
                f"{statistics.median(work):.1f} / {_p(work, 95):.1f}",
                f"{statistics.median(render):.1f} / {_p(render, 95):.1f}",
                f"{statistics.median(cpu):.1f}",
                target,
            ]
        )

    # The baseline: the same dashboard, paused, nothing changing (every widget skipped; drawing alone).
    app.timeline.seek(span[0] + 120)
    measure("baseline: one frame, cursor still (the drawing alone)", "")
    rng = random.Random(11)
    # Each seek is a click: the whole frame is drawn at it (back to back, the seeks would count as a
    # cursor moving frame after frame, whose plot lines are drawn during the render and shown a frame late).
    moving_frames, TimeRange.MOVING_FRAMES = TimeRange.MOVING_FRAMES, 2**62
    measure(
        "seek to a random time + one frame (20 widgets redrawn)",
        "p95 ≤ 50 ms",
        [rng.uniform(span[0] + 120, span[1]) for _ in range(args.moves)],
    )
    TimeRange.MOVING_FRAMES = moving_frames
    # A drag: the cursor +0.1 s a frame for 5 s, frames back to back (their times in a row of their own).
    t = span[0] + 120
    drag: list[float] = []
    begin = time.perf_counter()
    while time.perf_counter() - begin < 5.0:
        t += 0.1
        drag.append(t)
        app.timeline.seek(t)
        app.frame()
    fps = len(drag) / (time.perf_counter() - begin)
    measure("drag: the same moves again, frame by frame", "", drag)
    # The same drag with every widget frame filling itself (the look before the canvas was cleared to the
    # panel colour), alternating 1 s blocks with today's drawing in this process: the ratio is this sitting's.
    blocks: dict[bool, list[float]] = {True: [0, 0.0, 0.0], False: [0, 0.0, 0.0]}  # frames, seconds, CPU
    for block in range(2 * args.fill_blocks):
        panel = block % 2 == 1
        app.canvas.paint.panel_clear = panel
        app.frame()  # the canvas and frames take the look (not counted)
        begin, cpu0 = time.perf_counter(), time.process_time()
        while time.perf_counter() - begin < 1.0:
            t += 0.1
            app.timeline.seek(t)
            app.frame()
            blocks[panel][0] += 1
        blocks[panel][1] += time.perf_counter() - begin
        blocks[panel][2] += time.process_time() - cpu0
    fill_rows = [
        [
            f"drag, 1 s blocks alternating ({args.fill_blocks} each): {label}",
            f"{blocks[panel][0] / blocks[panel][1]:.1f} fps",
            "",
            "",
            "",
            "",
            f"{blocks[panel][2] / blocks[panel][0] * 1e3:.1f}",
            "",
        ]
        for panel, label in (
            (False, "every widget frame filled (before)"),
            (True, "canvas cleared to the panel colour"),
        )
    ]
    app.canvas.paint.panel_clear = True  # today's look for what follows
    # The same drag with the plots' lines computed at once on the UI thread (before the line worker), and
    # on the line worker while the frame renders (today), alternating 1 s blocks in this process.
    lines: dict[bool, list[float]] = {True: [0, 0.0, 0.0, 0.0], False: [0, 0.0, 0.0, 0.0]}
    for block in range(2 * args.fill_blocks):
        on_worker = block % 2 == 1
        TimeRange.MOVING_FRAMES = moving_frames if on_worker else 2**62
        for _ in range(moving_frames + 1):  # the cursor counts as moving again (not counted)
            t += 0.1
            app.timeline.seek(t)
            app.frame()
        begin, cpu0, work = time.perf_counter(), time.process_time(), 0.0
        while time.perf_counter() - begin < 1.0:
            t += 0.1
            app.timeline.seek(t)
            app.frame()
            work += app.loop.last_work_s
            lines[on_worker][0] += 1
        lines[on_worker][1] += time.perf_counter() - begin
        lines[on_worker][2] += time.process_time() - cpu0
        lines[on_worker][3] += work
    TimeRange.MOVING_FRAMES = moving_frames
    fill_rows += [
        [
            f"drag, 1 s blocks alternating ({args.fill_blocks} each): {label}",
            f"{lines[on][0] / lines[on][1]:.1f} fps",
            "",
            "",
            f"{lines[on][3] / lines[on][0] * 1e3:.1f}",
            "",
            f"{lines[on][2] / lines[on][0] * 1e3:.1f}",
            "",
        ]
        for on, label in (
            (False, "plot lines computed at once (before)"),
            (True, "plot lines on the line worker during the render"),
        )
    ]
    if args.shot:
        app.screenshot(args.shot)
    app.close()
    load_after = os.getloadavg()
    rows.append(["drag: cursor +0.1 s per frame, 5 s", f"{fps:.1f} fps", "", "", "", "", "", "≥ 30 fps"])
    rows.extend(fill_rows)
    print_table(
        f"Redraw: the real viewer, 20 widgets, {args.topics} topics × {args.rate} Hz × {args.minutes} min "
        f"({store.stats().samples:,} samples) from a ReplaySource; {args.moves} frames a row; load average "
        f"{load_before[0]:.2f} before, {load_after[0]:.2f} after",
        [
            "operation",
            "p50 ms",
            "p95 ms",
            "max ms",
            "app work p50 / p95",
            "render p50 / p95",
            "CPU ms p50",
            "target",
        ],
        rows,
    )
    print(
        "app work = the seek and everything of ViewerApp.frame() before render_dearpygui_frame (input, "
        "snapshots, widget updates); render = that call (Dear ImGui/ImPlot, GL rasterising, swap); CPU = "
        "the process's CPU time over the frame, every thread counted (Mesa's rasterizer threads too), the "
        "figure least moved by other load."
    )


def _open(args: argparse.Namespace) -> None:
    import tempfile

    from benchmarks.bench_record import _write_large
    from dbglog.viewer._data._replay import load_replay

    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "hour.mcap"
        n = _write_large(path, args.topics, float(args.rate), args.minutes * 60.0)
        size = path.stat().st_size
        names = [f"/rosdashboard/big/t{i}" for i in range(args.widgets)]
        firsts: list[float] = []
        wholes: list[float] = []
        plains: list[float] = []
        for _ in range(args.repeats):
            begin = time.perf_counter()
            source = load_replay(path, progressive=True)
            for name in names:
                source.bind(Binding(name))
            assert all(source.snapshot(Binding(name)).last is not None for name in names)
            firsts.append(time.perf_counter() - begin)
            while source.loading:
                time.sleep(0.005)
            wholes.append(time.perf_counter() - begin)
            assert source.samples_held(Binding(names[0])) == n // args.topics
            del source
            begin = time.perf_counter()
            plain = load_replay(path, progressive=False)
            for name in names:
                plain.bind(Binding(name))
            plains.append(time.perf_counter() - begin)
            del plain
    print_table(
        f"Open for replay: {args.topics} topics × {args.rate} Hz × {args.minutes} min = {n:,} messages "
        f"({size / 1e6:,.0f} MB), {args.widgets} bindings, {args.repeats} repeats",
        ["", "p50 s", "max s", "target"],
        [
            [
                "first frame (the last 10 s, bindings filled)",
                f"{statistics.median(firsts):.2f}",
                f"{max(firsts):.2f}",
                "≤ 2 s",
            ],
            [
                "whole file seekable (progressive)",
                f"{statistics.median(wholes):.1f}",
                f"{max(wholes):.1f}",
                "≤ 20 s",
            ],
            [
                "whole file, loaded before anything is shown",
                f"{statistics.median(plains):.1f}",
                f"{max(plains):.1f}",
                "",
            ],
        ],
    )


def main(argv: list[str] | None = None) -> int:
    """Run the benchmark and print Markdown tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--only", choices=["cursor", "backfill", "redraw", "open"], default=None)
    parser.add_argument("--shot", default="", help="(redraw) a PNG of the dashboard at the end")
    parser.add_argument("--topics", type=int, default=50)
    parser.add_argument("--rate", type=int, default=100)
    parser.add_argument("--minutes", type=int, default=60)
    parser.add_argument("--widgets", type=int, default=20)
    parser.add_argument("--moves", type=int, default=200)
    parser.add_argument(
        "--fill-blocks", type=int, default=6, help="(redraw) 1 s drag blocks per look in the fill comparison"
    )
    parser.add_argument("--backfill-samples", type=int, default=60_000)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--domain", type=int, default=None, help="ROS_DOMAIN_ID (random by default)")
    args = parser.parse_args(argv)
    if args.only in (None, "backfill"):
        local_ros_env(args.domain)
        _backfill(args)
    if args.only in (None, "cursor"):
        _cursor(args)
    if args.only in (None, "open"):
        _open(args)
    if args.only in (None, "redraw"):
        if os.environ.get("DISPLAY"):
            _redraw(args)
        else:
            print("\n(redraw skipped: no DISPLAY; run under xvfb-run)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
