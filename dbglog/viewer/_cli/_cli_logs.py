"""``dbglog logs``: print /rosout lines (time, level, node, message), filtered, coloured, following."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from types import FrameType
from typing import Any, Final, TextIO

from dbglog._regex._compile import MAX_LINE, RegexError, compile_regex
from dbglog._ros._loglevels import LEVEL_NAMES, LEVELS, level_of, node_matches

__all__ = ["HELP", "LEVELS", "LogLine", "LogsFilter", "add_arguments", "format_line", "run"]

HELP = "Print /rosout log lines (time, level, node, message), filtered, coloured on a terminal; follows."

_COLOURS: Final = {10: "\x1b[2m", 20: "", 30: "\x1b[33m", 40: "\x1b[31m", 50: "\x1b[1;35m"}
"""ANSI colours per level: debug dim, info plain, warn yellow, error red, fatal bold magenta."""
_RESET: Final = "\x1b[0m"
_SETTLE_S: Final = 0.3
"""The publishers' kept history arrives in a burst after matching: lines of the first this-many seconds
are sorted by their stamps before printing (each node's history arrives in one piece)."""


def _level(text: str) -> int:
    """Parse ``--level``: a name of `LEVELS`, or ``warning``."""
    try:
        value = level_of(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    if not value:
        raise argparse.ArgumentTypeError(f"unknown level {text!r} (one of: {', '.join(LEVELS)})")
    return value


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``logs`` options."""
    parser.add_argument(
        "--level",
        type=_level,
        default=0,
        metavar="LEVEL",
        help="minimum level: debug, info, warn, error or fatal (default: every line)",
    )
    parser.add_argument(
        "--node",
        metavar="GLOB",
        help="only lines whose logger matches: exact (talker) or an fnmatch glob (planner*, robot1.*)",
    )
    parser.add_argument(
        "--grep",
        metavar="RE2",
        help="only lines whose message contains a match of this RE2 regular expression",
    )
    parser.add_argument(
        "--count",
        "-n",
        type=int,
        default=0,
        metavar="N",
        help="exit after printing N lines (default 0: follow until Ctrl-C)",
    )
    parser.add_argument(
        "--since",
        type=float,
        metavar="SECONDS",
        help="only lines stamped at most SECONDS ago (0: only lines logged from now on); by default the "
        "lines the nodes still keep for late readers (up to their last 1,000, 10 s) appear first",
    )
    parser.add_argument(
        "--topic", default="/rosout", help="the rcl_interfaces/msg/Log topic (default: /rosout)"
    )
    parser.add_argument(
        "--color",
        choices=("auto", "always", "never"),
        default="auto",
        help="colour by level: auto (default: on a terminal, unless NO_COLOR is set), always, never",
    )


@dataclass(frozen=True, slots=True)
class LogLine:
    """One line from a Log topic."""

    stamp: float
    """Seconds since the epoch (the line's own stamp)."""
    level: int
    node: str
    message: str


@dataclass(frozen=True, slots=True)
class LogsFilter:
    """The ``--level``, ``--node``, ``--grep`` and ``--since`` filters."""

    min_level: int = 0
    node: str | None = None
    grep: Any = None
    """A compiled RE2 (``re2._Regexp``) or None."""
    not_before: float | None = None
    """Earliest stamp (seconds since the epoch) shown, or None."""

    def accepts(self, line: LogLine) -> bool:
        """Tell whether `line` passes every filter."""
        if line.level < self.min_level:
            return False
        if self.not_before is not None and line.stamp < self.not_before:
            return False
        if self.node is not None and not node_matches(line.node, self.node):
            return False
        return self.grep is None or self.grep.search(line.message[:MAX_LINE]) is not None


def format_line(line: LogLine, *, colour: bool) -> str:
    """Render `line` as ``HH:MM:SS.mmm LEVEL [node] message`` (continuation lines indented)."""
    clock = time.strftime("%H:%M:%S", time.localtime(line.stamp)) + f".{int(line.stamp * 1000) % 1000:03d}"
    name = LEVEL_NAMES.get(line.level, str(line.level))
    message = line.message.replace("\n", "\n    ")
    text = f"{clock} {name:<5} [{line.node}] {message}"
    if not colour:
        return text
    code = _COLOURS.get(line.level, "")
    return f"{code}{text}{_RESET}" if code else text


def _use_colour(choice: str, stream: TextIO) -> bool:
    if choice != "auto":
        return choice == "always"
    if os.environ.get("NO_COLOR"):
        return False
    isatty: Callable[[], bool] | None = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def run(args: argparse.Namespace) -> int:
    """Print the Log topic's lines that pass the filters until --count lines or Ctrl-C/SIGTERM."""
    if args.count < 0:
        print(f"dbglog logs: --count must be >= 0, not {args.count}", file=sys.stderr)
        return 2
    if args.since is not None and args.since < 0:
        print(f"dbglog logs: --since must be >= 0 seconds, not {args.since:g}", file=sys.stderr)
        return 2
    grep = None
    if args.grep is not None:
        try:
            grep = compile_regex(args.grep).compiled
        except RegexError as exc:
            print(f"dbglog logs: --grep does not compile with RE2: {exc}", file=sys.stderr)
            return 2
    topic = args.topic if args.topic.startswith("/") else "/" + args.topic
    started = time.time()
    filters = LogsFilter(
        min_level=args.level,
        node=args.node,
        grep=grep,
        not_before=None if args.since is None else started - args.since,
    )
    colour = _use_colour(args.color, sys.stdout)
    stop = threading.Event()

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        return _follow(topic, filters, args.count, colour, stop)
    except BrokenPipeError:
        # The reader went away (``| head``): stop quietly, and keep Python from complaining at exit.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return 0
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)


def _follow(topic: str, filters: LogsFilter, count: int, colour: bool, stop: threading.Event) -> int:
    from rcl_interfaces.msg import Log
    from rclpy.executors import SingleThreadedExecutor

    from dbglog._ros._node import PrivateNode
    from dbglog._ros._qos import log_qos
    from dbglog._rosenv import localhost_discovery

    localhost_discovery()
    ros = PrivateNode("dbglog_logs")
    node = ros.node
    pending: list[LogLine] = []  # filled by on_line inside spin_once, on this same thread: no lock

    def on_line(msg: Any) -> None:
        line = LogLine(msg.stamp.sec + msg.stamp.nanosec * 1e-9, int(msg.level), msg.name, msg.msg)
        if filters.accepts(line):
            pending.append(line)

    executor = SingleThreadedExecutor(context=ros.context)
    try:
        node.create_subscription(Log, topic, on_line, log_qos())  # reliable, transient-local, 1000
        executor.add_node(node)
        printed = 0
        first_at: float | None = None
        settled = False
        out = sys.stdout
        while not stop.is_set():
            executor.spin_once(timeout_sec=0.05)
            if not pending:
                continue
            if first_at is None:
                first_at = time.monotonic()
            if not settled and time.monotonic() - first_at < _SETTLE_S:
                continue
            batch = sorted(pending, key=lambda line: line.stamp) if not settled else list(pending)
            pending.clear()
            settled = True
            for line in batch:
                out.write(format_line(line, colour=colour) + "\n")
                printed += 1
                if count and printed >= count:
                    out.flush()
                    return 0
            out.flush()
        return 0
    finally:
        executor.shutdown(timeout_sec=1)
        ros.close()
