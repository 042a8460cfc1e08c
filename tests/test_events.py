"""The events store: parameter changes (old → new) and user markers by time, fed from real ParameterEvent
messages, each node's seeded values, a recording's history and the live engine."""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from rcl_interfaces.msg import Parameter, ParameterEvent
from rclpy.serialization import serialize_message

from dbglog._ros._markers import MARKER_TOPIC, Marker, encode_marker
from dbglog._ros._paramclient import ParamClient
from dbglog._ros._params import PARAMETER_EVENTS, PARAMETER_EVENTS_TYPE, ParamType, ParamValue
from dbglog.viewer._data._engine import Engine
from dbglog.viewer._data._events import (
    EventKind,
    EventStore,
    ParamChange,
    event_json,
    event_label,
    events_of,
)
from dbglog.viewer._data._history import History
from dbglog.viewer._data._replay import load_replay
from tests._children import stop_child
from tests._param_nodes import ParamNodes
from tests._ros import wait_until

WAIT = 30.0


def _event(
    node: str,
    *,
    new: dict[str, object] | None = None,
    changed: dict[str, object] | None = None,
    deleted: tuple[str, ...] = (),
) -> bytes:
    """The CDR bytes of a real ParameterEvent."""
    msg = ParameterEvent(node=node)
    msg.stamp.sec = 7
    msg.new_parameters = [Parameter(name=k, value=ParamValue.of(v).to_msg()) for k, v in (new or {}).items()]
    msg.changed_parameters = [
        Parameter(name=k, value=ParamValue.of(v).to_msg()) for k, v in (changed or {}).items()
    ]
    msg.deleted_parameters = [Parameter(name=k) for k in deleted]
    return bytes(serialize_message(msg))


class _Clock:
    """A monotonic clock the test moves."""

    def __init__(self) -> None:
        self.now = 100.0

    def __call__(self) -> float:
        return self.now


def test_changes_carry_old_and_new_values() -> None:
    """Declared values are remembered, so a later change reads old → new; an unknown old value reads ?."""
    store = EventStore()
    store.push(PARAMETER_EVENTS, [10.0], [_event("/robot/pid", new={"kp": 1.25, "ki": 0.5})])
    store.push(
        PARAMETER_EVENTS,
        [11.0, 12.0],
        [_event("/robot/pid", changed={"kp": 2.5}), _event("/x", changed={"a": 1})],
    )
    changes = store.between(0, 100)
    assert [event_label(e) for e in changes] == ["robot/pid.kp 1.25 → 2.5", "x.a ? → 1"]
    first = changes[0]
    assert isinstance(first, ParamChange)
    assert (first.time, first.node, first.name, first.kind) == (11.0, "/robot/pid", "kp", EventKind.CHANGED)
    assert first.old == ParamValue(ParamType.DOUBLE, 1.25)
    assert first.new == ParamValue(ParamType.DOUBLE, 2.5)
    assert first.stamp == 7.0
    declared = store.between(0, 100, kinds=None)[:2]
    assert [event_label(e) for e in declared] == [
        "robot/pid.kp = 1.25 (declared)",
        "robot/pid.ki = 0.5 (declared)",
    ]
    assert store.value("/robot/pid", "kp") == ParamValue(ParamType.DOUBLE, 2.5)
    assert store.values("/x") == {"a": ParamValue(ParamType.INTEGER, 1)}
    assert store.nodes() == ["/robot/pid", "/x"]


def test_deleted_parameters_and_unreadable_messages() -> None:
    """A deletion is an event (was …) and forgets the value; a message no ParameterEvent is counted."""
    store = EventStore()
    store.push(
        PARAMETER_EVENTS,
        [1.0, 2.0, 3.0],
        [_event("/n", new={"k": "v"}), b"\x00\x01junk", _event("/n", deleted=("k",))],
    )
    [deleted] = store.all()
    assert event_label(deleted) == "n.k deleted (was v)"
    assert store.value("/n", "k") is None
    assert store.unreadable == 1


