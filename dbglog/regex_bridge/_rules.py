"""Bridge rules files: YAML (safe loader) validated into typed rules, every problem reported with its place.

Pure (no rclpy): ``dbglog bridge --check`` and the viewer can load rules without a ROS installation.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final, get_args

import yaml

from dbglog._regex._compile import SHOWN_CHARS, NumberKind, RegexError, compile_regex, shorten
from dbglog._ros._loglevels import LEVELS, node_matches
from dbglog._ros._tags import TagError, escape_tag, normalize_robot, tag_topic, topic_for_tag

__all__ = [
    "FOLLOW_NODE",
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


_KINDS: Final = frozenset(get_args(NumberKind))
_RULE_KEYS: Final = ("tag", "pattern", "node", "level", "type", "source_topic", "namespace")
FOLLOW_NODE: Final = "node"
"""``namespace: node``: a rule's values go to the namespace of the node that logged the line."""
_REQUIRED: Final = ("tag", "pattern")
_TOPIC = re.compile(r"(?:/[A-Za-z_][A-Za-z0-9_]*)+")


@dataclass(frozen=True, slots=True)
class Output:
    """One value a rule publishes: a capture group, its tag and topic, and the number kind."""

    tag: str
    """The tag's topic name (`escape_tag` of the rule's tag text)."""
    topic: str
    """The full topic; with `follow_node`, the root's (the line's node namespace goes before it)."""
    group: int
    """1-based index of the capture group."""
    kind: NumberKind
    follow_node: bool = False
    """``namespace: node``: published in the namespace of the node that logged the line."""


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
    """The kind of every output whose group the rule's ``type`` does not name (``float`` by default)."""
    source_topic: str
    outputs: tuple[Output, ...]
    """Each output's own kind may differ from `kind` (``type: {group: kind}``)."""

    def accepts(self, source: str, logger: str, level: int) -> bool:
        """Return whether a line from `source`, logged by `logger` at `level`, is for this rule."""
        if source != self.source_topic or level < self.min_level:
            return False
        return self.node is None or node_matches(logger, self.node)


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
        tag = f", tag {_r(self.tag)}" if self.tag else ""
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


def load_rules(path: str | Path, *, namespace: str = "") -> RuleSet:
    """Read and validate a rules file.

    Args:
        path: a YAML file with a top-level ``rules:`` list.
        namespace: the robot namespace of the topics of rules without a ``namespace`` of their own
            (``""``: the root; normalized, see `normalize_robot`).

    Raises:
        RulesError: the file is missing, not YAML, or any rule is invalid; lists every problem.
    """
    name = str(path)
    try:
        text = Path(path).read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RulesError([Problem(name, 0, None, None, f"cannot read the file: {exc}")]) from None
    return parse_rules(text, source=name, namespace=namespace)


