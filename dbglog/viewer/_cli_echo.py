"""``dbglog echo TARGET``: print a tag's or a topic field's values, one per line, from the data engine."""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dbglog.viewer._engine import Engine
    from dbglog.viewer._model import SeriesSnapshot

__all__ = ["HELP", "add_arguments", "format_line", "run", "split_target"]

HELP = "Print the values of a dbglog tag or of a topic field, one per line."

_POLL_S = 0.02
_TAG_PREFIX = "/rosdashboard/"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``echo`` options."""
    parser.add_argument(
        "target",
        help="a dbglog tag (proximity) or a topic with an optional field path: "
        "/turtle1/cmd_vel.linear.x, /scan.ranges[3] (rqt style /turtle1/pose/x works too)",
    )
    parser.add_argument("--count", "-n", type=int, default=0, metavar="N", help="exit after N values")
    parser.add_argument(
        "--timeout",
        type=float,
        default=None,
        metavar="S",
        help="exit with status 1, saying why, when no value arrives for S seconds",
    )
    parser.add_argument("--regex", default="", help="extract a number from text values (first group)")
    parser.add_argument("--stamp", action="store_true", help="prefix each value with its source time")


def split_target(target: str, graph_topics: set[str]) -> tuple[str, str] | None:
    """Split TARGET into (topic, field path); None while a slash-style target matches no topic yet.

    A tag maps to ``/rosdashboard/<tag>``. Topic names never contain ``.``, so the first dot starts
    the field path. Without a dot, a name that is not itself a topic is read rqt-style: the longest
    prefix that is a topic on the graph, the rest a ``/``-separated field path.
    """
    target = target.strip()
    if not target.startswith("/"):
        tag, _, path = target.partition(".")
        return _TAG_PREFIX + tag, path
    topic, dot, path = target.partition(".")
    if dot or topic in graph_topics:
        return topic, path
    parts = topic.split("/")
    for cut in range(len(parts) - 1, 1, -1):
        prefix = "/".join(parts[:cut])
        if prefix in graph_topics:
            return prefix, ".".join(parts[cut:])
    return None


def format_line(value: object, stamp: float | None = None) -> str:
    """Render one value for a line of output."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = repr(value)
    elif isinstance(value, tuple):
        text = "[" + ", ".join(repr(v) for v in value) + "]"
    else:
        text = str(value)
    return text if stamp is None else f"{stamp:.6f} {text}"


def _why(engine: Engine, topic: str, snap: SeriesSnapshot | None, waited: float) -> str:
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    names = {t.name: t for t in engine.topics()}
    if topic not in names:
        return f"topic {topic} does not exist on the ROS graph (ROS_DOMAIN_ID={domain}) after {waited:g} s"
    if names[topic].publishers == 0:
        return f"topic {topic} has no publisher (waited {waited:g} s)"
    if snap is not None and snap.reason:
        return f"no value from {topic} in {waited:g} s: {snap.reason}"
    return f"no message on {topic} in {waited:g} s"


def run(args: argparse.Namespace) -> int:
    """Bind the target and print its new values until --count or --timeout ends it."""
    from dbglog.viewer._engine import Engine
    from dbglog.viewer._model import Binding, Status, ValueKind

    if args.count < 0 or (args.timeout is not None and args.timeout <= 0):
        print("dbglog echo: --count must be >= 0 and --timeout > 0", file=sys.stderr)
        return 2
    printed = 0
    with Engine(node_name="dbglog_echo") as engine:
        started = last_value_at = time.monotonic()
        split = split_target(args.target, set())
        while split is None:  # rqt-style name: wait for the graph to say where the topic ends
            split = split_target(args.target, {t.name for t in engine.topics()})
            waited = time.monotonic() - started
            if split is None and args.timeout is not None and waited > args.timeout:
                topic = args.target.split(".")[0]
                print(f"dbglog echo: {_why(engine, topic, None, args.timeout)}", file=sys.stderr)
                return 1
            time.sleep(_POLL_S)
        topic, path = split
        binding = Binding(topic, path, args.regex)
        engine.bind(binding)
        seen = 0
        last_error = ""
        while True:
            snap = engine.snapshot(binding)
            if snap.status == Status.ERROR and snap.reason != last_error:
                last_error = snap.reason
                print(f"dbglog echo: {topic}: {snap.reason}", file=sys.stderr, flush=True)
                if printed == 0 and "type changed" not in snap.reason:
                    return 1
            new = snap.count - seen
            if new > 0:
                if snap.kind in (ValueKind.NUMBER, ValueKind.BOOL):
                    numbers = snap.values[-new:].tolist()
                    values: list[object] = (
                        [bool(v) for v in numbers]
                        if snap.kind == ValueKind.BOOL
                        else [int(v) for v in numbers]
                        if isinstance(snap.last, int)
                        else numbers
                    )
                    times: list[float | None] = list(snap.times[-new:])
                elif snap.kind == ValueKind.TEXT:
                    values, times = list(snap.texts[-new:]), list(snap.times[-new:])
                else:
                    values, times = [snap.last], [snap.last_time]
                for value, stamp in zip(values, times, strict=False):
                    print(format_line(value, stamp if args.stamp else None), flush=True)
                    printed += 1
                    if args.count and printed >= args.count:
                        return 0
                seen = snap.count
                last_value_at = time.monotonic()
            elif args.timeout is not None and time.monotonic() - last_value_at > args.timeout:
                print(f"dbglog echo: {_why(engine, topic, snap, args.timeout)}", file=sys.stderr)
                return 1
            time.sleep(_POLL_S)
