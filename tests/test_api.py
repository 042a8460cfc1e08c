"""The typed SDK on real ROS 2: an independent subscriber receives exactly what dbglog publishes."""

from __future__ import annotations

import functools
import threading
import time
import warnings
from collections.abc import Callable, Iterator
from typing import Any

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import Point, Vector3
from rclpy.context import Context
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from std_msgs.msg import (
    Bool,
    Float32,
    Float64,
    Float64MultiArray,
    Int32,
    Int64,
    Int64MultiArray,
    String,
    UInt8,
    UInt8MultiArray,
)

import dbglog
from dbglog import DbglogWarning
from dbglog._ros._qos import tag_qos
from dbglog.api._public import RUNTIME
from tests._ros import RELIABLE_VOLATILE, Collector, RosPeer, wait_until

LATCHED = tag_qos()


@pytest.fixture(scope="module")
def peer() -> Iterator[RosPeer]:
    """One independent ROS 2 participant for the whole module."""
    with RosPeer("api_peer") as p:
        yield p


def _twice(call: Callable[[], None]) -> None:
    call()
    call()


def _graph_type_becomes(peer: RosPeer, topic: str, expected: str) -> bool:
    return wait_until(lambda: peer.topic_types(topic) == [expected])


def _received(collector: Collector, value: object) -> bool:
    return value in collector.values()


def _publisher(tag: str) -> Any:
    return RUNTIME.channels[tag].publisher


def test_logfloat_values_arrive_exactly_with_float64_type(peer: RosPeer) -> None:
    """Every float reaches an independent subscriber bit for bit, typed Float64 on the graph."""
    values = [0.0, -0.0, 1.5, -2.25, 1e-300, 1.7976931348623157e308, float("inf"), -float("inf"), 0.1]
    got = peer.subscribe("/rosdashboard/t_float", Float64, LATCHED)
    for v in values:
        dbglog.logfloat("t_float", v)
    assert got.wait_for(len(values))
    assert [np.float64(x).tobytes() for x in got.values()] == [np.float64(x).tobytes() for x in values]
    assert wait_until(lambda: peer.topic_types("/rosdashboard/t_float") == ["std_msgs/msg/Float64"])
    s = dbglog.stats()
    assert (s.calls, s.published, s.dropped) == (len(values), len(values), 0)


def test_nan_is_published_as_nan(peer: RosPeer) -> None:
    """NaN is a valid Float64 and arrives as NaN."""
    got = peer.subscribe("/rosdashboard/t_nan", Float64, LATCHED)
    dbglog.logfloat("t_nan", float("nan"))
    assert got.wait_for(1)
    assert np.isnan(got.values()[0])


def test_each_typed_function_publishes_its_type(peer: RosPeer) -> None:
    """logint, logbool, logstring and msg_type= publish the declared std_msgs types."""
    cases: list[tuple[str, Any, list[Any]]] = [
        ("t_int", Int64, [0, -(2**63), 2**63 - 1, 42]),
        ("t_bool", Bool, [True, False, True]),
        ("t_str", String, ["", "hello", "ünïcødé ✓", "x" * 1000]),
        ("t_f32", Float32, [1.5, -0.25]),
        ("t_i32", Int32, [-(2**31), 2**31 - 1]),
        ("t_u8", UInt8, [0, 255]),
    ]
    collectors = {tag: peer.subscribe(f"/rosdashboard/{tag}", cls, LATCHED) for tag, cls, _ in cases}
    for v in cases[0][2]:
        dbglog.logint("t_int", v)
    for v in cases[1][2]:
        dbglog.logbool("t_bool", v)
    for v in cases[2][2]:
        dbglog.logstring("t_str", v)
    for v in cases[3][2]:
        dbglog.logfloat("t_f32", v, msg_type=Float32)
    for v in cases[4][2]:
        dbglog.logint("t_i32", v, msg_type="std_msgs/msg/Int32")
    for v in cases[5][2]:
        dbglog.logint("t_u8", v, msg_type=UInt8)
    for tag, cls, values in cases:
        assert collectors[tag].wait_for(len(values)), tag
        assert collectors[tag].values() == values, tag
        assert _graph_type_becomes(peer, f"/rosdashboard/{tag}", f"std_msgs/msg/{cls.__name__}"), tag
    assert dbglog.stats().dropped == 0


