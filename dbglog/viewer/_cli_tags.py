"""``dbglog tags``: a table of the live dbglog tags (or every topic) from the viewer's data engine."""

from __future__ import annotations

import argparse
import os
import sys
import time
from collections.abc import Sequence
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from dbglog.viewer._engine import Engine
    from dbglog.viewer._model import SeriesSnapshot, TopicInfo

__all__ = ["HELP", "add_arguments", "format_table", "format_value", "run"]

HELP = "List the live dbglog tags (tag, type, rate, last value, status); --all lists every topic."

_CLEAR = "\x1b[H\x1b[2J"


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``tags`` options."""
    parser.add_argument("--watch", action="store_true", help="refresh the table until Ctrl-C")
    parser.add_argument("--all", action="store_true", help="list every topic, not only dbglog tags")
    parser.add_argument(
        "--wait",
        type=float,
        default=2.0,
        metavar="S",
        help="seconds to let DDS discovery and first values arrive before printing (default 2)",
    )
    parser.add_argument(
        "--interval", type=float, default=1.0, metavar="S", help="refresh period with --watch (default 1 s)"
    )


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


def _rows(engine: Engine, topics: list[TopicInfo], show_all: bool) -> list[list[str]]:
    from dbglog.viewer._model import Binding, Status

    rows = []
    for info in topics:
        name = info.tag if info.tag is not None and not show_all else info.name
        type_name = info.types[0] if info.types else "?"
        snap: SeriesSnapshot | None = None
        if Binding(info.name) in engine.bindings():
            snap = engine.snapshot(Binding(info.name))
        if snap is None or (snap.status == Status.ERROR and "several fields" in snap.reason):
            rate, value, status = "-", "-", "-" if snap is not None else "unbound"
        else:
            rate = f"{snap.rate_hz:.1f} Hz" if snap.count else "-"
            value = format_value(snap.last)
            status = str(snap.status) if snap.status != Status.ERROR else f"error: {snap.reason}"
        rows.append([name, type_name, rate, value, status])
    return rows


def _listed(engine: Engine, show_all: bool) -> list[TopicInfo]:
    from dbglog.viewer._model import Binding

    topics = [t for t in engine.topics() if show_all or t.tag is not None]
    for info in topics:
        engine.bind(Binding(info.name))
    return topics


def run(args: argparse.Namespace) -> int:
    """Print the table once (or keep refreshing it with --watch)."""
    from dbglog.viewer._engine import Engine

    if args.wait < 0 or args.interval <= 0:
        print("dbglog tags: --wait must be >= 0 and --interval > 0", file=sys.stderr)
        return 2
    header = ["topic" if args.all else "tag", "type", "rate", "last value", "status"]
    with Engine(node_name="dbglog_tags") as engine:
        deadline = time.monotonic() + args.wait
        # Discovery first, then give the tags' latched values a moment to land.
        while time.monotonic() < deadline:
            topics = _listed(engine, args.all)
            snaps = [engine.snapshot(b) for b in engine.bindings()]
            if topics and all(s.count for s in snaps) and time.monotonic() > deadline - args.wait / 2:
                break
            time.sleep(0.05)
        while True:
            topics = _listed(engine, args.all)
            if topics:
                table = format_table(header, _rows(engine, topics, args.all))
            else:
                domain = os.environ.get("ROS_DOMAIN_ID", "0")
                what = "topics" if args.all else "dbglog tags (/rosdashboard/...)"
                table = f"no {what} on the ROS graph (ROS_DOMAIN_ID={domain}, waited {args.wait:g} s)"
            if not args.watch:
                print(table)
                return 0
            prefix = _CLEAR if sys.stdout.isatty() else "\n"
            print(f"{prefix}{time.strftime('%H:%M:%S')}  {len(topics)} shown\n{table}", flush=True)
            time.sleep(args.interval)
