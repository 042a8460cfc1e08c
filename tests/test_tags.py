"""Tags: the ROS 2 topic-name rules, the injective escape of any text, robot namespaces and targets."""

from __future__ import annotations

import itertools
import random

import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st
from rclpy.impl.implementation_singleton import rclpy_implementation as _rclpy

from dbglog._ros._tags import (
    MAX_TOPIC_LENGTH,
    TagError,
    TagName,
    dotted_namespace,
    escape_tag,
    logger_namespace,
    natural_key,
    normalize_robot,
    parse_target,
    parse_topic,
    robot_problem,
    ros_args_namespace,
    tag_of,
    tag_problem,
    tag_topic,
    topic_for_tag,
    unescape_tag,
)

VALID = ["x", "proximity", "arm/joint_1", "a/b/c", "_1", "A_b9", "a_", "_", "x" * (MAX_TOPIC_LENGTH - 14)]
INVALID = {
    "": "empty",
    " ": "not allowed",
    "a-b": "not allowed",
    "1abc": "digit",
    "~": "not allowed",
    "{x}": "not allowed",
    "a//b": "//",
    "/a": "starts with",
    "a/": "ends with",
    "a/2b": "digit",
    "a__b": "'__'",
    "x" * 300: "characters long",
    "nul\x00": "not allowed",
    "ünï": "not allowed",
}
ESCAPED = {
    "a-b": "a__2d_b",
    "速度": "__901f___5ea6_",
    "温度": "__6e29___5ea6_",
    "1abc": "__31_abc",
    "a/2b": "a/__32_b",
    "a//b": "a__2f_/b",
    "/a": "__2f_a",
    "a/": "a__2f_",
    "a__b": "a__5f__b",
    "a_-b": "a__5f___2d_b",
    "a b": "a__20_b",
    "": "__",
    "__": "__5f__",
    "😀": "__1f600_",
}

texts = st.text(max_size=60)
robots = st.sampled_from(["", "/robot1", "/lab/robot_2", "/r"])


def _full_topic_error(topic: str) -> object:
    """rcl's own verdict on a fully qualified topic name (None when valid)."""
    return _rclpy.rclpy_get_validation_error_for_full_topic_name(topic)


@pytest.mark.parametrize("tag", VALID)
def test_plain_tags_pass_and_are_their_own_topic_names(tag: str) -> None:
    """A plain tag has no problem and is its own topic name, as before escaping existed."""
    assert tag_problem(tag) is None
    assert escape_tag(tag) == tag
    assert unescape_tag(tag) == tag


@pytest.mark.parametrize(("tag", "why"), INVALID.items())
def test_invalid_tags_name_their_problem(tag: str, why: str) -> None:
    """Each rule violation is reported with a reason."""
    problem = tag_problem(tag)
    assert problem is not None
    assert why in problem


@pytest.mark.parametrize(("text", "name"), ESCAPED.items())
def test_documented_escapes(text: str, name: str) -> None:
    """The escapes docs/api.md shows, each read back to the text, and valid for rcl."""
    assert escape_tag(text) == name
    assert unescape_tag(name) == text
    assert _full_topic_error(topic_for_tag(name)) is None


def test_the_tags_that_collided_before_get_topics_of_their_own() -> None:
    """速度 and 温度 no longer share /rosdashboard/__, nor a-b the real a_b."""
    topics = {tag_topic(t) for t in ("速度", "温度", "a-b", "a_b", "a b")}
    assert len(topics) == 5
    assert tag_topic("a_b") == "/rosdashboard/a_b"


@pytest.mark.parametrize("bad", [None, 123, b"x", 1.5])
def test_non_strings_are_a_tag_error(bad: object) -> None:
    """Only strings have a topic."""
    with pytest.raises(TagError, match="must be a str"):
        escape_tag(bad)  # type: ignore[arg-type]


def test_a_tag_too_long_for_a_topic_is_refused() -> None:
    """A topic over rmw's limit is an error naming the length, not a cut name shared with other tags."""
    assert len(tag_topic("x" * 233)) == MAX_TOPIC_LENGTH
    with pytest.raises(TagError, match="248 characters"):
        tag_topic("x" * 234)
    with pytest.raises(TagError, match="at most 247"):
        tag_topic("速" * 40)
    with pytest.raises(TagError, match="at most 247"):
        tag_topic("x" * 230, "/robot1")


