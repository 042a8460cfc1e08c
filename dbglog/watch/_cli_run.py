"""``dbglog run SCRIPT [ARGS...]`` / ``dbglog run -m MODULE [ARGS...]``: run a Python program, watchable.

The program runs in this process as its ``__main__``, as ``python SCRIPT`` / ``python -m MODULE`` runs it
(``sys.argv``, ``sys.path[0]``, exit status, tracebacks), without importing dbglog itself; the watch agent
starts first (docs/watch.md). As a ros2 launch ``prefix`` it takes what launch puts after it: an
executable script whose shebang is Python, or ``python3 SCRIPT ...``.
"""

from __future__ import annotations

import argparse
import os
import re
import runpy
import sys
import traceback
from types import TracebackType

__all__ = ["HELP", "ProgramError", "add_arguments", "resolve_program", "run"]

HELP = "Run a Python program (as python SCRIPT / python -m MODULE would) and make it watchable."

_PYTHON = re.compile(r"python[0-9]*(\.[0-9]+)*")
_PYTHON_FLAGS = {"-u": "unbuffered", "-B": "no_bytecode"}
_NOT_PYTHON_EXTENSIONS = (".sh", ".bash", ".so", ".exe")


class ProgramError(ValueError):
    """The command line does not name a Python program; the message says why."""


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``run`` options."""
    parser.add_argument(
        "-m",
        dest="module",
        action="store_true",
        help="run a module: dbglog run -m MODULE [ARGS...] (as python -m MODULE)",
    )
    parser.add_argument(
        "program",
        nargs=argparse.REMAINDER,
        metavar="SCRIPT [ARGS...]",
        help="the script and its arguments; 'python3 SCRIPT ...' and an executable with a Python shebang "
        "(what ros2 launch passes to a prefix) work too",
    )


def _is_python(arg: str) -> bool:
    if _PYTHON.fullmatch(os.path.basename(arg)):
        return True
    try:
        return os.path.realpath(arg) == os.path.realpath(sys.executable)
    except OSError:
        return False


def resolve_program(argv: list[str], module: bool) -> tuple[str, str, list[str], set[str]]:
    """Return (``script`` or ``module``, the script path or module name, its argv, python flags used).

    Accepts ``SCRIPT ARGS``, ``-m MODULE ARGS`` (`module`), and either after a ``python3`` (with ``-u``,
    ``-B`` or ``-m`` among python's own options).

    Raises:
        ProgramError: nothing to run, an unsupported python option, or not a Python program.
    """
    flags: set[str] = set()
    args = list(argv)
    if not module and args and _is_python(args[0]):
        args = args[1:]
        while args and args[0].startswith("-") and args[0] != "-":
            option = args.pop(0)
            if option == "-m":
                module = True
                break
            if option not in _PYTHON_FLAGS:
                raise ProgramError(f"python option {option} is not supported by dbglog run (only -u, -B, -m)")
            flags.add(_PYTHON_FLAGS[option])
    if not args:
        raise ProgramError(
            "nothing to run: give a script (dbglog run SCRIPT) or a module (dbglog run -m MODULE)"
        )
    target, rest = args[0], args[1:]
    if module:
        return "module", target, rest, flags
    if not os.path.exists(target):
        raise ProgramError(f"can't open file {target!r}: no such file")
    if os.path.isfile(target) and not _python_source(target):
        raise ProgramError(
            f"{target} is not a Python program (no python shebang): only Python processes can be watched"
        )
    return "script", target, rest, flags


def _python_source(path: str) -> bool:
    if path.endswith((".py", ".pyc", ".pyw", ".pyz")):
        return True
    if path.endswith(_NOT_PYTHON_EXTENSIONS):
        return False
    try:
        with open(path, "rb") as f:
            head = f.read(256)
    except OSError:
        return True  # python would try, and say why
    if head.startswith(b"\x7fELF"):
        return False
    if head.startswith(b"#!"):
        return b"python" in head.split(b"\n", 1)[0]
    return True


def _start_agent() -> None:
    from dbglog._config import load_config

    if not load_config().enabled:
        print("dbglog run: dbglog is switched off (DBGLOG=off): the program runs unwatched", file=sys.stderr)
        return
    from dbglog.watch import _agent

    _agent.start()


def _program_frames(tb: TracebackType | None) -> TracebackType | None:
    """Skip this module's and runpy's frames, so a traceback starts in the program as python's does."""
    while tb is not None and tb.tb_frame.f_globals.get("__name__") in (__name__, "runpy"):
        tb = tb.tb_next
    return tb


def run(args: argparse.Namespace) -> int:
    """Run the program; return its exit status (SystemExit passes through, as with python)."""
    try:
        kind, target, rest, flags = resolve_program(list(args.program), bool(args.module))
    except ProgramError as exc:
        print(f"dbglog run: {exc}", file=sys.stderr)
        return 2
    if "unbuffered" in flags:
        for stream in (sys.stdout, sys.stderr):
            reconfigure = getattr(stream, "reconfigure", None)
            if reconfigure is not None:
                reconfigure(write_through=True)
    if "no_bytecode" in flags:
        sys.dont_write_bytecode = True
    if kind == "module":
        sys.argv = [target, *rest]  # run_module sets argv[0] to the module's file, as python -m does
        sys.path[0] = os.getcwd()
    else:
        path = os.path.abspath(target)
        sys.argv = [path, *rest]
        sys.path[0] = os.path.dirname(os.path.realpath(path))
    _start_agent()  # after sys.argv is the program's: its --ros-args name the robot namespace
    try:
        if kind == "module":
            runpy.run_module(target, run_name="__main__", alter_sys=True)
        else:
            runpy.run_path(os.path.abspath(target), run_name="__main__")
    except KeyboardInterrupt as exc:
        _print_exception(exc)
        return 130
    except Exception as exc:
        _print_exception(exc)
        return 1
    return 0


def _print_exception(exc: BaseException) -> None:
    tb = _program_frames(exc.__traceback__)
    if tb is None and isinstance(exc, ImportError):  # runpy found no such module (python says it so too)
        print(f"dbglog run: {exc}", file=sys.stderr)
        return
    exc.__traceback__ = tb  # the hook prints the exception's own traceback (3.12)
    try:
        sys.excepthook(type(exc), exc, tb)
    except Exception:
        traceback.print_exception(type(exc), exc, tb)
    sys.stderr.flush()
