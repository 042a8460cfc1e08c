"""The viewer's commands as named actions: registered once with their keys, run on the UI thread."""

from __future__ import annotations

import threading

import pytest

from dbglog.viewer._ui._actions import Actions, Chord, ModifierHold


def test_a_chord_is_read_and_written_back() -> None:
    """Chords read as written (modifiers, then a key) and print for menus and, with arrows, for tooltips."""
    assert Chord.parse("Ctrl+Shift+S") == Chord("S", ctrl=True, shift=True)
    assert Chord.parse("Shift+Left").text() == "Shift+Left"
    assert Chord.parse("Shift+Left").text(symbols=True) == "Shift+\u2190"
    assert Chord.parse("Delete").text(symbols=True) == "Del"
    with pytest.raises(ValueError, match="unknown key 'Spacebar'"):
        Chord.parse("Spacebar")
    with pytest.raises(ValueError, match="bad modifier"):
        Chord.parse("Alt+S")
    with pytest.raises(ValueError, match="bad modifier"):
        Chord.parse("Ctrl+Ctrl+S")


def test_a_chord_needs_its_modifier_down_as_its_key_goes_down() -> None:
    """A key pressed while Ctrl is down is a chord, even handled after Ctrl went up; Ctrl let go in the very
    frame that sees its key (Dear ImGui takes a frame's events together) still is; a letter after Ctrl+A,
    even in the frame that sees Ctrl up, is not; nor a key pressed a frame after Ctrl went up alone."""
    a, m, s = 546, 558, 564
    hold = ModifierHold()
    hold.frame(True, lambda: [s])  # Ctrl+S: Ctrl and S down in one frame
    hold.frame(False, list)  # Ctrl up before S's press is handled
    assert hold.chord(s, down_now=False)
    assert not hold.chord(m, down_now=False)
    hold.frame(False, list)
    assert not hold.chord(s, down_now=False), "S again, a frame after that hold: S alone (not Ctrl+S)"

    hold = ModifierHold()
    hold.frame(True, lambda: [s])  # Ctrl+S, its press handled late (the callback thread, a loaded machine)
    hold.frame(False, list)
    hold.frame(False, list)
    hold.frame(False, list)
    assert hold.chord(s, down_now=False), "S pressed in the hold, handled three frames after: Ctrl+S"
    hold.frame(True, lambda: [s])
    hold.frame(False, list)
    hold.released_at -= 1.0  # a second after the hold
    hold.frame(False, list)
    assert not hold.chord(s, down_now=False), "S alone a second after Ctrl+S: S"

    left = 513
    hold = ModifierHold()
    assert hold.chord(left, down_now=True), "Shift+Left handled before the frame records the press"
    hold.frame(True, lambda: [left])
    hold.frame(False, list)
    hold.frame(False, list)
    assert not hold.chord(left, down_now=False), "Left alone just after Shift+Left: Left"

    hold = ModifierHold()
    hold.frame(True, list)  # Ctrl down alone
    assert hold.chord(m, down_now=False), "m's frame saw Ctrl go up (not yet recorded): a chord"
    hold.frame(False, list)
    assert hold.chord(m, down_now=False), "Ctrl went up in m's frame: a chord"
    hold.frame(False, list)
    assert not hold.chord(m, down_now=False), "m a frame after Ctrl went up"

    hold = ModifierHold()
    hold.frame(True, lambda: [a])  # Ctrl+A in a field
    hold.frame(False, list)  # Ctrl went up in the frame that sees m
    assert not hold.chord(m, down_now=False)
    assert hold.chord(m, down_now=True), "Ctrl down again: Ctrl+M"
    asked: list[bool] = []

    def pressed() -> list[int]:
        asked.append(True)
        return []

    hold.frame(False, pressed)
    assert not asked, "the keys pressed are asked only while the modifier is down"


def test_registering_refuses_a_bad_name_a_second_command_or_a_key_taken() -> None:
    """A name is dotted words and registered once; a key runs one command, and the error names both."""
    actions = Actions()
    actions.register("file.save", "Save", "Save the dashboard", lambda: None, keys=("Ctrl+S",))
    with pytest.raises(ValueError, match="registered already"):
        actions.register("file.save", "Save", "again", lambda: None)
    with pytest.raises(ValueError, match=r"Ctrl\+S runs 'file\.save' already: 'file\.other' cannot"):
        actions.register("file.other", "Other", "x", lambda: None, keys=("Ctrl+S",))
    with pytest.raises(ValueError, match="bad action name 'Save'"):
        actions.register("Save", "Save", "x", lambda: None)
    with pytest.raises(KeyError, match=r"no action named 'file\.nope'"):
        actions.run("file.nope")
    assert "file.save" in actions
    assert "file.other" not in actions
    assert len(actions) == 1


def test_a_key_runs_the_most_specific_chord_whose_modifiers_are_held() -> None:
    """Shift+Left beats Left when Shift is down; Left alone runs with Ctrl down too; S needs its Ctrl."""
    actions = Actions()
    for name, key in (("time.previous", "Left"), ("time.back", "Shift+Left"), ("file.save", "Ctrl+S")):
        actions.register(name, name, name, lambda: None, keys=(key,))
    actions.register("file.save_as", "Save As", "x", lambda: None, keys=("Ctrl+Shift+S",))

    def picked(key: str, *, ctrl: bool = False, shift: bool = False) -> str | None:
        action = actions.for_key(key, ctrl=ctrl, shift=shift)
        return None if action is None else action.name

    assert picked("Left") == "time.previous"
    assert picked("Left", shift=True) == "time.back"
    assert picked("Left", ctrl=True) == "time.previous"
    assert picked("S") is None
    assert picked("S", ctrl=True) == "file.save"
    assert picked("S", ctrl=True, shift=True) == "file.save_as"
    assert actions.keys() == {"Left", "S"}


def test_commands_asked_for_from_other_threads_run_in_order_at_the_next_frame() -> None:
    """`soon` (Dear PyGui's callback thread) only queues; `run_queued` (the UI thread) runs them in order."""
    actions = Actions()
    ran: list[str] = []
    actions.register("view.a", "A", "a", lambda: ran.append("a"))
    actions.register("view.b", "B", "b", lambda: ran.append("b"))

    def callbacks() -> None:
        actions.soon("view.a")
        actions.soon("view.b")

    thread = threading.Thread(target=callbacks)
    thread.start()
    thread.join()
    actions.call_soon(lambda: ran.append("speed"))
    assert ran == []
    assert actions.pending
    assert actions.run_queued() == 3
    assert ran == ["a", "b", "speed"]
    assert not actions.pending


def test_menus_and_tooltips_show_the_keys_an_action_has() -> None:
    """An action's shortcut and tooltip come from its registered keys (none: the description alone)."""
    actions = Actions()
    save = actions.register("file.save", "Save", "Save the dashboard", lambda: None, keys=("Ctrl+S",))
    step = actions.register("time.next", "Next", "The next message", lambda: None, keys=("Right",))
    plain = actions.register("file.new", "New", "Start an empty dashboard", lambda: None)
    assert actions.shortcut("file.save") == "Ctrl+S" == save.shortcut
    assert step.tooltip == "The next message (\u2192)"
    assert plain.tooltip == "Start an empty dashboard"
    assert plain.shortcut == ""