def parse_rules(text: str, *, source: str = "<string>", namespace: str = "") -> RuleSet:
    """Validate rules given as YAML text.

    Args:
        text: the YAML document.
        source: the name used in problem messages (usually the file path).
        namespace: the robot namespace of rules without a ``namespace`` of their own (see `load_rules`).

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
    return _validate(doc, source, namespace)


def _validate(doc: Any, source: str, namespace: str) -> RuleSet:
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
    checked: list[_Checked] = []
    item_lines = getattr(entries, "lines", None) or [doc[_LINES]["rules"]] * len(entries)
    for index, entry in enumerate(entries):
        one = _validate_rule(index, entry, item_lines[index], source, problems, namespace)
        checked.append(one)
        if one.rule is not None:
            rules.append(one.rule)

    # Every rule whose tag and pattern are good takes part, even with other problems: one problem of a
    # rule never hides another.
    seen: dict[str, _Checked] = {}
    for one in checked:
        for out in one.outputs:
            first = seen.setdefault(out.topic, one)
            if first is not one:
                problems.append(
                    Problem(
                        source,
                        one.line,
                        one.index,
                        one.tag,
                        f"publishes to {out.topic}, which rule #{first.index + 1} (tag {_r(first.tag)}, "
                        f"line {first.line}) already publishes to",
                    )
                )
    if problems:
        raise RulesError(sorted(problems, key=lambda p: p.line))
    return RuleSet(tuple(rules), source)


@dataclass(frozen=True, slots=True)
class _Checked:
    """One entry of ``rules:`` once checked: the rule when valid, and the outputs it would have anyway."""

    index: int
    line: int
    tag: str | None
    rule: Rule | None
    outputs: tuple[Output, ...]
    """The topics the rule publishes to when its tag and pattern are good (for the duplicate check)."""


def _validate_rule(
    index: int, entry: Any, item_line: int, source: str, problems: list[Problem], namespace: str
) -> _Checked:
    if not isinstance(entry, dict):
        problems.append(
            Problem(source, item_line, index, None, f"a rule must be a mapping, not a {_yaml_type(entry)}")
        )
        return _Checked(index, item_line, None, None, ())
    start = int(entry[_START])
    lines: dict[Any, int] = entry[_LINES]
    raw_tag = entry.get("tag")
    tag_name = raw_tag if isinstance(raw_tag, str) else None
    found: list[Problem] = []

    def problem(reason: str, key: str | None = None, line: int | None = None) -> None:
        where = line if line is not None else lines.get(key, start) if key else start
        found.append(Problem(source, where, index, tag_name, reason))

    for key, _line in entry.get(_DUPLICATES, []):
        problem(f"duplicate key {_r(key)}", key)
    for key in _public_keys(entry):
        if key not in _RULE_KEYS:
            problem(f"unknown key {_r(key)} (known keys: {', '.join(_RULE_KEYS)})", key)
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
            shown = f" ({_r(value)})" if isinstance(value, int | float) else ""
            problem(f"{key!r} must be a string, not a {_yaml_type(value)}{shown}", key)
            return None
        return value

    tag = text("tag")
    robot: str | None = namespace
    raw_namespace = text("namespace")
    if raw_namespace is not None:
        if raw_namespace == FOLLOW_NODE:
            robot = None
        else:
            try:
                robot = normalize_robot(raw_namespace)
            except TagError as exc:
                problem(
                    f"invalid namespace: {exc} (or 'node': the namespace of the line's node)", "namespace"
                )
    if tag is not None:
        try:  # any text: escaped as the SDK escapes it
            tag_topic(tag, robot or "")
        except TagError as exc:
            problem(f"invalid tag {_r(tag)}: {exc}", "tag")
            tag = None

    source_topic = ROSOUT
    raw_topic = text("source_topic")
    if raw_topic is not None:
        candidate = raw_topic if raw_topic.startswith("/") else "/" + raw_topic
        if _TOPIC.fullmatch(candidate) is None:
            problem(
                f"invalid source_topic {_r(raw_topic)}: use a ROS topic name such as /chatter "
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
    if robot is None and not from_rosout:
        problem(
            f"'namespace: node' only applies to {ROSOUT} (a std_msgs/msg/String topic has no logger name)",
            "namespace",
        )

    min_level = 0
    level = text("level")
    if level is not None:
        if level.lower() not in LEVELS:
            problem(f"unknown level {_r(level)} (one of: {', '.join(LEVELS)})", "level")
        elif not from_rosout:
            problem(f"'level' only applies to {ROSOUT} (a std_msgs/msg/String topic has no level)", "level")
        else:
            min_level = LEVELS[level.lower()]

    kind, group_kinds = _kinds(entry, problem)

    pattern = text("pattern")
    outputs: tuple[Output, ...] = ()
    if pattern is not None:
        try:
            compiled = compile_regex(pattern)
        except RegexError as exc:
            problem(f"pattern {_quoted(pattern)} does not compile with RE2: {exc}", "pattern")
        else:

            def group_problem(why: str, line: int | None = None) -> None:
                problem(why, "pattern", line)

            outputs = _outputs(tag, robot, kind, group_kinds, compiled.group_names, group_problem)

    problems.extend(found)
    if found or tag is None or pattern is None:
        return _Checked(index, start, tag_name, None, outputs)
    rule = Rule(index, start, tag, pattern, node, min_level, kind, source_topic, outputs)
    return _Checked(index, start, tag_name, rule, outputs)


_KINDS_HELP: Final = "float, int or bool"


def _kinds(entry: dict[Any, Any], problem: Any) -> tuple[NumberKind, dict[str, tuple[NumberKind, int]]]:
    """Read ``type``: one kind for the whole rule, or a mapping of group names to kinds (each with its
    line); returns the rule's kind (``float`` when not given) and the per-group kinds."""
    kind: NumberKind = "float"
    per_group: dict[str, tuple[NumberKind, int]] = {}
    if "type" not in entry:
        return kind, per_group
    raw = entry["type"]
    if isinstance(raw, str):
        if raw in _KINDS:
            kind = raw  # type: ignore[assignment]  # checked against the Literal's values
        else:
            problem(f"unknown type {_r(raw)} (one of: float, int, bool)", "type")
        return kind, per_group
    if not isinstance(raw, dict):
        problem(
            f"'type' must be {_KINDS_HELP}, or a mapping of group names to those "
            f"(e.g. {{percent: int, volts: float}}), not a {_yaml_type(raw)}",
            "type",
        )
        return kind, per_group
    where: dict[Any, int] = raw[_LINES]
    for group, _line in raw.get(_DUPLICATES, []):
        problem(f"'type' names group {_r(group)} twice", "type", where.get(group))
    groups = list(_public_keys(raw))
    if not groups:
        problem("'type' is an empty mapping: give each named group its type (e.g. {percent: int})", "type")
    for group in groups:
        value, line = raw[group], where.get(group, 0)
        if not isinstance(group, str):
            why = f"'type' maps group names to types, but {_r(group)} ({_yaml_type(group)}) is no group name"
            problem(why, "type", line)
        elif not isinstance(value, str) or value not in _KINDS:
            shown = _r(value) if isinstance(value, str | int | float) else f"a {_yaml_type(value)}"
            problem(f"unknown type {shown} for group {_r(group)} (one of: float, int, bool)", "type", line)
        else:
            per_group[group] = (value, line)  # type: ignore[assignment]  # checked against the Literal
    return kind, per_group


