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
import math
import re
import time
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
        """Every key some chord uses (the key handlers to install)."""
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


LATE_PRESS_S = 0.5
"""How long after its hold ended a key pressed during it still makes a chord: Dear PyGui's callback thread
may handle the press frames later than the frame that saw it (a loaded machine)."""


class ModifierHold:
    """Whether a modifier (Ctrl, Shift) makes a key's press a chord: it was down when the key went down.

    Dear ImGui takes a frame's input events together: a quick chord's modifier can be released in the very
    frame that sees its key pressed; and Dear PyGui's callback thread handles a press after the frame that
    saw it, frames later on a loaded machine. The frames tell the hold's story (`frame`): the keys pressed
    while it was down, and the frame that first saw it up. A key's press is a chord when the modifier is
    down; when a press of the key seen during a hold has not made its chord yet (handled within
    `LATE_PRESS_S` of the hold's end); or when the hold ends in the frame that sees the key with no other
    key pressed during it (a modifier let go with its key). A letter typed after Ctrl+A is not Ctrl+letter,
    nor is Left pressed alone after Shift+Left.
    """

    def __init__(self) -> None:
        self.down = False
        """Whether the last frame saw the modifier down."""
        self.keys: set[int] = set()
        """The keys pressed while it was down, in its last hold."""
        self.seen: collections.Counter[int] = collections.Counter()
        """Presses of each key the frames saw during holds (all of them so far)."""
        self.made: collections.Counter[int] = collections.Counter()
        """Chords each key made while its modifier was down or from a press seen during a hold."""
        self.released = -1
        """The frame that first saw the last hold's modifier up (-1: none yet)."""
        self.released_at = -math.inf
        """When (monotonic) that frame saw it."""
        self.frames = 0
        """Frames seen."""

    def frame(self, down: bool, pressed: Callable[[], Iterable[int]]) -> None:
        """After a rendered frame (UI thread): the modifier is `down`; `pressed` gives the frame's key presses
        (asked only while it is down)."""
        self.frames += 1
        if down:
            if not self.down:
                self.keys = set()
            keys = list(pressed())
            self.keys.update(keys)
            self.seen.update(keys)
        elif self.down:
            self.released = self.frames
            self.released_at = time.monotonic()
        self.down = down

    def chord(self, key: int, *, down_now: bool) -> bool:
        """Whether a press of `key`, seen at the last frame (or the one being rendered), is a chord with the
        modifier (`down_now`: whether it is down as the press is handled)."""
        # A press makes one chord: counted whether the frames saw it before its handling or after.
        if down_now:
            self.made[key] += 1
            return True
        late = self.down or time.monotonic() - self.released_at < LATE_PRESS_S
        if late and self.seen[key] > self.made[key]:  # a press in the hold, handled after it ended
            self.made[key] += 1
            return True
        ends_with_it = self.down or self.released == self.frames  # not yet seen up, or up since this frame
        if not (ends_with_it and self.keys <= {key}):
            return False
        self.made[key] = max(self.made[key], self.seen[key])  # its press, if the frames saw it, is spent
        return True
