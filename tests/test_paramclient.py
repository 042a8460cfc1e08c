"""The asynchronous parameter client against real rclpy nodes: answers, rejections, silence, absence."""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future

import pytest
from std_msgs.msg import String

from dbglog._ros._markers import MARKER_TOPIC, Marker, decode_marker, marker_qos
from dbglog._ros._paramclient import (
    ClientClosedError,
    NoAnswerError,
    NodeNotFoundError,
    NoParametersError,
    ParamClient,
    ParamError,
)
from dbglog._ros._params import ParamRange, ParamType, ParamValue
from tests._param_nodes import CURSED, ParamNodes
from tests._ros import RosPeer, wait_until

WAIT = 30.0
"""Seconds a test waits for an answer the client must give (a loaded CI machine is slow)."""


@pytest.fixture(scope="module")
def nodes() -> Iterator[ParamNodes]:
    """The module's parameter nodes (one that never answers among them)."""
    with ParamNodes("pc_pid") as made:
        yield made


@pytest.fixture(scope="module")
def client(nodes: ParamNodes) -> Iterator[ParamClient]:
    """One started client for the module, once it sees the nodes."""
    with ParamClient(timeout=10.0) as made:
        assert wait_until(lambda: {nodes.fqn, nodes.twin_fqn, nodes.hung_fqn} <= set(made.nodes()), WAIT)
        yield made


def test_fetch_reads_values_and_descriptors(client: ParamClient, nodes: ParamNodes) -> None:
    """Every parameter of a node in a namespace, with ranges and steps (floating and integer), read-only
    flag, description and constraints."""
    params = {p.name: p for p in client.fetch(nodes.fqn).result(WAIT)}
    assert {"kp", "count", "frame", "gains", "names", "enabled", "label", "use_sim_time"} <= set(params)
    kp, count, frame = params["kp"], params["count"], params["frame"]
    assert kp.value.type is ParamType.DOUBLE
    assert kp.descriptor is not None
    assert kp.descriptor.range == ParamRange(0.0, 10.0, 0.25)
    assert kp.descriptor.description == "proportional gain"
    assert count.descriptor is not None
    assert count.descriptor.range == ParamRange(0, 100, 5, integer=True)
    assert count.descriptor.constraints == "a multiple of 5"
    assert frame.descriptor is not None
    assert frame.descriptor.read_only
    assert frame.value == ParamValue(ParamType.STRING, "base_link")
    assert params["gains"].value == ParamValue(ParamType.DOUBLE_ARRAY, (1.0, 2.0))
    assert params["names"].value == ParamValue(ParamType.STRING_ARRAY, ("a", "b"))


def test_set_accepted_and_rejected_with_the_nodes_reasons(client: ParamClient, nodes: ParamNodes) -> None:
    """A set answers per parameter: accepted ones change the node, rejections carry the node's reason (out
    of range, off the step, read-only, its own callback's, wrong type)."""
    results = client.set(
        nodes.fqn,
        {"kp": 2.5, "count": 7, "frame": "map", "gains": [3.0, 4.0], "enabled": False, "label": 3},
    ).result(WAIT)
    by_name = {r.name: r for r in results}
    assert [r.name for r in results] == ["kp", "count", "frame", "gains", "enabled", "label"]
    assert by_name["kp"].ok
    assert by_name["gains"].ok
    assert by_name["enabled"].ok
    assert nodes.value("kp") == 2.5
    assert list(nodes.value("gains")) == [3.0, 4.0]
    assert not by_name["count"].ok
    assert "step" in by_name["count"].reason
    assert not by_name["frame"].ok
    assert "read-only" in by_name["frame"].reason
    assert not by_name["label"].ok
    assert "type" in by_name["label"].reason
    [cursed] = client.set(nodes.fqn, {"kp": CURSED}).result(WAIT)
    assert not cursed.ok
    assert cursed.reason == f"kp={CURSED} makes the arm oscillate"
    [far] = client.set(nodes.fqn, {"kp": 20.0}).result(WAIT)
    assert not far.ok
    assert "out of range" in far.reason
    assert nodes.value("kp") == 2.5


