"""Field paths, their accessors, the field tree, and bulk CDR decoding checked against rclpy's serializer."""

from __future__ import annotations

import re
import struct

import pytest
from geometry_msgs.msg import PoseStamped, PoseWithCovariance, Twist
from hypothesis import given, settings
from hypothesis import strategies as st
from rclpy.serialization import serialize_message
from sensor_msgs.msg import Imu, LaserScan
from std_msgs.msg import Bool, Byte, Float32, Float64, Float64MultiArray, Int8, Int64, String, UInt16

from dbglog._ros._cdr import decode_fixed
from dbglog.viewer._data._fields import (
    FieldPathError,
    fixed_size,
    list_fields,
    message_class,
    parse_path,
    resolve,
)
from dbglog.viewer._data._model import ValueKind

finite = st.floats(allow_nan=False, allow_infinity=False, width=64)


def test_parse_path_steps() -> None:
    """Names and indexes split into steps; a trailing [] marks the whole sequence."""
    assert parse_path("pose.position.z") == (("pose", "position", "z"), False)
    assert parse_path("layout.dim[0].size") == (("layout", "dim", 0, "size"), False)
    assert parse_path("ranges[]") == (("ranges",), True)
    assert parse_path("") == ((), False)


@pytest.mark.parametrize(
    ("path", "message"),
    [
        ("a..b", "expected a field name"),
        ("a.", "expected a field name"),
        ("ranges[]x", "must come last"),
        ("ranges[x]", "expected '.' or '['"),
        ("3d", "expected a field name"),
    ],
)
def test_parse_path_rejects_malformed(path: str, message: str) -> None:
    """Malformed paths raise FieldPathError naming the problem."""
    with pytest.raises(FieldPathError, match=re.escape(message)):
        parse_path(path)


def test_resolve_reads_values_from_typed_messages() -> None:
    """Accessors read nested, indexed and whole-sequence values with their kinds."""
    twist = Twist()
    twist.angular.z = 2.5
    assert resolve(Twist, "angular.z").get(twist) == 2.5
    scan = LaserScan(ranges=[1.0, 2.0, 3.0, 4.0])
    whole = resolve(LaserScan, "ranges")
    assert whole.kind == ValueKind.ARRAY
    assert whole.get(scan) == (1.0, 2.0, 3.0, 4.0)
    assert resolve(LaserScan, "ranges[]").get(scan) == (1.0, 2.0, 3.0, 4.0)
    assert resolve(LaserScan, "ranges[2]").get(scan) == 3.0
    assert resolve(String, "").kind == ValueKind.TEXT
    assert resolve(Bool, "").get(Bool(data=True)) is True
    assert resolve(Byte, "").get(Byte(data=b"\x07")) == 7
    cov = PoseWithCovariance()
    cov.covariance[7] = 0.25
    assert resolve(PoseWithCovariance, "covariance[7]").get(cov) == 0.25


def test_resolve_errors_name_the_valid_choices() -> None:
    """A missing field lists the fields that exist; a message-valued path lists its leaves."""
    with pytest.raises(FieldPathError, match="its fields are: linear, angular"):
        resolve(Twist, "spin")
    with pytest.raises(FieldPathError, match=r"pick one of its fields: angular\.x"):
        resolve(Twist, "angular")
    with pytest.raises(FieldPathError, match="has 36 elements"):
        resolve(PoseWithCovariance, "covariance[36]")
    with pytest.raises(FieldPathError, match="cannot be indexed"):
        resolve(Float64, "data[0]")
    with pytest.raises(FieldPathError, match="not numbers"):
        resolve(Float64MultiArray, "layout.dim")


def test_message_class_reports_missing_packages() -> None:
    """An uninstalled type says so; a malformed name says what is expected."""
    assert message_class("std_msgs/msg/Float64") is Float64
    with pytest.raises(FieldPathError, match="not installed"):
        message_class("no_such_pkg/msg/Thing")
    with pytest.raises(FieldPathError, match="pkg/msg/Name"):
        message_class("Float64")


