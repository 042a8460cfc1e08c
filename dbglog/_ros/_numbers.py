"""A number given the Python type its field holds (bool, int or float): one rule for recordings and viewer."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, TypeAlias

if TYPE_CHECKING:
    import numpy as np

__all__ = ["NumberType", "as_number", "as_numbers"]

NumberType: TypeAlias = type[bool] | type[int] | type[float]
"""The Python type of a numeric field's value."""


def as_number(value: float | np.integer[Any] | np.bool_, want: NumberType) -> bool | int | float:
    """Return a Python or numpy number as `want`.

    An integer stays exact, beyond 2**53 too. In an int slot a float that is not a whole number (NaN, inf,
    2.5) stays a float rather than become a wrong int (or raise).

    Args:
        value: the number (``int``, ``float``, ``bool`` or a numpy scalar).
        want: ``bool``, ``int`` or ``float``.
    """
    if want is bool:
        return bool(value)
    if want is int and (isinstance(value, int) or float(value).is_integer()):
        return int(value)
    return float(value)


_KIND_TYPE: dict[str, NumberType] = {"f": float, "i": int, "u": int, "b": bool}
"""The Python type ``tolist`` gives the items of a numpy array of each dtype kind."""


def as_numbers(values: np.ndarray[Any, Any], want: NumberType) -> list[bool | int | float]:
    """Return a 1-D numpy array's numbers as a list of `want`, each as `as_number` gives it.

    A column that already holds `want` (float64 for a float field, int64 or uint64 for an int one) is
    ``tolist`` alone: no call per value.
    """
    items: list[bool | int | float] = values.tolist()
    if _KIND_TYPE.get(values.dtype.kind) is want:
        return items
    return [as_number(v, want) for v in items]
