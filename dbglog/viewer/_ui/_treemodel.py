"""The tag tree's model: every robot, group, tag and other topic as a tree, filtered, flattened to rows.

Plain Python, no Dear PyGui: the panel (`_tagtree`) shows a window of `TagTreeModel.rows` (only the rows in
view are Dear PyGui items) and asks `plan_drop` what a dragged or double-clicked row becomes on the canvas.
Built again only when the topics change, and filtered only when the filter text changes: never per frame.
"""

from __future__ import annotations

import fnmatch
import re
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

from dbglog._ros._tags import natural_key, parse_topic, robot_label
from dbglog.viewer._data._model import EVERY_ROBOT, SELECTED_ROBOT, Binding, FieldInfo, TopicInfo
from dbglog.viewer._data._robots import Fleet, robot_name
from dbglog.viewer._document._autodash import NUMBER_TYPES

__all__ = [
    "OTHER_TOPICS",
    "PLOT_SERIES",
    "DropPlan",
    "NodeKind",
    "TagTreeModel",
    "TreeNode",
    "is_hidden",
    "overlay_problem",
    "plan_drop",
    "plan_overlay",
    "short_type",
]

NodeKind = Literal["robot", "group", "tag", "topic"]
OTHER_TOPICS = "Other topics"
"""The group of the topics that are neither a tag nor in a robot's namespace."""
PLOT_SERIES = 6
"""A plot dropped for a group shows at most this many of its tags (a plot's series)."""
COLLAPSE_OVER = 60
"""Groups start collapsed when the tree has more leaves than this (robots always start open)."""
_GLOB = re.compile(r"[*?\[]")
_NUMBERS = NUMBER_TYPES | {"std_msgs/msg/Bool"}
_ARRAY = re.compile(r"std_msgs/msg/(?:Float|Int|UInt)(?:8|16|32|64)MultiArray|std_msgs/msg/ByteMultiArray")
_TEXT_TYPES = frozenset({"std_msgs/msg/String"})
_LOG_TYPES = frozenset({"rcl_interfaces/msg/Log"})


def short_type(msg_type: str) -> str:
    """A ROS type as the tree shows it: its last part (``Float64``, ``Log``), ``""`` when unknown."""
    return msg_type.rsplit("/", 1)[-1]


def is_hidden(topic: str) -> bool:
    """Whether a topic is hidden (a part starting with ``_``, as ``ros2 topic list`` hides them)."""
    return any(part.startswith("_") for part in topic.split("/"))


@dataclass(eq=False, slots=True)
class TreeNode:
    """One row of the tree: a robot, a group of tags (or topics), a tag, or another topic."""

    key: str
    """Unique and stable across rebuilds (the open/closed state and the drag payload go by it)."""
    kind: NodeKind
    label: str
    depth: int
    robot: str | None = None
    """The robot namespace it belongs to (None: a topic of no robot)."""
    topic: str = ""
    """A leaf's topic."""
    msg_type: str = ""
    children: list[TreeNode] = field(default_factory=list)
    leaves: int = 0
    """Tags and topics under it (1 for a leaf)."""
    path: str = ""
    """A leaf's full name: ``robot1:motor/rpm`` for a tag, the topic for another topic."""
    search: str = ""
    """What a filter looks in (lower case): the full name and the topic."""
    robots_with: int = 0
    """A leaf: how many robots have a topic of the same name (an overlay shows them all)."""
    shown: int = 0
    """Leaves under it that pass the filter."""

    @property
    def leaf(self) -> bool:
        """Whether it is a tag or topic (no children)."""
        return self.kind in ("tag", "topic")


@dataclass(frozen=True, slots=True)
class DropPlan:
    """What a tree row becomes on the canvas: a widget type, its name, its bindings, and a note."""

    type_name: str
    name: str
    bindings: tuple[Binding, ...]
    note: str = ""
    """What the status bar says besides "added" (``6 of 14 tags: a plot shows 6``)."""


