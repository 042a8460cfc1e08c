"""`set_cpu_policy`: a dbglog process steps aside for the robot (SCHED_IDLE), all of its threads.

Each case runs in a child process, so the test runner's own policy is never touched.
"""

from __future__ import annotations

import argparse
import functools
import os
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import pytest

from dbglog._sched import CPU_ENV, CpuPolicy, add_cpu_argument
from tests._children import BACKGROUND_START_S, run_dbglog, stop_child
from tests._ros import wait_until

pytestmark = pytest.mark.skipif(not hasattr(os, "SCHED_IDLE"), reason="SCHED_IDLE is Linux's")

CHILD = textwrap.dedent(
    """
    import os, sys, threading
    from pathlib import Path
    from dbglog._sched import CpuPolicy, set_cpu_policy

    def policies():
        return sorted({os.sched_getscheduler(int(t.name)) for t in Path("/proc/self/task").iterdir()})

    stop = threading.Event()
    before = threading.Thread(target=stop.wait)  # a thread that already runs
    before.start()
    print("start", policies(), flush=True)
    print("refused", set_cpu_policy(CpuPolicy(sys.argv[1])), flush=True)
    after = threading.Thread(target=stop.wait)  # and one started afterwards
    after.start()
    print("end", policies(), flush=True)
    stop.set()
    """
)


def run_child(policy: str, *prefix: str) -> dict[str, str]:
    """Run CHILD with `policy` (under the `prefix` command, e.g. chrt); its lines by their first word."""
    done = subprocess.run(
        [*prefix, sys.executable, "-c", CHILD, policy], capture_output=True, text=True, timeout=60, check=True
    )
    return dict(line.split(" ", 1) for line in done.stdout.splitlines())


def test_background_puts_every_thread_under_sched_idle_and_normal_brings_them_back() -> None:
    """Background: the threads that run and those started later are SCHED_IDLE; normal: SCHED_OTHER."""
    out = run_child("background")
    assert out["start"] == str([os.SCHED_OTHER])
    assert out["refused"] == "None"
    assert out["end"] == str([os.SCHED_IDLE]), "every thread, the one already running and the new one"
    assert shutil.which("chrt"), "util-linux's chrt starts the child in the background"
    out = run_child("normal", "chrt", "--idle", "0")
    assert out["start"] == str([os.SCHED_IDLE])
    assert out["end"] == str([os.SCHED_OTHER])


def test_a_policy_the_user_chose_stands() -> None:
    """A process started under SCHED_BATCH (chrt --batch) keeps it: only the two ordinary policies move."""
    out = run_child("background", "chrt", "--batch", "0")
    assert out["start"] == str([os.SCHED_BATCH])
    assert out["refused"] == "None"
    assert out["end"] == str([os.SCHED_BATCH])


def test_the_policy_names_are_the_cli_words() -> None:
    """`--cpu` takes the enum's values."""
    assert [p.value for p in CpuPolicy] == ["background", "normal"]


def test_the_cpu_option_shows_every_policy() -> None:
    """`--cpu`'s usage lists the enum's values, as argparse shows choices."""
    parser = argparse.ArgumentParser(prog="dbglog x")
    add_cpu_argument(parser, CpuPolicy.NORMAL, "how")
    assert "[--cpu {background,normal}]" in parser.format_usage()


def test_dbglog_cpu_sets_the_default_and_the_option_still_wins(
    monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """``DBGLOG_CPU`` replaces a command's own default (and its help says which is in force); `--cpu`
    given on the command line wins; a word that is no policy is named once and the command's default
    stands."""

    def parse(*argv: str) -> CpuPolicy:
        parser = argparse.ArgumentParser(prog="dbglog x")
        add_cpu_argument(parser, CpuPolicy.BACKGROUND, "how")
        assert f"{CPU_ENV} sets the default" in parser.format_help()
        policy: CpuPolicy = parser.parse_args(list(argv)).cpu
        return policy

    monkeypatch.delenv(CPU_ENV, raising=False)
    assert parse() is CpuPolicy.BACKGROUND
    monkeypatch.setenv(CPU_ENV, " Normal ")
    assert parse() is CpuPolicy.NORMAL
    assert parse("--cpu", "background") is CpuPolicy.BACKGROUND
    monkeypatch.setenv(CPU_ENV, "idle")
    monkeypatch.setattr("dbglog._sched._ENV_WARNED", set())
    assert parse() is CpuPolicy.BACKGROUND
    assert parse() is CpuPolicy.BACKGROUND
    err = capsys.readouterr().err
    assert err.count("DBGLOG_CPU: 'idle' is not a CPU policy: use one of background, normal") == 1, err


def policies_of(pid: int) -> dict[str, set[int]]:
    """The scheduling policies of process `pid`'s threads, by thread name."""
    found: dict[str, set[int]] = {}
    for task in Path(f"/proc/{pid}/task").iterdir():
        try:
            name = (task / "comm").read_text().strip()
            found.setdefault(name, set()).add(os.sched_getscheduler(int(task.name)))
        except (OSError, ProcessLookupError):  # a thread that ended meanwhile
            continue
    return found


def middleware_up(proc: subprocess.Popen[Any]) -> bool:
    """Whether `proc` ended, or runs Fast DDS's threads."""
    return proc.poll() is not None or any(name.startswith("dds.") for name in policies_of(proc.pid))


@pytest.mark.parametrize("command", ["bridge", "record"])
def test_bridge_and_record_run_in_the_background_when_asked(tmp_path: Path, command: str) -> None:
    """`dbglog bridge` and `dbglog record` stay ordinary by default (a starved one would lose data); with
    `--cpu background` (or ``DBGLOG_CPU=background``) every one of their threads, the middleware's
    included, is SCHED_IDLE."""
    rules = tmp_path / "rules.yaml"
    rules.write_text("rules:\n  - tag: battery\n    pattern: 'battery=(\\d+)%'\n")
    base = {
        "bridge": ["bridge", str(rules), "--no-state"],
        "record": ["record", "battery", "-o", str(tmp_path / "out.mcap"), "--force"],
    }[command]
    plain = {k: v for k, v in os.environ.items() if k != CPU_ENV}  # (the suite sets it: see conftest)
    for extra, env, policy in (
        ([], plain, os.SCHED_OTHER),
        (["--cpu", "background"], plain, os.SCHED_IDLE),
        ([], {**plain, CPU_ENV: "background"}, os.SCHED_IDLE),
    ):
        proc = subprocess.Popen(
            [sys.executable, "-m", "dbglog", *base, *extra],
            env=env,
            stdout=subprocess.DEVNULL,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            started = wait_until(
                functools.partial(middleware_up, proc),
                timeout=BACKGROUND_START_S if policy == os.SCHED_IDLE else 30,
            )
            assert started
            assert proc.poll() is None, proc.communicate()[1]
            found = policies_of(proc.pid)
            assert all(p == {policy} for p in found.values()), (extra, env.get(CPU_ENV), found)
        finally:
            err = stop_child(proc)
        assert "--cpu" not in err, err


def test_a_bad_cpu_word_is_named() -> None:
    """`--cpu` says what it takes."""
    done = run_dbglog("bridge", "rules.yaml", "--cpu", "idle")
    assert done.returncode == 2
    assert "'idle' is not a CPU policy: use one of background, normal" in done.stderr
