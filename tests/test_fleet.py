"""Robots for dashboards: discovery from the topics seen, the selection, robot-relative bindings resolved,
each robot's status and a topic's rate from the history; plain Python, no ROS and no window."""

from __future__ import annotations

import subprocess
import sys

import pytest

from dbglog._ros._tags import TagError
from dbglog.viewer._data._history import History, Sample
from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding, Status, TopicInfo
from dbglog.viewer._data._robots import (
    NO_NAMESPACE,
    SETTLE_S,
    Fleet,
    parse_robot,
    relative_to,
    resolve,
    robot_name,
    robot_of,
    topic_rate,
)

FLOAT = ("std_msgs/msg/Float64",)


def infos(*names: str) -> list[TopicInfo]:
    """Graph topics of the given names (Float64, one publisher)."""
    return [TopicInfo(n, FLOAT, 1) for n in names]


def test_robots_are_the_namespaces_of_tags_in_natural_order() -> None:
    """Only dbglog tags make robots (the root too); other topics in a namespace do not."""
    fleet = Fleet()
    assert fleet.observe(
        infos("/robot10/rosdashboard/speed", "/robot2/rosdashboard/speed", "/rosdashboard/x", "/turtle1/pose")
    )
    assert fleet.robots == ["", "/robot2", "/robot10"]
    assert fleet.tags["/robot2"] == ["/robot2/rosdashboard/speed"]
    assert not fleet.observe(
        infos("/robot10/rosdashboard/speed", "/robot2/rosdashboard/speed", "/rosdashboard/x", "/turtle1/pose")
    ), "the same topics again are no change"
    assert [robot_name(r) for r in fleet.robots] == [NO_NAMESPACE, "robot2", "robot10"]


def test_the_first_robot_with_a_namespace_is_selected_until_one_is_chosen() -> None:
    """Root tags seen first leave the selection to the first namespaced robot (robots found a moment apart
    settle on the first in natural order); later arrivals do not take it; a choice then stays."""
    now = [100.0]
    fleet = Fleet(clock=lambda: now[0])
    fleet.observe(infos("/rosdashboard/x"))
    assert fleet.selected == ""
    fleet.observe(infos("/rosdashboard/x", "/robot2/rosdashboard/x"))
    assert fleet.selected == "/robot2"
    now[0] += SETTLE_S / 2
    fleet.observe(infos("/rosdashboard/x", "/robot2/rosdashboard/x", "/robot1/rosdashboard/x"))
    assert fleet.selected == "/robot1", "still settling: the first in natural order"
    now[0] += SETTLE_S
    fleet.observe(infos("/robot0/rosdashboard/x", "/robot1/rosdashboard/x", "/robot2/rosdashboard/x"))
    assert fleet.selected == "/robot1", "a robot that appears later does not take the selection"
    assert fleet.select("/robot2")
    assert not fleet.select("/robot2")
    fleet.observe(infos("/robot0/rosdashboard/x"), held=["/robot1/rosdashboard/x"])
    assert fleet.selected == "/robot2"
    assert fleet.robots == ["", "/robot0", "/robot1", "/robot2"], "robots seen are never forgotten"


def test_a_robot_given_at_start_is_selected_before_it_is_seen() -> None:
    """``--robot robot3``: the widgets follow robot3 whatever appears first."""
    fleet = Fleet("/robot3")
    fleet.observe(infos("/robot1/rosdashboard/x"))
    assert fleet.selected == "/robot3"
    assert fleet.expand(Binding("/rosdashboard/x", robot=SELECTED_ROBOT)) == (
        Binding("/robot3/rosdashboard/x"),
    )


def test_step_goes_round_the_robots() -> None:
    """Next and previous robot wrap around the list."""
    fleet = Fleet()
    fleet.observe(infos("/a/rosdashboard/x", "/b/rosdashboard/x"))
    assert fleet.selected == "/a"
    assert fleet.step(1)
    assert fleet.selected == "/b"
    assert fleet.step(1)
    assert fleet.selected == "/a"
    assert fleet.step(-1)
    assert fleet.selected == "/b"


def test_resolving_a_binding_keeps_its_field_regex_and_transforms() -> None:
    """A relative binding becomes the robot's topic with everything else as it was; a plain one stays."""
    fleet = Fleet("/robot1")
    relative = Binding("/rosdashboard/motor/rpm", "data", "x=(\\d+)", robot=SELECTED_ROBOT)
    assert fleet.expand(relative) == (Binding("/robot1/rosdashboard/motor/rpm", "data", "x=(\\d+)"),)
    plain = Binding("/robot2/rosdashboard/x")
    assert fleet.expand(plain) == (plain,)
    assert resolve(relative, "") == Binding("/rosdashboard/motor/rpm", "data", "x=(\\d+)")


def test_every_robot_gives_one_series_per_robot_in_the_order_they_got_the_topic() -> None:
    """An overlay's series: each robot that has the topic, a later one added at the end (colours stay)."""
    fleet = Fleet()
    every = Binding("/rosdashboard/speed", robot=EVERY_ROBOT)
    assert fleet.expand(every) == (Binding("/rosdashboard/speed"),), "none has it yet: the selected one"
    fleet.observe(infos("/robot2/rosdashboard/speed", "/robot3/rosdashboard/other"))
    assert fleet.expand(every) == (Binding("/robot2/rosdashboard/speed"),)
    fleet.observe(infos("/robot2/rosdashboard/speed", "/robot1/rosdashboard/speed"))
    assert fleet.expand(every) == (
        Binding("/robot2/rosdashboard/speed"),
        Binding("/robot1/rosdashboard/speed"),
    )
    both = fleet.expand_all([every, Binding("/robot1/rosdashboard/speed")])
    assert len(both) == 2, "a concrete binding that an overlay already has is not bound twice"