@given(texts, texts)
def test_escape_is_injective(a: str, b: str) -> None:
    """Two different texts never share a topic name."""
    if a != b:
        assert escape_tag(a) != escape_tag(b)


@given(texts)
def test_escape_round_trips_and_is_valid_for_rcl(text: str) -> None:
    """Every text's name reads back to the text, is stable, and rcl accepts its full topic."""
    name = escape_tag(text)
    assert escape_tag(text) == name
    assert unescape_tag(name) == text
    for topic in (topic_for_tag(name), topic_for_tag(name, "/robot1")):
        if len(topic) <= MAX_TOPIC_LENGTH:  # longer ones are refused (test_a_tag_too_long_...)
            assert _full_topic_error(topic) is None


@given(st.from_regex(r"[A-Za-z_][A-Za-z0-9_]{0,8}(/[A-Za-z_][A-Za-z0-9_]{0,8}){0,3}", fullmatch=True))
def test_plain_names_are_kept_unless_they_hold_the_escape_marker(name: str) -> None:
    """Every valid ROS name without '__' maps to itself; with '__' it is escaped (and reads back)."""
    if "__" in name:
        assert escape_tag(name) != name
        assert unescape_tag(escape_tag(name)) == name
    else:
        assert escape_tag(name) == name


@given(st.text(alphabet="_a1/-", max_size=20))
def test_names_nobody_escaped_read_as_themselves(name: str) -> None:
    """A topic name that is not an escape's output (a hand-made a__b, a__zz_) is shown as it is."""
    text = unescape_tag(name)
    assert text == name or escape_tag(text) == name


@given(texts, robots)
def test_topics_parse_back_to_robot_tag_and_text(text: str, robot: str) -> None:
    """parse_topic inverts tag_topic: robot, escaped tag and the user's own text."""
    topic = topic_for_tag(escape_tag(text), robot)
    name = parse_topic(topic)
    assert name == TagName(robot, escape_tag(text))
    assert name.text == text
    assert name.topic == topic


@given(texts, robots)
def test_labels_read_back_as_the_same_tag(text: str, robot: str) -> None:
    """What tools show (robot1:tag, :a:b) is what parse_target reads back."""
    name = TagName(robot, escape_tag(text))
    assume(len(name.topic) <= MAX_TOPIC_LENGTH)
    assert parse_target(name.label) == name


def test_targets_users_type() -> None:
    """robot1:tag, nested robots, a leading ':' for root tags with ':', full topics, odd heads."""
    assert parse_target("speed") == TagName("", "speed")
    assert parse_target("robot1:speed") == TagName("/robot1", "speed")
    assert parse_target("/robot1:speed") == TagName("/robot1", "speed")
    assert parse_target("lab/robot1:arm/x") == TagName("/lab/robot1", "arm/x")
    assert parse_target(":a:b") == TagName("", "a__3a_b")
    assert parse_target("速度") == TagName("", "__901f___5ea6_")
    assert parse_target("ratio 1:2") == TagName("", escape_tag("ratio 1:2"))
    assert parse_target("/odom") == "/odom"
    assert TagName("", escape_tag("a:b")).label == ":a:b"
    assert TagName("/robot1", "speed").label == "robot1:speed"


def test_other_topics_are_not_tags() -> None:
    """Only /rosdashboard/ topics (in the root or a namespace) parse as tags."""
    for topic in (
        "/odom",
        "/rosdashboard",
        "/rosdashboard/",
        "/x/y",
        "/1a/rosdashboard/x",
        "/a//rosdashboard/x",
    ):
        assert parse_topic(topic) is None
        assert tag_of(topic) is None
    assert tag_of("/rosdashboard/a/rosdashboard/b") == "a/rosdashboard/b"
    assert parse_topic("/r/rosdashboard/a/rosdashboard/b") == TagName("/r", "a/rosdashboard/b")
    assert tag_of("/robot1/rosdashboard/__901f___5ea6_") == "robot1:速度"


@pytest.mark.parametrize(
    ("given_ns", "normal"),
    [("", ""), ("/", ""), ("robot1", "/robot1"), ("/lab/r2", "/lab/r2"), (" r ", "/r")],
)
def test_robot_namespaces_normalize(given_ns: str, normal: str) -> None:
    """A namespace with or without its leading slash; the root is empty."""
    assert normalize_robot(given_ns) == normal


