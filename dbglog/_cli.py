"""The ``dbglog`` command line: one dispatcher, each subcommand in the module that owns its work."""

from __future__ import annotations

import argparse
import importlib
import signal
import sys
from collections.abc import Sequence
from typing import Protocol, cast

__all__ = ["main"]


class _Command(Protocol):
    """What a subcommand module provides (kept light: no rclpy or Dear PyGui import at module level)."""

    HELP: str

    def add_arguments(self, parser: argparse.ArgumentParser) -> None:
        """Declare the subcommand's options."""

    def run(self, args: argparse.Namespace) -> int:
        """Do the work; return the process exit code."""


# name -> module implementing the _Command protocol; order is the order shown in --help.
_COMMANDS: dict[str, str] = {
    "bridge": "dbglog.regex_bridge._cli",
    "view": "dbglog.viewer._cli._cli_view",
    "tags": "dbglog.viewer._cli._cli_tags",
    "echo": "dbglog.viewer._cli._cli_echo",
    "logs": "dbglog.viewer._cli._cli_logs",
    "params": "dbglog._params._cli",
    "record": "dbglog.record._cli",
    "watch": "dbglog.watch._cli_watch",
    "run": "dbglog.watch._cli_run",
    "demo": "dbglog._demo._cli",
}


def _load(module: str) -> _Command:
    return cast(_Command, importlib.import_module(module))


def build_parser(only: str | None = None) -> argparse.ArgumentParser:
    """Build the argument parser with every subcommand, or with subcommand `only` alone.

    Each subcommand's module is imported to declare its options; `main` builds the one it runs alone, so
    that ``dbglog run`` does not load the other commands' modules into the program it runs.
    """
    from dbglog import __version__

    parser = argparse.ArgumentParser(
        prog="dbglog",
        description="Typed debug logging for ROS 2: publish values, bridge log lines, view them live.",
    )
    parser.add_argument("--version", action="version", version=f"dbglog {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    for name, module in _COMMANDS.items():
        if only is not None and name != only:
            continue
        command = _load(module)
        child = sub.add_parser(name, help=command.HELP, description=command.HELP)
        command.add_arguments(child)
        child.set_defaults(_module=module)
    return parser


def interruptible() -> None:
    """Make SIGINT (Ctrl-C, or a supervisor's stop) interrupt even when it was inherited ignored.

    A shell starts a background command (``cmd &`` in a script) with SIGINT ignored, and Python keeps
    it so: ``dbglog demo`` could then not stop its viewer, nor Ctrl-C a ``record`` started that way.
    """
    if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        signal.signal(signal.SIGINT, signal.default_int_handler)


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``dbglog`` command line and return its exit code."""
    arguments = list(sys.argv[1:] if argv is None else argv)
    first = arguments[0] if arguments else None
    parser = build_parser(first if first in _COMMANDS else None)
    args = parser.parse_args(arguments)
    if args.command is None:  # as argparse answers a missing argument: usage on stderr, status 2
        parser.print_help(sys.stderr)
        return 2
    interruptible()
    if args.command != "run":  # `dbglog run` is the user's program: its participants keep their profile
        from dbglog._ros._profile import claim

        claim()
    try:
        return _load(args._module).run(args)
    except KeyboardInterrupt:
        return 130


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
