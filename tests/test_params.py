"""Parameter values as data: ``ros2 param set`` parsing, one-line formatting, descriptors, ParameterEvents,
markers. Pure functions (rclpy only to make real messages to read)."""

from __future__ import annotations

import datetime
import math

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    Parameter,
    ParameterDescriptor,
    ParameterEvent,
)
from rclpy.parameter import get_parameter_value
from rclpy.serialization import serialize_message

from dbglog._ros._cdr import string_payload
from dbglog._ros._markers import MAX_NOTE, Marker, decode_marker, encode_marker
from dbglog._ros._params import (
    ParamRange,
    ParamType,
    ParamValue,
    coerce,
    decode_event,
    descriptor_from_msg,
    format_value,
    join_name,
    parse_value,
    resolve_node,
    split_name,
)

# What users type, as the issue lists it, and the corners of YAML 1.1 that ros2 param set reads.
TYPED = [
    "true", "True", "off", "yes", "1", "-7", "0x1f", "1_000", "1.0", "-2.5", "1e3", "1.5e3", "1.0e-3",
    ".inf", "-.inf", "'[1, 2]'", "[1, 2]", "[1.0, 2.5]", "[1, 2.5]", "[true, false]", "[true, 1]",
    "[a, b]", "['a', 'b']", "[]", "hello", "hello world", "", " ", "null", "~", "'1'", '"2.5"',
    "!!str off", "- a", "[\"a\", 1]", "2024-01-01", "#comment", "a # b", "'quoted text'",
]  # fmt: skip


def _rclpy(text: str) -> ParamValue:
    return ParamValue.from_msg(get_parameter_value(text))


@pytest.mark.parametrize("text", TYPED)
def test_parse_value_reads_text_as_ros2_param_set(text: str) -> None:
    """Every example reads to the type and value rclpy's ``get_parameter_value`` (what ``ros2 param set``
    calls) gives it."""
    assert parse_value(text) == _rclpy(text)


def test_parse_value_named_cases() -> None:
    """The issue's examples: true a bool, 1 an integer, 1.0 a double, '[1, 2]' a string, [1, 2] an array."""
    assert parse_value("true") == ParamValue(ParamType.BOOL, True)
    assert parse_value("1") == ParamValue(ParamType.INTEGER, 1)
    assert parse_value("1.0") == ParamValue(ParamType.DOUBLE, 1.0)
    assert parse_value("'[1, 2]'") == ParamValue(ParamType.STRING, "[1, 2]")
    assert parse_value("[1, 2]") == ParamValue(ParamType.INTEGER_ARRAY, (1, 2))
    assert parse_value("[1.5, 2.0]") == ParamValue(ParamType.DOUBLE_ARRAY, (1.5, 2.0))
    assert parse_value("[on, off]") == ParamValue(ParamType.BOOL_ARRAY, (True, False))
    assert parse_value("[x, y]") == ParamValue(ParamType.STRING_ARRAY, ("x", "y"))
    assert parse_value("hello world") == ParamValue(ParamType.STRING, "hello world")


@pytest.mark.parametrize("text", ["a: b", "{a: 1}", "x: y: z", "[1, [2]]", "@at", "`tick"])
def test_parse_value_reads_what_ros2_cannot_as_the_text(text: str) -> None:
    """A mapping, a nested list or YAML its scanner rejects (where ``ros2 param set`` fails) is the string
    as typed."""
    assert parse_value(text) == ParamValue(ParamType.STRING, text)


def test_parse_value_refuses_integers_beyond_64_bits() -> None:
    """An integer no parameter can hold is an error naming it (ros2 param set fails on it too)."""
    with pytest.raises(ValueError, match="99999999999999999999 is out of range for a 64-bit integer"):
        parse_value("99999999999999999999")


_SCALAR_TEXT = st.one_of(
    st.booleans().map(lambda b: "true" if b else "false"),
    st.integers(-(2**63), 2**63 - 1).map(str),
    st.floats(allow_nan=False, allow_infinity=False).map(repr),
    st.text(st.characters(codec="utf-8", exclude_categories=("Cs", "Cc")), max_size=12),
)


