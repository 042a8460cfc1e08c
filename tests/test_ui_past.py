"""`Widget.past_needed`: a widget (a plugin's as much as a built-in) says how much of the past it draws.

Paused over a replayed history, the viewer then hands it only those samples; one that does not say gets
the whole window, as before. Each scenario runs a real viewer (Dear PyGui under Xvfb) in a process of its
own; the widgets are plugin-style classes registered like an entry point's.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any, ClassVar

import numpy as np
import pytest

from dbglog.viewer._data._model import Binding, SeriesSnapshot
from dbglog.viewer.widget_api import Widget
from tests._children import run_scenario

pytestmark = pytest.mark.gui

T0 = 1_700_000_000.0
KINDS = ("whole_window", "last_two_seconds", "value_only", "confused")
"""One topic each: a frame reads a series once, for the widget that asks most (`FrameSnapshots`)."""


class _Recorder(Widget):
    """Keeps the snapshots it was given (a plugin's widget that draws nothing)."""

    label: ClassVar[str] = "Recorder"

    def __init__(self, props: Any = None) -> None:
        super().__init__(props)
        self.seen: list[SeriesSnapshot] = []

    def create(self, parent: int | str, width: int, height: int) -> None:
        """Nothing to build."""

    def update(self, snapshots: Sequence[SeriesSnapshot], now: float) -> None:
        """Keep what the viewer handed over."""
        self.seen = list(snapshots)


class WholeWindow(_Recorder):
    """Says nothing about the past: gets every sample of the window."""

    type_name: ClassVar[str] = "whole_window"


class LastTwoSeconds(_Recorder):
    """Draws two seconds before the cursor."""

    type_name: ClassVar[str] = "last_two_seconds"

    def past_needed(self, at: float) -> float | None:
        """Two seconds."""
        return 2.0


class ValueOnly(_Recorder):
    """Shows the value at the cursor alone."""

    type_name: ClassVar[str] = "value_only"

    def past_needed(self, at: float) -> float | None:
        """None of the past."""
        return 0.0


class Confused(_Recorder):
    """Answers nonsense: the viewer reads everything rather than fail."""

    type_name: ClassVar[str] = "confused"

    def past_needed(self, at: float) -> float | None:
        """Not a number."""
        return "two" if at > 0 else None  # type: ignore[return-value]


def run_here(name: str, tmp: str) -> None:
    """Child-process entry: a viewer over a replayed history of one 10 Hz tag, the scenario's widgets."""
    warnings.simplefilter("error")
    from dbglog.viewer._data._history import History
    from dbglog.viewer._data._replay import ReplaySource
    from dbglog.viewer._ui import ViewerApp
    from dbglog.viewer._widgets import WidgetRegistry

    store = History(clock=None, max_seconds=3600, max_bytes=2**30)
    times = T0 + np.arange(600) / 10  # 60 s at 10 Hz
    for kind in KINDS:
        store.append_numbers(f"/{kind}", times, times - T0)
    registry = WidgetRegistry.builtin()
    for cls in (WholeWindow, LastTwoSeconds, ValueOnly, Confused):
        assert registry.register(cls, name=cls.type_name, origin="test"), registry.problems
    source = ReplaySource(store, {f"/{kind}": "std_msgs/msg/Float64" for kind in KINDS})
    app = ViewerApp(source, registry, width=1000, height=700)
    app.start()
    try:
        globals()[f"scenario_{name}"](app)
    finally:
        app.close()


def scenario_each_widget_gets_the_past_it_asks_for(app: Any) -> None:
    """Paused at 40 s: the widget that asks for 2 s gets them and the sample at their start; one that asks for
    none gets the sample at the cursor; one that says nothing, or nonsense, the whole window; the value,
    time and count at the cursor are the same for all."""
    items = {}
    for n, kind in enumerate(KINDS):
        item = app.add_widget(kind, 20 + 230 * n, 20)
        app.apply_bindings(item, (Binding(f"/{kind}", "data"),))
        items[kind] = item
    app.select(None)
    cursor = T0 + 40.0
    app.time.seek(cursor)
    for _ in range(3):
        app.frame()
    seen = {kind: item.widget.seen[0] for kind, item in items.items()}
    whole = seen["whole_window"]
    assert len(whole.times) > 100, "a live window's worth"
    two = seen["last_two_seconds"].times
    assert len(two) == 21, "the last two seconds' samples, from the one at their start"
    assert two[0] == pytest.approx(cursor - 2.0)
    assert two[-1] == pytest.approx(cursor)
    assert len(seen["value_only"].times) == 1
    assert len(seen["confused"].times) == len(whole.times)
    for snap in seen.values():
        assert snap.last_time == pytest.approx(cursor)
        assert snap.last == pytest.approx(40.0)
        assert snap.count == whole.count == 401
    assert not any(item.failed for item in items.values())


SCENARIOS = sorted(n.removeprefix("scenario_") for n in dir() if n.startswith("scenario_"))


@pytest.mark.parametrize("scenario", SCENARIOS)
def test_past_scenario(scenario: str, tmp_path: Path) -> None:
    """Each scenario (see its docstring) passes in a process of its own (one Dear PyGui context each)."""
    run_scenario("test_ui_past", scenario, tmp_path)
