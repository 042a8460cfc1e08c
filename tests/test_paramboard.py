"""The viewer's parameter service (`ParamBoard`) against real rclpy nodes: what a widget bound to a node's
parameter shows (its value, range and step, read-only, the node's errors), its sets (rate limited while
dragged, rejections with the node's reason), a node that never answers, time travel, a recording; and the
typed values a widget sends. Real nodes, a real engine's events store and a real parameter client."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator

import pytest

from dbglog._ros._paramclient import ParamClient
from dbglog._ros._params import (
    PARAMETER_EVENTS,
    ParamDescriptor,
    ParamRange,
    ParamType,
    ParamValue,
)
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._events import EventStore
from dbglog.viewer._data._model import Binding, Status
from dbglog.viewer._publishing._params import ParamBoard, ParamState
from tests._param_nodes import CURSED, ParamNodes
from tests._ros import wait_until

WAIT = 30.0
"""Seconds a test waits for what must come (a loaded machine is slow)."""


@pytest.fixture(scope="module")
def nodes() -> Iterator[ParamNodes]:
    """The module's parameter nodes (one that never answers among them)."""
    with ParamNodes("pb_pid") as made:
        yield made


@pytest.fixture(scope="module")
def live(nodes: ParamNodes) -> Iterator[tuple[Engine, ParamClient]]:
    """A real engine's events store, seeded by a real parameter client, as ``dbglog view`` runs them."""
    with Engine() as engine, ParamClient() as client:
        store = engine.events()
        client.watch(store.seed)
        assert wait_until(lambda: store.value(nodes.fqn, "kp") is not None, WAIT), "the node was not seen"
        yield engine, client


class Cursor:
    """The time cursor a test moves (None: live)."""

    def __init__(self) -> None:
        self.at: float | None = None

    def __call__(self) -> float | None:
        return self.at


def _board(live: tuple[Engine, ParamClient], cursor: Cursor | None = None, **kw: object) -> ParamBoard:
    engine, client = live
    return ParamBoard(client, engine.events, cursor or Cursor(), **kw)  # type: ignore[arg-type]


def _until(board: ParamBoard, target: str, check: Callable[[ParamState], object]) -> ParamState:
    """Tick the board (as the viewer's frames do) until the state of `target` passes `check`."""
    deadline = time.monotonic() + WAIT
    while True:
        board.tick()
        state = board.state(target)
        if check(state):
            return state
        assert time.monotonic() < deadline, f"timed out; last state {state}"
        time.sleep(0.01)


def test_a_bound_parameter_is_asked_then_shown_with_its_range(
    live: tuple[Engine, ParamClient], nodes: ParamNodes
) -> None:
    """First asked (waiting), then live: the node's value, its descriptor's range and step, editable."""
    board = _board(live)
    target = f"{nodes.fqn}:count"
    first = board.state(target)
    assert first.status is Status.WAITING
    assert "asking" in first.reason
    state = _until(board, target, lambda s: s.status is Status.LIVE)
    assert state.value == ParamValue(ParamType.INTEGER, nodes.value("count"))
    assert state.range == ParamRange(0, 100, 5, integer=True)
    assert state.editable
    assert (state.node, state.name, state.type) == (nodes.fqn, "count", ParamType.INTEGER)
    assert board.state(target) is state, "an unchanged state is the same object (cheap every frame)"


def test_a_dragged_value_is_rate_limited_and_the_last_one_lands(
    live: tuple[Engine, ParamClient], nodes: ParamNodes
) -> None:
    """Thirty values dragged within a moment go out at most at the rate (on the step, within the range);
    the one let go goes at once and is the node's value; the widget shows it as soon as it is sent."""
    board = _board(live)
    target = f"{nodes.fqn}:kp"
    _until(board, target, lambda s: s.editable)
    sets: list[float] = []
    original = live[1].set_latest

    def counting(node: str, name: str, value: object, **kw: object) -> object:
        sets.append(float(value.value))  # type: ignore[attr-defined]
        return original(node, name, value, **kw)  # type: ignore[arg-type]

    live[1].set_latest = counting  # type: ignore[method-assign,assignment]
    try:
        t0 = time.monotonic()
        for i in range(30):
            board.set(target, 2.0 + i * 0.11, final=False, rate_hz=5.0)
            board.tick()
            time.sleep(0.01)
        board.set(target, 20.0, final=True, rate_hz=5.0)  # past the range: the maximum
        board.set(target, 10.0, final=True, rate_hz=5.0)  # the same again: a release where it was
        span = time.monotonic() - t0
        assert board.state(target).value == ParamValue(ParamType.DOUBLE, 10.0)
        _until(board, target, lambda s: nodes.value("kp") == 10.0 and s.value == ParamValue.of(10.0))
    finally:
        live[1].set_latest = original  # type: ignore[method-assign]
    assert sets[-1] == 10.0
    assert len(sets) <= span * 5 + 2, (sets, span)
    assert len(set(sets)) == len(sets), "a value already asked for, or the node's own, is not sent again"
    assert all(ParamRange(0.0, 10.0, 0.25).contains(v) for v in sets), sets


