"""Value transforms on any binding (scale, unit conversions, filters, formulas) and their dashboard JSON form.

A transform is a frozen dataclass holding its settings; a `TransformChain` applies several in order and
keeps the per-stream state of the stateful ones (derivative, moving average, angle unwrap). The chain has an
incremental `TransformChain.apply` for live samples and a vectorised `TransformChain.apply_array` for
history; both advance the same state and agree. Transforms are values: a `Binding` holds a tuple of them, and
only the dashboard file turns them into JSON (`transforms_from_json`, `written_transforms`). A list a file
gave that is rejected stays one `Invalid` value, kept as written with the reason.

Example:
    >>> chain = TransformChain.from_json([{"kind": "rad2deg"}, {"kind": "clamp", "min": -90, "max": 90}])
    >>> chain.apply(0.0, 1.0)
    57.29577951308232
"""

from __future__ import annotations

import abc
import json
import math
from collections import deque
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import ClassVar, Final

import numpy as np
import numpy.typing as npt

from dbglog.viewer._values._expr import VALUE_NAME, Formula, FormulaError, parse_formula

__all__ = [
    "MAX_TRANSFORMS",
    "MAX_WINDOW",
    "Abs",
    "Clamp",
    "DegToRad",
    "Derivative",
    "FormulaTransform",
    "Invalid",
    "MovingAverage",
    "RadToDeg",
    "Scale",
    "Transform",
    "TransformChain",
    "TransformError",
    "Unwrap",
    "transforms_from_json",
    "transforms_or_invalid",
    "transforms_to_json",
    "written_transforms",
]

MAX_TRANSFORMS: Final = 16
"""Most transforms on one binding."""
MAX_WINDOW: Final = 10_000
"""Largest moving-average window, in samples."""

F64 = npt.NDArray[np.float64]
_Json = dict[str, object]

_RAD_PER_DEG: Final = math.pi / 180.0
_DEG_PER_RAD: Final = 180.0 / math.pi


class TransformError(ValueError):
    """A transform with a bad kind, key or parameter; the message names it (prefix it with the widget)."""


# ---------------------------------------------------------------------------------------------------------
# Runtime stages: one per transform per stream.


class _Stage(abc.ABC):
    """The running form of one transform for one stream."""

    error: str | None = None
    """Why the latest output is NaN, when the stage can say (formulas)."""

    def reset(self) -> None:
        """Forget the stream's history."""
        self.error = None

    @abc.abstractmethod
    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        """Transform one sample."""

    @abc.abstractmethod
    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        """Transform many samples at once, advancing the state exactly as `step` would."""


class _Stateless(_Stage):
    def __init__(self, scalar: Callable[[float], float], vector: Callable[[F64], F64]) -> None:
        self._scalar = scalar
        self._vector = vector

    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        return self._scalar(v)

    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        return self._vector(values)


def _finite(v: float) -> bool:
    return v - v == 0.0


class _DerivativeStage(_Stage):
    """(v - v_prev) / (t - t_prev); NaN for the first sample, non-finite input and non-increasing time."""

    def __init__(self) -> None:
        self._t: float | None = None
        self._v = 0.0

    def reset(self) -> None:
        self._t = None

    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        if not (_finite(t) and _finite(v)):
            return math.nan
        if self._t is None:
            self._t, self._v = t, v
            return math.nan
        dt = t - self._t
        if not dt > 0.0:
            return math.nan
        out = (v - self._v) / dt
        self._t, self._v = t, v
        return out

    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        out = np.full(len(values), np.nan)
        ok = np.isfinite(times) & np.isfinite(values)
        before = -np.inf if self._t is None else self._t
        # Accepted times rise strictly, so the running maximum of usable times is the last accepted one.
        latest = np.maximum.accumulate(np.concatenate([[before], np.where(ok, times, -np.inf)]))[:-1]
        idx = np.flatnonzero(ok & (times > latest))
        if len(idx) == 0:
            return out
        t_acc, v_acc = times[idx], values[idx]
        if self._t is not None:
            out[idx] = (v_acc - np.concatenate([[self._v], v_acc[:-1]])) / (
                t_acc - np.concatenate([[self._t], t_acc[:-1]])
            )
        else:
            out[idx[1:]] = (v_acc[1:] - v_acc[:-1]) / (t_acc[1:] - t_acc[:-1])
        self._t, self._v = float(t_acc[-1]), float(v_acc[-1])
        return out


