"""Numbers in log lines and RE2 patterns proposed from a clicked number ("plot this number").

Ground floor: imports only the standard library, ``re2``, ``numpy`` and the ground floor itself.
Nothing from a line is ever evaluated; every pattern is RE2 (linear time).
"""

from __future__ import annotations

import functools
import math
import re
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Final, Literal, NamedTuple

import numpy as np
import re2
from numpy.lib.stride_tricks import sliding_window_view

from dbglog._regex._compile import MAX_LINE, MAX_PROGRAM_SIZE, re2_options, shorten
from dbglog._ros._loglevels import LEVELS, node_matches
from dbglog._ros._tags import tag_problem

__all__ = [
    "ANY_NUMBER_PATTERN",
    "MAX_LINE",
    "MAX_PROGRAM_SIZE",
    "NUMBER_PATTERN",
    "WORD_PATTERN",
    "NumberSpan",
    "Proposal",
    "ProposalError",
    "capture_name",
    "find_numbers",
    "match_joined",
    "match_lines",
    "parse_console_line",
    "preview",
    "propose",
    "suggest_tag",
    "to_bridge_yaml",
]

NUMBER_PATTERN: Final = r"[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?"
"""RE2 for one finite number in a notation the bridge's float parser accepts: optional sign, ASCII
digits, an optional decimal point and exponent (``-12.5``, ``+.5``, ``3.``, ``1e-3``, ``6.02E+23``).
No hex, no ``_`` separators, no decimal comma (the bridge refuses those). The bridge's rules should use
this pattern (and `ANY_NUMBER_PATTERN`) for their number grammar."""

_SPECIALS: Final = "infinity|Infinity|INFINITY|inf|Inf|INF|nan|NaN|NAN"
ANY_NUMBER_PATTERN: Final = rf"[-+]?(?:(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?|{_SPECIALS})"
"""`NUMBER_PATTERN` or a not-a-number / infinity as C, C++, Python and JavaScript print them
(``nan``, ``-nan``, ``NaN``, ``inf``, ``-Infinity``, ...): what a proposal captures."""

WORD_PATTERN: Final = r"[\w[:^ascii:]]+"
"""RE2 for one word of a log line: ASCII letters, digits and ``_``, or any other script (``south``, ``速度``);
what `propose` writes for the words it generalises (`generalise_words`)."""

_PROPOSAL_BUDGET: Final = 900
"""Estimated RE2 program size of a proposal: context around the number is added while it fits."""
_NUMBER_COST: Final = 45
_SPACE_COST: Final = 8
_WORD_COST: Final = 18
_SPACES: Final = frozenset(" \t\r\n\f")
"""Whitespace that RE2's ``\\s`` matches: runs of it are generalised to ``\\s+``."""
_ASCII_PUNCT: Final = frozenset("!\"#$%&'()*+,-./:;<=>?@[\\]^_`{|}~")
_SIGN_BREAKERS: Final = frozenset(b")]+-")
"""A sign right after one of these is an operator or a dash, not the number's (as after a letter or digit)."""
_SIGN_BYTES: Final = frozenset(b"+-")

_OPTIONS = re2_options()

# Each search finds the next number that starts a word: at the start of the line or after a character
# that is not a letter, digit, ``_`` or ``.`` (so digits inside ``turtle1`` or ``a.5`` never start one),
# with what is glued after it (a unit, or the rest of ``1_000``, ``0x1F``, ``1.2.3``, ``info``) so that
# a rejected token is skipped whole. RE2 skips identifiers itself: one call per number.
_SCANNER = re2.compile(
    rb"(?:\A|[^\pL\pN_.])"
    rb"(?:(?P<num>[-+]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][-+]?[0-9]+)?)"
    rb"|(?P<special>[-+]?(?:" + _SPECIALS.encode() + rb")))"
    rb"(?P<tail>[\pL\pN_.]*)",
    options=_OPTIONS,
)
_G_NUM, _G_SPECIAL, _G_TAIL = 1, 2, 3
_UNANCHORED = re2._Anchor.UNANCHORED
_ANCHOR_START = re2._Anchor.ANCHOR_START


class ProposalError(ValueError):
    """No pattern could be proposed (no such number, or the line repeats itself around it); says why."""


