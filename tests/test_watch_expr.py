"""The watch expression reader and value copies: what they read, what they refuse, and that no code runs."""

from __future__ import annotations

import enum
import math
import operator
import types
from collections.abc import Callable
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog.watch._expr import MAX_LENGTH, EvalError, ExprError, parse_expr, read_attribute
from dbglog.watch._values import MAX_TEXT, freeze


class Spy:
    """Counts every call of the hooks a careless reader would run."""

    calls: list[str]

    def __init__(self) -> None:
        self.calls = []
        self.value = 2.5

    @property
    def costly(self) -> int:
        self.calls.append("property")
        return 1

    def __getattr__(self, name: str) -> object:
        if name.startswith("__"):
            raise AttributeError(name)
        self.calls.append(f"__getattr__({name})")
        return 0

    def __eq__(self, other: object) -> bool:
        self.calls.append("__eq__")
        return True

    def __lt__(self, other: object) -> bool:
        self.calls.append("__lt__")
        return True

    def __add__(self, other: object) -> int:
        self.calls.append("__add__")
        return 0

    def __radd__(self, other: object) -> int:
        self.calls.append("__radd__")
        return 0

    def __bool__(self) -> bool:
        self.calls.append("__bool__")
        return True

    def __hash__(self) -> int:
        self.calls.append("__hash__")
        return 1

    def __repr__(self) -> str:
        self.calls.append("__repr__")
        return "Spy()"

    def __getitem__(self, key: object) -> int:
        self.calls.append("__getitem__")
        return 0

    def __float__(self) -> float:
        self.calls.append("__float__")
        return 0.0


class SpyDict(dict[str, int]):
    """A dict subclass whose lookups would run code."""

    calls: list[str] = []  # noqa: RUF012  (shared on purpose: the test reads it)

    def __getitem__(self, key: str) -> int:
        SpyDict.calls.append("__getitem__")
        return 0

    def __missing__(self, key: str) -> int:
        SpyDict.calls.append("__missing__")
        return 0


class Slotted:
    """Attributes in slots only."""

    __slots__ = ("unset", "x")

    def __init__(self) -> None:
        self.x = 7


class Color(enum.Enum):
    """An enum: its members compare with `is`."""

    RED = 1
    BLUE = 2


class Limits:
    """A class constant beside methods."""

    MAX = 3.5

    def method(self) -> int:
        return 1


def ev(text: str, local_ns: dict[str, Any] | None = None, global_ns: dict[str, Any] | None = None) -> object:
    return parse_expr(text).evaluate(local_ns or {}, global_ns or {})


def refused(text: str, local_ns: dict[str, Any]) -> str:
    with pytest.raises(EvalError) as info:
        ev(text, local_ns)
    return str(info.value)


def test_names_read_locals_before_globals() -> None:
    """A name is looked up in the frame's locals, then its globals; an unknown name says so."""
    assert ev("x", {"x": 1}, {"x": 2}) == 1
    assert ev("y", {"x": 1}, {"y": 3}) == 3
    with pytest.raises(EvalError, match="name 'z' is not defined"):
        ev("z", {"x": 1}, {"y": 3})


def test_arithmetic_comparisons_and_logic_on_numbers() -> None:
    """Numbers take + - * / // % **, comparisons (chained too), and/or/not, and a if c else b."""
    ns = {"a": 7, "b": 2.0, "flag": True}
    assert ev("a * b + 1", ns) == 15.0
    assert ev("a // 2", ns) == 3
    assert ev("a % 4 - -b ** 2", ns) == 7
    assert ev("1 < a <= 7 != b", ns) is True
    assert ev("a > 10 or b", ns) == 2.0
    assert ev("not flag and a", ns) is False
    assert ev("'big' if a > 5 else 'small'", ns) == "big"
    assert ev("a & 3 | 8 ^ 1", ns) == (7 & 3 | 8 ^ 1)


