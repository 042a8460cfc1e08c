"""``dbglog echo TARGET``: print a tag's or a topic field's values, one per line, from the data engine."""

from __future__ import annotations

import argparse
import os
import sys
import time
from typing import TYPE_CHECKING

from dbglog._ros._tags import TagError, TagName, parse_target
from dbglog._ros._text import format_line
from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S, graph_names

if TYPE_CHECKING:
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import SeriesSnapshot

__all__ = ["HELP", "add_arguments", "format_line", "run", "split_target"]

HELP = "Print the values of a dbglog tag or of a topic field, one per line."

_POLL_S = 0.02
_HINT_AFTER_S = DISCOVERY_HORIZON_S + 0.5
"""Without a value this long, say once on stderr why (nothing publishes it, close matches): not before
discovery can have found every publisher, or the note would blame a topic that is merely not seen yet."""
_SETTLE_QUIET_S = 0.15
"""The kept history has fully arrived once no sample came for this long after the first one, or once a
sample published after echo started arrives (a writer sends its history first, in order)..."""
_SETTLE_MAX_S = 1.0
"""...and at the latest this long after the first sample (clock skew, very fast publishers)."""
_ARRIVAL_SLACK_S = 0.05
"""How much earlier than echo noticed it the first sample may have landed (poll period, engine cycle)."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``echo`` options."""
    parser.add_argument(
        "target",
        help="a dbglog tag (proximity, 速度; a robot's: robot1:proximity; a root tag holding ':' as :a:b) "
        "or a topic with an optional field path: /turtle1/cmd_vel.linear.x, /scan.ranges[3] (rqt style "
        "/turtle1/pose/x works too)",
    )
    parser.add_argument(
        "--count",
        "-n",
        type=int,
        default=0,
        metavar="N",
        help="exit after N values: first the current value (the newest one a latched tag kept), then "
        "the next N-1 as they arrive; 0 (default) runs until Ctrl-C",
    )
    parser.add_argument(
        "--history",
        action="store_true",
        help="start with every value the publishers kept for late subscribers (a dbglog tag keeps at "
        "least its last 100), oldest first, instead of only the newest; --count counts them too",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=None,
        metavar="S",
        help="exit with status 1, saying why, when no value arrives for S seconds (without it, echo "
        "keeps waiting and says on stderr after a few seconds if nothing publishes the target)",
    )
    parser.add_argument("--regex", default="", help="extract a number from text values (first group)")
    parser.add_argument("--stamp", action="store_true", help="prefix each value with its source time")
    parser.add_argument(
        "--file",
        metavar="FILE",
        help="print the target's values from a recording (.mcap file or rosbag2 directory) and exit",
    )


def split_target(target: str, graph_topics: set[str]) -> tuple[str, str] | None:
    """Split TARGET into (topic, field path); None while the graph cannot tell yet where the topic ends.

    A tag (``proximity``, ``速度``, ``robot1:speed``, ``:a:b``: `parse_target`) maps to its topic; topic
    names never contain ``.``, so in a ``/topic`` the first dot starts the field path. A tag's text may
    hold dots: ``tag.field`` is the tag ``tag.field`` when the graph has it, else ``tag`` and its field.
    Without a dot, a ``/topic`` that is not itself on the graph is read rqt-style: the longest prefix
    that is a topic on the graph, the rest a ``/``-separated field path.

    Raises:
        TagError: the tag's topic would be too long for ROS 2.
    """
    target = target.strip()
    whole = parse_target(target)
    if isinstance(whole, TagName):
        if "." not in target or whole.topic in graph_topics:
            return whole.topic, ""
        head, _, path = target.partition(".")
        tag = parse_target(head)
        if isinstance(tag, TagName) and tag.topic in graph_topics:
            return tag.topic, path
        return None
    topic, dot, path = target.partition(".")
    if dot or topic in graph_topics:
        return topic, path
    parts = topic.split("/")
    for cut in range(len(parts) - 1, 1, -1):
        prefix = "/".join(parts[:cut])
        if prefix in graph_topics:
            return prefix, ".".join(parts[cut:])
    return None