@pytest.mark.parametrize(
    "bad", ["1robot", "/a/", "a//b", "a-b", "/rosdashboard", "/a/rosdashboard/b", "x" * 240]
)
def test_bad_robot_namespaces_say_why(bad: str) -> None:
    """A namespace rcl would refuse, or one with dbglog's own part, is an error naming it."""
    with pytest.raises(TagError, match="robot namespace"):
        normalize_robot(bad)
    assert robot_problem("/" + bad.lstrip("/")) is not None


def test_logger_names_give_their_nodes_namespace() -> None:
    """A /rosout logger's node: from the graph (child loggers too), else its dotted parts say it."""
    nodes = [("ctrl", "/robot1"), ("ctrl", "/"), ("plan", "/lab/r2")]
    assert logger_namespace("robot1.ctrl", nodes) == "/robot1"
    assert logger_namespace("ctrl", nodes) == ""
    assert logger_namespace("ctrl.child", nodes) == ""
    assert logger_namespace("lab.r2.plan.deep", nodes) == "/lab/r2"
    assert logger_namespace("robot3.drive", nodes) is None
    assert dotted_namespace("robot3.drive") == "/robot3"
    assert dotted_namespace("drive") == ""
    assert dotted_namespace("1x.drive") == ""


@settings(max_examples=200)
@given(texts, robots)
def test_every_escaped_topic_is_valid_for_rcl_in_a_namespace(text: str, robot: str) -> None:
    """Namespaced topics of escaped tags pass rcl's full-name validation."""
    try:
        topic = tag_topic(text, robot)
    except TagError:
        return
    assert _full_topic_error(topic) is None


_ARG_TOKENS = [
    "--ros-args",
    "--",
    "-r",
    "--remap",
    "__ns:=/robot1",
    "__ns:=/lab/r2",
    "__ns:=/",
    "other:__ns:=/x",
    "-p",
    "x:=1",
    "-e",
    "/enc",
    "--log-level",
    "info",
    "__node:=renamed",
    "/a:=/b",
    "plain",
    "--enable-rosout-logs",
]


@settings(max_examples=60, deadline=None)
@given(st.lists(st.sampled_from(_ARG_TOKENS), max_size=8))
def test_ros_args_namespace_reads_argv_as_rcl_does(args: list[str]) -> None:
    """The namespace read from a command line is the one rcl gives a node of that process."""
    from rclpy.context import Context
    from rclpy.node import Node

    argv = ["prog", *args]
    context = Context()
    try:
        context.init(argv, initialize_logging=False)
    except Exception:  # rcl refuses the command line: no process would run with it
        assume(False)
    try:
        node = Node("dbglog_1", context=context, enable_rosout=False, start_parameter_services=False)
        try:
            rcl_namespace = node.get_namespace()
        finally:
            node.destroy_node()
    finally:
        context.try_shutdown()
    assert (ros_args_namespace(argv) or "/") == rcl_namespace


def test_natural_key_orders_numbers_by_value() -> None:
    """Digit runs sort by their value (s2 before s10), letters without case first, ties by the text."""
    assert sorted(["s10", "s2", "s1", "s0", "s11"], key=natural_key) == ["s0", "s1", "s2", "s10", "s11"]
    assert sorted(["b", "A", "a2", "a10", "a"], key=natural_key) == ["A", "a", "a2", "a10", "b"]
    assert sorted(["robot10:x", "robot2:x", "robot1:y"], key=natural_key) == [
        "robot1:y",
        "robot2:x",
        "robot10:x",
    ]
    assert sorted(["a1", "a01", "a001"], key=natural_key) == ["a001", "a01", "a1"]
    assert sorted(["x/10/a", "x/9/b", "x/9"], key=natural_key) == ["x/9", "x/9/b", "x/10/a"]


@given(st.lists(st.text(alphabet="ab01_/9", max_size=8), max_size=12), st.randoms())
def test_natural_key_is_a_total_order(texts: list[str], rnd: random.Random) -> None:
    """Any texts sort without error, in one order however they come; equal keys only for equal texts."""
    once = sorted(texts, key=natural_key)
    shuffled = list(texts)
    rnd.shuffle(shuffled)
    assert sorted(shuffled, key=natural_key) == once
    for a, b in itertools.pairwise(once):
        assert natural_key(a) <= natural_key(b)
        assert (natural_key(a) == natural_key(b)) == (a == b)
