"""Value transforms: known values, JSON loading and its errors, chain state, batch == incremental."""

from __future__ import annotations

import itertools
import json
import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog.viewer._values._transforms import (
    MAX_TRANSFORMS,
    MAX_WINDOW,
    Abs,
    Clamp,
    DegToRad,
    Derivative,
    FormulaTransform,
    MovingAverage,
    RadToDeg,
    Scale,
    Transform,
    TransformChain,
    TransformError,
    Unwrap,
    transforms_from_json,
    transforms_to_json,
)

NAN = math.nan


def _incremental(chain: TransformChain, times: list[float], values: list[float]) -> list[float]:
    return [chain.apply(t, v) for t, v in zip(times, values, strict=True)]


def _error(chain: TransformChain) -> str | None:
    """The chain's latest error, read through a call so the type checker does not narrow it."""
    return chain.last_error


def _same(actual: Any, expected: Any) -> None:
    np.testing.assert_allclose(np.asarray(actual, dtype=float), np.asarray(expected, dtype=float), rtol=1e-12)


# ---------------------------------------------------------------------------------------------------------
# Known values, one transform at a time (incremental and batch).


@pytest.mark.parametrize(
    ("transform", "values", "expected"),
    [
        (Scale(scale=2.0, offset=1.0), [0.0, 1.5, -3.0, NAN], [1.0, 4.0, -5.0, NAN]),
        (Scale(), [7.0], [7.0]),
        (DegToRad(), [180.0, -90.0, 0.0], [math.pi, -math.pi / 2, 0.0]),
        (RadToDeg(), [math.pi, math.pi / 4, 1.0], [180.0, 45.0, 57.29577951308232]),
        (Abs(), [-2.0, 0.0, 3.5, NAN], [2.0, 0.0, 3.5, NAN]),
        (Clamp(low=-1.0, high=1.0), [-5.0, -1.0, 0.5, 1.0, 9.0, NAN], [-1.0, -1.0, 0.5, 1.0, 1.0, NAN]),
        (Clamp(low=0.0), [-5.0, 5.0], [0.0, 5.0]),
        (Clamp(high=0.0), [-5.0, 5.0], [-5.0, 0.0]),
        (MovingAverage(window=3), [1.0, 2.0, 3.0, 4.0, 5.0], [1.0, 1.5, 2.0, 3.0, 4.0]),
        (MovingAverage(window=2), [1.0, NAN, 3.0, 5.0], [1.0, NAN, 2.0, 4.0]),
        (MovingAverage(window=1), [4.0, -1.0], [4.0, -1.0]),
        (Unwrap(), [3.0, -3.0, 3.0], [3.0, 2 * math.pi - 3.0, 3.0]),
        (Unwrap(), [0.1, 6.2, 0.1], [0.1, 6.2 - 2 * math.pi, 0.1]),
        (Unwrap(period=360.0), [170.0, -170.0, -10.0, NAN, 150.0], [170.0, 190.0, 350.0, NAN, 510.0]),
        (FormulaTransform("x * 57.2958"), [1.0, -2.0], [57.2958, -114.5916]),
        (FormulaTransform("1 / x"), [2.0, 0.0, 4.0], [0.5, NAN, 0.25]),
        (FormulaTransform("x if x > 0 else 0"), [-1.0, 2.0], [0.0, 2.0]),
    ],
)
def test_transform_known_values(transform: Transform, values: list[float], expected: list[float]) -> None:
    """Each transform gives the expected outputs sample by sample and as one batch."""
    times = [float(i) for i in range(len(values))]
    _same(_incremental(TransformChain([transform]), times, values), expected)
    _same(TransformChain([transform]).apply_array(times, values), expected)


def test_derivative_per_second() -> None:
    """The derivative divides by the source time step; the first sample, repeats and NaN give NaN."""
    times = [0.0, 0.5, 1.5, 1.5, 2.0, NAN, 3.0, 2.5, 4.0]
    values = [0.0, 1.0, 3.0, 9.0, NAN, 5.0, 7.0, 1.0, 5.0]
    # 0.5 s: +1 → 2/s; 1 s: +2 → 2/s; repeat time → NaN; NaN value → NaN; NaN time → NaN;
    # 3.0: (7 - 3) / (3.0 - 1.5); time going back → NaN; 4.0: (5 - 7) / 1.
    expected = [NAN, 2.0, 2.0, NAN, NAN, NAN, 4.0 / 1.5, NAN, -2.0]
    _same(_incremental(TransformChain([Derivative()]), times, values), expected)
    _same(TransformChain([Derivative()]).apply_array(times, values), expected)