def test_get_values_and_undeclared_names(client: ParamClient, nodes: ParamNodes) -> None:
    """A get answers the values asked for; a name the node lacks fails the call saying so."""
    values = client.get(nodes.twin_fqn, ["kp", "names"]).result(WAIT)
    assert values == {
        "kp": ParamValue(ParamType.DOUBLE, 1.25),
        "names": ParamValue(ParamType.STRING_ARRAY, ("a", "b")),
    }
    with pytest.raises(ParamError, match=r"has no parameter one of kp, nope \(not declared\)"):
        client.get(nodes.twin_fqn, ["kp", "nope"]).result(WAIT)
    described = client.describe(nodes.twin_fqn, ["count"]).result(WAIT)
    assert described["count"].range == ParamRange(0, 100, 5, integer=True)


def test_a_node_that_never_answers_costs_the_timeout_only(client: ParamClient, nodes: ParamNodes) -> None:
    """Calls to a node whose services never answer return at once; the future fails with NoAnswerError,
    naming the node, at the call's timeout; other nodes answer meanwhile."""
    start = time.monotonic()
    silent = client.get(nodes.hung_fqn, ["kp"], timeout=1.5)
    returned = time.monotonic() - start
    assert returned < 0.05, f"a call took {returned:.3f} s to return"
    answered = client.get(nodes.fqn, ["count"], timeout=WAIT).result(WAIT)
    assert answered["count"].value == 10
    with pytest.raises(
        NoAnswerError, match=rf"{nodes.hung_fqn} did not answer \(get_parameters\) within 1.5 s"
    ):
        silent.result(WAIT)
    took = time.monotonic() - start
    assert 1.4 <= took < 1.5 + 5.0, f"the silent node took {took:.2f} s to be given up"


def test_absent_node_and_node_without_parameters(client: ParamClient) -> None:
    """A node not on the graph fails with NodeNotFoundError; one without parameter services (dbglog's own
    private nodes have none) with NoParametersError."""
    with pytest.raises(NodeNotFoundError, match=r"/pc_nobody is not on the ROS graph"):
        client.list_names("/pc_nobody", timeout=1.0).result(WAIT)
    own = client.node_name
    assert wait_until(lambda: f"/{own}" in client.graph_nodes(), WAIT)
    with pytest.raises(
        NoParametersError, match=rf"/{own} is on the ROS graph but offers no parameter services"
    ):
        client.list_names(f"/{own}", timeout=1.0).result(WAIT)


def test_calls_never_block_and_callbacks_come_from_the_client_thread(
    client: ParamClient, nodes: ParamNodes
) -> None:
    """A hundred calls return in well under a frame; each answer's callback runs on the client's thread
    (one added to a future already answered runs at once in the caller, as `Future` does: not counted)."""
    threads: list[str] = []
    called: list[bool] = []
    start = time.monotonic()
    futures = [client.get(nodes.fqn, ["enabled"]) for _ in range(100)]
    took = time.monotonic() - start
    assert took < 0.1, f"100 calls took {took:.3f} s"
    done = threading.Event()

    def noter(answered_before: bool) -> Callable[[Future[dict[str, ParamValue]]], None]:
        def note(_f: Future[dict[str, ParamValue]]) -> None:
            if not answered_before:
                threads.append(threading.current_thread().name)
            called.append(True)
            if len(called) == len(futures):
                done.set()

        return note

    for future in futures:
        future.add_done_callback(noter(future.done()))
    assert done.wait(WAIT)
    assert set(threads) <= {"dbglog-params"}, threads
    late: list[str] = []
    timed_out = client.get(nodes.hung_fqn, ["kp"], timeout=0.5)  # pending for half a second at least
    timed_out.add_done_callback(lambda _f: late.append(threading.current_thread().name))
    assert wait_until(lambda: bool(late), WAIT)
    assert late == ["dbglog-params"]
    assert all(f.result()["enabled"].type is ParamType.BOOL for f in futures)


def test_cancelled_call_is_dropped(client: ParamClient, nodes: ParamNodes) -> None:
    """A call cancelled before it is sent is never answered (a widget that went away)."""
    future = client.get(nodes.hung_fqn, ["kp"], timeout=0.5)
    assert future.cancel() or future.done()
    later = client.get(nodes.fqn, ["kp"]).result(WAIT)
    assert "kp" in later


