"""``dbglog tags``: a table of the live dbglog tags (or every topic) from the viewer's data engine."""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from dbglog._ros._census import Census, discovery_reach, unseen_holders
from dbglog._ros._tags import natural_key, robot_label, tag_of
from dbglog.viewer._data._suggest import DISCOVERY_HORIZON_S

if TYPE_CHECKING:
    import numpy as np
    import numpy.typing as npt

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import SeriesSnapshot, TopicInfo

__all__ = [
    "HELP",
    "add_arguments",
    "format_rate",
    "format_table",
    "format_value",
    "rate_from_times",
    "run",
]

HELP = (
    "List the live dbglog tags (tag as logged, type, rate, last value, status; a robot column when tags "
    "come from robot namespaces); --all lists every topic."
)

_CLEAR = "\x1b[H\x1b[2J"
_POLL_S = 0.05
_DEFAULT_WAIT_S = 8.0
_QUIET_S = 0.5
"""The table prints once no topic or publisher count changed for this long (see `_Graph.settled`)."""
_RESEND_S = 1.2
"""Discovery data a socket dropped (its buffer full) is sent again within a heartbeat period (1 s): the graph
is settled only this long after the engine's discovery sockets last dropped a datagram."""
_QUIET_POLLS = 2
"""The engine's graph polls that must find nothing changed (they come every 0.25 s, or later while it
ingests a burst of kept batches: wall time alone would call the graph quiet between two polls)."""
_VALUE_GRACE_S = 6.0
"""A published tag gets this long to deliver its first value before the table stops waiting for it: a
value usually arrives within 0.5 s of the tag being listed, but 2-3 s when a participant of this host was
just killed (2026-11-28: 2.2 s beside a robot killed with SIGKILL, with or without the discovery profile;
over 4.3 s in a loaded full test run)."""
_VALUE_POLLS = 8
"""A published tag's first value is waited for over at least this many of the engine's graph polls too."""
_BURST_S = 0.3
"""Samples arriving this long after a tag's first one are live ones, not its kept history."""
_RATE_SAMPLES = 50
"""The rate is measured over the newest this many distinct samples."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``tags`` options."""
    parser.add_argument(
        "file",
        nargs="?",
        metavar="FILE",
        help="a recording (.mcap file or rosbag2 directory): list its tags (--all: topics) with type, "
        "count, rate, first and last value, instead of the live ones",
    )
    parser.add_argument("--watch", action="store_true", help="refresh the table until Ctrl-C")
    parser.add_argument("--all", action="store_true", help="list every topic, not only dbglog tags")
    parser.add_argument(
        "--wait",
        type=float,
        default=_DEFAULT_WAIT_S,
        metavar="S",
        help="at most this many seconds for DDS discovery and first values (default %(default)g); "
        "the table prints as soon as the graph has settled (after --settle, usually by a second more) and "
        "every tag has its first value, or says on stderr which tags it gave up on; with no tag at all, "
        "once the graph has settled and no other participant is on this host, else at the discovery horizon",
    )
    parser.add_argument(
        "--settle",
        type=float,
        default=None,
        metavar="S",
        help="the least time given to DDS discovery before the table prints (default: none when discovery "
        "stays on this host, ROS_AUTOMATIC_DISCOVERY_RANGE=LOCALHOST, where every participant is counted "
        f"and waited for; else {DISCOVERY_HORIZON_S:g} s, as one on another host that missed the handshake "
        "shows up at its next announcement)",
    )
    parser.add_argument(
        "--interval", type=float, default=1.0, metavar="S", help="refresh period with --watch (default 1 s)"
    )


def _of_file(args: argparse.Namespace) -> int:
    """Print a recording's table (problems with the file on stderr, the readable part still listed)."""
    from dbglog.record import RecordingError
    from dbglog.record._inspect import tags_table

    if args.watch:
        print("dbglog tags: --watch is for live tags, not a recording", file=sys.stderr)
        return 2
    try:
        table = tags_table(
            args.file, all_topics=args.all, warn=lambda m: print(f"dbglog tags: {m}", file=sys.stderr)
        )
        print(table)
    except RecordingError as exc:
        print(f"dbglog tags: {exc}", file=sys.stderr)
        return 1
    return 0


