"""Safe regexes (RE2, linear time) and strict ASCII number parsing."""

from __future__ import annotations

import math
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from dbglog._regex._compile import (
    MAX_LINE,
    MAX_PROGRAM_SIZE,
    RegexError,
    compile_regex,
    parse_number,
    parse_number_bytes,
)

PATHOLOGICAL_LINE = "a" * 100_000 + "!"


@pytest.mark.parametrize(
    ("pattern", "why"),
    [
        ("(", "missing )"),
        ("[", "missing ]"),
        ("(?P<x>", "missing )"),
        (r"(a)\1", "backreferences are not supported"),
        ("a(?=b)", "lookarounds are not supported"),
        ("(.*a){200}", "too complex"),
    ],
)
def test_patterns_re2_cannot_run_are_rejected_with_the_reason(pattern: str, why: str) -> None:
    """Broken patterns and PCRE-only features fail to compile, saying why (no fallback to `re`)."""
    with pytest.raises(RegexError, match=why.replace("(", r"\(").replace(")", r"\)")):
        compile_regex(pattern)


def test_non_string_pattern_is_rejected() -> None:
    """A pattern must be text."""
    with pytest.raises(RegexError, match="must be a string"):
        compile_regex(42)  # type: ignore[arg-type]


@pytest.mark.parametrize("pattern", ["(a+)+$", "(a|aa)+$", r"(\w+\s?)+$", "(.*a){20}"])
def test_catastrophic_backtracking_patterns_run_in_linear_time(pattern: str) -> None:
    """Patterns that hang backtracking engines compile and finish fast, even on a 100 kB line."""
    compiled = compile_regex(pattern)
    start = time.perf_counter()
    compiled.compiled.search(PATHOLOGICAL_LINE)
    compiled.extract(PATHOLOGICAL_LINE)
    assert time.perf_counter() - start < 2.0  # backtracking would need longer than the age of the universe


def test_pathological_line_costs_at_most_milliseconds() -> None:
    """100 kB of 'a' then '!' against (a+)+$ takes well under 10 ms (loosely checked: shared CI)."""
    compiled = compile_regex("(a+)+$")
    best = min(_timed(lambda: compiled.compiled.search(PATHOLOGICAL_LINE)) for _ in range(5))
    assert best < 0.05


def _timed(fn: object) -> float:
    assert callable(fn)
    start = time.perf_counter()
    fn()
    return time.perf_counter() - start


def test_program_size_cap_is_documented_and_generous() -> None:
    """Ordinary log patterns stay far below the program-size cap."""
    big = r"x=(?P<x>[-+]?\d+(?:\.\d+)?) y=(?P<y>[-+]?\d+(?:\.\d+)?) z=(?P<z>[-+]?\d+(?:\.\d+)?)"
    assert compile_regex(big).compiled._regexp.ProgramSize() * 10 < MAX_PROGRAM_SIZE


def test_extract_truncates_long_lines() -> None:
    """Only the first MAX_LINE characters of a line are matched."""
    compiled = compile_regex(r"v=(\d+)")
    assert compiled.extract("x" * (MAX_LINE - 4) + "v=12345") == "12"
    assert compiled.extract("x" * MAX_LINE + "v=1") is None


def test_extract_returns_group_names_and_first_group() -> None:
    """Group names are recorded in order; extract gives the first group or the whole match."""
    compiled = compile_regex(r"(?P<a>\d+)-(\d+)")
    assert compiled.group_names == ("a", None)
    assert compiled.extract("x 12-34") == "12"
    assert compile_regex(r"\d+").extract("ab 77") == "77"


def test_re2_digit_class_is_ascii_only() -> None:
    r"""RE2's \d never matches Arabic-Indic digits, so they never reach the number parser as digits."""
    assert compile_regex(r"(\d+)").extract("v=١٢٣") is None


@pytest.mark.parametrize(
    ("text", "kind", "expected"),
    [
        ("0.53", "float", 0.53),
        (" -87.2 ", "float", -87.2),
        ("1e3", "float", 1000.0),
        ("+5", "int", 5),
        ("-0012", "int", -12),
        ("true", "bool", True),
        ("OFF", "bool", False),
        ("1", "bool", True),
        ("-inf", "float", -math.inf),
    ],
)
def test_parse_number_accepts_plain_ascii_numbers(text: str, kind: str, expected: object) -> None:
    """Plain ASCII numbers of each kind parse to the right value."""
    assert parse_number(text, kind) == expected  # type: ignore[arg-type]
    assert parse_number_bytes(text.encode(), kind) == expected  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("text", "kind"),
    [
        ("١٢٣", "float"),
        ("١٢٣", "int"),
        ("１２", "int"),
        ("1_000", "float"),
        ("1_000", "int"),
        ("0x1F", "float"),
        ("0x1F", "int"),
        ("1,5", "float"),
        ("1.5", "int"),
        ("", "float"),
        (".", "float"),
        ("e5", "float"),
        ("nan", "int"),
        ("maybe", "bool"),
        ("\x1c1", "float"),
    ],
)
def test_parse_number_rejects_what_float_would_stretch_to_accept(text: str, kind: str) -> None:
    """Other scripts' digits, separators, hex and decimal commas are refused, never silently accepted."""
    with pytest.raises(ValueError, match="not a"):
        parse_number(text, kind)  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="not a"):
        parse_number_bytes(text.encode(), kind)  # type: ignore[arg-type]


def _outcome(fn: object, arg: object, kind: str) -> object:
    assert callable(fn)
    try:
        value = fn(arg, kind)
    except ValueError:
        return "error"
    return "nan" if isinstance(value, float) and math.isnan(value) else (type(value), value)


_NUMBERISH = st.text(alphabet="0123456789+-.eE_xX, \tnaiftyNAIF١٢３", max_size=12)


@given(text=st.one_of(_NUMBERISH, st.text(max_size=12)), kind=st.sampled_from(["float", "int", "bool"]))
def test_fast_byte_parser_agrees_with_parse_number(text: str, kind: str) -> None:
    """The bridge's bytes parser accepts exactly what parse_number accepts, with the same value."""
    assert _outcome(parse_number_bytes, text.encode("utf-8", "surrogatepass"), kind) == _outcome(
        parse_number, text, kind
    )


@pytest.mark.parametrize("pattern", ["(" + "a" * 100_000, "[" + "b" * 100_000, "(?P<" + "x" * 100_000])
def test_errors_for_huge_patterns_quote_only_their_start_and_length(pattern: str) -> None:
    """RE2 names the rest of a broken pattern; a 100 KB pattern comes back cut, with its length."""
    with pytest.raises(RegexError) as info:
        compile_regex(pattern)
    message = str(info.value)
    assert len(message) < 200, message[:300]
    assert f"… ({len(pattern)} chars)" in message
    assert pattern[:40] in message
