"""Topic setup under Xvfb, used with the real mouse and keyboard: focus, Enter, arrows, Escape, width, names.

The viewer runs in a child process reporting what is on screen (see `tests/test_ui_menus.py`, whose
harness this reuses); xdotool drags, clicks and types. The naming and file-name rules are also checked
as plain functions.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from dbglog.viewer._data._model import Binding
from dbglog.viewer._ui._dialogs import dashboard_file_name, topic_widget_name
from tests._viewer_child import ViewerChild as Viewer
from tests.test_ui_menus import center, item_named, start_viewers


@pytest.fixture
def viewer(display: str, tmp_path: Path) -> Iterator[Callable[[str], Viewer]]:
    """Start viewers on the display; each is killed at the end if it still runs."""
    yield from start_viewers(display, tmp_path)


def topic_dialog(state: dict[str, Any]) -> dict[str, Any] | None:
    """The open Topic setup as reported, or None."""
    dialog = state["dialog"]
    return dialog if dialog is not None and dialog["kind"] == "TopicDialog" else None


def open_topic_setup(v: Viewer, name: str) -> dict[str, Any]:
    """Right-click the widget called `name`, click Topic setup…, and wait until its field has the keyboard."""
    x, y, w, h = item_named(v.state(), name)["rect"]
    v.click(x + w / 2, y + h / 2, button=3)
    state = v.wait_for(lambda s: s["menu"] is not None and s["menu"].get("Topic setup\u2026"))
    v.click(*center(state["menu"]["Topic setup\u2026"]))
    return v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic_active"))


@pytest.mark.gui
def test_new_widget_topic_by_keyboard_named_after_it(viewer: Callable[[str], Viewer]) -> None:
    """A dropped dial's Topic setup takes typing at once; Enter takes the suggestion, Enter again is OK."""
    v = viewer("empty")
    state = v.state()
    canvas = (700.0, 420.0)
    v.drag(center(state["toolbox"]["Dial"]), canvas)
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic_active"))
    assert [i["name"] for i in state["items"]] == ["Dial"]
    v.type("spe")
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "spe")
    dialog = topic_dialog(state)
    assert dialog is not None
    assert [t.split()[0] for t in dialog["suggestions"]] == ["/rosdashboard/speed"]
    assert dialog["highlighted"].startswith("/rosdashboard/speed")
    v.key("Return")
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "/rosdashboard/speed")
    shot = v.shot("topic-chosen")
    v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic_active"))
    v.key("Return")
    state = v.wait_for(lambda s: s["dialog"] is None)
    assert [(i["name"], i["type"], i["topics"]) for i in state["items"]] == [
        ("speed", "dial", ["/rosdashboard/speed"])
    ]
    assert shot.stat().st_size > 0


@pytest.mark.gui
def test_topic_setup_arrows_escape_and_fixed_width(viewer: Callable[[str], Viewer]) -> None:
    """Arrows move the highlight, Enter takes it, Escape cancels it all; typing never resizes the dialog."""
    v = viewer("dashboard")
    state = open_topic_setup(v, "Speed")
    dialog = topic_dialog(state)
    assert dialog is not None
    assert dialog["topic"] == "/rosdashboard/speed"
    width = dialog["rect"][2]
    widths = [width]
    v.key("ctrl+a", "BackSpace")
    typed = ""
    for text in ("/r", "o", "bot/pose_of_a_robot_with_a_long_name_nobody_publishes"):
        v.type(text)
        typed += text
        state = v.wait_for(lambda s, t=typed: (topic_dialog(s) or {}).get("topic") == t)  # type: ignore[misc]
        state = v.frames(3)
        widths.append(topic_dialog(state)["rect"][2])  # type: ignore[index]
    shot = v.shot("long-topic")
    assert topic_dialog(v.state())["suggestions"] == []  # type: ignore[index]
    assert widths == [width] * len(widths), f"the dialog changed width while typing: {widths}"
    v.key("ctrl+a", "BackSpace")
    v.type("/ros")
    state = v.wait_for(lambda s: len((topic_dialog(s) or {}).get("suggestions", [])) == 2)
    assert topic_dialog(state)["highlighted"].startswith("/rosdashboard/speed")  # type: ignore[index]
    v.key("Down")
    state = v.wait_for(
        lambda s: (topic_dialog(s) or {}).get("highlighted", "").startswith("/rosdashboard/state")
    )
    v.key("Down", "Up", "Down")
    v.key("Return")
    state = v.wait_for(lambda s: (topic_dialog(s) or {}).get("topic") == "/rosdashboard/state")
    assert topic_dialog(state)["rect"][2] == width  # type: ignore[index]
    v.key("Escape")
    state = v.wait_for(lambda s: s["dialog"] is None)
    speed = item_named(state, "Speed")
    assert speed["topics"] == ["/rosdashboard/speed"]
    assert state["dirty"] is False
    assert shot.stat().st_size > 0


@pytest.mark.gui
def test_control_topic_setup_has_no_regex_or_transforms(viewer: Callable[[str], Viewer]) -> None:
    """A toggle's Topic setup asks where to publish, without the Regex and Transforms a dial's has."""
    v = viewer("dashboard")
    state = open_topic_setup(v, "Fan")
    dialog = topic_dialog(state)
    assert dialog is not None
    texts = " | ".join(dialog["texts"])
    assert "publishes to" in texts
    assert "Regex" not in texts
    assert "Transforms" not in texts
    assert "Add" not in dialog["controls"] or dialog["controls"]["Add"] is None
    toggle_height = dialog["rect"][3]
    v.shot("toggle-setup")
    v.key("Escape")
    v.wait_for(lambda s: s["dialog"] is None)
    state = open_topic_setup(v, "Speed")
    dialog = topic_dialog(state)
    assert dialog is not None
    texts = " | ".join(dialog["texts"])
    assert "Regex" in texts
    assert "Transforms" in texts
    assert dialog["rect"][3] > toggle_height + 100
    v.shot("dial-setup")


def test_topic_widget_name_rules() -> None:
    """A widget is named after the tag's last component and field; taken names reach further back."""
    speed = Binding("/rosdashboard/motor/speed", "data")
    assert topic_widget_name([speed]) == "speed"
    assert topic_widget_name([speed], {"speed"}) == "motor/speed"
    assert topic_widget_name([speed], {"speed", "motor/speed"}) == "motor/speed 2"
    assert topic_widget_name([Binding("/turtle1/cmd_vel", "linear.x")]) == "cmd_vel.linear.x"
    pose = [Binding("/robot/pose", "position.x"), Binding("/robot/pose", "position.y")]
    assert topic_widget_name(pose) == "pose"
    two = [Binding("/rosdashboard/a"), Binding("/rosdashboard/b")]
    assert topic_widget_name(two) == "a, b"
    assert topic_widget_name([Binding("")]) is None


def test_dashboard_file_name_adds_json_once() -> None:
    """Save As adds .json once, keeps a name that has it, and refuses a blank name or a folder."""
    assert dashboard_file_name("mydash") == "mydash.json"
    assert dashboard_file_name("  mydash.json ") == "mydash.json"
    assert dashboard_file_name("Setup.JSON") == "Setup.JSON"
    assert dashboard_file_name("sub/mydash") == "sub/mydash.json"
    for bad in ("", "   ", "sub/", ".."):
        with pytest.raises(ValueError, match="file name"):
            dashboard_file_name(bad)