def test_formula_over_several_fields() -> None:
    """A formula transform reads other fields of the message, which the chain reports it needs."""
    chain = TransformChain([FormulaTransform("sqrt(linear.x**2 + linear.y**2)"), Scale(scale=10.0)])
    assert chain.fields == {"linear.x", "linear.y"}
    assert chain.apply(0.0, 0.0, {"linear.x": 3.0, "linear.y": 4.0}) == 50.0
    assert _error(chain) is None
    assert math.isnan(chain.apply(1.0, 0.0, {"linear.x": 3.0}))
    assert "linear.y" in str(_error(chain))
    out = chain.fresh().apply_array([0.0, 1.0], [0.0, 0.0], {"linear.x": [3.0, 6.0], "linear.y": [4.0, 8.0]})
    _same(out, [50.0, 100.0])


def test_formula_error_reason_in_batch() -> None:
    """A batch with values a formula cannot compute reports how many failed."""
    chain = TransformChain([FormulaTransform("sqrt(x)")])
    out = chain.apply_array([0.0, 1.0, 2.0], [4.0, -1.0, 9.0])
    _same(out, [2.0, NAN, 3.0])
    assert _error(chain) == "1 of 3 values could not be computed"


def test_apply_never_raises() -> None:
    """A value that is not a number becomes NaN with a reason instead of an exception."""
    chain = TransformChain([Scale(scale=2.0)])
    assert math.isnan(chain.apply(0.0, "abc"))  # type: ignore[arg-type]
    assert _error(chain) is not None
    assert math.isnan(chain.apply(0.0, None))  # type: ignore[arg-type]
    assert chain.apply(0.0, True) == 2.0
    assert _error(chain) is None


def test_apply_array_rejects_misaligned_input() -> None:
    """Batch input must be two aligned 1-D arrays."""
    with pytest.raises(ValueError, match="aligned"):
        TransformChain([Abs()]).apply_array([0.0, 1.0], [1.0])


# ---------------------------------------------------------------------------------------------------------
# Chain state.


def test_reset_and_fresh() -> None:
    """reset() forgets the history; fresh() gives an independent chain with the same transforms."""
    chain = TransformChain([Derivative()])
    chain.apply(0.0, 0.0)
    assert chain.apply(1.0, 2.0) == 2.0
    other = chain.fresh()
    assert other.transforms == chain.transforms
    assert math.isnan(other.apply(2.0, 10.0))
    assert chain.apply(2.0, 5.0) == 3.0
    chain.reset()
    assert math.isnan(chain.apply(3.0, 6.0))
    assert chain.apply(4.0, 7.0) == 1.0


def test_chain_describe_and_bool() -> None:
    """A chain describes itself for the UI and is false when empty."""
    chain = TransformChain([RadToDeg(), MovingAverage(window=5), Clamp(low=0.0, high=360.0)])
    assert chain.describe() == "rad→deg → avg(5) → clamp [0, 360]"
    assert chain
    assert not TransformChain()
    assert TransformChain().apply(1.0, 4.5) == 4.5


SIGNAL = st.lists(
    st.tuples(
        st.floats(0.0, 2.0, allow_nan=False),  # time step (0 = repeated timestamp)
        st.floats(-1e3, 1e3, allow_nan=False) | st.just(NAN),
    ),
    min_size=1,
    max_size=60,
)
CHAINS = st.lists(
    st.sampled_from(
        [
            Scale(scale=-2.5, offset=3.0),
            DegToRad(),
            RadToDeg(),
            Abs(),
            Clamp(low=-100.0, high=250.0),
            Derivative(),
            MovingAverage(window=1),
            MovingAverage(window=4),
            MovingAverage(window=12),
            Unwrap(),
            Unwrap(period=360.0),
            FormulaTransform("x * 0.5 + 1"),
            FormulaTransform("x if x > 0 else -x / 2"),
        ]
    ),
    min_size=1,
    max_size=5,
)


