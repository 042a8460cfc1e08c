"""Let a dbglog process step aside for the robot: Linux's ``SCHED_IDLE`` policy for all of its threads.

A viewer beside a robot's nodes wakes at message rates (its middleware threads, its engine) and renders
frames of 10-40 ms. Under Linux's EEVDF scheduler a task that wakes up (a control loop at its next
period) may wait for the running task's slice to end (1.4 ms on a 2-core machine) before it gets the CPU:
the viewer's threads delayed a 1 kHz loop's wake-ups by up to a period. A ``SCHED_IDLE`` task is preempted
at once by any ordinary task that wakes; it still gets every CPU cycle nobody else wants, and it never
shares a lock or the GIL with the robot's processes. See ``docs/viewer.md`` for the measurements and for
the trade: on a machine saturated by other work (a build), a background process gets ~0.3 % of a CPU.

Pure standard library; no ROS. Policies other than these two are left alone.
"""

from __future__ import annotations

import argparse
import collections
import os
import sys
from enum import StrEnum
from pathlib import Path

__all__ = [
    "CPU_ENV",
    "CpuPolicy",
    "CpuWaitMeter",
    "add_cpu_argument",
    "apply_cpu_argument",
    "cpu_policy_arg",
    "cpu_times_ns",
    "in_background",
    "set_cpu_policy",
]


CPU_ENV = "DBGLOG_CPU"
"""The environment variable that sets the default of every command's ``--cpu`` (the option still wins):
``DBGLOG_CPU=normal`` on a machine kept busy by other work, once in a shell profile."""


_ENV_WARNED: set[str] = set()
"""The bad `CPU_ENV` values already named on stderr."""


class CpuPolicy(StrEnum):
    """How a dbglog process shares the CPU with the robot (``--cpu``)."""

    BACKGROUND = "background"
    """``SCHED_IDLE``: any other task that wakes up preempts it at once."""
    NORMAL = "normal"
    """The ordinary time-sharing policy (what a process has when started from a shell)."""


def _threads() -> list[int]:
    """The thread ids of this process (the calling thread alone where /proc is missing)."""
    try:
        return sorted(int(entry.name) for entry in Path("/proc/self/task").iterdir())
    except (OSError, ValueError):
        return [0]


def set_cpu_policy(policy: CpuPolicy) -> str | None:
    """Put every thread of this process (and so every thread and child it starts later) under `policy`.

    A thread the user put under another policy (a real-time one, ``SCHED_BATCH``) keeps it.

    Returns:
        None when done; otherwise why not (not Linux, the kernel refused): the process then keeps
        running as it was, which is never an error.
    """
    setter = getattr(os, "sched_setscheduler", None)
    if setter is None or not hasattr(os, "SCHED_IDLE"):
        return "this system has no SCHED_IDLE policy (Linux only)"
    value = os.SCHED_IDLE if policy is CpuPolicy.BACKGROUND else os.SCHED_OTHER
    for tid in _threads():
        try:
            if os.sched_getscheduler(tid) not in (os.SCHED_OTHER, os.SCHED_IDLE):
                continue  # (the user chose a policy, e.g. with chrt: theirs stands)
            setter(tid, value, os.sched_param(0))
        except ProcessLookupError:  # a thread that ended meanwhile
            continue
        except OSError as exc:
            return f"the kernel refused {policy.value} ({exc.strerror})"
    return None


def cpu_policy_arg(text: str) -> CpuPolicy:
    """Parse ``--cpu`` for argparse."""
    try:
        return CpuPolicy(text.strip().lower())
    except ValueError:
        names = ", ".join(policy.value for policy in CpuPolicy)
        raise argparse.ArgumentTypeError(f"{text!r} is not a CPU policy: use one of {names}") from None