def test_logdata_accepts_class_string_instance_and_nested_dict(peer: RosPeer) -> None:
    """logdata publishes any message type, from an instance or from a (nested) dict of fields."""
    got = peer.subscribe("/rosdashboard/t_point", Point, LATCHED)
    dbglog.logdata("t_point", Point(x=1.0, y=2.0, z=3.0), Point)
    dbglog.logdata("t_point", {"x": 4.0, "y": 5.0}, "geometry_msgs/msg/Point")
    assert got.wait_for(2)
    assert [(m.x, m.y, m.z) for m in got.messages] == [(1.0, 2.0, 3.0), (4.0, 5.0, 0.0)]
    from geometry_msgs.msg import Twist

    twist = peer.subscribe("/rosdashboard/t_twist", Twist, LATCHED)
    dbglog.logdata("t_twist", {"linear": {"x": 0.5}, "angular": {"z": -1.0}}, "geometry_msgs/Twist")
    assert twist.wait_for(1)
    assert (twist.messages[0].linear.x, twist.messages[0].angular.z) == (0.5, -1.0)


def test_log_dispatches_on_python_and_numpy_types(peer: RosPeer) -> None:
    """log() picks Bool/Int64/Float64/String, numpy dtypes, MultiArrays and a message's own type."""
    expect: list[tuple[str, Any, Any]] = [
        ("d_bool", True, Bool),
        ("d_int", 7, Int64),
        ("d_float", 2.5, Float64),
        ("d_str", "hi", String),
        ("d_np_f32", np.float32(1.25), Float32),
        ("d_np_i32", np.int32(-5), Int32),
        ("d_np_u8", np.uint8(200), UInt8),
        ("d_np_bool", np.bool_(True), Bool),
        ("d_list", [1.0, 2.0, 3.5], Float64MultiArray),
        ("d_ints", (1, 2, 3), Int64MultiArray),
        ("d_bytes", b"\x01\x02", UInt8MultiArray),
        ("d_vec", Vector3(x=1.0, y=2.0, z=3.0), Vector3),
    ]
    subs = {tag: peer.subscribe(f"/rosdashboard/{tag}", cls, LATCHED) for tag, _, cls in expect}
    for tag, value, _ in expect:
        dbglog.log(tag, value)
    for tag, value, cls in expect:
        assert subs[tag].wait_for(1), tag
        msg = subs[tag].messages[0]
        assert isinstance(msg, cls)
        if cls is Vector3:
            assert (msg.x, msg.y, msg.z) == (1.0, 2.0, 3.0)
        elif "MultiArray" in cls.__name__:
            assert list(msg.data) == list(value)
        else:
            assert msg.data == value, tag
    assert dbglog.stats().dropped == 0


def test_log_numpy_array_fills_multiarray_layout(peer: RosPeer) -> None:
    """A 2-D numpy array arrives flattened with one layout dimension per axis."""
    got = peer.subscribe("/rosdashboard/d_matrix", Float64MultiArray, LATCHED)
    dbglog.log("d_matrix", np.arange(6, dtype=np.float64).reshape(2, 3))
    assert got.wait_for(1)
    msg = got.messages[0]
    assert list(msg.data) == [0.0, 1.0, 2.0, 3.0, 4.0, 5.0]
    assert [(d.size, d.stride) for d in msg.layout.dim] == [(2, 6), (3, 3)]


def test_log_dict_makes_one_subtopic_per_key_recursively(peer: RosPeer) -> None:
    """A dict becomes /rosdashboard/<tag>/<key>, nested dicts nest further."""
    a = peer.subscribe("/rosdashboard/pose/x", Float64, LATCHED)
    b = peer.subscribe("/rosdashboard/pose/meta/ok", Bool, LATCHED)
    c = peer.subscribe("/rosdashboard/pose/meta/name", String, LATCHED)
    dbglog.log("pose", {"x": 1.5, "meta": {"ok": True, "name": "base"}})
    for collector in (a, b, c):
        assert collector.wait_for(1)
    assert (a.values(), b.values(), c.values()) == ([1.5], [True], ["base"])
    s = dbglog.stats()
    assert (s.calls, s.published) == (1, 3)


