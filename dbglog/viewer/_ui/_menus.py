"""The window's menus as lists of action names: a command is registered once (`Actions`), and a menu entry
is its name here (the entry shows the action's label and keys)."""

from __future__ import annotations

__all__ = ["CONTEXT_MENU", "MENUS"]

MENUS: tuple[tuple[str, tuple[str | None, ...]], ...] = (
    (
        "File",
        (
            "file.new",
            "file.open",
            "file.save",
            "file.save_as",
            None,
            "recording.open",
            "recording.save",
            "recording.export_csv",
            "recording.back_to_live",
            None,
            "events.add_marker",
            None,
            "file.quit",
        ),
    ),
    (
        "View",
        (
            "view.snap",
            "view.load_messages",
            "view.log_console",
            "view.events",
            "view.republish",
            None,
            "view.tag_tree",
            "view.find_tag",
        ),
    ),
    ("Watch", ("watch.add",)),
)
"""The menu bar: (title, entries); an entry is an action's name, None a separator."""
CONTEXT_MENU = (
    "widget.topic_setup",
    "widget.properties",
    "widget.rename",
    "widget.to_front",
    "robot.overlay",
)
"""The widget context menu's first entries (actions on the selected widget); then Change widget type ›,
and Delete (``widget.delete``)."""
