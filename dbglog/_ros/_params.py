"""ROS 2 node parameters as plain data: typed values, descriptors, ``ros2 param set`` parsing, their events.

`ParamValue` is a parameter's type and Python value; `parse_value` reads the text a user types exactly as
``ros2 param set`` does (a YAML scalar or flow list), and `format_value` writes a value as text that
`parse_value` reads back to the same value. `ParamDescriptor` is what a node says about a parameter (range
and step, read-only, description); `decode_event` reads a ``/parameter_events`` message. The asynchronous
client that asks nodes is `dbglog._ros._paramclient`. No import of rclpy at module level: the message
conversions import ``rcl_interfaces`` when called.
"""

from __future__ import annotations

import enum
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import Any, Final, TypeAlias

__all__ = [
    "PARAMETER_EVENTS",
    "PARAMETER_EVENTS_TYPE",
    "EventMessage",
    "Param",
    "ParamDescriptor",
    "ParamRange",
    "ParamType",
    "ParamValue",
    "PyValue",
    "SetResult",
    "coerce",
    "decode_event",
    "descriptor_from_msg",
    "format_value",
    "join_name",
    "node_name",
    "parse_value",
    "resolve_node",
    "split_name",
]

PARAMETER_EVENTS: Final = "/parameter_events"
"""The topic every ROS 2 node publishes its parameter changes on (rcl's ``qos_profile_parameter_events``)."""
PARAMETER_EVENTS_TYPE: Final = "rcl_interfaces/msg/ParameterEvent"
_INT64: Final = (-(2**63), 2**63 - 1)

PyValue: TypeAlias = (
    bool
    | int
    | float
    | str
    | bytes
    | tuple[bool, ...]
    | tuple[int, ...]
    | tuple[float, ...]
    | tuple[str, ...]
)
"""A parameter's value in Python: arrays are tuples, a byte array is `bytes`."""


class ParamType(enum.IntEnum):
    """A parameter's type, numbered as ``rcl_interfaces/msg/ParameterType``."""

    NOT_SET = 0
    BOOL = 1
    INTEGER = 2
    DOUBLE = 3
    STRING = 4
    BYTE_ARRAY = 5
    BOOL_ARRAY = 6
    INTEGER_ARRAY = 7
    DOUBLE_ARRAY = 8
    STRING_ARRAY = 9

    @property
    def label(self) -> str:
        """The type's name as ``ros2 param`` prints it (``double``, ``integer array``, ``not set``)."""
        return _LABELS[self]

    @property
    def article(self) -> str:
        """``a double``, ``an integer``: the label after its article, for messages."""
        return ("an " if self.label[0] in "aeiou" else "a ") + self.label

    @property
    def is_array(self) -> bool:
        """True for the array types (byte array included)."""
        return self >= ParamType.BYTE_ARRAY


_LABELS: Final = {
    ParamType.NOT_SET: "not set",
    ParamType.BOOL: "boolean",
    ParamType.INTEGER: "integer",
    ParamType.DOUBLE: "double",
    ParamType.STRING: "string",
    ParamType.BYTE_ARRAY: "byte array",
    ParamType.BOOL_ARRAY: "boolean array",
    ParamType.INTEGER_ARRAY: "integer array",
    ParamType.DOUBLE_ARRAY: "double array",
    ParamType.STRING_ARRAY: "string array",
}
_FIELDS: Final = {
    ParamType.BOOL: "bool_value",
    ParamType.INTEGER: "integer_value",
    ParamType.DOUBLE: "double_value",
    ParamType.STRING: "string_value",
    ParamType.BYTE_ARRAY: "byte_array_value",
    ParamType.BOOL_ARRAY: "bool_array_value",
    ParamType.INTEGER_ARRAY: "integer_array_value",
    ParamType.DOUBLE_ARRAY: "double_array_value",
    ParamType.STRING_ARRAY: "string_array_value",
}
_KIND: Final[dict[ParamType, type]] = {
    ParamType.BOOL: bool,
    ParamType.INTEGER: int,
    ParamType.DOUBLE: float,
    ParamType.STRING: str,
    ParamType.BOOL_ARRAY: bool,
    ParamType.INTEGER_ARRAY: int,
    ParamType.DOUBLE_ARRAY: float,
    ParamType.STRING_ARRAY: str,
}
"""The Python type of a scalar parameter, or of an array parameter's elements."""


