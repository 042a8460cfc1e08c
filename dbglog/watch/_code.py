"""Where a watch goes: the source files a process has loaded and the code objects that hold a line.

A line's code objects are found without running the program's code: from the modules' namespaces
(functions, classes and their methods, properties, ``__wrapped__`` chains), every thread's running
frames (a script's module-level loop has no function), and, recursively, the code objects nested in
those (inner functions, lambdas, comprehensions). A function defined in a loop is a new function object
around the same code object, so one watch covers every copy.
"""

from __future__ import annotations

import contextlib
import os
import site
import sys
import sysconfig
import tokenize
import types
from collections.abc import Iterable, Iterator
from dataclasses import dataclass
from typing import Any, Final

__all__ = [
    "CodeLookupError",
    "Located",
    "find_file",
    "loaded_files",
    "locate",
    "names_at",
    "read_source",
    "user_file",
]

MAX_SOURCE_BYTES: Final = 8 << 20
"""A larger file is not read (its lines are not sent)."""
_COMPREHENSIONS: Final = frozenset({"<listcomp>", "<dictcomp>", "<setcomp>", "<genexpr>"})
_MAX_NAMES: Final = 500
_COMPILED: Final = (".pyc", ".pyo", ".so", ".pyd", ".dll", ".dylib")
_func_dict: Final = vars(types.FunctionType)["__dict__"].__get__
_module_dict: Final = vars(types.ModuleType)["__dict__"].__get__
_type_dict: Final = type.__dict__["__dict__"].__get__
_DBGLOG_DIR: Final = os.path.dirname(os.path.dirname(os.path.abspath(__file__))) + os.sep


class CodeLookupError(LookupError):
    """A file or line that the process cannot watch; `state` says which (``no_file``, ``no_line``)."""

    def __init__(self, state: str, message: str) -> None:
        self.state = state
        super().__init__(message)


def _real(path: str) -> str:
    try:
        return os.path.realpath(path)
    except (OSError, ValueError):
        return path


def _system_dirs() -> tuple[str, ...]:
    dirs: set[str] = set()
    for key in ("stdlib", "platstdlib", "purelib", "platlib"):
        with contextlib.suppress(Exception):
            dirs.add(sysconfig.get_paths()[key])
    with contextlib.suppress(Exception):
        dirs.update(site.getsitepackages())
    with contextlib.suppress(Exception):
        dirs.add(site.getusersitepackages())
    dirs.update(("/opt/ros", "/usr/lib/python3", "/usr/local/lib/python3"))
    return tuple(sorted({_real(d).rstrip(os.sep) + os.sep for d in dirs if d}))


_SYSTEM: tuple[str, ...] | None = None


def user_file(path: str) -> bool:
    """True for a file of the user's tree: not the standard library, an installed package or dbglog."""
    global _SYSTEM
    if _SYSTEM is None:
        _SYSTEM = _system_dirs()
    real = _real(path)
    return not real.startswith(_DBGLOG_DIR) and not any(real.startswith(d) for d in _SYSTEM)


def _source_file(name: object) -> str | None:
    """The absolute path of a module's ``__file__`` or a code object's file, if it is Python source."""
    if not isinstance(name, str) or not name or name.startswith("<") or name.endswith(_COMPILED):
        return None
    return os.path.abspath(name)


def _frames() -> Iterator[types.FrameType]:
    """Every frame of every thread, innermost first."""
    for top in list(sys._current_frames().values()):
        frame: types.FrameType | None = top
        while frame is not None:
            yield frame
            frame = frame.f_back


def loaded_files() -> dict[str, list[types.ModuleType]]:
    """Return each loaded Python source file (absolute path) with the modules loaded from it."""
    files: dict[str, list[types.ModuleType]] = {}
    entries: list[object] = list(sys.modules.values())  # a lazy loader may stand in for a module there
    for module in entries:
        if not isinstance(module, types.ModuleType):
            continue
        name = _source_file(_module_dict(module).get("__file__"))
        if name is not None:
            files.setdefault(name, []).append(module)
    for frame in _frames():
        name = _source_file(frame.f_code.co_filename)
        if name is not None:
            files.setdefault(name, [])
    return files


def find_file(wanted: str, files: Iterable[str], local_path: str | None = None) -> str:
    """Return the one loaded file that `wanted` names: the same path, or the only one it is a suffix of
    (or the only one of the user's tree among those).

    Args:
        wanted: a path (absolute, or relative as the watcher typed it) or a unique suffix (``node.py``,
            ``pkg/node.py``).
        files: the loaded files (absolute paths).
        local_path: the watcher's own absolute path for `wanted`, when it exists on the watcher's machine.

    Raises:
        CodeLookupError: no loaded file matches, or several do.
    """
    paths = list(files)
    for exact in (wanted, local_path):
        if exact and os.path.isabs(exact):
            real = _real(exact)
            for path in paths:
                if path == exact or _real(path) == real:
                    return path
    suffix = os.path.normpath(wanted).lstrip(os.sep)
    while suffix.startswith(".." + os.sep):
        suffix = suffix[3:]
    if suffix in ("", "."):
        raise CodeLookupError("no_file", f"{wanted!r} names no file")
    matches = sorted({p for p in paths if p == suffix or p.endswith(os.sep + suffix)})
    if len(matches) > 1:  # `node.py` means the user's node.py, not rclpy's
        mine = [p for p in matches if user_file(p)]
        matches = mine if len(mine) == 1 else matches
    if len(matches) == 1:
        return matches[0]
    if matches:
        shown = ", ".join(matches[:5]) + (f" and {len(matches) - 5} more" if len(matches) > 5 else "")
        raise CodeLookupError(
            "no_file", f"{wanted} matches several loaded files ({shown}): give more of its path"
        )
    raise CodeLookupError("no_file", f"this process has loaded no file {wanted}")