def format_value(value: object, width: int = 40) -> str:
    """Render a last value for a table cell (numbers compact, arrays summarised, text cut)."""
    if value is None:
        return "-"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        return f"{value:.6g}"
    if isinstance(value, tuple):
        head = ", ".join(f"{v:.4g}" for v in value[:4])
        more = f", … ({len(value)} values)" if len(value) > 4 else ""
        text = f"[{head}{more}]"
    else:
        text = str(value).replace("\n", "⏎")
    return text if len(text) <= width else text[: width - 1] + "…"


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Align `rows` under `header` in plain-text columns."""
    widths = [max(len(str(c)) for c in col) for col in zip(header, *rows, strict=False)]
    lines = [
        "  ".join(str(c).ljust(w) for c, w in zip(row, widths, strict=False)).rstrip()
        for row in [header, *rows]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


@dataclass(slots=True)
class _Seen:
    """What the command watched of one listed topic."""

    listed_at: float
    listed_poll: int = 0
    """The engine's graph polls so far when the topic was listed."""
    first_value_at: float | None = None
    first_count: int = 0
    first_time: float | None = None
    count: int = 0
    arrived_live: bool = False
    """A sample arrived after the kept-history burst: the publisher is alive and sending."""


def rate_from_times(
    times: Sequence[float] | npt.NDArray[np.float64], samples: int = _RATE_SAMPLES
) -> float | None:
    """Return the publishing rate from source times (newest `samples` distinct ones); None under 2."""
    import numpy as np

    t = np.unique(np.asarray(times, dtype=np.float64))
    t = t[~np.isnan(t)][-samples:]
    if len(t) < 2 or t[-1] <= t[0]:
        return None
    return float((len(t) - 1) / (t[-1] - t[0]))


def format_rate(rate: float | None) -> str:
    """Render a rate for a table cell with three significant digits (``5.00 Hz``, ``10.0 Hz``, ``250 Hz``;
    whole numbers from 1000 Hz); `-` when there is none."""
    if rate is None:
        return "-"
    if not rate > 0 or rate >= 1000:
        return f"{rate:.0f} Hz"
    rounded = float(f"{rate:.3g}")
    return f"{rounded:.{max(0, 2 - math.floor(math.log10(rounded)))}f} Hz"


def _observe(
    engine: Engine, topics: list[TopicInfo], seen: dict[str, _Seen], now: float, poll: int = 0
) -> None:
    """Bind new topics and note, per topic, when values first and later arrived."""
    from dbglog.viewer._data._model import Binding

    for info in topics:
        binding = Binding(info.name)
        state = seen.get(info.name)
        if state is None:
            engine.bind(binding)
            state = seen[info.name] = _Seen(now, poll)
        snap = engine.snapshot(binding)
        if not snap.count or snap.count == state.count:
            continue
        if state.first_value_at is None:
            state.first_value_at, state.first_count, state.first_time = now, snap.count, snap.last_time
        elif now - state.first_value_at >= _BURST_S:
            state.arrived_live = True
        state.count = snap.count


def _judge(engine: Engine, snap: SeriesSnapshot, state: _Seen, now: float) -> tuple[bool, float | None]:
    """Return (live, rate) of a topic with values: stale topics have no rate.

    The engine judges age by arrival; a latched tag's kept history arrives now however old it is, so
    a topic that sent nothing after that burst is stale once watched for the stale time (before that,
    the source time of its newest value decides).
    """
    from dbglog.viewer._data._model import Status, ValueKind

    if snap.status == Status.STALE:
        live = False
    elif state.arrived_live:
        live = True
    elif state.first_value_at is not None and now - state.first_value_at >= engine.stale_after:
        live = False
    else:
        live = snap.last_time is None or time.time() - snap.last_time <= engine.stale_after
    if not live:
        return False, None
    if snap.kind in (ValueKind.NUMBER, ValueKind.BOOL, ValueKind.TEXT) and len(snap.times):
        return True, rate_from_times(snap.times)
    # Arrays keep no times: count the samples between the first newest time seen and the last one.
    n = snap.count - state.first_count
    if state.first_time is None or snap.last_time is None or n <= 0 or snap.last_time <= state.first_time:
        return True, None
    return True, n / (snap.last_time - state.first_time)


def _robots(topics: list[TopicInfo], show_all: bool) -> bool:
    """Whether the table has a robot column: some listed tag is in a robot's namespace (not with --all)."""
    return not show_all and any(t.robot for t in topics)


def _header(topics: list[TopicInfo], show_all: bool) -> list[str]:
    head = ["topic" if show_all else "tag", "type", "rate", "last value", "status"]
    return ["robot", *head] if _robots(topics, show_all) else head


def _order(info: TopicInfo, show_all: bool) -> tuple[object, ...]:
    """A row's place: by robot, then by the tag as logged (by topic name with --all), in natural order."""
    tag = info.tag_name
    if show_all or tag is None:
        return ((), natural_key(info.name))
    return (natural_key(tag.robot), natural_key(tag.text))