class _MovingAverageStage(_Stage):
    """Mean of the last `window` finite values (fewer at the start); NaN for a non-finite input."""

    def __init__(self, window: int) -> None:
        self._window = window
        self._recent: deque[float] = deque(maxlen=window)

    def reset(self) -> None:
        self._recent.clear()

    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        if not _finite(v):
            return math.nan
        self._recent.append(v)
        return sum(self._recent) / len(self._recent)

    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        out = np.full(len(values), np.nan)
        idx = np.flatnonzero(np.isfinite(values))
        if len(idx) == 0:
            return out
        n = self._window
        history = np.asarray(self._recent, dtype=np.float64)
        series = np.concatenate([history, values[idx]])
        padded = np.concatenate([np.zeros(n - 1), series])
        windows = np.lib.stride_tricks.sliding_window_view(padded, n)[len(history) :]
        positions = np.arange(len(history), len(series))
        out[idx] = windows.sum(axis=1) / np.minimum(positions + 1, n)
        self._recent.extend(values[idx][-n:].tolist())
        return out


class _UnwrapStage(_Stage):
    """Remove jumps of more than half a period (as numpy.unwrap does), sample by sample."""

    def __init__(self, period: float) -> None:
        self._period = period
        self._half = period / 2.0
        self._prev: float | None = None
        self._offset = 0.0

    def reset(self) -> None:
        self._prev = None
        self._offset = 0.0

    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        if not _finite(v):
            return math.nan
        if self._prev is not None:
            dd = v - self._prev
            if abs(dd) >= self._half:
                ddmod = (dd + self._half) % self._period - self._half
                if ddmod == -self._half and dd > 0.0:
                    ddmod = self._half
                self._offset += ddmod - dd
        self._prev = v
        return v + self._offset

    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        out = np.full(len(values), np.nan)
        idx = np.flatnonzero(np.isfinite(values))
        if len(idx) == 0:
            return out
        v_acc = values[idx]
        prev = np.concatenate([[v_acc[0] if self._prev is None else self._prev], v_acc[:-1]])
        dd = v_acc - prev
        ddmod = np.mod(dd + self._half, self._period) - self._half
        ddmod = np.where((ddmod == -self._half) & (dd > 0.0), self._half, ddmod)
        correction = np.where(np.abs(dd) >= self._half, ddmod - dd, 0.0)
        offsets = np.cumsum(np.concatenate([[self._offset], correction]))[1:]
        out[idx] = v_acc + offsets
        self._prev = float(v_acc[-1])
        self._offset = float(offsets[-1])
        return out


class _FormulaStage(_Stage):
    """A formula of ``x`` (the value so far) and of other fields of the same message.

    The formula is compiled once (`parse_formula`, cached by text); its compiled tree carries two entry
    points on purpose: `step` uses the float one (~1 us a sample, and a failure names its cause and column,
    which the engine shows as the widget's error), `run` the numpy one (a whole batch at once). A single
    numpy evaluator would cost tens of microseconds per live sample and lose the precise reason.
    """

    def __init__(self, formula: Formula) -> None:
        self._formula = formula

    def step(self, t: float, v: float, env: Mapping[str, float] | None) -> float:
        values: dict[str, float] = dict(env) if env and self._formula.fields else {}
        values[VALUE_NAME] = v
        result = self._formula.evaluate_result(values)
        self.error = result.error
        return result.value

    def run(self, times: F64, values: F64, cols: Mapping[str, npt.ArrayLike] | None) -> F64:
        columns: dict[str, npt.ArrayLike] = dict(cols) if cols and self._formula.fields else {}
        columns[VALUE_NAME] = values
        result = self._formula.evaluate_array_result(columns, len(values))
        self.error = result.error
        return result.values


# ---------------------------------------------------------------------------------------------------------
# Parameter checks shared by constructors and the JSON loader.


