"""The safe formula language: values, fields, caps, runtime errors, array evaluation, the escape corpus."""

from __future__ import annotations

import ast
import json
import math
import subprocess
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog.viewer._values import _expr
from dbglog.viewer._values._expr import (
    MAX_DEPTH,
    MAX_EXPONENT,
    MAX_INDEX,
    MAX_INT_LITERAL,
    MAX_LENGTH,
    MAX_NODES,
    FormulaError,
    parse_formula,
)
from dbglog.viewer._values._transforms import TransformError, transforms_from_json

CORPUS_PATH = Path(__file__).parent / "data" / "escape_corpus.json"
PACKAGE = Path(_expr.__file__).parent


def _corpus() -> list[dict[str, Any]]:
    entries: list[dict[str, Any]] = json.loads(CORPUS_PATH.read_text(encoding="utf-8"))
    return entries


def _text(entry: dict[str, Any], sentinel: Path) -> str:
    """The formula text of a corpus entry, with the sentinel path filled in and repetitions expanded."""
    if "expand" in entry:
        spec = entry["expand"]
        return str(spec["prefix"] * spec["count"] + spec["middle"] + spec["suffix"] * spec["count"])
    return str(entry["formula"]).replace("SENTINEL", str(sentinel))


# ---------------------------------------------------------------------------------------------------------
# Valid formulas.

VALUES = {
    "x": 2.0,
    "linear.x": 3.0,
    "linear.y": 4.0,
    "pose.position.z": -1.5,
    "ranges[3]": 0.25,
    "ranges[-1]": 8.0,
    "poses[2].position.x": 7.0,
    "flag": True,
    "count": 3,
}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("x * 57.2958", 2.0 * 57.2958),
        ("sqrt(linear.x**2 + linear.y**2)", 5.0),
        ("hypot(linear.x, linear.y)", 5.0),
        ("-x + +x - 1", -1.0),
        ("x / 4", 0.5),
        ("7 // x", 3.0),
        ("-7 % 3", 2.0),
        ("2 ** 10", 1024.0),
        ("x ** 0.5", math.sqrt(2.0)),
        ("(x + 1) * (x - 1)", 3.0),
        ("1 < x < 3", 1.0),
        ("1 < x > 3", 0.0),
        ("x == 2 and linear.x != 3", 0.0),
        ("x >= 2 or 0", 1.0),
        ("0 or x", 2.0),
        ("x and linear.x", 3.0),
        ("not x", 0.0),
        ("not 0", 1.0),
        ("x if x > 1 else -x", 2.0),
        ("pose.position.z if pose.position.z > 0 else 0", 0.0),
        ("ranges[3] + ranges[-1]", 8.25),
        ("poses[2].position.x", 7.0),
        ("flag + count", 4.0),
        ("True + False", 1.0),
        ("abs(pose.position.z)", 1.5),
        ("sin(pi / 2)", 1.0),
        ("cos(0)", 1.0),
        ("tan(0)", 0.0),
        ("asin(1)", math.pi / 2),
        ("acos(1)", 0.0),
        ("atan(1)", math.pi / 4),
        ("atan2(linear.y, linear.x)", math.atan2(4.0, 3.0)),
        ("sinh(0) + cosh(0) + tanh(0)", 1.0),
        ("exp(0) + log(e) + log10(1000) + log2(8)", 1.0 + 1.0 + 3.0 + 3.0),
        ("log(8, 2)", 3.0),
        ("floor(-1.5) + ceil(1.2) + trunc(-1.7)", -2.0 + 2.0 - 1.0),
        ("round(2.5) + round(3.5)", 2.0 + 4.0),
        ("round(1.23456, 2)", 1.23),
        ("min(3, x, 5) + max(3, x, 5)", 7.0),
        ("clamp(linear.y, 0, 1) + clamp(-5, 0, 1)", 1.0),
        ("sign(pose.position.z) + sign(0) + sign(x)", 0.0),
        ("degrees(pi)", 180.0),
        ("radians(180)", math.pi),
        ("wrap_angle(3 * pi / 2)", -math.pi / 2),
        ("tau / 2", math.pi),
        ("1e3 + 0.5e-3 + 1_000", 2000.0005),
        ("0x10 + 0o10 + 0b10", 26.0),
    ],
)
def test_formula_values(text: str, expected: float) -> None:
    """Each allowed construct computes what Python's float arithmetic and math module give."""
    result = parse_formula(text).evaluate_result(VALUES)
    assert result.ok, result.error
    assert result.value == pytest.approx(expected, rel=1e-12, abs=1e-12)