def _walk_codes(code: types.CodeType, path: str, seen: set[types.CodeType]) -> None:
    if code in seen or (code.co_filename != path and _source_file(code.co_filename) != path):
        return
    seen.add(code)
    for const in code.co_consts:
        if type(const) is types.CodeType:
            _walk_codes(const, path, seen)


def _function_codes(fn: object, depth: int = 0) -> Iterator[types.CodeType]:
    """The code of a function, and of the functions it wraps (``functools.wraps``'s ``__wrapped__``)."""
    while type(fn) is types.FunctionType and depth < 8:
        yield fn.__code__
        fn = _func_dict(fn).get("__wrapped__")
        depth += 1


def _namespace_codes(
    namespace: dict[str, Any], module_name: object, depth: int = 0
) -> Iterator[types.CodeType]:
    """Code objects of the functions, methods and properties in a module's or class's namespace."""
    for value in list(namespace.values()):
        kind = type(value)
        if kind is types.FunctionType:
            yield from _function_codes(value)
        elif kind in (staticmethod, classmethod):
            yield from _function_codes(value.__func__)
        elif kind is property:
            for fn in (value.fget, value.fset, value.fdel):
                yield from _function_codes(fn)
        elif isinstance(value, type) and depth < 4:
            own = _type_dict(value)
            if own.get("__module__") == module_name:  # defined here, not imported
                yield from _namespace_codes(dict(own), module_name, depth + 1)


@dataclass(frozen=True, slots=True)
class Located:
    """A file's line and the code objects whose instructions are on it."""

    path: str
    line: int
    codes: tuple[types.CodeType, ...]


def _codes_of(path: str, modules: list[types.ModuleType]) -> set[types.CodeType]:
    seen: set[types.CodeType] = set()
    for module in modules:
        namespace = _module_dict(module)
        for code in _namespace_codes(namespace, namespace.get("__name__")):
            _walk_codes(code, path, seen)
    for frame in _frames():
        _walk_codes(frame.f_code, path, seen)
    return seen


def _lines_of(code: types.CodeType) -> set[int]:
    return {line for _start, _end, line in code.co_lines() if line is not None}


def locate(path: str, line: int, modules: list[types.ModuleType]) -> Located:
    """Return the code objects of loaded file `path` that have instructions on `line`.

    Comprehensions count only when nothing else has the line (a line that builds a list is one hit).

    Raises:
        CodeLookupError: ``no_line``: nothing loaded runs that line; the message says why.
    """
    codes = [c for c in _codes_of(path, modules) if line in _lines_of(c)]
    plain = [c for c in codes if c.co_name not in _COMPREHENSIONS]
    found = tuple(plain or codes)
    if found:
        return Located(path, line, found)
    total = _count_lines(path)
    if total is not None and not 1 <= line <= total:
        raise CodeLookupError("no_line", f"{path} has {total} lines: there is no line {line}")
    raise CodeLookupError(
        "no_line",
        f"line {line} of {path} holds no code that can still run (a blank line, a comment, a docstring, "
        "or module-level code that has finished)",
    )


def _count_lines(path: str) -> int | None:
    try:
        return len(read_source(path))
    except OSError:
        return None


def read_source(path: str) -> list[str]:
    """Return the file's lines (as on disk now, decoded as Python reads source), without line ends.

    Raises:
        OSError: the file cannot be read, or is larger than `MAX_SOURCE_BYTES`.
    """
    if os.path.getsize(path) > MAX_SOURCE_BYTES:
        raise OSError(f"{path} is larger than {MAX_SOURCE_BYTES >> 20} MiB")
    try:
        with tokenize.open(path) as f:
            return f.read().splitlines()
    except (SyntaxError, UnicodeDecodeError) as exc:
        raise OSError(f"{path} cannot be decoded: {exc}") from None


def names_at(located: Located, modules: list[types.ModuleType]) -> tuple[list[str], list[str]]:
    """Return the local names of the line's innermost code and the module's global names (sorted)."""
    local: set[str] = set()
    for code in located.codes:
        if code.co_name == "<module>":
            continue
        local.update(code.co_varnames, code.co_cellvars, code.co_freevars)
    globals_: set[str] = set()
    for module in modules:
        globals_.update(k for k in list(_module_dict(module)) if isinstance(k, str))
    keep = [n for n in sorted(local) if n.isidentifier() and not (n.startswith("__") and n.endswith("__"))]
    glob = [n for n in sorted(globals_ - local) if not (n.startswith("__") and n.endswith("__"))]
    return keep[:_MAX_NAMES], glob[:_MAX_NAMES]