def test_a_seed_gives_old_values_unless_a_newer_change_arrived() -> None:
    """Values asked for before a change arrived never overwrite it; names gone from the node are forgotten."""
    clock = _Clock()
    store = EventStore(clock=clock)
    store.seed("/n", {"a": ParamValue.of(1), "b": ParamValue.of(2)}, asked_at=99.0)
    store.push(PARAMETER_EVENTS, [5.0], [_event("/n", changed={"a": 10})])
    assert event_label(store.all()[-1]) == "n.a 1 → 10"
    asked = clock.now - 0.5  # asked before the change above was received
    store.seed("/n", {"a": ParamValue.of(1), "c": ParamValue.of(3)}, asked_at=asked)
    assert store.values("/n") == {"a": ParamValue.of(10), "c": ParamValue.of(3)}
    clock.now += 1
    store.seed("/n", {"a": ParamValue.of(11)}, asked_at=clock.now)
    assert store.values("/n") == {"a": ParamValue.of(11)}


def test_markers_in_time_order_once_each_and_published() -> None:
    """A marker lands at its own time (the cursor's, in the past), a copy received again is dropped, the
    store hands each added marker to `publish` and keeps it when publishing fails."""
    store = EventStore()
    store.push(
        PARAMETER_EVENTS, [10.0, 30.0], [_event("/n", changed={"a": 1}), _event("/n", changed={"a": 2})]
    )
    sent: list[Marker] = []
    store.publish = sent.append
    mark = store.add_marker("  robot bumped here ", 20.0)
    assert mark.note == "robot bumped here"
    assert sent == [mark]
    store.push(MARKER_TOPIC, [25.0], [encode_marker(mark)])  # its own copy, back from the graph
    other = Marker(5.0, "before everything")
    store.push(MARKER_TOPIC, [40.0, 41.0], [encode_marker(other), encode_marker(other)])
    assert [e.time for e in store.all()] == [5.0, 10.0, 20.0, 30.0]
    assert store.markers() == [other, mark]

    def broken(_m: Marker) -> None:
        raise RuntimeError("no ROS")

    store.publish = broken
    kept = store.add_marker("still here", 50.0)
    assert store.markers()[-1] == kept
    with pytest.raises(ValueError, match="finite"):
        store.add_marker("never", float("nan"))


def test_between_neighbour_and_version() -> None:
    """Queries by time with kinds; `neighbour` steps to the previous or next event; `version` grows."""
    store = EventStore()
    v0 = store.version
    store.push(
        PARAMETER_EVENTS,
        [1.0, 2.0, 3.0],
        [_event("/n", new={"a": 0}), _event("/n", changed={"a": 1}), _event("/n", changed={"a": 2})],
    )
    store.add_marker("m", 2.5)
    assert store.version > v0
    assert [e.time for e in store.between(2.0, 3.0)] == [2.0, 2.5, 3.0]
    assert [e.time for e in store.between(2.0, 3.0, kinds={EventKind.MARKER})] == [2.5]
    assert store.times(0, 10).tolist() == [2.0, 2.5, 3.0]
    after = store.neighbour(2.0, +1)
    assert after is not None
    assert after.time == 2.5
    before = store.neighbour(2.0, -1, kinds=None)
    assert before is not None
    assert before.time == 1.0
    assert store.neighbour(3.0, +1) is None
    assert len(store) == 4