@dataclass(frozen=True, slots=True)
class ParamValue:
    """A parameter's type and value (``value`` None only for NOT_SET); immutable and hashable.

    Example:
        >>> ParamValue(ParamType.DOUBLE, 2.5).text
        '2.5'
    """

    type: ParamType
    value: PyValue | None = None

    def __post_init__(self) -> None:
        _check(self.type, self.value)

    @property
    def text(self) -> str:
        """The value as `format_value` writes it (``ros2 param set`` reads it back to this value)."""
        return format_value(self)

    def to_json(self) -> object:
        """The value for JSON: arrays as lists, a byte array as a list of numbers, NOT_SET as None."""
        value = self.value
        if isinstance(value, bytes):
            return list(value)
        if isinstance(value, tuple):
            return list(value)
        return value

    @staticmethod
    def of(value: object) -> ParamValue:
        """Return the value of a Python object, typed as rclpy types it (bool, int, float, str, bytes,
        a list or tuple of one of the four scalar types; None is NOT_SET).

        Raises:
            ValueError: the object is of no parameter type (the message says what it is).
        """
        if isinstance(value, ParamValue):
            return value
        if value is None:
            return ParamValue(ParamType.NOT_SET)
        for ptype, kind in ((ParamType.BOOL, bool), (ParamType.INTEGER, int), (ParamType.DOUBLE, float)):
            if isinstance(value, kind):
                return ParamValue(ptype, value)
        if isinstance(value, str):
            return ParamValue(ParamType.STRING, value)
        if isinstance(value, bytes | bytearray):
            return ParamValue(ParamType.BYTE_ARRAY, bytes(value))
        if isinstance(value, list | tuple):
            items = tuple(value)
            for ptype in (
                ParamType.BOOL_ARRAY,
                ParamType.INTEGER_ARRAY,
                ParamType.DOUBLE_ARRAY,
                ParamType.STRING_ARRAY,
            ):
                if all(_is(v, _KIND[ptype]) for v in items):
                    return ParamValue(ptype, items)
        raise ValueError(f"{value!r} ({type(value).__name__}) is not a parameter value")

    @staticmethod
    def from_msg(msg: Any) -> ParamValue:
        """Read an ``rcl_interfaces/msg/ParameterValue`` (an unknown type number reads as NOT_SET)."""
        try:
            ptype = ParamType(int(msg.type))
        except ValueError:
            return ParamValue(ParamType.NOT_SET)
        if ptype is ParamType.NOT_SET:
            return ParamValue(ptype)
        raw = getattr(msg, _FIELDS[ptype])
        value: PyValue
        if ptype is ParamType.BYTE_ARRAY:
            value = b"".join(bytes(b) if isinstance(b, bytes) else bytes([int(b)]) for b in raw)
        elif ptype.is_array:
            kind = _KIND[ptype]
            value = tuple(kind(v) for v in raw)
        else:
            value = _KIND[ptype](raw)
        return ParamValue(ptype, value)

    def to_msg(self) -> Any:
        """Return the ``rcl_interfaces/msg/ParameterValue`` of this value."""
        from rcl_interfaces.msg import ParameterValue as ValueMsg

        msg = ValueMsg(type=int(self.type))
        if self.type is ParamType.BYTE_ARRAY:
            assert isinstance(self.value, bytes)
            msg.byte_array_value = [bytes([b]) for b in self.value]
        elif self.type is not ParamType.NOT_SET:
            setattr(msg, _FIELDS[self.type], list(self.value) if self.type.is_array else self.value)  # type: ignore[arg-type]
        return msg


def _check(ptype: ParamType, value: object) -> None:
    """Raise ValueError unless `value` is what a `ParamType` holds (``bool`` is not an integer here)."""
    ok: bool
    if ptype is ParamType.NOT_SET:
        ok = value is None
    elif ptype is ParamType.BYTE_ARRAY:
        ok = isinstance(value, bytes)
    elif ptype.is_array:
        kind = _KIND[ptype]
        ok = isinstance(value, tuple) and all(_is(v, kind) for v in value)
    else:
        ok = _is(value, _KIND[ptype])
    if not ok:
        raise ValueError(f"{value!r} is not {ptype.article} value")
    if ptype in (ParamType.INTEGER, ParamType.INTEGER_ARRAY):
        values = value if isinstance(value, tuple) else (value,)
        for v in values:
            if not _INT64[0] <= v <= _INT64[1]:
                raise ValueError(f"{v} is out of range for a 64-bit integer parameter")


