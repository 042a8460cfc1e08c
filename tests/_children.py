"""Child processes the tests start: a viewer scenario in a fresh process, dbglog SDK code in its own node."""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from dbglog.viewer._cli._cli_view import ENGINE_START_BACKGROUND_S

ROOT = Path(__file__).resolve().parent.parent

BACKGROUND_START_S = ENGINE_START_BACKGROUND_S
"""Seconds a dbglog process under ``--cpu background`` may take to start, as `dbglog view` allows its own
engine: it runs only as fast as the CPUs others leave it, and CI's busiest moments leave it little."""


def busy_loop(seconds: float, *, nice: int = 0, cpu: int | None = None) -> str:
    """A Python script that keeps one CPU busy for `seconds`, at `nice`, pinned to `cpu` if given; it ends by
    itself, so a test killed meanwhile leaves no busy process behind."""
    lines = ["import os, time"]
    if nice:
        lines.append(f"os.nice({nice})")
    if cpu is not None:
        lines.append(f"os.sched_setaffinity(0, {{{cpu}}})")
    lines += [f"end = time.time() + {seconds}", "while time.time() < end: pass"]
    return "\n".join(lines)


def stop_child(proc: subprocess.Popen[Any], sig: int = signal.SIGINT, timeout: float = 30.0) -> str:
    """Send `sig` and wait `timeout` s for the child to end, killing it if it does not (a starved or stuck
    child must not outlive its test); return its stderr when piped, else ''."""
    proc.send_signal(sig)
    try:
        err = proc.communicate(timeout=timeout)[1]
    except subprocess.TimeoutExpired:
        proc.kill()
        err = proc.communicate(timeout=10)[1]
    return str(err or "")


def run_scenario(
    module: str, scenario: str, tmp: Path, *, timeout: float = 90, env: Mapping[str, str] | None = None
) -> None:
    """Run ``tests.<module>.run_here(scenario, tmp)`` in a fresh Python process; fail with its output.

    Dear PyGui 2.3 crashes now and then when a second context is created in one process, so each viewer
    scenario gets a process (and a Dear PyGui context) of its own.
    """
    code = (
        f"import sys; sys.path.insert(0, {str(ROOT)!r}); "
        f"from tests import {module}; {module}.run_here(sys.argv[1], sys.argv[2])"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code, scenario, str(tmp)],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        cwd=ROOT,
        env=None if env is None else dict(env),
    )
    assert proc.returncode == 0, f"scenario {scenario} failed:\n{proc.stdout}\n{proc.stderr}"


def run_sdk(
    code: str, *, timeout: float = 90, stay_until: Callable[[], bool] | None = None, stay_s: float = 30.0
) -> subprocess.CompletedProcess[str]:
    """Run dbglog SDK code (dedented) in a child process: its own node and batch writer, dbglog on.

    With `stay_until`, the child stays (its writers and their kept history with it) after `code` until
    `stay_until()` holds, at most `stay_s`: a reader that discovers it late still gets everything. A fixed
    stay was not enough: a participant that takes the id of one killed moments before is found 3 s late
    (Fast DDS), and a loaded run lost the tail of a child that left at 3 s.
    """
    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    source = textwrap.dedent(code)
    if stay_until is None:
        return subprocess.run(
            [sys.executable, "-c", source],
            env=env,
            capture_output=True,
            text=True,
            timeout=timeout,
            cwd=ROOT,
            check=False,
        )
    source += "\nimport sys as _sys\n_sys.stdin.read()  # stay until the test is done with us\n"
    with subprocess.Popen(
        [sys.executable, "-c", source],
        env=env,
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    ) as child:
        deadline = time.monotonic() + stay_s
        while child.poll() is None and not stay_until() and time.monotonic() < deadline:
            time.sleep(0.05)
        out, err = child.communicate(input="", timeout=timeout)
    return subprocess.CompletedProcess(child.args, child.returncode, out, err)


def run_dbglog(
    *args: str, timeout: float = 60, env: Mapping[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    """Run ``python -m dbglog ARGS`` to its end and return what it printed (text) and its exit code."""
    return subprocess.run(
        [sys.executable, "-m", "dbglog", *args],
        capture_output=True,
        text=True,
        timeout=timeout,
        check=False,
        env=None if env is None else dict(env),
    )
