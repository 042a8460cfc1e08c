"""``dbglog watch FILE:LINE EXPR...``: print variables of running Python processes at a line, live.

Arms the watch in every watchable process that has the line (and in those that start later), prints one
line per hit per expression (``EXPR = VALUE``), and removes the watch on exit, Ctrl-C included.
``dbglog watch --list`` lists the watchable processes and their watches.
"""

from __future__ import annotations

import argparse
import os
import socket
import sys
import time
from typing import TYPE_CHECKING

from dbglog._ros._text import format_line
from dbglog.watch._protocol import DEFAULT_MAX_CPU, MAX_CPU_LIMIT, MIN_CPU_LIMIT

if TYPE_CHECKING:
    from dbglog.watch.client import Process, Sample, Watch, WatchClient, WatchEvent, WatchStatus

__all__ = ["HELP", "add_arguments", "format_sample", "parse_target", "run"]

HELP = "Watch variables at a line of running Python processes: print them live and publish them as tags."

_POLL_S = 0.02
_HINT_AFTER_S = 3.0
"""Without a process that armed the watch this long, say once why on stderr."""
_LIST_MAX_S = 8.0
"""``--list`` waits this long at most for a first watchable process (discovery on a busy machine)."""
_DELIVERY_S = 5.0
"""After every process ended the watch, how long its last hits may still take to arrive."""
_NOT_ARMED = frozenset({"no_file", "no_line", "expr_error", "refused"})


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``watch`` options."""
    parser.add_argument("target", nargs="?", metavar="FILE:LINE", help="the line: a path or a unique suffix")
    parser.add_argument("exprs", nargs="*", metavar="EXPR", help="what to read there: x, self.pose.x, d['k']")
    parser.add_argument("--when", metavar="COND", help="publish only the hits where COND is true")
    parser.add_argument(
        "--throttle",
        type=float,
        metavar="S",
        help="at most one hit per S seconds (default: every hit up to 1 kHz; 0: every hit, no cap)",
    )
    parser.add_argument("--count", "-n", type=int, metavar="N", help="stop after N hits")
    parser.add_argument(
        "--timeout", type=float, metavar="S", help="stop (status 1) after S seconds without a hit"
    )
    parser.add_argument("--node", metavar="NODE", help="only processes with an rclpy node of this name")
    parser.add_argument("--label", metavar="LABEL", help="publish on watch/LABEL (default: the expression)")
    parser.add_argument(
        "--max-cpu",
        type=float,
        default=DEFAULT_MAX_CPU * 100,
        metavar="PCT",
        help=f"disarm when the watch takes more than PCT %% of a CPU in the program (default "
        f"{DEFAULT_MAX_CPU * 100:g}; {MIN_CPU_LIMIT * 100:g} to {MAX_CPU_LIMIT * 100:g})",
    )
    parser.add_argument("--stamp", action="store_true", help="prefix each line with the hit's time")
    parser.add_argument("--list", action="store_true", help="list the watchable processes and their watches")


def parse_target(target: str) -> tuple[str, int]:
    """Split ``FILE:LINE``.

    Raises:
        ValueError: no ``:LINE``, or LINE is not a positive number.
    """
    file, colon, line = target.rpartition(":")
    if not colon or not file:
        raise ValueError(f"{target!r} is not FILE:LINE")
    try:
        number = int(line)
    except ValueError:
        raise ValueError(f"{line!r} in {target!r} is not a line number") from None
    if number < 1:
        raise ValueError(f"line {number} in {target!r}: lines start at 1")
    return file, number


def _value_text(value: object) -> str:
    if isinstance(value, dict):
        return "{" + ", ".join(f"{k}: {_value_text(v)}" for k, v in value.items()) + "}"
    if isinstance(value, list):
        return "[" + ", ".join(_value_text(v) for v in value) + "]"
    return format_line(value)


def format_sample(expr: str, value: object, stamp_ns: int | None = None, who: str = "") -> str:
    """Render one hit of one expression: ``[who] [stamp] EXPR = VALUE``."""
    stamp = f"{stamp_ns / 1e9:.6f} " if stamp_ns is not None else ""
    prefix = f"[{who}] " if who else ""
    return f"{prefix}{stamp}{expr} = {_value_text(value)}"


def _group(samples: list[Sample]) -> list[tuple[Sample, object]]:
    """Merge the keys of a dict value of one hit into one value (a dict, keys as their sub-tags say)."""
    out: list[tuple[Sample, object]] = []
    for sample in samples:
        if not sample.key:
            out.append((sample, sample.value))
            continue
        last = out[-1] if out else None
        if (
            last is not None
            and isinstance(last[1], dict)
            and last[0].agent == sample.agent
            and last[0].stamp_ns == sample.stamp_ns
            and last[0].expr == sample.expr
        ):
            target = last[1]
        else:
            target = {}
            out.append((sample, target))
        parts = sample.key.split("/")
        for part in parts[:-1]:
            nested = target.setdefault(part, {})
            target = nested if isinstance(nested, dict) else {}
        target[parts[-1]] = sample.value
    return out


def _who(process: Process | None, pid: int) -> str:
    return f"{process.name} (pid {pid})" if process is not None else f"pid {pid}"


def _settled(client: WatchClient) -> list[Process]:
    """The processes, once discovery has settled: none new for a second after the discovery window and
    every watchable node on the graph announced (given up on after `_LIST_MAX_S`)."""
    processes = client.wait_for_processes()
    started = last_change = time.monotonic()
    while time.monotonic() - started < _LIST_MAX_S:
        time.sleep(0.1)
        now = client.processes()
        if [p.agent for p in now] != [p.agent for p in processes]:
            processes, last_change = now, time.monotonic()
        elif processes and time.monotonic() - last_change >= 1.0 and not client.discovering():
            break
    return processes


def _list(client: WatchClient) -> int:
    here = socket.gethostname()
    processes = [p for p in _settled(client) if not (p.pid == os.getpid() and p.host == here)]
    if not processes:
        print(
            "no watchable process (a Python process is watchable when started with dbglog run, or with "
            "DBGLOG_WATCH=1 and importing dbglog)",
            file=sys.stderr,
        )
        return 1
    rows = [("PID", "HOST", "NODES", "PROGRAM", "WATCHES")]
    for p in processes:
        watches = "; ".join(f"{w.file}:{w.line} {', '.join(w.exprs)}" for w in p.watches) or "-"
        rows.append((str(p.pid), p.host, ", ".join(p.nodes) or "-", " ".join(p.program) or "-", watches))
    widths = [max(len(r[i]) for r in rows) for i in range(4)]
    for row in rows:
        print("  ".join(c.ljust(w) for c, w in zip(row[:4], widths, strict=True)) + "  " + row[4])
    return 0


class _Session:
    """One ``dbglog watch`` run: what it printed and what it said."""

    def __init__(self, args: argparse.Namespace, client: WatchClient, watch: Watch, target: str) -> None:
        self.args = args
        self.client = client
        self.watch = watch
        self.target = target
        self.hits: set[tuple[str, int]] = set()
        self.started = self.last_hit = time.monotonic()
        self.hinted = False
        self.ended_at: float | None = None
        self.names: dict[str, Process] = {}

    def say(self, text: str) -> None:
        print(f"dbglog watch: {text}", file=sys.stderr, flush=True)

    def process(self, agent: str) -> Process | None:
        if agent not in self.names:
            for p in self.client.processes():
                self.names[p.agent] = p
        return self.names.get(agent)

    def on_event(self, event: WatchEvent) -> None:
        who = _who(self.process(event.agent), event.pid)
        if event.kind == "tag":
            return
        if event.kind == "error":
            self.say(f"{who}: {event.message}")
            return
        state = event.state
        if state == "armed":
            tags = ", ".join(t for t in self.watch.tags().get(event.agent, ()) if t)
            self.say(f"armed in {who} at {self.target} ({event.message}); tags {tags}")
        elif state == "gone":
            self.say(f"{who} exited; the watch is armed again when the program starts again (Ctrl-C to stop)")
        elif state in _NOT_ARMED:
            self.say(f"not armed in {who}: {event.message}")
        elif event.message:
            self.say(f"{who}: {event.message}")

    def print_samples(self, samples: list[Sample]) -> bool:
        """Print them; True once --count hits were printed."""
        many = len({s.agent for s in self.watch.armed}) > 1
        for sample, value in _group(samples):
            hit = (sample.agent, sample.stamp_ns)
            if hit not in self.hits:
                if self.args.count is not None and len(self.hits) >= self.args.count:
                    return True
                self.hits.add(hit)
            who = _who(self.process(sample.agent), sample.pid) if many else ""
            stamp = sample.stamp_ns if self.args.stamp else None
            print(format_sample(self.args.exprs[sample.expr], value, stamp, who), flush=True)
            self.last_hit = time.monotonic()
        return self.args.count is not None and len(self.hits) >= self.args.count

    def verdict(self) -> int | None:
        """An exit status once there is nothing more to wait for, else None."""
        statuses = list(self.watch.status().values())
        now = time.monotonic()
        if any(s.state == "armed" for s in statuses):
            return None
        ended = [s for s in statuses if s.state in ("done", "cpu")]
        if ended and not any(s.state == "asking" for s in statuses):
            # The hits it sent may still be on their way (a new batch writer is being discovered).
            sent = sum(s.stats.get("sent", 0) for s in ended)
            if self.ended_at is None:
                self.ended_at = now
            if len(self.hits) < sent and now - self.ended_at < _DELIVERY_S:
                return None
            if len(self.hits) < sent:
                self.say(
                    f"{sent - len(self.hits)} of the {sent} hits sent never arrived in {_DELIVERY_S:g} s"
                )
                return 1
            return 0 if all(s.state == "done" for s in ended) else 1
        if now - self.started < _HINT_AFTER_S:
            return None
        wrong = [s for s in statuses if s.state in ("no_line", "expr_error")]
        if wrong and not any(s.state == "asking" for s in statuses):
            return 1
        if not self.hinted:
            self.hinted = True
            self.hint(statuses)
        return None

    def hint(self, statuses: list[WatchStatus]) -> None:
        processes = self.client.processes()
        if not processes:
            self.say(
                "no watchable process on this ROS domain: a Python process is watchable when started with "
                "dbglog run, or with DBGLOG_WATCH=1 and importing dbglog; still waiting (Ctrl-C to stop)"
            )
        elif not statuses:
            names = ", ".join(_who(p, p.pid) for p in processes)
            self.say(
                f"no watchable process matches --node {self.args.node} (watchable: {names}); still waiting"
            )
        else:
            self.say(f"no watchable process has {self.target} loaded yet; still waiting (Ctrl-C to stop)")

    def summary(self) -> None:
        for status in self.watch.status().values():
            stats = status.stats
            if not stats:
                continue
            extra = [f"{stats[k]} {label}" for k, label in _SUMMARY if stats.get(k)]
            if extra:
                who = _who(self.process(status.agent), status.pid)
                self.say(
                    f"{who}: {stats.get('hits', 0)} hits, {stats.get('sent', 0)} sent, " + ", ".join(extra)
                )


_SUMMARY = (
    ("throttled", "over the rate limit (counted, not sent)"),
    ("filtered", "skipped by --when"),
    ("dropped", "dropped (queue full)"),
    ("errors", "with errors"),
)


def run(args: argparse.Namespace) -> int:
    """Arm the watch, print its values until --count, --timeout or Ctrl-C, then disarm it."""
    from dbglog.watch.client import WatchClient, WatchError, WatchSpec

    if args.list:
        with WatchClient() as client:
            return _list(client)
    if not args.target or not args.exprs:
        print("dbglog watch: give FILE:LINE and at least one expression (or --list)", file=sys.stderr)
        return 2
    try:
        file, line = parse_target(args.target)
    except ValueError as exc:
        print(f"dbglog watch: {exc}", file=sys.stderr)
        return 2
    if args.timeout is not None and args.timeout <= 0:
        print("dbglog watch: --timeout must be > 0", file=sys.stderr)
        return 2
    spec = WatchSpec(
        file=file,
        line=line,
        exprs=tuple(args.exprs),
        when=args.when,
        throttle=args.throttle,
        count=args.count,
        label=args.label,
        node=args.node,
        max_cpu=args.max_cpu / 100.0,
    )
    try:
        spec.check()
    except WatchError as exc:
        print(f"dbglog watch: {exc}", file=sys.stderr)
        return 2
    with WatchClient(values=True) as client:
        watch = client.arm(spec)
        session = _Session(args, client, watch, args.target)
        try:
            while True:
                for event in watch.events():
                    session.on_event(event)
                if session.print_samples(watch.samples()):
                    return 0
                status = session.verdict()
                if status is not None:
                    return status
                if args.timeout is not None and time.monotonic() - session.last_hit > args.timeout:
                    armed = len(watch.armed)
                    session.say(
                        f"no hit of {args.target} in {args.timeout:g} s (armed in {armed} process(es))"
                    )
                    return 1
                time.sleep(_POLL_S)
        except BrokenPipeError:  # `| head`: the reader is gone
            sys.stderr.close()
            return 0
        finally:
            watch.disarm()
            session.summary()