def _env_cpu_policy(default: CpuPolicy) -> tuple[CpuPolicy, str | None]:
    """Return the policy ``$DBGLOG_CPU`` (`CPU_ENV`) chooses, else `default`; and, when its value is no
    policy, what is wrong with it (`default` then stands)."""
    chosen = os.environ.get(CPU_ENV, "").strip()
    if not chosen:
        return default, None
    try:
        return cpu_policy_arg(chosen), None
    except argparse.ArgumentTypeError as exc:
        return default, f"{CPU_ENV}: {exc}"


def add_cpu_argument(parser: argparse.ArgumentParser, default: CpuPolicy, help_text: str) -> None:
    """Declare a command's ``--cpu`` option; its metavar lists every `CpuPolicy` (``{background,normal}``).

    `default` is the command's own; ``$DBGLOG_CPU`` (`CPU_ENV`) replaces it when set. A value that is no
    policy is named on stderr and the command's own default stands.
    """
    choices = "{" + ",".join(policy.value for policy in CpuPolicy) + "}"
    default, problem = _env_cpu_policy(default)
    if problem is not None and problem not in _ENV_WARNED:  # (every command's parser is built: say it once)
        _ENV_WARNED.add(problem)
        print(f"dbglog: warning: {problem}; each command's own --cpu default stands", file=sys.stderr)
    help_text += f"; {CPU_ENV} sets the default (now {default.value})"
    parser.add_argument("--cpu", type=cpu_policy_arg, default=default, metavar=choices, help=help_text)


def apply_cpu_argument(policy: CpuPolicy, prog: str) -> None:
    """Put the process under `policy` (first thing in a command: later threads inherit it); a refusal is
    said on stderr, never fatal."""
    refused = set_cpu_policy(policy)
    if refused is not None and policy is CpuPolicy.BACKGROUND:
        print(f"{prog}: note: runs as an ordinary process: {refused}", file=sys.stderr)
    elif refused is not None:
        print(f"{prog}: warning: --cpu {policy.value}: {refused}", file=sys.stderr)


def in_background() -> bool:
    """Whether the calling thread runs under ``SCHED_IDLE``."""
    try:
        return hasattr(os, "SCHED_IDLE") and os.sched_getscheduler(0) == os.SCHED_IDLE
    except OSError:
        return False


def cpu_times_ns() -> tuple[int, int] | None:
    """Nanoseconds the calling thread has run, and has waited runnable for a CPU (Linux's schedstat)."""
    try:
        run, wait = Path("/proc/thread-self/schedstat").read_text().split()[:2]
        return int(run), int(wait)
    except (OSError, ValueError):
        return None


class CpuWaitMeter:
    """Of the time a thread wanted a CPU over the last `window` seconds, the share it waited for one.

    Fed with readings of `cpu_times_ns`: a viewer in the background on a busy machine says so, rather than
    just drawing late. A thread that hardly wanted the CPU in the window (an idle viewer) has no share.
    """

    MIN_BUSY_NS = 50_000_000
    """Below this much time running or waiting in the window, no share is given."""

    def __init__(self, window: float = 3.0) -> None:
        self.window = window
        self._readings: collections.deque[tuple[float, int, int]] = collections.deque()

    def add(self, now: float, run_ns: int, wait_ns: int) -> float | None:
        """Take a reading at `now` (monotonic seconds); return the share waited over the window, or None
        (too little seen: less than half the window, or too little time wanting the CPU)."""
        readings = self._readings
        if readings and (now <= readings[-1][0] or run_ns < readings[-1][1] or wait_ns < readings[-1][2]):
            readings.clear()  # (the clock or a counter went back: another thread, a restart)
        readings.append((now, run_ns, wait_ns))
        while len(readings) > 2 and readings[1][0] <= now - self.window:
            readings.popleft()  # the oldest kept is the last one at or before the window's start
        first_t, first_run, first_wait = readings[0]
        busy = (run_ns - first_run) + (wait_ns - first_wait)
        if now - first_t < self.window / 2 or busy < self.MIN_BUSY_NS:
            return None
        return (wait_ns - first_wait) / busy