def _outputs(
    tag: str | None,
    robot: str | None,
    kind: NumberKind,
    group_kinds: dict[str, tuple[NumberKind, int]],
    names: tuple[str | None, ...],
    problem: Any,
) -> tuple[Output, ...]:
    """The rule's outputs (in `robot`'s namespace; None: the line's node's); every problem with its groups
    is reported (not only the first)."""
    named = [n for n in names if n is not None]
    for group, (_kind, line) in group_kinds.items():
        if group not in named:
            has = f"its named groups: {', '.join(map(_r, named))}" if named else "it has no named group"
            problem(f"'type' gives a type to group {_r(group)}, which the pattern lacks ({has})", line)
    if not names:
        problem("the pattern has no capture group: put the number in parentheses, e.g. 'speed (\\S+)'")
        return ()
    unnamed = [str(i + 1) for i, n in enumerate(names) if n is None]
    if len(names) > 1 and unnamed:
        problem(
            f"the pattern has {len(names)} capture groups, so each must be named (?P<name>...); "
            f"group(s) {', '.join(unnamed)} are unnamed (use (?:...) for grouping only)"
        )
    if tag is None:
        return ()

    def output(text: str, group: int, kind: NumberKind) -> Output:
        name = escape_tag(text)
        return Output(name, topic_for_tag(name, robot or ""), group, kind, robot is None)

    if len(names) == 1:
        first = names[0]
        one = group_kinds[first][0] if first is not None and first in group_kinds else kind
        return (output(tag, 1, one),)
    outputs = []
    for i, name in enumerate(names):
        if name is None:
            continue
        sub = f"{tag}/{name}"
        try:
            tag_topic(sub, robot or "")
        except TagError as exc:
            problem(f"group {_r(name)} gives the tag {_r(sub)}, which is invalid: {exc}")
            continue
        outputs.append(output(sub, i + 1, group_kinds.get(name, (kind, 0))[0]))
    return tuple(outputs)


def _r(value: Any) -> str:
    """`value`'s repr for a message; a string longer than `SHOWN_CHARS` is cut, with its length."""
    if isinstance(value, str) and len(value) > SHOWN_CHARS:
        return f"{value[:SHOWN_CHARS]!r}… ({len(value)} chars)"
    return shorten(repr(value))


def _quoted(text: str) -> str:
    """`text` in single quotes as written (a pattern), cut after `SHOWN_CHARS` characters with its length."""
    if len(text) <= SHOWN_CHARS:
        return f"'{text}'"
    return f"'{text[:SHOWN_CHARS]}'… ({len(text)} chars)"


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
