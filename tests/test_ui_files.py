"""The viewer's file commands without a window: save, open, new, Save As and the quit prompt's choices."""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

from dbglog.viewer._data._static_source import StaticSource
from dbglog.viewer._document._canvas_doc import CanvasDoc
from dbglog.viewer._document._dashboard import LoadResult, WidgetConfig
from dbglog.viewer._ui._files import Chosen, FileCommands, FileRequest, Opened
from dbglog.viewer._widgets import WidgetRegistry
from tests.test_canvas_doc import Item


@dataclass
class Window:
    """The window's side: the status bar, and whether it closed."""

    running: bool = True
    said: list[str] = field(default_factory=list)

    def set_status(self, text: str) -> None:
        """Keep the message."""
        self.said.append(text)

    def quit(self) -> None:
        """Close."""
        self.running = False


@dataclass
class Canvas:
    """The canvas's side: widgets without frames, put in the document as a canvas would."""

    doc: CanvasDoc[Item]
    grid_shown: int = 0

    def load(self, result: LoadResult) -> None:
        """Put the loaded widgets on the 'canvas'."""
        self.doc.clear()
        for config in result.dashboard.widgets:
            self.doc.add(Item(config))

    def clear(self) -> None:
        """Remove every widget."""
        self.doc.clear()

    def show_grid_settings(self) -> None:
        """Count the refreshes of the grid settings."""
        self.grid_shown += 1


@dataclass
class Prompts:
    """The dialogs: what was asked, and the answers the test gives through the callbacks kept."""

    messages: list[tuple[str, str]] = field(default_factory=list)
    asked: list[tuple[bool, Path | None]] = field(default_factory=list)
    closed: list[FileRequest] = field(default_factory=list)
    chosen: Chosen | None = None
    cancelled: Callable[[], None] | None = None
    prompt: dict[str, object] | None = None

    def message(self, title: str, message: str) -> object:
        """Keep the message."""
        self.messages.append((title, message))
        return None

    def ask_path(
        self, save: bool, start: Path | None, chosen: Chosen, cancelled: Callable[[], None]
    ) -> Opened:
        """Keep the question and its answers."""
        self.asked.append((save, start))
        self.chosen, self.cancelled = chosen, cancelled
        return len(self.asked), None

    def close_path(self, request: FileRequest) -> None:
        """Keep the closed request."""
        self.closed.append(request)

    def open_quit_prompt(self) -> object | None:
        """The prompt, while open."""
        return self.prompt

    def ask_quit(
        self, name: str | None, on_save: Callable[[], object], on_discard: Callable[[], object]
    ) -> object:
        """Open the 'prompt': its name and its two answers."""
        self.prompt = {"name": name, "save": on_save, "discard": on_discard}
        return self.prompt


def path_of(doc: CanvasDoc[Item]) -> Path | None:
    """The document's file (read through a call: each read is fresh for the type checker too)."""
    return doc.path


def running(window: Window) -> bool:
    """Whether the window is open (read through a call, as `path_of`)."""
    return window.running


def dirty(doc: CanvasDoc[Item]) -> bool:
    """Whether the document has unsaved changes (read through a call, as `path_of`)."""
    return doc.dirty


def make() -> tuple[FileCommands, CanvasDoc[Item], Window, Canvas, Prompts]:
    """File commands over a document with one dial, no window anywhere."""
    doc: CanvasDoc[Item] = CanvasDoc(StaticSource())
    doc.add(Item(WidgetConfig("dial", "Speed", 20, 40, 200, 160, ())))
    window, canvas, prompts = Window(), Canvas(doc), Prompts()
    files = FileCommands(doc, WidgetRegistry.builtin(), canvas, window, prompts)
    return files, doc, window, canvas, prompts


