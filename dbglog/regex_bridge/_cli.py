"""``dbglog bridge RULES.yaml``: run the regex bridge node; ``--check`` only validates the rules file."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from dbglog.regex_bridge._rules import RulesError, load_rules

__all__ = ["HELP", "add_arguments", "run"]

HELP = "Publish numbers found in existing log lines as typed /rosdashboard topics, by regex rules."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the bridge's options."""
    parser.add_argument("rules", metavar="RULES.yaml", help="the rules file (YAML, see docs/bridge.md)")
    parser.add_argument(
        "--check",
        action="store_true",
        help="validate the rules file, list its topics and exit (0 when valid)",
    )
    parser.add_argument("--name", default="dbglog_bridge", help="ROS node name (default: %(default)s)")
    parser.add_argument(
        "--depth",
        type=int,
        default=10_000,
        help="history depth of the /rosout (and String) subscriptions (default: %(default)s)",
    )
    parser.add_argument(
        "--state-dir",
        metavar="DIR",
        type=Path,
        help="where the bridge leaves, when stopped, what it published in its last seconds, so that a "
        "restart does not publish lines from /rosout's history again (default: "
        "$XDG_STATE_HOME/dbglog/bridge, or ~/.local/state/dbglog/bridge)",
    )
    parser.add_argument(
        "--no-state",
        action="store_true",
        help="keep nothing between runs: a bridge restarted within 10 s publishes /rosout's recent "
        "history again",
    )


def default_state_dir() -> Path:
    """The XDG state directory for the bridge: ``$XDG_STATE_HOME/dbglog/bridge`` (``~/.local/state``)."""
    base = os.environ.get("XDG_STATE_HOME", "").strip()
    root = Path(base) if base and Path(base).is_absolute() else Path.home() / ".local" / "state"
    return root / "dbglog" / "bridge"


def run(args: argparse.Namespace) -> int:
    """Validate the rules; unless ``--check``, run the bridge until SIGINT or SIGTERM (exit 0)."""
    try:
        rules = load_rules(args.rules)
    except RulesError as exc:
        print(f"dbglog bridge: {exc}", file=sys.stderr)
        return 2
    if args.depth < 1:
        print(f"dbglog bridge: --depth must be at least 1, not {args.depth}", file=sys.stderr)
        return 2
    if args.check:
        outputs = rules.outputs
        print(f"{args.rules}: OK, {len(rules.rules)} rules, {len(outputs)} topics")
        for rule in rules.rules:
            for out in rule.outputs:
                print(f"  {out.topic} ({out.kind}) <- rule #{rule.index + 1} line {rule.line}")
        return 0

    stop = threading.Event()

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        from dbglog.regex_bridge._node import Bridge

        state_dir = None if args.no_state else args.state_dir or default_state_dir()
        with Bridge(rules, node_name=args.name, depth=args.depth, state_dir=state_dir) as bridge:
            print(
                f"dbglog bridge: running, {len(rules.rules)} rules -> {len(bridge.topics)} topics "
                f"(Ctrl-C to stop)",
                flush=True,
            )
            while not stop.wait(0.5):
                pass
            stats = bridge.stats
        print(
            f"dbglog bridge: stopped after {stats.lines} lines, {stats.values} values published, "
            f"{stats.unparseable} unparseable, {stats.duplicates} duplicates skipped, {stats.errors} errors",
            flush=True,
        )
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, handler)
    return 0