def test_field_tree_lists_parents_before_children() -> None:
    """list_fields gives every path with its type; sequences end in [] and messages are not numeric."""
    paths = [(f.path, f.type_name, f.numeric) for f in list_fields(Imu)]
    names = [p for p, _, _ in paths]
    assert names.index("orientation") < names.index("orientation.x")
    assert ("orientation", "geometry_msgs/Quaternion", False) in paths
    assert ("orientation_covariance[]", "double[9]", True) in paths
    assert ("header.stamp", "builtin_interfaces/Time", True) in paths
    assert ("header.frame_id", "string", False) in paths


def test_fixed_offsets_are_found_only_before_variable_fields() -> None:
    """Fixed layouts get a CDR offset; anything after a string or sequence does not."""
    assert resolve(Twist, "angular.y").cdr == (32, "<f8")
    assert resolve(Float64, "").cdr == (0, "<f8")
    assert resolve(PoseWithCovariance, "covariance[1]").cdr == (64, "<f8")
    assert resolve(Imu, "orientation.x").cdr is None  # after header.frame_id (a string)
    assert resolve(LaserScan, "ranges[0]").cdr is None


def test_fixed_size_matches_rclpy_serialization_or_is_none() -> None:
    """Fixed-layout types report their CDR payload size; strings and sequences make the size unknown."""
    for msg in (Float64(), Bool(), Twist(), PoseWithCovariance(), Int8(), UInt16()):
        payload = serialize_message(msg)[4:]  # after the encapsulation header
        size = fixed_size(type(msg))
        assert size is not None
        assert len(payload) - 3 <= size <= len(payload)  # CDR pads the payload to a multiple of 4
    for cls in (String, Float64MultiArray, PoseStamped, LaserScan, Imu):
        assert fixed_size(cls) is None


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(finite, finite, finite), min_size=1, max_size=40))
def test_bulk_decode_matches_rclpy_serialization(rows: list[tuple[float, float, float]]) -> None:
    """decode_fixed reads the same numbers from rclpy-serialised Twists as the messages hold."""
    buffers = []
    for lx, ay, az in rows:
        m = Twist()
        m.linear.x, m.angular.y, m.angular.z = lx, ay, az
        buffers.append(serialize_message(m))
    plan = [resolve(Twist, p).cdr for p in ("linear.x", "angular.y", "angular.z")]
    columns = decode_fixed(buffers, [p for p in plan if p is not None])
    assert columns is not None
    assert [c.tolist() for c in columns] == [list(col) for col in zip(*rows, strict=True)]


@pytest.mark.parametrize(
    ("cls", "value"),
    [(Float32, 1.5), (Int8, -7), (UInt16, 65535), (Int64, -(2**40)), (Bool, True)],
)
def test_bulk_decode_of_each_primitive(cls: type, value: float) -> None:
    """Every fixed primitive decodes to its value, in the numpy and in the struct path alike."""
    resolved = resolve(cls, "")
    assert resolved.cdr is not None
    for n in (1, 20):  # few messages use struct, many use one numpy view
        columns = decode_fixed([serialize_message(cls(data=value))] * n, [resolved.cdr])
        assert columns is not None
        assert columns[0].tolist() == [float(value)] * n


def test_bulk_decode_refuses_big_endian_and_short_buffers() -> None:
    """Buffers that are not little-endian CDR, or too short, return None (caller deserialises)."""
    big = b"\x00\x00\x00\x00" + struct.pack(">d", 1.0)
    assert decode_fixed([big] * 3, [(0, "<f8")]) is None
    assert decode_fixed([big] * 20, [(0, "<f8")]) is None
    little = b"\x00\x01\x00\x00" + struct.pack("<d", 1.0)
    for k in (0, 7, 19):  # one of a joined batch is enough
        mixed = [little] * 20
        mixed[k] = big
        assert decode_fixed(mixed, [(0, "<f8")]) is None
    columns = decode_fixed([little] * 20, [(0, "<f8")])
    assert columns is not None
    assert columns[0].tolist() == [1.0] * 20
    assert decode_fixed([b"\x00\x01\x00\x00\x01"], [(0, "<f8")]) is None
