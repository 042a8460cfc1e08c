"""A small, safe formula language for dashboard values: parsed with ``ast``, checked, never eval'd.

A formula is parsed into a Python AST (``mode="eval"``), every node is checked against an allow-list, and
the tree is compiled into nested plain closures over floats. Nothing is passed to ``eval``/``exec`` and
no code object is ever built from the text, so a dashboard file from a stranger cannot run code here.

Example:
    >>> f = parse_formula("sqrt(linear.x**2 + linear.y**2)")
    >>> sorted(f.fields)
    ['linear.x', 'linear.y']
    >>> f.evaluate({"linear.x": 3.0, "linear.y": 4.0})
    5.0
"""

from __future__ import annotations

import ast
import functools
import math
import operator
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Final

import numpy as np
import numpy.typing as npt

__all__ = [
    "CONSTANTS",
    "FUNCTIONS",
    "MAX_DEPTH",
    "MAX_EXPONENT",
    "MAX_INDEX",
    "MAX_INT_LITERAL",
    "MAX_LENGTH",
    "MAX_NODES",
    "VALUE_NAME",
    "ArrayEvaluation",
    "Evaluation",
    "Formula",
    "FormulaError",
    "parse_formula",
]

MAX_LENGTH: Final = 500
"""Longest formula text, in characters."""
MAX_NODES: Final = 200
"""Most expression nodes (numbers, names, operators, calls, ...) in one formula."""
MAX_DEPTH: Final = 50
"""Deepest nesting of expression nodes (and of brackets in the text)."""
MAX_EXPONENT: Final = 128
"""Largest magnitude of a constant exponent in ``a ** b``."""
MAX_INT_LITERAL: Final = 2**53
"""Largest magnitude of an integer literal (every such integer is exact as a float)."""
MAX_INDEX: Final = 1_000_000
"""Largest magnitude of a constant index in a field path such as ``ranges[3]``."""
VALUE_NAME: Final = "x"
"""The name under which a formula reads the bound value."""

CONSTANTS: Final[Mapping[str, float]] = {"pi": math.pi, "e": math.e, "tau": math.tau}
"""Named constants a formula may use."""

F64 = npt.NDArray[np.float64]
_Bools = npt.NDArray[np.bool_]
_Scalar = Callable[[Mapping[str, object]], float]
_Vector = Callable[[Mapping[str, F64], int], tuple[F64, _Bools]]

_DEG_PER_RAD: Final = 180.0 / math.pi
_RAD_PER_DEG: Final = math.pi / 180.0


class FormulaError(ValueError):
    """A formula that is not allowed or not valid; the message names the problem and its column."""

    def __init__(self, reason: str, column: int | None = None) -> None:
        self.reason = reason
        """What is wrong, without the column."""
        self.column = column
        """1-based column in the formula text where the problem starts (None when it is the whole text)."""
        super().__init__(f"column {column}: {reason}" if column is not None else reason)


class _EvalError(Exception):
    """A value that cannot be computed at run time; the evaluation yields NaN with this reason."""

    def __init__(self, reason: str, column: int | None = None) -> None:
        self.reason = reason
        super().__init__(f"column {column}: {reason}" if column is not None else reason)


@dataclass(frozen=True, slots=True)
class Evaluation:
    """The result of one evaluation: a finite value, or NaN with the reason."""

    value: float
    error: str | None = None

    @property
    def ok(self) -> bool:
        """True when the value was computed."""
        return self.error is None


@dataclass(frozen=True, slots=True)
class ArrayEvaluation:
    """The result of a vectorised evaluation: NaN where a value could not be computed."""

    values: F64
    failed: int = 0
    """How many values are NaN because they could not be computed."""
    error: str | None = None
    """Why values failed (the first reason, or a count), None when every value was computed."""


# ---------------------------------------------------------------------------------------------------------
# The function table.


def _s_floor(a: float) -> float:
    return float(math.floor(a)) if a - a == 0.0 else a


def _s_ceil(a: float) -> float:
    return float(math.ceil(a)) if a - a == 0.0 else a


def _s_trunc(a: float) -> float:
    return float(math.trunc(a)) if a - a == 0.0 else a


def _s_round(a: float, ndigits: float | None = None) -> float:
    if a - a != 0.0:
        return a
    if ndigits is None:
        return float(round(a))
    return round(a, int(ndigits))


def _v_round(a: F64, ndigits: F64 | None = None) -> F64:
    if ndigits is None:
        return np.rint(a)
    digits = int(ndigits[0]) if len(ndigits) else 0
    return np.fromiter((round(v, digits) for v in a.tolist()), dtype=np.float64, count=len(a))