def test_relative_to_takes_off_the_namespace_of_the_robot_a_topic_belongs_to() -> None:
    """A tag loses its robot, a topic inside a known robot's namespace loses it, another stays whole."""
    robots = ["", "/robot1", "/lab/robot2"]
    b = relative_to(Binding("/lab/robot2/rosdashboard/speed", "data"), SELECTED_ROBOT, robots)
    assert b == Binding("/rosdashboard/speed", "data", robot=SELECTED_ROBOT)
    assert relative_to(Binding("/robot1/odom", "pose.x"), EVERY_ROBOT, robots) == Binding(
        "/odom", "pose.x", robot=EVERY_ROBOT
    )
    assert relative_to(Binding("/turtle1/pose"), SELECTED_ROBOT, robots).topic == "/turtle1/pose"
    assert relative_to(Binding("/x", robot=SELECTED_ROBOT), "", robots) == Binding("/x")
    assert robot_of("/robot1/odom", robots) == "/robot1"
    assert robot_of("/robot1x/odom", robots) == ""
    with pytest.raises(ValueError, match="robot mode"):
        relative_to(Binding("/x"), "$all", robots)


def test_robots_are_named_as_users_type_them() -> None:
    """robot1, /lab/robot1, / and (no namespace) read as namespaces; a bad one says why."""
    assert parse_robot("robot1") == "/robot1"
    assert parse_robot("/lab/robot1") == "/lab/robot1"
    assert parse_robot("/") == ""
    assert parse_robot(NO_NAMESPACE) == ""
    with pytest.raises(TagError, match="rosdashboard"):
        parse_robot("rosdashboard")
    with pytest.raises(TagError, match="namespace"):
        parse_robot("1robot")


def test_robot_states_come_from_their_tags_newest_sample_at_the_moment_shown() -> None:
    """Live within the stale time, stale after it, waiting without a sample; paused, as it was then."""
    store = History(clock=None)
    store.append_numbers("/robot1/rosdashboard/a", [100.0, 101.0], [1.0, 2.0])
    store.append_numbers("/robot1/rosdashboard/b", [104.5], [3.0])
    store.append_numbers("/robot2/rosdashboard/a", [90.0], [1.0])
    fleet = Fleet()
    fleet.observe(infos("/robot3/rosdashboard/a"), held=store.topics())
    states = {s.robot: s for s in fleet.states(store, 105.0, 2.0)}
    assert states["/robot1"].status is Status.LIVE
    assert states["/robot1"].newest == 104.5
    assert states["/robot1"].tags == 2
    assert states["/robot2"].status is Status.STALE
    assert states["/robot3"].status is Status.WAITING
    then = {s.robot: s for s in fleet.states(store, 101.5, 2.0)}
    assert then["/robot1"].newest == 101.0, "paused: the newest sample at the cursor, not after it"
    assert {s.status for s in fleet.states(None, 105.0, 2.0)} == {Status.WAITING}


class _CountedHistory(History):
    """A history that counts its sample look-ups (`at`)."""

    looked_up = 0

    def at(self, topic: str, t: float) -> Sample | None:
        self.looked_up += 1
        return super().at(topic, t)


def test_live_robot_states_read_each_tags_newest_time_without_looking_up_samples() -> None:
    """Live (the cursor after every sample), 2,000 tags' states are their newest held times, no sample looked
    up (16 ms a second for 2,000 tags); paused before a tag's newest sample, that tag's is looked up."""
    store = _CountedHistory(clock=None)
    names = [f"/robot{i % 4 + 1}/rosdashboard/group{i // 80}/tag{i // 4 % 20}" for i in range(2000)]
    for k, name in enumerate(names):
        store.append_numbers(name, [100.0 + k % 7, 200.0 + k % 5], [1.0, 2.0])
    fleet = Fleet()
    fleet.observe(infos(*names), held=store.topics())
    states = {s.robot: s for s in fleet.states(store, 300.0, 2.0)}
    assert store.looked_up == 0
    assert [states[f"/robot{r}"].newest for r in (1, 2, 3, 4)] == [204.0, 204.0, 204.0, 204.0]
    assert {s.status for s in states.values()} == {Status.STALE}
    then = {s.robot: s for s in fleet.states(store, 150.0, 60.0)}
    assert store.looked_up == 2000, "each tag's sample at the cursor, before its newest"
    assert [then[f"/robot{r}"].newest for r in (1, 2, 3, 4)] == [106.0, 106.0, 106.0, 106.0]
    assert {s.status for s in then.values()} == {Status.LIVE}


def test_a_topic_rate_counts_the_samples_of_the_last_seconds() -> None:
    """20 samples a second over the window before t, and the time of the last one."""
    store = History(clock=None)
    times = [1000.0 + i * 0.05 for i in range(200)]
    store.append_numbers("/t", times, [0.0] * 200)
    rate, last = topic_rate(store, "/t", times[-1])
    assert rate == pytest.approx(20.0, rel=0.02)
    assert last == times[-1]
    assert topic_rate(store, "/t", 999.0) == (0.0, None)
    assert topic_rate(store, "/none", 1005.0) == (0.0, None)


def test_dbglog_view_refuses_a_robot_that_is_no_namespace() -> None:
    """``dbglog view --robot 1robot`` exits 2 saying why, before it opens anything."""
    done = subprocess.run(
        [sys.executable, "-m", "dbglog._cli", "view", "--robot", "1robot"],
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert done.returncode == 2
    assert "argument --robot: robot namespace '1robot'" in done.stderr
    assert "no part starting with a digit" in done.stderr