def _number(name: str, value: object) -> float:
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise TransformError(f"'{name}' must be a number, got {value!r}")
    try:
        number = float(value)
    except OverflowError:
        raise TransformError(f"'{name}' is out of float range") from None
    if not math.isfinite(number):
        raise TransformError(f"'{name}' must be a finite number, got {value!r}")
    return number


def _clip(scalar: float, low: float | None, high: float | None) -> float:
    if low is not None and scalar < low:
        return low
    if high is not None and scalar > high:
        return high
    return scalar


# ---------------------------------------------------------------------------------------------------------
# The transforms.


@dataclass(frozen=True, slots=True)
class Scale:
    """``v * scale + offset``."""

    kind: ClassVar[str] = "scale"
    keys: ClassVar[tuple[str, ...]] = ("scale", "offset")

    scale: float = 1.0
    offset: float = 0.0

    def __post_init__(self) -> None:
        object.__setattr__(self, "scale", _number("scale", self.scale))
        object.__setattr__(self, "offset", _number("offset", self.offset))

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind, "scale": self.scale, "offset": self.offset}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return f"×{self.scale:g} {'+' if self.offset >= 0 else '-'} {abs(self.offset):g}"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        scale, offset = self.scale, self.offset
        return _Stateless(lambda v: v * scale + offset, lambda a: a * scale + offset)


@dataclass(frozen=True, slots=True)
class DegToRad:
    """Degrees to radians."""

    kind: ClassVar[str] = "deg2rad"
    keys: ClassVar[tuple[str, ...]] = ()

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return "deg→rad"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _Stateless(lambda v: v * _RAD_PER_DEG, lambda a: a * _RAD_PER_DEG)


@dataclass(frozen=True, slots=True)
class RadToDeg:
    """Radians to degrees."""

    kind: ClassVar[str] = "rad2deg"
    keys: ClassVar[tuple[str, ...]] = ()

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return "rad→deg"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _Stateless(lambda v: v * _DEG_PER_RAD, lambda a: a * _DEG_PER_RAD)


@dataclass(frozen=True, slots=True)
class Abs:
    """Absolute value."""

    kind: ClassVar[str] = "abs"
    keys: ClassVar[tuple[str, ...]] = ()

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return "|v|"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _Stateless(abs, np.abs)


@dataclass(frozen=True, slots=True)
class Clamp:
    """Limit to ``[low, high]`` (either bound may be left open); NaN stays NaN."""

    kind: ClassVar[str] = "clamp"
    keys: ClassVar[tuple[str, ...]] = ("min", "max")

    low: float | None = None
    high: float | None = None

    def __post_init__(self) -> None:
        if self.low is None and self.high is None:
            raise TransformError("needs 'min', 'max' or both")
        if self.low is not None:
            object.__setattr__(self, "low", _number("min", self.low))
        if self.high is not None:
            object.__setattr__(self, "high", _number("max", self.high))
        if self.low is not None and self.high is not None and self.low > self.high:
            raise TransformError(f"'min' ({self.low:g}) is above 'max' ({self.high:g})")

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        out: _Json = {"kind": self.kind}
        if self.low is not None:
            out["min"] = self.low
        if self.high is not None:
            out["max"] = self.high
        return out

    def describe(self) -> str:
        """Return a short label for the UI."""
        low = "-∞" if self.low is None else f"{self.low:g}"
        high = "∞" if self.high is None else f"{self.high:g}"
        return f"clamp [{low}, {high}]"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        low, high = self.low, self.high

        def vector(a: F64) -> F64:
            out = a if low is None else np.where(a < low, low, a)
            return out if high is None else np.where(out > high, high, out)

        return _Stateless(lambda v: _clip(v, low, high), vector)


@dataclass(frozen=True, slots=True)
class Derivative:
    """Rate of change per second, from the source timestamps."""

    kind: ClassVar[str] = "derivative"
    keys: ClassVar[tuple[str, ...]] = ()

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return "d/dt"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _DerivativeStage()