class NumberSpan(NamedTuple):
    """One number found in a line: where it is (character offsets), its text, value and glued unit."""

    start: int
    end: int
    text: str
    value: float
    kind: Literal["int", "float"]
    """``int`` when written as an integer (sign and digits only), else ``float``."""
    unit: str
    """Letters glued right after the number (``m`` in ``0.42m``, ``ms`` in ``12ms``), or ``""``."""


@dataclass(frozen=True, slots=True)
class Proposal:
    """An RE2 pattern for "that kind of line", capturing the chosen number in group 1."""

    pattern: str
    """The full pattern (with ``^``/``$`` when the whole line is covered), as a rule's ``pattern``."""
    body: str
    """`pattern` without its anchors."""
    anchored_start: bool
    anchored_end: bool
    number: NumberSpan
    """The chosen number in `line`."""
    index: int
    """0-based position of the number among ``find_numbers(line)``."""
    line: str
    node: str | None
    """Logger name the pattern is meant for (a rule's ``node`` filter), or None for any node."""
    compiled: re2._Regexp = field(repr=False, compare=False)

    def extract(self, line: str) -> float | None:
        """Return the value this proposal takes from `line` (the first match), or None."""
        m = self.compiled.search(_visible(line)[0])
        return None if m is None else float(m.group(1))

    def named(self, name: str) -> str:
        """`pattern` with its capture group named after `name` (``(?P<x>…)``: a plot's legend shows it).

        The name keeps ASCII letters, digits and ``_`` (others become ``_``) and starts with a letter or
        ``_``; a name with nothing left leaves the group unnamed.
        """
        group = re.sub(r"[^A-Za-z0-9_]", "_", name.strip())[:60]
        if group and group[0].isdigit():
            group = "_" + group
        if not group.strip("_"):
            return self.pattern
        marker = f"({ANY_NUMBER_PATTERN})"
        return self.pattern.replace(marker, f"(?P<{group}>{ANY_NUMBER_PATTERN})", 1)


def _visible(line: str) -> tuple[str, bool]:
    """Return what a matcher reads of `line` (its first `MAX_LINE` UTF-8 bytes) and whether it was cut."""
    if len(line) * 4 <= MAX_LINE:
        return line, False
    data = line.encode("utf-8", "surrogatepass")
    if len(data) <= MAX_LINE:
        return line, False
    return data[:MAX_LINE].decode("utf-8", "ignore"), True


def find_numbers(line: str) -> list[NumberSpan]:
    """Return every number in the first `MAX_LINE` bytes of `line`, in order.

    A number is what the bridge can parse (see `NUMBER_PATTERN`), standing alone: digits inside an
    identifier (``turtle1``, ``x2``), hex/binary/octal literals (``0x1F``), ``_``-separated digits
    (``1_000``) and dotted versions or addresses (``1.2.3``, ``10.0.0.1``) are not numbers. Letters
    glued after a number are its unit (``0.42m``, ``12ms``, ``87%`` keeps ``%`` as text). A sign belongs
    to the number unless it follows a letter, digit, ``)``, ``]``, ``.``, ``_`` or another sign
    (``3-5`` is 3 and 5; ``x=-5`` is -5). A decimal comma separates two numbers (``1,5`` is 1 and 5).

    Args:
        line: the log line (its message text).
    """
    visible, cut = _visible(line)
    data = visible.encode("utf-8", "surrogatepass")
    ascii_only = len(data) == len(visible)
    match = _SCANNER._regexp.Match
    end = len(data)
    pos = 0
    found: list[NumberSpan] = []
    last_byte = last_char = 0
    while pos < end:
        spans = match(_UNANCHORED, data, pos, end)
        stop = spans[0][1]
        if stop < 0:
            break
        pos = stop
        tail_start, tail_end = spans[_G_TAIL]
        num_start, num_end = spans[_G_NUM]
        if num_start < 0:
            num_start, num_end = spans[_G_SPECIAL]
            if tail_end > tail_start and data[tail_start] != 0x2E:  # "info", "nan5", but "inf." is fine
                continue
        elif tail_end > tail_start and not _accept_tail(data, num_start, num_end, tail_start, tail_end):
            continue
        if data[num_end - 1] == 0x2E:  # "took 5." ends a sentence: the dot is text
            num_end -= 1
        if data[num_start] in _SIGN_BYTES and num_start > 0 and data[num_start - 1] in _SIGN_BREAKERS:
            num_start += 1  # "(x)-5", "+-5": an operator or a dash, not the number's sign
        if cut and num_end >= end:
            continue  # the cut may have split it
        text = data[num_start:num_end].decode("ascii")
        if ascii_only:
            c_start, c_end = num_start, num_end
        else:
            last_char += len(data[last_byte:num_start].decode("utf-8", "surrogatepass"))
            last_byte = num_start
            c_start, c_end = last_char, last_char + (num_end - num_start)
        kind: Literal["int", "float"] = "int" if text.lstrip("+-").isdigit() else "float"
        found.append(NumberSpan(c_start, c_end, text, float(text), kind, _unit(data, num_end, tail_end)))
    return found


