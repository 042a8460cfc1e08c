"""The viewer's commands as named actions: registered once with their keys, run on the UI thread."""

from __future__ import annotations

import functools
import threading

import pytest

from dbglog.viewer._ui import _bindings
from dbglog.viewer._ui._actions import Actions, Chord, ModifierHold, Scope
from dbglog.viewer._ui._bindings import KEY_CODES, NAMED_KEYS, KeyBindings


def test_only_dear_imgui_named_keys_are_read() -> None:
    """Every key read after a frame is one of Dear ImGui's named keys (or a modifier): Dear PyGui's legacy
    and -1 codes (`mvKey_Colon`, `mvKey_Apps`) read no real state, and one that read as held made a
    modifier's hold look unclean, so a quick Ctrl+Q did nothing."""
    import dearpygui.dearpygui as dpg

    legacy = {
        getattr(dpg, n) for n in ("mvKey_Colon", "mvKey_Prior", "mvKey_Apps", "mvKey_Quote", "mvKey_F25")
    }
    assert legacy.isdisjoint(NAMED_KEYS)  # what the filter is for, still in this Dear PyGui
    mods = {dpg.mvKey_ModCtrl, dpg.mvKey_ModShift, dpg.mvKey_ModAlt}
    assert all(code in NAMED_KEYS for code in _bindings._PLAIN_KEYS)
    assert all(code in NAMED_KEYS or code in mods for code in _bindings._WATCHED_KEYS)
    assert all(code in NAMED_KEYS for code in KEY_CODES.values())
    assert {dpg.mvKey_A, dpg.mvKey_Z, dpg.mvKey_Delete, dpg.mvKey_Escape} <= set(_bindings._PLAIN_KEYS)


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


def test_a_key_runs_the_chord_of_the_modifiers_its_own_frame_saw_down() -> None:
    """The keys a frame saw pressed run the chords of the modifiers that frame saw down, at the next frame:
    Ctrl+S saves, S alone does not, a letter after Ctrl+A (Ctrl up in its frame) is the letter; a canvas
    key waits while the keyboard is taken; a key that does not repeat runs once until it is seen up."""
    ran: list[str] = []
    actions = Actions()
    scopes: tuple[tuple[str, str, Scope], ...] = (
        ("file.save", "Ctrl+S", "window"),
        ("time.previous", "Left", "canvas"),
        ("time.back", "Shift+Left", "canvas"),
        ("marker.add", "Ctrl+M", "window"),
    )
    for name, key, scope in scopes:
        actions.register(name, name, name, functools.partial(ran.append, name), keys=(key,), scope=scope)
    actions.register(
        "edit.delete", "Delete", "x", lambda: ran.append("edit.delete"), keys=("Delete",), repeat=False
    )
    taken = [False]
    keys = KeyBindings(actions, keyboard_taken=lambda: taken[0])

    def frame(pressed: list[str], *, ctrl: bool = False, shift: bool = False) -> list[str]:
        keys.pressed(pressed, ctrl=ctrl, shift=shift)
        assert not ran, "an action runs at the next frame, not in the callback that saw its key"
        actions.run_queued()
        done = list(ran)
        ran.clear()
        return done

    assert frame(["S"], ctrl=True) == ["file.save"]
    assert frame(["S"]) == []
    assert frame(["M"]) == [], "m typed after Ctrl+A: Ctrl was up in its frame"
    assert frame(["M"], ctrl=True) == ["marker.add"]
    assert frame(["Left"], shift=True) == ["time.back"]
    assert frame(["Left"], ctrl=True) == ["time.previous"], "Left alone runs with Ctrl down too"
    taken[0] = True
    assert frame(["Left"]) == [], "a canvas key waits while a field has the keyboard"
    assert frame(["S"], ctrl=True) == ["file.save"], "a window key does not"
    assert frame(["Delete"]) == ["edit.delete"]
    assert frame(["Delete"]) == [], "its key's repeat, not seen up since"


def test_a_modifier_held_with_a_key_in_its_frame_or_let_go_in_it_after_a_clean_hold_makes_a_chord() -> None:
    """Ctrl down in the frame that sees S: Ctrl+S. Ctrl let go in the very frame that sees Q, nothing else
    pressed in its hold (xdotool's ctrl+q): Ctrl+Q. A letter in the frame that sees Ctrl up after Ctrl+A:
    the letter. Left a frame after Shift+Left: Left. The keys are asked only while the modifier is down."""
    a, left = 546, 513
    hold = ModifierHold()
    assert hold.frame(True, lambda: [564]), "Ctrl and S down in one frame"
    assert not hold.frame(False, list), "S pressed again, in the frame after Ctrl went up with S: S"

    hold = ModifierHold()
    assert hold.frame(True, list), "Ctrl down alone"
    assert hold.frame(False, list), "Q's frame sees Ctrl go up: a clean hold ends with Q, Ctrl+Q"
    assert not hold.frame(False, list), "a key a frame later: plain"

    hold = ModifierHold()
    assert hold.frame(True, lambda: [a]), "Ctrl+A in a field"
    assert not hold.frame(False, list), "m in the frame that sees Ctrl up after Ctrl+A: m"

    hold = ModifierHold()
    assert hold.frame(True, lambda: [left]), "Shift+Left"
    assert not hold.frame(False, list), "Shift up with Left's release: a Left pressed now is Left"
    assert hold.frame(True, list)
    asked: list[bool] = []

    def pressed() -> list[int]:
        asked.append(True)
        return []

    hold.frame(False, pressed)
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
