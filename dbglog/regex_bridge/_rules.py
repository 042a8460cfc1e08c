"""Bridge rules files: YAML (safe loader) validated into typed rules, every problem reported with its place.

Pure (no rclpy): ``dbglog bridge --check`` and the viewer can load rules without a ROS installation.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, get_args

import yaml

from dbglog.api._tags import tag_problem, topic_for_tag
from dbglog.regex_bridge._regex import NumberKind, RegexError, compile_regex

__all__ = [
    "LEVELS",
    "ROSOUT",
    "Output",
    "Problem",
    "Rule",
    "RuleSet",
    "RulesError",
    "load_rules",
    "parse_rules",
]

ROSOUT: Final = "/rosout"
"""The default source: ``rcl_interfaces/msg/Log`` messages, matched on their ``msg`` field."""

LEVELS: Final[Mapping[str, int]] = {"debug": 10, "info": 20, "warn": 30, "error": 40, "fatal": 50}
"""Minimum-severity names and their ``rcl_interfaces/msg/Log`` level values."""

_KINDS: Final = frozenset(get_args(NumberKind))
_RULE_KEYS: Final = ("tag", "pattern", "node", "level", "type", "source_topic")
_REQUIRED: Final = ("tag", "pattern")
_TOPIC = re.compile(r"(?:/[A-Za-z_][A-Za-z0-9_]*)+")
_GLOB_CHARS: Final = frozenset("*?[")


@dataclass(frozen=True, slots=True)
class Output:
    """One value a rule publishes: a capture group, its tag and topic, and the number kind."""

    tag: str
    topic: str
    group: int
    """1-based index of the capture group."""
    kind: NumberKind


@dataclass(frozen=True, slots=True)
class Rule:
    """A validated rule: which lines it reads and which typed values it publishes."""

    index: int
    """0-based position in the file's ``rules:`` list."""
    line: int
    """1-based line of the rule in the file (0 when the rule was not read from YAML)."""
    tag: str
    pattern: str
    node: str | None
    """Logger name that must match: exact, or an fnmatch glob such as ``planner*``; None for any."""
    min_level: int
    """Minimum ``rcl_interfaces/msg/Log`` level (0 for any)."""
    kind: NumberKind
    source_topic: str
    outputs: tuple[Output, ...]

    def accepts(self, source: str, logger: str, level: int) -> bool:
        """Return whether a line from `source`, logged by `logger` at `level`, is for this rule."""
        if source != self.source_topic or level < self.min_level:
            return False
        if self.node is None:
            return True
        if _GLOB_CHARS.isdisjoint(self.node):
            return logger == self.node
        return fnmatch.fnmatchcase(logger, self.node)


@dataclass(frozen=True, slots=True)
class RuleSet:
    """Every rule of a rules file, in file order."""

    rules: tuple[Rule, ...]
    source: str
    """Where the rules came from (a path, or ``<string>``)."""

    @property
    def outputs(self) -> tuple[Output, ...]:
        """Every output of every rule, in file order."""
        return tuple(o for r in self.rules for o in r.outputs)

    @property
    def source_topics(self) -> tuple[str, ...]:
        """The distinct source topics, in first-use order."""
        return tuple(dict.fromkeys(r.source_topic for r in self.rules))


@dataclass(frozen=True, slots=True)
class Problem:
    """One thing wrong with a rules file, with where it is."""

    source: str
    line: int
    """1-based line in the file (0 when unknown)."""
    rule_index: int | None
    tag: str | None
    reason: str

    def __str__(self) -> str:
        where = f"{self.source}:{self.line}" if self.line else self.source
        if self.rule_index is None:
            return f"{where}: {self.reason}"
        tag = f", tag {self.tag!r}" if self.tag else ""
        return f"{where}: rule #{self.rule_index + 1}{tag}: {self.reason}"


class RulesError(ValueError):
    """A rules file that cannot be used; `problems` lists everything found, the message shows them all."""

    def __init__(self, problems: list[Problem]) -> None:
        self.problems = tuple(problems)
        count = len(self.problems)
        head = f"{count} problem{'s' if count != 1 else ''} in rules"
        super().__init__(head + ":\n" + "\n".join(f"  {p}" for p in self.problems))


class _Marked:
    """A YAML value with the line it starts on (1-based)."""

    __slots__ = ("line", "value")

    def __init__(self, value: Any, line: int) -> None:
        self.value = value
        self.line = line


class _MarkedLoader(yaml.SafeLoader):
    """The safe loader, but mappings and lists keep their items' lines and duplicate keys are recorded."""


class _Seq(list[Any]):
    """A YAML list with the 1-based line of each item."""

    lines: list[int]


def _construct_sequence(loader: _MarkedLoader, node: yaml.SequenceNode) -> _Seq:
    result = _Seq(loader.construct_object(child, deep=True) for child in node.value)
    result.lines = [child.start_mark.line + 1 for child in node.value]
    return result


