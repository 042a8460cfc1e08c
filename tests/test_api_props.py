"""Properties: whatever tag and value a caller passes, no exception escapes and every call is counted."""

from __future__ import annotations

import warnings
from collections.abc import Callable
from decimal import Decimal
from typing import Any

import numpy as np
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import dbglog
from dbglog import DbglogWarning
from dbglog._ros._tags import MAX_TOPIC_LENGTH, escape_tag, name_problem, topic_for_tag


class _BadFloat:
    """A number-like object whose conversions and repr raise."""

    def __float__(self) -> float:
        raise RuntimeError("no float for you")

    def __index__(self) -> int:
        raise RuntimeError("no int either")

    def __repr__(self) -> str:
        raise RuntimeError("no repr")

    def __str__(self) -> str:
        raise RuntimeError("no str")


class _Unhashable(list[int]):
    """A tag that cannot even be hashed."""


LISTED_TAGS: list[object] = [
    "",
    " ",
    "a-b",
    "1abc",
    "~",
    "{x}",
    "a//b",
    "x" * 300,
    "ünïcødé",
    "nul\x00byte",
    "/lead",
    "trail/",
    None,
    123,
    b"x",
    _Unhashable(),
]
LISTED_VALUES: list[object] = [
    float("nan"),
    float("inf"),
    -float("inf"),
    2**63,
    -(2**63) - 1,
    10**400,
    Decimal("1.5"),
    Decimal("NaN"),
    1 + 2j,
    "x" * 1_000_000,
    None,
    b"x",
    [1, "a"],
    [[1, 2], [3]],
    np.array(["a", "b"]),
    np.complex128(1j),
    object(),
    3,
    -1.5,
    True,
]

tags = st.one_of(
    st.sampled_from(LISTED_TAGS),
    st.text(max_size=40),
    st.integers(),
    st.binary(max_size=4),
    st.builds(_BadFloat),
)


def _bad_dict() -> dict[str, object]:
    return {"a": _BadFloat(), "b": {"c": 10**400}}


# Objects with a failing __repr__ come from builds(): hypothesis describes sampled_from() by repr.
values = st.one_of(
    st.sampled_from(LISTED_VALUES),
    st.builds(_BadFloat),
    st.builds(_bad_dict),
    st.floats(allow_nan=True, allow_infinity=True),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.text(max_size=30),
    st.booleans(),
    st.lists(st.floats(allow_nan=False, width=32), max_size=4),
)
options = st.fixed_dictionaries(
    {},
    optional={
        "once": st.booleans(),
        "skip_first": st.booleans(),
        "throttle": st.one_of(st.none(), st.floats(), st.text(max_size=3)),
    },
)
msg_types = st.one_of(
    st.none(),
    st.sampled_from(
        ["std_msgs/msg/Float32", "std_msgs/msg/Int8", "nope/msg/X", "bad", 42, str, "std_msgs/String"]
    ),
)

FUNCTIONS: list[tuple[str, Callable[..., None]]] = [
    ("logfloat", dbglog.logfloat),
    ("logint", dbglog.logint),
    ("logbool", dbglog.logbool),
    ("logstring", dbglog.logstring),
]


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    fn=st.sampled_from(FUNCTIONS),
    tag=tags,
    value=values,
    msg_type=msg_types,
    opts=options,
)
def test_scalar_functions_never_raise_and_count_every_call(
    fn: tuple[str, Callable[..., None]], tag: object, value: object, msg_type: object, opts: dict[str, Any]
) -> None:
    """logfloat/logint/logbool/logstring: no exception escapes; each call ends exactly once in stats()."""
    before = dbglog.stats()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DbglogWarning)
        fn[1](tag, value, msg_type=msg_type, **opts)
    after = dbglog.stats()
    assert after.calls == before.calls + 1
    outcomes = (after.published + after.rate_limited + after.dropped) - (
        before.published + before.rate_limited + before.dropped
    )
    assert outcomes == 1


@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(
    tag=tags, value=values, msg_type=st.sampled_from(["geometry_msgs/msg/Point", "std_msgs/msg/Float64", 7])
)
def test_log_and_logdata_never_raise_and_count_every_call(
    tag: object, value: object, msg_type: object
) -> None:
    """log() and logdata() with any tag, value and type: no exception escapes, each call is counted."""
    before = dbglog.stats().calls
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DbglogWarning)
        dbglog.log(tag, value)  # type: ignore[arg-type]
        dbglog.logdata(tag, value, msg_type)  # type: ignore[arg-type]
        dbglog.logdata(tag, {"x": value}, msg_type)  # type: ignore[arg-type]
    assert dbglog.stats().calls == before + 3


@settings(max_examples=60, deadline=None)
@given(tag=st.text(max_size=60) | st.text(alphabet="速度-", min_size=30, max_size=40))
def test_any_string_tag_publishes_on_a_valid_topic(tag: str) -> None:
    """Every string tag ends on a valid topic of its own: a float logged with it is published, dropped
    only when that topic would pass rmw's length limit."""
    before = dbglog.stats().dropped
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DbglogWarning)
        dbglog.logfloat(tag, 1.0)
    s = dbglog.stats()
    fits = len(topic_for_tag(escape_tag(tag))) <= MAX_TOPIC_LENGTH
    assert s.dropped - before == (0 if fits else 1)
    assert set(s.dropped_by_reason) <= {"bad_tag"}
    from dbglog.api._public import RUNTIME

    assert all(name_problem(t) is None for t in RUNTIME.channels)
    assert (escape_tag(tag) in RUNTIME.channels) == fits


def test_warning_is_given_once_per_problem_and_tag() -> None:
    """Repeating the same bad call warns once but counts every drop."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        for _ in range(50):
            dbglog.logint("w_once", 2**64)
            dbglog.logfloat(None, 1.0)  # type: ignore[arg-type]
    assert len(caught) == 2
    assert all(issubclass(w.category, DbglogWarning) for w in caught)
    assert dbglog.stats().dropped_by_reason == {"out_of_range": 50, "bad_tag": 50}


def test_recursive_logging_from_a_warning_handler_is_dropped_not_looped() -> None:
    """A showwarning hook that logs again is cut off by the recursion guard."""
    seen: list[str] = []

    def hook(message: Warning | str, *args: object, **kwargs: object) -> None:
        seen.append(str(message))
        dbglog.logint("w_rec2", 2**64)

    with warnings.catch_warnings():
        warnings.simplefilter("always")
        warnings.showwarning = hook
        dbglog.logint("w_rec", 2**64)
    assert len(seen) == 1
    assert dbglog.stats().dropped_by_reason == {"out_of_range": 1, "recursion": 1}