@dataclass(frozen=True, slots=True)
class MovingAverage:
    """Mean of the last ``window`` samples."""

    kind: ClassVar[str] = "moving_average"
    keys: ClassVar[tuple[str, ...]] = ("window",)

    window: int = 5

    def __post_init__(self) -> None:
        w = self.window
        if isinstance(w, bool) or not isinstance(w, int):
            raise TransformError(f"'window' must be an integer, got {w!r}")
        if not 1 <= w <= MAX_WINDOW:
            raise TransformError(f"'window' must be between 1 and {MAX_WINDOW}, got {w}")

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind, "window": self.window}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return f"avg({self.window})"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _MovingAverageStage(self.window)


@dataclass(frozen=True, slots=True)
class Unwrap:
    """Make a wrapped angle continuous (period 2π for radians, 360 for degrees)."""

    kind: ClassVar[str] = "unwrap"
    keys: ClassVar[tuple[str, ...]] = ("period",)

    period: float = math.tau

    def __post_init__(self) -> None:
        period = _number("period", self.period)
        if period <= 0.0:
            raise TransformError(f"'period' must be positive, got {period:g}")
        object.__setattr__(self, "period", period)

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind, "period": self.period}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return "unwrap" if self.period == math.tau else f"unwrap({self.period:g})"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _UnwrapStage(self.period)


@dataclass(frozen=True, slots=True)
class FormulaTransform:
    """A formula of the value ``x`` and of other fields of the message, e.g. ``x * 57.2958``."""

    kind: ClassVar[str] = "formula"
    keys: ClassVar[tuple[str, ...]] = ("expr",)

    expr: str
    formula: Formula = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.expr, str):
            raise TransformError(f"'expr' must be a string, got {self.expr!r}")
        try:
            object.__setattr__(self, "formula", parse_formula(self.expr))
        except FormulaError as exc:
            raise TransformError(f"'expr' {self.expr!r}: {exc}") from None

    def to_json(self) -> _Json:
        """Return the dashboard-file form."""
        return {"kind": self.kind, "expr": self.expr}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return f"= {self.expr}"

    def stage(self) -> _Stage:
        """Return the running form for one stream."""
        return _FormulaStage(self.formula)


@dataclass(frozen=True, slots=True)
class Invalid:
    """A transform list that was rejected, kept as written: the binding shows `reason` as its error.

    A dashboard file may hold a list the viewer refuses (an unknown kind, a formula it rejects); the
    binding keeps it as this one value so the widget says why and saving writes the list back unchanged.
    """

    kind: ClassVar[str] = "invalid"
    keys: ClassVar[tuple[str, ...]] = ()

    written: str
    """The list as written, compact JSON text (any JSON value: it was rejected)."""
    reason: str
    """Why it was rejected (the `TransformError` message)."""

    def to_json(self) -> _Json:
        """Return a placeholder object (the file form is `written`; see `written_transforms`)."""
        return {"kind": self.kind, "written": self.written, "reason": self.reason}

    def describe(self) -> str:
        """Return a short label for the UI."""
        return f"invalid: {self.reason}"

    def stage(self) -> _Stage:
        """Refuse to run: the reason is the binding's error."""
        raise TransformError(self.reason)


Transform = (
    Scale
    | DegToRad
    | RadToDeg
    | Abs
    | Clamp
    | Derivative
    | MovingAverage
    | Unwrap
    | FormulaTransform
    | Invalid
)
"""Any one transform (`Invalid` stands for a rejected list and never runs)."""

_Loader = Callable[[Mapping[str, object]], Transform]


def _integer(name: str, value: object) -> int:
    if isinstance(value, bool) or not isinstance(value, int):
        raise TransformError(f"'{name}' must be an integer, got {value!r}")
    return value


def _optional(name: str, value: object) -> float | None:
    return None if value is None else _number(name, value)


def _required(params: Mapping[str, object], key: str, what: str) -> object:
    if key not in params:
        raise TransformError(f"needs '{key}' ({what})")
    return params[key]


def _text(name: str, value: object) -> str:
    if not isinstance(value, str):
        raise TransformError(f"'{name}' must be a string, got {value!r}")
    return value


