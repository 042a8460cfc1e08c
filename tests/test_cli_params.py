"""``dbglog params`` against real rclpy nodes: list nodes, list a node's parameters, set them."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from dbglog._cli import main
from dbglog._params._cli import parameter_rows, split_assignments
from dbglog._ros._params import Param, ParamDescriptor, ParamRange, ParamType, ParamValue
from tests._children import run_dbglog
from tests._param_nodes import CURSED, ParamNodes


@pytest.fixture(scope="module")
def nodes() -> Iterator[ParamNodes]:
    """The module's parameter nodes: /robot/cli_pid and /arm/cli_pid answer, /cli_pid_hung never does."""
    with ParamNodes("cli_pid") as made:
        yield made


def _params(capsys: pytest.CaptureFixture[str], *args: str) -> tuple[int, str, str]:
    """Run ``dbglog params ARGS`` in this process; return its exit code, stdout and stderr."""
    code = main(["params", *args])
    out, err = capsys.readouterr()
    return code, out, err


def test_lists_a_nodes_parameters_with_their_descriptors(
    nodes: ParamNodes, capsys: pytest.CaptureFixture[str]
) -> None:
    """NODE lists name, type, value, range with its step, read-only and description (with constraints); a
    name the node lacks is said with its close match."""
    code, _out, err = _params(capsys, nodes.fqn, "kpp", "--timeout", "20")
    assert code == 1
    assert f"{nodes.fqn} has no parameter kpp (did you mean kp?)" in err
    code, out, err = _params(capsys, nodes.fqn, "--timeout", "20")
    assert (code, err) == (0, "")
    lines = {line.split()[0]: line for line in out.splitlines()[2:]}
    assert out.splitlines()[0].split() == ["name", "type", "value", "range", "read-only", "description"]
    assert lines["kp"].split() == [
        "kp",
        "double",
        "1.25",
        "0.0..10.0",
        "step",
        "0.25",
        "proportional",
        "gain",
    ]
    assert "0..100 step 5" in lines["count"]
    assert "samples averaged (a multiple of 5)" in lines["count"]
    assert lines["frame"].split()[3:5] == ["-", "yes"]
    assert "double array  [1.0, 2.0]" in lines["gains"]


def test_a_bare_name_finds_the_node_in_its_namespace_or_says_it_is_ambiguous(
    nodes: ParamNodes, capsys: pytest.CaptureFixture[str]
) -> None:
    """``cli_pid`` names two nodes: both are listed, exit 2; ``robot/cli_pid`` is one, whose named
    parameters show alone."""
    code, _out, err = _params(capsys, "cli_pid", "--timeout", "20")
    assert code == 2
    assert f"'cli_pid' names several nodes: {nodes.twin_fqn}, {nodes.fqn}" in err
    code, out, err = _params(capsys, "robot/cli_pid", "names", "enabled", "--timeout", "20")
    assert code == 0, err
    assert [line.split()[0] for line in out.splitlines()[2:]] == ["names", "enabled"]


