"""The watch expression reader: a small language that reads a frame's variables and never runs code.

An expression is parsed with ``ast`` (``mode="eval"``), every node is checked against an allow-list, and
the tree is compiled into nested closures; nothing is given to ``eval``/``exec``. The language: names
(locals, then globals), attribute access, subscripts with constant or simple-name keys, arithmetic,
comparisons, ``and``/``or``/``not`` and ``a if c else b``. No calls, no dunder names, no lambdas or
comprehensions.

"Never runs code" is stricter than the allow-list (docs/watch.md, *Never runs code*): an operator on a
user object would call its ``__add__``/``__eq__``/``__lt__``, a subscript its ``__getitem__``, a truth
test its ``__bool__``, an attribute read a property or ``__getattr__``. So operators, subscripts and truth
tests apply only to exact built-in types whose behaviour is C code (int, float, bool, str, bytes, None,
tuple, list, dict with keys of those types, numpy arrays and scalars of numbers); attributes are read the
way ``inspect.getattr_static`` reads them (instance dicts and slots); anything else is an `EvalError`
that names the type ("would run code").

Example:
    >>> e = parse_expr("pose.x * 2")
    >>> e.evaluate({"pose": types.SimpleNamespace(x=1.5)}, {})
    3.0
"""

from __future__ import annotations

import ast
import operator
import sys
import types
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Final

__all__ = [
    "MAX_DEPTH",
    "MAX_ITEMS",
    "MAX_LENGTH",
    "MAX_NODES",
    "EvalError",
    "Expr",
    "ExprError",
    "parse_expr",
    "read_attribute",
]

MAX_LENGTH: Final = 500
"""Longest expression text, in characters."""
MAX_NODES: Final = 100
"""Most syntax nodes in one expression."""
MAX_DEPTH: Final = 20
"""Deepest nesting of syntax nodes."""
MAX_ITEMS: Final = 65_536
"""Most elements of a string, bytes or array an operator may build (and a value may carry)."""
_MAX_INT_BITS: Final = 4096
"""Largest integer ``**`` may build, in bits."""
_MAX_CONSTANT_TEXT: Final = 200
_MAX_CONSTANT_INT: Final = 2**64

Namespace = dict[str, Any]
_Fn = Callable[[Namespace, Namespace], Any]


class ExprError(ValueError):
    """An expression that is not allowed or not valid; the message says why (and where)."""

    def __init__(self, reason: str, column: int | None = None) -> None:
        self.reason = reason
        """What is wrong, without the column."""
        self.column = column
        """1-based column in the text where the problem starts (None: the whole text)."""
        super().__init__(f"column {column}: {reason}" if column is not None else reason)


class EvalError(Exception):
    """A value that cannot be read at this hit without running code (or does not exist); says why."""


_MISSING: Final = object()
_NONE_TYPE: Final = type(None)
_NUMBERS: Final = frozenset({int, float, bool})
_TEXTS: Final = frozenset({str, bytes})
_COMPARABLE: Final = _NUMBERS | _TEXTS | {_NONE_TYPE}
_TRUTHY: Final = _COMPARABLE | {list, tuple, dict}
_KEYS: Final = _COMPARABLE
_SEQUENCES: Final = frozenset({list, tuple, str, bytes})
_type_mro: Final = type.__dict__["__mro__"].__get__
_type_dict: Final = type.__dict__["__dict__"].__get__
_module_dict: Final = vars(types.ModuleType)["__dict__"].__get__
_DICT_DESCRIPTORS: Final = (types.GetSetDescriptorType, types.MemberDescriptorType)


# ---------------------------------------------------------------------------------------------------------
# numpy: allowed when the program loaded it (its arrays and scalars of numbers run C code only).