class TagTreeModel:
    """The tree of the topics seen, its open groups, its filter and the rows it shows.

    Robots are the top level (with the root, ``(no namespace)``), each with its tags grouped by their
    ``/`` parts and its other topics under ``topics``; the topics of no robot are under *Other topics*.
    With no robot in a namespace, the root's tags are the top level themselves.
    """

    def __init__(self) -> None:
        self.roots: list[TreeNode] = []
        self.rows: list[TreeNode] = []
        """The rows shown, in order: the open part of the tree, or what the filter keeps."""
        self.query = ""
        self.glob = False
        """Whether the filter is a glob (it has ``*``, ``?`` or ``[``) rather than a substring."""
        self.total = 0
        """Tags and topics in the tree."""
        self.matches = 0
        """Those the filter keeps (all without a filter)."""
        self.version = 0
        """Grows whenever the rows change."""
        self._open: dict[str, bool] = {}
        """Groups opened or closed by the user (the rest follow `COLLAPSE_OVER`)."""
        self._nodes: dict[str, TreeNode] = {}
        self._seen: tuple[object, ...] = ()

    # -- building -------------------------------------------------------------------------------------

    def update(
        self, infos: Sequence[TopicInfo], robots: Sequence[str], held: Mapping[str, str] | None = None
    ) -> bool:
        """Build the tree from the graph's topics, the robots seen and the topics only the history still
        holds (name -> type: a robot gone); True when it changed (then the filter runs again)."""
        gone = {n: t for n, t in (held or {}).items() if n.startswith("/")}
        seen = (tuple((i.name, i.types) for i in infos), tuple(robots), tuple(sorted(gone.items())))
        if seen == self._seen:
            return False
        self._seen = seen
        types: dict[str, str] = dict(gone)
        for info in infos:
            types[info.name] = info.types[0] if info.types else types.get(info.name, "")
        self._build(types, robots)
        self._refilter()
        return True

    def _build(self, types: Mapping[str, str], robots: Sequence[str]) -> None:
        known = list(robots)
        namespaced = any(known)
        tops: dict[str, TreeNode] = {}
        nodes: dict[str, TreeNode] = {}
        others = TreeNode("o:", "group", OTHER_TOPICS, 0)
        by_relative: dict[str, int] = {}
        leaves: list[TreeNode] = []

        def robot_node(robot: str) -> TreeNode | None:
            if not namespaced:
                return None
            node = tops.get(robot)
            if node is None:
                node = tops[robot] = TreeNode(f"r:{robot}", "robot", robot_name(robot), 0, robot=robot)
            return node

        def group(
            parent: TreeNode | None, robot: str | None, parts: Sequence[str], kind: str
        ) -> TreeNode | None:
            """The group node for `parts` under `parent` (None: the top level), made as needed."""
            node = parent
            for i in range(len(parts)):
                key = f"g:{kind}:{robot if robot is not None else '-'}|{'/'.join(parts[: i + 1])}"
                found = nodes.get(key)
                if found is None:
                    depth = 0 if node is None else node.depth + 1
                    found = nodes[key] = TreeNode(key, "group", parts[i], depth, robot=robot)
                    if node is None:
                        tops[key] = found
                    else:
                        node.children.append(found)
                node = found
            return node

        for name in sorted(types, key=natural_key):
            if is_hidden(name):
                continue
            msg_type = types[name]
            tag = parse_topic(name)
            if tag is not None:
                parts = [p for p in tag.text.split("/") if p] or [tag.text]
                parent = group(robot_node(tag.robot), tag.robot, parts[:-1], "t")
                depth = 0 if parent is None else parent.depth + 1
                shown = f"{robot_label(tag.robot)}:{tag.text}" if tag.robot else tag.text
                leaf = TreeNode(
                    f"t:{name}", "tag", parts[-1], depth, robot=tag.robot, topic=name, msg_type=msg_type
                )
                leaf.path = shown
                rel = name[len(tag.robot) :]
            else:
                owner = max((r for r in known if r and name.startswith(r + "/")), key=len, default=None)
                if owner is not None:
                    parent = group(robot_node(owner), owner, ["topics"], "o")
                    label = name[len(owner) + 1 :]
                    rel = name[len(owner) :]
                else:
                    parent, label, rel = others, name, name
                assert parent is not None
                leaf = TreeNode(
                    f"p:{name}",
                    "topic",
                    label,
                    parent.depth + 1,
                    robot=owner,
                    topic=name,
                    msg_type=msg_type,
                )
                leaf.path = name
            leaf.search = f"{leaf.path}\n{name}".casefold()
            leaf.leaves = 1
            by_relative[rel] = by_relative.get(rel, 0) + 1
            leaves.append(leaf)
            if parent is None:
                tops[leaf.key] = leaf
            else:
                parent.children.append(leaf)
        for leaf in leaves:
            robot = leaf.robot if leaf.robot is not None else ""
            leaf.robots_with = by_relative.get(leaf.topic[len(robot) :], 0) if leaf.robot is not None else 0
        if others.children:
            tops["o:"] = others
        roots = sorted(tops.values(), key=_top_order)
        for root in roots:
            _finish(root)
        self.roots = roots
        self.total = len(leaves)
        self._nodes = {n.key: n for n in _walk(roots)}

    # -- open and closed ------------------------------------------------------------------------------

    def is_open(self, node: TreeNode) -> bool:
        """Whether a robot or group shows its children (a filter opens every group with a match)."""
        if node.leaf:
            return False
        if self.query:
            return True
        chosen = self._open.get(node.key)
        if chosen is not None:
            return chosen
        return node.kind == "robot" or self.total <= COLLAPSE_OVER

    def toggle(self, key: str) -> bool:
        """Open a closed group or close an open one; True when it was a group (the rows changed)."""
        node = self._nodes.get(key)
        if node is None or node.leaf or self.query:
            return False
        self._open[key] = not self.is_open(node)
        self._flatten()
        return True

    def node(self, key: str) -> TreeNode | None:
        """The node with `key` (None: not in the tree now)."""
        return self._nodes.get(key)

    # -- the filter -----------------------------------------------------------------------------------

    def set_query(self, text: str) -> None:
        """Keep only the tags and topics whose full name or topic holds `text` (case aside), or match it
        as a glob when it has ``*``, ``?`` or ``[`` (``robot?:motor/*``, ``*rpm``); empty: everything."""
        text = text.strip()
        if text == self.query:
            return
        self.query = text
        self._refilter()

    def _refilter(self) -> None:
        query = self.query.casefold()
        self.glob = bool(_GLOB.search(query))
        if not query:
            keep: Callable[[TreeNode], bool] = lambda n: True  # noqa: E731
        elif self.glob:
            pattern = re.compile(fnmatch.translate(query))
            keep = lambda n: any(pattern.match(part) for part in n.search.split("\n"))  # noqa: E731
        else:
            keep = lambda n: query in n.search  # noqa: E731
        self.matches = sum(_count(root, keep) for root in self.roots)
        self._flatten()

    def _flatten(self) -> None:
        rows: list[TreeNode] = []
        stack = list(reversed(self.roots))
        while stack:
            node = stack.pop()
            if not node.shown:
                continue
            rows.append(node)
            if not node.leaf and self.is_open(node):
                stack.extend(reversed(node.children))
        self.rows = rows
        self.version += 1