_LOADERS: Final[Mapping[str, _Loader]] = {
    Scale.kind: lambda p: Scale(
        _number("scale", p.get("scale", 1.0)), _number("offset", p.get("offset", 0.0))
    ),
    DegToRad.kind: lambda p: DegToRad(),
    RadToDeg.kind: lambda p: RadToDeg(),
    Abs.kind: lambda p: Abs(),
    Clamp.kind: lambda p: Clamp(_optional("min", p.get("min")), _optional("max", p.get("max"))),
    Derivative.kind: lambda p: Derivative(),
    MovingAverage.kind: lambda p: MovingAverage(
        _integer("window", _required(p, "window", "number of samples"))
    ),
    Unwrap.kind: lambda p: Unwrap(_number("period", p.get("period", math.tau))),
    FormulaTransform.kind: lambda p: FormulaTransform(
        _text("expr", _required(p, "expr", "the formula text"))
    ),
}
"""Each kind's loader from its file object (parameters checked and typed here, ranges by the class)."""

_KINDS: Final[Mapping[str, type[Transform]]] = {
    cls.kind: cls
    for cls in (Scale, DegToRad, RadToDeg, Abs, Clamp, Derivative, MovingAverage, Unwrap, FormulaTransform)
}


def _prefix(where: str, text: str) -> str:
    return f"{where}: {text}" if where else text


def transforms_from_json(data: object, *, where: str = "") -> tuple[Transform, ...]:
    """Load transforms from their dashboard-file form (a list of objects with a ``kind``).

    Args:
        data: e.g. ``[{"kind": "scale", "scale": 2}, {"kind": "formula", "expr": "x * 57.2958"}]``;
            ``None`` means no transforms.
        where: prefix for error messages, e.g. ``"widget 'Heading'"``.

    Raises:
        TransformError: an item is not an object, has an unknown kind, an unknown key or a bad parameter;
            the message names the item's index, kind and key.
    """
    if data is None:
        return ()
    if isinstance(data, (str, bytes, Mapping)) or not isinstance(data, Sequence):
        raise TransformError(
            _prefix(where, f"transforms must be a list of objects, got {type(data).__name__}")
        )
    if len(data) > MAX_TRANSFORMS:
        raise TransformError(_prefix(where, f"at most {MAX_TRANSFORMS} transforms, got {len(data)}"))
    out: list[Transform] = []
    for i, item in enumerate(data):
        label = f"transforms[{i}]"
        if not isinstance(item, Mapping):
            raise TransformError(_prefix(where, f"{label} must be an object, got {type(item).__name__}"))
        kind = item.get("kind")
        if not isinstance(kind, str) or kind not in _KINDS:
            raise TransformError(
                _prefix(where, f"{label}: unknown kind {kind!r} (known: {', '.join(sorted(_KINDS))})")
            )
        cls = _KINDS[kind]
        label = f"{label} ({kind})"
        for key in item:
            if key != "kind" and key not in cls.keys:
                allowed = ", ".join(("kind", *cls.keys))
                raise TransformError(_prefix(where, f"{label}: unknown key {key!r} (allowed: {allowed})"))
        params = {k: v for k, v in item.items() if k != "kind"}
        try:
            out.append(_LOADERS[kind](params))
        except TransformError as exc:
            raise TransformError(_prefix(where, f"{label}: {exc}")) from None
    return tuple(out)


def transforms_to_json(transforms: Iterable[Transform]) -> list[_Json]:
    """Return the dashboard-file form of `transforms` (what `transforms_from_json` reads)."""
    return [t.to_json() for t in transforms]


def transforms_or_invalid(data: object) -> tuple[Transform, ...]:
    """Load transforms as `transforms_from_json` does; a rejected list becomes one `Invalid`, kept as written.

    Args:
        data: the file's ``transforms`` value (any JSON value).

    Raises:
        ValueError: `data` cannot be written back as JSON (e.g. NaN); the caller drops it.
    """
    try:
        return transforms_from_json(data)
    except (TransformError, OverflowError) as exc:
        written = json.dumps(data, ensure_ascii=False, separators=(",", ":"), allow_nan=False)
        return (Invalid(written, str(exc)),)


def written_transforms(transforms: Iterable[Transform]) -> object:
    """Return the file form of transforms: objects with sorted keys, or a rejected list as written."""
    out: list[_Json] = []
    for t in transforms:
        if isinstance(t, Invalid):
            written: object = json.loads(t.written)
            return written
        out.append(dict(sorted(t.to_json().items())))
    return out


