"""The matching engine: lines → typed values, filters, strict numbers, truncation, golden files; no ROS."""

from __future__ import annotations

import json
import math
import random
import time
from pathlib import Path
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from rcl_interfaces.msg import Log
from rclpy.serialization import serialize_message
from std_msgs.msg import Bool, Float64, Int64, String

from dbglog._ros._cdr import read_log, read_string
from dbglog.regex_bridge import MAX_LINE, Matcher, Value, load_rules, parse_rules

GOLDEN = Path(__file__).resolve().parent / "golden" / "bridge"
DEMO_RULES = Path(__file__).resolve().parent.parent / "examples" / "rules" / "demo_rules.yaml"


def _cases() -> list[str]:
    return sorted(p.name for p in GOLDEN.iterdir() if p.is_dir())


def _jsonl(path: Path) -> list[dict[str, Any]]:
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines() if line.strip()]


@pytest.mark.parametrize("case", _cases())
def test_golden_lines_give_the_expected_values(case: str) -> None:
    """Each golden case's sample lines yield exactly the recorded values and unparseable counts."""
    folder = GOLDEN / case
    rules_path = folder / "rules.yaml" if (folder / "rules.yaml").exists() else DEMO_RULES
    matcher = Matcher(load_rules(rules_path))
    inputs, expected = _jsonl(folder / "lines.jsonl"), _jsonl(folder / "expected.jsonl")
    assert len(inputs) == len(expected) > 0
    for given_line, want in zip(inputs, expected, strict=True):
        before = matcher.stats.unparseable_total
        got = matcher.match(
            given_line["line"],
            logger=given_line.get("logger", ""),
            level=given_line.get("level", 0),
            source=given_line.get("source", "/rosout"),
        )
        assert [list(v) for v in got] == want["values"], given_line
        assert matcher.stats.unparseable_total - before == want["unparseable"], given_line
        for value in got:
            assert type(value.value) is {"float": float, "int": int, "bool": bool}[value.kind]


def test_golden_cases_cover_the_demo_and_strictness() -> None:
    """The golden set includes the demo robot's lines, the strict-number and the per-group type cases."""
    assert {"demo", "strict_numbers", "filters", "group_types"} <= set(_cases())


def test_match_and_match_bytes_agree() -> None:
    """The str API and the UTF-8 bytes API give the same values."""
    matcher = Matcher(load_rules(DEMO_RULES))
    line = "sound source: azimuth=1.234 rad elevation=0.120 rad confidence=0.87"
    expected = [
        Value("/rosdashboard/sound/log/azimuth", "float", 1.234),
        Value("/rosdashboard/sound/log/elevation", "float", 0.12),
        Value("/rosdashboard/sound/log/confidence", "float", 0.87),
    ]
    assert matcher.match(line, logger="demo_sound_localizer", level=20) == expected
    assert matcher.match_bytes(line.encode(), "demo_sound_localizer", 20) == expected


def test_unparseable_captures_are_counted_with_the_last_one_kept() -> None:
    """A capture that is not a number is never returned; the stats say where and what."""
    matcher = Matcher(parse_rules("rules: [{tag: t, pattern: 'v=(\\S+)', type: int}]"))
    assert matcher.match("v=1,5") == []
    assert matcher.match("v=12") == [Value("/rosdashboard/t", "int", 12)]
    stats = matcher.reset_stats()
    assert stats.unparseable == {"/rosdashboard/t": 1}
    assert stats.values == 1
    assert stats.last_unparseable is not None
    assert stats.last_unparseable.text == "1,5"
    assert matcher.stats.unparseable_total == 0


def test_lines_are_truncated_for_matching() -> None:
    """Only the first MAX_LINE bytes of a line are matched, for str and bytes input alike."""
    matcher = Matcher(parse_rules("rules: [{tag: t, pattern: 'v=(\\d+)'}]"))
    inside, outside = "x" * (MAX_LINE - 4) + "v=12345", "x" * MAX_LINE + "v=1"
    assert matcher.match(inside) == [Value("/rosdashboard/t", "float", 12.0)]
    assert matcher.match_bytes(inside.encode()) == [Value("/rosdashboard/t", "float", 12.0)]
    assert matcher.match(outside) == []
    assert matcher.match_bytes(outside.encode()) == []


