"""``dbglog bridge RULES.yaml``: run the regex bridge node; ``--check`` only validates the rules file;
``dbglog bridge suggest LINE`` prints a rule for a number of a log line."""

from __future__ import annotations

import argparse
import os
import signal
import sys
import threading
from pathlib import Path
from types import FrameType

from dbglog._regex._compile import shorten
from dbglog._sched import CpuPolicy, add_cpu_argument, apply_cpu_argument
from dbglog.regex_bridge._rules import RulesError, load_rules

__all__ = ["HELP", "add_arguments", "run"]

HELP = "Publish numbers found in existing log lines as typed /rosdashboard topics, by regex rules."


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the bridge's options."""
    parser.add_argument(
        "rules",
        metavar="RULES.yaml",
        help="the rules file (YAML, see docs/bridge.md); or the word 'suggest' followed by a log line, "
        "to print a rule for one of its numbers (dbglog bridge suggest 'battery=87%%')",
    )
    parser.add_argument(
        "line",
        nargs="?",
        metavar="LINE",
        help="with 'suggest': the log line (its message, or a whole line as ROS prints it: "
        "'[INFO] [1732200000.1] [node]: message', whose node then becomes the rule's node)",
    )
    parser.add_argument(
        "--check",
        action="store_true",
        help="validate the rules file, list its topics and exit (0 when valid)",
    )
    parser.add_argument("--name", default="dbglog_bridge", help="ROS node name (default: %(default)s)")
    parser.add_argument(
        "--namespace",
        metavar="NS",
        help="the robot namespace of the bridge's node and of its topics (robot1 -> "
        "/robot1/rosdashboard/<tag>; default: DBGLOG_NAMESPACE, else the root); a rule's own "
        "'namespace:' wins, 'namespace: node' follows the node of each line",
    )
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
    add_cpu_argument(
        parser,
        CpuPolicy.NORMAL,
        "how the bridge shares the CPU with the robot: normal (default) or background (Linux's "
        "SCHED_IDLE: a robot thread that wakes up takes the CPU from the bridge at once; on a machine "
        "kept busy, log lines then wait and may be lost)",
    )
    suggest = parser.add_argument_group("suggest options")
    suggest.add_argument(
        "--number",
        type=int,
        metavar="K",
        help="which number of the line the rule captures, counting from 1 (default: 1; the numbers "
        "found are listed at the top of the output)",
    )
    suggest.add_argument("--tag", help="the rule's tag (default: the word before the number)")
    suggest.add_argument(
        "--node", help="the rule's node filter (default: the node of a ROS-formatted line, else none)"
    )
    suggest.add_argument("--level", help="the rule's minimum level: debug, info, warn, error or fatal")


def default_state_dir() -> Path:
    """The XDG state directory for the bridge: ``$XDG_STATE_HOME/dbglog/bridge`` (``~/.local/state``)."""
    base = os.environ.get("XDG_STATE_HOME", "").strip()
    root = Path(base) if base and Path(base).is_absolute() else Path.home() / ".local" / "state"
    return root / "dbglog" / "bridge"


def run(args: argparse.Namespace) -> int:
    """Validate the rules; unless ``--check``, run the bridge until SIGINT or SIGTERM (exit 0).

    ``suggest LINE`` prints a rule for one number of LINE instead.
    """
    if args.rules == "suggest":
        return suggest(args)
    extra = [f"--{name}" for name in ("number", "tag", "node", "level") if getattr(args, name) is not None]
    if args.line is not None or extra:
        given = f"argument {args.line!r}" if args.line is not None else ", ".join(extra)
        print(
            f"dbglog bridge: unexpected {given}: only 'dbglog bridge suggest LINE' takes a line and "
            "--number/--tag/--node/--level (a rules file named 'suggest' is ./suggest)",
            file=sys.stderr,
        )
        return 2
    from dbglog._config import ConfigError, load_config
    from dbglog._ros._tags import TagError, normalize_robot

    try:
        namespace = load_config().namespace if args.namespace is None else normalize_robot(args.namespace)
    except (ConfigError, TagError) as exc:
        print(f"dbglog bridge: --namespace: {exc}", file=sys.stderr)
        return 2
    try:
        rules = load_rules(args.rules, namespace=namespace)
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
                where = "<the line's node namespace>" if out.follow_node else ""
                print(f"  {where}{out.topic} ({out.kind}) <- rule #{rule.index + 1} line {rule.line}")
        return 0

    apply_cpu_argument(args.cpu, "dbglog bridge")  # before rclpy starts its threads: they inherit it
    stop = threading.Event()

    def request_stop(signum: int, _frame: FrameType | None) -> None:
        stop.set()

    previous = {s: signal.signal(s, request_stop) for s in (signal.SIGINT, signal.SIGTERM)}
    try:
        from dbglog.regex_bridge._node import Bridge

        state_dir = None if args.no_state else args.state_dir or default_state_dir()
        with Bridge(
            rules, node_name=args.name, depth=args.depth, state_dir=state_dir, namespace=namespace
        ) as bridge:
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


def suggest(args: argparse.Namespace) -> int:
    """Print, as a rules file, the rule proposed for the K-th number of a line (exit 2 if there is none)."""
    from dbglog._regex._propose import (
        ProposalError,
        find_numbers,
        parse_console_line,
        propose,
        suggest_tag,
        to_bridge_yaml,
    )

    if args.line is None:
        print(
            "dbglog bridge suggest: give the log line, e.g. dbglog bridge suggest 'battery=87%'",
            file=sys.stderr,
        )
        return 2
    if args.number is not None and args.number < 1:
        print(f"dbglog bridge suggest: --number counts from 1, not {args.number}", file=sys.stderr)
        return 2
    line: str = args.line
    node: str | None = args.node
    notes: list[str] = []
    console = parse_console_line(line)
    if console is not None:
        level, logger, line = console
        node = node if node is not None else logger
        notes.append(f"# read as a ROS console line: level {level}, node {logger}; matching its message")
    numbers = find_numbers(line)
    if not numbers:
        print(f"dbglog bridge suggest: no number in the line {shorten(line)!r}", file=sys.stderr)
        return 2
    k = args.number or 1
    try:
        proposal = propose(line, k - 1, node=node or None)
        text = to_bridge_yaml(proposal, args.tag or suggest_tag(proposal), level=args.level)
    except (ProposalError, ValueError) as exc:
        print(f"dbglog bridge suggest: {exc}", file=sys.stderr)
        return 2
    listed = "  ".join(f"{i}) {n.text}{n.unit}" for i, n in enumerate(numbers[:20], start=1))
    more = f"  … ({len(numbers)} numbers)" if len(numbers) > 20 else ""
    notes.append(f"# numbers in the line: {listed}{more}")
    hint = "" if args.number is not None or len(numbers) == 1 else "; --number K for another"
    notes.append(f"# this rule captures number {k} ({proposal.number.text}){hint}")
    print("\n".join(notes))
    print(text, end="")
    return 0
