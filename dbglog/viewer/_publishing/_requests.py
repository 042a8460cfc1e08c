"""What a control asks the publishing service for, and what the service answers: plain values, no ROS.

Kept apart from the service (`_publish`) so that the widget API and the dashboard format can name these
types without loading the service, its node or its thread.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Final

from dbglog.viewer._data._model import Status

__all__ = ["DEFAULT_RATE_LIMIT_HZ", "PublishRequest", "PublishState", "Value"]

DEFAULT_RATE_LIMIT_HZ: Final = 20.0
"""The most messages per second one control sends unless its ``rate_limit`` property says otherwise."""

Value = bool | int | float | str


@dataclass(frozen=True, slots=True)
class PublishRequest:
    """What one control wants on the wire: a topic, a type rule, and a value or a whole message.

    Args:
        topic: where to publish, e.g. ``/turtle1/cmd_vel``.
        msg_type: an explicit type (``pkg/msg/Name``); ``""`` takes the topic's type from the graph, or
            `default_type` while the topic does not exist.
        default_type: the type used for a new topic when `msg_type` is empty.
        field: for a single value, the field path it sets (``""``: the type's only field, e.g. ``data``).
        value: the single value (Toggle, Slider, Text); None when `fields` gives the whole message.
        fields: the whole message as JSON-like values, nested or dotted (Button, Publish).
        value_kind: what the control sends (``bool``, ``number``, ``string``), checked against the field.
    """

    topic: str
    msg_type: str = ""
    default_type: str = "std_msgs/msg/Float64"
    field: str = ""
    value: Value | None = None
    fields: Mapping[str, object] | None = None
    value_kind: str = "number"


@dataclass(frozen=True, slots=True)
class PublishState:
    """Where one control stands, for its status pill."""

    status: Status
    reason: str = ""
    msg_type: str | None = None
    """The type it publishes, once resolved."""
    subscribers: int = 0
    """Subscriptions on the topic outside this viewer."""
    sent: int = 0
    """Messages sent so far by this control."""