def _s_sign(a: float) -> float:
    if a > 0.0:
        return 1.0
    if a < 0.0:
        return -1.0
    return a


def _s_min(*args: float) -> float:
    for a in args:
        if a != a:
            return a
    return min(args)


def _s_max(*args: float) -> float:
    for a in args:
        if a != a:
            return a
    return max(args)


def _v_min(*args: F64) -> F64:
    return functools.reduce(np.minimum, args)


def _v_max(*args: F64) -> F64:
    return functools.reduce(np.maximum, args)


def _s_clamp(a: float, lo: float, hi: float) -> float:
    return _s_min(_s_max(a, lo), hi)


def _v_clamp(a: F64, lo: F64, hi: F64) -> F64:
    return np.minimum(np.maximum(a, lo), hi)


def _s_log(a: float, base: float | None = None) -> float:
    return math.log(a) if base is None else math.log(a) / math.log(base)


def _v_log(a: F64, base: F64 | None = None) -> F64:
    return np.log(a) if base is None else np.log(a) / np.log(base)


def _s_hypot(*args: float) -> float:
    return math.hypot(*args)


def _v_hypot(*args: F64) -> F64:
    if len(args) == 1:
        return np.abs(args[0])
    return functools.reduce(np.hypot, args)


def _s_wrap(a: float) -> float:
    return (a + math.pi) % math.tau - math.pi


def _v_wrap(a: F64) -> F64:
    return np.mod(a + math.pi, math.tau) - math.pi


@dataclass(frozen=True, slots=True)
class _Function:
    """One callable of the language: arity and its scalar and array implementations."""

    min_args: int
    max_args: int
    scalar: Callable[..., float]
    vector: Callable[..., F64]
    doc: str


_MANY: Final = MAX_NODES

FUNCTIONS: Final[Mapping[str, _Function]] = {
    "abs": _Function(1, 1, abs, np.abs, "absolute value"),
    "sqrt": _Function(1, 1, math.sqrt, np.sqrt, "square root"),
    "exp": _Function(1, 1, math.exp, np.exp, "e to the power"),
    "log": _Function(1, 2, _s_log, _v_log, "natural log; log(x, base)"),
    "log10": _Function(1, 1, math.log10, np.log10, "base-10 log"),
    "log2": _Function(1, 1, math.log2, np.log2, "base-2 log"),
    "sin": _Function(1, 1, math.sin, np.sin, "sine (radians)"),
    "cos": _Function(1, 1, math.cos, np.cos, "cosine (radians)"),
    "tan": _Function(1, 1, math.tan, np.tan, "tangent (radians)"),
    "asin": _Function(1, 1, math.asin, np.arcsin, "arc sine"),
    "acos": _Function(1, 1, math.acos, np.arccos, "arc cosine"),
    "atan": _Function(1, 1, math.atan, np.arctan, "arc tangent"),
    "atan2": _Function(2, 2, math.atan2, np.arctan2, "atan2(y, x)"),
    "sinh": _Function(1, 1, math.sinh, np.sinh, "hyperbolic sine"),
    "cosh": _Function(1, 1, math.cosh, np.cosh, "hyperbolic cosine"),
    "tanh": _Function(1, 1, math.tanh, np.tanh, "hyperbolic tangent"),
    "hypot": _Function(1, _MANY, _s_hypot, _v_hypot, "Euclidean norm of the arguments"),
    "floor": _Function(1, 1, _s_floor, np.floor, "round down"),
    "ceil": _Function(1, 1, _s_ceil, np.ceil, "round up"),
    "trunc": _Function(1, 1, _s_trunc, np.trunc, "round toward zero"),
    "round": _Function(1, 2, _s_round, _v_round, "round half to even; round(x, digits)"),
    "min": _Function(1, _MANY, _s_min, _v_min, "smallest argument"),
    "max": _Function(1, _MANY, _s_max, _v_max, "largest argument"),
    "clamp": _Function(3, 3, _s_clamp, _v_clamp, "clamp(x, lo, hi)"),
    "sign": _Function(1, 1, _s_sign, np.sign, "-1, 0 or 1"),
    "degrees": _Function(1, 1, lambda a: a * _DEG_PER_RAD, lambda a: a * _DEG_PER_RAD, "radians to degrees"),
    "radians": _Function(1, 1, lambda a: a * _RAD_PER_DEG, lambda a: a * _RAD_PER_DEG, "degrees to radians"),
    "wrap_angle": _Function(1, 1, _s_wrap, _v_wrap, "wrap radians into [-pi, pi)"),
}
"""The only functions a formula may call, by name."""