@settings(max_examples=300, deadline=None)
@given(
    st.one_of(
        _SCALAR_TEXT,
        st.lists(_SCALAR_TEXT, max_size=4).map(lambda items: "[" + ", ".join(items) + "]"),
    )
)
def test_parse_value_agrees_with_rclpy_on_generated_text(text: str) -> None:
    """Generated scalars and flow lists read as rclpy reads them, wherever rclpy gives a value at all."""
    try:
        theirs = _rclpy(text)
    except Exception:  # rclpy fails on YAML its scanner rejects, huge integers
        return
    try:
        loaded = yaml.safe_load(text)
    except yaml.YAMLError:
        loaded = text
    if isinstance(loaded, dict | datetime.date):
        return  # rclpy puts the object itself in string_value (it fails when sent); dbglog sends the text
    assert parse_value(text) == theirs


_VALUES = st.one_of(
    st.booleans().map(lambda v: ParamValue(ParamType.BOOL, v)),
    st.integers(-(2**63), 2**63 - 1).map(lambda v: ParamValue(ParamType.INTEGER, v)),
    st.floats(allow_nan=False).map(lambda v: ParamValue(ParamType.DOUBLE, v)),
    st.text(max_size=20).map(lambda v: ParamValue(ParamType.STRING, v)),
    st.lists(st.booleans(), max_size=4).map(lambda v: ParamValue(ParamType.BOOL_ARRAY, tuple(v))),
    st.lists(st.integers(-(2**63), 2**63 - 1), min_size=1, max_size=4).map(
        lambda v: ParamValue(ParamType.INTEGER_ARRAY, tuple(v))
    ),
    st.lists(st.floats(allow_nan=False), min_size=1, max_size=4).map(
        lambda v: ParamValue(ParamType.DOUBLE_ARRAY, tuple(v))
    ),
    st.lists(st.text(max_size=8), min_size=1, max_size=4).map(
        lambda v: ParamValue(ParamType.STRING_ARRAY, tuple(v))
    ),
)


@settings(max_examples=400, deadline=None)
@given(_VALUES)
def test_format_value_reads_back_to_the_same_value(value: ParamValue) -> None:
    """What a value shows as (a table cell, an event label, a text field) is one line that ``ros2 param
    set`` and `parse_value` read back to that very value."""
    text = format_value(value)
    assert "\n" not in text
    assert parse_value(text) == value
    assert _rclpy(text) == value


@pytest.mark.parametrize(
    ("value", "text"),
    [
        (ParamValue(ParamType.DOUBLE, 2.5), "2.5"),
        (ParamValue(ParamType.DOUBLE, 1e-5), "1.0e-05"),
        (ParamValue(ParamType.DOUBLE, math.inf), ".inf"),
        (ParamValue(ParamType.STRING, "1.0"), "'1.0'"),
        (ParamValue(ParamType.STRING, "two\nlines"), '"two\\nlines"'),
        (ParamValue(ParamType.STRING_ARRAY, ("\x85",)), '["\\N"]'),
        (ParamValue(ParamType.STRING, "a\u2028b"), '"a\\Lb"'),
        (ParamValue(ParamType.BOOL, False), "false"),
        (ParamValue(ParamType.STRING_ARRAY, ("a", "b c")), "[a, b c]"),
        (ParamValue(ParamType.BYTE_ARRAY, b"\x01\xff"), "[1, 255]"),
        (ParamValue(ParamType.NOT_SET), "not set"),
    ],
)
def test_format_value_examples(value: ParamValue, text: str) -> None:
    """Numbers as YAML writes them, strings that would read as another type quoted, bytes as numbers."""
    assert format_value(value) == text


def test_param_value_checks_its_type() -> None:
    """A value of the wrong Python type for its parameter type is refused (a bool is no integer here)."""
    with pytest.raises(ValueError, match="True is not an integer value"):
        ParamValue(ParamType.INTEGER, True)
    with pytest.raises(ValueError, match="is not a double array value"):
        ParamValue(ParamType.DOUBLE_ARRAY, (1.0, "x"))  # type: ignore[arg-type]