def test_a_rejection_shows_the_nodes_reason_and_its_value_again(
    live: tuple[Engine, ParamClient], nodes: ParamNodes
) -> None:
    """The node's own callback refuses a value: the note says so with its reason, the value shown is the
    node's again, and the next accepted set clears it."""
    board = _board(live)
    target = f"{nodes.fqn}:kp"
    before = _until(board, target, lambda s: s.editable).value
    board.set(target, CURSED, final=True)
    state = _until(board, target, lambda s: "rejected" in s.note)
    assert state.problem
    assert state.note == f"rejected {CURSED}: kp={CURSED} makes the arm oscillate"
    assert state.value == before
    assert state.status is Status.LIVE, "a rejection is an answer: the node is fine"
    board.set(target, 4.0, final=True)
    state = _until(board, target, lambda s: s.value == ParamValue.of(4.0) and not s.note)
    assert not state.problem


def test_a_read_only_parameter_is_shown_not_set(live: tuple[Engine, ParamClient], nodes: ParamNodes) -> None:
    """A read-only parameter shows its value and says it is read-only; a set is not even sent."""
    board = _board(live)
    target = f"{nodes.fqn}:frame"
    state = _until(board, target, lambda s: s.status is Status.LIVE)
    assert not state.editable
    assert state.read_only
    assert state.note == "read-only (the node says so)"
    assert state.value == ParamValue(ParamType.STRING, "base_link")
    board.set(target, "map", final=True)
    for _ in range(20):
        board.tick()
        time.sleep(0.01)
    assert nodes.value("frame") == "base_link"
    assert board.state(target).note == "read-only (the node says so)"


def test_changes_from_elsewhere_are_shown(live: tuple[Engine, ParamClient], nodes: ParamNodes) -> None:
    """The node changing its own parameter (as another process, rqt or a launch file would) is shown."""
    board = _board(live)
    target = f"{nodes.fqn}:label"
    _until(board, target, lambda s: s.status is Status.LIVE)
    nodes.set_own("label", "from the node")
    _until(board, target, lambda s: s.value == ParamValue(ParamType.STRING, "from the node"))


def test_a_node_that_never_answers_is_an_error_and_nothing_waits(nodes: ParamNodes) -> None:
    """A node whose services never answer: waiting, then an error naming it and saying it did not answer,
    asked again later; no call ever waits on it (each state is answered at once)."""
    with ParamClient(timeout=1.0) as client:
        assert wait_until(lambda: nodes.hung_fqn in client.nodes(), WAIT)
        asked: list[float] = []
        describe = client.describe

        def counting(node: str, names: object, **kw: object) -> object:
            asked.append(time.monotonic())
            return describe(node, names, **kw)  # type: ignore[arg-type]

        client.describe = counting  # type: ignore[method-assign,assignment]
        board = ParamBoard(client, lambda: None, lambda: None, retry_s=0.5)
        target = f"{nodes.hung_fqn}:kp"
        slowest = 0.0
        deadline = time.monotonic() + WAIT
        while True:
            t0 = time.perf_counter()
            board.tick()
            state = board.state(target)
            slowest = max(slowest, time.perf_counter() - t0)
            if state.status is Status.ERROR and len(asked) >= 2:
                break
            assert state.status is not Status.LIVE
            assert time.monotonic() < deadline, state
            time.sleep(0.01)
        assert "did not answer" in state.reason
        assert nodes.hung_fqn in state.reason
        assert "asked again every 0.5 s" in state.reason
        assert asked[1] - asked[0] >= 1.0 + 0.5 - 0.1, "asked again once the timeout and the pause passed"
        assert not state.editable
        assert state.problem
        assert "did not answer" in state.note
        assert slowest < 0.05, f"a frame's parameter work took {slowest * 1000:.1f} ms"


def test_a_node_not_on_the_graph_is_waited_for(live: tuple[Engine, ParamClient]) -> None:
    """A node that is not there (yet) leaves its widget waiting, saying so."""
    _engine, client = live
    board = ParamBoard(ParamClient(timeout=0.5).start(), lambda: None, lambda: None)
    try:
        state = _until(board, "/pb_nobody:kp", lambda s: "not on the ROS graph" in s.reason)
        assert state.status is Status.WAITING
    finally:
        assert board.client is not None
        board.client.close()
    assert client.error is None