@settings(max_examples=300, deadline=None)
@given(CHAINS, SIGNAL, st.lists(st.integers(0, 60), max_size=4), st.data())
def test_batch_equals_incremental(
    transforms: list[Transform], signal: list[tuple[float, float]], cuts: list[int], data: st.DataObject
) -> None:
    """Batches of any size, mixed with single samples, give what sample-by-sample application gives."""
    times = list(np.cumsum([step for step, _ in signal]))
    values = [v for _, v in signal]
    expected = _incremental(TransformChain(transforms), times, values)
    chain = TransformChain(transforms)
    out: list[float] = []
    bounds = sorted({0, len(values), *(c for c in cuts if c <= len(values))})
    for lo, hi in itertools.pairwise(bounds):
        if data.draw(st.booleans()):
            out.extend(chain.apply_array(times[lo:hi], values[lo:hi]).tolist())
        else:
            out.extend(_incremental(chain, times[lo:hi], values[lo:hi]))
    np.testing.assert_array_equal(np.isnan(out), np.isnan(expected))
    np.testing.assert_allclose(out, expected, rtol=1e-9, atol=1e-9)


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-1e6, 1e6, allow_nan=False),
    st.floats(0.0, 1e6, allow_nan=False),
    st.lists(st.floats(allow_nan=False), min_size=1, max_size=30),
)
def test_clamp_bounds(low: float, width: float, values: list[float]) -> None:
    """Clamped values always lie within the bounds, and values inside them pass unchanged."""
    high = low + width
    chain = TransformChain([Clamp(low=low, high=high)])
    for v, out in zip(values, chain.apply_array(np.zeros(len(values)), values), strict=True):
        assert low <= out <= high
        assert out == v or not low <= v <= high
        assert chain.apply(0.0, v) == out


@settings(max_examples=200, deadline=None)
@given(
    st.floats(-50.0, 50.0, allow_nan=False),
    st.lists(st.floats(-3.0, 3.0, allow_nan=False), min_size=1, max_size=80),
)
def test_unwrap_recovers_continuous_signal(start: float, steps: list[float]) -> None:
    """Unwrapping a wrapped angle whose steps stay below π recovers the original signal up to 2πk."""
    signal = start + np.cumsum(steps)
    wrapped = np.mod(signal + math.pi, 2 * math.pi) - math.pi
    chain = TransformChain([Unwrap()])
    batch = chain.apply_array(np.arange(len(wrapped), dtype=float), wrapped)
    shift = wrapped[0] - signal[0]
    assert abs(shift / (2 * math.pi) - round(shift / (2 * math.pi))) < 1e-9
    np.testing.assert_allclose(batch, signal + shift, atol=1e-9)
    incremental = _incremental(TransformChain([Unwrap()]), list(range(len(wrapped))), wrapped.tolist())
    np.testing.assert_allclose(incremental, signal + shift, atol=1e-9)


@settings(max_examples=100, deadline=None)
@given(
    st.floats(-100.0, 100.0, allow_nan=False),
    st.floats(-100.0, 100.0, allow_nan=False),
    st.lists(st.floats(0.01, 5.0), min_size=2, max_size=40),
)
def test_derivative_of_a_line_is_its_slope(slope: float, intercept: float, steps: list[float]) -> None:
    """The derivative of a straight line sampled at uneven times is its slope after the first sample."""
    times = np.cumsum(steps)
    out = TransformChain([Derivative()]).apply_array(times, slope * times + intercept)
    assert math.isnan(out[0])
    np.testing.assert_allclose(out[1:], slope, rtol=1e-6, atol=1e-6)


# ---------------------------------------------------------------------------------------------------------
# The dashboard-file form.

PARAMETERS = st.floats(-1e9, 1e9, allow_nan=False)
TRANSFORMS = st.one_of(
    st.builds(Scale, scale=PARAMETERS, offset=PARAMETERS),
    st.just(DegToRad()),
    st.just(RadToDeg()),
    st.just(Abs()),
    st.tuples(PARAMETERS, st.floats(0, 1e9)).map(lambda p: Clamp(low=p[0], high=p[0] + p[1])),
    st.builds(Clamp, low=PARAMETERS),
    st.builds(Clamp, high=PARAMETERS),
    st.just(Derivative()),
    st.builds(MovingAverage, window=st.integers(1, MAX_WINDOW)),
    st.builds(Unwrap, period=st.floats(1e-3, 1e6)),
    st.sampled_from(["x * 57.2958", "sqrt(linear.x**2 + linear.y**2)", "clamp(x, -1, 1)"]).map(
        FormulaTransform
    ),
)


@settings(max_examples=200, deadline=None)
@given(st.lists(TRANSFORMS, max_size=MAX_TRANSFORMS))
def test_json_round_trip(transforms: list[Transform]) -> None:
    """Transforms survive a trip through JSON text unchanged."""
    text = json.dumps(transforms_to_json(transforms))
    assert transforms_from_json(json.loads(text)) == tuple(transforms)
    assert TransformChain.from_json(json.loads(text)).to_json() == json.loads(text)