def _top_order(node: TreeNode) -> tuple[object, ...]:
    """Robots first (the root's first), then groups, then tags, in natural order; *Other topics* last."""
    if node.kind == "robot":
        return (0, natural_key(node.robot or ""))
    return (1 + (node.key == "o:"), node.leaf, natural_key(node.label))


def _walk(nodes: Iterable[TreeNode]) -> Iterable[TreeNode]:
    stack = list(nodes)
    while stack:
        node = stack.pop()
        yield node
        stack.extend(node.children)


def _finish(node: TreeNode) -> None:
    """Sort a node's children (groups first, then natural order) and count its leaves."""
    if node.leaf:
        return
    node.children.sort(key=lambda n: (n.leaf, natural_key(n.label)))
    for child in node.children:
        _finish(child)
    node.leaves = sum(c.leaves for c in node.children)


def _count(node: TreeNode, keep: Callable[[TreeNode], bool]) -> int:
    """Mark how many leaves under `node` pass `keep` (`TreeNode.shown`) and return it."""
    if node.leaf:
        node.shown = 1 if keep(node) else 0
    else:
        node.shown = sum(_count(c, keep) for c in node.children)
    return node.shown


# -- what a row becomes on the canvas -----------------------------------------------------------------------


def _leaves(node: TreeNode) -> list[TreeNode]:
    """The leaves under `node`, in tree order."""
    if node.leaf:
        return [node]
    return [leaf for child in node.children for leaf in _leaves(child)]