def _rows(engine: Engine, topics: list[TopicInfo], seen: dict[str, _Seen], show_all: bool) -> list[list[str]]:
    from dbglog.viewer._data._model import Binding, Status

    now = time.monotonic()
    robots = _robots(topics, show_all)
    rows = []
    # Natural order (s2 before s10); each robot's tags together, the root's first.
    topics = sorted(topics, key=lambda t: _order(t, show_all))
    for info in topics:
        tag = info.tag_name
        name = info.name if show_all or tag is None else (tag.text if robots else tag.label)
        type_name = info.types[0] if info.types else "?"
        snap = engine.snapshot(Binding(info.name))
        state = seen.get(info.name)
        if state is None or (snap.status == Status.ERROR and "several fields" in snap.reason):
            rate, value, status = "-", "-", "-" if state is not None else "unbound"
        elif snap.status == Status.ERROR:
            rate, value, status = "-", format_value(snap.last), f"error: {snap.reason}"
        elif not snap.count:
            rate, value, status = "-", "-", str(Status.WAITING)
        else:
            live, hz = _judge(engine, snap, state, now)
            rate = format_rate(hz)
            value = format_value(snap.last)
            status = str(Status.LIVE if live else Status.STALE)
        row = [name, type_name, rate, value, status]
        rows.append([robot_label(info.robot) or "-", *row] if robots else row)
    return rows


def _listed(engine: Engine, show_all: bool) -> list[TopicInfo]:
    return [t for t in engine.topics() if show_all or t.tag is not None]


def _waiting_for(
    engine: Engine, topics: list[TopicInfo], seen: dict[str, _Seen], now: float, poll: int, grace: float
) -> list[str]:
    """Return the published topics without a first value that are still within `grace` seconds (and
    `_VALUE_POLLS` engine graph polls) of being listed."""
    from dbglog.viewer._data._model import Binding, Status

    return [
        t.name
        for t in topics
        if t.publishers
        and seen[t.name].first_value_at is None
        and (now - seen[t.name].listed_at < grace or poll - seen[t.name].listed_poll < _VALUE_POLLS)
        and engine.snapshot(Binding(t.name)).status != Status.ERROR  # e.g. several fields (--all)
    ]


def _undecided(engine: Engine, topics: list[TopicInfo], seen: dict[str, _Seen]) -> bool:
    """True while the engine is still taking a backlog and some tag with values would be called stale.

    A robot's kept batches are taken oldest first, in 50 ms slices: a tag judged on the first slice (its
    newest value then seconds old) was called stale, though its newer values were in the next slice. The
    engine's word is read after the snapshots `_observe` read, so a take under way then is seen here.
    Once every tag with values is live, the table prints without waiting for the rest of the backlog
    (beside two robots of 300 tags that takes seconds): their last values may then be older than the
    robot's newest (docs/engine.md, *Discovery*).
    """
    from dbglog.viewer._data._model import Binding

    if not engine.catching_up:
        return False
    now = time.monotonic()
    for info in topics:
        state = seen[info.name]
        if (
            state.first_value_at is not None
            and not _judge(engine, engine.snapshot(Binding(info.name)), state, now)[0]
        ):
            return True
    return False


def _least_wait(args: argparse.Namespace, census: Census | None) -> float:
    """Return the least seconds given to discovery: --settle, else none where the census counts every
    participant discovery can reach (this host's), else the discovery horizon."""
    if args.settle is not None:
        return float(args.settle)
    if census is not None and census.unseen is not None and discovery_reach() == "host":
        return 0.0
    return DISCOVERY_HORIZON_S


def _none_to_come(census: Census | None, waited: float) -> bool:
    """With no tag listed and the graph settled: whether none can still come, as this host has no
    participant of the domain but this command's, or the discovery horizon passed (a participant found
    lists its topics moments later; one on another host can miss the handshake)."""
    return (census is not None and census.local == 1) or waited >= DISCOVERY_HORIZON_S


@dataclass(slots=True)
class _Graph:
    """How the graph moved, poll by poll of the engine, while the command waited for it to settle."""

    started: float
    signature: frozenset[tuple[str, int]] | None = None
    poll: int = -1
    """The engine's graph polls so far, and when the last one was first seen."""
    polled_at: float = -math.inf
    changed_poll: int = 0
    changed_at: float = -math.inf
    drops: int = 0
    dropped_at: float = -math.inf

    def watch(self, topics: list[TopicInfo], census: Census | None, poll: int, now: float) -> None:
        """Note a new poll, a change of topics or publisher counts, a datagram the discovery sockets lost."""
        if poll != self.poll:
            self.poll, self.polled_at = poll, now
        current = frozenset((t.name, t.publishers) for t in topics)
        if current != self.signature:
            self.signature, self.changed_poll, self.changed_at = current, poll, now
        if census is not None and census.dropped is not None and census.dropped != self.drops:
            self.drops, self.dropped_at = census.dropped, now

    def settled(self, args: argparse.Namespace, census: Census | None, now: float) -> bool:
        """Whether discovery is done: the least wait passed; every participant of this host is found (or the
        horizon passed); `_QUIET_POLLS` polls over `_QUIET_S` found nothing changed; and one poll came
        `_RESEND_S` after the discovery sockets last dropped a datagram."""
        waited = now - self.started
        found = census is None or not census.unseen or waited >= DISCOVERY_HORIZON_S
        return (
            waited >= _least_wait(args, census)
            and found
            and self.poll - self.changed_poll >= _QUIET_POLLS
            and self.polled_at - self.changed_at >= _QUIET_S
            and self.polled_at - self.dropped_at >= _RESEND_S
        )