_ROUND_DIGITS: Final = 15

# ---------------------------------------------------------------------------------------------------------
# Node kinds the checker explains by name when it rejects them.

_FORBIDDEN: Final[Mapping[type[ast.AST], str]] = {
    ast.Lambda: "lambdas are not allowed",
    ast.ListComp: "comprehensions are not allowed",
    ast.SetComp: "comprehensions are not allowed",
    ast.DictComp: "comprehensions are not allowed",
    ast.GeneratorExp: "generator expressions are not allowed",
    ast.JoinedStr: "f-strings are not allowed",
    ast.FormattedValue: "f-strings are not allowed",
    ast.NamedExpr: "':=' assignments are not allowed",
    ast.Starred: "'*' unpacking is not allowed",
    ast.List: "lists are not allowed",
    ast.Tuple: "tuples are not allowed",
    ast.Set: "sets are not allowed",
    ast.Dict: "dicts are not allowed",
    ast.Await: "'await' is not allowed",
    ast.Yield: "'yield' is not allowed",
    ast.YieldFrom: "'yield' is not allowed",
    ast.Slice: "slices are not allowed",
}

_BINOPS: Final[
    Mapping[type[ast.operator], tuple[str, Callable[[float, float], float], Callable[..., F64]]]
] = {
    ast.Add: ("+", operator.add, np.add),
    ast.Sub: ("-", operator.sub, np.subtract),
    ast.Mult: ("*", operator.mul, np.multiply),
    ast.Div: ("/", operator.truediv, np.true_divide),
    ast.FloorDiv: ("//", operator.floordiv, np.floor_divide),
    ast.Mod: ("%", operator.mod, np.mod),
    ast.Pow: ("**", math.pow, np.power),
}

_CMPOPS: Final[Mapping[type[ast.cmpop], tuple[Callable[[float, float], bool], Callable[..., _Bools]]]] = {
    ast.Eq: (operator.eq, np.equal),
    ast.NotEq: (operator.ne, np.not_equal),
    ast.Lt: (operator.lt, np.less),
    ast.LtE: (operator.le, np.less_equal),
    ast.Gt: (operator.gt, np.greater),
    ast.GtE: (operator.ge, np.greater_equal),
}

_BAD_CHARS: Final[Mapping[str, str]] = {
    "'": "string literals are not allowed",
    '"': "string literals are not allowed",
    "\\": "backslashes are not allowed",
    "{": "braces are not allowed (no sets, dicts or format strings)",
    "}": "braces are not allowed (no sets, dicts or format strings)",
    ":": "':' is not allowed (no slices, lambdas, dicts or ':=')",
    ";": "a formula is a single expression",
    "#": "comments are not allowed",
    "@": "'@' is not allowed",
    "&": "bitwise operators are not allowed",
    "|": "bitwise operators are not allowed",
    "^": "bitwise operators are not allowed (use '**' for powers)",
    "~": "bitwise operators are not allowed",
    "`": "'`' is not allowed",
    "$": "'$' is not allowed",
    "?": "'?' is not allowed",
}


# ---------------------------------------------------------------------------------------------------------
# The compiled form.


@dataclass(frozen=True, slots=True)
class _Node:
    """A compiled subtree: scalar and array closures, and its value when it reads no field."""

    scalar: _Scalar
    vector: _Vector
    const: float | None = None


def _const_node(value: float) -> _Node:
    def scalar(env: Mapping[str, object]) -> float:
        return value

    def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
        return np.full(n, value), np.zeros(n, dtype=np.bool_)

    return _Node(scalar, vector, value)


def _show(value: float) -> str:
    return str(int(value)) if value.is_integer() and abs(value) < 1e18 else f"{value:g}"


def _problem(result: float, zero_divisor: bool = False) -> str:
    if zero_divisor:
        return "division by zero"
    if result != result:
        return "undefined result (math domain error)"
    return "result out of float range"


def _as_float(key: str, raw: object) -> float:
    if type(raw) is float:
        return raw
    if isinstance(raw, (int, float, np.integer, np.floating)):  # bool is an int
        try:
            return float(raw)
        except OverflowError:
            raise _EvalError(f"field '{key}' is out of float range") from None
    raise _EvalError(f"field '{key}' is not a number ({type(raw).__name__})")


def _column(cols: Mapping[str, F64], key: str, n: int) -> F64:
    try:
        raw = cols[key]
    except KeyError:
        raise _EvalError(f"field '{key}' is missing") from None
    try:
        arr = np.asarray(raw, dtype=np.float64)
    except (TypeError, ValueError, OverflowError):
        raise _EvalError(f"field '{key}' is not numeric") from None
    if arr.shape != (n,):
        raise _EvalError(f"field '{key}' has shape {arr.shape}, expected ({n},)")
    return arr