def _mode(node: TreeNode, fleet: Fleet) -> str:
    """A row of the selected robot follows the robot switcher; another robot's row stays on that robot."""
    return SELECTED_ROBOT if fleet.namespaced and node.robot == fleet.selected else ""


def _bind(node: TreeNode, field_path: str, fleet: Fleet) -> Binding:
    binding = Binding(node.topic, field_path)
    mode = _mode(node, fleet)
    return fleet.relative(binding, mode) if mode else binding


def plan_drop(node: TreeNode, fleet: Fleet, fields: Callable[[str], list[FieldInfo]]) -> DropPlan | str:
    """What dropping (or double-clicking) `node` adds: a plot of a number tag, a String of a text tag, a
    Log console of a log topic, a plot of a message's numeric fields, a plot of a group's numbers (those the
    filter shows, up to `PLOT_SERIES`); or why nothing (a robot row, nothing to plot).

    A row of the selected robot gives bindings that follow the selected robot (when robots have
    namespaces); another robot's row binds to that robot's own topics.
    """
    if node.kind == "robot":
        return f"{node.label} is a robot: drag one of its tags or groups (double-click selects the robot)"
    if node.leaf:
        return _plan_leaf(node, fleet, fields)
    numeric = [
        leaf for leaf in _leaves(node) if leaf.kind == "tag" and leaf.msg_type in _NUMBERS and leaf.shown
    ]
    if not numeric:
        return f"{node.label}: no number tags to plot"
    chosen = numeric[:PLOT_SERIES]
    note = (
        f"{len(chosen)} of its {len(numeric)} number tags (a plot shows {PLOT_SERIES})"
        if len(numeric) > PLOT_SERIES
        else ""
    )
    return DropPlan("plot", node.label, tuple(_bind(leaf, "", fleet) for leaf in chosen), note)


def _plan_leaf(node: TreeNode, fleet: Fleet, fields: Callable[[str], list[FieldInfo]]) -> DropPlan | str:
    msg_type = node.msg_type
    if msg_type in _NUMBERS:
        return DropPlan("plot", "", (_bind(node, "", fleet),))
    if msg_type in _TEXT_TYPES:
        return DropPlan("string", "", (_bind(node, "", fleet),))
    if msg_type in _LOG_TYPES:
        return DropPlan("log", "", (_bind(node, "", fleet),))
    if _ARRAY.fullmatch(msg_type):
        return DropPlan(
            "plot", "", (_bind(node, "data[0]", fleet),), "its first element (Topic setup adds more)"
        )
    numeric = [f.path for f in fields(node.topic) if f.numeric and "[" not in f.path]
    if not numeric:
        what = msg_type or "its type is not known yet"
        return f"{node.path}: nothing to plot ({what})"
    chosen = numeric[:PLOT_SERIES]
    note = f"{len(chosen)} of its {len(numeric)} numeric fields" if len(numeric) > PLOT_SERIES else ""
    return DropPlan("plot", "", tuple(_bind(node, f, fleet) for f in chosen), note)


def overlay_problem(node: TreeNode) -> str | None:
    """Why `node` cannot be one plot with a series per robot (None: it can): a number tag that at least
    two robots have."""
    if not node.leaf or node.robot is None or node.kind != "tag":
        return f"{node.label}: only a robot's tag overlays across robots"
    if node.msg_type not in _NUMBERS:
        return f"{node.path}: not a number (a plot overlays numbers)"
    if node.robots_with < 2:
        return f"{node.path}: no other robot has it"
    return None


def plan_overlay(node: TreeNode, fleet: Fleet) -> DropPlan | str:
    """One plot of a tag with a series per robot (`EVERY_ROBOT`), or why not (`overlay_problem`)."""
    problem = overlay_problem(node)
    if problem is not None:
        return problem
    binding = fleet.relative(Binding(node.topic), EVERY_ROBOT)
    return DropPlan("plot", f"{node.label} (every robot)", (binding,))