def test_formula_fields_and_value() -> None:
    """A formula reports the field paths it reads, separately from the bound value x."""
    f = parse_formula("sqrt(linear.x**2 + linear.y**2) + ranges[3] * x + poses[2].position.x")
    assert f.fields == {"linear.x", "linear.y", "ranges[3]", "poses[2].position.x"}
    assert f.uses_value
    assert f.keys == f.fields | {"x"}
    g = parse_formula("x * 57.2958")
    assert g.fields == frozenset()
    assert g.uses_value
    assert not parse_formula("linear.x").uses_value


def test_constant_formula_is_folded() -> None:
    """A formula that reads nothing is computed once, at parse time."""
    assert parse_formula("2 * pi").constant == 2 * math.pi
    assert parse_formula("x * 2").constant is None
    assert parse_formula("2 * pi").evaluate({}) == 2 * math.pi


def test_formula_equality_and_cache() -> None:
    """Formulas compare and hash by their text; parsing the same text twice gives an equal formula."""
    a = parse_formula("x + 1")
    assert a == parse_formula("x + 1")
    assert a != parse_formula("x + 2")
    assert len({a, parse_formula("x + 1")}) == 1


# ---------------------------------------------------------------------------------------------------------
# Rejections, with the column.


@pytest.mark.parametrize(
    ("text", "column", "fragment"),
    [
        ("open(x)", 1, "unknown function 'open'"),
        ("x + foo(1)", 5, "unknown function 'foo'"),
        ("x + 'a'", 5, "string literals"),
        ("x.y", 1, "bound value"),
        ("linear._x", 1, "'_x'"),
        ("linear.__dict__", 8, "'__'"),
        ("ranges[x]", 8, "constant integer"),
        ("x +", 4, "invalid syntax"),
        ("sqrt", 1, "is a function"),
        ("pi.real", 1, "no attributes"),
        ("x ** 200", 6, "exponent 200 is too large"),
        ("atan2(x)", 1, "takes 2 arguments, got 1"),
        ("min()", 1, "at least 1"),
        ("round(x, 1, 2)", 1, "takes 1 or 2 arguments"),
        ("round(x, 0.5)", 10, "constant integer"),
        ("max(x, key=1)", 1, "keyword"),
        ("x is 1", 1, "'is'"),
        ("  [x]", 3, "lists"),
        ("x < (1, 2)", 5, "tuples"),
        ("1 / 0", 1, "division by zero"),
        ("sqrt(-1)", 1, "domain"),
        ("x\ty", 2, "U+0009"),
        ("x + é", 5, "U+00E9"),
    ],
)
def test_rejections_name_problem_and_column(text: str, column: int, fragment: str) -> None:
    """A bad formula raises FormulaError naming the problem and the 1-based column where it starts."""
    with pytest.raises(FormulaError) as info:
        parse_formula(text)
    assert info.value.column == column, str(info.value)
    assert fragment in str(info.value)
    assert str(info.value).startswith(f"column {column}: ")


def test_formula_error_is_value_error() -> None:
    """FormulaError subclasses ValueError, and a non-string is rejected the same way."""
    assert issubclass(FormulaError, ValueError)
    with pytest.raises(FormulaError, match="must be a string"):
        parse_formula(42)  # type: ignore[arg-type]
    with pytest.raises(FormulaError, match="empty"):
        parse_formula("   ")


def test_length_cap() -> None:
    """A formula of exactly MAX_LENGTH characters parses; one more is rejected before the Python parser."""
    exact = "x" + " " * (MAX_LENGTH - 1)
    assert parse_formula(exact).evaluate({"x": 1.0}) == 1.0
    with pytest.raises(FormulaError, match=f"the limit is {MAX_LENGTH}"):
        parse_formula(exact + " ")