class _Compiler:
    """Checks an AST against the allow-list and compiles it into closures."""

    def __init__(self, shift: int = 0) -> None:
        self.shift = shift
        """Characters stripped from the start of the text before parsing (added back to columns)."""
        self.fields: set[str] = set()
        self.uses_value = False

    def fail(self, node: ast.AST, reason: str) -> FormulaError:
        return FormulaError(reason, self.column(node))

    def column(self, node: ast.AST) -> int:
        """Return the 1-based column of `node` in the original text."""
        return int(getattr(node, "col_offset", 0)) + 1 + self.shift

    def build(self, node: ast.AST) -> _Node:
        """Compile one node (recursively), folding subtrees that read no field into constants."""
        return self._compile(node)

    def _fold(self, node: ast.AST, compiled: _Node, parts: list[_Node]) -> _Node:
        """Replace `compiled` by its value when every part is a constant; a failing constant is an error."""
        if not all(p.const is not None for p in parts):
            return compiled
        try:
            value = compiled.scalar({})
        except _EvalError as exc:
            raise self.fail(node, f"constant part cannot be computed: {exc.reason}") from None
        return _const_node(value)

    def _compile(self, node: ast.AST) -> _Node:
        forbidden = _FORBIDDEN.get(type(node))
        if forbidden is not None:
            raise self.fail(node, forbidden)
        if isinstance(node, ast.Expression):
            return self._compile(node.body)
        if isinstance(node, ast.Constant):
            return self._constant(node)
        if isinstance(node, ast.Name):
            return self._name(node)
        if isinstance(node, (ast.Attribute, ast.Subscript)):
            return self._field(node, self._field_path(node))
        if isinstance(node, ast.BinOp):
            return self._binop(node)
        if isinstance(node, ast.UnaryOp):
            return self._unary(node)
        if isinstance(node, ast.BoolOp):
            return self._boolop(node)
        if isinstance(node, ast.Compare):
            return self._compare(node)
        if isinstance(node, ast.IfExp):
            return self._ifexp(node)
        if isinstance(node, ast.Call):
            return self._call(node)
        raise self.fail(node, f"{type(node).__name__} expressions are not allowed")

    # -- leaves ---------------------------------------------------------------------------------------

    def _constant(self, node: ast.Constant) -> _Node:
        value = node.value
        if isinstance(value, bool):
            return _const_node(1.0 if value else 0.0)
        if isinstance(value, int):
            if abs(value) > MAX_INT_LITERAL:
                raise self.fail(node, f"integer literal is too large (the limit is {MAX_INT_LITERAL})")
            return _const_node(float(value))
        if isinstance(value, float):
            if not math.isfinite(value):
                raise self.fail(node, "number literal is out of float range")
            return _const_node(value)
        if isinstance(value, (str, bytes)):
            raise self.fail(node, "string literals are not allowed")
        if isinstance(value, complex):
            raise self.fail(node, "complex numbers are not allowed")
        if value is None:
            raise self.fail(node, "None is not allowed")
        raise self.fail(node, f"literal {type(value).__name__} is not allowed")

    def _check_name(self, node: ast.AST, name: str) -> None:
        if name.startswith("_") or "__" in name:
            raise self.fail(node, f"name '{name}' is not allowed (names may not start with '_' or hold '__')")
        if not name.isascii() or not name.isidentifier():
            raise self.fail(node, f"name {name!r} is not allowed")

    def _name(self, node: ast.Name) -> _Node:
        name = node.id
        self._check_name(node, name)
        if name in CONSTANTS:
            return _const_node(CONSTANTS[name])
        if name in FUNCTIONS:
            raise self.fail(node, f"'{name}' is a function: call it, e.g. {name}(x)")
        if name == VALUE_NAME:
            self.uses_value = True
        else:
            self.fields.add(name)
        return self._field(node, name)

    def _field_path(self, node: ast.AST) -> str:
        """Return the dotted/indexed path of an attribute or subscript chain rooted at a field name."""
        if isinstance(node, ast.Name):
            self._check_name(node, node.id)
            if node.id == VALUE_NAME:
                raise self.fail(
                    node,
                    f"'{VALUE_NAME}' is the bound value and has no fields or items; "
                    "write the field path from the message root, e.g. linear.y",
                )
            if node.id in CONSTANTS or node.id in FUNCTIONS:
                raise self.fail(node, f"'{node.id}' has no attributes or items")
            return node.id
        if isinstance(node, ast.Attribute):
            base = self._field_path(node.value)
            self._check_name(node, node.attr)
            return f"{base}.{node.attr}"
        if isinstance(node, ast.Subscript):
            base = self._field_path(node.value)
            return f"{base}[{self._index(node.slice)}]"
        if isinstance(node, ast.Call):
            raise self.fail(node, "attributes and items of call results are not allowed")
        raise self.fail(node, "attributes and items are only allowed on message field paths")

    def _index(self, node: ast.AST) -> int:
        sign = 1
        inner = node
        if isinstance(node, ast.UnaryOp) and isinstance(node.op, ast.USub):
            sign, inner = -1, node.operand
        if not (
            isinstance(inner, ast.Constant)
            and isinstance(inner.value, int)
            and not isinstance(inner.value, bool)
        ):
            if isinstance(inner, ast.Slice):
                raise self.fail(node, "slices are not allowed")
            raise self.fail(node, "an index must be a constant integer, e.g. ranges[3]")
        if abs(inner.value) > MAX_INDEX:
            raise self.fail(node, f"index is too large (the limit is {MAX_INDEX})")
        return sign * inner.value

    def _field(self, node: ast.AST, key: str) -> _Node:
        if key != VALUE_NAME:
            self.fields.add(key)

        def scalar(env: Mapping[str, object]) -> float:
            try:
                raw = env[key]
            except KeyError:
                raise _EvalError(f"field '{key}' is missing") from None
            if type(raw) is float:
                return raw
            return _as_float(key, raw)

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            return _column(cols, key, n), np.zeros(n, dtype=np.bool_)

        return _Node(scalar, vector)

    # -- operators ------------------------------------------------------------------------------------

    def _binop(self, node: ast.BinOp) -> _Node:
        entry = _BINOPS.get(type(node.op))
        if entry is None:
            if isinstance(node.op, ast.MatMult):
                raise self.fail(node, "'@' is not allowed")
            raise self.fail(node, "bitwise operators are not allowed")
        symbol, s_op, v_op = entry
        left = self._compile(node.left)
        right = self._compile(node.right)
        if symbol == "**" and right.const is not None and abs(right.const) > MAX_EXPONENT:
            raise self.fail(
                node.right, f"exponent {_show(right.const)} is too large (the limit is {MAX_EXPONENT})"
            )
        col = self.column(node)
        divides = symbol in ("/", "//", "%")
        fa, fb = left.scalar, right.scalar

        def scalar(env: Mapping[str, object]) -> float:
            a = fa(env)
            b = fb(env)
            try:
                r = s_op(a, b)
            except OverflowError:
                r = math.inf
            except (ArithmeticError, ValueError):
                r = math.nan
            if r - r != 0.0 and a - a == 0.0 and b - b == 0.0:
                raise _EvalError(f"'{symbol}': {_problem(r, divides and b == 0.0)}", col)
            return r

        va, vb = left.vector, right.vector
        exponent = right.const if symbol == "**" else None

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            a, ba = va(cols, n)
            if exponent is not None:
                # ndarray ** scalar takes numpy's fast paths (square, sqrt, reciprocal).
                r = np.asarray(a**exponent, dtype=np.float64)
                return r, ba | (~np.isfinite(r) & np.isfinite(a))
            b, bb = vb(cols, n)
            r = np.asarray(v_op(a, b), dtype=np.float64)
            bad = ba | bb | (~np.isfinite(r) & np.isfinite(a) & np.isfinite(b))
            return r, bad

        return self._fold(node, _Node(scalar, vector), [left, right])

    def _unary(self, node: ast.UnaryOp) -> _Node:
        operand = self._compile(node.operand)
        f, v = operand.scalar, operand.vector
        if isinstance(node.op, ast.UAdd):
            return operand
        if isinstance(node.op, ast.USub):

            def scalar(env: Mapping[str, object]) -> float:
                return -f(env)

            def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
                a, bad = v(cols, n)
                return -a, bad

        elif isinstance(node.op, ast.Not):

            def scalar(env: Mapping[str, object]) -> float:
                return 0.0 if f(env) else 1.0

            def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
                a, bad = v(cols, n)
                return (a == 0.0).astype(np.float64), bad

        else:
            raise self.fail(node, "bitwise operators are not allowed")
        return self._fold(node, _Node(scalar, vector), [operand])

    def _boolop(self, node: ast.BoolOp) -> _Node:
        parts = [self._compile(value) for value in node.values]
        is_and = isinstance(node.op, ast.And)
        result = parts[0]
        for part in parts[1:]:
            result = self._fold(node, _pair_bool(result, part, is_and=is_and), [result, part])
        return result

    def _compare(self, node: ast.Compare) -> _Node:
        ops = []
        for op in node.ops:
            entry = _CMPOPS.get(type(op))
            if entry is None:
                raise self.fail(node, "only ==, !=, <, <=, >, >= comparisons are allowed (no 'is' or 'in')")
            ops.append(entry)
        operands = [self._compile(node.left), *(self._compile(c) for c in node.comparators)]
        s_funcs = [o.scalar for o in operands]
        v_funcs = [o.vector for o in operands]
        s_ops = [o[0] for o in ops]
        v_ops = [o[1] for o in ops]

        def scalar(env: Mapping[str, object]) -> float:
            a = s_funcs[0](env)
            for s_op, f in zip(s_ops, s_funcs[1:], strict=True):
                b = f(env)
                if not s_op(a, b):
                    return 0.0
                a = b
            return 1.0

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            a, bad = v_funcs[0](cols, n)
            alive = np.ones(n, dtype=np.bool_)
            for v_op, f in zip(v_ops, v_funcs[1:], strict=True):
                b, bb = f(cols, n)
                bad = bad | (alive & bb)
                alive = alive & v_op(a, b)
                a = b
            return alive.astype(np.float64), bad

        return self._fold(node, _Node(scalar, vector), operands)

    def _ifexp(self, node: ast.IfExp) -> _Node:
        test = self._compile(node.test)
        body = self._compile(node.body)
        orelse = self._compile(node.orelse)
        ft, fb, fo = test.scalar, body.scalar, orelse.scalar
        vt, vb, vo = test.vector, body.vector, orelse.vector

        def scalar(env: Mapping[str, object]) -> float:
            return fb(env) if ft(env) else fo(env)

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            c, bc = vt(cols, n)
            a, ba = vb(cols, n)
            b, bb = vo(cols, n)
            pick = c != 0.0
            return np.where(pick, a, b), bc | np.where(pick, ba, bb)

        return self._fold(node, _Node(scalar, vector), [test, body, orelse])

    def _call(self, node: ast.Call) -> _Node:
        if not isinstance(node.func, ast.Name):
            raise self.fail(node, "only the listed functions can be called, by name (e.g. sqrt(x))")
        name = node.func.id
        self._check_name(node.func, name)
        spec = FUNCTIONS.get(name)
        if spec is None:
            raise self.fail(node, f"unknown function '{name}' (allowed: {', '.join(sorted(FUNCTIONS))})")
        if node.keywords:
            raise self.fail(node, f"{name}() takes no keyword arguments")
        for arg in node.args:
            if isinstance(arg, ast.Starred):
                raise self.fail(arg, "'*' unpacking is not allowed")
        count = len(node.args)
        if not spec.min_args <= count <= spec.max_args:
            wanted = (
                str(spec.min_args)
                if spec.min_args == spec.max_args
                else f"{spec.min_args} or {spec.max_args}"
                if spec.max_args == spec.min_args + 1
                else f"at least {spec.min_args}"
            )
            raise self.fail(
                node, f"{name}() takes {wanted} argument{'s' if wanted != '1' else ''}, got {count}"
            )
        args = [self._compile(a) for a in node.args]
        if name == "round" and count == 2:
            digits = args[1].const
            if digits is None or digits != int(digits) or abs(digits) > _ROUND_DIGITS:
                raise self.fail(
                    node.args[1], f"round() digits must be a constant integer within ±{_ROUND_DIGITS}"
                )
        return self._fold(node, _call_node(name, spec, args, self.column(node)), args)