def _is(value: object, kind: type) -> bool:
    if kind is bool:
        return isinstance(value, bool)
    return isinstance(value, kind) and not isinstance(value, bool)


def parse_value(text: str) -> ParamValue:
    """Read a value typed on a command line exactly as ``ros2 param set`` (Jazzy) reads it.

    The text is loaded as YAML: a boolean (``true``, ``off``, ``yes``), an integer (``1``, ``0x1f``), a
    double (``1.0``, ``1.5e3``, ``.inf``) or a flow list of one of those or of strings (``[1, 2]``,
    ``'[a, b]'``; an empty ``[]`` is a boolean array, a list mixing integers and doubles is the text).
    A quoted or tagged scalar is a string without its quotes (``"'1'"`` and ``'!!str off'`` are the
    strings ``1`` and ``off``); anything else (plain words, empty text, ``null``, a mapping, YAML it cannot
    read) is the text itself, as typed. Where ``ros2 param set`` stops with a traceback (a mapping, a
    date, YAML its scanner rejects) this reads the text as a string.

    Raises:
        ValueError: an integer outside the 64-bit range (``ros2 param set`` fails there too).
    """
    import yaml  # (on use: importing the viewer's API must not load it)

    try:
        loaded = yaml.safe_load(text)
    except yaml.YAMLError:
        return ParamValue(ParamType.STRING, text)
    if isinstance(loaded, bool):
        return ParamValue(ParamType.BOOL, loaded)
    if isinstance(loaded, int):
        return ParamValue(ParamType.INTEGER, loaded)
    if isinstance(loaded, float):
        return ParamValue(ParamType.DOUBLE, loaded)
    if isinstance(loaded, str):
        return ParamValue(ParamType.STRING, loaded)
    if isinstance(loaded, list):
        if all(isinstance(v, bool) for v in loaded):
            return ParamValue(ParamType.BOOL_ARRAY, tuple(loaded))
        if all(isinstance(v, int) for v in loaded):  # booleans among integers count as 0 and 1
            return ParamValue(ParamType.INTEGER_ARRAY, tuple(int(v) for v in loaded))
        if all(isinstance(v, float) for v in loaded):
            return ParamValue(ParamType.DOUBLE_ARRAY, tuple(loaded))
        if all(isinstance(v, str) for v in loaded):
            return ParamValue(ParamType.STRING_ARRAY, tuple(loaded))
    return ParamValue(ParamType.STRING, text)


def format_value(value: ParamValue) -> str:
    """Write a value on one line as YAML flow text that `parse_value` reads back to the same value.

    ``true``, ``3``, ``2.5``, ``1.0e-05``, ``.inf``, ``hello``, ``'1.0'`` (a string that would read as a
    number is quoted), ``[1, 2]``, ``[a, b]``; a string with a line break is double-quoted, the break
    escaped (``\\n``, ``\\N`` ...). Two values read back differently: an empty array of a type other than
    boolean reads as a boolean array, and a byte array (written ``[1, 255]``) as an integer array. NOT_SET
    is ``not set``.
    """
    v = value.value
    if value.type is ParamType.NOT_SET:
        return "not set"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, bytes):
        return "[" + ", ".join(str(b) for b in v) + "]"
    data: object = list(v) if isinstance(v, tuple) else v
    text = _dump(data)
    if any(c in text for c in _BREAKS):  # YAML folds a raw line break: escape it in double quotes
        text = _dump(data, style='"')
    return text


_BREAKS: Final = "\n\r\x85\u2028\u2029"
"""The characters YAML reads as line breaks."""


def _dump(data: object, style: str | None = None) -> str:
    import yaml

    text = yaml.safe_dump(
        data, default_flow_style=True, allow_unicode=True, width=math.inf, default_style=style
    )
    if text.endswith("\n...\n"):
        text = text[: -len("\n...\n")]
    return text.rstrip("\n")


