"""The matching engine: (line, logger, level, source topic) → typed values, with RE2 Set searches.

Pure (no rclpy). Rules are grouped by what a line's origin selects: for each distinct (source topic,
logger, level) the applicable rules are found once (node globs and level minimums evaluated then) and
their patterns compiled into RE2 Sets. One line costs one Set search, which says which rules match;
only those rules run again for their capture groups.

A batch (`Matcher.match_many`) costs one Set search per chunk of lines joined with newlines. That Set
holds each pattern in multi-line mode (``(?m)``: ``^``/``$`` also match at the joins), so a line a rule
matches on its own always makes its chunk match the rule too: no false negatives. Each rule a chunk hits
is then searched through the chunk for its lines; a hit that stays inside one line is exactly that line's
own match (the joins look like the ends of a text to every assertion), a hit running past its line is
checked line by line. Chunks that many rules hit, lines with a newline of their own, and the rule groups
with a pattern whose meaning depends on the ends of the text (``\\A``, ``\\z``, ``(?-m)``) go line by line.
"""

from __future__ import annotations

import re
import threading
from bisect import bisect_right
from collections.abc import Callable, Iterable, Sequence, Sized
from dataclasses import dataclass, field
from itertools import accumulate
from typing import Any, Final, NamedTuple

from re2 import _re2

from dbglog._regex._compile import BYTES_PARSERS, MAX_LINE, NumberKind, re2_options
from dbglog.regex_bridge._rules import ROSOUT, Output, Rule, RuleSet

__all__ = ["Matcher", "MatcherStats", "Unparseable", "Value"]

_UNANCHORED: Final = _re2.RE2.Anchor.UNANCHORED
_INT64_MIN: Final = -(1 << 63)
_INT64_MAX: Final = (1 << 63) - 1
_MAX_GROUPS: Final = 4096
"""Distinct (source, logger, level) keys remembered; the cache starts over past this (loggers are few)."""
_SET_MAX_MEM: Final = 64 << 20
"""RE2 budget for one rule Set: ample, so its DFA never gives up (a Set search never bails when slow)."""
_CHUNK_BYTES: Final = MAX_LINE
"""Most bytes of lines joined for one search, so that no search in a batch costs more than one over the
longest single line: the pathological-line bound holds for batches too."""
_TEXT_ENDS: Final = re.compile(r"\\[Az]|\(\?[imsU]*-[imsU]*m")
"""Pattern text that may depend on where the text starts or ends (``\\A``, ``\\z``, multi-line mode
turned off): such rules never run over joined lines. Errs on the safe side (an escaped ``\\\\A`` counts)."""
_FEW_TO_JOIN: Final = 12
"""Batches of fewer lines are matched one line at a time (below this, a batch's own cost outweighs what
joining saves)."""
_FEW_ORIGINS: Final = 64
"""A batch with at most this many (logger, level) combinations checks whether they all select the
same rules, to match it as one."""
_DENSE: Final = 5
"""A chunk where more than one rule in this many lines hits is matched line by line: one Set search per
line then costs less than two searches through the chunk per hit."""
_NO_VALUES: Final[tuple[Value, ...]] = ()


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


_OutputSpec = tuple[int, str, NumberKind, Callable[[bytes], float | int | bool]]


class _Compiled:
    """A rule's capture programs (for a line alone, and over joined lines) and outputs, for the hot loop."""

    __slots__ = ("joinable", "match", "match_joined", "outputs", "pattern", "rule")

    def __init__(self, rule: Rule) -> None:
        self.rule = rule
        self.pattern = rule.pattern.encode("utf-8")
        self.match: Any = _re2.RE2(self.pattern, re2_options()).Match
        self.joinable = _TEXT_ENDS.search(rule.pattern) is None
        self.match_joined: Any = (
            _re2.RE2(b"(?m)" + self.pattern, re2_options()).Match if self.joinable else None
        )
        self.outputs: tuple[_OutputSpec, ...] = tuple(
            (o.group, o.topic, o.kind, _PARSERS[o.kind]) for o in rule.outputs
        )


def _compile_set(patterns: Iterable[bytes]) -> Any:
    rule_set: Any = _re2.Set(_UNANCHORED, re2_options(_SET_MAX_MEM))
    for pattern in patterns:
        if rule_set.Add(pattern) < 0:  # pragma: no cover - each pattern compiled alone already
            raise ValueError(f"RE2 Set rejected the pattern {pattern!r}")
    if not rule_set.Compile():  # pragma: no cover - only on exhausting RE2's memory budget
        raise ValueError("RE2 could not compile a rule Set")
    return rule_set.Match