def test_depth_cap() -> None:
    """Nesting up to MAX_DEPTH is fine; deeper brackets or operator chains are rejected."""
    ok = "(" * (MAX_DEPTH - 1) + "x" + ")" * (MAX_DEPTH - 1)
    assert parse_formula(ok).evaluate({"x": 3.0}) == 3.0
    with pytest.raises(FormulaError, match="nested deeper"):
        parse_formula("(" * (MAX_DEPTH + 1) + "x" + ")" * (MAX_DEPTH + 1))
    with pytest.raises(FormulaError, match="nested deeper"):
        parse_formula("-" * (MAX_DEPTH + 1) + "x")
    with pytest.raises(FormulaError, match="nested deeper"):
        parse_formula("+".join(["x"] * (MAX_DEPTH + 2)))


def test_node_cap() -> None:
    """A formula with more than MAX_NODES parts is rejected even when shallow."""
    wide = "max(" + ",".join(["x"] * (MAX_NODES + 1)) + ")"
    assert len(wide) <= MAX_LENGTH
    with pytest.raises(FormulaError, match=f"more than {MAX_NODES} parts"):
        parse_formula(wide)
    assert parse_formula("max(" + ",".join(["x"] * 40) + ")").evaluate({"x": 1.0}) == 1.0


def test_exponent_and_literal_caps() -> None:
    """Constant exponents, integer literals and indices are capped; values at the cap are accepted."""
    assert parse_formula(f"x ** {MAX_EXPONENT}").evaluate({"x": 1.0}) == 1.0
    assert parse_formula(f"x ** -{MAX_EXPONENT}").evaluate({"x": 2.0}) == 2.0**-MAX_EXPONENT
    with pytest.raises(FormulaError, match="exponent"):
        parse_formula(f"x ** {MAX_EXPONENT + 1}")
    with pytest.raises(FormulaError, match="exponent 387420489"):
        parse_formula("9**9**9")
    assert parse_formula(str(MAX_INT_LITERAL)).constant == float(MAX_INT_LITERAL)
    with pytest.raises(FormulaError, match="integer literal"):
        parse_formula(str(MAX_INT_LITERAL + 1))
    with pytest.raises(FormulaError, match="out of float range"):
        parse_formula("1e309")
    assert parse_formula(f"ranges[{MAX_INDEX}]").fields == {f"ranges[{MAX_INDEX}]"}
    with pytest.raises(FormulaError, match="index is too large"):
        parse_formula(f"ranges[{MAX_INDEX + 1}]")


# ---------------------------------------------------------------------------------------------------------
# Runtime errors: NaN plus a reason, never an exception.


@pytest.mark.parametrize(
    ("text", "values", "fragment"),
    [
        ("1 / x", {"x": 0.0}, "division by zero"),
        ("x // 0.0 + 1", {"x": 1.0}, "division by zero"),
        ("x % 0.0", {"x": 1.0}, "division by zero"),
        ("sqrt(x)", {"x": -1.0}, "domain"),
        ("log(x)", {"x": 0.0}, "domain"),
        ("acos(x)", {"x": 2.0}, "domain"),
        ("x ** 0.5", {"x": -8.0}, "domain"),
        ("0.0 ** x", {"x": -1.0}, "'**'"),
        ("exp(x)", {"x": 1000.0}, "out of float range"),
        ("x * 1e300 * 1e300", {"x": 1.0}, "out of float range"),
        ("x ** 100", {"x": 1e10}, "out of float range"),
        ("x ** linear.x", {"x": 10.0, "linear.x": 1e6}, "out of float range"),
        ("(1 / x) > 1", {"x": 0.0}, "division by zero"),
        ("linear.z", {"x": 1.0}, "field 'linear.z' is missing"),
        ("x", {}, "field 'x' is missing"),
        ("x + 1", {"x": "3"}, "not a number (str)"),
        ("x + 1", {"x": None}, "not a number (NoneType)"),
        ("x + 1", {"x": 10**400}, "out of float range"),
        ("x + 1", {"x": math.inf}, "not a finite number"),
        ("x + 1", {"x": math.nan}, "not a finite number"),
    ],
)
def test_runtime_errors_give_nan_and_reason(text: str, values: dict[str, Any], fragment: str) -> None:
    """A value that cannot be computed yields NaN and a reason; evaluate itself never raises."""
    formula = parse_formula(text)
    result = formula.evaluate_result(values)
    assert math.isnan(result.value)
    assert result.error is not None
    assert fragment in result.error
    assert math.isnan(formula.evaluate(values))