def coerce(value: object, ptype: ParamType) -> ParamValue:
    """Return `value` as a parameter of type `ptype`, as a control bound to it sets it: a number for an
    integer parameter is rounded, an integer for a double one widened, a bool for a bool one kept.

    Raises:
        ValueError: the value cannot be that type (a word for a number, a fraction out of range ...).
    """
    if isinstance(value, ParamValue):
        if value.type is ptype:
            return value
        value = value.value
    try:
        if ptype is ParamType.BOOL and isinstance(value, bool | int | float):
            return ParamValue(ptype, bool(value))
        if ptype is ParamType.INTEGER and isinstance(value, int | float) and math.isfinite(value):
            return ParamValue(ptype, round(value))
        if ptype is ParamType.DOUBLE and isinstance(value, int | float):
            return ParamValue(ptype, float(value))
        if ptype is ParamType.STRING and isinstance(value, str):
            return ParamValue(ptype, value)
        if ptype.is_array and isinstance(value, list | tuple) and ptype is not ParamType.BYTE_ARRAY:
            kind = _KIND[ptype]
            items = tuple(coerce(v, _SCALAR_OF[ptype]).value for v in value)
            return ParamValue(ptype, tuple(kind(v) for v in items))
        if ptype is ParamType.BYTE_ARRAY and isinstance(value, bytes | bytearray | list | tuple):
            return ParamValue(ptype, bytes(value))
    except ValueError as exc:
        raise ValueError(f"{value!r} cannot be {ptype.article} parameter: {exc}") from None
    raise ValueError(f"{value!r} cannot be {ptype.article} parameter")


_SCALAR_OF: Final = {
    ParamType.BOOL_ARRAY: ParamType.BOOL,
    ParamType.INTEGER_ARRAY: ParamType.INTEGER,
    ParamType.DOUBLE_ARRAY: ParamType.DOUBLE,
    ParamType.STRING_ARRAY: ParamType.STRING,
}


@dataclass(frozen=True, slots=True)
class ParamRange:
    """A descriptor's range: values from `low` to `high`, on the grid ``low + k * step`` (`step` 0: any).

    rcl accepts `high` itself even off the grid, and a value within a relative 1e-7 of a grid point
    (an integer range: exactly on it).
    """

    low: float
    high: float
    step: float = 0.0
    integer: bool = False
    """An ``integer_range`` (bounds and step are ints) rather than a ``floating_point_range``."""

    @property
    def text(self) -> str:
        """``0.0..10.0 step 0.25``, ``0..100``."""

        def fmt(x: float) -> str:
            return str(int(x)) if self.integer else format_value(ParamValue(ParamType.DOUBLE, float(x)))

        step = f" step {fmt(self.step)}" if self.step else ""
        return f"{fmt(self.low)}..{fmt(self.high)}{step}"

    def snap(self, value: float) -> float | int:
        """Return the accepted value nearest `value`: clamped to the range and put on its grid (what a
        slider sends); an int for an integer range."""
        low, high = (self.low, self.high) if self.low <= self.high else (self.high, self.low)
        x = min(max(value, low), high)
        if self.step > 0:
            k = round((x - low) / self.step)
            on = low + k * self.step
            x = high if on > high or (high - x) < abs(on - x) else on
        return round(x) if self.integer else float(x)

    def contains(self, value: float) -> bool:
        """True when the node would accept `value` by its range (bounds and step)."""
        low, high = (self.low, self.high) if self.low <= self.high else (self.high, self.low)
        if self.integer:
            if value != value // 1 or not low <= value <= high:
                return False
            return not self.step or value == high or (value - low) % self.step == 0
        if not low <= value <= high and not (math.isclose(value, low) or math.isclose(value, high)):
            return False
        if not self.step or math.isclose(value, high, rel_tol=1e-7):
            return True
        k = round((value - low) / self.step)
        return math.isclose(value, low + k * self.step, rel_tol=1e-7)


@dataclass(frozen=True, slots=True)
class ParamDescriptor:
    """What a node says about one of its parameters (``rcl_interfaces/msg/ParameterDescriptor``)."""

    type: ParamType = ParamType.NOT_SET
    description: str = ""
    constraints: str = ""
    """Free text (``additional_constraints``): rules the range cannot say."""
    read_only: bool = False
    dynamic_typing: bool = False
    """The parameter may change type (otherwise a set of another type is rejected)."""
    range: ParamRange | None = None