def test_late_joining_subscriber_gets_the_latest_value(peer: RosPeer) -> None:
    """A transient-local subscriber created after publishing still receives the last value."""
    for v in (1.0, 2.0, 3.0):
        dbglog.logfloat("t_late", v)
    got = peer.subscribe("/rosdashboard/t_late", Float64, LATCHED)
    assert got.wait_for(3)
    assert got.values()[-1] == 3.0


@pytest.mark.parametrize(
    "qos",
    [RELIABLE_VOLATILE, QoSProfile(depth=10, reliability=ReliabilityPolicy.BEST_EFFORT)],
    ids=["volatile", "best_effort"],
)
def test_volatile_and_best_effort_subscribers_receive(peer: RosPeer, qos: QoSProfile) -> None:
    """dbglog's QoS matches volatile and best-effort subscribers too."""
    tag = f"t_qos_{qos.reliability.name.lower()}"
    got = peer.subscribe(f"/rosdashboard/{tag}", Float64, qos)
    dbglog.logfloat(tag, 0.0)
    assert wait_until(lambda: _publisher(tag).get_subscription_count() >= 1, timeout=15)

    def publish_and_check() -> bool:
        dbglog.logfloat(tag, 9.5)
        return 9.5 in got.values()

    assert wait_until(publish_and_check, timeout=15)


def test_ten_threads_on_one_new_tag_create_exactly_one_publisher(peer: RosPeer) -> None:
    """Ten threads logging the same new tag at once share one publisher."""
    created: list[object] = []
    original = RUNTIME._create_channel

    def counting(*args: Any) -> Any:
        ch = original(*args)
        created.append(ch)
        return ch

    RUNTIME._create_channel = counting  # type: ignore[method-assign,assignment]
    try:
        barrier = threading.Barrier(10)

        def worker() -> None:
            barrier.wait()
            dbglog.logfloat("t_race", 1.0)

        threads = [threading.Thread(target=worker) for _ in range(10)]
        for t in threads:
            t.start()
        for t in threads:
            t.join(20)
    finally:
        del RUNTIME._create_channel
    assert len(created) == 1
    assert wait_until(lambda: len(peer.node.get_publishers_info_by_topic("/rosdashboard/t_race")) == 1)
    assert dbglog.stats().published == 10


