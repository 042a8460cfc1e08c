"""``dbglog bridge suggest LINE`` as a real subprocess: the YAML it prints is a working rules file."""

from __future__ import annotations

import subprocess
from pathlib import Path

from dbglog.regex_bridge import Matcher, load_rules
from tests._children import run_dbglog


def _suggest(*args: str) -> subprocess.CompletedProcess[str]:
    return run_dbglog("bridge", "suggest", *args)


def test_suggest_prints_a_rules_file_for_the_first_number_and_lists_the_others(tmp_path: Path) -> None:
    """Without --number: the numbers are listed, number 1 is captured, and the output loads as rules."""
    done = _suggest("distance to wall: 0.42m (angle -12.5 deg)")
    assert done.returncode == 0, done.stderr
    assert "# numbers in the line: 1) 0.42m  2) -12.5" in done.stdout
    assert "this rule captures number 1 (0.42); --number K for another" in done.stdout
    rules_file = tmp_path / "rules.yaml"
    rules_file.write_text(done.stdout)
    rules = load_rules(rules_file)
    (rule,) = rules.rules
    assert rule.tag == "wall"
    assert rule.node is None
    values = Matcher(rules).match("distance to wall: 1.5m (angle 3 deg)", logger="any", level=20)
    assert [v.value for v in values] == [1.5]


def test_suggest_number_k_counts_from_one_and_takes_tag_node_level(tmp_path: Path) -> None:
    """--number 2 captures the second number; --tag, --node and --level go into the rule."""
    done = _suggest(
        "battery=87% 12.1V", "--number", "2", "--tag", "power/volts", "--node", "power*", "--level", "warn"
    )
    assert done.returncode == 0, done.stderr
    assert "--number K for another" not in done.stdout
    rules_file = tmp_path / "rules.yaml"
    rules_file.write_text(done.stdout)
    (rule,) = load_rules(rules_file).rules
    assert (rule.tag, rule.node, rule.min_level) == ("power/volts", "power*", 30)
    values = Matcher([rule]).match("battery=50% 11.75V", logger="power_monitor", level=30)
    assert [(v.topic, v.value) for v in values] == [("/rosdashboard/power/volts", 11.75)]


def test_suggest_reads_a_line_as_ros_prints_it_and_filters_its_node(tmp_path: Path) -> None:
    """A pasted console line: its message is matched and its node becomes the rule's node."""
    done = _suggest("[INFO] [1732200000.125] [planner_local]: speed -3.5e-1 m/s", "--number", "1")
    assert done.returncode == 0, done.stderr
    assert "node planner_local" in done.stdout
    rules_file = tmp_path / "rules.yaml"
    rules_file.write_text(done.stdout)
    rules = load_rules(rules_file)
    assert rules.rules[0].node == "planner_local"
    matcher = Matcher(rules)
    assert [v.value for v in matcher.match("speed -3.5e-1 m/s", logger="planner_local", level=20)] == [-0.35]
    assert matcher.match("speed 1 m/s", logger="driver", level=20) == []


def test_suggest_line_starting_with_a_minus_after_double_dash() -> None:
    """A line that starts with '-' is given after '--'."""
    done = _suggest("--", "-5 deg")
    assert done.returncode == 0, done.stderr
    assert "captures number 1 (-5)" in done.stdout


def test_suggest_errors_are_clear() -> None:
    """No number, a number out of range, --number 0, a bad tag, or no line: exit 2 saying what is wrong."""
    cases = [
        (("no numbers here",), "no number in the line 'no numbers here'"),
        (("a=1 b=2", "--number", "3"), "number 3 does not exist: the line has 2 number(s) (1, 2)"),
        (("a=1", "--number", "0"), "--number counts from 1, not 0"),
        (("a=1", "--tag", "1st"), "invalid tag '1st'"),
        ((), "give the log line"),
    ]
    for args, message in cases:
        done = _suggest(*args)
        assert done.returncode == 2, (args, done.stdout)
        assert message in done.stderr, (args, done.stderr)
        assert done.stdout == ""


def test_bridge_refuses_a_line_or_suggest_options_without_suggest() -> None:
    """`dbglog bridge RULES.yaml LINE` or `--number` without suggest is exit 2 with the reason."""
    done = run_dbglog("bridge", "rules.yaml", "--number", "2")
    assert done.returncode == 2
    assert "unexpected --number: only 'dbglog bridge suggest LINE'" in done.stderr