def test_paused_shows_the_value_then_read_only(live: tuple[Engine, ParamClient], nodes: ParamNodes) -> None:
    """Paused at a time, the value is the one the parameter had then (from its changes), read-only, and
    saying so; live again, the node's value and editable."""
    board = _board(live, cursor := Cursor())
    target = f"{nodes.fqn}:enabled"
    _until(board, target, lambda s: s.editable)
    store = live[0].events()
    start = store.version
    nodes.set_own("enabled", False)
    assert wait_until(
        lambda: store.version > start and store.value(nodes.fqn, "enabled") == ParamValue.of(False)
    )
    [change] = [e for e in store.all() if getattr(e, "name", "") == "enabled"][-1:]
    cursor.at = change.time - 0.001
    state = board.state(target)
    assert state.value == ParamValue.of(True)
    assert not state.editable
    assert state.note == "paused: the value then, read-only"
    board.set(target, True, final=True)
    cursor.at = change.time
    assert board.state(target).value == ParamValue.of(False)
    cursor.at = None
    assert _until(board, target, lambda s: s.editable).value == ParamValue.of(False)
    assert nodes.value("enabled") is False, "nothing was set while paused"


def test_a_parameter_first_shown_from_a_recording_is_asked_once_live_again(
    live: tuple[Engine, ParamClient], nodes: ParamNodes
) -> None:
    """A widget that came while a recording was shown (nothing asked) asks its node when the viewer is
    live again (File > Back to live), and becomes editable."""
    recording = [True]
    engine, client = live
    board = ParamBoard(client, engine.events, Cursor(), live=lambda: not recording[0])
    target = f"{nodes.fqn}:count"
    assert not board.state(target).editable
    board.tick()
    recording[0] = False
    _until(board, target, lambda s: s.editable and s.range is not None)


def test_a_recording_is_read_only_from_its_events() -> None:
    """Without a client (a recording), values come from the events at the cursor, read-only."""
    from rcl_interfaces.msg import Parameter, ParameterEvent
    from rclpy.serialization import serialize_message

    def event(**changed: object) -> bytes:
        msg = ParameterEvent(node="/rec")
        msg.changed_parameters = [
            Parameter(name=k, value=ParamValue.of(v).to_msg()) for k, v in changed.items()
        ]
        return bytes(serialize_message(msg))

    store = EventStore()
    store.push(PARAMETER_EVENTS, [10.0, 20.0], [event(kp=1.5), event(kp=2.5)])
    cursor = Cursor()
    board = ParamBoard(None, lambda: store, cursor, live=lambda: False)
    cursor.at = 15.0
    state = board.state("/rec:kp")
    assert (state.status, state.value, state.editable) == (Status.LIVE, ParamValue.of(1.5), False)
    assert state.note == "a recording: read-only"
    cursor.at = 5.0
    state = board.state("/rec:kp")
    assert state.status is Status.WAITING
    assert state.value is None
    assert "no value known at the cursor" in state.note
    cursor.at = None
    offline = ParamBoard(None, lambda: store, cursor)  # live, but ROS could not start: read-only too
    state = offline.state("/rec:kp")
    assert (state.value, state.editable) == (ParamValue.of(2.5), False)
    assert state.note == "read-only: no parameter client (no ROS)"


def test_typed_values_take_the_parameters_type() -> None:
    """What a widget sends is made the parameter's type: a slider's float snapped to the step (an integer
    rounded), typed text read as ros2 param set reads it; another type is refused, naming both."""
    double = ParamState(
        "/n:kp", Status.LIVE, descriptor=ParamDescriptor(ParamType.DOUBLE, range=ParamRange(0, 10, 0.25))
    )
    integer = ParamState(
        "/n:count",
        Status.LIVE,
        descriptor=ParamDescriptor(ParamType.INTEGER, range=ParamRange(0, 100, 5, True)),
    )
    text = ParamState("/n:label", Status.LIVE, value=ParamValue.of("x"))
    flag = ParamState("/n:on", Status.LIVE, descriptor=ParamDescriptor(ParamType.BOOL))
    assert double.typed(3.37) == ParamValue(ParamType.DOUBLE, 3.25)
    assert double.typed(99) == ParamValue(ParamType.DOUBLE, 10.0)
    assert integer.typed(12.9) == ParamValue(ParamType.INTEGER, 15)
    assert flag.typed(False) == ParamValue(ParamType.BOOL, False)
    assert double.parse("2") == ParamValue(ParamType.DOUBLE, 2.0)
    assert double.parse("12.5") == ParamValue(ParamType.DOUBLE, 12.5), "the node judges the range"
    assert integer.parse("0x10") == ParamValue(ParamType.INTEGER, 16)
    assert text.parse("1.5") == ParamValue(ParamType.STRING, "1.5")
    assert flag.parse("off") == ParamValue(ParamType.BOOL, False)
    with pytest.raises(ValueError, match="'abc' is a string, not a double"):
        double.parse("abc")
    with pytest.raises(ValueError, match=r"'2\.5' is a double, not an integer"):
        integer.parse("2.5")
    assert Binding("/robot/pid_node:kp").parameter == ("/robot/pid_node", "kp")
    assert Binding("/robot/pid_node").parameter is None