@pytest.mark.timeout(240)
def test_ten_threads_times_ten_thousand_calls_all_counted(peer: RosPeer) -> None:
    """10 threads x 10k calls: every call counted and published, the last value of each arrives."""
    got = {i: peer.subscribe(f"/rosdashboard/mt/t{i}", Float64, LATCHED) for i in range(10)}

    def worker(i: int) -> None:
        for k in range(10_000):
            dbglog.logfloat(f"mt/t{i}", float(k))

    threads = [threading.Thread(target=worker, args=(i,)) for i in range(10)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(90)
    # stats() first publishes what is still queued, for at most 30 s: with a reliable subscriber on each tag
    # a loaded CI machine once needed longer for the 100k messages (45,056 published by then): ask again.
    s = dbglog.stats()
    for _ in range(3):
        if s.published + s.dropped >= s.calls:
            break
        s = dbglog.stats()
    assert (s.calls, s.published, s.dropped) == (100_000, 100_000, 0)
    for i in range(10):
        assert got[i].wait_for(100, timeout=20), i
        assert wait_until(functools.partial(_received, got[i], 9999.0), timeout=20), i


def test_other_type_on_a_tag_warns_once_and_is_dropped(peer: RosPeer) -> None:
    """The first type wins a tag; another type is dropped with one warning, counted each time."""
    got = peer.subscribe("/rosdashboard/t_conflict", Float64, LATCHED)
    dbglog.logfloat("t_conflict", 1.0)
    with pytest.warns(DbglogWarning, match="one type per tag") as rec:
        _twice(lambda: dbglog.logstring("t_conflict", "oops"))
    assert len(rec) == 1
    dbglog.logfloat("t_conflict", 2.0)
    assert got.wait_for(2)
    assert got.values() == [1.0, 2.0]
    assert dbglog.stats().dropped_by_reason == {"type_conflict": 2}


def test_a_batch_that_cannot_be_encoded_goes_out_sample_by_sample(peer: RosPeer) -> None:
    """A queued value that fits no batch slot (only a bug could queue one) costs only itself: the
    batch's other samples still reach their topics, and the failure is said once."""
    good = peer.subscribe("/rosdashboard/t_unbatched", Float64, LATCHED)
    dbglog.logfloat("t_unbatched", 0.0)
    dbglog.logint("t_unbatchable", 1)
    assert dbglog.flush(10.0)
    assert good.wait_for(1)
    with RUNTIME.pipe.lock:  # the three in one batch
        dbglog.logfloat("t_unbatched", 1.0)
        RUNTIME.pipe.queue.append((RUNTIME.channels["t_unbatchable"], 2.5, time.time_ns()))
        dbglog.logfloat("t_unbatched", 2.0)
    with pytest.warns(DbglogWarning) as rec:
        assert dbglog.flush(10.0)
    said = [str(w.message) for w in rec]
    assert len(said) == 2
    assert said[0].startswith("dbglog: encoding a batch of 3 samples failed (")
    assert "publishing on /rosdashboard/t_unbatchable failed" in said[1]
    assert good.wait_for(3)
    assert good.values() == [0.0, 1.0, 2.0]
    assert dbglog.stats().dropped_by_reason == {"publish_failed": 1}


def test_invalid_tag_is_escaped_with_one_warning_at_the_callers_line(peer: RosPeer) -> None:
    """'t-a-b' publishes on /rosdashboard/t__2d_a__2d_b; the warning names both and points at this file."""
    got = peer.subscribe("/rosdashboard/t__2d_a__2d_b", Float64, LATCHED)
    with pytest.warns(DbglogWarning) as rec:
        _twice(lambda: dbglog.logfloat("t-a-b", 1.0))
    assert len(rec) == 1
    text = str(rec[0].message)
    assert "'t-a-b'" in text
    assert "/rosdashboard/t__2d_a__2d_b" in text
    assert rec[0].filename == __file__
    assert got.wait_for(2)
    assert dbglog.stats().renamed_tags == 1


def test_tags_that_once_shared_a_topic_publish_apart(peer: RosPeer) -> None:
    """速度 and 温度 (both /rosdashboard/__ before), and x-y beside a real x_y, each keep their own topic."""
    names = {"速度": "__901f___5ea6_", "温度": "__6e29___5ea6_", "t_x-y": "t_x__2d_y", "t_x_y": "t_x_y"}
    got = {tag: peer.subscribe("/rosdashboard/" + name, Float64, LATCHED) for tag, name in names.items()}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DbglogWarning)
        for value, tag in enumerate(names):
            dbglog.logfloat(tag, float(value))
    for value, tag in enumerate(names):
        assert got[tag].wait_for(1)
        assert got[tag].values() == [float(value)]
    assert dbglog.stats().renamed_tags == 3


def test_a_dict_under_an_escaped_tag_escapes_each_key_path_once(peer: RosPeer) -> None:
    """log('速度', {'x-1': ...}) publishes on the escaped text 速度/x-1, not an escape of an escape."""
    got = peer.subscribe("/rosdashboard/__901f___5ea6_/x__2d_1", Float64, LATCHED)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DbglogWarning)
        dbglog.log("速度", {"x-1": 2.5})
    assert got.wait_for(1)
    assert got.values() == [2.5]


def test_a_tag_too_long_for_a_topic_is_dropped_with_a_warning(peer: RosPeer) -> None:
    """A tag whose topic would pass rmw's 247 characters is dropped as bad_tag, saying so."""
    with pytest.warns(DbglogWarning, match="too long: its topic would be 574 characters"):
        dbglog.logfloat("速" * 80, 1.0)
    assert dbglog.stats().dropped_by_reason == {"bad_tag": 1}


def test_rate_control_once_skip_first_and_throttle(peer: RosPeer) -> None:
    """once, skip_first and throttle act per tag and call site like ROS logging."""
    once = peer.subscribe("/rosdashboard/r_once", Int64, LATCHED)
    skip = peer.subscribe("/rosdashboard/r_skip", Int64, LATCHED)
    thr = peer.subscribe("/rosdashboard/r_thr", Int64, LATCHED)
    for i in range(5):
        dbglog.logint("r_once", i, once=True)
        dbglog.logint("r_skip", i, skip_first=True)
        dbglog.logint("r_thr", i, throttle=3600.0)
    dbglog.logint("r_once", 99, once=True)  # another call site: its own first call
    assert once.wait_for(2)
    assert skip.wait_for(4)
    assert thr.wait_for(1)
    assert once.values() == [0, 99]
    assert skip.values() == [1, 2, 3, 4]
    assert thr.values() == [0]
    s = dbglog.stats()
    assert (s.calls, s.published, s.rate_limited) == (16, 7, 9)