@given(
    st.one_of(st.integers(-(10**6), 10**6), st.floats(allow_nan=False, allow_infinity=False, width=32)),
    st.one_of(st.integers(-(10**6), 10**6), st.floats(allow_nan=False, allow_infinity=False, width=32)),
    st.sampled_from(["+", "-", "*", "/", "//", "%", "<", "==", ">="]),
)
def test_operators_equal_pythons(a: float, b: float, symbol: str) -> None:
    """A binary operator on two numbers gives what Python gives, or an error where Python raises."""
    fns: dict[str, Callable[[Any, Any], Any]] = {
        "+": operator.add,
        "-": operator.sub,
        "*": operator.mul,
        "/": operator.truediv,
        "//": operator.floordiv,
        "%": operator.mod,
        "<": operator.lt,
        "==": operator.eq,
        ">=": operator.ge,
    }
    try:
        expected: object = fns[symbol](a, b)
    except ZeroDivisionError:
        with pytest.raises(EvalError, match="ZeroDivisionError"):
            ev(f"a {symbol} b", {"a": a, "b": b})
        return
    got = ev(f"a {symbol} b", {"a": a, "b": b})
    assert got == expected or (isinstance(got, float) and math.isnan(got) and math.isnan(float(expected)))  # type: ignore[arg-type]


def test_attributes_read_instance_dicts_slots_and_class_constants() -> None:
    """Attributes come from the instance dict, slots and plain class attributes; modules read their dict."""
    ns: dict[str, Any] = {
        "pose": types.SimpleNamespace(x=1.0, inner=types.SimpleNamespace(y=2)),
        "s": Slotted(),
        "lim": Limits(),
        "math": math,
        "C": Limits,
    }
    assert ev("pose.inner.y + pose.x", ns) == 3.0
    assert ev("s.x", ns) == 7
    assert ev("lim.MAX", ns) == 3.5
    assert ev("C.MAX", ns) == 3.5
    assert ev("math.pi", ns) == math.pi
    assert "is not set" in refused("s.unset", ns)
    assert "is a method" in refused("lim.method", ns)


def test_properties_getattr_and_descriptors_never_run() -> None:
    """A property, __getattr__ and __getattribute__ are never invoked: the reader says it would run code."""
    spy = Spy()
    assert "property: reading it would run code" in refused("spy.costly", {"spy": spy})
    assert "__getattr__ would run code" in refused("spy.missing", {"spy": spy})
    assert ev("spy.value", {"spy": spy}) == 2.5
    assert spy.calls == []

    class Sneaky:
        def __getattribute__(self, name: str) -> object:
            raise AssertionError("__getattribute__ ran")

    sneaky = Sneaky()
    vars_ = object.__getattribute__(sneaky, "__dict__")
    vars_["v"] = 4
    assert ev("s.v", {"s": sneaky}) == 4


def test_module_getattr_is_not_called() -> None:
    """A module's __getattr__ (PEP 562) is never called for a name its dict lacks."""
    calls: list[str] = []
    module = types.ModuleType("lazy")
    module.__getattr__ = lambda name: calls.append(name)  # type: ignore[method-assign]
    module.present = 5  # type: ignore[attr-defined]
    assert ev("m.present", {"m": module}) == 5
    assert "__getattr__ would run code" in refused("m.absent", {"m": module})
    assert calls == []


def test_operators_on_user_objects_run_nothing() -> None:
    """==, <, +, truth tests, subscripts and dict keys of a user object are refused without calling it."""
    spy = Spy()
    ns: dict[str, Any] = {"spy": spy, "n": 1, "d": {"k": 1}, "sd": SpyDict(k=1)}
    for text in ("spy == 1", "n < spy", "1 + spy", "spy + 1", "spy and 1", "not spy", "spy[0]", "d[spy]"):
        assert "would run code" in refused(text, ns), text
    assert "would run code" in refused("sd['k']", ns)
    assert "would run code" in refused("'%s' % n", ns)
    assert spy.calls == []
    assert SpyDict.calls == []


def test_is_compares_anything() -> None:
    """`is` and `is not` compare identities, so enum members and None work without any hook."""
    ns: dict[str, Any] = {"state": Color.RED, "Color": Color, "spy": Spy()}
    assert ev("state is Color.RED", ns) is True
    assert ev("spy is not None", ns) is True


def test_subscripts_on_builtin_containers_and_numpy() -> None:
    """Lists, tuples, strings, dicts (builtin keys, constants or names) and numpy arrays are indexed."""
    arr = np.arange(6.0).reshape(2, 3)
    ns: dict[str, Any] = {"xs": [1, 2, 3], "t": (4, 5), "d": {"a": 1, 2: "two"}, "k": "a", "arr": arr, "i": 1}
    assert ev("xs[-1] + t[0]", ns) == 7
    assert ev("d[k]", ns) == 1
    assert ev("d[2]", ns) == "two"
    assert ev("arr[1, 2]", ns) == 5.0
    assert ev("arr[i][0] * 2", ns) == 6.0
    assert "out of range" in refused("xs[5]", ns)
    assert "not in the dict" in refused("d['zz']", ns)