def test_optional_groups_that_do_not_take_part_publish_nothing() -> None:
    """A named group left out of the match gives no value for that output only."""
    matcher = Matcher(parse_rules("rules: [{tag: p, pattern: 'x=(?P<x>\\d+)(?: y=(?P<y>\\d+))?'}]"))
    assert matcher.match("x=1") == [Value("/rosdashboard/p/x", "float", 1.0)]
    assert len(matcher.match("x=1 y=2")) == 2


def test_many_distinct_loggers_do_not_grow_the_cache_without_bound() -> None:
    """Each (source, logger, level) is remembered, but the cache starts over past its limit."""
    matcher = Matcher(parse_rules("rules: [{tag: t, node: 'n*', pattern: 'v=(\\d+)'}]"))
    for i in range(5000):
        assert matcher.match("v=1", logger=f"n{i}", level=20) == [Value("/rosdashboard/t", "float", 1.0)]
    assert len(matcher._groups) <= 4096


@pytest.mark.parametrize("pattern", ["(a+)+$", "(a|aa)+$", r"(\w+\s?)+$", "(.*a){20}"])
def test_pathological_line_is_fast_through_the_engine(pattern: str) -> None:
    """100 kB of 'a' then '!' costs milliseconds at most against slow-for-backtracking rules."""
    matcher = Matcher(parse_rules(f"rules: [{{tag: t, pattern: '{pattern}'}}]"))
    line = "a" * 100_000 + "!"
    start = time.perf_counter()
    matcher.match(line)
    assert time.perf_counter() - start < 0.5  # loose: the benchmark measures it properly


@settings(max_examples=200, deadline=None)
@given(
    line=st.text(max_size=300),
    logger=st.text(max_size=20),
    level=st.integers(min_value=0, max_value=255),
)
def test_any_line_gives_a_list_of_typed_values_and_never_raises(line: str, logger: str, level: int) -> None:
    """Whatever the line (any Unicode, surrogates included), the result is a list of finite-typed values."""
    matcher = _RANDOM_MATCHER
    for value in matcher.match(line, logger=logger, level=level):
        assert value.topic.startswith("/rosdashboard/")
        assert isinstance(value.value, {"float": float, "int": int, "bool": bool}[value.kind])


_RANDOM_MATCHER = Matcher(
    parse_rules(
        "rules:\n"
        "  - {tag: a, pattern: '(\\S+)'}\n"
        "  - {tag: b, pattern: '(\\d+)', type: int}\n"
        "  - {tag: c, pattern: '(?i)(true|false)', type: bool}\n"
        "  - {tag: d, pattern: '(?P<x>.)(?P<y>.)', node: '*x*', level: warn}\n"
    )
)


def test_cdr_reader_matches_rclpy_serialization() -> None:
    """The raw Log/String readers return what rclpy serialized, for ASCII and non-ASCII text."""
    for name, text in [("demo_turtle", "odometry: speed 0.53 m/s"), ("n", ""), ("ñödé", "ünï ١٢٣ ✓" * 50)]:
        raw = serialize_message(Log(level=30, name=name, msg=text, file="f.py", function="fn", line=7))
        assert read_log(raw) == (30, name.encode(), text.encode())
        assert read_string(serialize_message(String(data=text))) == text.encode()
    assert read_log(b"\x00\x07\x00\x00" + bytes(40)) is None
    assert read_log(b"\x00\x01\x00\x00") is None
    assert read_string(b"\x00\x01\x00\x00\xff\xff\x00\x00") is None


def test_value_encoding_matches_rclpy_serialization() -> None:
    """Pre-serialized outputs deserialize to the same values rclpy would publish."""
    from rclpy.serialization import deserialize_message

    from dbglog.regex_bridge._node import encode_value

    for kind, msg_type, value in [
        ("float", Float64, 0.53),
        ("float", Float64, -math.inf),
        ("int", Int64, -(1 << 63)),
        ("bool", Bool, True),
        ("bool", Bool, False),
    ]:
        assert deserialize_message(encode_value(kind, value), msg_type).data == value  # type: ignore[arg-type]


# ------------------------------------------------------------------------------------------ batches