def test_set_from_another_process_types_values_as_ros2_param_set(nodes: ParamNodes) -> None:
    """NAME=VALUE pairs set the node (a double, a bool from ``off``, a double array, the string '7') and
    print old → new for each."""
    done = run_dbglog(
        "params", nodes.fqn, "kp=2.5", "enabled=off", "gains=[1.5, 2.5]", "label='7'", "--timeout", "20"
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == [
        f"{nodes.fqn} kp: 1.25 → 2.5",
        f"{nodes.fqn} enabled: true → false",
        f"{nodes.fqn} gains: [1.0, 2.0] → [1.5, 2.5]",
        f"{nodes.fqn} label: hello → '7'",
    ]
    assert nodes.value("kp") == 2.5
    assert nodes.value("enabled") is False
    assert list(nodes.value("gains")) == [1.5, 2.5]
    assert nodes.value("label") == "7"


def test_rejections_exit_1_with_the_nodes_reasons(
    nodes: ParamNodes, capsys: pytest.CaptureFixture[str]
) -> None:
    """Out of range, read-only, off the step, the node's own callback, an undeclared name: each is said on
    stderr with the node's reason; what the node accepted is still set and printed."""
    code, out, err = _params(
        capsys, nodes.twin_fqn, "kp=20.0", "frame=map", "count=15", "kpp=1", "--timeout", "20"
    )
    assert code == 1
    assert out == f"{nodes.twin_fqn} count: 10 → 15\n"
    assert f"{nodes.twin_fqn} kp: 20.0 (double) rejected: Parameter kp out of range" in err
    assert f"{nodes.twin_fqn} frame: map (string) rejected: Trying to set a read-only parameter" in err
    assert f"kpp: 1 (integer) rejected: {nodes.twin_fqn} has no parameter kpp (did you mean kp?)" in err
    code, out, err = _params(capsys, nodes.twin_fqn, f"kp={CURSED}", "--timeout", "20")
    assert (code, out) == (1, "")
    assert f"rejected: kp={CURSED} makes the arm oscillate" in err


def test_a_node_that_never_answers_costs_the_timeout(
    nodes: ParamNodes, capsys: pytest.CaptureFixture[str]
) -> None:
    """A node whose services never answer is named once the timeout for its answers has passed, exit 1; so
    is a node not there."""
    start = time.monotonic()
    code, _out, err = _params(capsys, nodes.hung_fqn, "--timeout", "5")
    took = time.monotonic() - start
    assert code == 1, err
    assert f"{nodes.hung_fqn} did not answer (list_parameters) within" in err
    assert took < 5 + 5 + 3, f"took {took:.1f} s"  # finding it (discovery), then its answers, each <= 5 s
    code, _out, err = _params(capsys, "/cli_nobody", "--timeout", "1")
    assert code == 1
    assert "no node /cli_nobody" in err


def test_lists_nodes_with_parameters(nodes: ParamNodes, capsys: pytest.CaptureFixture[str]) -> None:
    """No NODE: every node with parameters and its count; the silent one 'did not answer' (named on
    stderr), exit 0."""
    code, out, err = _params(capsys, "--timeout", "5")
    assert code == 0
    rows = {line.split()[0]: line.split(maxsplit=1)[1] for line in out.splitlines()[2:]}
    assert {nodes.fqn, nodes.twin_fqn, nodes.hung_fqn} <= set(rows), out + err
    assert rows[nodes.fqn] == rows[nodes.twin_fqn]
    assert int(rows[nodes.fqn]) >= 8
    assert rows[nodes.hung_fqn] == "did not answer"
    assert f"{nodes.hung_fqn} did not answer" in err


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["/n", "=3"], "'=3' has no parameter name before '='"),
        (["/n", "kp", "ki=1"], "give names to show (kp) or NAME=VALUE pairs to set, not both"),
        (["/n", "kp=1", "kp=2"], "kp is given twice"),
        (["/n", "kp=99999999999999999999"], "out of range for a 64-bit integer parameter"),
        (["/n", "--timeout", "0"], "--timeout must be a positive number of seconds"),
    ],
)
def test_usage_errors_exit_2_before_any_ros(
    args: list[str], said: str, capsys: pytest.CaptureFixture[str]
) -> None:
    """Malformed items are refused at once with what is wrong (exit 2)."""
    code, _out, err = _params(capsys, *args)
    assert code == 2
    assert said in err


def test_split_assignments_and_rows() -> None:
    """Items split into names or pairs (the value may hold '=' or be empty); rows cut long cells."""
    assert split_assignments(["a=1", "b==2", "c="]) == ([], [("a", "1"), ("b", "=2"), ("c", "")])
    assert split_assignments(["x", "y"]) == (["x", "y"], [])
    described = ParamDescriptor(ParamType.STRING, description="d" * 100, read_only=True)
    long = Param("s", ParamValue(ParamType.STRING, "v" * 100), described)
    [row] = parameter_rows([long])
    assert row[2] == "v" * 59 + "…"
    assert row[4] == "yes"
    [full] = parameter_rows([long], full=True)
    assert full[2] == "v" * 100
    ranged = Param("k", ParamValue.of(1.0), ParamDescriptor(ParamType.DOUBLE, range=ParamRange(0.0, 2.0)))
    assert parameter_rows([ranged])[0][3] == "0.0..2.0"