def test_untaken_branch_is_not_evaluated() -> None:
    """Conditionals and boolean operators short-circuit like Python, so a guarded division is fine."""
    f = parse_formula("1 / x if x != 0 else 0")
    assert f.evaluate({"x": 0.0}) == 0.0
    assert f.evaluate({"x": 4.0}) == 0.25
    g = parse_formula("x != 0 and 1 / x")
    assert g.evaluate({"x": 0.0}) == 0.0
    h = parse_formula("0 > x > 1 / x")
    assert h.evaluate({"x": 0.0}) == 0.0


@settings(max_examples=200, deadline=None)
@given(
    st.sampled_from(
        ["x * 57.2958", "sqrt(linear.x**2 + linear.y**2)", "log(x) / x", "x ** linear.x", "exp(x) % linear.y"]
    ),
    st.one_of(st.floats(), st.integers(), st.booleans(), st.none(), st.text(max_size=3)),
    st.floats(),
    st.floats(),
)
def test_evaluate_never_raises(text: str, x: object, lx: float, ly: float) -> None:
    """Whatever values arrive, evaluation returns a finite value or NaN with a reason."""
    result = parse_formula(text).evaluate_result({"x": x, "linear.x": lx, "linear.y": ly})  # type: ignore[dict-item]
    if result.ok:
        assert math.isfinite(result.value)
    else:
        assert math.isnan(result.value)
        assert result.error


# ---------------------------------------------------------------------------------------------------------
# Generated formulas: scalar evaluation matches a Python reference, and array evaluation matches scalar.

Ref = Callable[[dict[str, float]], float]
_LEAVES = st.one_of(
    st.sampled_from([("x", lambda v: v["x"]), ("a.b", lambda v: v["a.b"]), ("r[2]", lambda v: v["r[2]"])]),
    st.integers(-9, 9).map(lambda i: (f"({i})", lambda v, i=i: float(i))),
    st.floats(-100, 100, allow_nan=False).map(lambda f: (f"({f!r})", lambda v, f=f: f)),
)


