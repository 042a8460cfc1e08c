"""The logic of "Watch a variable…" without a window: file type-ahead, completion, expression checks, rows."""

from __future__ import annotations

from dbglog.viewer._data._model import Binding
from dbglog.viewer._document._dashboard import WatchConfig
from dbglog.viewer._ui._watchdialog import (
    complete,
    completions,
    condition_check,
    expression_check,
    file_suggestions,
    process_label,
    source_row,
    typed_token,
    unknown_names,
)
from dbglog.viewer._ui._watches import watch_bindings, watch_spec
from dbglog.watch.client import Names, Process

FILES = [
    "/ws/src/robot/robot/controller.py",
    "/ws/src/robot/robot/control_utils.py",
    "/ws/src/robot/launch/robot.launch.py",
    "/ws/scripts/run_control.py",
]


def test_file_type_ahead_puts_names_that_start_with_the_text_first() -> None:
    """Names that start with the text come first, then names holding it, then paths; case does not matter."""
    assert file_suggestions(FILES, "controller") == [FILES[0]]
    assert file_suggestions(FILES, "CONTROL") == [FILES[1], FILES[0], FILES[3]]
    assert file_suggestions(FILES, "launch") == [FILES[2]]
    assert file_suggestions(FILES, "scripts/") == [FILES[3]]
    assert file_suggestions(FILES, "") == sorted(FILES, key=lambda p: p.rsplit("/", 1)[1])
    assert file_suggestions(FILES, "nothing") == []
    assert len(file_suggestions([f"/f{i}.py" for i in range(500)], "f", limit=60)) == 60


NAMES = Names("/ws/c.py", ("robot", "ranges", "self", "__class__"), ("Robot", "json", "ranges", "__name__"))


def test_completion_offers_the_names_of_the_line_locals_first() -> None:
    """The name typed last is completed from the line's locals, then its globals; no dunder, no repeat."""
    assert completions(NAMES, "r") == ["robot", "ranges", "Robot"]
    assert completions(NAMES, "ra") == ["ranges"]
    assert completions(NAMES, "") == ["robot", "ranges", "self", "Robot", "json"]
    assert completions(NAMES, "error + js") == ["json"]
    assert completions(NAMES, "self.r") == []  # an attribute: not known
    assert completions(NAMES, "a[0] ") == []  # nothing being typed
    assert completions(NAMES, "__cl") == []
    assert completions(None, "r") == []


def test_completing_replaces_only_the_name_typed_last() -> None:
    """A completion replaces the name being typed, and keeps everything before it."""
    assert typed_token("error + sel") == "sel"
    assert typed_token("self.ga") == ""
    assert complete("error + sel", "self") == "error + self"
    assert complete("ro", "robot") == "robot"
    assert complete("", "speed") == "speed"


def test_expression_check_says_why_a_watch_would_refuse_it() -> None:
    """Allowed expressions are ok; a call or a dunder is refused with the reason; blank asks for one."""
    assert expression_check("self.pose.x")[0]
    assert expression_check("ranges[0] * 2")[0]
    ok, text = expression_check("len(ranges)")
    assert not ok
    assert "'len(ranges)' is not allowed" in text
    assert "calls are not allowed" in text
    assert not expression_check("x.__class__")[0]
    assert not expression_check("a +")[0]
    ok, text = expression_check("  ")
    assert not ok
    assert text.startswith("type a name")


def test_a_condition_is_every_hit_when_empty_and_refused_as_an_expression_is() -> None:
    """An empty condition is every hit; a comparison is allowed; a call in it is refused, saying so."""
    assert condition_check("") == (True, "")
    assert condition_check("  ") == (True, "")
    assert condition_check("self.count % 2 == 0 and speed > 0.5") == (True, "")
    ok, text = condition_check("len(ranges) > 2")
    assert not ok
    assert text.startswith("only when: 'len(ranges) > 2' is not allowed")


def test_names_the_line_does_not_have_are_found_without_running_anything() -> None:
    """Names an expression reads that are neither locals nor globals at the line are listed, once each."""
    assert unknown_names("robot.speed + ranges[0]", NAMES) == []
    assert unknown_names("nosuch + robot.nosuch_attr * nosuch", NAMES) == ["nosuch"]
    assert unknown_names("a if json else b", NAMES) == ["a", "b"]
    assert unknown_names("nosuch", None) == []
    assert unknown_names("a +", NAMES) == []


def test_source_rows_and_process_labels() -> None:
    """A source row has its number aligned and tabs as spaces; a process's label names its pid and program."""
    assert source_row(7, "\tx = 1\n", 3) == "  7      x = 1"
    assert source_row(120, "", 3) == "120  "
    process = Process(
        "a1", "dbglog_watch_1_a", 4812, "", ("/ws/run.py", "--rate", "100"), "", "3.12", "/ws", (), "", ()
    )
    assert process_label(process) == "run.py   pid 4812   /ws/run.py --rate 100"


def test_a_dashboard_watch_becomes_the_clients_spec_and_the_widgets_bindings() -> None:
    """A saved watch arms as the client's spec (empty options as none); its topics bind a widget, up to its
    number of series."""
    spec = watch_spec(WatchConfig("/ws/c.py", 9, ("x", "y"), node="/ctl", throttle=0.5))
    assert (spec.file, spec.line, spec.exprs, spec.node, spec.when, spec.throttle) == (
        "/ws/c.py",
        9,
        ("x", "y"),
        "/ctl",
        None,
        0.5,
    )
    assert watch_spec(WatchConfig("c.py", 1, ("x",))).node is None
    assert watch_spec(WatchConfig("c.py", 1, ("x",))).max_cpu == 0.05
    assert watch_spec(WatchConfig("c.py", 1, ("x",), max_cpu=0.1)).max_cpu == 0.001
    topics = ("/rosdashboard/watch/x", "/rosdashboard/watch/y")
    assert watch_bindings(topics, 6) == (Binding(topics[0], "data"), Binding(topics[1], "data"))
    assert watch_bindings(topics, 1) == (Binding(topics[0], "data"),)
