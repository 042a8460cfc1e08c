"""Numbers in log lines and proposed RE2 patterns: found, captured exactly, previewed, bridge-ready."""

from __future__ import annotations

import math
import time

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog._regex._propose import (
    MAX_LINE,
    MAX_PROGRAM_SIZE,
    WORD_PATTERN,
    Proposal,
    ProposalError,
    _match_slow,
    capture_name,
    find_numbers,
    match_joined,
    match_lines,
    parse_console_line,
    preview,
    propose,
    suggest_tag,
    to_bridge_yaml,
)
from dbglog.regex_bridge import Matcher, parse_rules

# --- generated lines ---------------------------------------------------------------------------------

_DIGITS = st.text("0123456789", min_size=1, max_size=6)
_SIGN = st.sampled_from(["", "-", "+"])


@st.composite
def _numbers(draw: st.DrawFn) -> str:
    """A number in one of the notations the bridge's float parser accepts."""
    form = draw(st.sampled_from(["int", "decimal", "leading_dot", "exponent", "special"]))
    sign = draw(_SIGN)
    if form == "int":
        return sign + draw(_DIGITS)
    if form == "decimal":
        return f"{sign}{draw(_DIGITS)}.{draw(_DIGITS)}"
    if form == "leading_dot":
        return f"{sign}.{draw(_DIGITS)}"
    if form == "exponent":
        mantissa = draw(st.sampled_from([draw(_DIGITS), f"{draw(_DIGITS)}.{draw(_DIGITS)}"]))
        return f"{sign}{mantissa}{draw(st.sampled_from('eE'))}{draw(_SIGN)}{draw(_DIGITS)}"
    return sign + draw(st.sampled_from(["nan", "NaN", "inf", "Inf", "infinity", "Infinity", "INF"]))


# Text between numbers: letters (no 'n'/'N', so no nan/inf word appears by chance), spaces and every RE2
# metacharacter; it never ends with a letter, digit, '_' or '.' right before a number (the separators
# below), so each generated number stands alone.
_TEXT = st.text(
    st.sampled_from([*list("abcdghjklmopqrsuvwxyzABCDGHJ _=:,;/\\|^$*+?()[]{}\"'#@!&<>~`-"), "é", "→", "\t"]),
    max_size=12,
)
_BEFORE = st.sampled_from([" ", "=", ": ", "(", "[", ", ", "\t", " |", "{"])
_AFTER = st.sampled_from([" ", ",", ")", "]", ";", "%", " |", "}"])
_UNIT = st.sampled_from(["", "", "m", "ms", "V", "deg", "Hz", "µs"])


@st.composite
def _lines(draw: st.DrawFn) -> tuple[str, list[str]]:
    """A line with 1-5 numbers and the text of each number as it appears."""
    parts: list[str] = []
    numbers: list[str] = []
    for _ in range(draw(st.integers(1, 5))):
        parts.append(draw(_TEXT) + draw(_BEFORE))
        number = draw(_numbers())
        unit = "" if number[-1:].isalpha() else draw(_UNIT)
        parts.append(number + unit + draw(_AFTER))
        numbers.append(number)
    parts.append(draw(_TEXT))
    return "".join(parts), numbers