def _accept_tail(data: bytes, num_start: int, num_end: int, t0: int, t1: int) -> bool:
    """Tell whether a number followed by glued text ``data[t0:t1]`` (letters, digits, ``_``, ``.``)
    stands alone: ``12ms`` does; ``1_000``, ``0x1F``, ``1.2.3``, ``10.0.0.1`` do not."""
    first = data[t0]
    if first == 0x5F:  # _
        return False
    if first == 0x2E:  # .
        return not (t1 > t0 + 1 and 0x30 <= data[t0 + 1] <= 0x39)
    if data[num_start:num_end].lstrip(b"+-") == b"0" and first in b"xXbBoO" and t1 > t0 + 1:
        return chr(data[t0 + 1]) not in "0123456789abcdefABCDEF"
    if first >= 0x80:
        return not data[t0:t1].decode("utf-8", "replace")[:1].isdigit()
    return True


def _unit(data: bytes, num_end: int, tail_end: int) -> str:
    """The letters glued after a number (``ms`` of ``12ms``), or ``%`` right after it, or ``""``."""
    if data[num_end : num_end + 1] == b"%":
        return "%"
    glued = data[num_end:tail_end].decode("utf-8", "replace") if tail_end > num_end else ""
    n = 0
    while n < len(glued) and glued[n].isalpha():
        n += 1
    return glued[:n]


def _escape(text: str) -> str:
    """Escape `text` as RE2 literal text; non-printable characters become ``\\x{...}`` (YAML-safe)."""
    out: list[str] = []
    for ch in text:
        if ch.isascii():
            if ch.isalnum():
                out.append(ch)
            elif ch in _ASCII_PUNCT or ch == " ":
                out.append("\\" + ch)
            else:
                out.append(f"\\x{{{ord(ch):x}}}")
        elif ch.isprintable():
            out.append(ch)
        else:
            out.append(f"\\x{{{ord(ch):x}}}")
    return "".join(out)


class _Piece(NamedTuple):
    """A piece of a proposal: its RE2 text, its estimated cost, and whether it is a word of the line."""

    pattern: str
    cost: int
    word: bool = False


def _text_pieces(text: str, spaces: bool) -> list[_Piece]:
    """Split literal text into pieces (word, whitespace run, single character) with their RE2 cost."""
    pieces: list[_Piece] = []
    i, n = 0, len(text)
    while i < n:
        ch = text[i]
        j = i + 1
        word = False
        if ch in _SPACES:
            while j < n and text[j] in _SPACES:
                j += 1
            if spaces:
                pieces.append(_Piece(r"\s+", _SPACE_COST))
                i = j
                continue
        elif ch.isalnum() or ch == "_":
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            word = True
        chunk = text[i:j]
        pieces.append(_Piece(_escape(chunk), len(chunk.encode("utf-8", "surrogatepass")) + 1, word))
        i = j
    return pieces


def _generalise_words(left: list[_Piece], right: list[_Piece], glued: bool) -> None:
    """Write every word of `left` and `right` as `WORD_PATTERN` but the anchor: the word nearest before the
    number (without one, the nearest after it), and a unit glued to the number (``ms`` of ``12ms``)."""
    before = [k for k, p in enumerate(left) if p.word]
    after = [k for k, p in enumerate(right) if p.word]
    keep_left = {before[-1]} if before else set()
    keep_right = {after[0]} if after and (not before or (glued and after[0] == 0)) else set()
    for pieces, keep in ((left, keep_left), (right, keep_right)):
        for k, piece in enumerate(pieces):
            if piece.word and k not in keep:
                pieces[k] = _Piece(WORD_PATTERN, _WORD_COST, True)