def _pair_bool(left: _Node, right: _Node, *, is_and: bool) -> _Node:
    fa, fb, va, vb = left.scalar, right.scalar, left.vector, right.vector
    if is_and:

        def scalar(env: Mapping[str, object]) -> float:
            a = fa(env)
            return fb(env) if a else a

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            a, ba = va(cols, n)
            b, bb = vb(cols, n)
            truthy = a != 0.0
            return np.where(truthy, b, a), ba | (truthy & bb)

    else:

        def scalar(env: Mapping[str, object]) -> float:
            a = fa(env)
            return a if a else fb(env)

        def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
            a, ba = va(cols, n)
            b, bb = vb(cols, n)
            truthy = a != 0.0
            return np.where(truthy, a, b), ba | (~truthy & bb)

    return _Node(scalar, vector)


def _call_node(name: str, spec: _Function, args: list[_Node], col: int) -> _Node:
    s_fn, v_fn = spec.scalar, spec.vector
    s_args = [a.scalar for a in args]
    v_args = [a.vector for a in args]

    def fault(r: float) -> _EvalError:
        return _EvalError(f"{name}(): {_problem(r)}", col)

    if len(args) == 1:
        f0 = s_args[0]

        def scalar(env: Mapping[str, object]) -> float:
            a = f0(env)
            try:
                r = s_fn(a)
            except OverflowError:
                r = math.inf
            except (ArithmeticError, ValueError):
                r = math.nan
            if r - r != 0.0 and a - a == 0.0:
                raise fault(r)
            return r

    else:

        def scalar(env: Mapping[str, object]) -> float:
            vals = [f(env) for f in s_args]
            try:
                r = s_fn(*vals)
            except OverflowError:
                r = math.inf
            except (ArithmeticError, ValueError):
                r = math.nan
            if r - r != 0.0 and all(v - v == 0.0 for v in vals):
                raise fault(r)
            return r

    def vector(cols: Mapping[str, F64], n: int) -> tuple[F64, _Bools]:
        pairs = [f(cols, n) for f in v_args]
        vals = [p[0] for p in pairs]
        bad = np.zeros(n, dtype=np.bool_)
        inputs_finite = np.ones(n, dtype=np.bool_)
        for value, value_bad in pairs:
            bad |= value_bad
            inputs_finite &= np.isfinite(value)
        r = np.asarray(v_fn(*vals), dtype=np.float64)
        if r.shape != (n,):
            r = np.broadcast_to(r, (n,)).copy()
        return r, bad | (~np.isfinite(r) & inputs_finite)

    return _Node(scalar, vector)


