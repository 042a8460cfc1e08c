"""The test harness itself: real ROS 2 participants talk over the loopback; private X displays never reset."""

from __future__ import annotations

import ctypes
import os

import pytest
from std_msgs.msg import Float64

from dbglog.viewer._ui._display import load_xlib
from tests._ros import RosPeer
from tests._workers import MAX_DOMAIN, private_display, worker_domain, worker_index
from tests._xvfb import x_display


def test_session_environment_keeps_dds_local() -> None:
    """Every test process runs with a random domain (each worker its own) and localhost-only discovery."""
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    lowest = 100 * worker_index(os.environ)
    assert lowest < int(os.environ["ROS_DOMAIN_ID"]) <= min(lowest + 100, MAX_DOMAIN)


def test_parallel_workers_get_a_domain_and_a_display_each() -> None:
    """Workers gw0, gw1 of one suite never share a ROS domain or, when several, an X display."""
    assert worker_domain(37, {}) == 37
    assert worker_domain(37, {"PYTEST_XDIST_WORKER": "gw0"}) == 37
    assert worker_domain(37, {"PYTEST_XDIST_WORKER": "gw1"}) == 137
    assert worker_domain(95, {"PYTEST_XDIST_WORKER": "gw1"}) == 195  # .ci/run's second suite
    with pytest.raises(ValueError, match="domain 237, outside 0-232"):
        worker_domain(37, {"PYTEST_XDIST_WORKER": "gw2"})
    with pytest.raises(ValueError, match="expected gw<number>"):
        worker_index({"PYTEST_XDIST_WORKER": "worker-1"})
    assert not private_display({})
    assert not private_display({"PYTEST_XDIST_WORKER_COUNT": "1"})
    assert private_display({"PYTEST_XDIST_WORKER_COUNT": "2"})


def test_two_peers_exchange_messages() -> None:
    """A publisher in one context reaches a subscriber in another."""
    with RosPeer("harness_a") as a, RosPeer("harness_b") as b:
        got = b.subscribe("/harness/x", Float64)
        pub = a.publisher("/harness/x", Float64)
        assert a.wait_for_subscribers(pub)
        for i in range(5):
            pub.publish(Float64(data=float(i)))
        assert got.wait_for(5)
        assert got.values() == [0.0, 1.0, 2.0, 3.0, 4.0]


def test_private_display_takes_a_connection_right_after_the_last_one_closed() -> None:
    """A private Xvfb never resets between clients, so each test's first connection is accepted at once."""
    x = load_xlib()
    x.XOpenDisplay.restype, x.XOpenDisplay.argtypes = ctypes.c_void_p, [ctypes.c_char_p]
    x.XCloseDisplay.argtypes = [ctypes.c_void_p]
    with x_display(private=True) as name:
        for attempt in range(2000):  # a resetting server refused about 1 in 330 of these (measured)
            handle = x.XOpenDisplay(name.encode())
            assert handle, f"connection {attempt + 1} to {name} refused"
            x.XCloseDisplay(handle)
