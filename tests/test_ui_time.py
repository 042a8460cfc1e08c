"""The viewer's time control without a window: pause, seek, live, play, speed, loop, stepping, its keys."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import pytest

from dbglog.viewer._data._model import Binding, FieldInfo
from dbglog.viewer._data._static_source import StaticSource
from dbglog.viewer._data._timeline import Timeline
from dbglog.viewer._ui._actions import Actions
from dbglog.viewer._ui._time import TimeControl
from dbglog.viewer.widget_api import TimeRange

A = Binding("/a", "data")
B = Binding("/b", "data")


@dataclass
class Scope:
    """The widgets' series as the time keys see them: the selected widget's, or everybody's."""

    selected: str | None = None
    series: dict[str, list[Binding]] = field(default_factory=dict)

    def step_series(self, *, all_widgets: bool = False) -> list[Binding]:
        """The selected widget's series, or every widget's."""
        if not all_widgets and self.selected is not None and self.series.get(self.selected):
            return list(self.series[self.selected])
        return list(dict.fromkeys(b for bs in self.series.values() for b in bs))

    def step_owner(self) -> str | None:
        """The selected widget's name when it has series."""
        return self.selected if self.selected is not None and self.series.get(self.selected) else None


def playing(timeline: Timeline) -> bool:
    """Whether the cursor plays (read through a call: each read is fresh for the type checker too)."""
    return timeline.playing


def make(recording: bool = False) -> tuple[TimeControl, Scope, list[str], StaticSource]:
    """A time control over a static source holding /a at 10, 11, 12 and /b at 10.5, 13 (no window)."""
    source = StaticSource()
    for topic in ("/a", "/b"):
        source.add_topic(topic, "std_msgs/msg/Float64", [FieldInfo("data", "double", True)])
    source.set_series("/a", "data", np.array([10.0, 11.0, 12.0]), np.array([1.0, 2.0, 3.0]))
    source.set_series("/b", "data", np.array([10.5, 13.0]), np.array([5.0, 6.0]))
    scope = Scope(series={"Dial": [A], "Plot": [A, B]})
    said: list[str] = []
    timeline = Timeline(source, recording=recording, ticks=lambda: 0.0)
    control = TimeControl(timeline, scope, said.append, TimeRange(), clock=lambda: 99.0, ticks=lambda: 1.0)
    return control, scope, said, source


def test_pause_holds_the_newest_sample_and_seek_stays_within_what_is_held() -> None:
    """Space pauses at the newest sample the widgets hold; a seek past either end stops at that end."""
    control, _scope, _said, _source = make()
    assert control.live
    assert control.time_span() == (10.0, 13.0)
    control.toggle_live()
    assert control.timeline.cursor == 13.0
    control.seek(2.0)
    assert control.timeline.cursor == 10.0
    control.seek(50.0)
    assert control.timeline.cursor == 13.0
    control.toggle_live()
    assert control.live


def test_arrows_step_through_the_selected_widgets_messages_or_everybodys() -> None:
    """Left and Right move to the previous or next message of the selected widget, else of any widget, and
    say so when there is none that way."""
    control, scope, said, _source = make()
    control.seek(11.0)
    assert control.step_time(1)
    assert control.timeline.cursor == 12.0, "any widget: /a at 12 comes before /b at 13"
    scope.selected = "Dial"
    assert not control.step_time(1)
    assert said[-1] == "no later message of Dial"
    control.seek(11.0)
    assert control.step_time(-1)
    assert control.timeline.cursor == 10.0, "the Dial's own series (/a), not /b at 10.5"
    control.shift_time(1.5)
    assert control.timeline.cursor == 11.5


def test_playback_speed_and_loop_say_what_they_did() -> None:
    """Play from a live cursor asks to pause first; speed and loop are set and named in the status bar."""
    control, _scope, said, _source = make()
    timeline = control.timeline
    control.toggle_play()
    assert not playing(timeline)
    assert said[-1].startswith("pause or click on the timeline first")
    control.pause()
    control.toggle_play()
    assert playing(timeline)
    control.set_speed(2.0)
    assert control.timeline.speed == 2.0
    assert said[-1] == "playback speed 2\u00d7"
    with pytest.raises(ValueError, match="playback speed"):
        control.set_speed(50.0)
    control.toggle_loop()
    assert control.timeline.loop
    assert said[-1].startswith("loop on")


def test_end_goes_live_a_recording_to_its_end_and_home_to_its_start() -> None:
    """End follows the newest data again (a recording: its end, paused), the plots' range too; Home goes to
    the oldest moment held."""
    control, _scope, _said, _source = make(recording=True)
    control.time_range.hold(10.0, 11.0)
    control.oldest()
    assert control.timeline.cursor == 10.0
    control.newest()
    assert control.timeline.cursor == 13.0, "a recording stays paused at its end"
    assert control.time_range.held is None, "the plots follow the newest data again"


def test_another_source_takes_every_binding_and_the_replay_is_named() -> None:
    """A recording shown in place of the live source takes every binding over, opens paused, and is named."""
    control, _scope, _said, live = make()
    replay = StaticSource()
    replay.name = "/tmp/run.mcap"  # type: ignore[attr-defined]
    live.bind(A)
    control.use_source(replay, recording=True, bound=[A])
    assert A in replay.bound
    assert A not in live.bound
    assert not control.live
    assert control.replay_name == "run.mcap"
    assert control.source_changes == 1
    control.use_source(live, recording=False, bound=[A])
    assert playing(control.timeline) is False
    assert control.timeline.cursor is None, "live again"


def test_time_commands_are_actions_with_their_keys() -> None:
    """Each time command is registered once with its keys: Space does not repeat, Shift picks the 1 s step,
    and the keys act on the canvas only (not while typing)."""
    control, _scope, _said, _source = make()
    actions = Actions()
    control.register(actions)
    space = actions.for_key("Space", ctrl=False, shift=False)
    assert space is not None
    assert space.name == "time.toggle_live"
    assert not space.repeat
    back = actions.for_key("Left", ctrl=False, shift=True)
    assert back is not None
    assert back.name == "time.back"
    step = actions.for_key("Left", ctrl=True, shift=False)
    assert step is not None
    assert step.name == "time.previous"
    assert all(actions[name].scope == "canvas" for name in ("time.toggle_live", "time.next", "time.newest"))
    actions.run("time.toggle_live")
    assert control.timeline.cursor == 13.0
    actions.run("time.back")
    assert control.timeline.cursor == 12.0
