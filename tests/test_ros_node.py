"""The private ROS node of the ground floor: own context, argv never parsed, wait set, take loop, identity."""

from __future__ import annotations

import os
import subprocess
import sys
import time

from std_msgs.msg import Float64

from dbglog._ros._node import PrivateNode, WaitSet, own_nodes, take_batch
from dbglog._ros._qos import subscription_qos
from tests._ros import RosPeer, wait_until


def test_private_node_lists_its_identity_while_alive() -> None:
    """A private node's (namespace, name) is in own_nodes until it is closed; close is idempotent."""
    ros = PrivateNode("dbglog_test_private")
    try:
        assert ros.identity == ("/", "dbglog_test_private")
        assert ros.identity in own_nodes()
        assert ros.ok()
    finally:
        ros.close()
    assert ros.identity not in own_nodes()
    assert not ros.ok()
    ros.close()


def test_wait_set_wakes_for_data_and_take_batch_takes_at_most_limit() -> None:
    """The wait set reports a ready subscription; take_batch takes CDR bytes and stamps, `limit` at a time."""
    ros = PrivateNode("dbglog_test_take")
    try:
        sub = ros.node.create_subscription(
            Float64, "/ros_node_test/x", lambda _m: None, subscription_qos(50), raw=True
        )
        waits = WaitSet(ros, ros.guard())
        with RosPeer("ros_node_test_peer") as peer:
            pub = peer.publisher("/ros_node_test/x", Float64)
            assert peer.wait_for_subscribers(pub)
            assert waits.wait([sub], 0) == set()
            for i in range(5):
                pub.publish(Float64(data=float(i)))
            assert wait_until(lambda: sub.handle.pointer in waits.wait([sub], 100_000_000))
            got: list[bytes] = []
            stamps: list[int] = []

            def took_all() -> bool:
                items, times = take_batch(sub.handle.take_message, Float64, True, 3)
                assert len(items) <= 3
                got.extend(items)
                stamps.extend(times)
                return len(got) == 5

            assert wait_until(took_all)
        assert [b[:4] for b in got] == [b"\x00\x01\x00\x00"] * 5
        assert all(s > 0 for s in stamps)
        assert stamps == sorted(stamps)
    finally:
        ros.close([lambda: ros.node.destroy_subscription(sub)])


def test_ros_starts_whatever_the_command_line_holds() -> None:
    """An argument that is not UTF-8 (a dashboard file name) no longer stops the engine or the bridge."""
    code = (
        "import sys\n"
        "assert sys.argv[1] == '\\udcff.json'\n"
        "from dbglog.viewer._data._engine import Engine\n"
        "from dbglog.regex_bridge import parse_rules\n"
        "from dbglog.regex_bridge._node import Bridge\n"
        "with Engine(node_name='dbglog_argv_test') as engine:\n"
        "    assert engine.identity is not None\n"
        "text = \"rules:\\n  - tag: argv_test\\n    type: int\\n    pattern: 'v=([0-9]+)'\\n\"\n"
        "rules = parse_rules(text)\n"
        "with Bridge(rules, node_name='dbglog_argv_bridge') as bridge:\n"
        "    print('started', bridge.topics)\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code, os.fsdecode(b"\xff.json")],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert out.returncode == 0, out.stderr
    assert "started ('/rosdashboard/argv_test',)" in out.stdout


def test_publisher_tells_its_own_nodes_by_identity_not_by_name() -> None:
    """The engine's subscription is not counted; a foreign node named like the viewer's nodes is."""
    from std_msgs.msg import Bool

    from dbglog.viewer._data._engine import Engine
    from dbglog.viewer._data._model import Binding, Status
    from dbglog.viewer._publishing._publish import PublishRequest, PublishService

    topic = "/ros_node_test/flag"
    service = PublishService(graph_period=0.2)
    try:
        with Engine(graph_period=0.2) as engine, RosPeer("ros_node_test_flag_pub") as peer:
            pub = peer.publisher(topic, Bool)
            engine.bind(Binding(topic))
            assert peer.wait_for_subscribers(pub), "the engine subscribes"
            request = PublishRequest(topic, msg_type="std_msgs/msg/Bool", value=True, value_kind="bool")
            service.update("flag", request, send=False)
            assert wait_until(lambda: "no subscriber" in service.state("flag").reason, 15)
            time.sleep(0.5)  # a few graph reads: the engine's subscription is on the graph all along
            assert service.state("flag").subscribers == 0, service.state("flag")
            with RosPeer("dbglog_viewer_elsewhere") as foreign:
                foreign.subscribe(topic, Bool)
                assert wait_until(lambda: service.state("flag").subscribers == 1, 15), service.state("flag")
                assert service.state("flag").status is Status.LIVE
    finally:
        service.stop()