def test_json_examples() -> None:
    """Documented JSON forms load into the expected transforms."""
    loaded = transforms_from_json(
        [
            {"kind": "scale", "scale": 2, "offset": -1},
            {"kind": "deg2rad"},
            {"kind": "rad2deg"},
            {"kind": "abs"},
            {"kind": "clamp", "min": 0, "max": 1},
            {"kind": "derivative"},
            {"kind": "moving_average", "window": 5},
            {"kind": "unwrap", "period": 360},
            {"kind": "formula", "expr": "x * 57.2958"},
        ]
    )
    assert loaded == (
        Scale(scale=2.0, offset=-1.0),
        DegToRad(),
        RadToDeg(),
        Abs(),
        Clamp(low=0.0, high=1.0),
        Derivative(),
        MovingAverage(window=5),
        Unwrap(period=360.0),
        FormulaTransform("x * 57.2958"),
    )
    assert transforms_from_json(None) == ()
    assert transforms_from_json([]) == ()


@pytest.mark.parametrize(
    ("data", "message"),
    [
        ("scale", r"transforms must be a list of objects, got str"),
        ({"kind": "abs"}, r"transforms must be a list of objects, got dict"),
        ([3], r"transforms\[0\] must be an object, got int"),
        ([{"scale": 2}], r"transforms\[0\]: unknown kind None \(known: abs, clamp"),
        ([{"kind": "abs"}, {"kind": "sclae"}], r"transforms\[1\]: unknown kind 'sclae'"),
        (
            [{"kind": "scale", "gain": 2}],
            r"transforms\[0\] \(scale\): unknown key 'gain' \(allowed: kind, scale",
        ),
        ([{"kind": "abs", "x": 1}], r"transforms\[0\] \(abs\): unknown key 'x' \(allowed: kind\)"),
        ([{"kind": "scale", "scale": "2"}], r"transforms\[0\] \(scale\): 'scale' must be a number, got '2'"),
        (
            [{"kind": "scale", "offset": True}],
            r"transforms\[0\] \(scale\): 'offset' must be a number, got True",
        ),
        ([{"kind": "scale", "scale": float("inf")}], r"transforms\[0\] \(scale\): 'scale' must be a finite"),
        ([{"kind": "clamp"}], r"transforms\[0\] \(clamp\): needs 'min', 'max' or both"),
        (
            [{"kind": "clamp", "min": 2, "max": 1}],
            r"transforms\[0\] \(clamp\): 'min' \(2\) is above 'max' \(1\)",
        ),
        ([{"kind": "moving_average"}], r"transforms\[0\] \(moving_average\): needs 'window'"),
        (
            [{"kind": "moving_average", "window": 2.5}],
            r"transforms\[0\] \(moving_average\): 'window' must be an int",
        ),
        (
            [{"kind": "moving_average", "window": 0}],
            rf"transforms\[0\] \(moving_average\): 'window' must be between 1 and {MAX_WINDOW}",
        ),
        (
            [{"kind": "moving_average", "window": MAX_WINDOW + 1}],
            r"transforms\[0\] \(moving_average\): 'window' must",
        ),
        ([{"kind": "unwrap", "period": 0}], r"transforms\[0\] \(unwrap\): 'period' must be positive"),
        ([{"kind": "formula"}], r"transforms\[0\] \(formula\): needs 'expr'"),
        ([{"kind": "formula", "expr": 3}], r"transforms\[0\] \(formula\): 'expr' must be a string, got 3"),
        (
            [{"kind": "formula", "expr": "open(x)"}],
            r"transforms\[0\] \(formula\): 'expr' 'open\(x\)': column 1: unknown function 'open'",
        ),
        ([{"kind": "abs"}] * (MAX_TRANSFORMS + 1), rf"at most {MAX_TRANSFORMS} transforms"),
    ],
)
def test_json_errors_name_the_problem(data: object, message: str) -> None:
    """Bad dashboard data is rejected with a message naming item, kind and key after the caller's label."""
    with pytest.raises(TransformError, match=rf"^widget 'Heading': {message}"):
        transforms_from_json(data, where="widget 'Heading'")
    with pytest.raises(TransformError, match=rf"^{message}"):
        transforms_from_json(data)


def test_constructors_validate() -> None:
    """Building a transform directly checks its parameters the same way the loader does."""
    with pytest.raises(TransformError, match="above"):
        Clamp(low=2.0, high=1.0)
    with pytest.raises(TransformError, match="integer"):
        MovingAverage(window=True)
    with pytest.raises(TransformError, match="column"):
        FormulaTransform("x +")
    with pytest.raises(TransformError, match="not a transform"):
        TransformChain(["abs"])  # type: ignore[list-item]
    assert issubclass(TransformError, ValueError)