class _Numpy:
    """numpy's array and numeric scalar types, looked up once numpy is loaded (never imported here)."""

    def __init__(self) -> None:
        self.module: Any = None
        self.scalars: frozenset[type] = frozenset()

    def load(self) -> Any:
        np = self.module
        if np is None:
            np = sys.modules.get("numpy")
            if np is None:
                return None
            self.scalars = frozenset(
                t
                for t in set(np.sctypeDict.values())
                if isinstance(t, type) and np.dtype(t).kind in "biuf" and t.__module__ == "numpy"
            )
            self.module = np
        return np

    def array(self, value: object) -> bool:
        """True for an exact numpy array of bools or numbers."""
        np = self.load()
        return np is not None and type(value) is np.ndarray and value.dtype.kind in "biuf"  # type: ignore[attr-defined]

    def scalar(self, value: object) -> bool:
        """True for an exact numpy scalar of a bool or number type."""
        return self.load() is not None and type(value) in self.scalars

    def either(self, value: object) -> bool:
        """True for a numpy array or scalar of numbers."""
        return self.scalar(value) or self.array(value)


NUMPY: Final = _Numpy()


def _size(value: object) -> int:
    """Elements in a numpy array (1 for a scalar)."""
    return int(getattr(value, "size", 1)) if NUMPY.array(value) else 1


def _numpy_op(fn: Callable[..., Any], *args: Any) -> Any:
    """Apply `fn` to numpy operands with numpy's floating-point warnings off (they would reach the
    program's own warning filters)."""
    np = NUMPY.load()
    with np.errstate(all="ignore"):
        return fn(*args)


def _name(t: type) -> str:
    return str(type.__dict__["__qualname__"].__get__(t))


# ---------------------------------------------------------------------------------------------------------
# Static attribute reads.


def _static_lookup(tp: type, name: str) -> object:
    """Return `name` from the first class of `tp`'s MRO whose own dict holds it, else `_MISSING`."""
    for klass in _type_mro(tp):
        d = _type_dict(klass)
        if name in d:
            return d[name]
    return _MISSING


def _describe(found: object) -> str:
    """Say what kind of class attribute `found` is, for a refusal."""
    kinds = {property: "property", staticmethod: "static method", classmethod: "class method"}
    kind = kinds.get(type(found))
    if kind is not None:
        return f"a {kind}"
    if type(found) in (types.FunctionType, types.BuiltinFunctionType, types.MethodDescriptorType):
        return "a method"
    return f"a descriptor ({_name(type(found))})"


@dataclass(frozen=True, slots=True)
class _Plan:
    """How to read one attribute name from instances of one type."""

    slot: Any = None
    """A ``__slots__`` member descriptor: read with its C ``__get__``."""
    dict_descriptor: Any = None
    """The type's ``__dict__`` descriptor (C): the instance dict is read first."""
    class_value: object = _MISSING
    """A plain class attribute (no ``__get__``), the value when the instance dict lacks the name."""
    refuse: str | None = None
    """Why reading it would run code: said when the instance dict lacks the name (or at once if
    `dict_first` is False)."""
    dict_first: bool = True
    """False for a data descriptor (a property): it wins over the instance dict, so it is refused."""


def _plan(tp: type, name: str) -> _Plan:
    """Work out how to read `name` from a `tp` instance without running code (getattr_static's rules)."""
    owner = _name(tp)
    found = _static_lookup(tp, name)
    descriptor = _static_lookup(tp, "__dict__")
    dict_descriptor = descriptor if type(descriptor) in _DICT_DESCRIPTORS else None
    getattr_hook = _static_lookup(tp, "__getattr__")
    missing = (
        f"{owner}.__getattr__ would run code to find {name!r}"
        if getattr_hook is not _MISSING
        else f"{owner} object has no attribute {name!r}"
    )
    if found is _MISSING:
        return _Plan(dict_descriptor=dict_descriptor, refuse=missing)
    kind = type(found)
    if kind is types.MemberDescriptorType:
        return _Plan(slot=found)
    if _static_lookup(kind, "__get__") is _MISSING:
        return _Plan(dict_descriptor=dict_descriptor, class_value=found)
    data = (
        _static_lookup(kind, "__set__") is not _MISSING or _static_lookup(kind, "__delete__") is not _MISSING
    )
    refuse = f"{owner}.{name} is {_describe(found)}: reading it would run code"
    return _Plan(dict_descriptor=dict_descriptor, refuse=refuse, dict_first=not data)


