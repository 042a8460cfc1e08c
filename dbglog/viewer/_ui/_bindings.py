"""Where named actions meet Dear PyGui: the keys, menu entries and buttons that run them (by name).

Dear PyGui calls key, menu and button callbacks on its own thread: each only queues the action, which runs
on the UI thread at the next frame (`Actions.run_queued`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import dearpygui.dearpygui as dpg

from dbglog.viewer._ui._actions import KEYS, Action, Actions

__all__ = ["KEY_CODES", "KeyBindings", "MenuBar", "add_button", "add_menu_entry", "keys_hint"]

_SPECIAL = {
    "Space": "mvKey_Spacebar",
    "Enter": "mvKey_Return",
    **{k: f"mvKey_{k}" for k in ("Left", "Right", "Up", "Down", "Home", "End", "Delete", "Escape", "Tab")},
}
KEY_CODES: dict[str, int] = {name: int(getattr(dpg, _SPECIAL.get(name, f"mvKey_{name}"))) for name in KEYS}
"""Key name (`Chord.key`) -> Dear PyGui's key code."""


class KeyBindings:
    """One key press handler per key an action uses: a press runs the action its chord picks.

    Args:
        actions: the window's actions.
        chord: whether a press of a key (Dear PyGui's key code) is a chord with a modifier (its
            ``mvKey_ModCtrl``, ``mvKey_ModShift``): the modifier was down as the key went down.
        keyboard_taken: whether a dialog, a menu or a text field has the keyboard (``canvas`` keys wait).
    """

    def __init__(
        self, actions: Actions, *, chord: Callable[[int, int], bool], keyboard_taken: Callable[[], bool]
    ) -> None:
        self.actions = actions
        self._chord = chord
        self._keyboard_taken = keyboard_taken
        self._held: set[str] = set()
        """Keys of actions that do not repeat, taken and not seen up since (their repeats are ignored)."""

    def install(self) -> None:
        """Add the key handlers (call inside ``dpg.handler_registry()``)."""
        for key in sorted(self.actions.keys()):
            dpg.add_key_press_handler(KEY_CODES[key], callback=lambda *_, k=key: self.pressed(k))

    def pressed(self, key: str) -> None:
        """Dear PyGui's callback thread: queue the action this key runs with the modifiers held now."""
        code = KEY_CODES[key]
        action = self.actions.for_key(
            key, ctrl=self._chord(dpg.mvKey_ModCtrl, code), shift=self._chord(dpg.mvKey_ModShift, code)
        )
        if action is not None:
            self.actions.call_soon(lambda: self._fire(action, key))

    def _fire(self, action: Action, key: str) -> None:
        if action.scope == "canvas" and self._keyboard_taken():
            return
        if not action.repeat:
            if key in self._held:
                return
            self._held.add(key)
        action.run()

    def after_frame(self) -> None:
        """After a rendered frame: forget the keys seen up (their next press counts again)."""
        if self._held:
            self._held = {key for key in self._held if dpg.is_key_down(KEY_CODES[key])}


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
