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

import os
from enum import StrEnum
from pathlib import Path

__all__ = ["CpuPolicy", "set_cpu_policy"]


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