def propose(
    line: str,
    index: int,
    *,
    node: str | None = None,
    generalise_spaces: bool = True,
    generalise_words: bool = False,
) -> Proposal:
    """Propose an RE2 pattern for lines like `line`, capturing its `index`-th number (0-based).

    The line's text is escaped literally, the chosen number becomes ``(ANY_NUMBER_PATTERN)``, every other
    number ``NUMBER_PATTERN`` (or ``ANY_NUMBER_PATTERN`` when it is a nan or an infinity), (by default)
    every whitespace run ``\\s+`` and, with `generalise_words`, every word but the one nearest before the
    number (its name, ``x`` of ``x=2.87``) `WORD_PATTERN`: lines that differ in their words match too
    (``bumped into the north wall`` as ``... the south wall``). The pattern is anchored
    ``^…$`` when it covers the whole line; on a long line it covers as much context around the number
    as keeps its RE2 program well under `MAX_PROGRAM_SIZE`. The proposal is checked: it matches `line`
    and captures exactly the chosen number, or `ProposalError` is raised.

    Args:
        line: the log line's message text.
        index: which number, 0-based, among ``find_numbers(line)``.
        node: the logger that wrote the line; becomes the proposal's node filter.
        generalise_spaces: write whitespace runs as ``\\s+`` (True) or literally.
        generalise_words: write the words around the number (but its nearest) as `WORD_PATTERN`; when
            that cannot capture the number unambiguously the words stay literal.

    Raises:
        ProposalError: `index` is out of range, or no pattern captures that number unambiguously.

    Example:
        ``propose("battery=87% 12.1V", 0).pattern`` is ``^battery\\=(N)\\%\\s+NV$`` where ``N`` stands
        for `NUMBER_PATTERN`.
    """
    numbers = find_numbers(line)
    if not numbers:
        raise ProposalError(f"no number in the line {shorten(line)!r}")
    if not 0 <= index < len(numbers):
        raise ProposalError(
            f"number {index + 1} does not exist: the line has {len(numbers)} number(s) "
            f"({', '.join(n.text for n in numbers[:10])}{', …' if len(numbers) > 10 else ''})"
        )
    visible, cut = _visible(line)
    target = numbers[index]
    failure = ""
    for words, keep_numbers in ((True, False), (False, False), (False, True)):
        if words and not generalise_words:
            continue
        budget = _PROPOSAL_BUDGET
        while budget >= 100:
            body, at_start, at_end = _build(
                visible,
                numbers,
                index,
                budget,
                keep_numbers=keep_numbers,
                spaces=generalise_spaces,
                words=words,
            )
            at_end = at_end and not cut
            pattern = ("^" if at_start else "") + body + ("$" if at_end else "")
            try:
                compiled = re2.compile(pattern, options=_OPTIONS)
            except re2.error as exc:  # pragma: no cover - every piece is escaped or a fixed pattern
                raise ProposalError(f"internal error: proposed pattern does not compile: {exc}") from None
            if compiled._regexp.ProgramSize() > MAX_PROGRAM_SIZE:
                budget = budget * 2 // 3
                continue
            m = compiled.search(visible)
            if m is not None and m.span(1) == (target.start, target.end):
                return Proposal(pattern, body, at_start, at_end, target, index, line, node, compiled)
            failure = "the text around it repeats earlier in the line"
            break
    raise ProposalError(f"cannot propose a pattern for number {index + 1} ({target.text}): {failure}")