def _pending_topic(target: str) -> str:
    """The topic a target whose split waits for the graph is named by (for its hints): ``/a/b/c`` as
    typed, a ``tag.field`` target's tag."""
    head = target.strip().split(".")[0]
    tag = parse_target(head)
    return tag.topic if isinstance(tag, TagName) else head


def _why(engine: Engine, topic: str, snap: SeriesSnapshot | None, waited: float) -> str:
    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    names = {t.name: t for t in engine.topics()}
    if topic not in names:
        why = f"topic {topic} does not exist on the ROS graph (ROS_DOMAIN_ID={domain}) after {waited:g} s"
        hint = _hint(engine, topic)
        return why if hint is None or "not on the ROS graph yet" in hint else f"{why}: {hint}"
    if names[topic].publishers == 0:
        return f"topic {topic} has no publisher (waited {waited:g} s)"
    if snap is not None and snap.reason:
        return f"no value from {topic} in {waited:g} s: {snap.reason}"
    return f"no message on {topic} in {waited:g} s"


def _hint(engine: Engine, topic: str) -> str | None:
    """Say why `topic` has no value when nothing publishes it (None when something does)."""
    from dbglog.viewer._data._suggest import unpublished_reason

    topics = engine.topics()
    if any(t.name == topic and t.publishers for t in topics):
        return None
    return unpublished_reason(topic, graph_names(topics))


def _values(snap: SeriesSnapshot, new: int) -> tuple[list[object], list[float | None]]:
    """Return the `new` newest values of `snap` (oldest first) with their source times."""
    from dbglog.viewer._data._model import ValueKind

    if snap.kind in (ValueKind.NUMBER, ValueKind.BOOL):
        numbers = snap.values[-new:].tolist()
        values: list[object] = (
            [bool(v) for v in numbers]
            if snap.kind == ValueKind.BOOL
            else [int(v) for v in numbers]
            if isinstance(snap.last, int)
            else numbers
        )
        return values, list(snap.times[-new:])
    if snap.kind == ValueKind.TEXT:
        return list(snap.texts[-new:]), list(snap.times[-new:])
    return [snap.last], [snap.last_time]


def _settled(snap: SeriesSnapshot, first_at: float, last_change_at: float, now: float, since: float) -> bool:
    """Tell whether the burst of kept history that follows a subscription has fully arrived."""
    if now - first_at >= _SETTLE_MAX_S or now - last_change_at >= _SETTLE_QUIET_S:
        return True
    return snap.last_time is not None and snap.last_time >= since


def _backlog(snap: SeriesSnapshot, since: float, started: float, history: bool) -> int:
    """Return how many received values to print first.

    Values published before echo started (source time before `started`) are the publishers' kept
    history: of those only the newest is the current value (all of them with --history), and values
    published before the first one arrived (`since`) are taken as that history too. When nothing older
    than echo's start arrived, the publishers started after echo: every value is printed, from the first
    call on (the batches keep seconds of them, so discovery's delay loses none). Arrays keep no times:
    their newest value only.
    """
    import numpy as np

    times = snap.times
    if history:
        return snap.count
    if not len(times):
        return min(1, snap.count)
    if not (times < started).any():
        return len(times)
    kept = np.flatnonzero(times < since)
    return len(times) - int(kept[-1]) if len(kept) else len(times)


def _of_file(args: argparse.Namespace) -> int:
    """Print a target's values from a recording, oldest first (--count: the first N)."""
    import itertools

    from dbglog.record import RecordingError
    from dbglog.record._inspect import echo_lines

    if args.regex or args.history or args.timeout is not None or args.count < 0:
        print("dbglog echo: with --file, only --stamp and --count apply", file=sys.stderr)
        return 2
    lines = echo_lines(
        args.file, args.target, stamp=args.stamp, warn=lambda m: print(f"dbglog echo: {m}", file=sys.stderr)
    )
    try:
        for line in itertools.islice(lines, args.count or None):
            print(line)
    except RecordingError as exc:
        print(f"dbglog echo: {exc}", file=sys.stderr)
        return 1
    except BrokenPipeError:  # `| head`: the reader is gone
        sys.stderr.close()
    return 0