# ---------------------------------------------------------------------------------------------------------
# The chain.


class TransformChain:
    """Several transforms applied in order to one stream, with that stream's state.

    Use one chain per stream (`fresh` makes another with the same transforms and a clean state).
    """

    def __init__(self, transforms: Iterable[Transform] = ()) -> None:
        self._transforms = tuple(transforms)
        for t in self._transforms:
            if isinstance(t, Invalid):
                raise TransformError(t.reason)
            if not isinstance(t, tuple(_KINDS.values())):
                raise TransformError(f"not a transform: {t!r}")
        if len(self._transforms) > MAX_TRANSFORMS:
            raise TransformError(f"at most {MAX_TRANSFORMS} transforms, got {len(self._transforms)}")
        self._stages = [t.stage() for t in self._transforms]
        self.last_error: str | None = None
        """Why the latest output (or some of the latest batch) is NaN, when a formula can say; else None."""

    @classmethod
    def from_json(cls, data: object, *, where: str = "") -> TransformChain:
        """Build a chain from the dashboard-file form (see `transforms_from_json`).

        Args:
            data: a list of transform objects, or None.
            where: prefix for error messages, e.g. ``"widget 'Heading'"``.
        """
        return cls(transforms_from_json(data, where=where))

    @property
    def transforms(self) -> tuple[Transform, ...]:
        """The transforms, in order."""
        return self._transforms

    @property
    def fields(self) -> frozenset[str]:
        """Message fields the formulas read besides the bound value (the caller must supply them)."""
        out: frozenset[str] = frozenset()
        for t in self._transforms:
            if isinstance(t, FormulaTransform):
                out |= t.formula.fields
        return out

    def __bool__(self) -> bool:
        return bool(self._transforms)

    def __repr__(self) -> str:
        return f"TransformChain({list(self._transforms)!r})"

    def to_json(self) -> list[_Json]:
        """Return the dashboard-file form."""
        return transforms_to_json(self._transforms)

    def describe(self) -> str:
        """Return a short label for the UI, e.g. ``rad→deg → avg(5)``."""
        return " → ".join(t.describe() for t in self._transforms)

    def fresh(self) -> TransformChain:
        """Return a chain with the same transforms and no history, for another stream."""
        return TransformChain(self._transforms)

    def reset(self) -> None:
        """Forget the stream's history (e.g. after a gap or when the binding changes)."""
        for stage in self._stages:
            stage.reset()
        self.last_error = None

    def apply(self, t: float, v: float, fields: Mapping[str, float] | None = None) -> float:
        """Transform one sample; never raises (NaN, with `last_error` when a formula says why).

        Args:
            t: the sample's source time in seconds.
            v: the bound value (bools and ints are taken as numbers).
            fields: other fields of the same message, for formulas (see `fields`).
        """
        self.last_error = None
        try:
            t, v = float(t), float(v)
            for stage in self._stages:
                v = stage.step(t, v, fields)
                if stage.error is not None:
                    self.last_error = stage.error
        except (ArithmeticError, ValueError, TypeError) as exc:
            self.last_error = f"cannot transform: {exc}"
            return math.nan
        return v

    def apply_array(
        self,
        times: npt.ArrayLike,
        values: npt.ArrayLike,
        fields: Mapping[str, npt.ArrayLike] | None = None,
    ) -> F64:
        """Transform many samples (oldest first), advancing the state as repeated `apply` calls would.

        Args:
            times: source times in seconds, 1-D.
            values: the bound values, 1-D, aligned with `times`.
            fields: other fields of the same messages, aligned arrays, for formulas.

        Raises:
            ValueError: `times` and `values` are not 1-D arrays of the same length.
        """
        t = np.asarray(times, dtype=np.float64)
        v = np.array(values, dtype=np.float64)
        if t.ndim != 1 or v.ndim != 1 or len(t) != len(v):
            raise ValueError(f"times and values must be 1-D and aligned, got {t.shape} and {v.shape}")
        self.last_error = None
        with np.errstate(all="ignore"):
            for stage in self._stages:
                v = np.asarray(stage.run(t, v, fields), dtype=np.float64)
                if stage.error is not None:
                    self.last_error = stage.error
        return v
