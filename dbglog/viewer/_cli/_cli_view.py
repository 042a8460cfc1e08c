"""``dbglog view``: open the live dashboard viewer (or replay a recording), optionally render a screenshot."""

from __future__ import annotations

import argparse
import functools
import math
import os
import re
import signal
import sys
import time
from pathlib import Path
from typing import TYPE_CHECKING

from dbglog._sched import CpuPolicy, add_cpu_argument, apply_cpu_argument, in_background

if TYPE_CHECKING:
    from dbglog._ros._paramclient import ParamClient
    from dbglog.viewer._data._events import EventStore
    from dbglog.viewer._data._model import DataSource
    from dbglog.viewer._data._replay import ReplaySource
    from dbglog.viewer._publishing._republish import Republisher
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._auto import AutoDashboard

__all__ = [
    "HELP",
    "add_arguments",
    "cursor_arg",
    "duration_arg",
    "events_of_source",
    "follow_parameters",
    "fps_arg",
    "megabytes_arg",
    "run",
    "seconds_arg",
    "size_arg",
    "write_full_report",
]

HELP = (
    "Open the live dashboard viewer (drag widgets onto a canvas, bind them to topics, save dashboards), "
    "or replay a recording in it (--replay)."
)


ENGINE_START_BACKGROUND_S = 120.0
"""Seconds the data engine may take to start (its ROS context and node) under ``--cpu background``, whose
threads wait while other processes keep every CPU busy (otherwise: ``Engine.start``'s own timeout)."""


_BUSY = "with --cpu background the viewer waits while the machine is busy (--cpu normal does not)"


def _say_engine_waits() -> None:
    print(f"dbglog view: note: still starting: {_BUSY}", file=sys.stderr)


