"""Tags and their topics: ``[/<robot>]/rosdashboard/<tag>``, valid under the ROS 2 topic-name rules.

The one definition of how a tag (any text a user logs under) becomes a topic name and back, and of
robot namespaces (SDK, bridge, viewer, CLI, recordings). Pure functions, no rclpy.

A tag that is already a plain ROS 2 name (letters, digits, ``_`` and ``/``, no part starting with a
digit, no ``__``) is its own topic name. Any other text is *escaped*: each character that cannot stand
as it is becomes ``__<hex code point>_`` (``a-b`` -> ``a__2d_b``, ``速度`` -> ``__901f___5ea6_``). ``__``
never occurs in a plain tag (ROS 2 names use single underscores), so an escaped name is never another
tag's name: two different texts never share a topic, and the text is read back from the topic name.
"""

from __future__ import annotations

import functools
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass

__all__ = [
    "MAX_TOPIC_LENGTH",
    "TAG_PREFIX",
    "TagError",
    "TagName",
    "dotted_namespace",
    "escape_tag",
    "logger_namespace",
    "name_problem",
    "natural_key",
    "normalize_robot",
    "parse_target",
    "parse_topic",
    "robot_label",
    "robot_problem",
    "robot_target",
    "ros_args_namespace",
    "tag_of",
    "tag_problem",
    "tag_topic",
    "topic_for_tag",
    "unescape_tag",
]

TAG_PREFIX = "/rosdashboard/"
"""The prefix of every tag's topic in the root namespace; a robot's topics are ``/<robot>`` + this."""
_TAG_TOKEN = TAG_PREFIX.strip("/")
MAX_TOPIC_LENGTH = 247
"""rmw's limit for a full topic name (255 minus the DDS ``rt/`` prefix and suffix room)."""
MAX_TAG_LENGTH = MAX_TOPIC_LENGTH - len(TAG_PREFIX)
"""The longest tag in the root namespace (a robot's namespace leaves less)."""
EMPTY_TAG = "__"
"""The topic name of the empty text (every other escaped name has a code point after ``__``)."""

_NAME_CHARS = re.compile(r"[^A-Za-z0-9_/]")
_NAMESPACE = re.compile(r"(?:/[A-Za-z_][A-Za-z0-9_]*)+")
_ESCAPE = re.compile(r"__([0-9a-f]{2,6})_")
_DIGITS = re.compile(r"(\d+)")
_CHAR_CODES = 0x10FFFF


class TagError(ValueError):
    """A tag or robot name that cannot be turned into a topic (not a string, or too long)."""


# ----- order --------------------------------------------------------------------------------------


def natural_key(text: str) -> tuple[tuple[str | int, ...], str]:
    """Return a sort key that orders text as people read it: runs of digits by their value.

    ``sorted(["s10", "s2", "S1"], key=natural_key)`` is ``["S1", "s2", "s10"]``. Letters compare without
    case first; texts that differ only in case or leading zeros (``a01``, ``a1``) then compare as they
    are, so the order is total. Every key is a tuple of alternating text and numbers starting with text,
    so any two keys compare (never a number against a text).

    Args:
        text: the text (a tag, a label, a topic name).
    """
    parts = _DIGITS.split(text)
    return tuple(int(p) if i % 2 else p.casefold() for i, p in enumerate(parts)), text


# ----- tags ---------------------------------------------------------------------------------------


def name_problem(name: str) -> str | None:
    """Return why `name` is not a valid relative ROS 2 topic name (``rcl_validate_topic_name``'s rules,
    without ``~`` and substitutions), or None; ``__`` is allowed here (escaped tags contain it)."""
    if not name:
        return "it is empty"
    bad = _NAME_CHARS.search(name)
    if bad:
        return f"character {bad.group(0)!r} is not allowed (only A-Z a-z 0-9 _ /)"
    if name.startswith("/"):
        return "it starts with '/' (tags are relative to /rosdashboard/)"
    if name.endswith("/"):
        return "it ends with '/'"
    if "//" in name:
        return "it contains '//'"
    for token in name.split("/"):
        if token[:1].isdigit():
            return f"its part {token!r} starts with a digit"
    return None


