"""Rules files: validated into typed rules; every problem reported with the rule's tag, line and reason."""

from __future__ import annotations

import re
import textwrap
from pathlib import Path

import pytest
import yaml
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog.regex_bridge import LEVELS, Problem, RulesError, RuleSet, load_rules, parse_rules

DEMO_RULES = Path(__file__).resolve().parent.parent / "examples" / "rules" / "demo_rules.yaml"


def _problems(text: str) -> list[Problem]:
    with pytest.raises(RulesError) as info:
        parse_rules(textwrap.dedent(text), source="r.yaml")
    return list(info.value.problems)


def test_valid_rules_become_typed_rules_with_outputs() -> None:
    """A rule's fields and outputs are typed; one group → the tag, named groups → tag/name."""
    rules = parse_rules(
        textwrap.dedent(
            r"""
            rules:
              - tag: battery
                pattern: 'battery=(\d+)%'
                type: int
              - tag: pose
                node: 'planner*'
                level: warn
                pattern: 'x=(?P<x>\S+) y=(?P<y>\S+)'
              - tag: chat
                source_topic: chatter
                type: bool
                pattern: 'ok=(\w+)'
            """
        )
    )
    battery, pose, chat = rules.rules
    assert (battery.tag, battery.kind, battery.node, battery.min_level, battery.line) == (
        "battery",
        "int",
        None,
        0,
        3,
    )
    assert [(o.topic, o.group, o.kind) for o in battery.outputs] == [("/rosdashboard/battery", 1, "int")]
    assert [o.topic for o in pose.outputs] == ["/rosdashboard/pose/x", "/rosdashboard/pose/y"]
    assert (pose.node, pose.min_level, pose.kind) == ("planner*", LEVELS["warn"], "float")
    assert chat.source_topic == "/chatter"
    assert rules.source_topics == ("/rosout", "/chatter")
    assert len(rules.outputs) == 4


def test_single_named_group_publishes_to_the_tag_itself() -> None:
    """With exactly one group, named or not, the value goes to /rosdashboard/<tag>."""
    rules = parse_rules("rules: [{tag: a/b, pattern: 'v=(?P<v>\\d+)'}]")
    assert [o.topic for o in rules.outputs] == ["/rosdashboard/a/b"]


def test_node_filter_supports_exact_names_and_globs() -> None:
    """`node` is an exact logger name or an fnmatch glob; level is a minimum."""
    exact, glob = parse_rules(
        "rules: [{tag: a, pattern: '(x)', node: planner},"
        " {tag: b, pattern: '(x)', node: 'plan*r', level: info}]"
    ).rules
    assert exact.accepts("/rosout", "planner", 10)
    assert not exact.accepts("/rosout", "planner2", 10)
    assert glob.accepts("/rosout", "planner", 20)
    assert glob.accepts("/rosout", "plan_b_for_r", 50)
    assert not glob.accepts("/rosout", "planner", 10)
    assert not glob.accepts("/chatter", "planner", 20)


@pytest.mark.parametrize(
    ("pattern", "reason"),
    [
        ("(", "missing )"),
        ("[", "missing ]"),
        ("(?P<x>", "missing )"),
        (r"(a)\1", "backreferences are not supported"),
        ("a(?=b)", "lookarounds are not supported"),
    ],
)
def test_invalid_patterns_are_load_errors_with_tag_line_and_reason(pattern: str, reason: str) -> None:
    """A pattern RE2 rejects names the rule's tag, its index and line, and RE2's reason."""
    text = f"rules:\n  - tag: ok\n    pattern: '(\\d+)'\n  - tag: broken\n    pattern: '{pattern}'\n"
    (problem,) = _problems(text)
    assert (problem.tag, problem.rule_index, problem.line) == ("broken", 1, 5)
    assert reason in problem.reason
    shown = str(problem)
    assert shown.startswith("r.yaml:5: rule #2, tag 'broken': ")
    assert reason in shown


@pytest.mark.parametrize("pattern", ["(a+)+$", "(a|aa)+$", r"(\w+\s?)+$", "(.*a){20}"])
def test_slow_for_backtracking_patterns_load(pattern: str) -> None:
    """Patterns that are catastrophic for backtracking engines are fine for RE2."""
    assert parse_rules(f"rules: [{{tag: slow, pattern: '{pattern}'}}]").rules[0].pattern == pattern