def size_arg(text: str) -> tuple[int, int]:
    """Parse a window size ``WxH`` for argparse."""
    try:
        w, h = (int(part) for part in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 1440x900, not {text!r}") from None
    if not (320 <= w <= 8192 and 240 <= h <= 8192):
        raise argparse.ArgumentTypeError(f"size {text!r} is outside 320x240..8192x8192")
    return w, h


def _number_within(text: str, noun: str, name: str, low: int, high: int) -> float:
    """Parse a number for argparse, refused (naming `noun` or `name`) unless ``low <= it <= high``."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number of {noun}: {text!r}") from None
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"{name} must be within {low}..{high}, not {text}")
    return value


def seconds_arg(text: str) -> float:
    """Parse a number of seconds (0..3600) for argparse."""
    return _number_within(text, "seconds", "seconds", 0, 3600)


_DURATION = re.compile(
    r"(?:(\d+(?:\.\d*)?)d)?(?:(\d+(?:\.\d*)?)h)?(?:(\d+(?:\.\d*)?)m)?(?:(\d+(?:\.\d*)?)s?)?"
)
MAX_HISTORY_S = 7 * 86400.0


def duration_arg(text: str) -> float:
    """Parse a history length for argparse: seconds (``1800``) or with units (``90s``, ``30m``, ``1h30m``,
    ``2d``, ``1d12h``)."""
    match = _DURATION.fullmatch(text.strip().lower())
    if not text.strip() or match is None or not any(match.groups()):
        raise argparse.ArgumentTypeError(f"not a duration: {text!r} (e.g. 1800, 90s, 30m, 2h, 1h30m, 2d)")
    d, h, m, s = (float(g) if g else 0.0 for g in match.groups())
    value = d * 86400 + h * 3600 + m * 60 + s
    if not 1 <= value <= MAX_HISTORY_S:
        raise argparse.ArgumentTypeError(f"a history of {text} is outside 1 s..7 days (7d)")
    return value


def megabytes_arg(text: str) -> float:
    """Parse a memory cap in megabytes (MiB, 1..1,000,000) for argparse."""
    return _number_within(text, "megabytes", "megabytes", 1, 1_000_000)


def cursor_arg(text: str) -> float:
    """Parse a cursor time for argparse: negative seconds before the newest sample, or epoch seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a time: {text!r} (-2: 2 s before the newest sample)") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"not a time: {text!r}")
    return value


def robot_arg(text: str) -> str:
    """A robot's namespace for ``--robot`` (``robot1``, ``/lab/robot1``; ``/`` for none)."""
    from dbglog._ros._tags import TagError
    from dbglog.viewer._data._robots import parse_robot

    try:
        return parse_robot(text)
    except TagError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def fps_arg(text: str) -> float:
    """Parse a frame cap in frames per second (1..240) for argparse."""
    return _number_within(text, "frames per second", "fps", 1, 240)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare ``dbglog view``'s options."""
    parser.add_argument(
        "dashboard",
        nargs="?",
        type=Path,
        help="dashboard JSON file (current or ROSDashboard); a file that does not exist yet starts an "
        "empty dashboard that Save writes there; without one, an automatic dashboard of the live "
        "/rosdashboard/ tags (with --replay: of the recording's tags and topics)",
    )
    parser.add_argument(
        "--replay",
        type=Path,
        metavar="FILE",
        help="replay a recording (an MCAP file: dbglog record's, ros2 bag's; or a rosbag2 folder) instead of "
        "the live graph: no ROS node is started (unless --republish); it opens paused at its end, Space "
        "or the play button plays it (speed 0.1-10x, loop), the time bar seeks",
    )
    parser.add_argument(
        "--republish",
        action="store_true",
        help="with --replay: publish the recording on ROS 2 at the time cursor, so RViz or dbglog echo "
        "follow the replay: playing, every message the cursor passes (original topic, type and bytes, in "
        "time order); after a seek or step, each topic's latest message at the cursor; and /clock. Topics "
        "of types not installed here are skipped (a warning names them)",
    )
    parser.add_argument(
        "--template",
        action="store_true",
        help="open DASHBOARD as a new, untitled dashboard: the file is never written, Save asks where "
        "to keep your version (the demo opens its dashboard this way)",
    )
    parser.add_argument(
        "--all",
        action="store_true",
        help="automatic dashboard: also add widgets for topics that are not dbglog tags",
    )
    parser.add_argument(
        "--robot",
        type=robot_arg,
        metavar="NAME",
        help="the robot (namespace: robot1, lab/robot1; / for the tags of no namespace) that the widgets "
        "following 'the selected robot' show at start (default: the first robot seen; the Robot menu "
        "switches)",
    )
    parser.add_argument(
        "--no-tag-tree",
        dest="tag_tree",
        action="store_false",
        help="start without the tag tree beside the canvas (View \u203a Tag tree, Ctrl+T, shows it)",
    )
    parser.add_argument(
        "--screenshot", type=Path, metavar="PNG", help="render, write a PNG of the window, exit"
    )
    parser.add_argument(
        "--after",
        type=seconds_arg,
        default=2.0,
        metavar="SECONDS",
        help="with --screenshot: how long to render first (default 2)",
    )
    parser.add_argument(
        "--wait-live",
        type=seconds_arg,
        default=0.0,
        metavar="SECONDS",
        help="with --screenshot: after --after, keep rendering up to this long until every widget is live",
    )
    parser.add_argument(
        "--cursor",
        type=cursor_arg,
        metavar="T",
        help="with --screenshot: take it paused at time T: negative, seconds before the newest sample "
        "(-2; with --replay, before the end of the recording); otherwise epoch seconds; with --replay "
        "and no --screenshot, where the replay starts",
    )
    parser.add_argument(
        "--report-json",
        type=Path,
        metavar="PATH",
        help="on exit, write every widget's name, type, status and bindings (and the dashboard) as JSON, "
        "with the cursor and each binding's value at it and samples held, and the events: every parameter "
        "change seen (time, node, name, old and new value) and every user marker",
    )
    parser.add_argument(
        "--history",
        type=duration_arg,
        default=1800.0,
        metavar="DURATION",
        help="how far back the viewer remembers every tag and bound topic, for the timeline: seconds "
        "or 90s / 30m / 2h / 1d (default 30m, at most 7d)",
    )
    parser.add_argument(
        "--history-mb",
        type=megabytes_arg,
        default=512.0,
        metavar="N",
        help="memory cap of that history in MiB; the oldest samples go first (default 512)",
    )
    parser.add_argument(
        "--size", type=size_arg, default=(1440, 900), metavar="WxH", help="window size (1440x900)"
    )
    parser.add_argument(
        "--fps",
        type=fps_arg,
        default=60.0,
        metavar="N",
        help="frame cap while you work in the window (default 60); the viewer redraws only when "
        "something changed, so idle it uses almost no CPU",
    )
    parser.add_argument(
        "--data-fps",
        type=fps_arg,
        default=20.0,
        metavar="N",
        help="draw new data at most this often while you do not touch the window (default 20; at most "
        "--fps): the viewer's CPU use with live data scales with it",
    )
    parser.add_argument(
        "--stale-after",
        type=seconds_arg,
        default=2.0,
        metavar="SECONDS",
        help="a series turns stale after this long without a message (default 2)",
    )
    add_cpu_argument(
        parser,
        CpuPolicy.BACKGROUND,
        "how the viewer shares the CPU with the robot: background (default; Linux's SCHED_IDLE: "
        "any robot thread that wakes up takes the CPU from the viewer at once, and the viewer still "
        "gets all the CPU nobody else wants) or normal (share it evenly: for a machine kept busy by "
        "other work, e.g. a build, where a background viewer would draw late)",
    )


def _stacks_on_sigusr1() -> None:
    """``kill -USR1 <pid>`` prints every thread's stack on stderr: what a viewer that hangs is doing."""
    import faulthandler

    if hasattr(signal, "SIGUSR1") and signal.getsignal(signal.SIGUSR1) == signal.SIG_DFL:
        faulthandler.register(signal.SIGUSR1, all_threads=True)


def run(args: argparse.Namespace) -> int:
    """Open the viewer; return the exit code."""
    apply_cpu_argument(args.cpu, "dbglog view")  # first: every thread started from here on inherits it
    _stacks_on_sigusr1()
    from dbglog.viewer._document._dashboard import DashboardError, LoadResult, load_dashboard
    from dbglog.viewer._widgets import WidgetRegistry

    if args.cursor is not None and args.screenshot is None and args.replay is None:
        print(
            "dbglog view: error: --cursor needs --screenshot (it sets where the screenshot is taken)",
            file=sys.stderr,
        )
        return 2
    if args.republish and args.replay is None:
        print(
            "dbglog view: error: --republish needs --replay FILE (it publishes a recording's messages)",
            file=sys.stderr,
        )
        return 2
    registry = WidgetRegistry.discover()
    for problem in registry.problems:
        print(f"dbglog view: warning: {problem}", file=sys.stderr)
    result: LoadResult | None = None
    if args.template and args.dashboard is None:
        print("dbglog view: error: --template needs a dashboard file to start from", file=sys.stderr)
        return 2
    new_file = args.dashboard is not None and not args.template and not args.dashboard.exists()
    if new_file:
        folder = args.dashboard.parent
        if not folder.is_dir():
            print(
                f"dbglog view: error: cannot start {args.dashboard}: folder {folder} does not exist",
                file=sys.stderr,
            )
            return 2
    elif args.dashboard is not None:
        try:
            result = load_dashboard(args.dashboard, registry.get)
        except DashboardError as exc:
            print(f"dbglog view: error: {exc}", file=sys.stderr)
            return 2
        for message in result.messages:
            print(f"dbglog view: {args.dashboard}: {message}", file=sys.stderr)

    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._ui._auto import AutoDashboard
    from dbglog.viewer._ui._display import x_display_problem

    display_problem = x_display_problem(
        os.environ.get("DISPLAY"), wayland=bool(os.environ.get("WAYLAND_DISPLAY"))
    )
    if display_problem is not None:
        print(
            f"dbglog view: error: {display_problem}.\n"
            "  Without a screen, render on a virtual one and look at the picture:\n"
            "    xvfb-run -a dbglog view [DASHBOARD] --screenshot view.png --after 5",
            file=sys.stderr,
        )
        return 2
    source: DataSource
    republisher: Republisher | None = None
    params: ParamClient | None = None
    if args.replay is not None:
        replay = open_replay(args.replay, stale_after=max(0.1, args.stale_after))
        if replay is None:
            return 1
        source, engine = replay, None
        if args.republish:
            republisher = start_republisher()
            if republisher is None:
                return 1
    else:
        from dbglog.viewer._data._engine import Engine

        engine = Engine(
            stale_after=max(0.1, args.stale_after),
            history_seconds=args.history,
            history_bytes=int(args.history_mb * 2**20),
        )
        background = in_background()
        try:
            # Under --cpu background the engine's thread gets a CPU only when nothing else wants one: on a
            # busy machine it waits, which is no failure (say so, and wait longer).
            if background:
                engine.start(ENGINE_START_BACKGROUND_S, slow=_say_engine_waits)
            else:
                engine.start()
        except RuntimeError as exc:
            hint = f"; {_BUSY}" if background else ""
            print(f"dbglog view: error: {exc}{hint}", file=sys.stderr)
            return 1
        source = engine
        params = follow_parameters(engine.events())
    width, height = args.size
    app = ViewerApp(
        source,
        registry,
        width=width,
        height=height,
        fps=args.fps,
        data_fps=args.data_fps,
        recording=args.replay is not None,
        params=params,
        robot=args.robot,
        tag_tree=args.tag_tree,
    )
    app.recordings.republisher = republisher  # View › Republish on ROS 2 shows for it
    try:
        app.start()
        if republisher is not None:
            app.cursor_hooks.append(functools.partial(follow_cursor, app, republisher))
        from dbglog.viewer._ui._auto import AutoDashboard, all_live

        auto: AutoDashboard | None = None
        if new_file:
            app.files.new(args.dashboard)
            app.set_status(f"new dashboard: Save (Ctrl+S) writes {args.dashboard}")
        elif result is not None and args.template:
            app.load(result, None)
            app.set_status(f"opened {args.dashboard.name} as a new dashboard: Save asks where to keep it")
        elif result is not None:
            app.load(result, args.dashboard)
        else:
            # A recording's topics all have their messages at hand: every one gets a widget.
            auto = AutoDashboard(app, all_topics=args.all or args.replay is not None)
            auto.install()
        if args.replay is not None:
            replay_status(app, args.replay, auto is not None, republish=republisher is not None)
        if args.replay is not None and (args.screenshot is not None or args.cursor is not None):
            whole_recording(app)  # a cursor and a picture are of the whole file, not its first seconds
        if args.screenshot is None and args.replay is not None and args.cursor is not None:
            app.frame()
            place_cursor(app, args.cursor)
        if args.screenshot is not None:
            app.run(seconds=args.after)
            deadline = time.monotonic() + args.wait_live
            # Wait for every widget to be live, and for new array tags still learning their length (a
            # recording's widgets show its end: live or stale then, as it was).
            while (
                (not all_live(app) and args.replay is None) or (auto is not None and auto.pending)
            ) and time.monotonic() < deadline:
                app.frame()
            newest = place_cursor(app, args.cursor) if args.cursor is not None else None
            if args.report_json is not None:
                write_full_report(app, args.report_json, cursor_from=newest, auto=auto)
            try:
                path = app.screenshot(args.screenshot)
            except (OSError, TimeoutError) as exc:
                print(f"dbglog view: error: cannot write {args.screenshot}: {exc}", file=sys.stderr)
                return 1
            print(path)
            return 0
        app.run()
        if args.report_json is not None:
            write_full_report(app, args.report_json, auto=auto)
        return 0
    finally:
        app.close()
        if params is not None:
            params.close()
        if engine is not None:
            engine.stop()
        if republisher is not None:
            republisher.close()


def follow_parameters(events: EventStore) -> ParamClient:
    """Start the parameter client that tells `events` each node's values when first seen (so a change reads
    "old → new") and publishes the user's markers; its calls never wait on a node."""
    from dbglog._ros._paramclient import ParamClient

    params = ParamClient().start()
    params.watch(events.seed)
    events.publish = params.publish_marker
    return params


def events_of_source(source: object) -> EventStore | None:
    """The data source's events store (the engine's, a recording's), None for a source that keeps none."""
    from dbglog.viewer._data._events import EventStore

    make = getattr(source, "events", None)
    made = make() if callable(make) else None
    return made if isinstance(made, EventStore) else None


def write_full_report(
    app: ViewerApp, path: Path, *, cursor_from: float | None = None, auto: AutoDashboard | None = None
) -> Path:
    """Write ``--report-json``: the widgets' report (with the automatic dashboard's panels, `auto`) and
    ``events``, every parameter change (and deletion) the viewer saw and every user marker, oldest first."""
    import json

    from dbglog.viewer._data._events import event_json
    from dbglog.viewer._ui._auto import widget_report

    report = widget_report(app, cursor_from=cursor_from, auto=auto)
    events = events_of_source(app.source)
    report["events"] = [event_json(e) for e in events.all()] if events is not None else []
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(report, indent=2) + "\n", encoding="utf-8")
    return path


