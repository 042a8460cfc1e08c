"""``dbglog demo``: a simulated robot, the regex bridge and the viewer on a curated dashboard, in one command.

Everything runs as child processes of this one, each in its own process group; whatever way this process
ends (the window closed, Ctrl-C, SIGTERM, a crashed viewer), it stops them all: SIGTERM to each group,
then SIGKILL after a timeout. On Linux the children also get SIGTERM if this process is killed outright.
"""

from __future__ import annotations

import argparse
import contextlib
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from importlib import resources
from pathlib import Path
from types import FrameType
from typing import IO

from dbglog.viewer._cli._cli_view import seconds_arg, size_arg

__all__ = ["HELP", "Supervisor", "add_arguments", "dashboard_path", "rules_path", "run"]

HELP = "Run a simulated robot (turtle arena + sound localizer) and open the live viewer on it."

STOP_TIMEOUT_S = 5.0
"""How long a child may take to stop after SIGTERM before it gets SIGKILL."""


def dashboard_path() -> Path:
    """The curated demo dashboard bundled with dbglog."""
    return Path(str(resources.files("dbglog._demo").joinpath("demo_dashboard.json")))


def rules_path() -> Path:
    """The bridge rules for the demo nodes' log lines, bundled with dbglog."""
    return Path(str(resources.files("dbglog._demo").joinpath("demo_rules.yaml")))


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare ``dbglog demo``'s options."""
    parser.add_argument(
        "--screenshot",
        type=Path,
        metavar="PNG",
        help="headless: render the dashboard, write a PNG, stop everything and exit",
    )
    parser.add_argument(
        "--after",
        type=seconds_arg,
        default=8.0,
        metavar="SECONDS",
        help="with --screenshot: how long to render first (default 8)",
    )
    parser.add_argument(
        "--report-json",
        type=Path,
        metavar="PATH",
        help="on exit, write every widget's name, type and status as JSON",
    )
    parser.add_argument(
        "--size", type=size_arg, default=(1440, 900), metavar="WxH", help="window size (default 1440x900)"
    )


@dataclass
class _Child:
    name: str
    proc: subprocess.Popen[bytes]
    log: Path | None


def _die_with_parent() -> None:  # pragma: no cover - runs in the child between fork and exec
    """Ask Linux to send SIGTERM to this child when its parent dies (even by SIGKILL)."""
    os.setsid()
    if sys.platform.startswith("linux"):
        import ctypes

        try:
            libc = ctypes.CDLL(None, use_errno=True)
            libc.prctl(1, signal.SIGTERM)  # PR_SET_PDEATHSIG
        except (OSError, AttributeError):
            pass


class _StopRequestedError(Exception):
    """SIGTERM, SIGHUP or SIGINT arrived: leave through the clean-up path."""


class StopRequests:
    """The names of the stop signals that came, and whether their exception is held back for now."""

    def __init__(self) -> None:
        self.names: list[str] = []
        self._holding = 0

    def came(self, name: str) -> None:
        """Note a stop signal; raise `_StopRequestedError` unless held (`held` raises it then)."""
        self.names.append(name)
        if not self._holding:
            raise _StopRequestedError(name)

    @contextlib.contextmanager
    def held(self) -> Iterator[None]:
        """Around a step that must not be cut short (starting a child): a stop that comes meanwhile is
        noted, and raised when the step is done."""
        self._holding += 1
        try:
            yield
        finally:
            self._holding -= 1
        if not self._holding and self.names:
            raise _StopRequestedError(self.names[0])


@dataclass
class Supervisor:
    """Starts child processes in their own process groups and stops every one of them on `close`."""

    log_dir: Path
    stops: StopRequests = field(default_factory=StopRequests)
    """The stop signals that came (`_stop_on_signals`); held while a child starts."""
    children: list[_Child] = field(default_factory=list)

    def start(self, name: str, argv: Sequence[str], *, quiet: bool) -> subprocess.Popen[bytes]:
        """Start `argv`; with `quiet`, its output goes to a log file in `log_dir`."""
        log: Path | None = None
        out: IO[bytes] | None = None
        if quiet:
            log = self.log_dir / f"{name}.log"
            out = log.open("wb")
        # A stop signal whose exception was raised between the fork and Popen's return left the child
        # running, unknown to `close`: it died only when the demo had exited (CI saw it still exiting).
        # While `stops` holds them, a stop only is noted, and raises once the child is known.
        try:
            with self.stops.held():
                proc = subprocess.Popen(
                    list(argv),
                    stdin=subprocess.DEVNULL,
                    stdout=out,
                    stderr=subprocess.STDOUT if quiet else None,
                    preexec_fn=_die_with_parent,  # no threads run in this process yet
                )
                self.children.append(_Child(name, proc, log))
        finally:
            if out is not None:
                out.close()
        return proc

    def dead(self) -> list[_Child]:
        """Children that have exited."""
        return [c for c in self.children if c.proc.poll() is not None]

    def tail(self, child: _Child, lines: int = 15) -> str:
        """The last lines of a quiet child's log."""
        if child.log is None or not child.log.exists():
            return ""
        text = child.log.read_text(encoding="utf-8", errors="replace").splitlines()
        return "\n".join(text[-lines:])

    def close(self) -> None:
        """Stop every child and its process group: SIGTERM, then SIGKILL after `STOP_TIMEOUT_S`."""
        for child in reversed(self.children):
            _signal_group(child.proc, signal.SIGTERM)
        deadline = time.monotonic() + STOP_TIMEOUT_S
        for child in reversed(self.children):
            with contextlib.suppress(subprocess.TimeoutExpired):
                child.proc.wait(max(0.05, deadline - time.monotonic()))
        for child in self.children:
            _signal_group(child.proc, signal.SIGKILL)  # stragglers, and anything the child started
            with contextlib.suppress(subprocess.TimeoutExpired):
                child.proc.wait(STOP_TIMEOUT_S)