def _read_class_attribute(cls: type, name: str) -> object:
    """Read `name` from a class object: a plain class attribute only."""
    meta = _static_lookup(type(cls), name)
    if meta is not _MISSING and _static_lookup(type(meta), "__get__") is not _MISSING:
        raise EvalError(f"{_name(type(cls))}.{name} is {_describe(meta)}: reading it would run code")
    found = _static_lookup(cls, name)
    if found is _MISSING:
        raise EvalError(f"class {_name(cls)} has no attribute {name!r}")
    if _static_lookup(type(found), "__get__") is not _MISSING:
        raise EvalError(f"{_name(cls)}.{name} is {_describe(found)}: reading it would run code")
    return found


def read_attribute(obj: object, name: str, cache: dict[type, _Plan] | None = None) -> object:
    """Read attribute `name` of `obj` from its instance dict or slots only; never run code.

    A property, ``__getattr__``, ``__getattribute__`` or other descriptor is never invoked: an
    `EvalError` says "would run code". A plain class attribute (a constant) is read like Python reads it.

    Args:
        obj: any object.
        name: the attribute's name.
        cache: type -> plan, kept by the caller (one per attribute of an expression).

    Raises:
        EvalError: the attribute does not exist, or reading it would run code.
    """
    tp = type(obj)
    if tp is types.ModuleType:
        namespace = _module_dict(obj)
        try:
            return namespace[name]
        except KeyError:
            pass
        if "__getattr__" in namespace:
            raise EvalError(f"module {namespace.get('__name__')!s}'s __getattr__ would run code for {name!r}")
        raise EvalError(f"module {namespace.get('__name__')!s} has no attribute {name!r}") from None
    if issubclass(tp, type):
        return _read_class_attribute(obj, name)  # type: ignore[arg-type]
    plan = None if cache is None else cache.get(tp)
    if plan is None:
        plan = _plan(tp, name)
        if cache is not None and len(cache) < 16:
            cache[tp] = plan
    if plan.slot is not None:
        try:
            return plan.slot.__get__(obj, tp)
        except AttributeError:
            raise EvalError(f"{_name(tp)}.{name} is not set") from None
    if not plan.dict_first:
        raise EvalError(plan.refuse)
    if plan.dict_descriptor is not None:
        instance_dict = plan.dict_descriptor.__get__(obj, tp)
        if type(instance_dict) is dict:
            value = instance_dict.get(name, _MISSING)
            if value is not _MISSING:
                return value
    if plan.class_value is not _MISSING:
        return plan.class_value
    raise EvalError(plan.refuse)


# ---------------------------------------------------------------------------------------------------------
# Values the operators accept.


def truth(value: object) -> bool:
    """Return the truth of `value` when it runs no code (built-in scalars and containers, numpy)."""
    if type(value) in _TRUTHY or NUMPY.scalar(value):
        return bool(value)
    if NUMPY.array(value):
        try:
            return bool(value)
        except ValueError as exc:
            raise EvalError(f"the truth of an array is ambiguous ({exc})") from None
    raise EvalError(f"testing a {_name(type(value))} for truth would run code (its __bool__ or __len__)")


def _check_key(key: object) -> None:
    tk = type(key)
    if tk in _KEYS:
        return
    if tk is tuple and len(key) <= 8:  # type: ignore[arg-type]
        for item in key:  # type: ignore[attr-defined]
            _check_key(item)
        return
    raise EvalError(f"a {_name(tk)} key would run code (its __hash__ and __eq__)")