def test_logging_survives_the_users_rclpy_init_and_shutdown(peer: RosPeer) -> None:
    """dbglog keeps its own context: the user's global init and shutdown do not disturb it."""
    got = peer.subscribe("/rosdashboard/t_user_ctx", Float64, LATCHED)
    dbglog.logfloat("t_user_ctx", 1.0)
    rclpy.init()
    try:
        node = rclpy.create_node("user_node_ctx")
        dbglog.logfloat("t_user_ctx", 2.0)
        node.destroy_node()
    finally:
        rclpy.shutdown()
    dbglog.logfloat("t_user_ctx", 3.0)
    assert got.wait_for(3)
    assert got.values() == [1.0, 2.0, 3.0]
    assert dbglog.stats().dropped == 0


def test_init_with_user_node_publishes_through_it_and_falls_back_after_its_shutdown(peer: RosPeer) -> None:
    """dbglog.init(node=...) puts publishers on the user's node; when its context ends, dbglog's own."""
    ctx = Context()
    rclpy.init(context=ctx)
    node = Node("my_robot_node", context=ctx)
    got = peer.subscribe("/rosdashboard/t_user_node", Float64, LATCHED)
    dbglog.init(node=node)
    dbglog.logfloat("t_user_node", 1.0)
    assert got.wait_for(1)
    infos = peer.node.get_publishers_info_by_topic("/rosdashboard/t_user_node")
    assert wait_until(
        lambda: (
            [i.node_name for i in peer.node.get_publishers_info_by_topic("/rosdashboard/t_user_node")]
            == ["my_robot_node"]
        )
    ), infos
    node.destroy_node()
    rclpy.shutdown(context=ctx)
    dbglog.logfloat("t_user_node", 2.0)
    assert got.wait_for(2)
    assert got.values() == [1.0, 2.0]
    assert dbglog.stats().dropped == 0


def test_a_user_node_in_a_namespace_keeps_its_topics_there_after_the_fallback(peer: RosPeer) -> None:
    """A node in /robot5 puts the tags under /robot5; when its context ends, dbglog's own node goes on in
    /robot5 (the same topic, the same subscriber)."""
    ctx = Context()
    rclpy.init(context=ctx)
    node = Node("ns_robot_node", namespace="/robot5", context=ctx)
    got = peer.subscribe("/robot5/rosdashboard/t_ns_node", Float64, LATCHED)
    dbglog.init(node=node)
    dbglog.logfloat("t_ns_node", 1.0)
    assert got.wait_for(1)
    node.destroy_node()
    rclpy.shutdown(context=ctx)
    dbglog.logfloat("t_ns_node", 2.0)
    assert got.wait_for(2)
    assert got.values() == [1.0, 2.0]
    writers = peer.node.get_publishers_info_by_topic("/robot5/rosdashboard/t_ns_node")
    assert wait_until(
        lambda: (
            [
                (i.node_namespace, i.node_name[:7])
                for i in peer.node.get_publishers_info_by_topic("/robot5/rosdashboard/t_ns_node")
            ]
            == [("/robot5", "dbglog_")]
        )
    ), writers


def test_init_refuses_a_node_whose_namespace_cannot_hold_the_tags() -> None:
    """A node in a namespace with a 'rosdashboard' part would make its topics read as another robot's."""
    ctx = Context()
    rclpy.init(context=ctx)
    node = Node("odd_node", namespace="/lab/rosdashboard", context=ctx)
    try:
        with pytest.raises(ValueError, match="'rosdashboard' is dbglog's own"):
            dbglog.init(node=node)
    finally:
        node.destroy_node()
        rclpy.shutdown(context=ctx)


def test_shutdown_then_next_call_reconnects(peer: RosPeer) -> None:
    """dbglog.shutdown() releases everything; the next call connects again."""
    got = peer.subscribe("/rosdashboard/t_reconnect", Float64, LATCHED)
    dbglog.logfloat("t_reconnect", 1.0)
    assert got.wait_for(1)
    dbglog.shutdown()
    assert dbglog.stats().tags == 0
    dbglog.logfloat("t_reconnect", 2.0)
    assert got.wait_for(2)
    assert dbglog.flush(5.0)
