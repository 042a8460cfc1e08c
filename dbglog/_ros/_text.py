"""How a sample's value is printed on a terminal line (``dbglog echo``, live or from a recording)."""

from __future__ import annotations

__all__ = ["format_line"]


def format_line(value: object, stamp: float | None = None) -> str:
    """Render one value for a line of output, optionally after its source time in epoch seconds.

    Bools print as ``true``/``false``, floats round-trip (``repr``), arrays as ``[a, b, ...]``.
    """
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, float):
        text = repr(value)
    elif isinstance(value, tuple):
        text = "[" + ", ".join(repr(v) for v in value) + "]"
    else:
        text = str(value)
    return text if stamp is None else f"{stamp:.6f} {text}"