def _subscript(obj: object, key: object) -> object:
    tp = type(obj)
    if tp is dict:
        _check_key(key)
        try:
            return obj[key]  # type: ignore[index]
        except KeyError:
            raise EvalError(f"key {key!r} is not in the dict") from None
    if tp in _SEQUENCES:
        if type(key) is not int:
            raise EvalError(f"a {_name(tp)} index must be an int, not {_name(type(key))}")
        try:
            return obj[key]  # type: ignore[index]
        except IndexError:
            raise EvalError(f"index {key} is out of range (length {len(obj)})") from None  # type: ignore[arg-type]
    if NUMPY.array(obj):
        keys = key if type(key) is tuple else (key,)
        if not all(type(k) is int for k in keys):
            raise EvalError("a numpy array index must be an int or a tuple of ints")
        try:
            return obj[key]  # type: ignore[index]
        except IndexError as exc:
            raise EvalError(f"index {key!r}: {exc}") from None
    raise EvalError(f"{_name(tp)}[...] would run code (its __getitem__)")


def _pow_check(a: object, b: object) -> None:
    if type(a) is int and type(b) is int and b > 0 and a not in (0, 1, -1):
        if a.bit_length() * b > _MAX_INT_BITS:
            raise EvalError(f"{a} ** {b} is too large (more than {_MAX_INT_BITS} bits)")
        return
    if type(b) in _NUMBERS and abs(b) > 1e6 and type(a) is int and abs(a) > 1:  # type: ignore[arg-type]
        raise EvalError(f"{a} ** {b} is too large")


def _repeat_check(a: object, b: object) -> None:
    text, count = (a, b) if type(a) in _TEXTS else (b, a)
    if type(count) is not int:
        return
    if len(text) * max(count, 0) > MAX_ITEMS:  # type: ignore[arg-type]
        raise EvalError(f"the result would hold more than {MAX_ITEMS} characters")


_BINOPS: Final[dict[type[ast.operator], tuple[str, Callable[[Any, Any], Any]]]] = {
    ast.Add: ("+", operator.add),
    ast.Sub: ("-", operator.sub),
    ast.Mult: ("*", operator.mul),
    ast.Div: ("/", operator.truediv),
    ast.FloorDiv: ("//", operator.floordiv),
    ast.Mod: ("%", operator.mod),
    ast.Pow: ("**", operator.pow),
    ast.BitAnd: ("&", operator.and_),
    ast.BitOr: ("|", operator.or_),
    ast.BitXor: ("^", operator.xor),
}
_BITWISE: Final = frozenset({"&", "|", "^"})
_ARITH_ERRORS: Final = (ZeroDivisionError, OverflowError, ValueError, TypeError, ArithmeticError)


def _binop(symbol: str, fn: Callable[[Any, Any], Any], a: object, b: object) -> object:
    ta, tb = type(a), type(b)
    try:
        if ta in _NUMBERS and tb in _NUMBERS:
            if symbol in _BITWISE and (ta is float or tb is float):
                raise EvalError(f"{_name(ta)} {symbol} {_name(tb)}: bitwise operators take ints")
            if symbol == "**":
                _pow_check(a, b)
            return fn(a, b)
        if symbol == "+" and ta is tb and ta in _TEXTS:
            if len(a) + len(b) > MAX_ITEMS:  # type: ignore[arg-type]
                raise EvalError(f"the result would hold more than {MAX_ITEMS} characters")
            return fn(a, b)
        if symbol == "*" and ({ta, tb} in ({str, int}, {bytes, int})):
            _repeat_check(a, b)
            return fn(a, b)
        if (NUMPY.either(a) or ta in _NUMBERS) and (NUMPY.either(b) or tb in _NUMBERS):
            if max(_size(a), _size(b)) > MAX_ITEMS:
                raise EvalError(f"arrays of more than {MAX_ITEMS} elements are not computed on")
            return _numpy_op(fn, a, b)
    except _ARITH_ERRORS as exc:
        raise EvalError(f"{_name(ta)} {symbol} {_name(tb)}: {type(exc).__name__}: {exc}") from None
    if symbol == "%" and ta in _TEXTS:
        raise EvalError("'%' formatting of text would run code (the values' __str__/__repr__)")
    raise EvalError(f"{_name(ta)} {symbol} {_name(tb)} would run code (only numbers, text and numpy arrays)")


