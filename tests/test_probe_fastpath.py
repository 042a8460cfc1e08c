"""The hot path of a known tag (queue append only) behaves exactly like the checked path it skips."""

from __future__ import annotations

import math
import time
from collections.abc import Iterator

import pytest
from std_msgs.msg import Bool, Float64, Int64, String

import dbglog
from dbglog import DbglogWarning
from dbglog._ros._qos import tag_qos
from dbglog.api._public import RUNTIME
from tests._ros import RosPeer, wait_until

LATCHED = tag_qos()


@pytest.fixture(scope="module")
def peer() -> Iterator[RosPeer]:
    """One independent ROS 2 participant for the module."""
    with RosPeer("fastpath_peer") as p:
        yield p


def _five_rate_limited_rounds() -> None:
    for i in range(5):
        dbglog.logbool("fp/once", i % 2 == 0, once=True)
        dbglog.logstring("fp/skip", f"s{i}", skip_first=True)
        dbglog.logfloat("fp/thr", float(i), throttle=3600.0)
        dbglog.logint("fp/int_thr", i, throttle=3600)


def test_rate_options_on_the_hot_path_act_per_tag_and_call_site(peer: RosPeer) -> None:
    """once / skip_first / throttle on known tags: same values and counts as the checked path."""
    once = peer.subscribe("/rosdashboard/fp/once", Bool, LATCHED)
    skip = peer.subscribe("/rosdashboard/fp/skip", String, LATCHED)
    thr = peer.subscribe("/rosdashboard/fp/thr", Float64, LATCHED)
    ithr = peer.subscribe("/rosdashboard/fp/int_thr", Int64, LATCHED)
    _five_rate_limited_rounds()
    assert "fp/once" in RUNTIME.fast_bool  # later calls took the hot path
    assert "fp/skip" in RUNTIME.fast_str
    assert once.wait_for(1)
    assert skip.wait_for(4)
    assert thr.wait_for(1)
    assert ithr.wait_for(1)
    assert once.values() == [True]
    assert skip.values() == ["s1", "s2", "s3", "s4"]
    assert thr.values() == [0.0]
    assert ithr.values() == [0]
    s = dbglog.stats()
    assert (s.calls, s.published, s.rate_limited, s.dropped) == (20, 7, 13, 0)


def test_a_bad_option_on_a_known_tag_is_still_reported() -> None:
    """A negative or non-numeric throttle on a known tag is dropped as bad_option with a warning."""
    dbglog.logfloat("fp/bad", 1.0)
    with pytest.warns(DbglogWarning, match="throttle"):
        dbglog.logfloat("fp/bad", 2.0, throttle=-1.0)
    with pytest.warns(DbglogWarning, match="throttle"):
        dbglog.logstring("fp/bad_s", "x", throttle="often")  # type: ignore[arg-type]
    assert dbglog.stats().dropped_by_reason == {"bad_option": 2}


def test_strings_that_need_checking_on_a_known_tag_take_the_checked_path(peer: RosPeer) -> None:
    """NUL is replaced (one warning), non-ASCII published as is, a lone surrogate dropped."""
    got = peer.subscribe("/rosdashboard/fp/text", String, LATCHED)
    dbglog.logstring("fp/text", "a")
    with pytest.warns(DbglogWarning, match="NUL"):
        dbglog.logstring("fp/text", "b\x00c")
    dbglog.logstring("fp/text", "été")
    with pytest.warns(DbglogWarning, match="UTF-8"):
        dbglog.logstring("fp/text", "\ud800")
    assert got.wait_for(3)
    assert got.values() == ["a", "b\ufffdc", "été"]
    assert dbglog.stats().dropped_by_reason == {"bad_value": 1}


def test_an_int_beyond_int64_on_a_known_tag_is_dropped_out_of_range() -> None:
    """The hot path never queues an int outside Int64: the checked path drops it (out_of_range)."""
    dbglog.logint("fp/big", 1)
    dbglog.logint("fp/big", 2)
    with pytest.warns(DbglogWarning, match="Int64 range"):
        dbglog.logint("fp/big", 2**63)
    s = dbglog.stats()
    assert (s.published, s.dropped_by_reason) == (2, {"out_of_range": 1})
    assert wait_until(lambda: dbglog.flush(5.0))