def _plain_problem(text: str) -> str | None:
    """Why `text` is not its own topic name (length aside), or None."""
    problem = name_problem(text)
    if problem is None and "__" in text:
        return "it contains '__', which dbglog's escapes use (ROS 2 names use single underscores)"
    return problem


def tag_problem(tag: str, robot: str = "") -> str | None:
    """Return why `tag` is not a topic name as it stands (it is then escaped), or None.

    Args:
        tag: the tag's text.
        robot: the robot namespace its topic goes in (``""``: the root), for the length limit.
    """
    problem = _plain_problem(tag)
    if problem is not None:
        return problem
    longest = MAX_TOPIC_LENGTH - len(robot) - len(TAG_PREFIX)
    if len(tag) > longest:
        return f"it is {len(tag)} characters long (at most {longest})"
    return None


def escape_tag(text: str) -> str:
    """Return the topic name of the tag `text` (relative to ``/rosdashboard/``): `text` itself when it is
    a plain ROS 2 name, else its escaped form. Injective: two different texts never share a name.

    A character that cannot stand as it is becomes ``__<hex>_`` (its code point, at least two lowercase
    hex digits): any character outside ``A-Z a-z 0-9 _ /``, a digit that would start a part, a ``/``
    that would leave a part empty (leading, trailing, repeated), and a ``_`` followed by another ``_``
    or by an escape. The empty text is ``__``. The length is not limited here (see `tag_topic`).

    Raises:
        TagError: `text` is not a string.
    """
    if not isinstance(text, str):
        raise TagError(f"a tag must be a str, not {type(text).__name__}")
    if _plain_problem(text) is None:
        return text
    if not text:
        return EMPTY_TAG
    pieces: list[str] = []  # each one literal character, or one escape
    last = len(text) - 1
    for i, c in enumerate(text):
        part_start = not pieces or pieces[-1] == "/"
        if c == "/":
            literal = not part_start and i < last and text[i + 1] != "/"
        elif c == "_":
            literal = True  # unless followed by "_" (decided below, right to left)
        elif c.isascii() and c.isalnum():
            literal = not (part_start and c.isdigit())
        else:
            literal = False
        pieces.append(c if literal else f"__{ord(c):02x}_")
    for i in range(len(pieces) - 2, -1, -1):
        if pieces[i] == "_" and pieces[i + 1].startswith("_"):
            pieces[i] = "__5f_"
    return "".join(pieces)


def _decode(name: str) -> str | None:
    """Undo the escapes of `name` (None when an escape is malformed)."""
    if name == EMPTY_TAG:
        return ""
    out: list[str] = []
    i, n = 0, len(name)
    while i < n:
        if name.startswith("__", i):
            m = _ESCAPE.match(name, i)
            if m is None:
                return None
            code = int(m.group(1), 16)
            if code > _CHAR_CODES:
                return None
            out.append(chr(code))
            i = m.end()
        else:
            out.append(name[i])
            i += 1
    return "".join(out)


def unescape_tag(name: str) -> str:
    """Return the text whose topic name is `name` (the inverse of `escape_tag`).

    A name that `escape_tag` does not produce (a topic someone named by hand, ``a__b``) is its own text.
    """
    if "__" not in name:
        return name
    text = _decode(name)
    return text if text is not None and escape_tag(text) == name else name


def topic_for_tag(tag: str, robot: str = "") -> str:
    """Return the full topic of an already escaped tag (``robot``: ``""`` or a normalized namespace)."""
    return robot + TAG_PREFIX + tag


def tag_topic(text: str, robot: str = "") -> str:
    """Return the full topic of the tag `text` in `robot`'s namespace (escaped as needed).

    Raises:
        TagError: `text` is not a string, or the topic would exceed `MAX_TOPIC_LENGTH` characters.
    """
    topic = topic_for_tag(escape_tag(text), robot)
    if len(topic) > MAX_TOPIC_LENGTH:
        raise TagError(
            f"its topic would be {len(topic)} characters long (at most {MAX_TOPIC_LENGTH}): {topic[:60]}…"
        )
    return topic


# ----- robots -------------------------------------------------------------------------------------