def test_every_problem_is_reported_at_once() -> None:
    """Unknown keys, wrong types, missing keys, bad values: all listed, each with its own line."""
    problems = _problems(
        """\
        rules:
          - tag: speed
            patern: 'speed (\\S+)'
            level: loud
          - tag: 42
            pattern: '(\\d+)'
          - pattern: 'x=(\\d+)'
            type: decimal
            node: ''
          - tag: two
            pattern: '(\\d+) and (\\d+)'
          - tag: none
            pattern: 'no groups'
          - tag: 'any text is a tag!'
            namespace: 1bad
            pattern: '(\\d+)'
          - just a string
        """
    )
    got = {(p.rule_index, p.line, p.tag) for p in problems}
    reasons = "\n".join(str(p) for p in problems)
    assert (0, 3, "speed") in got
    assert "unknown key 'patern'" in reasons
    assert "missing required key 'pattern'" in reasons
    assert (0, 4, "speed") in got
    assert "unknown level 'loud'" in reasons
    assert (1, 5, None) in got
    assert "'tag' must be a string, not a integer (42)" in reasons
    assert "missing required key 'tag'" in reasons
    assert "unknown type 'decimal'" in reasons
    assert (2, 9, None) in got
    assert "'node' is empty" in reasons
    assert (3, 11, "two") in got
    assert "group(s) 1, 2 are unnamed" in reasons
    assert (4, 13, "none") in got
    assert "no capture group" in reasons
    assert (5, 15, "any text is a tag!") in got
    assert "invalid namespace: robot namespace '1bad'" in reasons
    assert (6, 17, None) in got
    assert "a rule must be a mapping, not a string" in reasons
    assert len(problems) == 11


def test_duplicate_outputs_name_both_rules() -> None:
    """Two rules publishing to one topic is an error naming the first rule and its line."""
    (problem,) = _problems(
        """\
        rules:
          - tag: pose/x
            pattern: 'x=(\\S+)'
          - tag: pose
            pattern: 'x=(?P<x>\\S+) y=(?P<y>\\S+)'
        """
    )
    assert (problem.rule_index, problem.tag, problem.line) == (1, "pose", 4)
    assert "/rosdashboard/pose/x" in problem.reason
    assert "rule #1 (tag 'pose/x', line 2)" in problem.reason


def test_duplicate_keys_are_errors_not_silently_overwritten() -> None:
    """YAML would keep the last of two equal keys; the loader reports it instead."""
    (problem,) = _problems("rules:\n  - tag: a\n    pattern: '(x)'\n    tag: b\n")
    assert "duplicate key 'tag'" in problem.reason
    assert problem.line == 4


def test_filters_that_need_rosout_are_rejected_on_string_topics() -> None:
    """`node` and `level` need a Log message; on a String topic they are errors."""
    problems = _problems("rules: [{tag: a, pattern: '(x)', source_topic: /chatter, node: n, level: info}]")
    assert {p.reason.split(" ", 1)[0] for p in problems} == {"'node'", "'level'"}


@pytest.mark.parametrize(
    ("text", "reason"),
    [
        ("", "found an empty file"),
        ("- a\n- b\n", "found a list"),
        ("rulez: []\n", "unknown top-level key 'rulez'"),
        ("rules: {}\n", "'rules' must be a list"),
        ("rules: []\n", "'rules' is empty"),
        ("rules: [\n", "not valid YAML"),
        ("rules: !!python/object:os.system [x]\n", "not valid YAML"),
        ("rules: [{tag: a, pattern: '(x)', source_topic: '/9bad'}]", "invalid source_topic"),
    ],
)
def test_file_level_problems_are_clear(text: str, reason: str) -> None:
    """Empty, non-mapping, unsafe or malformed documents give one clear problem."""
    problems = _problems(text)
    assert any(reason in str(p) for p in problems), problems


def test_load_rules_reads_a_file_and_reports_missing_files(tmp_path: Path) -> None:
    """load_rules names the file in every problem; a missing file is a RulesError too."""
    path = tmp_path / "r.yaml"
    path.write_text("rules:\n  - tag: a\n    pattern: '('\n", encoding="utf-8")
    with pytest.raises(RulesError, match=r"r\.yaml:3: rule #1, tag 'a': pattern '\(' does not compile"):
        load_rules(path)
    with pytest.raises(RulesError, match="cannot read the file"):
        load_rules(tmp_path / "missing.yaml")


def test_demo_rules_file_is_valid() -> None:
    """The demo robot's rules file loads and publishes the documented topics."""
    topics = [(o.topic, o.kind) for o in load_rules(DEMO_RULES).outputs]
    assert topics == [
        ("/rosdashboard/turtle/speed", "float"),
        ("/rosdashboard/turtle/heading_deg", "float"),
        ("/rosdashboard/turtle/wall_hits", "int"),
        ("/rosdashboard/sound/log/azimuth", "float"),
        ("/rosdashboard/sound/log/elevation", "float"),
        ("/rosdashboard/sound/log/confidence", "float"),
    ]