def open_replay(path: Path, *, stale_after: float) -> ReplaySource | None:
    """Load a recording for ``--replay``; its problems are warnings on stderr; None if it cannot be read."""
    from dbglog.record import RecordingError
    from dbglog.viewer._data._replay import load_replay
    from dbglog.viewer._ui._recordings import import_ros

    import_ros()  # on this thread, before the controls' publishing service may import it on its own
    try:
        replay = load_replay(path, stale_after=stale_after)
    except RecordingError as exc:
        print(f"dbglog view: error: {exc}", file=sys.stderr)
        return None
    for problem in replay.problems:
        print(f"dbglog view: warning: {problem} (the readable part plays)", file=sys.stderr)
    if replay.time_span() is None:
        print(f"dbglog view: warning: {path} holds no readable message", file=sys.stderr)
    return replay


def start_republisher() -> Republisher | None:
    """Start ``--republish``'s ROS node and thread; None (the error said on stderr) when ROS cannot start."""
    from dbglog.viewer._publishing._republish import Republisher

    republisher = Republisher()
    try:
        republisher.start()
    except Exception as exc:  # rclpy missing or ROS refusing to start: say so in one line
        print(f"dbglog view: error: --republish cannot start ROS 2: {exc}", file=sys.stderr)
        return None
    return republisher