def test_an_unwatched_tag_gets_its_newest_value_at_most_every_tenth_and_a_watcher_every_sample(
    peer: RosPeer,
) -> None:
    """Nobody on a tag's topic (after its first seconds): its newest value goes there at most every
    0.1 s (and the last one when stats() publishes the queue), all values go in the batch; once a
    subscriber is matched, every sample goes on the topic again."""
    dbglog.logfloat("fp/unwatched", -1.0)
    ch = RUNTIME.channels["fp/unwatched"]
    ch.created -= 60.0  # an old tag: past the first seconds in which every sample is sent anyway
    ch.checked -= 60.0
    _burst("fp/unwatched", 1000)
    assert dbglog.stats().published == 1001  # handed to the middleware, in the batch
    got = peer.subscribe("/rosdashboard/fp/unwatched", Float64, LATCHED)
    assert wait_until(lambda: ch.publisher.get_subscription_count() >= 1)
    assert got.wait_for(1)
    history = got.values()
    assert history[-1] == 999.0
    assert len(history) < 50  # a 1000-sample burst left a few newest values on the topic
    assert wait_until(lambda: ch.listened(time.monotonic()))
    for k in range(300):  # 1 kHz: within the topic's keep-last 100 for a live reader
        dbglog.logfloat("fp/unwatched", float(k))
        time.sleep(0.001)
    assert got.wait_for(len(history) + 300)
    assert got.values()[len(history) :] == [float(k) for k in range(300)]


def _burst(tag: str, n: int) -> None:
    for k in range(n):
        dbglog.logfloat(tag, float(k))


def test_throttle_on_the_hot_path_is_per_line_and_follows_each_calls_own_period() -> None:
    """Two calls on one line share a throttle; another line has its own; a call's own period counts."""
    log, tag = dbglog.logfloat, "fp/lines"
    log(tag, -1.0)  # the tag's hot path exists from here on
    for k in range(3):
        _ = log(tag, float(k), throttle=3600.0), log(tag, 9.0, throttle=3600.0)  # one line, two calls
        log(tag, float(k), throttle=3600.0)
    s = dbglog.stats()
    assert (s.published, s.rate_limited) == (3, 7)  # the first value, then each line's first call
    dbglog.logint("fp/own", 0)
    for period in (3600.0, 3600.0, 0.0, 3600.0):  # passes, held, passes (its own period is 0), held
        dbglog.logint("fp/own", 1, throttle=period)
    s = dbglog.stats()
    assert (s.published, s.rate_limited) == (3 + 1 + 2, 7 + 2)


def test_an_infinite_or_nan_throttle_on_a_known_site_is_still_a_bad_option() -> None:
    """The hot path's shortcut never holds back a call whose throttle is not a finite period."""
    dbglog.logbool("fp/inf", True)
    for period in (3600.0, 3600.0):  # passes (a new site), held
        dbglog.logbool("fp/inf", True, throttle=period)
    with pytest.warns(DbglogWarning, match="throttle"):
        dbglog.logbool("fp/inf", True, throttle=math.inf)
    dbglog.logbool("fp/inf", True, throttle=math.nan)  # counted; warned once per tag and reason
    s = dbglog.stats()
    assert (s.published, s.rate_limited, s.dropped_by_reason) == (2, 1, {"bad_option": 2})


def test_the_last_value_of_an_unwatched_tag_reaches_its_topic_without_a_flush(peer: RosPeer) -> None:
    """After a burst on a tag nobody subscribes to, its last value goes on the topic by itself."""
    dbglog.logfloat("fp/last", -1.0)
    ch = RUNTIME.channels["fp/last"]
    ch.created -= 60.0  # past the first seconds
    ch.checked -= 60.0
    _burst("fp/last", 1000)
    assert wait_until(lambda: not RUNTIME.pipe.queue and not RUNTIME.pipe.pending)  # no flush(), no stats()
    got = peer.subscribe("/rosdashboard/fp/last", Float64, LATCHED)
    assert got.wait_for(1)
    assert wait_until(lambda: got.values()[-1] == 999.0)