def _build(
    visible: str,
    numbers: list[NumberSpan],
    index: int,
    budget: int,
    *,
    keep_numbers: bool,
    spaces: bool,
    words: bool = False,
) -> tuple[str, bool, bool]:
    """Return the body of a pattern around ``numbers[index]`` within `budget`, and whether it reaches
    the start and the end of `visible`."""
    target = numbers[index]
    reach = budget // 2 + 64  # each side takes about half the budget (one character costs about 1)
    lo = max(0, target.start - reach)
    hi = min(len(visible), target.end + reach)
    left: list[_Piece] = []  # pieces before the number, in text order
    right: list[_Piece] = []
    cursor = lo
    for n in numbers:
        if n.end <= lo or n.start >= hi or n is target:
            if n is target:
                left.extend(_text_pieces(visible[cursor : n.start], spaces))
                cursor = n.end
            continue
        if n.start < lo:
            continue
        dest = left if n.start < target.start else right
        dest.extend(_text_pieces(visible[cursor : n.start], spaces))
        if keep_numbers:
            dest.append(_Piece(_escape(n.text), len(n.text) + 1))
        elif math.isfinite(n.value):
            dest.append(_Piece(NUMBER_PATTERN, _NUMBER_COST))
        else:
            dest.append(_Piece(f"(?:{ANY_NUMBER_PATTERN})", _NUMBER_COST * 2))
        cursor = n.end
    right.extend(_text_pieces(visible[cursor:hi], spaces))
    if words:
        _generalise_words(left, right, glued=bool(target.unit))
    total = _NUMBER_COST * 2
    i, j = len(left), 0  # left[i:] and right[:j] are taken
    grew = True
    while grew:
        grew = False
        if i > 0 and total + left[i - 1].cost <= budget:
            i -= 1
            total += left[i].cost
            grew = True
        if j < len(right) and total + right[j].cost <= budget:
            total += right[j].cost
            j += 1
            grew = True
    body = (
        "".join(p.pattern for p in left[i:])
        + f"({ANY_NUMBER_PATTERN})"
        + "".join(p.pattern for p in right[:j])
    )
    return body, i == 0 and lo == 0, j == len(right) and hi == len(visible)


# --- preview over stored lines ----------------------------------------------------------------------


def _ungrouped(body: str) -> str:
    """`body` with the capture group made non-capturing (the only ``(`` not followed by ``?``)."""
    marker = f"({ANY_NUMBER_PATTERN})"
    return body.replace(marker, f"(?:{ANY_NUMBER_PATTERN})", 1)


def _preview_regex(proposal: Proposal) -> re2._Regexp:
    """One stored line, from its ``\\x00`` to its ``\\x01``, capturing the number."""
    lead = r"\x00" if proposal.anchored_start else r"\x00[^\x00\x01]*?"
    trail = r"\x01" if proposal.anchored_end else r"[^\x00\x01]*\x01"
    return re2.compile(lead + proposal.body + trail, options=re2_options(32 << 20))