_TRICKY = (
    r"v=(\d+)",
    r"^v=(\d+)",
    r"(\d+)$",
    r"^(\d+)$",
    r"\Av(\d)",
    r"(\d)\z",
    r"(?-m)^a(\d)",
    r"(?s)a.(\d)",
    r"a\s*(\d)",
    r"a[^x]*?(\d)",
    r"\b(\d+)\b",
    r"\B(\d)",
    r"x?(\d*)",
    r"(?P<a>\d)=(?P<b>\d)?",
    r"(?P<x>\d+)\n(?P<y>\d+)",
    r"(?m)^b(\d)",
    r"é(\d)",
    r"(?i)A(\d)",
    r"a$|b(\d)",
    r"(\S+)",
)
_ALPHABET = "abvx=12 \n\té\u0661A"


def _rules_for(patterns: list[str], kinds: list[str]) -> str:
    rows = [
        f"  - {{tag: r{i}, pattern: {json.dumps(p)}, type: {kind}}}"
        for i, (p, kind) in enumerate(zip(patterns, kinds, strict=True))
    ]
    return "rules:\n" + "\n".join(rows) + "\n"


def _one_by_one(matcher: Matcher, lines: list[str], **origin: Any) -> list[tuple[Value, ...]]:
    return [tuple(matcher.match(line, **origin)) for line in lines]


@settings(max_examples=250, deadline=None)
@given(
    patterns=st.lists(st.sampled_from(_TRICKY), min_size=1, max_size=6, unique=True),
    kinds=st.lists(st.sampled_from(["float", "int", "bool"]), min_size=6, max_size=6),
    lines=st.lists(st.text(alphabet=_ALPHABET, max_size=24), max_size=40),
)
def test_match_many_gives_what_match_gives_line_by_line(
    patterns: list[str], kinds: list[str], lines: list[str]
) -> None:
    """A batch yields, line for line and in rule order, the values and unparseable counts of single calls."""
    rules = parse_rules(_rules_for(patterns, kinds[: len(patterns)]))
    alone, batched, raw = Matcher(rules), Matcher(rules), Matcher(rules)
    expected = _one_by_one(alone, lines)
    assert batched.match_many(lines) == expected
    assert raw.match_many_bytes([line.encode() for line in lines]) == expected
    for stats in (batched.stats, raw.stats):
        assert (stats.values, stats.unparseable) == (alone.stats.values, alone.stats.unparseable)


def test_match_many_over_several_chunks_and_long_lines() -> None:
    """Big batches (many chunks, lines up to past MAX_LINE, some with newlines) agree with single calls."""
    rnd = random.Random(7)
    patterns = [
        r"v=(\d+)",
        r"^b(\d)",
        r"(\d+)$",
        r"a\s*(\d)",
        r"a[^x]*(\d)",
        r"\Av(\d)",
        r"(?P<a>\d)=(?P<b>\d)",
    ]
    rules = parse_rules(_rules_for(patterns, ["float"] * len(patterns)))
    lines = []
    for _ in range(3000):
        size = rnd.choice([0, 1, 5, 20, 80, 300, MAX_LINE - 1, MAX_LINE, MAX_LINE + 3])
        lines.append(
            "".join(rnd.choice("abvx=12 é\n" if rnd.random() < 0.05 else "abvx=12 ") for _ in range(size))
        )
    alone, batched = Matcher(rules), Matcher(rules)
    expected = _one_by_one(alone, lines)
    assert sum(map(len, expected)) > 1000
    for size in (1, 7, 64, 3000):
        got = []
        for i in range(0, len(lines), size):
            got += batched.match_many(lines[i : i + size])
        assert got == expected, size
    assert batched.match_many_bytes([line.encode() for line in lines]) == expected


def test_match_many_with_a_logger_and_level_per_line() -> None:
    """Per-line origins select each line's rules, as `match` does; a length mismatch is a clear error."""
    matcher = Matcher(
        parse_rules(
            "rules:\n"
            "  - {tag: any, pattern: 'v=(\\d+)'}\n"
            "  - {tag: planner, pattern: 'v=(\\d+)', node: 'planner*'}\n"
            "  - {tag: loud, pattern: 'v=(\\d+)', level: warn}\n"
        )
    )
    lines = ["v=1", "v=2", "v=3", "v=4", "nothing"]
    loggers = ["planner_a", "other", "planner_b", "other", "planner_a"]
    levels = [20, 40, 30, 10, 50]
    expected = [tuple(matcher.match(*args)) for args in zip(lines, loggers, levels, strict=True)]
    assert [len(v) for v in expected] == [2, 2, 3, 1, 0]
    assert matcher.match_many(lines, loggers, levels) == expected
    assert matcher.match_many(lines, "other", levels) == [
        tuple(matcher.match(line, "other", lvl)) for line, lvl in zip(lines, levels, strict=True)
    ]
    assert matcher.match_many(lines, source="/elsewhere") == [()] * 5
    assert matcher.match_many([]) == []
    with pytest.raises(ValueError, match="5 lines but 4 loggers"):
        matcher.match_many(lines, loggers[:4], 20)