_SCALARS = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(),
    st.floats(allow_nan=False),
    st.text(max_size=20),
    st.sampled_from(
        ["(\\d+)", "(", "x=(?P<x>\\S+) y=(?P<y>\\S+)", "info", "warn", "int", "bool", "planner*"]
    ),
)
_KEYS = st.sampled_from(["tag", "pattern", "node", "level", "type", "source_topic", "extra", "rules"])
_VALUES = st.recursive(
    _SCALARS,
    lambda inner: (
        st.lists(inner, max_size=4) | st.dictionaries(_KEYS | st.text(max_size=5), inner, max_size=6)
    ),
    max_leaves=20,
)


@settings(max_examples=300, deadline=None)
@given(doc=st.one_of(_VALUES, st.fixed_dictionaries({"rules": st.lists(_VALUES, max_size=5)})))
def test_random_structures_only_ever_raise_rules_error(doc: object) -> None:
    """Any YAML structure either loads or raises RulesError with at least one problem; never crashes."""
    text = yaml.safe_dump(doc, allow_unicode=True)
    outcome = _outcome(text)
    if isinstance(outcome, RulesError):
        assert outcome.problems
        assert all(isinstance(p, Problem) and p.reason for p in outcome.problems)
    else:
        assert outcome.rules


def _outcome(text: str) -> RuleSet | RulesError:
    try:
        return parse_rules(text)
    except RulesError as exc:
        return exc


@settings(max_examples=300, deadline=None)
@given(text=st.text(max_size=200))
def test_random_text_only_ever_raises_rules_error(text: str) -> None:
    """Arbitrary text, however broken as YAML, gives RulesError and nothing else."""
    outcome = _outcome(text)
    assert isinstance(outcome, RuleSet) or re.match(r"\d+ problems? in rules:\n", str(outcome))


def test_named_groups_can_each_have_their_own_type() -> None:
    """`type: {group: kind}` types each named group; groups it leaves out are floats."""
    rules = parse_rules(
        textwrap.dedent(
            r"""
            rules:
              - tag: power
                pattern: 'battery=(?P<percent>\d+)% (?P<volts>\S+) V (?P<charging>\w+) (?P<amps>\S+) A'
                type: {percent: int, volts: float, charging: bool}
              - tag: level
                pattern: 'level (?P<value>\d+)'
                type: {value: int}
              - tag: plain
                pattern: 'plain (\d+)'
                type: int
            """
        )
    )
    power, level, plain = rules.rules
    assert [(o.tag, o.kind) for o in power.outputs] == [
        ("power/percent", "int"),
        ("power/volts", "float"),
        ("power/charging", "bool"),
        ("power/amps", "float"),
    ]
    assert [(o.tag, o.kind) for o in level.outputs] == [("level", "int")]
    assert [(o.tag, o.kind) for o in plain.outputs] == [("plain", "int")]


@pytest.mark.parametrize(
    ("type_yaml", "reason"),
    [
        ("{percent: int, amps: int}", "'type' gives a type to group 'amps', which the pattern lacks"),
        ("{percent: decimal}", "unknown type 'decimal' for group 'percent'"),
        ("{percent: [int]}", "unknown type a list for group 'percent'"),
        ("{}", "'type' is an empty mapping"),
        ("[int]", "'type' must be float, int or bool, or a mapping of group names to those"),
        ("{3: int}", "'type' maps group names to types, but 3 (integer) is no group name"),
        ("{percent: int, percent: float}", "'type' names group 'percent' twice"),
    ],
)
def test_bad_per_group_types_are_clear_errors(type_yaml: str, reason: str) -> None:
    """Every mistake in a per-group `type` mapping is an error naming the group and the reason."""
    problems = _problems(
        f"rules:\n  - tag: power\n    pattern: 'b=(?P<percent>\\d+) (?P<volts>\\S+)'\n    type: {type_yaml}\n"
    )
    assert any(reason in p.reason for p in problems), problems
    assert all(p.line == 4 for p in problems), problems


def test_a_rule_with_several_problems_reports_its_duplicate_topic_too() -> None:
    """A rule with other errors still has its duplicate topic reported: every problem, never the first."""
    problems = _problems(
        """\
        rules:
          - tag: speed
            pattern: 'speed (\\S+)'
          - tag: speed
            level: loud
            node: ''
            pattern: 'v=(?P<v>\\S+)'
            type: {v: int, w: int}
        """
    )
    reasons = [p.reason for p in problems]
    assert len(problems) == 4, reasons
    assert any("publishes to /rosdashboard/speed, which rule #1" in r for r in reasons)
    assert any("unknown level 'loud'" in r for r in reasons)
    assert any("'node' is empty" in r for r in reasons)
    assert any("group 'w'" in r for r in reasons)