def _construct_mapping(loader: _MarkedLoader, node: yaml.MappingNode) -> dict[Any, Any]:
    loader.flatten_mapping(node)
    result: dict[Any, Any] = {}
    lines: dict[Any, int] = {}
    duplicates: list[tuple[Any, int]] = []
    for key_node, value_node in node.value:
        key = loader.construct_object(key_node, deep=True)
        try:
            hash(key)
        except TypeError:
            key = repr(key)
        line = key_node.start_mark.line + 1
        if key in result:
            duplicates.append((key, line))
        result[key] = loader.construct_object(value_node, deep=True)
        lines[key] = line
    result[_LINES] = lines
    result[_START] = node.start_mark.line + 1
    if duplicates:
        result[_DUPLICATES] = duplicates
    return result


# Private keys no YAML document can produce (YAML keys are never these objects).
_LINES: Final = object()
_START: Final = object()
_DUPLICATES: Final = object()

_MarkedLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_MAPPING_TAG, _construct_mapping)
_MarkedLoader.add_constructor(yaml.resolver.BaseResolver.DEFAULT_SEQUENCE_TAG, _construct_sequence)


def _public_keys(mapping: dict[Any, Any]) -> Iterator[Any]:
    return (k for k in mapping if k is not _LINES and k is not _START and k is not _DUPLICATES)


