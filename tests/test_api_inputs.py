"""Odd inputs to the SDK on real ROS 2: NULs in strings, out-of-range fields, bad options per tag."""

from __future__ import annotations

import warnings
from collections.abc import Callable, Iterator

import pytest
from sensor_msgs.msg import JointState
from std_msgs.msg import Int64, Int64MultiArray, String

import dbglog
from dbglog import DbglogWarning
from dbglog._ros._qos import tag_qos
from tests._ros import RosPeer

LATCHED = tag_qos()


def _warned(calls: Callable[[], None]) -> list[str]:
    """Run `calls` and return the text of every DbglogWarning it issued (none other is allowed)."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        calls()
    assert all(issubclass(w.category, DbglogWarning) for w in caught), [str(w.message) for w in caught]
    return [str(w.message) for w in caught]


@pytest.fixture(scope="module")
def peer() -> Iterator[RosPeer]:
    """One independent ROS 2 participant for the whole module."""
    with RosPeer("inputs_peer") as p:
        yield p


def test_nul_in_a_string_arrives_as_u_fffd_with_one_warning(peer: RosPeer) -> None:
    """logstring/log with a NUL: the subscriber gets the whole text with U+FFFD; one warning per tag."""
    got = peer.subscribe("/rosdashboard/t_nul", String, LATCHED)

    def calls() -> None:
        dbglog.logstring("t_nul", "a\x00b")
        dbglog.logstring("t_nul", "c\x00\x00d")
        dbglog.log("t_nul", "e\x00")

    text = _warned(calls)
    assert len(text) == 1
    assert text[0].startswith("dbglog.logstring('t_nul'): the string held NUL characters")
    assert "U+FFFD" in text[0]
    assert got.wait_for(3)
    assert got.values() == ["a\ufffdb", "c\ufffd\ufffdd", "e\ufffd"]
    s = dbglog.stats()
    assert (s.calls, s.published, s.dropped) == (3, 3, 0)


def test_nul_in_message_fields_is_replaced_in_a_copy(peer: RosPeer) -> None:
    """logdata (dict or instance), NULs in string fields: replaced and named; the caller's message kept."""
    got = peer.subscribe("/rosdashboard/t_nul_msg", JointState, LATCHED)
    mine = JointState(name=["left", "ri\x00ght"], position=[1.0, 2.0])
    mine.header.frame_id = "base\x00link"

    def calls() -> None:
        dbglog.logdata("t_nul_msg", mine, JointState)
        dbglog.logdata("t_nul_msg", {"name": ["a\x00"]}, "sensor_msgs/msg/JointState")

    text = _warned(calls)
    assert len(text) == 1
    assert "field header.frame_id, name held NUL characters" in text[0]
    assert (mine.header.frame_id, mine.name) == ("base\x00link", ["left", "ri\x00ght"])
    assert got.wait_for(2)
    first, second = got.messages
    assert (first.header.frame_id, first.name, list(first.position)) == (
        "base\ufffdlink",
        ["left", "ri\ufffdght"],
        [1.0, 2.0],
    )
    assert second.name == ["a\ufffd"]


def test_bad_options_warn_once_per_tag_not_per_function(peer: RosPeer) -> None:
    """A bad option warns once for each tag it is used with (as documented), and each value is dropped."""

    def calls() -> None:
        for _ in range(3):
            dbglog.logfloat("t_opt_a", 1.0, throttle=-1.0)
            dbglog.logfloat("t_opt_b", 1.0, throttle=-1.0)

    text = _warned(calls)
    assert [t.split(":")[0] for t in text] == ["dbglog.logfloat('t_opt_a')", "dbglog.logfloat('t_opt_b')"]
    assert all("throttle must be a finite number" in t for t in text)
    assert dbglog.stats().dropped_by_reason == {"bad_option": 6}


def test_logdata_int_beyond_int64_is_out_of_range_naming_field_and_bounds(peer: RosPeer) -> None:
    """2**80 into an Int64 field is out_of_range (not publish_failed), the message names field and bounds."""
    got = peer.subscribe("/rosdashboard/t_big", Int64, LATCHED)

    def calls() -> None:
        dbglog.logdata("t_big", {"data": 2**80}, "std_msgs/msg/Int64")
        dbglog.logdata("t_big_seq", {"data": [1, 2**80]}, Int64MultiArray)

    text = _warned(calls)
    assert len(text) == 2
    assert "field 'data' of std_msgs/msg/Int64" in text[0]
    assert "[-9223372036854775808, 9223372036854775807]" in text[0]
    assert "field 'data' of std_msgs/msg/Int64MultiArray" in text[1]
    assert "[-9223372036854775808, 9223372036854775807]" in text[1]
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dbglog.logdata("t_big", {"data": 2**63 - 1}, "std_msgs/msg/Int64")
    assert got.wait_for(1)
    assert got.values() == [2**63 - 1]
    s = dbglog.stats()
    assert s.dropped_by_reason == {"out_of_range": 2}
    assert s.published == 1
