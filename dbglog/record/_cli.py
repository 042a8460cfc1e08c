"""``dbglog record``: record tags and topics into an MCAP file (ROS 2 profile), or a RAM window on demand."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import time
from types import FrameType

from dbglog._sched import CpuPolicy, add_cpu_argument, apply_cpu_argument

__all__ = ["HELP", "add_arguments", "run"]

HELP = "Record dbglog tags and ROS topics into an MCAP file (ROS 2 profile) until Ctrl-C or SIGTERM."

_EPILOG = """\
TARGET is a dbglog tag (proximity -> /rosdashboard/proximity and its sub-tags) or a topic (/odom).
Without TARGET: every dbglog tag (also those appearing later), the hidden /_dbglog/samples batch topic
(every sample with its source time) and /rosout. With or without TARGET: /parameter_events (every
parameter change on the graph) and /_dbglog/markers (the viewer's user markers), which a replay shows on
its timeline (--no-events leaves them out). A tag that only dbglog SDK nodes publish is written
to its topic from the batches (every sample) rather than subscribed. A live summary is printed on
stderr every second; the last line says whether messages were lost and where.

Snapshot mode (--snapshot SECONDS) keeps the last SECONDS in RAM and writes nothing until it receives
SIGUSR1 (kill -USR1 <pid>): each signal writes the window to a new file named after -o with the time
added (run-20260101-120000.mcap). The summary counts what a snapshot would write now (the samples of
the batches held included) and what left the window. Ctrl-C or SIGTERM ends it without writing.
"""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``record`` options."""
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = _EPILOG
    parser.add_argument("targets", nargs="*", metavar="TARGET", help="tags or /topics to record")
    parser.add_argument("-o", "--output", required=True, metavar="FILE", help="the .mcap file to write")
    parser.add_argument("--all", action="store_true", help="record every topic on the graph")
    parser.add_argument("--force", action="store_true", help="overwrite FILE if it exists")
    parser.add_argument(
        "--no-batch",
        action="store_true",
        help="leave out /_dbglog/samples (smaller files; tags then hold what their own topics carry)",
    )
    parser.add_argument(
        "--no-events",
        action="store_true",
        help="leave out /parameter_events and /_dbglog/markers (parameter changes and user markers) unless "
        "named as targets (--all records every topic)",
    )
    parser.add_argument(
        "--snapshot",
        type=float,
        metavar="SECONDS",
        help="keep the last SECONDS in RAM; write them to a new timestamped file on SIGUSR1",
    )
    parser.add_argument(
        "--duration", type=float, metavar="S", help="stop by itself after S seconds (default: never)"
    )
    parser.add_argument(
        "--queue-depth",
        type=int,
        default=None,
        metavar="N",
        help="messages each topic may hold while waiting to be written (default: 1000)",
    )
    add_cpu_argument(
        parser,
        CpuPolicy.NORMAL,
        "how the recorder shares the CPU with the robot: normal (default) or background (Linux's "
        "SCHED_IDLE: a robot thread that wakes up takes the CPU from it at once; on a machine kept busy, "
        "messages then wait, and past --queue-depth they may be dropped (the summary says how often a "
        "queue was full)",
    )


def _human(n: float) -> str:
    for unit in ("B", "kB", "MB", "GB"):
        if abs(n) < 1000 or unit == "GB":
            return f"{n:.0f} {unit}" if unit == "B" else f"{n:.1f} {unit}"
        n /= 1000
    return f"{n:.1f} GB"  # pragma: no cover


def _snapshot_path(base: str, taken: set[str]) -> str:
    stem, ext = os.path.splitext(base)
    stamp = time.strftime("%Y%m%d-%H%M%S")
    path = f"{stem}-{stamp}{ext or '.mcap'}"
    k = 1
    while path in taken or os.path.exists(path):
        k += 1
        path = f"{stem}-{stamp}-{k}{ext or '.mcap'}"
    taken.add(path)
    return path


def run(args: argparse.Namespace) -> int:
    """Record until Ctrl-C/SIGTERM (or --duration); finalise the file; return the exit code."""
    from dbglog.record._recorder import DEFAULT_DEPTH, Recorder, parse_targets
    from dbglog.record._writer import McapWriter, RecordingError

    def say(message: str) -> None:
        print(f"dbglog record: {message}", file=sys.stderr, flush=True)

    try:
        targets = parse_targets(
            args.targets, everything=args.all, batch=not args.no_batch, events=not args.no_events
        )
    except ValueError as exc:
        say(str(exc))
        return 2
    if args.snapshot is not None and not args.snapshot > 0:
        say(f"--snapshot must be a positive number of seconds, not {args.snapshot}")
        return 2
    depth = DEFAULT_DEPTH if args.queue_depth is None else args.queue_depth
    if depth < 1:
        say(f"--queue-depth must be at least 1, not {depth}")
        return 2
    apply_cpu_argument(args.cpu, "dbglog record")  # before rclpy starts its threads: they inherit it
    writer = None
    if args.snapshot is None:
        try:
            writer = McapWriter(args.output, force=args.force)
        except RecordingError as exc:
            say(str(exc))
            return 1
    recorder = Recorder(targets, writer, window_s=args.snapshot, depth=depth)
    recorder.warn = say
    requests: list[int] = []

    def on_stop(signum: int, _frame: FrameType | None) -> None:
        recorder.stop()

    def on_usr1(signum: int, _frame: FrameType | None) -> None:
        requests.append(signum)

    signal.signal(signal.SIGINT, on_stop)
    signal.signal(signal.SIGTERM, on_stop)
    if args.snapshot is not None:
        signal.signal(signal.SIGUSR1, on_usr1)
    tty = sys.stderr.isatty()
    started = time.monotonic()
    last = [started, 0]
    written: set[str] = set()

    def tick() -> None:
        now = time.monotonic()
        stats = recorder.stats
        rate = (stats.messages - last[1]) / max(1e-6, now - last[0])
        last[0], last[1] = now, stats.messages
        if writer is not None:
            size = writer.size
            line = (
                f"{args.output}: {stats.messages:,} messages, {stats.topics} topics, "
                f"{_human(size)}, {rate:,.0f} msg/s"
            )
        else:
            window = recorder.window
            line = (
                f"RAM window {args.snapshot:g} s: {window.messages:,} messages "
                f"({window.from_batch:,} of them samples from batches), {window.dropped:,} dropped as "
                f"older, {rate:,.0f} msg/s"
            )
        print(
            ("\r" if tty else "") + f"dbglog record: {line}",
            end="" if tty else "\n",
            file=sys.stderr,
            flush=True,
        )
        while requests:
            requests.pop()
            path = _snapshot_path(args.output, written)
            try:
                n = recorder.snapshot(McapWriter(path, atomic=True))
            except RecordingError as exc:
                say(str(exc))
                continue
            except OSError as exc:  # a full disk: the recorder keeps its window and goes on
                say(f"cannot write {path}: {exc.strerror or exc}")
                continue
            say(f"snapshot of the last {args.snapshot:g} s: {n:,} messages written to {path}")
        if args.duration is not None and now - started >= args.duration:
            recorder.stop()

    try:
        recorder.run(on_tick=tick)
    finally:
        if tty:
            print(file=sys.stderr)
        if writer is not None:
            writer.close()
    stats = recorder.stats
    if writer is not None:
        say(
            f"wrote {writer.messages:,} messages on {stats.topics} topics to {args.output} "
            f"({_human(writer.size)}); longest pause of the take loop {stats.longest_gap_s * 1e3:.0f} ms, "
            f"fullest queue {stats.fullest:.0%} (full {stats.full_takes} times), "
            f"batches missing {recorder.batches_missing}, reported lost by DDS {stats.dds_lost}"
        )
    if stats.full_takes:
        say(
            f"a topic's queue was full {stats.full_takes} times: messages may have been dropped "
            "(the machine was too busy; a larger --queue-depth rides out longer stalls)"
        )
    if recorder.batches_missing:
        say(
            f"{recorder.batches_missing} SDK batch message(s) never arrived (numbers missing): their samples "
            "are not in the file"
        )
    if stats.dds_lost:
        say(
            f"DDS reported {stats.dds_lost} lost message(s): publishers overwrote them in their history "
            "before this recorder received them (the machine was too busy for this message rate)"
        )
    return 0