def _same(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or a == b


# --- find_numbers --------------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(_lines())
def test_find_numbers_finds_every_generated_number_in_every_notation(case: tuple[str, list[str]]) -> None:
    """Every number written in a notation the bridge accepts is found, with its exact text and value."""
    line, numbers = case
    found = find_numbers(line)
    assert [n.text for n in found] == numbers
    for n in found:
        assert line[n.start : n.end] == n.text
        assert _same(n.value, float(n.text))


@pytest.mark.parametrize(
    ("line", "expected"),
    [
        ("turtle1 moved to x2 y=3", ["3"]),
        ("flags 0x1F 0b1010 0o17 then 7", ["7"]),
        ("count 1_000 then 5", ["5"]),
        ("version 1.2.3 at 10.0.0.1 is 4.5", ["4.5"]),
        ("range 3-5 and x=-5 and (x)-2", ["3", "5", "-5", "2"]),
        ("took 12ms, 0.42m, 87% and 5.", ["12", "0.42", "87", "5"]),
        ("info about nanometers, inf and -NaN", ["inf", "-NaN"]),
        ("a.5 b_7 größe5 é7 but 2e5m", ["2e5"]),
        ("decimal comma 1,5", ["1", "5"]),
        ("arabic ١٢٣ is not 9", ["9"]),
    ],
)
def test_find_numbers_rules(line: str, expected: list[str]) -> None:
    """Identifiers, hex/binary/octal, _-separated digits, versions and addresses are not numbers."""
    assert [n.text for n in find_numbers(line)] == expected


def test_find_numbers_reports_glued_units_and_kind() -> None:
    """A unit glued to a number is reported; integers and floats are told apart."""
    found = find_numbers("latency 12ms speed 0.42m/s battery 87%")
    assert [(n.text, n.unit, n.kind) for n in found] == [
        ("12", "ms", "int"),
        ("0.42", "m", "float"),
        ("87", "%", "int"),
    ]


def test_find_numbers_offsets_are_characters_after_non_ascii_text() -> None:
    """Offsets count characters, not UTF-8 bytes, after non-ASCII text."""
    line = "température → 21.5 °C, humidité 40%"
    found = find_numbers(line)
    assert [line[n.start : n.end] for n in found] == ["21.5", "40"]


def test_find_numbers_reads_only_what_a_matcher_reads() -> None:
    """Numbers beyond the first MAX_LINE bytes are not offered (the bridge never sees them)."""
    line = "v=1 " + "x" * MAX_LINE + " 5"
    assert [n.text for n in find_numbers(line)] == ["1"]
    cut = "a " * ((MAX_LINE - 6) // 2) + "123456789"  # the cut splits the last number
    assert all(n.text != "1234" for n in find_numbers(cut))


# --- propose -----------------------------------------------------------------------------------------


@settings(max_examples=300, deadline=None)
@given(_lines(), st.data())
def test_proposal_matches_its_line_and_captures_exactly_the_chosen_number(
    case: tuple[str, list[str]], data: st.DataObject
) -> None:
    """The proposal matches the line it came from and captures exactly the chosen number (RE2 only)."""
    line, numbers = case
    index = data.draw(st.integers(0, len(numbers) - 1))
    proposal = propose(line, index, node="planner")
    number = proposal.number
    m = proposal.compiled.search(line)
    assert m is not None
    assert m.span(1) == (number.start, number.end)
    assert m.group(1) == numbers[index]
    assert proposal.anchored_start
    assert proposal.anchored_end
    assert proposal.compiled._regexp.ProgramSize() <= MAX_PROGRAM_SIZE
    assert type(proposal.compiled).__module__.startswith("re2")
    value = proposal.extract(line)
    assert value is not None
    assert _same(value, float(numbers[index]))


@settings(max_examples=150, deadline=None)
@given(_lines(), st.data())
def test_bridge_yaml_loads_and_the_bridge_matcher_takes_the_same_value(
    case: tuple[str, list[str]], data: st.DataObject
) -> None:
    """The YAML parses with the bridge's rules loader; its matcher takes the clicked value from the line."""
    line, numbers = case
    index = data.draw(st.integers(0, len(numbers) - 1))
    proposal = propose(line, index, node="planner")
    rules = parse_rules(to_bridge_yaml(proposal, "probe/value"))
    (rule,) = rules.rules
    assert rule.node == "planner"
    assert rule.pattern == proposal.pattern
    values = Matcher(rules).match(line, logger="planner", level=20)
    assert len(values) == 1
    assert values[0].topic == "/rosdashboard/probe/value"
    assert _same(float(values[0].value), float(numbers[index]))
    assert Matcher(rules).match(line, logger="other", level=20) == []


def test_proposal_escapes_text_and_generalises_other_numbers() -> None:
    """Literal text is escaped, other numbers generalised, whitespace runs become \\s+."""
    proposal = propose("distance to wall: 0.42 m (angle -12.5 deg)", 1)
    assert proposal.pattern.startswith(r"^distance\s+to\s+wall\:\s+")
    assert proposal.pattern.endswith(r"\s+deg\)$")
    assert proposal.extract("distance to wall: 3 m (angle 1e2 deg)") == 100.0
    assert proposal.extract("distance  to wall: 3 m (angle 7 deg)") == 7.0
    assert proposal.extract("distance to floor: 3 m (angle 7 deg)") is None


BUMPS = [
    f"bumped into the {wall} wall (hit #{k}) at x={k / 10:.2f} y=1.03"
    for k, wall in enumerate(["north", "south", "east", "west"] * 125)
]
"""The demo robot's bumps: one kind of line, the wall's name a word that changes."""


def test_generalised_words_match_every_line_of_that_kind_and_keep_the_numbers_name() -> None:
    """With `generalise_words` the words around the number match any word but the nearest before it (its
    name, `x` of `x=`): every bump matches, whichever wall; the literal words match a quarter."""
    line = BUMPS[1]  # the south wall
    loose = propose(line, 1, generalise_words=True)
    exact = propose(line, 1)
    assert preview(loose, BUMPS)[0] == 500
    assert preview(exact, BUMPS)[0] == 125
    assert r"\s+x\=(" in loose.pattern, "the anchor nearest the number stays literal"
    assert "south" not in loose.pattern
    assert loose.pattern.count(WORD_PATTERN) == 8
    assert loose.extract("bumped into the west wall (hit #3) at x=-2.5 y=0") == -2.5
    assert loose.extract("bumped into the west wall (hit #3) at y=-2.5 x=0") is None, "x, not y"
    assert preview(loose, [*BUMPS, "moved to the goal at x=1.0 y=2.0"])[0] == 500, "another kind of line"


@pytest.mark.parametrize(
    ("line", "index", "kept"),
    [
        ("took 12ms to plan 5 paths", 0, r"^took\s+("),
        ("took 12ms to plan 5 paths", 0, r")ms\s+"),
        ("12.5 m/s forward", 0, r"\s+m\/"),
        ("速度 12.5", 0, r"^速度\s+("),
        ("a=1 a=2", 1, r"\s+a\=("),
    ],
)
def test_the_nearest_word_and_a_glued_unit_stay_literal(line: str, index: int, kept: str) -> None:
    """The word nearest before the number (without one, after it) and a unit glued to it stay literal;
    the proposal still captures exactly its number."""
    proposal = propose(line, index, generalise_words=True)
    assert kept in proposal.pattern
    assert proposal.extract(line) == find_numbers(line)[index].value


def test_a_named_capture_carries_the_tag_and_is_read_back() -> None:
    """`named` names the capture group after a tag (made a valid group name); `capture_name` reads it."""
    proposal = propose("battery=87% 12.1V", 0)
    assert capture_name(proposal.pattern) is None
    assert capture_name(proposal.named("battery")) == "battery"
    assert capture_name(proposal.named("motor speed")) == "motor_speed"
    assert capture_name(proposal.named("2nd")) == "_2nd"
    assert proposal.named("!!") == proposal.pattern, "nothing left of the name: unnamed"
    assert capture_name("(unclosed") is None


def test_proposal_of_a_number_beyond_the_last_says_how_many_there_are() -> None:
    """Asking for a number the line lacks is a clear error naming the numbers it has."""
    with pytest.raises(ProposalError, match=r"number 3 does not exist: the line has 2 number\(s\) \(1, 2\)"):
        propose("a=1 b=2", 2)
    with pytest.raises(ProposalError, match="no number in the line"):
        propose("nothing here", 0)


def test_long_line_proposal_is_bounded_and_still_exact() -> None:
    """A 100 kB line: numbers found and a pattern proposed in bounded time, under RE2's size limit."""
    line = " ".join(f"key{i}={i * 0.5}" for i in range(10_000))
    assert len(line) > 100_000
    started = time.perf_counter()
    numbers = find_numbers(line)
    proposals = [propose(line, k) for k in (0, len(numbers) // 2, len(numbers) - 1)]
    assert time.perf_counter() - started < 2.0  # ~20 ms on an idle machine; generous for a loaded one
    for p in proposals:
        assert p.compiled._regexp.ProgramSize() <= MAX_PROGRAM_SIZE
        m = p.compiled.search(line[:MAX_LINE])
        assert m is not None
        assert m.span(1) == (p.number.start, p.number.end)
        assert not p.anchored_end


def test_repetitive_long_line_proposal_keeps_numbers_literal_to_stay_exact() -> None:
    """Where the generalised context repeats earlier in a long line, the other numbers stay literal."""
    line = " ".join(f"x={i}" for i in range(1500))
    numbers = find_numbers(line)
    p = propose(line, len(numbers) - 1)
    m = p.compiled.search(line[:MAX_LINE])
    assert m is not None
    assert m.span(1) == (p.number.start, p.number.end)


def test_proposal_never_evaluates_the_line() -> None:
    """Text that would run code if evaluated is only ever escaped into the pattern."""
    line = "__import__('os').system('touch /tmp/dbglog_pwned') value=3"
    p = propose(line, 0)
    assert p.extract(line) == 3.0
    assert r"\_\_import\_\_\(\'os\'\)" in p.pattern


# --- preview -----------------------------------------------------------------------------------------


@settings(max_examples=100, deadline=None)
@given(st.lists(_lines(), min_size=1, max_size=20), st.data())
def test_preview_agrees_with_matching_line_by_line(
    cases: list[tuple[str, list[str]]], data: st.DataObject
) -> None:
    """The joined-text preview gives the same rows and values as searching each line on its own."""
    lines = [line for line, _ in cases]
    source = data.draw(st.integers(0, len(lines) - 1))
    proposal = propose(lines[source], data.draw(st.integers(0, len(cases[source][1]) - 1)))
    lines = lines + lines[: data.draw(st.integers(0, len(lines)))]  # runs of matching lines
    rows, values = match_lines(proposal, lines)
    slow_rows, slow_values = _match_slow(proposal, lines)
    assert rows.tolist() == slow_rows.tolist()
    assert np.array_equal(values, slow_values, equal_nan=True)
    assert source in rows.tolist()


@settings(max_examples=100, deadline=None)
@given(_lines(), st.data())
def test_preview_of_runs_of_that_kind_agrees_with_matching_line_by_line(
    case: tuple[str, list[str]], data: st.DataObject
) -> None:
    """Runs of lines of the proposal's kind (other numbers, nan, other spacing) read as RE2 reads them."""
    line, numbers = case
    index = data.draw(st.sampled_from([0, len(numbers) - 1]))  # where numpy may read the values
    proposal = propose(line, index)
    spans = find_numbers(line)
    lines: list[str] = []
    for _ in range(data.draw(st.integers(5, 30))):
        variant = line
        for span in reversed(spans):
            variant = variant[: span.start] + data.draw(_numbers()) + variant[span.end :]
        if data.draw(st.booleans()):
            variant = variant.replace(" ", "  ", 1)
        lines.append(variant)
        if data.draw(st.integers(0, 9)) == 0:
            lines.append("unrelated line 7")
    rows, values = match_lines(proposal, lines)
    slow_rows, slow_values = _match_slow(proposal, lines)
    assert rows.tolist() == slow_rows.tolist()
    assert np.array_equal(values, slow_values, equal_nan=True)


def test_preview_counts_and_values_in_order() -> None:
    """preview returns the count and the values in line order; other lines don't count."""
    proposal = propose("battery=87% voltage 12.1V", 0)
    lines = ["battery=50% voltage 11.9V", "unrelated 3", "battery=49% voltage 11.8V", "battery=x% voltage 1V"]
    count, values = preview(proposal, lines)
    assert count == 2
    assert values.tolist() == [50.0, 49.0]


def test_match_joined_reads_a_columnar_buffer_like_the_list() -> None:
    """A store keeping lines as one separator-framed buffer gets the same rows and values as a list."""
    lines = ["speed 2 m/s", "other", "speed -1e1 m/s", "speed 3 m/s", "speed x m/s"]
    proposal = propose("speed 1.5 m/s", 0)
    store = bytearray()
    starts: list[int] = []
    for line in lines:
        starts.append(len(store))
        store += b"\x00" + line.encode() + b"\x01"
    rows, values = match_joined(proposal, store, starts)
    assert rows.tolist() == [0, 2, 3]
    assert values.tolist() == [2.0, -10.0, 3.0]
    list_rows, list_values = match_lines(proposal, lines)
    assert rows.tolist() == list_rows.tolist()
    assert values.tolist() == list_values.tolist()


def test_preview_filters_by_the_proposals_node() -> None:
    """With each line's node given, only the proposal's node's lines count."""
    proposal = propose("speed 1.5", 0, node="planner")
    rows, values = match_lines(
        proposal, ["speed 2", "speed 3", "speed 4"], nodes=["planner", "driver", "planner"]
    )
    assert rows.tolist() == [0, 2]
    assert values.tolist() == [2.0, 4.0]


def test_preview_handles_lines_holding_separator_bytes() -> None:
    """Lines containing NUL or \\x01 are matched correctly (line by line)."""
    proposal = propose("speed 1.5", 0)
    count, values = preview(proposal, ["speed 2", "a\x00b", "speed \x01", "speed 7"])
    assert count == 2
    assert values.tolist() == [2.0, 7.0]


def test_preview_of_100k_lines_is_fast() -> None:
    """Previewing 100,000 stored lines (one in ten matching) takes well under a second."""
    lines = [
        f"distance to wall: {i * 0.01:.2f} m (angle {-i % 90} deg)" if i % 10 == 0 else f"tick {i} ok"
        for i in range(100_000)
    ]
    proposal = propose(lines[0], 0)
    started = time.perf_counter()
    count, values = preview(proposal, lines)
    elapsed = time.perf_counter() - started
    assert count == 10_000
    assert values[1] == pytest.approx(0.1)
    assert elapsed < 2.0  # benchmarks/bench_logs.py reports the figure; this only guards against a stall


def test_preview_of_long_lines_is_bounded() -> None:
    """A thousand 100 kB lines preview in bounded time: each is read to MAX_LINE bytes, like the bridge."""
    line = "v=1 " + "y" * 100_000
    proposal = propose(line, 0)
    started = time.perf_counter()
    count, _ = preview(proposal, [line] * 1000)
    assert count == 1000
    assert time.perf_counter() - started < 5.0


# --- YAML, tags, console lines -------------------------------------------------------------------------


def test_to_bridge_yaml_refuses_a_bad_tag_and_level() -> None:
    """A bad tag or level is refused with the reason."""
    proposal = propose("x=1", 0)
    with pytest.raises(ValueError, match="invalid tag '1x': its part '1x' starts with a digit"):
        to_bridge_yaml(proposal, "1x")
    with pytest.raises(ValueError, match="unknown level 'loud'"):
        to_bridge_yaml(proposal, "x", level="loud")
    assert "level: warn" in to_bridge_yaml(proposal, "x", level="WARN")


def test_yaml_quotes_survive_single_quotes_in_the_line() -> None:
    """Quotes and backslashes in the line survive the YAML round trip."""
    line = "it's \\ 'odd' value=4"
    proposal = propose(line, 0, node="it's")
    (rule,) = parse_rules(to_bridge_yaml(proposal, "odd")).rules
    assert rule.pattern == proposal.pattern
    assert rule.node == "it's"


@pytest.mark.parametrize(
    ("line", "index", "tag"),
    [("battery=87%", 0, "battery"), ("took 12ms", 0, "took"), ("12ms", 0, "ms"), ("-> 5", 0, "value")],
)
def test_suggest_tag_names_the_word_before_the_number(line: str, index: int, tag: str) -> None:
    """The suggested tag is the word before the number, else its unit, else 'value'."""
    assert suggest_tag(propose(line, index)) == tag


def test_parse_console_line() -> None:
    """A line as rcl prints it splits into level, node and message; other text does not."""
    assert parse_console_line("[WARN] [1732200000.125] [planner_local]: speed 3") == (
        "warn",
        "planner_local",
        "speed 3",
    )
    assert parse_console_line("[INFO] speed 3") is None
    assert parse_console_line("speed 3") is None


def test_proposal_is_a_frozen_value() -> None:
    """A proposal is immutable data."""
    proposal = propose("x=1", 0)
    assert isinstance(proposal, Proposal)
    with pytest.raises(AttributeError):
        proposal.pattern = "x"  # type: ignore[misc]