# ---------------------------------------------------------------------------------------------------------
# Text checks and the public entry point.


def _check_text(text: str) -> None:
    """Check length, characters and bracket depth before the text reaches the Python parser."""
    if len(text) > MAX_LENGTH:
        raise FormulaError(
            f"formula is {len(text)} characters long; the limit is {MAX_LENGTH}", MAX_LENGTH + 1
        )
    if not text.strip():
        raise FormulaError("formula is empty")
    depth = 0
    for i, ch in enumerate(text):
        code = ord(ch)
        if code < 0x20 or code > 0x7E:
            raise FormulaError(
                f"character {ch!r} (U+{code:04X}) is not allowed: formulas are printable ASCII", i + 1
            )
        reason = _BAD_CHARS.get(ch)
        if reason is not None:
            raise FormulaError(reason, i + 1)
        if ch == "_" and text.startswith("__", i):
            raise FormulaError("'__' is not allowed (no dunder names)", i + 1)
        if ch in "([":
            depth += 1
            if depth > MAX_DEPTH:
                raise FormulaError(f"brackets nested deeper than {MAX_DEPTH}", i + 1)
        elif ch in ")]":
            depth -= 1


def _check_tree(tree: ast.AST, shift: int) -> None:
    """Check the node count and nesting depth without recursion."""
    nodes = 0
    stack: list[tuple[ast.AST, int]] = [(tree, 0)]
    while stack:
        node, depth = stack.pop()
        if isinstance(node, ast.expr):
            nodes += 1
            depth += 1
            if nodes > MAX_NODES:
                raise FormulaError(f"formula has more than {MAX_NODES} parts", node.col_offset + 1 + shift)
            if depth > MAX_DEPTH:
                raise FormulaError(f"formula is nested deeper than {MAX_DEPTH}", node.col_offset + 1 + shift)
        stack.extend((child, depth) for child in ast.iter_child_nodes(node))