def test_value_at_a_time_from_the_changes_held() -> None:
    """A parameter's value at a past time: its last change's new value then, before its first change that
    change's old value (None when unknown, not declared yet or deleted), a never-changed one its known value;
    after trimming, what is left still answers."""
    store = EventStore(capacity=20)
    store.seed("/still", {"k": ParamValue.of(7)}, asked_at=0.0)
    store.push(
        PARAMETER_EVENTS,
        [10.0, 20.0, 30.0, 40.0],
        [
            _event("/n", new={"kp": 1.0}),
            _event("/n", changed={"kp": 2.0}),
            _event("/n", changed={"kp": 3.0}),
            _event("/n", deleted=("kp",)),
        ],
    )
    store.push(PARAMETER_EVENTS, [15.0], [_event("/m", changed={"ki": 0.5})])  # first seen changing
    value = ParamValue.of
    assert store.value_at("/n", "kp", 5.0) is None  # not declared yet
    assert store.value_at("/n", "kp", 10.0) == value(1.0)
    assert store.value_at("/n", "kp", 25.0) == value(2.0)
    assert store.value_at("/n", "kp", 39.9) == value(3.0)
    assert store.value_at("/n", "kp", 45.0) is None  # deleted
    assert store.value_at("/m", "ki", 1.0) is None  # unknown before its first change
    assert store.value_at("/m", "ki", 15.0) == value(0.5)
    assert store.value_at("/still", "k", 1.0) == value(7)
    assert store.value_at("/nobody", "k", 1.0) is None
    store.push(PARAMETER_EVENTS, np.arange(50.0, 70.0), [_event("/n", new={"kp": 9.0})] * 20)
    assert store.value_at("/n", "kp", 60.5) == value(9.0)
    assert len(store.between(0, 100, kinds=None)) <= 20


def test_capacity_drops_oldest_changes_never_markers() -> None:
    """Past the capacity the oldest changes go (a tenth at once); markers stay."""
    store = EventStore(capacity=10)
    store.add_marker("keep me", 0.5)
    times = np.arange(1.0, 21.0)
    store.push(PARAMETER_EVENTS, times, [_event("/n", changed={"a": int(t)}) for t in times])
    held = store.all()
    assert store.markers()[0].note == "keep me"
    changes = [e for e in held if isinstance(e, ParamChange)]
    assert len(changes) <= 10
    assert changes[-1].time == 20.0


def test_event_json() -> None:
    """Report entries: a change's node, name, old and new (null and old_known false when unknown), a
    marker's note; arrays are lists."""
    store = EventStore()
    store.push(
        PARAMETER_EVENTS,
        [1.0, 2.0],
        [_event("/n", changed={"g": [1.0, 2.0]}), _event("/n", changed={"g": [3.0]})],
    )
    first, second = (event_json(e) for e in store.all())
    assert first == {
        "time": 1.0, "kind": "changed", "node": "/n", "name": "g", "old": None, "old_type": None,
        "old_known": False, "new": [1.0, 2.0], "new_type": "double array", "label": "n.g ? → [1.0, 2.0]",
    }  # fmt: skip
    assert second["old"] == [1.0, 2.0]
    assert second["old_known"] is True
    mark = store.add_marker("note", 3.0)
    assert event_json(mark) == {"time": 3.0, "kind": "marker", "note": "note", "id": mark.id}


def test_events_of_a_history_and_the_markers_to_save() -> None:
    """A history holding both topics (a recording's) gives the same events; `marker_messages` are what a
    saved recording needs for its replay to show the markers."""
    live = EventStore()
    live.add_marker("m1", 1.5)
    history = History(clock=None)
    history.append_payloads(
        PARAMETER_EVENTS,
        [1.0, 2.0],
        [_event("/n", new={"a": 1}), _event("/n", changed={"a": 2})],
        msg_type=PARAMETER_EVENTS_TYPE,
    )
    times, payloads = live.marker_messages()
    history.append_payloads(MARKER_TOPIC, times, payloads, msg_type="std_msgs/msg/String")
    replayed = events_of(history)
    assert [event_label(e) for e in replayed.all()] == ["m1", "n.a 1 → 2"]