def test_save_writes_the_dashboard_and_reopening_restores_it(tmp_path: Path) -> None:
    """Save to a path writes the document, names it in the status bar and clears the modified mark; opening
    the file puts its widgets back and shows its grid settings."""
    files, doc, window, canvas, _prompts = make()
    doc.mark_dirty()
    target = tmp_path / "dash.json"
    assert files.save(target)
    assert not dirty(doc)
    assert path_of(doc) == target
    assert window.said[-1] == f"saved {target}"
    assert [w["name"] for w in json.loads(target.read_text())["widgets"]] == ["Speed"]
    files.new()
    assert doc.items == []
    assert path_of(doc) is None
    assert files.open_path(target)
    assert [i.name for i in doc.items] == ["Speed"]
    assert path_of(doc) == target
    assert canvas.grid_shown == 1
    assert window.said[-1] == "opened dashboard dash.json"


def test_a_file_that_cannot_be_opened_says_why_and_keeps_the_dashboard(tmp_path: Path) -> None:
    """Opening a broken file shows why in a message and the status bar; the dashboard stays as it was."""
    files, doc, window, _canvas, prompts = make()
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    assert not files.open_path(bad)
    assert [i.name for i in doc.items] == ["Speed"]
    assert prompts.messages[-1][0] == "Cannot open dashboard"
    assert window.said[-1].startswith("open failed:")


def test_save_without_a_file_asks_for_one_and_writes_it_once_chosen(tmp_path: Path) -> None:
    """Save with no file opens Save As; choosing a name saves there, cancelling writes nothing."""
    files, doc, _window, _canvas, prompts = make()
    assert not files.save()
    assert prompts.asked == [(True, None)]
    request = files.request
    assert request is not None
    assert request.save
    assert prompts.cancelled is not None
    prompts.cancelled()
    assert prompts.closed == [request], "the dialog closed"
    assert path_of(doc) is None
    files.save()
    assert prompts.chosen is not None
    prompts.chosen(str(tmp_path / "named.json"))
    assert len(prompts.closed) == 2
    assert path_of(doc) == tmp_path / "named.json"
    assert (tmp_path / "named.json").exists()


def test_quit_closes_at_once_when_saved_and_asks_when_there_are_changes(tmp_path: Path) -> None:
    """Quit with nothing unsaved closes; with changes it asks, and the prompt's answers save or discard."""
    files, doc, window, _canvas, prompts = make()
    assert files.request_quit() is None
    assert not running(window)
    files, doc, window, _canvas, prompts = make()
    doc.mark_dirty()
    prompt = files.request_quit()
    assert prompt is prompts.prompt
    assert running(window)
    assert files.request_quit() is prompt, "one prompt, however often the user asks"
    assert prompts.prompt is not None
    save = prompts.prompt["save"]
    assert callable(save)
    save()  # untitled: Save As first; cancelling it keeps the viewer open
    assert prompts.cancelled is not None
    prompts.cancelled()
    assert running(window)
    assert window.said[-1] == "not saved: the viewer stays open"
    save()
    assert prompts.chosen is not None
    prompts.chosen(str(tmp_path / "kept.json"))
    assert not running(window)
    assert (tmp_path / "kept.json").exists()


def test_file_commands_are_actions_and_save_waits_for_an_open_dialog(tmp_path: Path) -> None:
    """New, Open, Save, Save As and Quit are registered with their keys; Save does nothing while a dialog is
    open (its text field has the keys)."""
    from dbglog.viewer._ui._actions import Actions

    files, doc, _window, _canvas, prompts = make()
    actions = Actions()
    modal = [True]
    files.register(actions, modal=lambda: modal[0])
    assert actions.shortcut("file.save") == "Ctrl+S"
    assert actions.shortcut("file.save_as") == "Ctrl+Shift+S"
    assert actions.shortcut("file.quit") == "Ctrl+Q"
    doc.saved(tmp_path / "d.json")
    doc.mark_dirty()
    actions.run("file.save")
    assert dirty(doc), "not while a dialog is open"
    modal[0] = False
    actions.run("file.save")
    assert not dirty(doc)
    actions.run("file.save_as")
    assert prompts.asked[-1] == (True, tmp_path / "d.json")
