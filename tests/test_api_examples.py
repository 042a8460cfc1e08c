"""The two examples run for real and their values reach an independent subscriber."""

from __future__ import annotations

import ast
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from std_msgs.msg import Float64, Int64

import dbglog
from dbglog._ros._qos import tag_qos
from tests._ros import RosPeer, own_output

ROOT = Path(__file__).resolve().parent.parent


def _run_example(
    name: str, *args: str, env: dict[str, str] | None = None
) -> subprocess.CompletedProcess[str]:
    full = {**os.environ, "PYTHONPATH": str(ROOT), **(env or {})}
    return subprocess.run(
        [sys.executable, str(ROOT / "examples" / name), *args],
        env=full,
        capture_output=True,
        text=True,
        timeout=90,
        check=False,
    )


def test_typed_node_example_publishes_typed_values() -> None:
    """examples/typed_node.py logs from its timer; a subscriber sees Float64 proximity and Int64 ticks."""
    with RosPeer("example_peer") as peer:
        proximity = peer.subscribe("/rosdashboard/proximity", Float64, tag_qos())
        ticks = peer.subscribe("/rosdashboard/wheel/ticks", Int64, tag_qos())
        proc = _run_example("typed_node.py", "--duration", "4", "--rate", "20")
        assert proc.returncode == 0, proc.stderr
        assert "dropped 0" in proc.stdout
        assert proximity.wait_for(1, timeout=15)
        assert ticks.wait_for(1, timeout=15)
        assert all(0.19 <= v <= 1.81 for v in proximity.values())
        assert ticks.values() == sorted(ticks.values())


def test_plain_script_runs_on_and_off() -> None:
    """examples/plain_script.py runs with dbglog on (publishing) and off (counting nothing)."""
    on = _run_example("plain_script.py", "--steps", "20", "--dt", "0.001")
    assert on.returncode == 0, on.stderr
    fields = dict(item.split("=") for item in own_output(on.stdout).split())
    assert (fields["enabled"], fields["calls"], fields["dropped"]) == ("True", "120", "0")
    assert 121 <= int(fields["published"]) <= 140  # 20 steps x 7 values, the throttled phase mostly held
    off = _run_example("plain_script.py", "--steps", "20", "--dt", "0.001", env={"DBGLOG": "off"})
    assert off.returncode == 0, off.stderr
    assert "enabled=False calls=0" in off.stdout


def _dbglog_imports(path: Path) -> list[str]:
    """Return every dbglog module or name `path` imports, as dotted names."""
    found: list[str] = []
    for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found += [a.name for a in node.names if a.name.split(".")[0] == "dbglog"]
        elif isinstance(node, ast.ImportFrom) and (node.module or "").split(".")[0] == "dbglog":
            found += [f"{node.module}.{a.name}" for a in node.names]
    return found


@pytest.mark.parametrize("name", ["typed_node.py", "plain_script.py"])
def test_examples_use_only_the_public_api(name: str) -> None:
    """The examples users copy import only `dbglog` and its public names, never a private module."""
    imports = _dbglog_imports(ROOT / "examples" / name)
    assert imports == ["dbglog"]
    source = (ROOT / "examples" / name).read_text(encoding="utf-8")
    used = set(re.findall(r"\bdbglog\.(\w+)", source))
    assert used <= set(dbglog.__all__), used - set(dbglog.__all__)


_BESIDE_SCRIPT = """
import dbglog

dbglog.logfloat("beside/x", 1.0)
print(dbglog.__file__, dbglog.stats().published)
"""


def test_script_beside_a_clone_named_dbglog_imports_the_package(tmp_path: Path) -> None:
    """A script beside a clone folder named dbglog/ (no __init__.py) gets the package, not the folder."""
    subprocess.run(["git", "clone", "-q", str(ROOT), str(tmp_path / "dbglog")], check=True, timeout=60)
    (tmp_path / "script.py").write_text(_BESIDE_SCRIPT, encoding="utf-8")
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "DBGLOG")}
    proc = subprocess.run(
        [sys.executable, "script.py"],
        cwd=tmp_path,
        env=env,
        capture_output=True,
        text=True,
        timeout=60,
        check=False,
    )
    assert proc.returncode == 0, (
        "the venv's dbglog must be installed as .ci/setup.sh does (editable_mode=compat):\n" + proc.stderr
    )
    location, published = own_output(proc.stdout).split()
    assert Path(location).name == "__init__.py"
    assert published == "1"