def test_batches_never_join_lines_into_a_match() -> None:
    """A pattern that could run across the join of two lines finds only what each line holds alone."""
    matcher = Matcher(
        parse_rules("rules:\n  - {tag: s, pattern: 'a\\s*(\\d+)'}\n  - {tag: n, pattern: 'b[^x]*(\\d+)'}\n")
    )
    # Few rules hit among many lines, so the batch searches each rule through the joined lines.
    lines = ["a", "12", "b", "b 3", "b", "", "4", "a 5 a", "6"] + ["nothing here"] * 30 + ["b", "7 a", "8"]
    got = matcher.match_many(lines)
    assert got == _one_by_one(matcher, lines)
    assert [[v.value for v in values] for values in got if values] == [[3.0], [5.0]]


def test_rules_that_need_the_ends_of_the_line_see_each_line_alone() -> None:
    """With \\A, \\z or (?-m) in a pattern, a batch matches each line on its own."""
    matcher = Matcher(
        parse_rules(
            "rules:\n  - {tag: e, pattern: '(\\d+)\\z'}\n  - {tag: t, pattern: '\\Av(\\d)'}\n"
            "  - {tag: m, pattern: '(?-m)^w(\\d)'}\n"
        )
    )
    lines = ["7 v", "v5", "v=1\nv2", "w3", "x\nw4"] + ["nothing"] * 20
    got = matcher.match_many(lines)
    assert got == _one_by_one(matcher, lines)
    assert [[v.value for v in values] for values in got[:5]] == [[], [5.0, 5.0], [2.0], [3.0, 3.0], [4.0]]


@pytest.mark.parametrize("pattern", ["(a+)+$", "(a|aa)+$", r"(\w+\s?)+$", "(.*a){20}", r"([^!]*a)+$"])
def test_pathological_lines_in_a_batch_stay_fast(pattern: str) -> None:
    """A batch with 100 kB lines of 'a' then '!' and many short matching lines costs milliseconds per line."""
    matcher = Matcher(parse_rules(f"rules: [{{tag: t, pattern: '{pattern}'}}]"))
    lines = (["a" * 100_000 + "!"] + ["a" * 30] * 50) * 4
    start = time.perf_counter()
    got = matcher.match_many(lines)
    elapsed = time.perf_counter() - start
    assert got == _one_by_one(matcher, lines)
    assert elapsed < 0.02 * len(lines)  # loose (a shared machine): 20 ms a line; the benchmark measures it


@settings(max_examples=150, deadline=None)
@given(
    lines=st.lists(
        st.tuples(
            st.text(alphabet="v=12 \n", max_size=12),
            st.sampled_from(["a", "ab", "b", ""]),
            st.sampled_from([0, 10, 20, 30, 40]),
        ),
        max_size=40,
    ),
    same_origin=st.booleans(),
)
def test_match_many_with_mixed_origins_gives_what_match_gives(
    lines: list[tuple[str, str, int]], same_origin: bool
) -> None:
    """Per-line loggers and levels (some selecting no rule at all) give the single-call values."""
    matcher = Matcher(
        parse_rules(
            "rules:\n"
            "  - {tag: any, pattern: 'v=(\\d+)'}\n"
            "  - {tag: a, pattern: '(\\d)$', node: 'a*'}\n"
            "  - {tag: loud, pattern: '^(\\d)', level: warn, node: ab}\n"
            "  - {tag: b, pattern: '=(\\d)', node: b, level: info}\n"
        )
    )
    texts = [text for text, _, _ in lines]
    loggers = [logger for _, logger, _ in lines]
    levels = [level for _, _, level in lines]
    if same_origin:
        loggers, levels = ["a"] * len(lines), [20] * len(lines)
    expected = [tuple(matcher.match(*args)) for args in zip(texts, loggers, levels, strict=True)]
    assert matcher.match_many(texts, loggers, levels) == expected
    assert matcher.match_many_bytes([t.encode() for t in texts], loggers, levels) == expected
