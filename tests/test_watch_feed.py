"""The SDK's feed for watches: work handed to the publisher thread, samples queued with their own time."""

from __future__ import annotations

import threading
import time

from std_msgs.msg import UInt8MultiArray

import dbglog
from dbglog._ros._batch import BATCH_TOPIC, decode_batch
from dbglog._ros._qos import batch_qos
from dbglog.api import feed
from tests._ros import RosPeer, wait_until


def test_call_soon_runs_on_the_publisher_thread() -> None:
    """A call handed over runs on dbglog's publisher thread, not the caller's, even when it was asleep."""
    ran: list[str] = []
    done = threading.Event()

    def work() -> None:
        ran.append(threading.current_thread().name)
        done.set()

    feed.call_soon(work)
    assert done.wait(10)
    assert ran == ["dbglog-publisher"]


def test_a_call_that_raises_does_not_stop_the_thread() -> None:
    """An exception in handed-over work is swallowed there; later work still runs."""
    done = threading.Event()

    def broken() -> None:
        raise RuntimeError("boom")

    feed.call_soon(broken)
    feed.call_soon(done.set)
    assert done.wait(10)


def test_enqueued_samples_keep_their_source_time() -> None:
    """A sample queued through the feed reaches the batch topic with the time it was given, hit for hit."""
    batches: list[bytes] = []
    with RosPeer("feed_reader") as peer:
        peer.node.create_subscription(UInt8MultiArray, BATCH_TOPIC, batches.append, batch_qos(), raw=True)
        got: dict[str, list[tuple[int, object]]] = {}
        made = threading.Event()
        channels: list[object] = []

        def create() -> None:
            channels.append(feed.scalar_channel(feed.resolve_tag("watch/feed_test") or "", "Int64"))
            made.set()

        assert feed.connect()
        feed.call_soon(create)
        assert made.wait(10)
        ch = channels[0]
        assert isinstance(ch, feed.Channel)
        stamps = [time.time_ns() - 10_000_000 + k for k in range(5)]
        for k, stamp in enumerate(stamps):
            assert feed.enqueue(ch, k, stamp)

        def arrived() -> bool:
            for raw in batches:
                for samples in decode_batch(raw).tags:
                    if samples.tag == "watch/feed_test":
                        values = list(samples.values)
                        got[raw.hex()] = list(zip(samples.times_ns.tolist(), values, strict=True))
            return sum(len(v) for v in got.values()) >= 5

        dbglog.flush(5.0)
        assert wait_until(arrived, 20)
        received = sorted(s for v in got.values() for s in v)
        assert received == list(zip(stamps, range(5), strict=True))