def _compile_tree(tree: ast.AST, shift: int = 0) -> tuple[_Node, frozenset[str], bool]:
    """Check a parsed tree against the caps and the allow-list and compile it (no text checks)."""
    _check_tree(tree, shift)
    compiler = _Compiler(shift)
    root = compiler.build(tree)
    return root, frozenset(compiler.fields), compiler.uses_value


@dataclass(frozen=True, slots=True, eq=False)
class Formula:
    """A checked, compiled formula; evaluating it never raises and never runs foreign code."""

    text: str
    fields: frozenset[str]
    """Field paths of the message the formula reads (``linear.x``, ``ranges[3]``), without ``x``."""
    uses_value: bool
    """True when the formula reads the bound value ``x``."""
    _root: _Node = field(repr=False)

    @property
    def keys(self) -> frozenset[str]:
        """Every key `evaluate` looks up: the fields, plus ``x`` when the bound value is used."""
        return (self.fields | {VALUE_NAME}) if self.uses_value else self.fields

    @property
    def constant(self) -> float | None:
        """The formula's value when it reads nothing (e.g. ``2 * pi``), else None."""
        return self._root.const

    def evaluate_result(self, values: Mapping[str, float]) -> Evaluation:
        """Evaluate with ``values`` (field path or ``x`` → number); NaN plus a reason on error.

        Args:
            values: the numbers to read; ints and bools are taken as floats.
        """
        try:
            result = self._root.scalar(values)
        except _EvalError as exc:
            return Evaluation(math.nan, str(exc))
        except (
            ArithmeticError,
            ValueError,
            TypeError,
        ) as exc:  # defensive: the closures should not raise these
            return Evaluation(math.nan, f"cannot compute: {exc}")
        if result - result != 0.0:
            return Evaluation(math.nan, "result is not a finite number (an input is inf or NaN)")
        return Evaluation(result)

    def evaluate(self, values: Mapping[str, float]) -> float:
        """Evaluate with ``values``; NaN when the value cannot be computed (see `evaluate_result`).

        Args:
            values: field path → number, and ``x`` → the bound value.
        """
        return self.evaluate_result(values).value

    def evaluate_array_result(
        self, columns: Mapping[str, npt.ArrayLike], length: int | None = None
    ) -> ArrayEvaluation:
        """Evaluate over aligned 1-D arrays at once; NaN where a value cannot be computed.

        Agrees with `evaluate` row by row (up to rounding of the math library) for finite inputs.

        Args:
            columns: field path (and ``x``) → 1-D array, all of the same length.
            length: the number of rows; needed only when the formula reads nothing.
        """
        cols: dict[str, F64] = {}
        for key in sorted(self.keys):
            if key in columns:
                try:
                    cols[key] = np.asarray(columns[key], dtype=np.float64)
                except (TypeError, ValueError, OverflowError):
                    cols[key] = np.empty(0)
        n = length
        if n is None:
            first = next((c for c in cols.values() if c.ndim == 1), None)
            if first is None:
                raise ValueError("pass length=: no column of this formula to take the length from")
            n = len(first)
        try:
            with np.errstate(all="ignore"):
                values, bad = self._root.vector(cols, n)
                out = np.where(bad | ~np.isfinite(values), np.nan, values).astype(np.float64)
        except _EvalError as exc:
            return ArrayEvaluation(np.full(n, np.nan), n, str(exc))
        failed = int(np.count_nonzero(np.isnan(out)))
        error = None if failed == 0 else f"{failed} of {n} values could not be computed"
        return ArrayEvaluation(out, failed, error)

    def evaluate_array(self, columns: Mapping[str, npt.ArrayLike], length: int | None = None) -> F64:
        """Evaluate over aligned 1-D arrays at once (see `evaluate_array_result`).

        Args:
            columns: field path (and ``x``) → 1-D array, all of the same length.
            length: the number of rows; needed only when the formula reads nothing.
        """
        return self.evaluate_array_result(columns, length).values

    def __eq__(self, other: object) -> bool:
        return isinstance(other, Formula) and other.text == self.text

    def __hash__(self) -> int:
        return hash(self.text)


