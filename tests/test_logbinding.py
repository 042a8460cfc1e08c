"""Bindings on log topics filter by node and minimum level (issue 18.4): saved in dashboards, validated."""

from __future__ import annotations

import json
from typing import Any

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from dbglog.viewer._data._model import Binding
from dbglog.viewer._document._dashboard import (
    FORMAT,
    VERSION,
    Dashboard,
    WidgetConfig,
    dumps,
    parse_dashboard,
)
from dbglog.viewer._widgets import WidgetRegistry

LOOKUP = WidgetRegistry.builtin().get


def _plot(**binding: Any) -> dict[str, Any]:
    entry = {
        "type": "plot",
        "name": "Wall",
        "x": 0,
        "y": 0,
        "width": 400,
        "height": 260,
        "bindings": [{"topic": "/rosout", "field": "msg", "regex": "d=([0-9.]+)", **binding}],
    }
    return {"format": FORMAT, "version": VERSION, "widgets": [entry]}


def _binding(data: dict[str, Any]) -> tuple[Binding, list[str]]:
    result = parse_dashboard(data, LOOKUP)
    (widget,) = result.dashboard.widgets
    assert isinstance(widget, WidgetConfig)
    (binding,) = widget.bindings
    return binding, result.messages


def test_node_and_level_load_and_save_back() -> None:
    """A log binding's node glob and minimum level load as written and are saved back the same."""
    binding, messages = _binding(_plot(node="planner*", level="WARN"))
    assert messages == []
    assert (binding.node, binding.level) == ("planner*", "warn")
    saved = json.loads(dumps(parse_dashboard(_plot(node="planner*", level="warn"), LOOKUP).dashboard))
    assert saved["widgets"][0]["bindings"][0] == {
        "topic": "/rosout",
        "field": "msg",
        "regex": "d=([0-9.]+)",
        "node": "planner*",
        "level": "warn",
    }


def test_bindings_without_them_are_saved_as_before() -> None:
    """Files without log filters stay byte-for-byte the same shape: no empty node or level keys."""
    binding, messages = _binding(_plot())
    assert (binding.node, binding.level, messages) == ("", "", [])
    saved = json.loads(dumps(parse_dashboard(_plot(), LOOKUP).dashboard))
    assert set(saved["widgets"][0]["bindings"][0]) == {"topic", "field", "regex"}


@pytest.mark.parametrize(
    ("extra", "expected"),
    [
        ({"level": "loud"}, "field 'level' must be one of debug, info, warn, error, fatal"),
        ({"level": 30}, "field 'level' must be one of"),
        ({"node": 5}, "field 'node' must be a logger name"),
        ({"node": "a\nb"}, "field 'node' "),
    ],
)
def test_bad_values_are_named_and_ignored(extra: dict[str, Any], expected: str) -> None:
    """A bad node or level is named in a message and left out; the binding itself stays."""
    binding, messages = _binding(_plot(**extra))
    (message,) = messages
    assert message.startswith("widget #1 'Wall': bindings[0]: ")
    assert expected in message
    assert (binding.topic, binding.regex) == ("/rosout", "d=([0-9.]+)")
    assert (binding.node, binding.level) == ("", "")


@settings(max_examples=60)
@given(
    node=st.sampled_from(["", "planner", "planner*", "robot1.driver", "?x[ab]"]),
    level=st.sampled_from(["", "debug", "info", "warn", "error", "fatal"]),
)
def test_round_trip(node: str, level: str) -> None:
    """Any valid node and level survive saving and loading."""
    plot = LOOKUP("plot")
    assert plot is not None
    binding = Binding("/rosout", "msg", "x=(\\d)", node=node, level=level)
    config = WidgetConfig("plot", "p", 0.0, 0.0, 400.0, 260.0, (binding,), plot.default_properties())
    dashboard = Dashboard([config], 20, True)
    result = parse_dashboard(json.loads(dumps(dashboard)), LOOKUP)
    assert result.messages == []
    assert result.dashboard == dashboard
