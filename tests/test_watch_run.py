"""``dbglog run``: a program runs as ``python SCRIPT`` / ``python -m MODULE`` would run it.

These run with ``DBGLOG=off`` (nothing of the watch agent starts: the program's side is what is checked);
tests/test_watch_live.py runs programs with the agent.
"""

from __future__ import annotations

import json
import os
import signal
import stat
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

from dbglog.watch._cli_run import ProgramError, resolve_program
from tests._ros import first_line

REPORT = """
import json, os, sys
print(json.dumps({"argv": sys.argv, "path0": sys.path[0], "name": __name__, "file": __file__,
                  "main": sys.modules["__main__"].__dict__.get("MARK"), "dbglog": "dbglog" in sys.modules}))
"""


def _run(*args: str, cwd: Path, env: dict[str, str] | None = None) -> subprocess.CompletedProcess[str]:
    full = {**os.environ, "DBGLOG": "off", **(env or {})}
    return subprocess.run(
        [sys.executable, "-m", "dbglog", "run", *args],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=cwd,
        env=full,
        check=False,
    )


def _script(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / name
    path.write_text(textwrap.dedent(body))
    return path


def test_a_script_runs_as_main(tmp_path: Path) -> None:
    """The script is __main__ with its arguments, its folder first on sys.path, exit status 0."""
    script = _script(tmp_path, "report.py", "MARK = 'main'\n" + REPORT)
    out = _run(str(script), "a", "--flag", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    seen = json.loads(out.stdout)
    assert seen["argv"] == [str(script), "a", "--flag"]
    assert seen["path0"] == str(tmp_path.resolve())
    assert seen["name"] == "__main__"
    assert seen["file"] == str(script)
    assert seen["main"] == "main"
    assert "switched off" in out.stderr


def test_the_program_does_not_load_the_other_commands(tmp_path: Path) -> None:
    """`dbglog run` loads only its own command's module: the viewer's, bridge's and recorder's stay out."""
    script = _script(
        tmp_path,
        "mods.py",
        """
        import sys
        others = ("dbglog.viewer", "dbglog.regex_bridge", "dbglog.record", "dbglog._demo", "re2", "yaml")
        print(",".join(sorted(m for m in sys.modules if m.startswith(others))))
        """,
    )
    out = _run(str(script), cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == ""


def test_a_module_runs_as_main(tmp_path: Path) -> None:
    """``-m MODULE`` runs the module as __main__, the current folder first on sys.path, as python -m."""
    pkg = tmp_path / "pkg"
    pkg.mkdir()
    (pkg / "__init__.py").write_text("")
    (pkg / "tool.py").write_text("MARK = 'module'\n" + REPORT)
    out = _run("-m", "pkg.tool", "x", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    seen = json.loads(out.stdout)
    assert seen["argv"] == [str(pkg / "tool.py"), "x"]
    assert seen["path0"] == str(tmp_path)
    assert seen["name"] == "__main__"
    assert seen["main"] == "module"
    missing = _run("-m", "no_such_module_here", cwd=tmp_path)
    assert missing.returncode == 1
    assert "No module named no_such_module_here" in missing.stderr
    assert "Traceback" not in missing.stderr


def test_exit_status_and_tracebacks_as_python(tmp_path: Path) -> None:
    """sys.exit(N) gives N; an exception prints python's traceback (the program's frames only) and gives 1."""
    exits = _script(tmp_path, "exits.py", "import sys\nsys.exit(7)\n")
    assert _run(str(exits), cwd=tmp_path).returncode == 7
    message = _script(tmp_path, "message.py", "import sys\nsys.exit('bye')\n")
    out = _run(str(message), cwd=tmp_path)
    assert out.returncode == 1
    assert out.stderr.strip().endswith("bye")
    fails = _script(tmp_path, "fails.py", "def f():\n    raise ValueError('bad')\n\nf()\n")
    out = _run(str(fails), cwd=tmp_path)
    assert out.returncode == 1
    direct = subprocess.run(
        [sys.executable, str(fails)], capture_output=True, text=True, timeout=60, check=False
    )
    assert out.stderr.splitlines()[-5:] == direct.stderr.splitlines()[-5:]
    traceback = out.stderr[out.stderr.index("Traceback") :]
    assert "runpy" not in traceback
    assert "dbglog" not in traceback


def test_ctrl_c_ends_like_python(tmp_path: Path) -> None:
    """SIGINT raises KeyboardInterrupt in the program; uncaught, it is printed and the status is 130."""
    script = _script(tmp_path, "sleeps.py", "import time\nprint('up', flush=True)\ntime.sleep(60)\n")
    proc = subprocess.Popen(
        [sys.executable, "-m", "dbglog", "run", str(script)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env={**os.environ, "DBGLOG": "off"},
    )
    assert proc.stdout is not None
    assert first_line(proc.stdout) == "up"
    proc.send_signal(signal.SIGINT)
    _out, err = proc.communicate(timeout=30)
    assert proc.returncode == 130
    assert "KeyboardInterrupt" in err


def test_the_forms_ros2_launch_passes(tmp_path: Path) -> None:
    """An executable with a python shebang (a ros2 package's node) and ``python3 SCRIPT`` both run."""
    lib = tmp_path / "lib"
    lib.mkdir()
    (lib / "talker_main.py").write_text("MARK = 'entry'\ndef main():\n" + textwrap.indent(REPORT, "    "))
    exe = tmp_path / "talker"
    exe.write_text(
        "#!/usr/bin/python3\n"
        "import sys\n"
        f"sys.path.insert(0, {str(lib)!r})\n"
        "from talker_main import main\n"
        "if __name__ == '__main__':\n"
        "    sys.exit(main())\n"
    )
    exe.chmod(exe.stat().st_mode | stat.S_IXUSR)
    out = _run(str(exe), "--ros-args", "-r", "__node:=t", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["argv"] == [str(exe), "--ros-args", "-r", "__node:=t"]
    script = _script(tmp_path, "plain.py", REPORT)
    out = _run("python3", "-u", str(script), "z", cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert json.loads(out.stdout)["argv"] == [str(script), "z"]


def test_what_is_not_a_python_program_is_refused(tmp_path: Path) -> None:
    """A missing file, a shell script, an unsupported python option or nothing at all: status 2, and why."""
    shell = tmp_path / "tool"
    shell.write_text("#!/bin/sh\necho hi\n")
    cases = {
        (str(tmp_path / "missing.py"),): "no such file",
        (str(shell),): "not a Python program",
        ("python3", "-X", "dev", "x.py"): "python option -X is not supported",
        (): "nothing to run",
    }
    for args, reason in cases.items():
        out = _run(*args, cwd=tmp_path)
        assert out.returncode == 2, args
        assert reason in out.stderr, (args, out.stderr)


def test_resolve_program_forms() -> None:
    """The command line is read as SCRIPT, -m MODULE, or either after a python executable."""
    here = str(Path(__file__))
    assert resolve_program([here, "a"], False) == ("script", here, ["a"], set())
    assert resolve_program(["mod", "a"], True) == ("module", "mod", ["a"], set())
    assert resolve_program([sys.executable, "-B", "-m", "mod"], False) == (
        "module",
        "mod",
        [],
        {"no_bytecode"},
    )
    assert resolve_program(["/usr/bin/python3.12", "-u", here], False) == ("script", here, [], {"unbuffered"})
    with pytest.raises(ProgramError, match="nothing to run"):
        resolve_program(["python3"], False)


def test_a_run_program_is_watchable(tmp_path: Path) -> None:
    """With dbglog on, ``dbglog run`` starts the agent before the program, which never imports dbglog."""
    script = _script(
        tmp_path,
        "probe.py",
        """
        import sys, time
        from dbglog.watch import _agent
        agent = _agent.agent()
        print(agent is not None and agent.wait_ready(60), flush=True)
        """,
    )
    out = subprocess.run(
        [sys.executable, "-m", "dbglog", "run", str(script)],
        capture_output=True,
        text=True,
        timeout=90,
        cwd=tmp_path,
        env={k: v for k, v in os.environ.items() if k != "DBGLOG"},
        check=False,
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "True"
