"""What a watch sends: a copy of the value, taken in the program's thread, that runs none of its code.

The publisher thread reads the value later, while the program goes on: a list or dict it would read
then could be changed meanwhile (a race), so a list of numbers is copied into an array, a dict into a
new dict of copies, a numpy array with ``copy()``; numbers and text are immutable and go as they are.
Only exact built-in types (and numpy's numeric arrays and scalars) are taken: converting anything else
(``str()``, ``float()``, ``repr()``) could run the program's ``__str__``/``__float__``/``__repr__``.
"""

from __future__ import annotations

from typing import Any, Final, Literal

from dbglog.watch._expr import MAX_ITEMS, NUMPY, EvalError

__all__ = [
    "MAX_DICT_ITEMS",
    "MAX_TEXT",
    "Kind",
    "freeze",
    "kind_name",
]

Kind = Literal["int", "float", "bool", "text", "array", "dict"]
MAX_TEXT: Final = 65_536
"""Longer text is cut to this many characters (the SDK's limit for a String tag)."""
MAX_DICT_ITEMS: Final = 64
"""Most keys of a dict value (each becomes a sub-tag)."""
_MAX_DICT_DEPTH: Final = 4
_INT64_LOW: Final = -(2**63)
_INT64_HIGH: Final = 2**63
_NUL: Final = "\x00"
_NUL_REPLACEMENT: Final = "\ufffd"


def kind_name(kind: Kind) -> str:
    """Say what a tag of `kind` carries, for a message."""
    return {
        "int": "integers (Int64)",
        "float": "numbers (Float64)",
        "bool": "bools (Bool)",
        "text": "text (String)",
        "array": "arrays",
        "dict": "dicts (one sub-tag per key)",
    }[kind]


def _number_array(sequence: list[Any] | tuple[Any, ...]) -> Any:
    items = tuple(sequence)  # one C step: another thread cannot change it while it is checked
    if len(items) > MAX_ITEMS:
        raise EvalError(f"a sequence of {len(items)} items is longer than {MAX_ITEMS}")
    for item in items:
        if type(item) not in (int, float, bool):
            raise EvalError(
                f"a sequence holding a {type(item).__name__} is not sent (a tag carries sequences of numbers)"
            )
    import numpy as np

    try:
        return np.array(items, dtype=np.float64)
    except OverflowError:
        raise EvalError("a sequence holds an integer too large for a float") from None


def freeze(value: object, depth: int = 0) -> tuple[Kind, Any]:
    """Return the kind of tag `value` goes on and a copy of it that the publisher thread may read.

    Ints (in the int64 range) stay ints, other numbers (numpy's too) become floats, bools stay bools, text
    is cut to `MAX_TEXT` with NUL characters replaced, sequences of numbers and numpy arrays of numbers
    become float/numpy arrays, bytes an array of bytes, dicts with text keys a dict of frozen values.

    Raises:
        EvalError: the value is of a type whose conversion could run code, or too large.
    """
    tv = type(value)
    if tv is float:
        return "float", value
    if tv is bool:
        return "bool", value
    if tv is int:
        if _INT64_LOW <= value < _INT64_HIGH:  # type: ignore[operator]
            return "int", value
        try:
            return "float", float(value)  # type: ignore[arg-type]
        except OverflowError:
            raise EvalError(f"the integer {value} is too large for a float") from None
    if tv is str:
        text: str = value  # type: ignore[assignment]
        if len(text) > MAX_TEXT:
            text = text[:MAX_TEXT]
        if _NUL in text:
            text = text.replace(_NUL, _NUL_REPLACEMENT)
        return "text", text
    if NUMPY.scalar(value):
        kind = value.dtype.kind  # type: ignore[attr-defined]
        if kind == "b":
            return "bool", bool(value)
        if kind in "iu" and _INT64_LOW <= int(value) < _INT64_HIGH:  # type: ignore[call-overload]
            return "int", int(value)  # type: ignore[call-overload]
        return "float", float(value)  # type: ignore[arg-type]
    if NUMPY.array(value):
        if value.size > MAX_ITEMS:  # type: ignore[attr-defined]
            raise EvalError(f"an array of {value.size} elements is larger than {MAX_ITEMS}")  # type: ignore[attr-defined]
        return "array", value.copy()  # type: ignore[attr-defined]
    if tv is list or tv is tuple:
        return "array", _number_array(value)  # type: ignore[arg-type]
    if tv is bytes:
        if len(value) > MAX_ITEMS:  # type: ignore[arg-type]
            raise EvalError(f"{len(value)} bytes are more than {MAX_ITEMS}")  # type: ignore[arg-type]
        return "array", value
    if tv is dict:
        return "dict", _freeze_dict(value, depth)  # type: ignore[arg-type]
    if value is None:
        raise EvalError("the value is None (a tag carries numbers, bools, text, arrays and dicts)")
    raise EvalError(
        f"a {tv.__qualname__} is not sent: a tag carries numbers, bools, text, arrays and dicts, and "
        "converting it would run code (watch one of its fields instead)"
    )


def _freeze_dict(value: dict[Any, Any], depth: int) -> dict[str, tuple[Kind, Any]]:
    if depth >= _MAX_DICT_DEPTH:
        raise EvalError(f"dicts nested deeper than {_MAX_DICT_DEPTH} are not sent")
    if len(value) > MAX_DICT_ITEMS:
        raise EvalError(f"a dict of {len(value)} keys is larger than {MAX_DICT_ITEMS}")
    out: dict[str, tuple[Kind, Any]] = {}
    for key, item in list(value.items()):
        if type(key) is not str:
            raise EvalError(f"a dict with a {type(key).__name__} key is not sent (keys must be text)")
        out[key] = freeze(item, depth + 1)
    return out
