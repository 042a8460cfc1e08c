"""Session-wide test setup: DDS kept on loopback, a random ROS domain per session (and per worker)."""

from __future__ import annotations

import os
import random
import time
from collections.abc import Iterator

import pytest

from tests._shm import remove_dead_segments
from tests._workers import private_display, worker_domain
from tests._xvfb import x_display

# Before anything imports rclpy: every process of this session (and its children) shares one random
# domain, a parallel worker's its own (tests/_workers.py), and discovery never leaves this machine unless
# the caller set the range explicitly.
os.environ.setdefault("ROS_AUTOMATIC_DISCOVERY_RANGE", "LOCALHOST")
if "DBGLOG_TEST_DOMAIN_FIXED" not in os.environ:
    os.environ["ROS_DOMAIN_ID"] = str(random.SystemRandom().randint(1, 100))
os.environ["ROS_DOMAIN_ID"] = str(worker_domain(int(os.environ.get("ROS_DOMAIN_ID", "0")), os.environ))
os.environ.setdefault("RMW_IMPLEMENTATION", "rmw_fastrtps_cpp")
# Every `dbglog view` a test starts shares the CPU evenly (`--cpu normal`) unless the test is about the
# policy (test_ui_cpu, test_sched): the suite keeps 2 cores saturated, and a viewer in the background
# (SCHED_IDLE, the product's default) then gets almost no CPU: against three busy loops one did not show
# its first value within 60 s, and CI's busiest moments made such viewers start late or fail.
os.environ.setdefault("DBGLOG_CPU", "normal")  # (dbglog._sched.CPU_ENV: nothing of dbglog imported yet)
# SDK processes a test starts exit at once (no wait for readers still discovering them: up to 2 s each
# where a child sees no other node yet) unless the test is about that wait (test_probe_delivery).
os.environ.setdefault("DBGLOG_EXIT_WAIT", "0")
_STARTED = time.time()


def pytest_sessionfinish(session: pytest.Session) -> None:
    """At the end of the run (the controller's, with workers): remove the Fast DDS segments of the processes
    it killed (tests/_shm.py), so runs after runs do not fill /dev/shm."""
    if not hasattr(session.config, "workerinput"):
        remove_dead_segments(_STARTED)


@pytest.fixture(autouse=True)
def _reset_dbglog_state() -> Iterator[None]:
    """Give every test a fresh dbglog: disconnected, counters and warnings zeroed."""
    yield
    import dbglog

    if dbglog.enabled:
        from dbglog.api._public import reset

        reset()


@pytest.fixture(scope="session", autouse=True)
def _worker_display() -> Iterator[None]:
    """Parallel workers: a private Xvfb is ``$DISPLAY`` for the whole session, so the GUI children a test
    starts with the inherited environment never share a screen with another worker or suite (CI's shared
    xvfb-run display refused a viewer's connection now and then: "Failed to open display :99", most likely
    the server's reset after its last client, which the private servers turn off)."""
    if not private_display(os.environ):
        yield
        return
    before = os.environ.get("DISPLAY")
    with x_display(private=True) as name:
        os.environ["DISPLAY"] = name
        try:
            yield
        finally:
            if before is None:
                os.environ.pop("DISPLAY", None)
            else:
                os.environ["DISPLAY"] = before


@pytest.fixture(scope="module")
def display() -> Iterator[str]:
    """The X display for GUI tests: the caller's, or a private Xvfb (always one for parallel workers)."""
    with x_display(private=private_display(os.environ)) as name:
        yield name