def test_numpy_arithmetic_and_object_arrays() -> None:
    """Numeric numpy arrays compute (no warning escapes); object arrays are refused."""
    ns: dict[str, Any] = {"a": np.array([1.0, 0.0]), "o": np.array([Spy()], dtype=object)}
    result: Any = ev("a / 0", ns)
    assert result[0] == math.inf
    assert math.isnan(result[1])
    assert ev("a[0] + 1", ns) == 2.0
    assert "would run code" in refused("o + 1", ns)


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("len(x)", "calls are not allowed"),
        ("open('/etc/passwd')", "calls are not allowed"),
        ("__import__('os')", "calls are not allowed"),
        ("x.__class__", "dunder attributes"),
        ("__builtins__", "dunder names"),
        ("lambda: 1", "lambdas are not allowed"),
        ("[v for v in x]", "comprehensions are not allowed"),
        ("(v for v in x)", "generator expressions"),
        ("f'{x}'", "f-strings"),
        ("(y := 1)", "':=' is not allowed"),
        ("x[1:2]", "slices are not allowed"),
        ("x[y + 1]", "a subscript key must be"),
        ("[1, 2]", "list displays"),
        ("1 in x", "'in' is not allowed"),
        ("x = 1", "not a Python expression"),
        ("x" * (MAX_LENGTH + 1), "longer than"),
        (" < ".join(["x"] * 120), "more than"),
        ("-" * 40 + "x", "nests deeper"),
        ("10 ** 100000000000000000000000", "too large"),
    ],
)
def test_refused_expressions_say_why(text: str, reason: str) -> None:
    """Calls, dunders, lambdas, comprehensions and the rest are refused at parse time with a reason."""
    with pytest.raises(ExprError, match=reason):
        parse_expr(text)


def test_size_limits_at_run_time() -> None:
    """A power or a repetition that would build a huge value is refused, not computed."""
    assert "too large" in refused("n ** 100000", {"n": 12345})
    assert "more than" in refused("s * 1000000", {"s": "ab"})


def test_read_attribute_caches_per_type() -> None:
    """A plan is kept per type: a different type with the same attribute name is read by its own rules."""

    class P:
        @property
        def v(self) -> int:
            raise AssertionError("ran")

    cache: dict[type, Any] = {}
    assert read_attribute(types.SimpleNamespace(v=1), "v", cache) == 1
    with pytest.raises(EvalError, match="property"):
        read_attribute(P(), "v", cache)
    assert read_attribute(types.SimpleNamespace(v=2), "v", cache) == 2
    assert len(cache) == 2


def test_freeze_copies_containers() -> None:
    """A list, dict or array is copied at the hit: later changes by the program do not reach the copy."""
    xs = [1, 2.5]
    d = {"a": 1, "b": {"c": True}}
    arr = np.array([1, 2, 3], dtype=np.int32)
    kind, frozen_list = freeze(xs)
    assert kind == "array"
    xs[0] = 99
    assert list(frozen_list) == [1.0, 2.5]
    kind, frozen_dict = freeze(d)
    d["a"] = 5
    assert kind == "dict"
    assert frozen_dict == {"a": ("int", 1), "b": ("dict", {"c": ("bool", True)})}
    _, frozen_arr = freeze(arr)
    arr[0] = 7
    assert frozen_arr.tolist() == [1, 2, 3]
    assert frozen_arr.dtype == np.int32


def test_freeze_kinds_and_limits() -> None:
    """Ints stay ints, floats floats, numpy scalars their kind; text is cut and NUL replaced."""
    assert freeze(3) == ("int", 3)
    assert freeze(2**70) == ("float", float(2**70))
    assert freeze(np.float32(1.5)) == ("float", 1.5)
    assert freeze(np.int16(-4)) == ("int", -4)
    assert freeze(np.bool_(True)) == ("bool", True)
    kind, text = freeze("a\x00" + "b" * MAX_TEXT)
    assert kind == "text"
    assert len(text) == MAX_TEXT
    assert text.startswith("a\ufffd")


def test_freeze_refuses_what_would_run_code() -> None:
    """A user object, a list holding one, a dict with a non-text key, or None is not sent; nothing runs."""
    spy = Spy()
    for value in (spy, [1, spy], {"k": spy}, {1: 2}, None, {1.5}):
        with pytest.raises(EvalError):
            freeze(value)
    assert spy.calls == []
