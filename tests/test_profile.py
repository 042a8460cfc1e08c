"""The Fast DDS discovery profile of dbglog's own command processes: when it applies, that it is valid."""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

from dbglog._ros._profile import ENV, PROFILE, user_configuration

TIMEOUT = 60

# A fresh process (the profile is a once-per-process decision): claims or not, then creates ROS nodes
# and reports what each creation saw in the environment and whether the profile was used.
_PROBE = """
import json, os, sys
from dbglog._ros import _profile
if sys.argv[1] == "claim":
    _profile.claim()
seen = []
for _ in range(2):
    with _profile.first_participant() as used:
        seen.append([used, os.environ.get(_profile.ENV)])
print(json.dumps({"seen": seen, "after": os.environ.get(_profile.ENV), "claimed": _profile.claimed()}))
"""


def _probe(mode: str, env: dict[str, str] | None = None, cwd: Path | None = None) -> dict[str, object]:
    out = subprocess.run(
        [sys.executable, "-c", _PROBE, mode],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        check=True,
        env=env,
        cwd=cwd,
    )
    result: dict[str, object] = json.loads(out.stdout)
    return result


def _env_without_profiles() -> dict[str, str]:
    return {k: v for k, v in os.environ.items() if k not in (ENV, "FASTDDS_DEFAULT_PROFILES_FILE")}


def test_a_claimed_process_gives_its_first_participant_the_profile_and_its_children_never_see_it(
    tmp_path: Path,
) -> None:
    """Claimed: the first node's creation sees the variable naming the profile, the second does not, and it
    is gone afterwards (children started later do not inherit it)."""
    result = _probe("claim", _env_without_profiles(), tmp_path)
    assert result["seen"] == [[True, str(PROFILE)], [False, None]]
    assert result["after"] is None
    assert result["claimed"] is True


def test_an_unclaimed_process_never_gets_the_profile(tmp_path: Path) -> None:
    """Not claimed (the SDK in a robot's process, `dbglog run`'s program): no node creation sees it."""
    result = _probe("no", _env_without_profiles(), tmp_path)
    assert result["seen"] == [[False, None], [False, None]]
    assert result["claimed"] is False


def test_the_users_own_fast_dds_profiles_keep_ours_out(tmp_path: Path) -> None:
    """A profiles file the user set (either Fast DDS's variable) or left in the working directory wins:
    ours is not used and their variable is left as it was."""
    theirs = tmp_path / "theirs.xml"
    theirs.write_text("<dds/>")
    for name in (ENV, "FASTDDS_DEFAULT_PROFILES_FILE"):
        env = {**_env_without_profiles(), name: str(theirs)}
        result = _probe("claim", env, tmp_path)
        assert result["seen"] == [[False, env.get(ENV)], [False, env.get(ENV)]], name
    (tmp_path / "DEFAULT_FASTRTPS_PROFILES.xml").write_text("<dds/>")
    result = _probe("claim", _env_without_profiles(), tmp_path)
    assert result["seen"] == [[False, None], [False, None]]


def test_user_configuration_names_what_configures_fast_dds(tmp_path: Path) -> None:
    """The variable, or the file in the working directory, that gives Fast DDS the user's profiles."""
    assert user_configuration({}, tmp_path) is None
    assert user_configuration({"FASTDDS_DEFAULT_PROFILES_FILE": "x.xml"}, tmp_path) == (
        "FASTDDS_DEFAULT_PROFILES_FILE"
    )
    (tmp_path / "DEFAULT_FASTDDS_PROFILES.xml").write_text("<dds/>")
    assert user_configuration({}, tmp_path) == str(tmp_path / "DEFAULT_FASTDDS_PROFILES.xml")


def test_the_profile_is_valid_fast_dds_xml_and_its_participant_works(tmp_path: Path) -> None:
    """With the profile loaded, Fast DDS reports no error and a node finds a peer's topic."""
    script = textwrap.dedent(
        """
        import time
        import rclpy
        from rclpy.context import Context
        from rclpy.node import Node
        from std_msgs.msg import Int32
        contexts = []
        for name in ("a", "b"):
            context = Context()
            rclpy.init(args=[], context=context)
            contexts.append(Node(f"profile_{name}", context=context))
        contexts[0].create_publisher(Int32, "/profile_check", 10)
        deadline = time.monotonic() + 30
        while time.monotonic() < deadline:
            if contexts[1].count_publishers("/profile_check"):
                print("found")
                break
            time.sleep(0.05)
        """
    )
    env = {**_env_without_profiles(), ENV: str(PROFILE)}
    out = subprocess.run(
        [sys.executable, "-c", script], capture_output=True, text=True, timeout=TIMEOUT, env=env, cwd=tmp_path
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "found", out.stdout + out.stderr
    assert "Error" not in out.stdout + out.stderr, out.stdout + out.stderr


def test_dbglog_commands_claim_the_profile_but_dbglog_run_leaves_the_program_alone(tmp_path: Path) -> None:
    """`dbglog run` executes the user's program in its process: that process never claims the profile;
    every other command (here `dbglog tags`) does."""
    program = tmp_path / "program.py"
    program.write_text("from dbglog._ros._profile import claimed\nprint('claimed', claimed())\n")
    out = subprocess.run(
        [sys.executable, "-m", "dbglog", "run", str(program)],
        capture_output=True,
        text=True,
        timeout=TIMEOUT,
        env=_env_without_profiles(),
    )
    assert out.returncode == 0, out.stderr
    assert "claimed False" in out.stdout
    check = (
        "import sys\nfrom dbglog._cli import main\nfrom dbglog._ros._profile import claimed\n"
        "main(['tags', '--wait', '0'])\nprint('claimed', claimed())\n"
    )
    env = _env_without_profiles()
    out = subprocess.run(
        [sys.executable, "-c", check], capture_output=True, text=True, timeout=TIMEOUT, env=env, check=False
    )
    assert "claimed True" in out.stdout, out.stdout + out.stderr


_NODE_UP = "import rclpy; rclpy.init(); node = rclpy.create_node('profile_log'); print('up')"


def _with_bad_element(profile: str) -> str:
    """`profile` with an element Fast DDS does not know in the participant's rtps (it logs an error)."""
    assert "<rtps>" in profile
    return profile.replace("<rtps>", "<rtps>\n        <dbglogNoSuchElement>1</dbglogNoSuchElement>", 1)


def test_fast_dds_errors_go_to_stderr_under_the_profile(tmp_path: Path) -> None:
    """Under dbglog's profile, an error Fast DDS logs goes to stderr and stdout keeps only the process's own
    output; the same error without the profile's log section goes to stdout (why the section is there)."""
    text = PROFILE.read_text()
    with_log = tmp_path / "with_log.xml"
    with_log.write_text(_with_bad_element(text))
    without_log = tmp_path / "without_log.xml"
    without_log.write_text(
        _with_bad_element(text[: text.index("  <log>")] + text[text.index("</log>") + 7 :])
    )
    outs = {}
    for path in (with_log, without_log):
        env = {**_env_without_profiles(), ENV: str(path)}
        outs[path.stem] = subprocess.run(
            [sys.executable, "-c", _NODE_UP],
            capture_output=True,
            text=True,
            timeout=TIMEOUT,
            env=env,
            cwd=tmp_path,
        )
    assert outs["with_log"].returncode == 0, outs["with_log"].stderr
    assert outs["with_log"].stdout == "up\n"
    assert "dbglogNoSuchElement" in outs["with_log"].stderr
    assert "dbglogNoSuchElement" in outs["without_log"].stdout, "without the section the error is on stdout"