class _Group:
    """The rules that apply to one kind of line, with RE2 Sets over their patterns."""

    __slots__ = ("match_joined", "match_set", "rules")

    def __init__(self, rules: Sequence[_Compiled]) -> None:
        self.rules = tuple(rules)
        self.match_set: Any = _compile_set(r.pattern for r in self.rules)
        self.match_joined: Any = (
            _compile_set(b"(?m)" + r.pattern for r in self.rules)
            if all(r.joinable for r in self.rules)
            else None
        )
        """Over lines joined by newlines; None when a rule must see each line alone."""


class Matcher:
    """Map log lines to typed values with a set of rules; thread-safe, no ROS needed.

    Example:
        >>> m = Matcher(parse_rules("rules: [{tag: battery, pattern: 'battery=(\\\\d+)%', type: int}]").rules)
        >>> m.match("battery=87% ok", logger="power")
        [Value(topic='/rosdashboard/battery', kind='int', value=87)]
        >>> [len(values) for values in m.match_many(["battery=87%", "idle", "battery=86%"], logger="power")]
        [1, 0, 1]
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
        """Return the values `line` yields (empty when no rule applies or matches), in rule order.

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
        if hits:
            return self._extract(group.rules, hits, data)
        return []

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
        if hits:
            return self._extract(group.rules, hits, data)
        return []

    def match_many(
        self,
        lines: Sequence[str],
        logger: str | Sequence[str] = "",
        level: int | Sequence[int] = 0,
        source: str = ROSOUT,
    ) -> list[tuple[Value, ...]]:
        """Return the values of each line, exactly as `match` gives them one line at a time, but cheaper.

        Lines that no rule matches cost a fraction of a separate `match` call each: one RE2 search
        covers up to `MAX_LINE` bytes of lines.

        Args:
            lines: log texts; only the first `MAX_LINE` bytes of UTF-8 of each are matched.
            logger: one logger name for every line, or one per line.
            level: one level for every line, or one per line.
            source: the topic every line came from.

        Raises:
            ValueError: `logger` or `level` is a sequence of another length than `lines`.
        """
        if len(lines) < _FEW_TO_JOIN:
            if isinstance(logger, str) and isinstance(level, int):
                return [tuple(self.match(line, logger, level, source)) for line in lines]
            loggers, levels = _origins(len(lines), logger, level)
            return [tuple(self.match(*args, source)) for args in zip(lines, loggers, levels, strict=True)]
        return self._many(lines, logger, level, source, _join_str)

    def match_many_bytes(
        self,
        lines: Sequence[bytes],
        logger: str | Sequence[str] = "",
        level: int | Sequence[int] = 0,
        source: str = ROSOUT,
    ) -> list[tuple[Value, ...]]:
        """Like `match_many`, for lines already in UTF-8 (the bridge's ingest batches)."""
        if len(lines) < _FEW_TO_JOIN:
            if isinstance(logger, str) and isinstance(level, int):
                return [tuple(self.match_bytes(line, logger, level, source)) for line in lines]
            loggers, levels = _origins(len(lines), logger, level)
            return [
                tuple(self.match_bytes(*args, source)) for args in zip(lines, loggers, levels, strict=True)
            ]
        return self._many(lines, logger, level, source, _join_bytes)

    def reset_stats(self) -> MatcherStats:
        """Return the counters so far and start new ones."""
        old, self.stats = self.stats, MatcherStats()
        return old

    # ------------------------------------------------------------------------------ one line

    def _extract(self, rules: tuple[_Compiled, ...], hits: list[int], data: bytes) -> list[Value]:
        values: list[Value] = []
        if len(hits) > 1:
            hits.sort()  # RE2 reports them in no particular order; keep file order
        for index in hits:
            compiled = rules[index]
            spans = compiled.match(_UNANCHORED, data, 0, len(data))
            for group_index, topic, kind, parse in compiled.outputs:
                start, stop = spans[group_index]
                if start < 0:  # an optional group that took no part in the match
                    continue
                try:
                    values.append(_new_tuple(Value, (topic, kind, parse(data[start:stop]))))
                except ValueError:
                    self._unparseable(topic, kind, data[start:stop])
        self.stats.values += len(values)
        return values

    # ------------------------------------------------------------------------------ batches

    def _many(
        self,
        lines: Sequence[Any],
        logger: str | Sequence[str],
        level: int | Sequence[int],
        source: str,
        join: Callable[[Sequence[Any]], tuple[bytes, Sequence[Sized]]],
    ) -> list[tuple[Value, ...]]:
        count = len(lines)
        results: list[tuple[Value, ...]] = [_NO_VALUES] * count
        for group, where in self._split(count, logger, level, source):
            self._batch(group, *join(lines if where is None else [lines[i] for i in where]), where, results)
        return results

    def _group(self, source: str, logger: str, level: int) -> _Group | None:
        try:
            return self._groups[source, logger, level]
        except KeyError:
            return self._group_for((source, logger, level))

    def _split(
        self, count: int, logger: str | Sequence[str], level: int | Sequence[int], source: str
    ) -> list[tuple[_Group, list[int] | None]]:
        """Sort line numbers by the rule group their origin selects (None: all lines; lines no rule is
        for are left out)."""
        if isinstance(logger, str) and isinstance(level, int):
            group = self._group(source, logger, level)
            return [] if group is None or not count else [(group, None)]
        loggers, levels = _origins(count, logger, level)
        names, severities = set(loggers), set(levels)
        if len(names) * len(severities) <= _FEW_ORIGINS:  # often every origin selects the same rules
            groups = {self._group(source, name, severity) for name in names for severity in severities}
            if len(groups) == 1:
                group = groups.pop()
                return [] if group is None or not count else [(group, None)]
        buckets: dict[_Group, list[int]] = {}
        last: tuple[str, int] | None = None
        bucket: list[int] | None = None
        for i, origin in enumerate(zip(loggers, levels, strict=True)):
            if origin != last:
                last = origin
                found = self._group(source, *origin)
                bucket = None if found is None else buckets.setdefault(found, [])
            if bucket is not None:
                bucket.append(i)
        return list(buckets.items())

    def _batch(
        self,
        group: _Group,
        joined: bytes,
        sized: Sequence[Sized],
        where: list[int] | None,
        results: list[tuple[Value, ...]],
    ) -> None:
        """Match lines joined by newlines, chunk by chunk.

        Each line is at most `MAX_LINE` bytes; ``len(sized[k])`` is line k's size in bytes, and its values
        go to ``results[where[k]]`` (``results[k]`` without `where`).
        """
        count = len(sized)
        if group.match_joined is None:  # a rule must see each line alone: go line by line
            self._each_line(group, joined, _offsets(sized), 0, count, where, results)
            return
        if joined.count(b"\n") != count - 1:  # some line has a newline of its own: it goes alone
            offsets = _offsets(sized)
            datas = [joined[offsets[k] : offsets[k + 1] - 1] for k in range(count)]
            kept = []
            for k, data in enumerate(datas):
                if b"\n" not in data:
                    kept.append(k)
                    continue
                hits = group.match_set(data)
                if hits:
                    results[k if where is None else where[k]] = tuple(self._extract(group.rules, hits, data))
            if kept:
                self._batch(
                    group,
                    b"\n".join([datas[k] for k in kept]),
                    [datas[k] for k in kept],
                    kept if where is None else [where[k] for k in kept],
                    results,
                )
            return
        if len(joined) <= _CHUNK_BYTES:  # one chunk: often no rule hits, and then nothing more to do
            hits = group.match_joined(joined)
            if hits:
                self._chunk(group, hits, joined, _offsets(sized), 0, count, where, results)
            return
        offsets = _offsets(sized)
        first = 0
        while first < count:
            base = offsets[first]
            # A chunk holds at most _CHUNK_BYTES bytes, or one line (at most MAX_LINE bytes).
            last = max(first + 1, bisect_right(offsets, base + _CHUNK_BYTES + 1, first + 1) - 1)
            chunk = joined[base : offsets[last] - 1]
            hits = group.match_joined(chunk)
            if hits:
                self._chunk(group, hits, chunk, offsets, first, last, where, results)
            first = last

    def _chunk(
        self,
        group: _Group,
        hits: list[int],
        chunk: bytes,
        offsets: list[int],
        first: int,
        last: int,
        where: list[int] | None,
        results: list[tuple[Value, ...]],
    ) -> None:
        """Find the values of the rules `hits` (the joined Set's answer) in lines `first` to `last`
        (excluded), joined in `chunk`; none has a newline of its own."""
        if len(hits) * _DENSE > last - first:  # many rules hit: going line by line costs less
            self._each_line(group, chunk, offsets, first, last, where, results)
            return
        if len(hits) > 1:
            hits.sort()  # rule by rule in file order, so each line's values are in file order
        rules, base, end = group.rules, offsets[first], len(chunk)
        for index in hits:
            compiled = rules[index]
            search = compiled.match_joined
            pos = 0
            while True:
                spans = search(_UNANCHORED, chunk, pos, end)
                start, stop = spans[0]
                if start < 0:
                    break
                line = bisect_right(offsets, base + start, first, last) - 1
                pos = offsets[line + 1] - base  # where the next line starts
                if stop >= pos:  # ran past its line: check the lines alone from this one on
                    self._lines_alone(compiled, chunk, offsets, first, line, last, where, results)
                    break
                self._emit(compiled.outputs, spans, chunk, results, line if where is None else where[line])
                if pos > end:
                    break

    def _each_line(
        self,
        group: _Group,
        chunk: bytes,
        offsets: list[int],
        first: int,
        last: int,
        where: list[int] | None,
        results: list[tuple[Value, ...]],
    ) -> None:
        """Match lines `first` to `last` (excluded) of `chunk` (which begins with line `first`) one by one."""
        base, match_set, rules = offsets[first], group.match_set, group.rules
        for line in range(first, last):
            data = chunk[offsets[line] - base : offsets[line + 1] - base - 1]
            hits = match_set(data)
            if hits:
                results[line if where is None else where[line]] = tuple(self._extract(rules, hits, data))

    def _lines_alone(
        self,
        compiled: _Compiled,
        chunk: bytes,
        offsets: list[int],
        first: int,
        start: int,
        last: int,
        where: list[int] | None,
        results: list[tuple[Value, ...]],
    ) -> None:
        """Run one rule on lines `start` to `last` (excluded) of `chunk` (which begins with line `first`)."""
        match, outputs, base = compiled.match, compiled.outputs, offsets[first]
        for line in range(start, last):
            data = chunk[offsets[line] - base : offsets[line + 1] - base - 1]
            spans = match(_UNANCHORED, data, 0, len(data))
            if spans[0][0] >= 0:
                self._emit(outputs, spans, data, results, line if where is None else where[line])

    def _emit(
        self,
        outputs: tuple[_OutputSpec, ...],
        spans: list[tuple[int, int]],
        data: bytes,
        results: list[tuple[Value, ...]],
        at: int,
    ) -> None:
        values = results[at]
        for group_index, topic, kind, parse in outputs:
            start, stop = spans[group_index]
            if start < 0:  # an optional group that took no part in the match
                continue
            try:
                values += (_new_tuple(Value, (topic, kind, parse(data[start:stop]))),)
            except ValueError:
                self._unparseable(topic, kind, data[start:stop])
                continue
            self.stats.values += 1
        results[at] = values

    # ------------------------------------------------------------------------------ shared

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