def test_every_echoed_value_is_cut_in_messages() -> None:
    """A 100 KB pattern, tag, key or level is quoted by its first 80 characters and its length."""
    huge = "x" * 100_000
    problems = _problems(
        f"rules:\n  - tag: '{huge}!'\n    pattern: '({huge}'\n    level: {huge}\n    ? {huge}\n    : 1\n"
    )
    message = str(RulesError(problems))
    assert len(problems) == 4
    assert len(message) < 2_000, message[:3000]
    assert "… (100001 chars)" in message
    assert "… (100000 chars)" in message


_GROUP_NAMES = st.lists(
    st.from_regex(r"[a-y][a-z0-9_]{0,6}", fullmatch=True), min_size=1, max_size=5, unique=True
)


@settings(max_examples=200, deadline=None)
@given(
    names=_GROUP_NAMES,
    data=st.data(),
)
def test_per_group_types_give_each_output_its_kind(names: list[str], data: st.DataObject) -> None:
    """Any mapping of some named groups to kinds gives those outputs those kinds and the others float."""
    kinds = data.draw(st.dictionaries(st.sampled_from(names), st.sampled_from(["float", "int", "bool"])))
    extra = data.draw(st.lists(st.from_regex(r"z[a-z]{1,4}", fullmatch=True), max_size=2, unique=True))
    pattern = " ".join(f"{n}=(?P<{n}>\\S+)" for n in names)
    mapping = {**kinds, **dict.fromkeys(extra, "int")}
    rule = {"tag": "t", "pattern": pattern, **({"type": mapping} if mapping else {})}
    outcome = _outcome(yaml.safe_dump({"rules": [rule]}))
    if extra:  # groups the pattern lacks: one problem each, naming the group
        assert isinstance(outcome, RulesError)
        assert sorted(p.reason.split("'")[3] for p in outcome.problems) == sorted(extra)
        return
    assert isinstance(outcome, RuleSet), outcome
    expected = [kinds.get(n, "float") for n in names]
    assert [o.kind for o in outcome.rules[0].outputs] == expected


def test_any_tag_text_is_escaped_as_the_sdk_escapes_it() -> None:
    """A rule's tag may be any text: its topic is the SDK's for that text (速度, a-b), never refused."""
    rules = parse_rules(
        "rules: [{tag: 速度, pattern: 'v=(\\S+)'}, {tag: a-b, pattern: 'w=(?P<x>\\S+) (?P<y>\\S+)'}]"
    )
    assert [o.topic for o in rules.outputs] == [
        "/rosdashboard/__901f___5ea6_",
        "/rosdashboard/a__2d_b/x",
        "/rosdashboard/a__2d_b/y",
    ]


def test_namespaces_of_the_bridge_and_of_a_rule() -> None:
    """The bridge's namespace applies to rules without one; a rule's own wins; 'node' follows each line."""
    text = textwrap.dedent(
        """\
        rules:
          - {tag: a, pattern: 'a=(\\S+)'}
          - {tag: b, pattern: 'b=(\\S+)', namespace: robot7}
          - {tag: c, pattern: 'c=(\\S+)', namespace: node}
          - {tag: d, pattern: 'd=(\\S+)', namespace: /}
        """
    )
    outputs = parse_rules(text, namespace="/lab").outputs
    assert [(o.topic, o.follow_node) for o in outputs] == [
        ("/lab/rosdashboard/a", False),
        ("/robot7/rosdashboard/b", False),
        ("/rosdashboard/c", True),
        ("/rosdashboard/d", False),
    ]


@pytest.mark.parametrize(
    ("rule", "reason"),
    [
        ("{tag: a, pattern: '(x)', namespace: 1bad}", "invalid namespace: robot namespace '1bad'"),
        ("{tag: a, pattern: '(x)', namespace: /rosdashboard}", "'rosdashboard' is dbglog's own"),
        ("{tag: a, pattern: '(x)', namespace: node, source_topic: /chat}", "'namespace: node' only applies"),
        ("{tag: '" + "x" * 240 + "', pattern: '(x)'}", "at most 247"),
    ],
)
def test_bad_namespaces_and_too_long_tags_are_load_errors(rule: str, reason: str) -> None:
    """A namespace rcl or dbglog refuses, 'node' without a logger, or a topic too long: named errors."""
    with pytest.raises(RulesError) as info:
        parse_rules(f"rules: [{rule}]")
    assert reason in str(info.value)
