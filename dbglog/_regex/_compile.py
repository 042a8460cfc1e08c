"""Safe regular expressions (google-re2, linear time) and strict ASCII number parsing.

Shared by the bridge's rule matcher and the viewer's per-binding regex.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Literal

import re2

__all__ = [
    "BYTES_PARSERS",
    "MAX_LINE",
    "MAX_PROGRAM_SIZE",
    "SHOWN_CHARS",
    "CompiledRegex",
    "NumberKind",
    "RegexError",
    "compile_regex",
    "parse_number",
    "parse_number_bytes",
    "re2_options",
    "shorten",
]

MAX_LINE = 4096
"""Lines longer than this many characters are truncated before matching."""

MAX_PROGRAM_SIZE = 1500
"""Largest RE2 program accepted: one match costs at most about ``MAX_LINE × MAX_PROGRAM_SIZE`` steps."""

NumberKind = Literal["float", "int", "bool"]

SHOWN_CHARS = 80
"""Longest user text (a pattern, a fragment of it) quoted whole in an error message."""


def shorten(text: str, limit: int = SHOWN_CHARS) -> str:
    """Return `text`, or its first `limit` characters and ``… (N chars)`` when it is longer (for messages)."""
    if len(text) <= limit:
        return text
    return f"{text[:limit]}… ({len(text)} chars)"


class RegexError(ValueError):
    """A pattern that RE2 cannot compile or express; the message says why."""


def re2_options(max_mem: int = 8 << 20) -> re2.Options:
    """Return RE2 options: UTF-8, quiet (errors come back as exceptions), at most `max_mem` bytes."""
    options = re2.Options()
    options.log_errors = False
    options.max_mem = max_mem
    return options


_OPTIONS = re2_options()


@dataclass(frozen=True, slots=True)
class CompiledRegex:
    """A compiled RE2 pattern with its capture-group layout."""

    pattern: str
    compiled: re2._Regexp
    group_names: tuple[str | None, ...]
    """Name of each capture group in order (None for unnamed groups)."""

    def extract(self, text: str) -> str | None:
        """Return the first capture group (or the whole match without groups) of the first match."""
        m = self.compiled.search(text[:MAX_LINE])
        if m is None:
            return None
        found: str | None = m.group(1) if self.group_names else m.group(0)
        return found


def compile_regex(pattern: str) -> CompiledRegex:
    """Compile `pattern` with RE2.

    Raises:
        RegexError: the pattern does not compile or uses a feature RE2 rejects (backreferences,
            lookarounds); the message gives RE2's reason.
    """
    if not isinstance(pattern, str):
        raise RegexError(f"pattern must be a string, not {type(pattern).__name__}")
    try:
        compiled = re2.compile(pattern, options=_OPTIONS)
    except re2.error as exc:
        raise RegexError(_reason(pattern, exc)) from None
    size = compiled._regexp.ProgramSize()
    if size > MAX_PROGRAM_SIZE:
        raise RegexError(
            f"pattern is too complex (RE2 program size {size} > {MAX_PROGRAM_SIZE}): simplify it; "
            "counted repeats such as {200} multiply its size"
        )
    names: list[str | None] = [None] * compiled.groups
    for name, index in compiled.groupindex.items():
        names[index - 1] = name
    return CompiledRegex(pattern, compiled, tuple(names))


def _reason(pattern: str, exc: Exception) -> str:
    raw = exc.args[0] if exc.args else ""
    text = raw.decode("utf-8", "replace") if isinstance(raw, bytes) else str(raw)
    # RE2 names what it stopped at after the first ": " (e.g. "missing ): (aaaa…"), often the whole
    # rest of the pattern: cut it, so a 100 KB pattern does not come back as a 100 KB message.
    what, sep, fragment = text.partition(": ")
    text = f"{what}{sep}{shorten(fragment)}" if sep else shorten(text)
    text = text or "invalid pattern"
    if "\\1" in pattern or any(f"\\{d}" in pattern for d in "123456789"):
        return f"{text} (backreferences are not supported: RE2 matches in linear time)"
    if any(look in pattern for look in ("(?=", "(?!", "(?<=", "(?<!")):
        return f"{text} (lookarounds are not supported: RE2 matches in linear time)"
    return text


_ASCII_SPACE = " \t\n\r\f\v"
_DIGITS = frozenset("0123456789")
_FLOAT_CHARS = _DIGITS | frozenset("+-.eE")
_SPECIAL = {
    "nan": math.nan,
    "+nan": math.nan,
    "-nan": math.nan,
    "inf": math.inf,
    "+inf": math.inf,
    "-inf": -math.inf,
    "infinity": math.inf,
    "+infinity": math.inf,
    "-infinity": -math.inf,
}
_BOOLS = {
    "true": True,
    "false": False,
    "1": True,
    "0": False,
    "yes": True,
    "no": False,
    "on": True,
    "off": False,
}


def parse_number(text: str, kind: NumberKind = "float") -> float | int | bool:
    """Parse `text` strictly: ASCII digits only, no ``_`` separators, no hex, no decimal comma.

    Raises:
        ValueError: the text is not a number of that kind; the message quotes it.
    """
    s = text.strip(_ASCII_SPACE)
    if kind == "bool":
        try:
            return _BOOLS[s.lower()]
        except KeyError:
            raise ValueError(f"not a bool: {text!r}") from None
    if kind == "int":
        body = s[1:] if s[:1] in "+-" else s
        if not body or not set(body) <= _DIGITS:
            raise ValueError(f"not an integer: {text!r}")
        return int(s)
    special = _SPECIAL.get(s.lower())
    if special is not None:
        return special
    if not s or not set(s) <= _FLOAT_CHARS or not (set(s) & _DIGITS):
        raise ValueError(f"not a number: {text!r}")
    try:
        return float(s)
    except ValueError:
        raise ValueError(f"not a number: {text!r}") from None


def parse_number_bytes(data: bytes, kind: NumberKind = "float") -> float | int | bool:
    """Parse a UTF-8 capture exactly as `parse_number` parses its text, but faster (the bridge's hot path).

    ``float()``/``int()`` on bytes read ASCII only, so other scripts' digits never pass; the only extra
    syntax they allow, ``_`` separators, is refused here.

    Raises:
        ValueError: the capture is not a number of that kind; the message quotes it.
    """
    return BYTES_PARSERS[kind](data)


def _float_bytes(data: bytes) -> float:
    if b"_" not in data:
        try:
            return float(data)
        except ValueError:
            pass
    raise ValueError(f"not a number: {_shown(data)!r}")


def _int_bytes(data: bytes) -> int:
    if b"_" not in data:
        try:
            return int(data)
        except ValueError:
            pass
    raise ValueError(f"not an integer: {_shown(data)!r}")


_ASCII_SPACE_BYTES = _ASCII_SPACE.encode()
_BYTES_BOOLS = {k.encode(): v for k, v in _BOOLS.items()}


def _bool_bytes(data: bytes) -> bool:
    found = _BYTES_BOOLS.get(data.strip(_ASCII_SPACE_BYTES).lower())
    if found is None:
        raise ValueError(f"not a bool: {_shown(data)!r}")
    return found


BYTES_PARSERS: dict[str, Callable[[bytes], float | int | bool]] = {
    "float": _float_bytes,
    "int": _int_bytes,
    "bool": _bool_bytes,
}
"""`parse_number_bytes` for each kind, as plain functions (no dispatch) for the hot loop."""


def _shown(data: bytes) -> str:
    return data.decode("utf-8", "replace")