def descriptor_from_msg(msg: Any) -> ParamDescriptor:
    """Read an ``rcl_interfaces/msg/ParameterDescriptor``."""
    span: ParamRange | None = None
    if len(msg.floating_point_range):
        r = msg.floating_point_range[0]
        span = ParamRange(float(r.from_value), float(r.to_value), float(r.step))
    elif len(msg.integer_range):
        r = msg.integer_range[0]
        span = ParamRange(int(r.from_value), int(r.to_value), int(r.step), integer=True)
    try:
        ptype = ParamType(int(msg.type))
    except ValueError:
        ptype = ParamType.NOT_SET
    return ParamDescriptor(
        type=ptype,
        description=str(msg.description),
        constraints=str(msg.additional_constraints),
        read_only=bool(msg.read_only),
        dynamic_typing=bool(msg.dynamic_typing),
        range=span,
    )


@dataclass(frozen=True, slots=True)
class Param:
    """One parameter of a node: its name, value and (when asked for) descriptor."""

    name: str
    value: ParamValue
    descriptor: ParamDescriptor | None = None


@dataclass(frozen=True, slots=True)
class SetResult:
    """A node's answer to setting one parameter."""

    name: str
    value: ParamValue
    """The value that was asked for."""
    ok: bool
    reason: str = ""
    """The node's reason (a rejection's: out of range, read-only, its own callback's words)."""


@dataclass(frozen=True, slots=True)
class EventMessage:
    """One ``/parameter_events`` message: what one node declared, changed and deleted at once."""

    node: str
    """The node's fully qualified name (``/ns/pid_node``)."""
    stamp: float
    """The node's own time of the change (its clock: simulated time under ``use_sim_time``)."""
    new: tuple[tuple[str, ParamValue], ...] = ()
    changed: tuple[tuple[str, ParamValue], ...] = ()
    deleted: tuple[tuple[str, ParamValue], ...] = ()


def decode_event(payload: bytes) -> EventMessage:
    """Read a serialized ``rcl_interfaces/msg/ParameterEvent`` (CDR bytes as a raw subscription takes them).

    Raises:
        ValueError: the bytes are not a ParameterEvent.
    """
    from rcl_interfaces.msg import ParameterEvent
    from rclpy.serialization import deserialize_message

    try:
        msg = deserialize_message(payload, ParameterEvent)
    except Exception as exc:  # rclpy raises its own error types for malformed CDR
        raise ValueError(f"not a ParameterEvent: {exc}") from None

    def values(params: Iterable[Any]) -> tuple[tuple[str, ParamValue], ...]:
        return tuple((str(p.name), ParamValue.from_msg(p.value)) for p in params)

    return EventMessage(
        node=str(msg.node),
        stamp=msg.stamp.sec + msg.stamp.nanosec * 1e-9,
        new=values(msg.new_parameters),
        changed=values(msg.changed_parameters),
        deleted=values(msg.deleted_parameters),
    )


def node_name(namespace: str, name: str) -> str:
    """The fully qualified name of a node (``/ns`` + ``name`` -> ``/ns/name``)."""
    return f"{namespace.rstrip('/')}/{name}"


def split_name(target: str) -> tuple[str, str]:
    """Split ``/pid_node:kp`` (how a control names a node's parameter) into the node and the parameter.

    Raises:
        ValueError: no ``:``, or an empty node or parameter name.
    """
    node, sep, name = target.strip().rpartition(":")
    if not sep or not node or not name:
        raise ValueError(f"{target!r} is not NODE:PARAMETER (e.g. /pid_node:kp)")
    return (node if node.startswith("/") else "/" + node), name


def join_name(node: str, name: str) -> str:
    """The ``/pid_node:kp`` form of a node's parameter (`split_name` reads it back)."""
    return f"{node}:{name}"


def resolve_node(given: str, nodes: Sequence[str]) -> str | list[str]:
    """Find the node a user means among the fully qualified `nodes`.

    ``/ns/pid`` must match exactly; a name without a leading ``/`` is ``/pid`` when that exists, else the
    only node called ``pid`` in any namespace. Returns the node, or the candidates (empty: none, several:
    ambiguous).
    """
    name = given.strip().rstrip("/") or "/"
    if name.startswith("/"):
        return name if name in nodes else []
    if "/" + name in nodes:
        return "/" + name
    same = sorted(n for n in nodes if n.rsplit("/", 1)[-1] == name or n.endswith("/" + name))
    return same[0] if len(same) == 1 else same