_COMPARE: Final[dict[type[ast.cmpop], tuple[str, Callable[[Any, Any], Any]]]] = {
    ast.Eq: ("==", operator.eq),
    ast.NotEq: ("!=", operator.ne),
    ast.Lt: ("<", operator.lt),
    ast.LtE: ("<=", operator.le),
    ast.Gt: (">", operator.gt),
    ast.GtE: (">=", operator.ge),
    ast.Is: ("is", operator.is_),
    ast.IsNot: ("is not", operator.is_not),
}


def _compare(symbol: str, fn: Callable[[Any, Any], Any], a: object, b: object) -> object:
    if symbol in ("is", "is not"):
        return fn(a, b)  # identity: no code
    ta, tb = type(a), type(b)
    try:
        if ta in _COMPARABLE and tb in _COMPARABLE:
            return fn(a, b)
        if (NUMPY.either(a) or ta in _NUMBERS) and (NUMPY.either(b) or tb in _NUMBERS):
            return _numpy_op(fn, a, b)
    except (TypeError, ValueError) as exc:
        raise EvalError(f"{_name(ta)} {symbol} {_name(tb)}: {exc}") from None
    raise EvalError(
        f"{_name(ta)} {symbol} {_name(tb)} would run code (only numbers, text, None and numpy arrays "
        "compare; 'is' compares anything)"
    )


def _unary(kind: type[ast.unaryop], value: object) -> object:
    tv = type(value)
    if kind is ast.Not:
        return not truth(value)
    if kind is ast.Invert:
        if tv is int or tv is bool:
            return ~value  # type: ignore[operator]
        raise EvalError(f"~ takes an int, not a {_name(tv)}")
    if tv in _NUMBERS:
        return -value if kind is ast.USub else +value  # type: ignore[operator]
    if NUMPY.either(value):
        return _numpy_op(operator.neg if kind is ast.USub else operator.pos, value)
    raise EvalError(f"{'-' if kind is ast.USub else '+'}{_name(tv)} would run code (only numbers)")


# ---------------------------------------------------------------------------------------------------------
# The checker and compiler.

_FORBIDDEN: Final[dict[type[ast.AST], str]] = {
    ast.Call: "calls are not allowed (a watch never runs code)",
    ast.Lambda: "lambdas are not allowed",
    ast.ListComp: "comprehensions are not allowed",
    ast.SetComp: "comprehensions are not allowed",
    ast.DictComp: "comprehensions are not allowed",
    ast.GeneratorExp: "generator expressions are not allowed",
    ast.JoinedStr: "f-strings are not allowed (formatting would run code)",
    ast.FormattedValue: "f-strings are not allowed (formatting would run code)",
    ast.NamedExpr: "':=' is not allowed (a watch never writes)",
    ast.Starred: "'*' unpacking is not allowed",
    ast.List: "list displays are not allowed",
    ast.Tuple: "tuples are allowed only as subscript keys",
    ast.Set: "set displays are not allowed",
    ast.Dict: "dict displays are not allowed",
    ast.Await: "'await' is not allowed",
    ast.Yield: "'yield' is not allowed",
    ast.YieldFrom: "'yield' is not allowed",
    ast.Slice: "slices are not allowed",
}


def _dunder(name: str) -> bool:
    return name.startswith("__") and name.endswith("__")


@dataclass(frozen=True, slots=True)
class Expr:
    """A checked, compiled expression."""

    text: str
    names: frozenset[str]
    """The variable names it reads."""
    _fn: _Fn

    def evaluate(self, local_ns: Namespace, global_ns: Namespace) -> object:
        """Evaluate against a frame's locals and globals (exact dicts).

        Raises:
            EvalError: a name is not defined, or reading a value would run code.
        """
        if type(local_ns) is not dict or type(global_ns) is not dict:
            raise EvalError("this frame's namespace is not a plain dict (reading it would run code)")
        return self._fn(local_ns, global_ns)

    def truth(self, local_ns: Namespace, global_ns: Namespace) -> bool:
        """Evaluate as a condition (``--when``).

        Raises:
            EvalError: as `evaluate`, or the value's truth would run code.
        """
        return truth(self.evaluate(local_ns, global_ns))


