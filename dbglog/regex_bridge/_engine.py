"""The matching engine: (line, logger, level, source topic) → typed values, in one RE2 pass per line.

Pure (no rclpy). Rules are grouped by what a line's origin selects: for each distinct (source topic,
logger, level) the applicable rules are found once (node globs and level minimums evaluated then) and
their patterns compiled into one ``RE2::Set``. A line costs one Set search, which says which rules match;
only those rules run again for their capture groups.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any, Final, NamedTuple

from re2 import _re2

from dbglog.regex_bridge._regex import BYTES_PARSERS, MAX_LINE, NumberKind, re2_options
from dbglog.regex_bridge._rules import ROSOUT, Output, Rule, RuleSet

__all__ = ["Matcher", "MatcherStats", "Unparseable", "Value"]

_UNANCHORED: Final = _re2.RE2.Anchor.UNANCHORED
_NO_SPAN: Final = (-1, -1)
_INT64_MIN: Final = -(1 << 63)
_INT64_MAX: Final = (1 << 63) - 1
_MAX_GROUPS: Final = 4096
"""Distinct (source, logger, level) keys remembered; the cache starts over past this (loggers are few)."""
_SET_MAX_MEM: Final = 64 << 20
"""RE2 budget for one rule Set: ample, so its DFA never gives up (a Set search never bails when slow)."""


def _int64(data: bytes) -> int:
    value = int(BYTES_PARSERS["int"](data))
    if not _INT64_MIN <= value <= _INT64_MAX:
        raise ValueError(f"out of the Int64 range: {data!r}")
    return value


_PARSERS: Final[dict[str, Callable[[bytes], float | int | bool]]] = {**BYTES_PARSERS, "int": _int64}
_new_tuple: Final = tuple.__new__
"""Builds a Value without NamedTuple's Python-level ``__new__`` (a third of a matched line's cost)."""


class Value(NamedTuple):
    """One typed value produced from a line: publish `value` on `topic` as `kind`."""

    topic: str
    kind: NumberKind
    value: float | int | bool


class Unparseable(NamedTuple):
    """A capture that is not a number of its output's kind."""

    topic: str
    kind: NumberKind
    text: str


@dataclass(slots=True)
class MatcherStats:
    """Counters since the matcher was built (or last reset)."""

    values: int = 0
    unparseable: dict[str, int] = field(default_factory=dict)
    """Per output topic: captures that were not numbers of the output's kind."""
    last_unparseable: Unparseable | None = None

    @property
    def unparseable_total(self) -> int:
        """All unparseable captures, over every topic."""
        return sum(self.unparseable.values())


class _Compiled:
    """A rule's capture program and outputs, ready for the hot loop."""

    __slots__ = ("outputs", "program", "rule")

    def __init__(self, rule: Rule) -> None:
        self.rule = rule
        self.program: Any = _re2.RE2(rule.pattern.encode("utf-8"), re2_options())
        self.outputs: tuple[tuple[int, str, NumberKind, Callable[[bytes], float | int | bool]], ...] = tuple(
            (o.group, o.topic, o.kind, _PARSERS[o.kind]) for o in rule.outputs
        )


class _Group:
    """The rules that apply to one kind of line, with one RE2 Set over their patterns."""

    __slots__ = ("match_set", "rules")

    def __init__(self, rules: Sequence[_Compiled]) -> None:
        self.rules = tuple(rules)
        rule_set: Any = _re2.Set(_UNANCHORED, re2_options(_SET_MAX_MEM))
        for r in self.rules:
            if rule_set.Add(r.rule.pattern.encode("utf-8")) < 0:  # pragma: no cover - compiled alone already
                raise ValueError(f"RE2 Set rejected the pattern of rule {r.rule.tag!r}")
        if not rule_set.Compile():  # pragma: no cover - only on exhausting RE2's memory budget
            raise ValueError("RE2 could not compile the rule Set")
        self.match_set: Any = rule_set.Match