def _settle(engine: Engine, args: argparse.Namespace, seen: dict[str, _Seen]) -> list[TopicInfo]:
    """Wait until discovery settled and first values arrived (at most --wait s); say what it gave up on."""
    started = time.monotonic()
    deadline = started + args.wait
    graph = _Graph(started)
    early = False
    while True:
        now = time.monotonic()
        poll = engine.stats().graph_polls  # first: the census and the topics are then as new as this poll
        census = engine.census()
        topics = _listed(engine, args.all)
        _observe(engine, topics, seen, now, poll)
        graph.watch(topics, census, poll, now)
        if now >= deadline:
            early = bool(topics) and not graph.settled(args, census, now)
            break
        waiting = _waiting_for(engine, topics, seen, now, poll, _VALUE_GRACE_S)
        if topics:
            if graph.settled(args, census, now) and not waiting and not _undecided(engine, topics, seen):
                break
        elif graph.settled(args, census, now) and _none_to_come(census, now - started):
            break
        time.sleep(_POLL_S)
    waiting = _waiting_for(engine, topics, seen, now, poll, math.inf)
    waited = f"{now - started:.1f} s"
    if waiting:
        names = ", ".join(t if args.all else (tag_of(t) or t) for t in waiting[:8])
        more = f" and {len(waiting) - 8} more" if len(waiting) > 8 else ""
        limit = " (the --wait limit)" if now >= deadline else ""
        print(
            f"dbglog tags: gave up after {waited}{limit} waiting for a first value from {names}{more}: "
            "published, but nothing arrived (a volatile publisher that has not published since?)",
            file=sys.stderr,
        )
    if early:
        print(
            f"dbglog tags: the ROS graph was still changing when --wait ran out ({waited}); "
            "the table may be incomplete (try a longer --wait)",
            file=sys.stderr,
        )
    if census is not None and census.unseen:
        domain = os.environ.get("ROS_DOMAIN_ID", "0")
        some = "1 DDS participant" if census.unseen == 1 else f"{census.unseen} DDS participants"
        holders = unseen_holders(census)
        which = f" ({'; '.join(holders[:8])}{' and more' if len(holders) > 8 else ''})" if holders else ""
        print(
            f"dbglog tags: {some} on this host (ROS_DOMAIN_ID={domain}) not found in {waited}{which}: "
            "the tags published there are missing from the table",
            file=sys.stderr,
        )
    return topics


def _empty_message(engine: Engine, show_all: bool, waited: float) -> str:
    from dbglog.viewer._data._suggest import EMPTY_GRAPH_HINT, graph_names

    domain = os.environ.get("ROS_DOMAIN_ID", "0")
    what = "topics" if show_all else "dbglog tags (/rosdashboard/...)"
    text = f"no {what} on the ROS graph (ROS_DOMAIN_ID={domain}, waited {waited:g} s)"
    return text if graph_names(engine.topics()) else f"{text}: {EMPTY_GRAPH_HINT}"


def run(args: argparse.Namespace) -> int:
    """Print the table once (or keep refreshing it with --watch); of a recording with FILE."""
    if args.file is not None:
        return _of_file(args)
    from dbglog.viewer._data._engine import Engine

    if args.wait < 0 or (args.settle is not None and args.settle < 0) or args.interval <= 0:
        print("dbglog tags: --wait must be >= 0, --settle must be >= 0 and --interval > 0", file=sys.stderr)
        return 2
    seen: dict[str, _Seen] = {}
    with Engine(node_name="dbglog_tags", hold_tags=False, census=True) as engine:
        started = time.monotonic()
        topics = _settle(engine, args, seen)
        while True:
            if topics:
                table = format_table(_header(topics, args.all), _rows(engine, topics, seen, args.all))
            else:
                table = _empty_message(engine, args.all, time.monotonic() - started)
            if not args.watch:
                print(table)
                return 0
            prefix = _CLEAR if sys.stdout.isatty() else "\n"
            print(f"{prefix}{time.strftime('%H:%M:%S')}  {len(topics)} shown\n{table}", flush=True)
            until = time.monotonic() + args.interval
            while True:
                now = time.monotonic()
                topics = _listed(engine, args.all)
                _observe(engine, topics, seen, now)
                if now >= until:
                    break
                time.sleep(min(_POLL_S, until - now))
