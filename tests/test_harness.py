"""The test harness itself: two independent real ROS 2 participants talk over the loopback."""

from __future__ import annotations

import os

from std_msgs.msg import Float64

from tests._ros import RosPeer


def test_session_environment_keeps_dds_local() -> None:
    """Every test process runs with a random domain and localhost-only discovery."""
    assert os.environ["ROS_AUTOMATIC_DISCOVERY_RANGE"] == "LOCALHOST"
    assert 0 < int(os.environ["ROS_DOMAIN_ID"]) <= 100


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
