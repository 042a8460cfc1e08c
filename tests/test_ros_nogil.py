"""Publishing serialized bytes with the GIL released: real rclpy, real Fast DDS, two participants."""

from __future__ import annotations

import pytest
import rclpy
from rclpy.serialization import serialize_message
from std_msgs.msg import Float64, UInt8MultiArray

from dbglog._ros._nogil import unlocked_publish
from dbglog._ros._qos import batch_qos
from tests._ros import RosPeer


def test_bytes_published_without_the_gil_arrive_in_order_like_rclpys() -> None:
    """Every message reaches a subscriber in another participant, in order, interleaved with rclpy's own
    (the handle held around each write or not)."""
    with RosPeer("nogil_pub") as a, RosPeer("nogil_sub") as b:
        got = b.subscribe("/nogil/x", Float64)
        pub = a.publisher("/nogil/x", Float64)
        guarded, unguarded = unlocked_publish(pub), unlocked_publish(pub, guarded=False)
        assert guarded is not None
        assert unguarded is not None
        assert a.wait_for_subscribers(pub)
        for i in range(300):
            data = serialize_message(Float64(data=float(i)))
            (pub.publish, guarded, unguarded)[i % 3](data)
        assert got.wait_for(300)
        assert got.values() == [float(i) for i in range(300)]


def test_a_batch_sized_message_on_the_batch_qos_arrives_whole() -> None:
    """A 64 kB UInt8MultiArray (a big batch) on dbglog's batch QoS arrives byte for byte."""
    payload = bytes(range(256)) * 256
    with RosPeer("nogil_big_pub") as a, RosPeer("nogil_big_sub") as b:
        got = b.subscribe("/nogil/big", UInt8MultiArray, batch_qos())
        pub = a.publisher("/nogil/big", UInt8MultiArray, batch_qos())
        publish = unlocked_publish(pub)
        assert publish is not None
        assert a.wait_for_subscribers(pub)
        publish(serialize_message(UInt8MultiArray(data=payload)))
        assert got.wait_for(1)
        assert bytes(got.values()[0]) == payload


def test_a_destroyed_publisher_or_a_shut_down_context_raises_rclpys_error_not_a_crash() -> None:
    """After the publisher is destroyed rclpy's InvalidHandle; after shutdown the failed write is retried
    through rclpy's publish, which raises its own error (rcl's error state reset, nothing written)."""
    data = serialize_message(Float64(data=1.0))
    with RosPeer("nogil_gone") as a:
        pub = a.publisher("/nogil/gone", Float64)
        publish = unlocked_publish(pub)
        assert publish is not None
        a.node.destroy_publisher(pub)
        with pytest.raises(Exception, match="destruction was requested"):
            publish(data)
    with RosPeer("nogil_down") as a:
        pub = a.publisher("/nogil/down", Float64)
        publish = unlocked_publish(pub)
        assert publish is not None
        rclpy.shutdown(context=a.context)  # the node and its publisher stay: rcl refuses the write
        with pytest.raises(Exception, match=r"(?i)failed to publish"):
            publish(data)