class _Compiler:
    def __init__(self) -> None:
        self.nodes = 0
        self.names: set[str] = set()

    def fail(self, node: ast.AST, reason: str) -> ExprError:
        return ExprError(reason, int(getattr(node, "col_offset", 0)) + 1)

    def compile(self, node: ast.AST, depth: int = 0) -> _Fn:
        self.nodes += 1
        if self.nodes > MAX_NODES:
            raise self.fail(node, f"the expression has more than {MAX_NODES} parts")
        if depth > MAX_DEPTH:
            raise self.fail(node, f"the expression nests deeper than {MAX_DEPTH}")
        reason = _FORBIDDEN.get(type(node))
        if reason is not None:
            raise self.fail(node, reason)
        method = self._methods().get(type(node))
        if method is None:
            raise self.fail(node, f"{type(node).__name__} is not allowed in a watch expression")
        fn: _Fn = method(node, depth + 1)
        return fn

    def _methods(self) -> dict[type[ast.AST], Callable[[Any, int], _Fn]]:
        return {
            ast.Constant: self._constant,
            ast.Name: self._name_node,
            ast.Attribute: self._attribute,
            ast.Subscript: self._subscript_node,
            ast.BinOp: self._binop_node,
            ast.UnaryOp: self._unary_node,
            ast.BoolOp: self._boolop,
            ast.Compare: self._compare_node,
            ast.IfExp: self._ifexp,
        }

    def _constant(self, node: ast.Constant, depth: int) -> _Fn:
        value: Any = node.value
        kind = type(value)
        if kind not in _COMPARABLE:
            raise self.fail(node, f"a {kind.__name__} constant is not allowed")
        if kind in _TEXTS and len(value) > _MAX_CONSTANT_TEXT:
            raise self.fail(node, f"text constants are at most {_MAX_CONSTANT_TEXT} characters")
        if kind is int and abs(value) > _MAX_CONSTANT_INT:
            raise self.fail(node, "the integer constant is too large")
        return lambda _ln, _gn: value

    def _name_node(self, node: ast.Name, depth: int) -> _Fn:
        name = node.id
        if _dunder(name):
            raise self.fail(node, f"dunder names ({name}) are not allowed")
        self.names.add(name)

        def read(local_ns: Namespace, global_ns: Namespace) -> object:
            value = local_ns.get(name, _MISSING)
            if value is _MISSING:
                value = global_ns.get(name, _MISSING)
                if value is _MISSING:
                    raise EvalError(f"name {name!r} is not defined here")
            return value

        return read

    def _attribute(self, node: ast.Attribute, depth: int) -> _Fn:
        attr = node.attr
        if _dunder(attr):
            raise self.fail(node, f"dunder attributes (.{attr}) are not allowed")
        base = self.compile(node.value, depth)
        cache: dict[type, _Plan] = {}

        def read(local_ns: Namespace, global_ns: Namespace) -> object:
            return read_attribute(base(local_ns, global_ns), attr, cache)

        return read

    def _key(self, node: ast.expr, depth: int) -> _Fn:
        """A subscript key: a constant, a negative number, a simple name, or a tuple of those."""
        if isinstance(node, ast.Tuple):
            if len(node.elts) > 8:
                raise self.fail(node, "a subscript key has at most 8 parts")
            parts = [self._key(elt, depth + 1) for elt in node.elts]
            self.nodes += 1
            return lambda ln, gn: tuple(p(ln, gn) for p in parts)
        if isinstance(node, ast.Constant | ast.Name):
            return self.compile(node, depth)
        if (
            isinstance(node, ast.UnaryOp)
            and isinstance(node.op, ast.USub)
            and isinstance(node.operand, ast.Constant)
            and type(node.operand.value) in (int, float)
        ):
            return self.compile(node, depth)
        if isinstance(node, ast.Slice):
            raise self.fail(node, _FORBIDDEN[ast.Slice])
        raise self.fail(node, "a subscript key must be a constant or a simple name")

    def _subscript_node(self, node: ast.Subscript, depth: int) -> _Fn:
        base = self.compile(node.value, depth)
        key = self._key(node.slice, depth)
        return lambda ln, gn: _subscript(base(ln, gn), key(ln, gn))

    def _binop_node(self, node: ast.BinOp, depth: int) -> _Fn:
        entry = _BINOPS.get(type(node.op))
        if entry is None:
            raise self.fail(node, f"the operator {type(node.op).__name__} is not allowed")
        symbol, fn = entry
        left, right = self.compile(node.left, depth), self.compile(node.right, depth)
        return lambda ln, gn: _binop(symbol, fn, left(ln, gn), right(ln, gn))

    def _unary_node(self, node: ast.UnaryOp, depth: int) -> _Fn:
        kind = type(node.op)
        operand = self.compile(node.operand, depth)
        return lambda ln, gn: _unary(kind, operand(ln, gn))

    def _boolop(self, node: ast.BoolOp, depth: int) -> _Fn:
        parts = [self.compile(v, depth) for v in node.values]
        if isinstance(node.op, ast.And):

            def both(ln: Namespace, gn: Namespace) -> object:
                value: object = None
                for part in parts:
                    value = part(ln, gn)
                    if not truth(value):
                        return value
                return value

            return both

        def either(ln: Namespace, gn: Namespace) -> object:
            value: object = None
            for part in parts:
                value = part(ln, gn)
                if truth(value):
                    return value
            return value

        return either

    def _compare_node(self, node: ast.Compare, depth: int) -> _Fn:
        ops: list[tuple[str, Callable[[Any, Any], Any]]] = []
        for op in node.ops:
            entry = _COMPARE.get(type(op))
            if entry is None:
                raise self.fail(node, f"'{'not in' if isinstance(op, ast.NotIn) else 'in'}' is not allowed")
            ops.append(entry)
        first = self.compile(node.left, depth)
        rest = [self.compile(c, depth) for c in node.comparators]
        if len(ops) == 1:
            (symbol, fn), right = ops[0], rest[0]
            return lambda ln, gn: _compare(symbol, fn, first(ln, gn), right(ln, gn))

        def chain(ln: Namespace, gn: Namespace) -> object:
            left = first(ln, gn)
            result: object = True
            for (symbol, fn), part in zip(ops, rest, strict=True):
                right = part(ln, gn)
                result = _compare(symbol, fn, left, right)
                if not truth(result):
                    return result
                left = right
            return result

        return chain

    def _ifexp(self, node: ast.IfExp, depth: int) -> _Fn:
        test, body, orelse = (self.compile(n, depth) for n in (node.test, node.body, node.orelse))
        return lambda ln, gn: body(ln, gn) if truth(test(ln, gn)) else orelse(ln, gn)


def parse_expr(text: str) -> Expr:
    """Check `text` against the watch language and compile it.

    Raises:
        ExprError: it is not an expression of the language; the message says what is not allowed.
    """
    if not isinstance(text, str):
        raise ExprError(f"an expression must be text, not {type(text).__name__}")
    stripped = text.strip()
    if not stripped:
        raise ExprError("the expression is empty")
    if len(stripped) > MAX_LENGTH:
        raise ExprError(f"the expression is longer than {MAX_LENGTH} characters")
    try:
        tree = ast.parse(stripped, mode="eval")
    except SyntaxError as exc:
        raise ExprError(f"not a Python expression: {exc.msg}", exc.offset) from None
    except (ValueError, RecursionError, MemoryError) as exc:
        raise ExprError(f"not a Python expression: {exc}") from None
    compiler = _Compiler()
    fn = compiler.compile(tree.body)
    return Expr(stripped, frozenset(compiler.names), fn)