def test_param_value_of_python_objects() -> None:
    """Python values type as rclpy types them: 2 an integer, 2.0 a double, a list by its elements."""
    assert ParamValue.of(2) == ParamValue(ParamType.INTEGER, 2)
    assert ParamValue.of(2.0) == ParamValue(ParamType.DOUBLE, 2.0)
    assert ParamValue.of(True) == ParamValue(ParamType.BOOL, True)
    assert ParamValue.of([1, 2]) == ParamValue(ParamType.INTEGER_ARRAY, (1, 2))
    assert ParamValue.of(["a"]) == ParamValue(ParamType.STRING_ARRAY, ("a",))
    assert ParamValue.of(b"\x00") == ParamValue(ParamType.BYTE_ARRAY, b"\x00")
    assert ParamValue.of(None) == ParamValue(ParamType.NOT_SET)
    with pytest.raises(ValueError, match=r"\{'a': 1\} \(dict\) is not a parameter value"):
        ParamValue.of({"a": 1})


@pytest.mark.parametrize(
    "value",
    [
        ParamValue(ParamType.BOOL, True),
        ParamValue(ParamType.INTEGER, -(2**63)),
        ParamValue(ParamType.DOUBLE, 0.1),
        ParamValue(ParamType.STRING, "é"),
        ParamValue(ParamType.BYTE_ARRAY, b"\x00\x7f\xff"),
        ParamValue(ParamType.BOOL_ARRAY, (True, False)),
        ParamValue(ParamType.INTEGER_ARRAY, (1, 2)),
        ParamValue(ParamType.DOUBLE_ARRAY, (1.5,)),
        ParamValue(ParamType.STRING_ARRAY, ("x", "")),
        ParamValue(ParamType.NOT_SET),
    ],
)
def test_param_value_message_round_trip(value: ParamValue) -> None:
    """Every type survives the trip through an rcl_interfaces ParameterValue message."""
    assert ParamValue.from_msg(value.to_msg()) == value


def test_coerce_to_a_parameters_type() -> None:
    """A control's number becomes the parameter's type: rounded for an integer, widened for a double."""
    assert coerce(2, ParamType.DOUBLE) == ParamValue(ParamType.DOUBLE, 2.0)
    assert coerce(2.6, ParamType.INTEGER) == ParamValue(ParamType.INTEGER, 3)
    assert coerce(0.0, ParamType.BOOL) == ParamValue(ParamType.BOOL, False)
    assert coerce([1, 2], ParamType.DOUBLE_ARRAY) == ParamValue(ParamType.DOUBLE_ARRAY, (1.0, 2.0))
    assert coerce(ParamValue.of(3), ParamType.DOUBLE) == ParamValue(ParamType.DOUBLE, 3.0)
    with pytest.raises(ValueError, match="'x' cannot be a double parameter"):
        coerce("x", ParamType.DOUBLE)
    with pytest.raises(ValueError, match="cannot be an integer parameter"):
        coerce(math.nan, ParamType.INTEGER)


def test_range_snap_and_contains() -> None:
    """A slider's value snaps into the range and onto its step; `contains` says what the node accepts."""
    gain = ParamRange(0.0, 10.0, 0.25)
    assert gain.snap(2.6) == 2.5
    assert gain.snap(2.63) == 2.75
    assert gain.snap(-3.0) == 0.0
    assert gain.snap(11.0) == 10.0
    assert gain.contains(2.5)
    assert not gain.contains(2.6)
    assert not gain.contains(10.5)
    assert gain.text == "0.0..10.0 step 0.25"
    count = ParamRange(0, 100, 5, integer=True)
    assert count.snap(12.4) == 10
    assert isinstance(count.snap(12.4), int)
    assert count.contains(15)
    assert not count.contains(7)
    assert not count.contains(105)
    assert count.text == "0..100 step 5"
    odd = ParamRange(0, 10, 3, integer=True)
    assert odd.snap(9.9) == 10
    assert odd.contains(10)
    free = ParamRange(-1.0, 1.0)
    assert free.snap(0.123) == 0.123
    assert free.text == "-1.0..1.0"