def _offsets(sized: Sequence[Sized]) -> list[int]:
    """Where each line starts once joined by newlines, and last one past the end plus one."""
    return list(accumulate([n + 1 for n in map(len, sized)], initial=0))


def _origins(
    count: int, logger: str | Sequence[str], level: int | Sequence[int]
) -> tuple[Sequence[str], Sequence[int]]:
    """The logger and level of each of `count` lines."""
    loggers = [logger] * count if isinstance(logger, str) else logger
    levels = [level] * count if isinstance(level, int) else level
    if len(loggers) != count or len(levels) != count:
        raise ValueError(f"match_many: {count} lines but {len(loggers)} loggers and {len(levels)} levels")
    return loggers, levels


def _utf8(line: str) -> bytes:
    """The first `MAX_LINE` bytes of `line` in UTF-8 (lone surrogates, from undecodable bytes, kept)."""
    if len(line) > MAX_LINE:
        line = line[:MAX_LINE]
    try:
        data = line.encode()
    except UnicodeEncodeError:
        data = line.encode("utf-8", "surrogatepass")
    return data if len(data) <= MAX_LINE else data[:MAX_LINE]


def _join_str(lines: Sequence[str]) -> tuple[bytes, Sequence[Sized]]:
    """The lines' UTF-8, each cut to `MAX_LINE` bytes, joined by newlines; and what gives their sizes."""
    if max(map(len, lines)) <= MAX_LINE:
        text = "\n".join(lines)
        if text.isascii():  # the common case: a few passes in C, as many bytes as characters
            return text.encode(), lines
    return _join_bytes([_utf8(line) for line in lines])


def _join_bytes(lines: Sequence[bytes]) -> tuple[bytes, Sequence[Sized]]:
    """The lines, each cut to `MAX_LINE` bytes, joined by newlines; and the lines so cut."""
    if max(map(len, lines)) > MAX_LINE:
        lines = [line[:MAX_LINE] for line in lines]
    return b"\n".join(lines), lines
