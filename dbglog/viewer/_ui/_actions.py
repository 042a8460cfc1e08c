"""The viewer's commands as named actions: each registered once with a label, a description and its keys.

Menus, buttons and keys bind to an action by its name (`_bindings`), so a tooltip or a menu shows the keys
the action really has, and a command is written once whoever triggers it. Plain Python: no Dear PyGui.

Example::

    actions = Actions()
    actions.register("file.save", "Save", "Save the dashboard to its file", save, keys=("Ctrl+S",))
    actions.shortcut("file.save")  # "Ctrl+S"
    actions.soon("file.save")      # from any thread: runs at the next frame, on the UI thread
"""

from __future__ import annotations

import collections
import re
from collections.abc import Callable, Iterable, Iterator, Sequence
from dataclasses import dataclass
from typing import Any, Literal

__all__ = ["Action", "Actions", "Chord", "ModifierHold", "Scope"]

Scope = Literal["window", "canvas"]
"""Where an action's keys act: ``window`` always (the command decides), ``canvas`` only while nothing else
has the keyboard (no dialog, menu or text field being typed in)."""

KEYS = frozenset(
    ["Space", "Left", "Right", "Up", "Down", "Home", "End", "Delete", "Escape", "Enter", "Tab"]
    + [chr(c) for c in range(ord("A"), ord("Z") + 1)]
    + [f"F{n}" for n in range(1, 13)]
)
"""The key names a chord may use (its last part)."""
_SHOWN = {
    "Left": "\u2190",
    "Right": "\u2192",
    "Up": "\u2191",
    "Down": "\u2193",
    "Delete": "Del",
    "Escape": "Esc",
}
_NAME = re.compile(r"[a-z][a-z0-9_]*(\.[a-z][a-z0-9_]*)+")


@dataclass(frozen=True, slots=True)
class Chord:
    """A key with the modifiers held with it: ``Ctrl+Shift+S``."""

    key: str
    ctrl: bool = False
    shift: bool = False

    @classmethod
    def parse(cls, text: str) -> Chord:
        """Read ``Ctrl+Shift+S``, ``Space``, ``Shift+Left``; raise ValueError naming what is wrong."""
        *mods, key = [part.strip() for part in text.split("+")]
        if key not in KEYS:
            raise ValueError(f"unknown key {key!r} in {text!r} (one of: {', '.join(sorted(KEYS))})")
        unknown = [m for m in mods if m not in ("Ctrl", "Shift")]
        if unknown or len(set(mods)) != len(mods):
            raise ValueError(f"bad modifier(s) in {text!r}: Ctrl and Shift, each once, before the key")
        return cls(key, "Ctrl" in mods, "Shift" in mods)

    @property
    def mods(self) -> int:
        """How many modifiers the chord needs (the more, the more specific)."""
        return int(self.ctrl) + int(self.shift)

    def text(self, *, symbols: bool = False) -> str:
        """The chord as menus show it (``Ctrl+Shift+S``); with `symbols`, arrows as arrows (``Shift+←``)."""
        key = _SHOWN.get(self.key, self.key) if symbols else self.key
        return "+".join([*(["Ctrl"] if self.ctrl else []), *(["Shift"] if self.shift else []), key])


@dataclass(frozen=True, slots=True)
class Action:
    """A user command: what it is called, what it does, and the keys that run it."""

    name: str
    """Dotted, by concern: ``file.save``, ``time.toggle_live``."""
    label: str
    """Its menu entry or button text (``Save As\u2026``)."""
    description: str
    """One sentence for tooltips and the docs."""
    run: Callable[[], object]
    """The command (on the UI thread)."""
    keys: tuple[Chord, ...] = ()
    scope: Scope = "window"
    repeat: bool = True
    """Whether a held key runs it again at every repeat (the arrows scrub) or once a press (Space)."""
    checked: Callable[[], bool] | None = None
    """For an on/off command: whether it is on now (a menu shows a check mark)."""
    shown: Callable[[], bool] | None = None
    """Whether its menu entry is shown now (None: always)."""
    applies: Callable[[Any], bool] | None = None
    """For a command on a widget: whether it can act on the widget the context menu is opened on (the menu
    leaves it out where it cannot; None: on every widget)."""

    @property
    def shortcut(self) -> str:
        """Its first key as menus show it, or ""."""
        return self.keys[0].text() if self.keys else ""

    @property
    def tooltip(self) -> str:
        """The description with the keys that run it."""
        keys = " or ".join(k.text(symbols=True) for k in self.keys)
        return f"{self.description} ({keys})" if keys else self.description