def test_watch_tells_each_nodes_values_once(client: ParamClient, nodes: ParamNodes) -> None:
    """A watcher hears every answering node's values with when they were asked; the silent node is not
    waited for."""
    heard: dict[str, tuple[dict[str, ParamValue], float]] = {}
    before = time.monotonic()

    def hear(node: str, values: dict[str, ParamValue], asked_at: float) -> None:
        heard.setdefault(node, (values, asked_at))

    client.watch(hear)
    assert wait_until(lambda: {nodes.fqn, nodes.twin_fqn} <= set(heard), WAIT)
    values, asked_at = heard[nodes.twin_fqn]
    assert values["kp"] == ParamValue(ParamType.DOUBLE, 1.25)
    assert before <= asked_at <= time.monotonic()
    assert nodes.hung_fqn not in heard


def test_publish_marker_reaches_a_late_subscriber() -> None:
    """A published marker is kept: a subscriber that joins afterwards (a recorder) still receives it."""
    marker = Marker(1767225600.5, "robot bumped here")
    with ParamClient() as params:
        params.publish_marker(marker)
        time.sleep(0.5)  # published before anyone subscribes
        with RosPeer("pc_marker_reader") as peer:
            got: list[bytes] = []
            peer.node.create_subscription(String, MARKER_TOPIC, got.append, marker_qos(), raw=True)
            assert wait_until(lambda: len(got) >= 1, WAIT)
    assert decode_marker(got[0]) == marker


def test_close_fails_what_is_unanswered() -> None:
    """Closing the client fails its pending calls with ClientClosedError; later calls fail at once."""
    with ParamNodes("pc_close") as local:
        params = ParamClient(timeout=30.0).start()
        pending = params.get(local.hung_fqn, ["kp"])
        time.sleep(0.3)
        params.close()
        with pytest.raises(ClientClosedError):
            pending.result(5.0)
        with pytest.raises(ClientClosedError):
            params.get(local.fqn, ["kp"]).result(1.0)


def test_bad_values_are_refused_before_sending(client: ParamClient, nodes: ParamNodes) -> None:
    """A value of no parameter type is a ValueError at the call, nothing sent."""
    with pytest.raises(ValueError, match="is not a parameter value"):
        client.set(nodes.fqn, {"kp": object()})
    with pytest.raises(ValueError, match="timeout must be > 0 seconds"):
        ParamClient(timeout=0)


def test_set_latest_sends_one_at_a_time_and_always_the_last(client: ParamClient, nodes: ParamNodes) -> None:
    """A drag's values: one set awaits the node at a time, values sent meanwhile replace one another
    (their futures cancelled), the last is always sent, and the node ends at it."""
    futures = [client.set_latest(nodes.fqn, "count", 5 * k) for k in range(1, 21)]
    last = futures[-1].result(WAIT)
    assert last.ok
    assert nodes.value("count") == 100
    assert futures[0].result(WAIT).ok  # the first went out at once
    cancelled = [f for f in futures if f.cancelled()]
    assert len(cancelled) >= 10, "values sent while one awaited its answer should have replaced each other"
    assert all(f.done() for f in futures)


def test_set_latest_waits_behind_a_silent_node(client: ParamClient, nodes: ParamNodes) -> None:
    """Behind a node that never answers, only the newest value waits; it is sent (and given up) after."""
    first = client.set_latest(nodes.hung_fqn, "kp", 1.0, timeout=1.0)
    waiting = [client.set_latest(nodes.hung_fqn, "kp", float(k), timeout=1.0) for k in range(2, 6)]
    assert all(f.cancelled() for f in waiting[:-1])
    with pytest.raises(NoAnswerError):
        first.result(WAIT)
    with pytest.raises(NoAnswerError):
        waiting[-1].result(WAIT)
    after = client.set_latest(nodes.hung_fqn, "kp", 9.0, timeout=0.5)  # nothing in flight: sent at once
    with pytest.raises(NoAnswerError):
        after.result(WAIT)


def test_ros_that_cannot_start_fails_every_call_saying_why() -> None:
    """When ROS refuses the client's node (an invalid name), every call, queued before or after, fails
    with the reason instead of waiting."""
    params = ParamClient(node_name="not a node name")
    queued = params.get("/anything", ["kp"])
    assert params.wait_started(30.0)
    with pytest.raises(ClientClosedError, match="ROS 2 could not start for the parameter client"):
        queued.result(WAIT)
    with pytest.raises(ClientClosedError, match="could not start"):
        params.list_names("/anything").result(1.0)
    params.close()