class Matcher:
    """Map log lines to typed values with a set of rules; thread-safe, no ROS needed.

    Example:
        >>> m = Matcher(parse_rules("rules: [{tag: battery, pattern: 'battery=(\\\\d+)%', type: int}]").rules)
        >>> m.match("battery=87% ok", logger="power")
        [Value(topic='/rosdashboard/battery', kind='int', value=87)]
    """

    def __init__(self, rules: RuleSet | Iterable[Rule]) -> None:
        """Compile `rules` (already validated: see `load_rules`/`parse_rules`)."""
        chosen = rules.rules if isinstance(rules, RuleSet) else tuple(rules)
        self._rules = tuple(_Compiled(r) for r in chosen)
        self._groups: dict[tuple[str, str, int], _Group | None] = {}
        self._by_subset: dict[tuple[int, ...], _Group] = {}
        self._lock = threading.Lock()
        self.stats = MatcherStats()

    @property
    def rules(self) -> tuple[Rule, ...]:
        """The rules, in file order."""
        return tuple(c.rule for c in self._rules)

    @property
    def outputs(self) -> tuple[Output, ...]:
        """Every output topic the rules can publish to, in file order."""
        return tuple(o for c in self._rules for o in c.rule.outputs)

    def match(self, line: str, logger: str = "", level: int = 0, source: str = ROSOUT) -> list[Value]:
        """Return the values `line` yields (empty when no rule applies or matches).

        Args:
            line: the log text (``msg`` of a ``/rosout`` Log, or ``data`` of a String); only its
                first `MAX_LINE` bytes of UTF-8 are matched.
            logger: the logger (node) name, for rules with ``node``.
            level: the ``rcl_interfaces/msg/Log`` level (10 debug … 50 fatal), for rules with ``level``.
            source: the topic the line came from.
        """
        try:
            group = self._groups[source, logger, level]
        except KeyError:
            group = self._group_for((source, logger, level))
        if group is None:
            return []
        if len(line) > MAX_LINE:
            line = line[:MAX_LINE]
        try:
            data = line.encode()
        except UnicodeEncodeError:  # lone surrogates (from undecodable bytes): keep them matchable
            data = line.encode("utf-8", "surrogatepass")
        if len(data) > MAX_LINE:
            data = data[:MAX_LINE]
        hits = group.match_set(data)
        if not hits:
            return []
        return self._extract(group, hits, data)

    def match_bytes(self, data: bytes, logger: str = "", level: int = 0, source: str = ROSOUT) -> list[Value]:
        """Like `match`, for a line already in UTF-8 (the bridge reads it straight from the message)."""
        try:
            group = self._groups[source, logger, level]
        except KeyError:
            group = self._group_for((source, logger, level))
        if group is None:
            return []
        if len(data) > MAX_LINE:
            data = data[:MAX_LINE]
        hits = group.match_set(data)
        if not hits:
            return []
        return self._extract(group, hits, data)

    def _extract(self, group: _Group, hits: list[int], data: bytes) -> list[Value]:
        values: list[Value] = []
        end = len(data)
        for index in sorted(hits):  # RE2 reports them in no particular order; keep file order
            compiled = group.rules[index]
            spans = compiled.program.Match(_UNANCHORED, data, 0, end)
            for group_index, topic, kind, parse in compiled.outputs:
                start, stop = spans[group_index]
                if start < 0:  # no match (cannot happen: the Set said so), or an optional group left out
                    continue
                try:
                    values.append(_new_tuple(Value, (topic, kind, parse(data[start:stop]))))
                except ValueError:
                    self._unparseable(topic, kind, data[start:stop])
        self.stats.values += len(values)
        return values

    def reset_stats(self) -> MatcherStats:
        """Return the counters so far and start new ones."""
        old, self.stats = self.stats, MatcherStats()
        return old

    def _unparseable(self, topic: str, kind: NumberKind, capture: bytes) -> None:
        stats = self.stats
        stats.unparseable[topic] = stats.unparseable.get(topic, 0) + 1
        stats.last_unparseable = Unparseable(topic, kind, capture[:80].decode("utf-8", "replace"))

    def _group_for(self, key: tuple[str, str, int]) -> _Group | None:
        source, logger, level = key
        with self._lock:
            subset = tuple(i for i, c in enumerate(self._rules) if c.rule.accepts(source, logger, level))
            group: _Group | None = None
            if subset:
                group = self._by_subset.get(subset)
                if group is None:
                    group = self._by_subset[subset] = _Group([self._rules[i] for i in subset])
            if len(self._groups) >= _MAX_GROUPS:
                self._groups.clear()
            self._groups[key] = group
            return group