def test_between_is_cheap_with_many_changes_held() -> None:
    """With 20,000 changes held, a second of the timeline is found in well under a millisecond (median 28
    µs a query with 50,000: benchmarks/bench_params)."""
    store = EventStore()
    payload = _event("/n", changed={"a": 1})
    store.push(PARAMETER_EVENTS, np.arange(20_000) * 0.01, [payload] * 20_000)
    start = time.perf_counter()
    for k in range(1000):
        store.between(k * 0.1, k * 0.1 + 1.0)
    per_query = (time.perf_counter() - start) / 1000
    assert per_query < 1e-3, f"{per_query * 1e6:.0f} µs a query"


# --- live: the engine's store, fed from /parameter_events --------------------------------------------


@pytest.fixture(scope="module")
def nodes() -> Iterator[ParamNodes]:
    """The module's parameter nodes."""
    with ParamNodes("ev_pid") as made:
        yield made


def test_live_changes_reach_the_store_fast_with_their_old_values(nodes: ParamNodes) -> None:
    """Changes from another participant and from the node itself appear with old → new (seeded by the
    client's watch) soon after the node accepted them (typically a few ms: benchmarks/bench_params measures
    it; the bound here allows a loaded machine); markers come back once."""
    with Engine() as engine, ParamClient() as params:
        store = engine.events()
        params.watch(store.seed)
        store.publish = params.publish_marker
        assert wait_until(lambda: store.value(nodes.fqn, "kp") is not None, WAIT)
        assert wait_until(lambda: PARAMETER_EVENTS in engine.stats().per_topic, WAIT)
        # An event the node sends before the engine's reader matched its writer is lost (volatile, as ROS
        # sends them): the node's own changes of another parameter until one arrives, then the test's.
        warm = iter(range(1_000_000))

        def warmed() -> bool:
            nodes.set_own("label", f"warm {next(warm)}")
            return any(isinstance(e, ParamChange) and e.name == "label" for e in store.all())

        assert wait_until(warmed, WAIT, interval=0.2)
        delays = []
        for value in (2.5, 3.0, 3.25):
            before = len(store.all())
            answer = params.set(nodes.fqn, {"kp": value})
            assert wait_until(lambda n=before: len(store.all()) > n, WAIT, interval=0.001)  # type: ignore[misc]
            seen = time.time()
            change = store.all()[-1]
            assert isinstance(change, ParamChange)
            delays.append(seen - change.stamp)  # the node's own time of accepting it (same machine's clock)
            assert answer.result(WAIT)[0].ok
        nodes.set_own("count", 20)
        assert wait_until(lambda: "robot/ev_pid.count" in " ".join(event_label(e) for e in store.all()), WAIT)
        labels = [
            event_label(e)
            for e in store.all()
            if isinstance(e, ParamChange) and e.node == nodes.fqn and e.name != "label"
        ]
        assert labels == [
            "robot/ev_pid.kp 1.25 → 2.5",
            "robot/ev_pid.kp 2.5 → 3.0",
            "robot/ev_pid.kp 3.0 → 3.25",
            "robot/ev_pid.count 10 → 20",
        ]
        mark = store.add_marker("robot bumped here")
        assert wait_until(lambda: engine.store.count(MARKER_TOPIC) >= 1, WAIT)
        assert store.markers() == [mark]
        assert engine.held_types()[PARAMETER_EVENTS] == PARAMETER_EVENTS_TYPE
    print(f"parameter change to events store: {', '.join(f'{d * 1e3:.1f} ms' for d in delays)}")
    assert max(delays) < 1.0, f"slowest {max(delays) * 1e3:.0f} ms"


# --- recorded and replayed ------------------------------------------------------------------------------


