"""The off switch, strict mode and process life cycle, each tested in a fresh interpreter."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parent.parent


def _run(
    code: str, *, env: dict[str, str] | None = None, flags: tuple[str, ...] = ()
) -> subprocess.CompletedProcess[str]:
    """Run `code` in a new interpreter with the session's ROS environment plus `env`."""
    full = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    full["PYTHONPATH"] = str(ROOT)
    full.update(env or {})
    return subprocess.run(
        [sys.executable, *flags, "-c", textwrap.dedent(code)],
        env=full,
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
        check=False,
    )


_OFF_PROBE = """
    import json, sys, threading
    import dbglog
    before = threading.active_count()
    dbglog.logfloat("x", 1.0)
    dbglog.logint("x", 1, msg_type="std_msgs/msg/Int32", throttle=1.0)
    dbglog.logbool("x", True, once=True)
    dbglog.logstring("x", "s", skip_first=True)
    dbglog.logdata("x", {"x": 1.0}, "geometry_msgs/msg/Point")
    dbglog.log("x", {"a": [1, 2]})
    dbglog.init()
    dbglog.flush()
    dbglog.shutdown()
    print(json.dumps({
        "enabled": dbglog.enabled,
        "rclpy": "rclpy" in sys.modules,
        "threads": threading.active_count() - before,
        "calls": dbglog.stats().calls,
        "stats_enabled": dbglog.stats().enabled,
    }))
"""


@pytest.mark.parametrize("word", ["off", "0", "false", "no", "OFF", " Off "])
def test_dbglog_off_binds_no_ops_and_never_imports_rclpy(word: str) -> None:
    """DBGLOG=off (any accepted spelling): every function is a no-op, rclpy is never imported."""
    proc = _run(_OFF_PROBE, env={"DBGLOG": word})
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout)
    assert out == {"enabled": False, "rclpy": False, "threads": 0, "calls": 0, "stats_enabled": False}


def test_disabled_functions_are_the_module_level_no_ops() -> None:
    """When off, the public names are the no-op functions themselves (no per-call flag check)."""
    proc = _run(
        "import dbglog, dbglog.api._disabled as d; "
        "print(all(getattr(dbglog, n) is getattr(d, n) for n in d.__all__))",
        env={"DBGLOG": "off"},
    )
    assert proc.stdout.strip() == "True", proc.stderr


def test_bad_dbglog_value_is_a_clear_error_at_import() -> None:
    """DBGLOG=maybe fails at import with a message naming DBGLOG and the value."""
    proc = _run("import dbglog", env={"DBGLOG": "maybe"})
    assert proc.returncode != 0
    assert "DBGLOG='maybe'" in proc.stderr
    assert "ConfigError" in proc.stderr


def test_python_optimized_switches_off_unless_forced_on() -> None:
    """Under python -O dbglog is off by default and on with DBGLOG=on."""
    code = "import sys, dbglog; print(dbglog.enabled, 'rclpy' in sys.modules)"
    assert _run(code, flags=("-O",)).stdout.split() == ["False", "False"]
    assert _run(code, flags=("-O",), env={"DBGLOG": "on"}).stdout.split() == ["True", "False"]
    assert _run(code).stdout.split() == ["True", "False"]


def test_enabled_import_is_lazy_and_first_call_connects() -> None:
    """Enabled: importing dbglog imports no rclpy; the first call does, and publishes."""
    proc = _run(
        """
        import sys, dbglog
        assert "rclpy" not in sys.modules
        dbglog.logfloat("lazy", 1.0)
        s = dbglog.stats()
        print("rclpy" in sys.modules, s.published, s.tags)
        """
    )
    assert proc.stdout.split() == ["True", "1", "1"], proc.stderr


def test_strict_mode_raises_dbglog_error() -> None:
    """DBGLOG_STRICT=1 turns a dropped value into a DbglogError at the call."""
    proc = _run(
        """
        import dbglog
        try:
            dbglog.logint("x", 2**63)
        except dbglog.DbglogError as exc:
            print("raised", exc)
        """,
        env={"DBGLOG_STRICT": "1"},
    )
    assert proc.stdout.startswith("raised dbglog.logint('x')"), proc.stderr
    assert "Int64 range" in proc.stdout


