"""The engine keeps bindings apart and tells the user why nothing arrives, against real ROS 2 publishers.

One bad field or formula is that binding's error alone (issue 13.5); a topic nobody publishes gets close
matches or the empty-graph hint (issue 12.17); ``rcl_interfaces/msg/Log`` topics deliver the lines kept
before the viewer started (issue 12.5).
"""

from __future__ import annotations

import itertools
import logging
import threading
import time
import uuid
from collections.abc import Iterator

import pytest
from std_msgs.msg import Float64

from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._model import Binding, SeriesSnapshot, Status
from dbglog.viewer._values._transforms import FormulaTransform
from tests._ros import RosPeer, wait_until

_ids = itertools.count()
TIMEOUT = 30.0
LINES = 300
"""More than the 100 a variable-size topic's queue holds, fewer than rosout's 1000."""


def _topic(stem: str) -> str:
    return f"/test_engine_iso/{stem}_{next(_ids)}_{uuid.uuid4().hex[:6]}"


def _snap_when(
    engine: Engine, binding: Binding, predicate: object, timeout: float = TIMEOUT
) -> SeriesSnapshot:
    """Wait until the binding's snapshot satisfies `predicate`, then return it."""
    assert callable(predicate)
    holder: list[SeriesSnapshot] = [engine.snapshot(binding)]

    def check() -> bool:
        holder[0] = engine.snapshot(binding)
        return bool(predicate(holder[0]))

    assert wait_until(check, timeout), f"condition never held; last snapshot: {holder[0]}"
    return holder[0]


@pytest.fixture
def peer() -> Iterator[RosPeer]:
    """An independent ROS participant that publishes."""
    with RosPeer(f"engine_iso_{uuid.uuid4().hex[:8]}") as p:
        yield p


class _Pump:
    """Publish a Float64 every 20 ms on a background thread until closed."""

    def __init__(self, peer: RosPeer, topic: str) -> None:
        self.pub = peer.publisher(topic, Float64)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        i = 0
        while not self._stop.wait(0.02):
            self.pub.publish(Float64(data=float(i)))
            i += 1

    def close(self) -> None:
        self._stop.set()
        self._thread.join(5)


def test_a_bad_field_or_formula_is_that_bindings_error_alone(
    peer: RosPeer, caplog: pytest.LogCaptureFixture
) -> None:
    """`data.x` and a formula reading `data.real` on Float64 are their own errors, named once, no
    traceback; the good bindings on the same topic stay live."""
    topic = _topic("poison")
    good = Binding(topic)
    also_good = Binding(topic, "data", transforms=(FormulaTransform("x * 2"),))
    bad_field = Binding(topic, "data.x")
    bad_formula = Binding(topic, transforms=(FormulaTransform("x + data.real"),))
    caplog.set_level(logging.DEBUG, logger="dbglog.viewer.engine")
    pump = _Pump(peer, topic)
    try:
        with Engine(graph_period=0.1) as engine:
            for binding in (good, bad_field, bad_formula, also_good):
                engine.bind(binding)
            live = _snap_when(engine, good, lambda s: s.status == Status.LIVE and s.count >= 20)
            doubled = _snap_when(engine, also_good, lambda s: s.status == Status.LIVE and s.count >= 20)
            assert live.last is not None
            assert doubled.last is not None
            field_err = _snap_when(engine, bad_field, lambda s: s.status == Status.ERROR)
            formula_err = _snap_when(engine, bad_formula, lambda s: s.status == Status.ERROR)
            assert "std_msgs/msg/Float64 has no field 'data.x'" in field_err.reason, field_err.reason
            assert "(fields: data)" in field_err.reason
            assert "a formula reads 'data.real'" in formula_err.reason, formula_err.reason
            assert "Float64 has no field 'data.real'" in formula_err.reason
            count = engine.snapshot(good).count
            time.sleep(1.0)  # several graph polls and ingest cycles with the bad bindings in place
            assert engine.snapshot(good).count > count, "the good binding keeps receiving"
            assert engine.snapshot(bad_field).reason == field_err.reason, "the error stays put"
    finally:
        pump.close()
    loud = [r for r in caplog.records if r.levelno >= logging.WARNING or r.exc_info]
    assert loud == [], [r.getMessage() for r in loud]