def robot_problem(namespace: str) -> str | None:
    """Return why `namespace` (absolute, e.g. ``/robot1``) cannot hold dbglog's topics, or None."""
    if not _NAMESPACE.fullmatch(namespace):
        return (
            "a robot namespace is '/' followed by parts of letters, digits and '_' separated by '/' "
            "(no part starting with a digit, no trailing '/')"
        )
    parts = namespace.split("/")[1:]
    if _TAG_TOKEN in parts:
        return f"its part {_TAG_TOKEN!r} is dbglog's own (it would read as a tag's topic)"
    if len(namespace) + len(TAG_PREFIX) >= MAX_TOPIC_LENGTH:
        return f"it is {len(namespace)} characters long (a topic has at most {MAX_TOPIC_LENGTH})"
    return None


def normalize_robot(namespace: str) -> str:
    """Return `namespace` as dbglog holds it: ``""`` for the root, else ``/a/b`` (``a/b`` accepted).

    Raises:
        TagError: it is not a valid namespace for dbglog's topics (the message says why).
    """
    if not isinstance(namespace, str):
        raise TagError(f"a robot namespace must be a str, not {type(namespace).__name__}")
    name = namespace.strip()
    if name in ("", "/"):
        return ""
    if not name.startswith("/"):
        name = "/" + name
    problem = robot_problem(name)
    if problem is not None:
        raise TagError(f"robot namespace {namespace!r}: {problem}")
    return name


def robot_label(robot: str) -> str:
    """Return how a robot is shown and typed: ``/lab/robot1`` -> ``lab/robot1`` (``""`` for the root)."""
    return robot[1:]


# ----- topics and what users type -----------------------------------------------------------------


@dataclass(frozen=True, slots=True)
class TagName:
    """A dbglog tag's topic, taken apart: the robot namespace it is in and the tag."""

    robot: str
    """``""`` for the root namespace, else ``/robot1`` (``/lab/robot1``)."""
    tag: str
    """The tag as in the topic name (escaped when its text is not a plain ROS 2 name)."""

    @property
    def text(self) -> str:
        """The tag as the user wrote it (``速度``), read back from the topic name."""
        return unescape_tag(self.tag)

    @property
    def topic(self) -> str:
        """The full topic name."""
        return topic_for_tag(self.tag, self.robot)

    @property
    def label(self) -> str:
        """What tools show and `parse_target` reads back: ``robot1:speed``, or the text in the root.

        A root tag whose text would read as another target (``a:b``, ``/x``, the empty text) gets a
        leading ``:`` (``:a:b``), meaning "no robot".
        """
        text = self.text
        if self.robot:
            return f"{robot_label(self.robot)}:{text}"
        head, colon, _ = text.partition(":")
        if not text or text.startswith("/") or (colon and _robot_part(head) is not None):
            return ":" + text
        return text


@functools.lru_cache(maxsize=4096)
def parse_topic(topic: str) -> TagName | None:
    """Return the robot and tag of a dbglog topic (``/robot1/rosdashboard/a/b``), or None for any other.

    The robot is what comes before the first ``/rosdashboard/`` part (a robot namespace never has a
    ``rosdashboard`` part: `robot_problem`). Cached: widgets ask for their labels every frame.
    """
    if topic.startswith(TAG_PREFIX):
        robot, tag = "", topic[len(TAG_PREFIX) :]
    else:
        at = topic.find(TAG_PREFIX)
        if at <= 0:
            return None
        robot, tag = topic[:at], topic[at + len(TAG_PREFIX) :]
        if not _NAMESPACE.fullmatch(robot):
            return None
    return TagName(robot, tag) if tag else None


@functools.lru_cache(maxsize=4096)
def tag_of(topic: str) -> str | None:
    """Return how a dbglog topic's tag is shown: the user's text (``速度``), with its robot
    (``robot1:speed``) in a robot's namespace (`TagName.label`); None for any other topic."""
    name = parse_topic(topic)
    return name.label if name is not None else None


def _robot_part(head: str) -> str | None:
    """The robot namespace `head` names in ``head:tag`` (``robot1``, ``/lab/robot1``), or None."""
    if head in ("", "/"):
        return ""
    name = head if head.startswith("/") else "/" + head
    return name if robot_problem(name) is None else None


def robot_target(target: str) -> TagName | None:
    """The tag a ``ROBOT:TAG`` (or ``:TAG``) target names, None for any other text (see `parse_target`).

    Raises:
        TagError: the tag's topic would be too long.
    """
    head, colon, rest = target.partition(":")
    robot = _robot_part(head) if colon else None
    if robot is None:
        return None
    tag_topic(rest, robot)  # the length check
    return TagName(robot, escape_tag(rest))