def test_descriptor_from_message() -> None:
    """A descriptor's range (floating or integer, with step), read-only flag and texts are read."""
    floating = descriptor_from_msg(
        ParameterDescriptor(
            type=3,
            description="gain",
            additional_constraints="keep it small",
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.25)],
        )
    )
    assert floating.type is ParamType.DOUBLE
    assert floating.range == ParamRange(0.0, 10.0, 0.25)
    assert (floating.description, floating.constraints, floating.read_only) == (
        "gain",
        "keep it small",
        False,
    )
    integer = descriptor_from_msg(
        ParameterDescriptor(
            type=2, read_only=True, integer_range=[IntegerRange(from_value=0, to_value=9, step=3)]
        )
    )
    assert integer.range == ParamRange(0, 9, 3, integer=True)
    assert integer.read_only


def test_decode_event_reads_new_changed_and_deleted() -> None:
    """A serialized ParameterEvent reads back with its node, stamp and each list's names and values."""
    msg = ParameterEvent(node="/robot/pid_node")
    msg.stamp.sec, msg.stamp.nanosec = 100, 500_000_000
    msg.new_parameters = [Parameter(name="ki", value=ParamValue.of(0.5).to_msg())]
    msg.changed_parameters = [Parameter(name="kp", value=ParamValue.of(2.5).to_msg())]
    msg.deleted_parameters = [Parameter(name="old")]
    event = decode_event(serialize_message(msg))
    assert event.node == "/robot/pid_node"
    assert event.stamp == 100.5
    assert event.new == (("ki", ParamValue.of(0.5)),)
    assert event.changed == (("kp", ParamValue.of(2.5)),)
    assert event.deleted == (("old", ParamValue(ParamType.NOT_SET)),)
    with pytest.raises(ValueError, match="not a ParameterEvent"):
        decode_event(b"\x00\x01\x00\x00garbage")


def test_resolve_node_names() -> None:
    """A full name must match; a bare one finds /name first, else the one node of that name anywhere."""
    nodes = ["/pid", "/robot/arm", "/robot/pid", "/a/twin", "/b/twin"]
    assert resolve_node("/robot/pid", nodes) == "/robot/pid"
    assert resolve_node("pid", nodes) == "/pid"
    assert resolve_node("arm", nodes) == "/robot/arm"
    assert resolve_node("robot/arm", nodes) == "/robot/arm"
    assert resolve_node("twin", nodes) == ["/a/twin", "/b/twin"]
    assert resolve_node("/arm", nodes) == []
    assert resolve_node("nope", nodes) == []


def test_split_and_join_node_parameter() -> None:
    """``/pid_node:kp`` (how a control names a parameter) splits into node and name and joins back."""
    assert split_name("/pid_node:kp") == ("/pid_node", "kp")
    assert split_name("ns/pid:gains.p") == ("/ns/pid", "gains.p")
    assert join_name("/pid_node", "kp") == "/pid_node:kp"
    for bad in ("/pid_node", ":kp", "/pid:"):
        with pytest.raises(ValueError, match="is not NODE:PARAMETER"):
            split_name(bad)


def test_type_labels_as_ros2_prints_them() -> None:
    """Type names read as ``ros2 param`` prints them."""
    assert [t.label for t in ParamType] == [
        "not set", "boolean", "integer", "double", "string", "byte array", "boolean array",
        "integer array", "double array", "string array",
    ]  # fmt: skip


def test_marker_round_trip_and_bad_payloads() -> None:
    """A marker survives its String message; malformed ones are refused with what is wrong."""
    marker = Marker(1767225600.25, "robot bumped here ✓")
    assert decode_marker(encode_marker(marker)) == marker
    assert Marker(1.0, "x" * (MAX_NOTE + 50)).note == "x" * MAX_NOTE
    with pytest.raises(ValueError, match="finite number"):
        Marker(math.nan, "never")
    for text, why in [
        ("not json", "not a marker's JSON"),
        ("[1]", "a JSON object"),
        ('{"time": "x", "id": "a"}', "time must be a number"),
        ('{"time": 1, "note": 2, "id": "a"}', "note must be text"),
        ('{"time": 1, "note": "n"}', "id must be non-empty text"),
    ]:
        with pytest.raises(ValueError, match=why):
            decode_marker(string_payload(text))
    with pytest.raises(ValueError, match="not a std_msgs/msg/String"):
        decode_marker(b"\x00")