def _combine(children: st.SearchStrategy[tuple[str, Ref]]) -> st.SearchStrategy[tuple[str, Ref]]:
    binary: list[tuple[str, Callable[[float, float], float]]] = [
        ("+", lambda a, b: a + b),
        ("-", lambda a, b: a - b),
        ("*", lambda a, b: a * b),
        ("/", lambda a, b: a / b),
        ("//", lambda a, b: a // b),
        ("%", lambda a, b: a % b),
        ("<", lambda a, b: float(a < b)),
        ("==", lambda a, b: float(a == b)),
        ("and", lambda a, b: a and b),
        ("or", lambda a, b: a or b),
    ]

    def make_binary(pair: tuple[tuple[str, Ref], tuple[str, Ref]], op: tuple[str, Any]) -> tuple[str, Ref]:
        (ta, fa), (tb, fb) = pair
        sym, fn = op
        if sym == "and":
            return f"({ta} and {tb})", lambda v: fa(v) and fb(v)
        if sym == "or":
            return f"({ta} or {tb})", lambda v: fa(v) or fb(v)
        return f"({ta} {sym} {tb})", lambda v: fn(fa(v), fb(v))

    def make_call(child: tuple[str, Ref], name: str) -> tuple[str, Ref]:
        text, f = child
        funcs: dict[str, Callable[[float], float]] = {
            "abs": abs,
            "sqrt": math.sqrt,
            "floor": lambda a: float(math.floor(a)),
            "-": lambda a: -a,
            "not": lambda a: float(not a),
        }
        if name in ("-", "not"):
            return f"({name} {text})", lambda v: funcs[name](f(v))
        return f"{name}({text})", lambda v: funcs[name](f(v))

    def make_if(triple: tuple[tuple[str, Ref], tuple[str, Ref], tuple[str, Ref]]) -> tuple[str, Ref]:
        (tc, fc), (ta, fa), (tb, fb) = triple
        return f"({ta} if {tc} else {tb})", lambda v: fa(v) if fc(v) else fb(v)

    def make_minmax(pair: tuple[tuple[str, Ref], tuple[str, Ref]], name: str) -> tuple[str, Ref]:
        (ta, fa), (tb, fb) = pair
        pick = min if name == "min" else max
        return f"{name}({ta}, {tb})", lambda v: pick(fa(v), fb(v))

    return st.one_of(
        st.builds(make_binary, st.tuples(children, children), st.sampled_from(binary)),
        st.builds(make_call, children, st.sampled_from(["abs", "sqrt", "floor", "-", "not"])),
        st.builds(make_if, st.tuples(children, children, children)),
        st.builds(make_minmax, st.tuples(children, children), st.sampled_from(["min", "max"])),
    )


_FORMULAS = st.recursive(_LEAVES, _combine, max_leaves=12)
_ROW = st.fixed_dictionaries(
    {k: st.floats(-1000, 1000, allow_nan=False) | st.integers(-3, 3).map(float) for k in ("x", "a.b", "r[2]")}
)


def _reference(f: Ref, row: dict[str, float]) -> float | None:
    try:
        value = f(row)
    except (ArithmeticError, ValueError):
        return None
    return value if math.isfinite(value) else None


@settings(max_examples=300, deadline=None)
@given(_FORMULAS, st.lists(_ROW, min_size=1, max_size=8))
def test_generated_formulas_match_python_and_vectorised(
    formula: tuple[str, Ref], rows: list[dict[str, float]]
) -> None:
    """Generated formulas give Python's float results; array evaluation gives the same values and NaNs."""
    text, ref = formula
    try:
        f = parse_formula(text)
    except FormulaError as exc:
        rejection = str(exc)
    else:
        rejection = ""
    if rejection:
        # A constant part that cannot be computed (e.g. "(3) / (0)") is rejected at parse time.
        assert "constant part cannot be computed" in rejection
        return
    scalar = []
    for row in rows:
        expected = _reference(ref, row)
        result = f.evaluate_result(row)
        if expected is None:
            assert not result.ok
        elif result.ok:
            assert result.value == expected
        else:
            # The language also rejects a non-finite intermediate from finite inputs (Python may recover).
            assert result.error is not None
        scalar.append(result.value)
    columns = {k: np.array([row[k] for row in rows]) for k in ("x", "a.b", "r[2]")}
    vector = f.evaluate_array(columns, len(rows))
    np.testing.assert_array_equal(vector, np.array(scalar))


def test_vectorised_missing_and_misaligned_columns() -> None:
    """Array evaluation reports a missing or misaligned column as all-NaN with a reason."""
    f = parse_formula("x + linear.y")
    missing = f.evaluate_array_result({"x": np.ones(3)})
    assert np.isnan(missing.values).all()
    assert missing.error is not None
    assert "linear.y" in missing.error
    bad = f.evaluate_array_result({"x": np.ones(3), "linear.y": np.ones(2)})
    assert np.isnan(bad.values).all()
    assert bad.error is not None
    assert "shape" in bad.error
    ok = f.evaluate_array_result({"x": np.array([1.0, 0.0]), "linear.y": [2.0, 3.0]})
    np.testing.assert_array_equal(ok.values, [3.0, 3.0])
    assert ok.failed == 0
    with pytest.raises(ValueError, match="length"):
        parse_formula("2 * pi").evaluate_array({})
    np.testing.assert_array_equal(parse_formula("2 * pi").evaluate_array({}, 2), [2 * math.pi] * 2)


def test_vectorised_partial_failures() -> None:
    """Array evaluation marks just the rows that fail and counts them."""
    result = parse_formula("sqrt(x) + 1 / x").evaluate_array_result({"x": [4.0, 0.0, -1.0, 1.0]})
    np.testing.assert_array_equal(np.isnan(result.values), [False, True, True, False])
    assert result.values[0] == 2.25
    assert result.failed == 2


# ---------------------------------------------------------------------------------------------------------
# The escape corpus.


def test_escape_corpus_size() -> None:
    """The corpus is large, holds live payloads, and names why each entry is there."""
    corpus = _corpus()
    assert len(corpus) >= 60
    assert sum(1 for e in corpus if e.get("sentinel")) >= 20
    assert all(e["why"] for e in corpus)


def test_escape_corpus_rejected_and_sentinel_never_created(tmp_path: Path) -> None:
    """Every corpus entry is rejected when loaded, as a formula and as a dashboard transform; nothing runs."""
    sentinel = tmp_path / "sentinel"
    messages: list[str] = []
    accepted: list[str] = []
    for entry in _corpus():
        text = _text(entry, sentinel)
        try:
            formula = parse_formula(text)
        except FormulaError as exc:
            messages.append(str(exc))
        else:
            formula.evaluate(VALUES)  # only reached if an entry were accepted: that fails below
            accepted.append(entry["why"])
        with pytest.raises(TransformError, match=r"^widget 'Gauge': transforms\[0\] \(formula\): "):
            transforms_from_json([{"kind": "formula", "expr": text}], where="widget 'Gauge'")
    assert accepted == []
    assert len(messages) == len(_corpus())
    assert all(messages)
    assert not sentinel.exists()
    assert list(tmp_path.iterdir()) == []


def test_escape_corpus_rejected_by_the_tree_check_alone(tmp_path: Path) -> None:
    """Defence in depth: with the text checks skipped, the AST allow-list still rejects every entry."""
    sentinel = tmp_path / "sentinel"
    checked = 0
    for entry in _corpus():
        if entry.get("text_only"):
            continue
        text = _text(entry, sentinel)
        if len(text) > 20 * MAX_LENGTH:
            continue  # the Python parser itself fails on these (RecursionError): the length cap comes first
        try:
            tree = ast.parse(text, mode="eval")
        except (SyntaxError, ValueError):
            continue
        with pytest.raises(FormulaError):
            _expr._compile_tree(tree)
        checked += 1
    assert checked >= 120
    assert not sentinel.exists()


def test_escape_corpus_payloads_are_live(tmp_path: Path) -> None:
    """Control: each sentinel payload, run by plain Python in a child process, does create the sentinel."""
    for i, entry in enumerate(e for e in _corpus() if e.get("sentinel")):
        workdir = tmp_path / f"p{i}"
        workdir.mkdir()
        sentinel = workdir / "sentinel"
        subprocess.run(
            [sys.executable, "-I", "-c", _text(entry, sentinel)],
            cwd=workdir,
            capture_output=True,
            timeout=30,
            check=False,
        )
        assert sentinel.exists(), f"payload did not run under Python: {entry['why']}"


def test_no_eval_exec_or_compile_in_the_formula_modules() -> None:
    """The formula and transform modules never call eval, exec, compile or __import__."""
    banned = {"eval", "exec", "compile", "__import__"}
    for name in ("_expr.py", "_transforms.py"):
        tree = ast.parse((PACKAGE / name).read_text(encoding="utf-8"))
        for node in ast.walk(tree):
            if isinstance(node, ast.Call):
                func = node.func
                called = func.id if isinstance(func, ast.Name) else getattr(func, "attr", "")
                assert called not in banned, f"{name}:{node.lineno} calls {called}"


# ---------------------------------------------------------------------------------------------------------
# Cost.


@pytest.mark.parametrize(
    "text",
    [
        "x * 57.2958",
        "sqrt(linear.x**2 + linear.y**2)",
        "degrees(atan2(linear.y, linear.x)) if hypot(linear.x, linear.y) > 0.1 else 0",
        "clamp(round(x * 100, 2) / 3 + min(linear.x, linear.y, 5) - max(x, 1) ** 2, -10, 10)",
    ],
)
def test_evaluation_is_fast(text: str) -> None:
    """One evaluation of a typical formula stays far below a millisecond (loose bound; see the benchmark)."""
    formula = parse_formula(text)
    values = {"x": 1.5, "linear.x": 3.0, "linear.y": 4.0}
    worst = 0.0
    for _ in range(5):
        start = time.perf_counter()
        for _ in range(200):
            formula.evaluate(values)
        worst = max(worst, (time.perf_counter() - start) / 200)
    assert worst <= 10e-3
    assert math.isfinite(formula.evaluate(values))