def _syntax_error(text: str, exc: SyntaxError, shift: int) -> FormulaError:
    msg = exc.msg or "invalid syntax"
    reason = msg if msg.startswith("invalid syntax") else f"invalid syntax: {msg}"
    if not exc.offset or exc.offset + shift > len(text):
        return FormulaError(f"{reason} (the formula ends too early)", len(text) + 1)
    return FormulaError(reason, exc.offset + shift)


@functools.lru_cache(maxsize=256)
def _parse_cached(text: str) -> Formula:
    _check_text(text)
    # Python reads leading blanks as an indent: parse without them and add them back to columns.
    body = text.lstrip(" ")
    shift = len(text) - len(body)
    try:
        tree = ast.parse(body, mode="eval")
    except SyntaxError as exc:
        raise _syntax_error(text, exc, shift) from None
    except (ValueError, MemoryError, RecursionError) as exc:
        raise FormulaError(f"cannot parse: {exc}") from None
    root, fields, uses_value = _compile_tree(tree, shift)
    return Formula(text, fields, uses_value, root)


def parse_formula(text: str) -> Formula:
    """Parse and check a formula; nothing in it is run.

    Args:
        text: e.g. ``x * 57.2958`` or ``sqrt(linear.x**2 + linear.y**2)``; ``x`` is the bound value, other
            names are field paths of the message, with optional constant indices (``ranges[3]``).

    Raises:
        FormulaError: the text is not a valid formula of the language or exceeds a cap; the message names
            the problem and its column.
    """
    if not isinstance(text, str):
        raise FormulaError(f"formula must be a string, not {type(text).__name__}")
    return _parse_cached(text)