def load_rules(path: str | Path) -> RuleSet:
    """Read and validate a rules file.

    Args:
        path: a YAML file with a top-level ``rules:`` list.

    Raises:
        RulesError: the file is missing, not YAML, or any rule is invalid; lists every problem.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RulesError([Problem(name, 0, None, None, f"cannot read the file: {exc}")]) from None
    return parse_rules(text, source=name)


def parse_rules(text: str, *, source: str = "<string>") -> RuleSet:
    """Validate rules given as YAML text.

    Args:
        text: the YAML document.
        source: the name used in problem messages (usually the file path).

    Raises:
        RulesError: the text is not YAML or any rule is invalid; lists every problem.
    """
    try:
        doc = yaml.load(text, Loader=_MarkedLoader)  # noqa: S506 - _MarkedLoader is a SafeLoader subclass
    except yaml.YAMLError as exc:
        mark = getattr(exc, "problem_mark", None)
        line = mark.line + 1 if mark is not None else 0
        reason = str(getattr(exc, "problem", None) or exc).strip()
        raise RulesError([Problem(source, line, None, None, f"not valid YAML: {reason}")]) from None
    except (ValueError, TypeError, RecursionError) as exc:
        raise RulesError([Problem(source, 0, None, None, f"not valid YAML: {exc}")]) from None
    return _validate(doc, source)


def _validate(doc: Any, source: str) -> RuleSet:
    problems: list[Problem] = []

    def top(reason: str, line: int = 0) -> RulesError:
        return RulesError([*problems, Problem(source, line, None, None, reason)])

    if not isinstance(doc, dict):
        found = "an empty file" if doc is None else f"a {_yaml_type(doc)}"
        raise top(f"expected a mapping with a top-level 'rules:' list, found {found}")
    for key, line in doc.get(_DUPLICATES, []):
        problems.append(Problem(source, line, None, None, f"duplicate top-level key {key!r}"))
    for key in _public_keys(doc):
        if key != "rules":
            problems.append(
                Problem(source, doc[_LINES][key], None, None, f"unknown top-level key {key!r} (only 'rules')")
            )
    if "rules" not in doc:
        raise top("missing the top-level 'rules:' list", doc[_START])
    entries = doc["rules"]
    if not isinstance(entries, list):
        raise top(f"'rules' must be a list of rules, not a {_yaml_type(entries)}", doc[_LINES]["rules"])
    if not entries:
        raise top("'rules' is empty: a bridge needs at least one rule", doc[_LINES]["rules"])

    rules: list[Rule] = []
    item_lines = getattr(entries, "lines", None) or [doc[_LINES]["rules"]] * len(entries)
    for index, entry in enumerate(entries):
        rule = _validate_rule(index, entry, item_lines[index], source, problems)
        if rule is not None:
            rules.append(rule)

    seen: dict[str, Rule] = {}
    for rule in rules:
        for out in rule.outputs:
            first = seen.setdefault(out.topic, rule)
            if first is not rule:
                problems.append(
                    Problem(
                        source,
                        rule.line,
                        rule.index,
                        rule.tag,
                        f"publishes to {out.topic}, which rule #{first.index + 1} (tag {first.tag!r}, "
                        f"line {first.line}) already publishes to",
                    )
                )
    if problems:
        raise RulesError(sorted(problems, key=lambda p: p.line))
    return RuleSet(tuple(rules), source)


def _validate_rule(
    index: int, entry: Any, item_line: int, source: str, problems: list[Problem]
) -> Rule | None:
    if not isinstance(entry, dict):
        problems.append(
            Problem(source, item_line, index, None, f"a rule must be a mapping, not a {_yaml_type(entry)}")
        )
        return None
    start = int(entry[_START])
    lines: dict[Any, int] = entry[_LINES]
    raw_tag = entry.get("tag")
    tag_name = raw_tag if isinstance(raw_tag, str) else None
    found: list[Problem] = []

    def problem(reason: str, key: str | None = None) -> None:
        found.append(Problem(source, lines.get(key, start) if key else start, index, tag_name, reason))

    for key, _line in entry.get(_DUPLICATES, []):
        problem(f"duplicate key {key!r}", key)
    for key in _public_keys(entry):
        if key not in _RULE_KEYS:
            problem(f"unknown key {key!r} (known keys: {', '.join(_RULE_KEYS)})", key)
    for key in _REQUIRED:
        if key not in entry:
            problem(f"missing required key {key!r}")

    def text(key: str) -> str | None:
        value = entry.get(key)
        if value is None:
            if key in entry:
                problem(f"{key!r} is empty", key)
            return None
        if not isinstance(value, str):
            shown = f" ({value!r})" if isinstance(value, int | float) else ""
            problem(f"{key!r} must be a string, not a {_yaml_type(value)}{shown}", key)
            return None
        return value

    tag = text("tag")
    if tag is not None and (why := tag_problem(tag)) is not None:
        problem(f"invalid tag {tag!r}: {why}", "tag")
        tag = None

    source_topic = ROSOUT
    raw_topic = text("source_topic")
    if raw_topic is not None:
        candidate = raw_topic if raw_topic.startswith("/") else "/" + raw_topic
        if _TOPIC.fullmatch(candidate) is None:
            problem(
                f"invalid source_topic {raw_topic!r}: use a ROS topic name such as /chatter "
                "(letters, digits, _ and /; no part may start with a digit)",
                "source_topic",
            )
        else:
            source_topic = candidate
    from_rosout = source_topic == ROSOUT

    node = text("node")
    if node is not None and not node:
        problem("'node' is empty: leave it out to accept every node", "node")
        node = None
    if node is not None and not from_rosout:
        problem(f"'node' only applies to {ROSOUT} (a std_msgs/msg/String topic has no logger name)", "node")

    min_level = 0
    level = text("level")
    if level is not None:
        if level.lower() not in LEVELS:
            problem(f"unknown level {level!r} (one of: {', '.join(LEVELS)})", "level")
        elif not from_rosout:
            problem(f"'level' only applies to {ROSOUT} (a std_msgs/msg/String topic has no level)", "level")
        else:
            min_level = LEVELS[level.lower()]

    kind: NumberKind = "float"
    raw_kind = text("type")
    if raw_kind is not None:
        if raw_kind not in _KINDS:
            problem(f"unknown type {raw_kind!r} (one of: float, int, bool)", "type")
        else:
            kind = raw_kind  # type: ignore[assignment]  # checked against the Literal's values above

    pattern = text("pattern")
    outputs: tuple[Output, ...] = ()
    if pattern is not None:
        try:
            compiled = compile_regex(pattern)
        except RegexError as exc:
            problem(f"pattern '{pattern}' does not compile with RE2: {exc}", "pattern")
        else:
            outputs = _outputs(tag, kind, compiled.group_names, lambda why: problem(why, "pattern"))

    problems.extend(found)
    if found or tag is None or pattern is None:
        return None
    return Rule(index, start, tag, pattern, node, min_level, kind, source_topic, outputs)


def _outputs(
    tag: str | None, kind: NumberKind, names: tuple[str | None, ...], problem: Any
) -> tuple[Output, ...]:
    if not names:
        problem("the pattern has no capture group: put the number in parentheses, e.g. 'speed (\\S+)'")
        return ()
    unnamed = [str(i + 1) for i, n in enumerate(names) if n is None]
    if len(names) > 1 and unnamed:
        problem(
            f"the pattern has {len(names)} capture groups, so each must be named (?P<name>...); "
            f"group(s) {', '.join(unnamed)} are unnamed (use (?:...) for grouping only)"
        )
        return ()
    if tag is None:
        return ()
    if len(names) == 1:
        return (Output(tag, topic_for_tag(tag), 1, kind),)
    outputs = []
    for i, name in enumerate(names):
        assert name is not None
        sub = f"{tag}/{name}"
        why = tag_problem(sub)
        if why is not None:
            problem(f"group {name!r} gives the invalid tag {sub!r}: {why}")
            continue
        outputs.append(Output(sub, topic_for_tag(sub), i + 1, kind))
    return tuple(outputs)


def _yaml_type(value: Any) -> str:
    if isinstance(value, dict):
        return "mapping"
    if isinstance(value, list):
        return "list"
    if isinstance(value, bool):
        return "boolean"
    if value is None:
        return "null"
    return {"str": "string", "int": "integer", "float": "number"}.get(
        type(value).__name__, type(value).__name__
    )
