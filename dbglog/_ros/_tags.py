"""Tags and their topics: ``/rosdashboard/<tag>``, validated against the ROS 2 topic-name rules.

The one definition of the tag prefix and tag rules (SDK, bridge, viewer, CLI). Pure functions (no
rclpy): an invalid tag maps deterministically to a valid one.
"""

from __future__ import annotations

import re

__all__ = [
    "MAX_TOPIC_LENGTH",
    "TAG_PREFIX",
    "TagError",
    "sanitize_tag",
    "tag_of",
    "tag_problem",
    "topic_for_tag",
]

TAG_PREFIX = "/rosdashboard/"
MAX_TOPIC_LENGTH = 247
"""rmw's limit for a full topic name (255 minus the DDS ``rt/`` prefix and suffix room)."""
MAX_TAG_LENGTH = MAX_TOPIC_LENGTH - len(TAG_PREFIX)

_INVALID_CHAR = re.compile(r"[^A-Za-z0-9_/]")
_SLASHES = re.compile(r"/{2,}")


class TagError(ValueError):
    """A tag that cannot be turned into a topic at all (not a string)."""


def tag_problem(tag: str) -> str | None:
    """Return why `tag` is not a valid tag, or None when it is valid as it stands."""
    if not tag:
        return "it is empty"
    bad = _INVALID_CHAR.search(tag)
    if bad:
        return f"character {bad.group(0)!r} is not allowed (only A-Z a-z 0-9 _ /)"
    if tag.startswith("/"):
        return "it starts with '/' (tags are relative to /rosdashboard/)"
    if tag.endswith("/"):
        return "it ends with '/'"
    if "//" in tag:
        return "it contains '//'"
    for token in tag.split("/"):
        if token[:1].isdigit():
            return f"its part {token!r} starts with a digit"
    if len(tag) > MAX_TAG_LENGTH:
        return f"it is {len(tag)} characters long (at most {MAX_TAG_LENGTH})"
    return None


def sanitize_tag(tag: str) -> str:
    """Map any string to a valid tag, deterministically; a valid tag maps to itself.

    Every disallowed character becomes ``_``, repeated slashes collapse, leading and trailing slashes
    go, a part starting with a digit gets a leading ``_``, and the result is cut to the length limit.

    Raises:
        TagError: `tag` is not a string.
    """
    if not isinstance(tag, str):
        raise TagError(f"a tag must be a str, not {type(tag).__name__}")
    if tag_problem(tag) is None:
        return tag
    cleaned = _SLASHES.sub("/", _INVALID_CHAR.sub("_", tag)).strip("/")
    parts = [("_" + p if p[:1].isdigit() else p) for p in cleaned.split("/")] if cleaned else []
    result = "/".join(p for p in parts if p) or "_"
    if len(result) > MAX_TAG_LENGTH:
        result = result[:MAX_TAG_LENGTH].rstrip("/")
    return result


def topic_for_tag(tag: str) -> str:
    """Return the full topic for an already valid tag."""
    return TAG_PREFIX + tag


def tag_of(topic: str) -> str | None:
    """Return the dbglog tag of `topic` (``/rosdashboard/a/b`` -> ``a/b``), or None for any other topic."""
    return topic[len(TAG_PREFIX) :] if topic.startswith(TAG_PREFIX) else None