def run(args: argparse.Namespace) -> int:
    """Bind the target and print its newest value, then the following ones, until --count or --timeout."""
    if args.file is not None:
        return _of_file(args)
    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding, Status

    if args.count < 0 or (args.timeout is not None and args.timeout <= 0):
        print("dbglog echo: --count must be >= 0 and --timeout > 0", file=sys.stderr)
        return 2
    printed = 0
    hinted = False
    started_at = time.time()  # a value published from now on is new, however late discovery delivers it

    def hint_once(topic: str) -> None:
        nonlocal hinted
        if hinted or time.monotonic() - started < _HINT_AFTER_S:
            return
        hinted = True
        reason = _hint(engine, topic)
        if reason is not None:
            print(f"dbglog echo: {reason} (still waiting; Ctrl-C to stop)", file=sys.stderr, flush=True)

    try:
        split = split_target(args.target, set())
    except TagError as exc:
        print(f"dbglog echo: {args.target!r} is not a tag: {exc}", file=sys.stderr)
        return 2
    with Engine(node_name="dbglog_echo", hold_tags=False) as engine:
        started = last_value_at = time.monotonic()
        while split is None:  # rqt-style name: wait for the graph to say where the topic ends
            split = split_target(args.target, {t.name for t in engine.topics()})
            waited = time.monotonic() - started
            if split is None and args.timeout is not None and waited > args.timeout:
                topic = _pending_topic(args.target)
                print(f"dbglog echo: {_why(engine, topic, None, args.timeout)}", file=sys.stderr)
                return 1
            if split is None:
                hint_once(_pending_topic(args.target))
            time.sleep(_POLL_S)
        topic, path = split
        binding = Binding(topic, path, args.regex)
        engine.bind(binding)
        seen = 0  # the series count already printed (or skipped as older history)
        first_at: float | None = None  # when the first sample (usually the kept history) arrived
        since = 0.0
        burst_count = 0
        last_change_at = 0.0
        caught_up = False
        last_error = ""
        while True:
            now = time.monotonic()
            snap = engine.snapshot(binding)
            if snap.status == Status.ERROR and snap.reason != last_error:
                last_error = snap.reason
                print(f"dbglog echo: {topic}: {snap.reason}", file=sys.stderr, flush=True)
                if printed == 0 and "type changed" not in snap.reason:
                    return 1
            if not caught_up and snap.count:
                # A latched tag sends its kept history at once: let it land, then start from its newest.
                if first_at is None:
                    first_at = now
                    # The writers send what they kept on matching: values older than its first
                    # arrival are that history, newer ones were published since (print them all).
                    since = time.time() - _ARRIVAL_SLACK_S
                if snap.count != burst_count:
                    burst_count, last_change_at = snap.count, now
                if not _settled(snap, first_at, last_change_at, now, since):
                    time.sleep(_POLL_S)
                    continue
                caught_up = True
                seen = snap.count - _backlog(snap, since, started_at, args.history)
            new = snap.count - seen if caught_up else 0
            if new > 0:
                values, times = _values(snap, new)
                for value, stamp in zip(values, times, strict=False):
                    print(format_line(value, stamp if args.stamp else None), flush=True)
                    printed += 1
                    if args.count and printed >= args.count:
                        return 0
                seen = snap.count
                last_value_at = now
            else:
                if not caught_up:
                    hint_once(topic)
                if args.timeout is not None and now - last_value_at > args.timeout:
                    print(f"dbglog echo: {_why(engine, topic, snap, args.timeout)}", file=sys.stderr)
                    return 1
            time.sleep(_POLL_S)
