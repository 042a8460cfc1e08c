"""Where named actions meet Dear PyGui: the keys, menu entries and buttons that run them (by name).

Dear PyGui calls menu and button callbacks on its own thread: each only queues the action, which runs on
the UI thread at the next frame (`Actions.run_queued`). Keys are read by the UI thread itself after each
rendered frame (`KeyBindings.after_frame`), with the modifiers that very frame saw down.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui._actions import KEYS, Action, Actions, ModifierHold

__all__ = ["KEY_CODES", "NAMED_KEYS", "KeyBindings", "MenuBar", "add_button", "add_menu_entry", "keys_hint"]

_SPECIAL = {
    "Space": "mvKey_Spacebar",
    "Enter": "mvKey_Return",
    **{k: f"mvKey_{k}" for k in ("Left", "Right", "Up", "Down", "Home", "End", "Delete", "Escape", "Tab")},
}
_MODIFIER_WORDS = ("Alt", "Ctrl", "Control", "Mod", "Shift", "Win", "Menu", "None")
NAMED_KEYS = range(512, 4096)
"""Dear ImGui's named keys (`ImGuiKey_NamedKey_BEGIN` on); the modifiers' codes are 4096 and up. Dear PyGui
2.x still names some keys by legacy codes (`mvKey_Colon` 59, `mvKey_Prior` 266, ...) or -1 (`mvKey_Apps`,
the media keys): Dear ImGui's `IsKeyDown` reads no real state for those, and some read as held, their
repeats as presses, in some runs and not others: a modifier's hold then looked unclean and a quick
Ctrl+Q (Ctrl up in Q's frame) did nothing."""
_PLAIN_KEYS = tuple(
    sorted(
        {
            code
            for n in dir(dpg)
            if n.startswith("mvKey_")
            and not any(w in n for w in _MODIFIER_WORDS)
            and (code := int(getattr(dpg, n))) in NAMED_KEYS
        }
    )
)
"""Dear PyGui's codes of Dear ImGui's named keys but the modifiers (the keys a modifier's hold records)."""
_WATCHED_KEYS = (*_PLAIN_KEYS, dpg.mvKey_ModCtrl, dpg.mvKey_ModShift, dpg.mvKey_ModAlt)
"""The keys whose going down or up after a frame keeps the loop rendering."""
KEY_CODES: dict[str, int] = {name: int(getattr(dpg, _SPECIAL.get(name, f"mvKey_{name}"))) for name in KEYS}
"""Key name (`Chord.key`) -> Dear PyGui's key code."""


class KeyBindings:
    """The actions' keys: after each rendered frame, a key that frame saw pressed runs the action its chord
    picks with the modifiers held with it (`ModifierHold`: that frame's, and the frames' before).

    The frame that sees a key go down knows which modifiers were held with it. Dear PyGui's key handlers
    run later on its callback thread, when the modifiers may be up already: frames later for a viewer
    waiting for a CPU (``SCHED_IDLE`` beside busy processes), where Ctrl+S and Ctrl+Q did nothing now and
    then.

    Args:
        actions: the window's actions.
        keyboard_taken: whether a dialog, a menu or a text field has the keyboard (``canvas`` keys wait).
    """

    def __init__(self, actions: Actions, *, keyboard_taken: Callable[[], bool]) -> None:
        self.actions = actions
        self._keyboard_taken = keyboard_taken
        self._codes: tuple[tuple[str, int], ...] = ()
        """The keys an action uses, with their Dear PyGui codes (read after each frame)."""
        self._actions_seen = -1
        """How many actions there were when `_codes` was made (actions are registered after this)."""
        self._held: set[str] = set()
        """Keys of actions that do not repeat, taken and not seen up since (their repeats are ignored)."""
        self._holds = (ModifierHold(), ModifierHold())
        """Ctrl's and Shift's holds as the rendered frames saw them."""
        self._down: frozenset[int] = frozenset()
        """The keys the last frame saw down."""

    def after_frame(self) -> bool:
        """After a rendered frame (UI thread): queue the actions of the keys it saw pressed; forget the keys
        seen up (their next press counts again). Return whether the frame used a key event (a key went
        down or up): Dear ImGui may hold more of them, for the next frames, with nothing left on the X
        connection to wake the loop."""
        down = frozenset(code for code in _WATCHED_KEYS if dpg.is_key_down(code))
        used, self._down = down != self._down, down
        if len(self.actions) != self._actions_seen:
            self._actions_seen = len(self.actions)
            self._codes = tuple((key, KEY_CODES[key]) for key in sorted(self.actions.keys()))
        ctrl_hold, shift_hold = self._holds
        plain = functools.cache(_pressed_plain_keys)  # read once a frame, and only while a modifier is down
        ctrl = ctrl_hold.frame(dpg.mvKey_ModCtrl in down, plain)
        shift = shift_hold.frame(dpg.mvKey_ModShift in down, plain)
        pressed = [key for key, code in self._codes if dpg.is_key_pressed(code)]
        if pressed:
            self.pressed(pressed, ctrl=ctrl, shift=shift)
        if self._held:
            self._held = {key for key in self._held if KEY_CODES[key] in down}
        return used or bool(pressed)

    def pressed(self, keys: Sequence[str], *, ctrl: bool, shift: bool) -> None:
        """Queue the action each of `keys`, pressed in one frame with these modifiers down, runs (if any)."""
        for key in keys:
            action = self.actions.for_key(key, ctrl=ctrl, shift=shift)
            if action is not None:
                self.actions.call_soon(functools.partial(self._fire, action, key))

    def _fire(self, action: Action, key: str) -> None:
        if action.scope == "canvas" and self._keyboard_taken():
            return
        if not action.repeat:
            if key in self._held:
                return
            self._held.add(key)
        action.run()


def _pressed_plain_keys() -> list[int]:
    """The keys but modifiers the frame just rendered saw pressed (25 us: asked while a modifier is down)."""
    return [code for code in _PLAIN_KEYS if dpg.is_key_pressed(code)]


def add_menu_entry(actions: Actions, name: str, **config: object) -> int | str:
    """A menu entry that runs action `name`, labelled and with its keys shown (inside a ``dpg.menu``)."""
    action = actions[name]
    entry: int | str = dpg.add_menu_item(
        label=action.label,
        shortcut=action.shortcut,
        check=action.checked is not None,
        default_value=bool(action.checked()) if action.checked is not None else False,
        callback=lambda *_: actions.soon(name),
        **config,
    )
    return entry


def add_button(actions: Actions, name: str, **config: object) -> int | str:
    """A button that runs action `name`, its tooltip the action's description and keys."""
    action = actions[name]
    config.setdefault("label", action.label)
    button: int | str = dpg.add_button(callback=lambda *_: actions.soon(name), **config)
    with dpg.tooltip(button):
        dpg.add_text(action.tooltip)
    return button


def keys_hint(actions: Actions, names: Sequence[tuple[str, str]]) -> str:
    """A line naming keys and what they do: ``Space pause/resume · ← previous message``.

    Args:
        actions: the registry.
        names: (action name, what to call it) pairs, in order; an action without keys is left out.
    """
    parts = [
        f"{'/'.join(k.text(symbols=True) for k in actions[name].keys)} {what}"
        for name, what in names
        if actions[name].keys
    ]
    return " \u00b7 ".join(parts)


class MenuBar:
    """The window's menu bar built from action names; `sync` shows which are on and which are offered.

    Args:
        actions: the registry.
        menus: (menu title, entries) in order; an entry is an action name, or None for a separator.
    """

    def __init__(self, actions: Actions, menus: Sequence[tuple[str, Sequence[str | None]]]) -> None:
        self.actions = actions
        self.layout = menus
        self.menus: dict[str, int | str] = {}
        """Menu title -> its Dear PyGui menu (more entries may be added there: the auto-dashboard's)."""
        self.entries: dict[str, int | str] = {}
        """Action name -> its menu entry."""
        self._shown: dict[str, tuple[bool, bool]] = {}
        self._changing: list[tuple[str, int | str, Action]] = []
        """The entries whose check mark or presence can change (each frame looks at these only)."""

    def build(self) -> None:
        """Create the menu bar (call inside the window that has ``menubar=True``)."""
        with dpg.menu_bar():
            for title, names in self.layout:
                with dpg.menu(label=title) as menu:
                    self.menus[title] = menu
                    for name in names:
                        if name is None:
                            dpg.add_separator()
                            continue
                        action = self.actions[name]
                        shown = action.shown() if action.shown is not None else True
                        self.entries[name] = add_menu_entry(self.actions, name, show=shown)
                        if action.checked is not None or action.shown is not None:
                            self._changing.append((name, self.entries[name], action))
        self.sync()

    def sync(self) -> None:
        """Show each entry's check mark and whether it is offered, as they are now (only changes cost)."""
        for name, entry, action in self._changing:
            now = (
                bool(action.checked()) if action.checked is not None else False,
                bool(action.shown()) if action.shown is not None else True,
            )
            if self._shown.get(name) == now:
                continue
            self._shown[name] = now
            if action.checked is not None:
                dpg.set_value(entry, now[0])
            dpg.configure_item(entry, show=now[1])