def match_lines(
    proposal: Proposal, lines: Sequence[str], *, nodes: Sequence[str] | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Return the indices of the `lines` the proposal matches and the value it takes from each.

    Each line is read as a matcher reads it (its first `MAX_LINE` bytes). With `nodes` (the logger of
    each line) and a proposal with a node, only that node's lines count (exact name or fnmatch glob).

    Args:
        proposal: from `propose`.
        lines: the stored lines' message texts.
        nodes: the logger name of each line, or None to ignore the proposal's node.

    Returns:
        ``(rows, values)``: int64 indices into `lines`, ascending, and float64 values.
    """
    rows_in: np.ndarray | None = None
    selected: Sequence[str] = lines
    if nodes is not None and proposal.node is not None:
        if len(nodes) != len(lines):
            raise ValueError(f"nodes has {len(nodes)} entries for {len(lines)} lines")
        want = proposal.node
        keep = [i for i, n in enumerate(nodes) if node_matches(n, want)]
        rows_in = np.asarray(keep, dtype=np.int64)
        selected = [lines[i] for i in keep]
    rows, values = _match_selected(proposal, selected)
    if rows_in is not None:
        rows = rows_in[rows]
    return rows, values


def preview(
    proposal: Proposal, lines: Sequence[str], *, nodes: Sequence[str] | None = None
) -> tuple[int, np.ndarray]:
    """Return how many of `lines` the proposal matches and the values it takes from them, in order.

    Args:
        proposal: from `propose`.
        lines: the stored lines' message texts.
        nodes: the logger of each line (the proposal's node filter applies), or None.
    """
    rows, values = match_lines(proposal, lines, nodes=nodes)
    return len(rows), values


def _cut_all(lines: Sequence[str]) -> list[str] | Sequence[str]:
    """`lines`, each cut to what a matcher reads (only long lines are touched)."""
    if max(map(len, lines)) * 4 <= MAX_LINE:
        return lines
    return [_visible(s)[0] for s in lines]


def _match_selected(proposal: Proposal, lines: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    if not lines:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64)
    lines = _cut_all(lines)
    if "\x00" in proposal.line or "\x01" in proposal.line:
        return _match_slow(proposal, lines)
    data = ("\x00" + "\x01\x00".join(lines) + "\x01").encode("utf-8", "surrogatepass")
    marks = np.frombuffer(data, dtype=np.uint8)
    starts = np.flatnonzero(marks == 0)
    if len(starts) != len(lines) or np.count_nonzero(marks == 1) != len(lines):
        return _match_slow(proposal, lines)  # a line holds a separator byte itself
    return match_joined(proposal, data, starts)


def match_joined(
    proposal: Proposal, data: bytes | bytearray | memoryview, starts: Sequence[int] | np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Like `match_lines`, over lines already stored as one buffer (what a columnar log store keeps).

    Args:
        proposal: from `propose`.
        data: every line's UTF-8 text (cut to `MAX_LINE` bytes, without ``\\x00``/``\\x01``), each as
            ``b"\\x00" + text + b"\\x01"``, one after the other.
        starts: the offset of each line's ``\\x00`` in `data`, ascending.

    Returns:
        ``(rows, values)``: indices into `starts` of the matching lines, and the value of each.
    """
    empty = (np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.float64))
    if "\x00" in proposal.line or "\x01" in proposal.line:
        return empty  # its pattern would need the separators themselves: no stored line can match it
    line_starts = np.asarray(starts, dtype=np.int64)
    # One RE2 call per matching line: RE2's DFA skips the other lines without returning to Python
    # (about 1 µs of binding overhead per call is the floor; see benchmarks/bench_logs.py). Where
    # lines of that kind follow each other, one DFA call finds the whole run and numpy reads the values.
    match = _preview_regex(proposal)._regexp.Match
    fast = _FastValues.for_proposal(proposal, data, line_starts)
    find_run = _runs_regex(proposal)._regexp.Match if fast is not None else None
    end = len(data)
    pos = 0
    adjacent = 0
    found: list[int] = []
    texts: list[bytes] = []
    blocks: list[tuple[np.ndarray, np.ndarray]] = []
    while pos < end:
        if find_run is not None and fast is not None and adjacent >= _RUN_AFTER:
            run_end = find_run(_ANCHOR_START, data, pos, end)[0][1]
            if run_end > pos:
                _flush(found, texts, line_starts, blocks)
                first, last = np.searchsorted(line_starts, (pos, run_end))
                blocks.append(fast.values(int(first), int(last), match))
                pos = int(run_end)
            adjacent = 0
            continue
        spans = match(_UNANCHORED, data, pos, end)
        start, stop = spans[0]
        if start < 0:
            break
        adjacent = adjacent + 1 if start == pos else 0
        pos = stop
        s, e = spans[1]
        found.append(start)
        texts.append(bytes(data[s:e]))
    _flush(found, texts, line_starts, blocks)
    if not blocks:
        return empty
    return np.concatenate([r for r, _ in blocks]), np.concatenate([v for _, v in blocks])


_RUN_AFTER: Final = 4
"""Consecutive matching lines after which the next lines are read as a run (one DFA call, numpy)."""
_NUM_BYTES: Final = np.zeros(256, dtype=bool)
_NUM_BYTES[list(b"0123456789.eE+-")] = True
_DIGIT_BYTES: Final = np.zeros(256, dtype=bool)
_DIGIT_BYTES[list(b"0123456789")] = True
_WINDOW: Final = 24
"""Longest number (in bytes) read by numpy; a longer one is read by RE2."""


def _flush(
    found: list[int], texts: list[bytes], starts: np.ndarray, blocks: list[tuple[np.ndarray, np.ndarray]]
) -> None:
    """Move the lines matched one by one into `blocks` (rows and values)."""
    if not found:
        return
    rows = np.searchsorted(starts, np.asarray(found, dtype=np.int64)).astype(np.int64)
    blocks.append((rows, np.fromiter(map(float, texts), dtype=np.float64, count=len(texts))))
    found.clear()
    texts.clear()


def _runs_regex(proposal: Proposal) -> re2._Regexp:
    """Consecutive stored lines that all match (no capture group: RE2's DFA alone)."""
    lead = r"\x00" if proposal.anchored_start else r"\x00[^\x00\x01]*?"
    trail = r"\x01" if proposal.anchored_end else r"[^\x00\x01]*\x01"
    return re2.compile(f"(?:{lead}{_ungrouped(proposal.body)}{trail})+", options=re2_options(32 << 20))


@dataclass(frozen=True, slots=True)
class _FastValues:
    """Reads the number of lines known to match with numpy, where its place is fixed by literal text.

    *Prefix* mode: the text before the number is literal (no other number) and each line starts with
    exactly the original's bytes; the number is the run of number characters after them. *Suffix* mode:
    the same from the end of the line. The run is the capture because the pattern's pieces on the other
    side begin with a character no number contains. Lines that do not fit (other whitespace, nan, a very
    long number) are matched by RE2 one by one.
    """

    raw: bytes | bytearray | memoryview
    data: np.ndarray
    """`raw` with `_WINDOW` zero bytes before and after (and room for the fixed text)."""
    starts: np.ndarray
    ends: np.ndarray
    """Offset of each line's ``\\x01``."""
    fixed: bytes
    from_start: bool

    @staticmethod
    def for_proposal(
        proposal: Proposal, data: bytes | bytearray | memoryview, starts: np.ndarray
    ) -> _FastValues | None:
        number = proposal.number
        if not math.isfinite(number.value) or not len(starts):
            return None
        visible = _visible(proposal.line)[0]
        before = visible[: number.start].encode("utf-8", "surrogatepass")
        after = visible[number.end :].encode("utf-8", "surrogatepass")
        numbers = find_numbers(proposal.line)
        buffer = np.frombuffer(data, dtype=np.uint8)
        ends = np.append(starts[1:], len(buffer)) - 1
        pad = np.zeros(_WINDOW, dtype=np.uint8)
        padded = np.concatenate([pad, buffer, pad, np.zeros(256, dtype=np.uint8)])
        if (
            proposal.anchored_start
            and proposal.index == 0
            and len(before) <= 256
            and not (after and _NUM_BYTES[after[0]])
        ):
            return _FastValues(data, padded, starts, ends, before, True)
        if (
            proposal.anchored_end
            and proposal.index == len(numbers) - 1
            and len(after) <= 256
            and not (before and _NUM_BYTES[before[-1]])
        ):
            return _FastValues(data, padded, starts, ends, after, False)
        return None

    def values(self, first: int, last: int, match: Any) -> tuple[np.ndarray, np.ndarray]:
        """Rows ``first..last-1`` (all matching) and their values."""
        rows = np.arange(first, last, dtype=np.int64)
        fixed = np.frombuffer(self.fixed, dtype=np.uint8)
        # `data` is padded with _WINDOW zero bytes before (and after): offsets shift by _WINDOW.
        windows = sliding_window_view(self.data, _WINDOW)
        if self.from_start:
            head = self.starts[first:last] + 1 + _WINDOW
            begin = head + len(fixed)
            same = self._same(head, fixed)
            window = windows[begin]
            is_num = _NUM_BYTES[window]
            length = np.where(is_num.all(axis=1), _WINDOW, np.argmin(is_num, axis=1))
        else:
            tail = self.ends[first:last] - len(fixed) + _WINDOW
            same = self._same(tail, fixed)
            back = _NUM_BYTES[windows[tail - _WINDOW][:, ::-1]]
            length = np.where(back.all(axis=1), _WINDOW, np.argmin(back, axis=1))
            begin = tail - length
            window = windows[begin]
        inside = np.arange(_WINDOW) < length[:, None]
        has_digit = (_DIGIT_BYTES[window] & inside).any(axis=1)
        good = same & (length < _WINDOW) & has_digit
        values = np.empty(len(rows), dtype=np.float64)
        if good.any():
            everyone = bool(good.all())
            text = window * inside if everyone else window[good] * inside[good]
            try:
                parsed = (
                    np.ascontiguousarray(text, dtype=np.uint8).view(f"S{_WINDOW}").ravel().astype(np.float64)
                )
            except ValueError:
                good[:] = False
            else:
                if everyone:
                    values = parsed
                else:
                    values[good] = parsed
        for k in np.flatnonzero(~good):  # read by RE2
            row = first + int(k)
            spans = match(_ANCHOR_START, self.raw, int(self.starts[row]), int(self.ends[row]) + 1)
            s, e = spans[1]
            values[k] = float(bytes(self.raw[s:e]))
        return rows, values

    def _same(self, at: np.ndarray, fixed: np.ndarray) -> np.ndarray:
        """Whether the (padded) data holds `fixed` at each offset of `at`."""
        if not len(fixed):
            return np.ones(len(at), dtype=bool)
        return np.asarray((sliding_window_view(self.data, len(fixed))[at] == fixed).all(axis=1))


def _match_slow(proposal: Proposal, lines: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """Line by line (for lines that contain the separator bytes ``\\x00``/``\\x01``)."""
    rows: list[int] = []
    values: list[float] = []
    search = proposal.compiled.search
    for i, line in enumerate(lines):
        m = search(line)
        if m is not None:
            rows.append(i)
            values.append(float(m.group(1)))
    return np.asarray(rows, dtype=np.int64), np.asarray(values, dtype=np.float64)


# --- rules and helpers --------------------------------------------------------------------------------


def _yaml_quoted(text: str) -> str:
    """`text` as a YAML single-quoted scalar (every character of a proposal is printable)."""
    return "'" + text.replace("'", "''") + "'"


def to_bridge_yaml(proposal: Proposal, tag: str, *, level: str | None = None) -> str:
    """Return a rules file (YAML) with one ``dbglog bridge`` rule for `proposal`, publishing `tag`.

    Args:
        proposal: from `propose`; its node becomes the rule's ``node``.
        tag: where the values go (``/rosdashboard/<tag>``).
        level: an optional minimum level (debug, info, warn, error, fatal).

    Raises:
        ValueError: `tag` is not a valid tag or `level` not a level name.
    """
    why = tag_problem(tag)
    if why is not None:
        raise ValueError(f"invalid tag {tag!r}: {why}")
    lines = ["rules:", f"  - tag: {tag}"]
    if proposal.node is not None:
        lines.append(f"    node: {_yaml_quoted(proposal.node)}")
    if level is not None:
        if level.lower() not in LEVELS:
            raise ValueError(f"unknown level {level!r} (one of: {', '.join(LEVELS)})")
        lines.append(f"    level: {level.lower()}")
    lines.append(f"    pattern: {_yaml_quoted(proposal.pattern)}")
    return "\n".join(lines) + "\n"


def suggest_tag(proposal: Proposal) -> str:
    """Return a tag named after the word just before the number (``battery=87%`` → ``battery``).

    Falls back to the unit (``12ms`` → ``ms``) and then to ``value``; always a valid tag.
    """
    before = proposal.line[: proposal.number.start]
    word: list[str] = []
    for ch in reversed(before):
        if ch.isascii() and (ch.isalnum() or ch == "_"):
            word.append(ch)
        elif word:
            break
    name = "".join(reversed(word)).lower().lstrip("0123456789_")
    unit = "".join(c for c in proposal.number.unit if c.isascii() and (c.isalnum() or c == "_")).lower()
    for candidate in (name, unit.lstrip("0123456789_")):
        if candidate:
            return candidate[:60]
    return "value"


@functools.lru_cache(maxsize=256)
def capture_name(pattern: str) -> str | None:
    """The name of `pattern`'s first capture group (``x`` of ``x\\=(?P<x>…)``), or None (unnamed, or no
    pattern RE2 takes)."""
    try:
        compiled = re2.compile(pattern, options=_OPTIONS)
    except re2.error:
        return None
    return next((name for name, index in compiled.groupindex.items() if index == 1), None)


def parse_console_line(text: str) -> tuple[str, str, str] | None:
    """Split a line as rcl prints it, ``[INFO] [1732200000.123] [node]: message``, into
    ``(level, node, message)``; None when `text` is not in that form."""
    if not text.startswith("["):
        return None
    level, sep, rest = text[1:].partition("] [")
    if not sep or level.lower() not in LEVELS or not level.isupper():
        return None
    stamp, sep, rest = rest.partition("] [")
    if not sep or not stamp.replace(".", "", 1).isdigit():
        return None
    node, sep, message = rest.partition("]: ")
    if not sep or not node:
        return None
    return level.lower(), node, message