class Actions:
    """The registry of a window's commands, and the queue that runs them on the UI thread."""

    def __init__(self) -> None:
        self._actions: dict[str, Action] = {}
        self._chords: dict[Chord, str] = {}
        self._queue: collections.deque[Callable[[], object]] = collections.deque()
        """Commands asked for by Dear PyGui's callback thread (keys, menus, buttons), run by `run_queued`."""

    def register(
        self,
        name: str,
        label: str,
        description: str,
        run: Callable[[], object],
        *,
        keys: Sequence[str] = (),
        scope: Scope = "window",
        repeat: bool = True,
        checked: Callable[[], bool] | None = None,
        shown: Callable[[], bool] | None = None,
        applies: Callable[[Any], bool] | None = None,
    ) -> Action:
        """Add a command; raise ValueError for a name or key already taken or written wrong.

        Args:
            name: dotted, by concern (``time.step_next``).
            label: the menu entry's or button's text.
            description: one sentence (tooltips).
            run: the command, called on the UI thread.
            keys: chords that run it (``Ctrl+S``, ``Shift+Left``).
            scope: where its keys act (`Scope`).
            repeat: whether a held key repeats it.
            checked: for an on/off command, whether it is on.
            shown: whether its menu entry shows now.
            applies: for a command on a widget, whether it can act on a given widget (`Action.applies`).
        """
        if not _NAME.fullmatch(name):
            raise ValueError(f"bad action name {name!r}: dotted lower-case words, like 'file.save'")
        if name in self._actions:
            raise ValueError(f"action {name!r} is registered already")
        chords = tuple(Chord.parse(k) for k in keys)
        for chord in chords:
            taken = self._chords.get(chord)
            if taken is not None:
                raise ValueError(f"{chord.text()} runs {taken!r} already: {name!r} cannot have it too")
        action = Action(name, label, description, run, chords, scope, repeat, checked, shown, applies)
        self._actions[name] = action
        for chord in chords:
            self._chords[chord] = name
        return action

    def __getitem__(self, name: str) -> Action:
        try:
            return self._actions[name]
        except KeyError:
            raise KeyError(f"no action named {name!r}") from None

    def __contains__(self, name: object) -> bool:
        return name in self._actions

    def __iter__(self) -> Iterator[Action]:
        return iter(self._actions.values())

    def __len__(self) -> int:
        return len(self._actions)

    def shortcut(self, name: str) -> str:
        """The first key of action `name` as menus show it, or ""."""
        return self[name].shortcut

    def keys(self) -> set[str]:
        """Every key some chord uses (the keys read after each frame)."""
        return {chord.key for chord in self._chords}

    def for_key(self, key: str, *, ctrl: bool, shift: bool) -> Action | None:
        """The action a press of `key` runs with these modifiers down: the most specific chord whose
        modifiers are all held (Shift+Left over Left), or None."""
        best: tuple[int, str] | None = None
        for chord, name in self._chords.items():
            if chord.key != key or (chord.ctrl and not ctrl) or (chord.shift and not shift):
                continue
            if best is None or chord.mods > best[0]:
                best = (chord.mods, name)
        return None if best is None else self._actions[best[1]]

    # -- running --------------------------------------------------------------------------------------

    def run(self, name: str) -> None:
        """Run action `name` now (on the UI thread)."""
        self[name].run()

    def soon(self, name: str) -> None:
        """Run action `name` at the next frame, on the UI thread (callable from any thread)."""
        action = self[name]
        self._queue.append(action.run)

    def call_soon(self, command: Callable[[], object]) -> None:
        """Run `command` at the next frame, on the UI thread (a choice with a value: a speed, a type)."""
        self._queue.append(command)

    @property
    def pending(self) -> bool:
        """Whether commands wait for the next frame."""
        return bool(self._queue)

    def run_queued(self) -> int:
        """Run what was asked for since the last frame, in order (UI thread); return how many ran."""
        done = 0
        while self._queue:
            self._queue.popleft()()
            done += 1
        return done


class ModifierHold:
    """Whether a modifier (Ctrl, Shift) makes the keys a rendered frame saw pressed chords with it.

    Dear ImGui trickles input events to frames, one change of a key per frame; yet a modifier let go with
    its key (Ctrl up before Q up: xdotool's ``key ctrl+q``, a quick hand) goes up in the very frame that
    sees the key go down. So a frame's presses are chords when the modifier is down in that frame, or went
    up in it after a hold in which no other key was pressed: a letter typed just after Ctrl+A is the letter,
    and so is Left pressed just after Shift+Left.
    """

    def __init__(self) -> None:
        self.down = False
        """Whether the last frame saw the modifier down."""
        self.keys: set[int] = set()
        """The keys pressed while it was down, in its last hold."""

    def frame(self, down: bool, pressed: Callable[[], Iterable[int]]) -> bool:
        """Take a rendered frame that saw the modifier `down`; return whether the keys it saw pressed are
        chords with it (`pressed` gives them all, and is asked only while the modifier is down)."""
        if down:
            if not self.down:
                self.keys = set()
            self.keys.update(pressed())
            chord = True
        else:
            chord = self.down and not self.keys  # let go in the frame that sees its key, after a clean hold
        self.down = down
        return chord
