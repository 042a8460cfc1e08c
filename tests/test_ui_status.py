"""The status bar's layout without a window: the message kept readable, what the window shows giving way."""

from __future__ import annotations

from dbglog.viewer._ui._status import GAP, SEPARATOR, fit_status


def width(text: str) -> float:
    """7 pixels a character, as a test's font."""
    return 7.0 * len(text)


PARTS = [
    "waits for CPU 57 % (--cpu normal)",
    "/home/me/src/robot_ws/src/robot_bringup/dashboards/robot.json",
    "6 widgets",
    "history 10 min",
    "42 fps",
]


def test_everything_shows_when_there_is_room() -> None:
    """A wide bar shows the message and every part, in order."""
    message, info = fit_status("saved robot.json", PARTS, 2000.0, width)
    assert message == "saved robot.json"
    assert info == SEPARATOR.join(PARTS)


def test_the_parts_give_way_and_the_message_stays_whole() -> None:
    """A narrower bar keeps the message whole and the most important parts that fit beside it: a long path
    gives way while the shorter parts after it still show, in their order."""
    message = "opened demo_dashboard.json as a new dashboard: Save asks where to keep it"
    room = width(message) + GAP + width(SEPARATOR.join(PARTS[:2])) + 3
    shown, info = fit_status(message, PARTS, room, width)
    assert shown == message
    assert info == SEPARATOR.join(PARTS[:2]), "the fps and the history give way first"
    room = width(message) + GAP + width(SEPARATOR.join([PARTS[0], *PARTS[2:]])) + 3
    assert fit_status(message, PARTS, room, width) == (message, SEPARATOR.join([PARTS[0], *PARTS[2:]]))
    shown, info = fit_status(message, PARTS, width(message) + 10, width)
    assert (shown, info) == (message, "")


def test_a_message_too_long_for_the_bar_is_cut_with_an_ellipsis() -> None:
    """A message wider than the bar alone is cut at a word's end or inside it, with an ellipsis."""
    shown, info = fit_status("a" * 50, PARTS, 7.0 * 20, width)
    assert info == ""
    assert shown == "a" * 19 + "\u2026"
    assert width(shown) <= 7.0 * 20
    assert fit_status("", [], 100.0, width) == ("", "")