def _signal_group(proc: subprocess.Popen[bytes], signum: int) -> None:
    # The child leads its own group (setsid): its pid is the group id, even after it exited.
    with contextlib.suppress(ProcessLookupError, PermissionError):
        os.killpg(proc.pid, signum)


@contextlib.contextmanager
def _stop_on_signals() -> Iterator[StopRequests]:
    """Raise `_StopRequestedError` on SIGTERM, SIGHUP and SIGINT (unless held); yield the requests.

    Python runs the handler in the main thread, whichever thread the kernel gave the signal. The exception
    can still be lost: raised while ``subprocess`` forks a child, inside an at-fork hook, Python prints it
    as ignored and goes on (CI saw a demo that never stopped). The names kept let `_watch` check between
    its waits, and `Supervisor.start` holds the exception while a child starts.
    """
    requests = StopRequests()

    def handler(signum: int, _frame: FrameType | None) -> None:
        requests.came(signal.Signals(signum).name)

    previous = {s: signal.signal(s, handler) for s in (signal.SIGTERM, signal.SIGHUP, signal.SIGINT)}
    try:
        yield requests
    finally:
        for signum, old in previous.items():
            signal.signal(signum, old)


def _viewer_argv(args: argparse.Namespace) -> list[str]:
    # A template: the shipped file is never overwritten; Save asks where to keep the user's version.
    argv = [sys.executable, "-m", "dbglog", "view", str(dashboard_path()), "--template"]
    argv += ["--size", "{}x{}".format(*args.size)]
    if args.screenshot is not None:
        argv += ["--screenshot", str(args.screenshot), "--after", f"{args.after:g}", "--wait-live", "20"]
    if args.report_json is not None:
        argv += ["--report-json", str(args.report_json)]
    return argv


def run(args: argparse.Namespace) -> int:
    """Start the robot and the bridge, run the viewer, stop everything; return the viewer's exit code."""
    from dbglog._config import has_display
    from dbglog._rosenv import localhost_discovery

    if args.screenshot is None and not has_display():
        print(
            "dbglog demo: no display here (neither DISPLAY nor WAYLAND_DISPLAY is set).\n"
            "  Render the demo on a virtual screen instead and look at the picture:\n"
            "    xvfb-run -a dbglog demo --screenshot demo.png --after 8",
            file=sys.stderr,
        )
        return 2
    localhost_discovery()
    with tempfile.TemporaryDirectory(prefix="dbglog-demo-") as tmp, _stop_on_signals() as stops:
        sup = Supervisor(Path(tmp), stops)
        try:
            sup.start("robot", [sys.executable, "-m", "dbglog._demo._robot"], quiet=True)
            sup.start("bridge", [sys.executable, "-m", "dbglog", "bridge", str(rules_path())], quiet=True)
            viewer = sup.start("viewer", _viewer_argv(args), quiet=False)
            print(
                "dbglog demo: robot, bridge and viewer running"
                + ("" if args.screenshot else " (close the window or press Ctrl-C to stop)"),
                file=sys.stderr,
                flush=True,
            )
            return _watch(sup, viewer)
        except _StopRequestedError as exc:
            print(f"dbglog demo: {exc}: stopping", file=sys.stderr)
            return 128 + int(getattr(signal, str(exc), signal.SIGTERM))
        finally:
            sup.close()


def _watch(sup: Supervisor, viewer: subprocess.Popen[bytes]) -> int:
    """Wait for the viewer; report a helper that died on the way; return the exit code.

    Raises:
        _StopRequestedError: a stop signal came (`sup.stops`), also one whose own exception was lost.
    """
    reported: set[str] = set()
    requested = sup.stops.names
    while True:
        if requested:
            raise _StopRequestedError(requested[0])
        try:
            code = viewer.wait(0.5)
            break
        except subprocess.TimeoutExpired:
            pass
        for child in sup.dead():
            if child.proc is not viewer and child.name not in reported:
                reported.add(child.name)
                print(
                    f"dbglog demo: the {child.name} stopped (exit code {child.proc.returncode}):\n"
                    f"{sup.tail(child)}",
                    file=sys.stderr,
                )
    if code < 0:
        print(f"dbglog demo: the viewer crashed ({signal.Signals(-code).name}); stopping", file=sys.stderr)
        return 1
    return code