def parse_target(target: str) -> TagName | str:
    """Read what a user typed for a tag: ``speed``, ``robot1:speed``, ``:a:b`` or a full ``/topic``.

    Returns the `TagName` of a tag, or the topic itself when `target` starts with ``/`` and names no
    robot. ``ROBOT:TAG`` splits at the first ``:`` when the text before it is a robot namespace
    (letters, digits, ``_``, ``/``); a leading ``:`` means the root namespace, so the tag ``a:b`` of no
    robot is ``:a:b``. Any other text is a tag of the root namespace as it stands.

    Raises:
        TagError: the tag's topic would be too long.
    """
    name = robot_target(target)
    if name is not None:
        return name
    if target.startswith("/"):
        return target
    tag_topic(target)
    return TagName("", escape_tag(target))


# ----- where a process's namespace comes from -----------------------------------------------------

_WITH_VALUE = frozenset(
    {
        "-r",
        "--remap",
        "-p",
        "--param",
        "--params-file",
        "-e",
        "--enclave",
        "--log-level",
        "--log-config-file",
        "--log-file-name",
    }
)
"""rcl's ``--ros-args`` flags that take the next argument (the others stand alone)."""


def ros_args_namespace(argv: Sequence[str]) -> str | None:
    """Return the namespace that ``--ros-args -r __ns:=/robot1`` in `argv` gives a process's nodes.

    Read as rcl reads it: ``-r``/``--remap`` rules inside ``--ros-args`` sections (each up to ``--``)
    and, outside them, the deprecated bare ``__ns:=/robot1``; the first global ``__ns`` rule wins (a
    node-specific ``name:__ns:=`` one is for that node alone). Returns the normalized namespace (``""``
    for ``/``), or None without such a rule (or when rcl would refuse its value, or dbglog's topics
    cannot be in it: `robot_problem`).
    """
    inside = False
    i = 0
    while i < len(argv):
        arg = argv[i]
        i += 1
        rule: str | None = None
        if arg == "--ros-args":
            inside = True
        elif arg == "--":
            inside = False
        elif inside and arg in _WITH_VALUE:
            if i < len(argv) and arg in ("-r", "--remap"):
                rule = argv[i]
            i += 1
        elif not inside:
            rule = arg
        if rule is None or not rule.startswith("__ns:="):
            continue
        namespace = rule[len("__ns:=") :]
        if namespace == "/":
            return ""
        if _NAMESPACE.fullmatch(namespace) and "__" not in namespace:
            return namespace if robot_problem(namespace) is None else None
    return None


def _logger_of(namespace: str, name: str) -> str:
    """The logger name rcl gives node `name` in `namespace` (``/robot1``, ``ctrl`` -> ``robot1.ctrl``)."""
    return f"{namespace.strip('/').replace('/', '.')}.{name}" if namespace.strip("/") else name


def logger_namespace(logger: str, nodes: Iterable[tuple[str, str]]) -> str | None:
    """Return the robot namespace of the node that logged as `logger` (a ``/rosout`` line's name), or None
    when none of `nodes` did.

    Args:
        logger: the logger name of a ``/rosout`` line (``robot1.ctrl``, a child ``robot1.ctrl.plan``).
        nodes: the (name, namespace) pairs of the nodes on the graph; the node whose logger name is
            `logger` or its longest dotted prefix is the one.
    """
    best: tuple[int, str] | None = None
    for name, namespace in nodes:
        own = _logger_of(namespace, name)
        if (logger == own or logger.startswith(own + ".")) and (best is None or len(own) > best[0]):
            best = (len(own), namespace)
    return _robot_or_root(best[1]) if best is not None else None


def dotted_namespace(logger: str) -> str:
    """Return the namespace a node's own logger name says: every dotted part but the last, as rcl names
    a node's logger (``robot1.ctrl`` -> ``/robot1``); ``""`` when that is no robot namespace."""
    return _robot_or_root("/" + "/".join(logger.split(".")[:-1]))


def _robot_or_root(namespace: str) -> str:
    try:
        return normalize_robot(namespace)
    except TagError:
        return ""