def test_without_rclpy_calls_are_dropped_with_one_warning() -> None:
    """When rclpy cannot be imported, calls are counted as dropped (no_ros) with one warning."""
    proc = _run(
        """
        import sys, warnings
        sys.modules["rclpy"] = None  # what a machine without ROS 2 looks like to an import
        import dbglog
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            for i in range(3):
                dbglog.logfloat("x", float(i))
        s = dbglog.stats()
        print(len(caught), s.calls, s.dropped_by_reason)
        print(caught[0].message)
        """
    )
    lines = proc.stdout.splitlines()
    assert lines[0] == "1 3 {'no_ros': 3}", proc.stderr
    assert "dbglog[ros]" in lines[1]


def test_clean_exit_with_live_publishers() -> None:
    """A script that logs and just ends exits 0 promptly (atexit shuts dbglog down)."""
    proc = _run(
        """
        import dbglog
        for i in range(100):
            dbglog.logfloat("bye", float(i))
            dbglog.log("bye_dict", {"a": i, "b": [1.0, 2.0]})
        print("done")
        """
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.strip() == "done"


_FORK_PROBE = """
    import json, os, sys, time, warnings
    import dbglog
    from dbglog._ros._qos import tag_qos
    from std_msgs.msg import Float64
    from tests._ros import RosPeer

    warnings.simplefilter("ignore")
    with RosPeer("fork_peer") as peer:
        got = peer.subscribe("/rosdashboard/fork/parent", Float64, tag_qos())
        dbglog.logfloat("fork/parent", 1.0)
        r, w = os.pipe()
        pid = os.fork()
        if pid == 0:
            start = time.monotonic()
            dbglog.logfloat("fork/parent", 5.0)
            dbglog.init()
            dbglog.log("fork/child", {"a": 1.0})
            s = dbglog.stats()
            took = time.monotonic() - start
            os.write(w, json.dumps({"dropped": s.dropped_by_reason, "calls": s.calls, "took": took}).encode())
            os._exit(0)
        child = json.loads(os.read(r, 1000))
        deadline = time.monotonic() + 20
        status = None
        while time.monotonic() < deadline:
            done, status = os.waitpid(pid, os.WNOHANG)
            if done:
                break
            time.sleep(0.05)
        else:
            os.kill(pid, 9)
        dbglog.logfloat("fork/parent", 2.0)
        got.wait_for(2, timeout=20)
        print(json.dumps({**child, "status": status, "parent": got.values()}))
"""


def test_fork_child_goes_quiet_at_once_and_parent_carries_on() -> None:
    """After fork the child drops values at once (counted), exits; the parent keeps publishing."""
    proc = _run(_FORK_PROBE)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    assert out["dropped"] == {"forked": 2}
    assert out["calls"] == 3  # one call in the parent before the fork
    assert out["took"] < 1.0
    assert out["status"] == 0
    assert out["parent"] == [1.0, 2.0]


_SIGNATURES_PROBE = """
    import inspect, json
    import dbglog
    functions = {n: getattr(dbglog, n) for n in dbglog.__all__}
    print(json.dumps({
        n: str(inspect.signature(f))
        for n, f in sorted(functions.items())
        if inspect.isfunction(inspect.unwrap(f))
    }))
"""


def test_every_public_signature_is_the_same_on_and_off() -> None:
    """inspect.signature of every public function is identical with DBGLOG=on and DBGLOG=off."""
    on, off = (_run(_SIGNATURES_PROBE, env={"DBGLOG": word}) for word in ("on", "off"))
    assert on.returncode == 0, on.stderr
    assert off.returncode == 0, off.stderr
    on_sigs, off_sigs = json.loads(on.stdout), json.loads(off.stdout)
    public = ["flush", "init", "log", "logbool", "logdata", "logfloat", "logint", "logstring", "shutdown"]
    assert sorted(on_sigs) == [*public, "stats"]
    assert off_sigs == on_sigs
    assert "*, msg_type" in on_sigs["logfloat"]


_CALL_SHAPES = [
    'logfloat("x", 1.0)',
    'logfloat(tag="x", value=1.0)',
    'logfloat("x", 1.0, throttle=1.0, once=True, skip_first=False, msg_type=None)',
    'logfloat("x", 1.0, None)',
    'logfloat("x", 1.0, None, True)',
    'logfloat("x", 1.0, None, False, None, False)',
    'logfloat("x", 1.0, 1, 2, 3, 4, 5, 6)',
    'logfloat("x")',
    'logfloat("x", 1.0, bogus=1)',
    'logfloat("x", 1.0, _positional=1)',
    'logint("i", 1, None)',
    'logint("i", 1, msg_type="std_msgs/msg/Int32")',
    'logbool("b", True, None, True)',
    'logstring("s", "v", None)',
    'logstring("s", value="v", once=True)',
    'logdata("p", {"x": 1.0}, "geometry_msgs/msg/Point")',
    'logdata("p", {"x": 1.0}, msg_type="geometry_msgs/msg/Point", throttle=1.0)',
    'logdata("p", {"x": 1.0}, "geometry_msgs/msg/Point", True)',
    'logdata("p", {"x": 1.0})',
    'log("d", 1.0)',
    'log("d", data=1.0, once=True)',
    'log("d", 1.0, True)',
    'log("d", 1.0, msg_type=None)',
    "init(None)",
    "init(node=None)",
    "flush(0.1)",
    "flush(timeout=0.1)",
    "flush(0.1, 2)",
    "shutdown(1)",
    "stats(1)",
    "shutdown()",
    "stats()",
]

_SHAPES_PROBE = """
    import json, warnings
    import dbglog
    warnings.simplefilter("ignore", dbglog.DbglogWarning)
    outcomes = []
    for shape in SHAPES:
        try:
            eval("dbglog." + shape)
        except TypeError:
            outcomes.append("TypeError")
        else:
            outcomes.append("ok")
    print(json.dumps(outcomes))
"""


def test_every_call_shape_behaves_the_same_on_and_off() -> None:
    """Positional options, unknown keywords, missing arguments: a TypeError switched on is one off too."""
    probe = _SHAPES_PROBE.replace("SHAPES", repr(_CALL_SHAPES))
    on, off = (_run(probe, env={"DBGLOG": word}) for word in ("on", "off"))
    assert on.returncode == 0, on.stderr
    assert off.returncode == 0, off.stderr
    on_out, off_out = json.loads(on.stdout), json.loads(off.stdout)
    assert dict(zip(_CALL_SHAPES, off_out, strict=True)) == dict(zip(_CALL_SHAPES, on_out, strict=True))
    assert on_out.count("ok") == 14
    assert off_out[_CALL_SHAPES.index('logfloat("x", 1.0, None, True)')] == "TypeError"


_WARNINGS_AS_ERRORS_PROBE = textwrap.dedent(
    """
    import json, sys
    import dbglog
    for i in range(3):
        dbglog.logfloat("werror/x", float(i))
    dbglog.logstring("werror/s", "up")
    s = dbglog.stats()
    print(json.dumps({"published": s.published, "dropped": s.dropped_by_reason}), flush=True)
    sys.stdin.readline()  # stay up (a transient-local writer) until the test has its values
    """
)


def test_deprecation_warnings_as_errors_do_not_stop_dbglogs_node() -> None:
    """Under python -W error::DeprecationWarning values still reach a real subscriber, none dropped."""
    from std_msgs.msg import Float64, String

    from dbglog._ros._qos import tag_qos
    from tests._ros import RosPeer

    env = {k: v for k, v in os.environ.items() if k not in ("DBGLOG", "DBGLOG_STRICT")}
    env["PYTHONPATH"] = str(ROOT)
    with RosPeer("werror_peer") as peer:
        floats = peer.subscribe("/rosdashboard/werror/x", Float64, tag_qos())
        strings = peer.subscribe("/rosdashboard/werror/s", String, tag_qos())
        command = [sys.executable, "-W", "error::DeprecationWarning", "-c", _WARNINGS_AS_ERRORS_PROBE]
        with subprocess.Popen(
            command,
            env=env,
            cwd=ROOT,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        ) as proc:
            try:
                assert proc.stdout is not None
                line = proc.stdout.readline()
                arrived = floats.wait_for(3, timeout=20) and strings.wait_for(1, timeout=20)
                _, err = proc.communicate(input="\n", timeout=30)
            finally:
                if proc.poll() is None:
                    proc.kill()
        assert json.loads(line) == {"published": 4, "dropped": {}}, err
        assert arrived
        assert floats.values() == [0.0, 1.0, 2.0]
        assert strings.values() == ["up"]
        assert proc.returncode == 0, err
        assert "Traceback" not in err