def follow_cursor(app: ViewerApp, republisher: Republisher) -> None:
    """A cursor hook: hand the time cursor to the republisher; show what it has to say (UI thread)."""
    timeline = app.timeline
    republisher.follow(app.source, timeline.cursor, playing=timeline.playing, speed=timeline.speed)
    for note in republisher.take_notes():
        print(f"dbglog view: warning: {note}", file=sys.stderr)
        app.set_status(note)


def whole_recording(app: ViewerApp, timeout: float = 600.0) -> None:
    """Render until a long recording has loaded whole (it opens with its last seconds, the rest behind)."""
    deadline = time.monotonic() + timeout
    while getattr(app.source, "loading", False) and time.monotonic() < deadline:
        app.frame()
        time.sleep(0.02)
    if not app.timeline.playing:
        app.time.go_live()  # the end of the whole file (the cursor was at the end of its first part)


def replay_status(app: ViewerApp, path: Path, auto: bool, *, republish: bool = False) -> None:
    """Say in the status bar what is replayed and how to play it."""
    from dbglog.viewer._ui._timescale import format_duration

    span = app.time.time_span()
    length = format_duration(span[1] - span[0]) if span is not None else "empty"
    how = "automatic dashboard of its topics; " if auto else ""
    also = "; republished on ROS 2 at the cursor" if republish else ""
    app.set_status(
        f"replay of {path.name} ({length}): {how}Space or the play button plays, the bar seeks{also}"
    )


def place_cursor(app: ViewerApp, t: float) -> float | None:
    """Pause `app` at `t` (negative: seconds before the newest sample held) and draw it.

    Returns the newest source time the cursor counted back from (None for an epoch time): live data go on
    arriving while the frames at the cursor are drawn, so the report says what the cursor was placed from.
    """
    newest = None
    if t < 0:
        span = app.time.time_span()
        newest = span[1] if span is not None else time.time()
        t += newest
    app.time.seek(t)
    for _ in range(3):  # every widget redraws at the cursor, the bar shows it
        app.frame()
    return newest