def test_an_extraction_that_raises_marks_only_its_own_binding(peer: RosPeer) -> None:
    """A binding whose transform raises at ingest turns ERROR with the reason; the topic's others go on."""
    topic = _topic("raises")
    good = Binding(topic)
    # A valid formula that reads a field of the message: the slow (typed-message) path feeds both.
    reader = Binding(topic, transforms=(FormulaTransform("x + data"),))
    pump = _Pump(peer, topic)
    try:
        with Engine(graph_period=0.1) as engine:
            engine.bind(good)
            engine.bind(reader)
            _snap_when(engine, reader, lambda s: s.status == Status.LIVE and s.count >= 5)
            # Break the reader's transform state from outside, as a plugin or a bug might: it raises.
            sub = next(iter(engine._subs.values()))  # white-box: reach the live sink
            sink = sub.sinks[reader]
            assert sink.chain is not None

            def boom(*_args: object) -> object:
                raise ZeroDivisionError("synthetic failure")

            sink.chain.apply_array = boom  # type: ignore[method-assign,assignment]
            err = _snap_when(engine, reader, lambda s: s.status == Status.ERROR)
            assert "ZeroDivisionError: synthetic failure" in err.reason, err.reason
            count = engine.snapshot(good).count
            assert wait_until(lambda: engine.snapshot(good).count > count + 10, TIMEOUT)
            assert engine.snapshot(good).status == Status.LIVE
    finally:
        pump.close()


def test_rosout_lines_logged_before_the_viewer_started_all_arrive(peer: RosPeer) -> None:
    """A node logs 300 lines (within what its rosout publisher keeps), then an engine starts and binds
    /rosout with a regex: all 300 arrive, once each."""
    marker = f"iso{uuid.uuid4().hex[:8]}"
    logger = peer.node.get_logger()
    for i in range(LINES):
        logger.info(f"{marker} value={i}")
    binding = Binding("/rosout", "msg", rf"{marker} value=(\d+)")
    with Engine(graph_period=0.1) as engine:
        engine.bind(binding)
        snap = _snap_when(engine, binding, lambda s: s.count >= LINES)
        time.sleep(0.5)  # anything re-sent would land now
        snap = engine.snapshot(binding)
        assert snap.values.tolist() == [float(i) for i in range(LINES)], snap.values.tolist()
        assert snap.count == LINES
        sub = engine._subs["/rosout"]  # white-box: the subscription's QoS
        qos = sub.sub.qos_profile
        assert (qos.reliability.name, qos.durability.name) == ("RELIABLE", "TRANSIENT_LOCAL")
        assert qos.depth >= 1000, "deep enough for everything a rosout publisher keeps"


def test_a_misspelled_topic_keeps_waiting_and_suggests_close_matches(peer: RosPeer) -> None:
    """After a few seconds, a binding on a typo'd topic still waits, and its reason names the real one."""
    topic = _topic("proximity")
    typo = topic.replace("proximity", "proximty")
    pump = _Pump(peer, topic)
    try:
        with Engine(graph_period=0.1) as engine:
            binding = Binding(typo)
            engine.bind(binding)
            engine.bind(Binding(topic))
            _snap_when(engine, Binding(topic), lambda s: s.status == Status.LIVE)
            snap = _snap_when(engine, binding, lambda s: "did you mean" in s.reason)
            assert snap.status == Status.WAITING
            assert f"nothing publishes {typo}; did you mean {topic}" in snap.reason, snap.reason
    finally:
        pump.close()