def test_record_keeps_changes_and_markers_for_the_replay(nodes: ParamNodes, tmp_path: Path) -> None:
    """``dbglog record`` (default targets) records /parameter_events and a viewer's markers; the replay's
    store shows the same changes, old → new from the recorded events, and the marker."""
    out = tmp_path / "run.mcap"
    recorder = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "record", "-o", str(out)],
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
        text=True,
    )
    try:
        with ParamClient() as params:

            def recorded() -> int:
                """The message count of the recorder's next once-a-second summary."""
                assert recorder.stderr is not None
                while True:
                    words = recorder.stderr.readline().replace(",", "").split()
                    assert words, "the recorder ended"
                    if "messages" in words:
                        return int(words[words.index("messages") - 1])

            deadline = time.monotonic() + WAIT
            while recorded() == 0:  # until the recorder is matched with the node's /parameter_events
                assert time.monotonic() < deadline, "the recorder never received a parameter change"
                assert params.set(nodes.twin_fqn, {"kp": 0.25}).result(WAIT)[0].ok
            base = recorded()
            mark = Marker(time.time() - 1.0, "robot bumped here")
            params.publish_marker(mark)
            for value in (4.5, 5.5):
                assert params.set(nodes.twin_fqn, {"kp": value}).result(WAIT)[0].ok
            while recorded() < base + 3:  # the two changes and the marker (its topic new to the recorder)
                assert time.monotonic() < deadline + WAIT, "the recorder missed a change or the marker"
            recorded()  # one more second: a probe's event counted late in `base` would have come first
    finally:
        said = stop_child(recorder)
        assert recorder.returncode == 0, said
    replay = load_replay(out)
    store = replay.events()
    changes = [e for e in store.all() if isinstance(e, ParamChange) and e.node == nodes.twin_fqn]
    assert [c.new for c in changes[-2:]] == [ParamValue.of(4.5), ParamValue.of(5.5)]
    assert event_label(changes[-1]) == "arm/ev_pid.kp 4.5 → 5.5"
    assert store.markers() == [mark]
    assert replay.events() is store


def test_markers_added_to_a_replay_are_saved_with_its_history(tmp_path: Path) -> None:
    """A marker added while replaying a recording is written when its history is saved as a recording (in
    time order, the file's own marker once), so the new file's replay shows both."""
    from dbglog._ros._markers import MARKER_TYPE
    from dbglog.record import McapWriter
    from dbglog.viewer._data._events import unsaved_markers
    from dbglog.viewer._data._export import save_recording

    first = tmp_path / "run.mcap"
    with McapWriter(first) as writer:
        channel = writer.add_channel(MARKER_TOPIC, MARKER_TYPE)
        mark = Marker(100.0, "from the robot")
        writer.write(channel, round(101e9), encode_marker(mark), round(101e9))
    replay = load_replay(first)
    store = replay.events()
    added = store.add_marker("seen in the replay", 100.5)
    times, payloads = unsaved_markers(store, replay.store)
    assert times.tolist() == [100.5]
    second = tmp_path / "again.mcap"
    extra = [(MARKER_TOPIC, MARKER_TYPE, times, payloads)]
    assert save_recording(replay.store, replay.held_types(), second, extra=extra) == 2
    again = load_replay(second).events()
    assert [(m.note, m.id) for m in again.markers()] == [(mark.note, mark.id), (added.note, added.id)]
    assert unsaved_markers(again, load_replay(second).store)[1] == []


def test_recorder_topic_choice_includes_events_unless_left_out() -> None:
    """Any targets record /parameter_events and /_dbglog/markers; --no-events leaves them out unless named
    (or with --all, which records every topic)."""
    from dbglog.record._recorder import parse_targets

    for targets in ([], ["speed"], ["/odom"]):
        chosen = parse_targets(targets, everything=False)
        assert chosen.wants(PARAMETER_EVENTS)
        assert chosen.wants(MARKER_TOPIC)
        assert not parse_targets(targets, everything=False, events=False).wants(PARAMETER_EVENTS)
    named = parse_targets([MARKER_TOPIC], everything=False, events=False)
    assert named.wants(MARKER_TOPIC)
    assert not named.wants(PARAMETER_EVENTS)
    assert parse_targets([], everything=True, events=False).wants(PARAMETER_EVENTS)
    assert not parse_targets(["/odom"], everything=False).wants("/rosout")
