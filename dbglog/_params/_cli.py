"""``dbglog params``: list nodes with parameters, list a node's parameters, set them as ``ros2 param set``.

Every question to a node goes through the ground floor's asynchronous `ParamClient` with a deadline
(``--timeout`` to find the node, as long again for its answers): a node that never answers costs that long
and is named, never a hang.
"""

from __future__ import annotations

import argparse
import difflib
import os
import sys
import time
from collections.abc import Sequence
from concurrent.futures import Future
from typing import TYPE_CHECKING, TypeVar

from dbglog._ros._paramclient import DEFAULT_TIMEOUT_S

if TYPE_CHECKING:
    from dbglog._ros._paramclient import ParamClient
    from dbglog._ros._params import Param, ParamValue

__all__ = ["HELP", "add_arguments", "format_table", "parameter_rows", "run", "split_assignments"]

HELP = "List ROS 2 nodes with parameters, a node's parameters (type, value, range, read-only), or set them."

_EPILOG = """\
  dbglog params                      nodes that have parameters, and how many each
  dbglog params /pid_node            its parameters: name, type, value, range/step, read-only, description
  dbglog params pid_node kp ki       only these (full values); a name without / is found in any namespace
  dbglog params /pid_node kp=2.5 enabled=true gains='[1.0, 2.0]'
                                     set them: values are read as `ros2 param set` reads them (YAML: true,
                                     1, 1.0, [1, 2], '1' for the string 1, anything else a string); prints
                                     old -> new, or the node's reason for a rejection (exit status 1)

A node that does not answer within --timeout seconds is named on stderr (exit status 1).
"""

_POLL_S = 0.05
_LOOK_S = 4.0
"""Listing nodes: the graph is looked at this long (at most the timeout). Fast DDS finds most participants
within a second, but one that misses the first announcement only at its next, 3 s later (the same horizon
as ``dbglog tags``)."""
_SETTLE_S = 0.5
"""A node name found in some namespace is taken once the graph's nodes stayed the same this long."""
_CELL = 60
"""Characters of a value or description shown in the table (a named parameter shows its whole value)."""
T = TypeVar("T")


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Declare the ``params`` options."""
    parser.formatter_class = argparse.RawDescriptionHelpFormatter
    parser.epilog = _EPILOG
    parser.add_argument(
        "node", nargs="?", metavar="NODE", help="the node (/ns/name, or a name in any namespace)"
    )
    parser.add_argument(
        "items",
        nargs="*",
        metavar="NAME[=VALUE]",
        help="parameters to show (NAME) or to set (NAME=VALUE)",
    )
    parser.add_argument(
        "--timeout",
        type=float,
        default=DEFAULT_TIMEOUT_S,
        metavar="S",
        help="at most this many seconds to find the node (DDS discovery), and as long for its answers "
        "(default %(default)g)",
    )


def split_assignments(items: Sequence[str]) -> tuple[list[str], list[tuple[str, str]]]:
    """Split the command's items into names to show and (name, text) pairs to set.

    Raises:
        ValueError: an item with an empty name (``=2``), or names mixed with assignments.
    """
    names: list[str] = []
    pairs: list[tuple[str, str]] = []
    for item in items:
        name, sep, text = item.partition("=")
        if not name.strip():
            raise ValueError(f"{item!r} has no parameter name before '='")
        if sep:
            if any(name.strip() == n for n, _ in pairs):
                raise ValueError(f"{name.strip()} is given twice")
            pairs.append((name.strip(), text))
        else:
            names.append(name.strip())
    if names and pairs:
        raise ValueError(
            f"give names to show ({', '.join(names)}) or NAME=VALUE pairs to set, not both in one command"
        )
    return names, pairs


def format_table(header: Sequence[str], rows: Sequence[Sequence[str]]) -> str:
    """Align `rows` under `header` in plain-text columns."""
    widths = [max(len(c) for c in col) for col in zip(header, *rows, strict=True)]
    lines = [
        "  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)).rstrip() for row in [header, *rows]
    ]
    lines.insert(1, "  ".join("-" * w for w in widths))
    return "\n".join(lines)


def _cell(text: str, full: bool) -> str:
    text = text.replace("\n", "\u23ce")
    return text if full or len(text) <= _CELL else text[: _CELL - 1] + "\u2026"


def parameter_rows(params: Sequence[Param], *, full: bool = False) -> list[list[str]]:
    """The table rows of `params`: name, type, value, range, read-only, description (cut unless `full`)."""
    rows = []
    for p in params:
        d = p.descriptor
        about = d.description if d is not None else ""
        if d is not None and d.constraints:
            about = f"{about} ({d.constraints})" if about else d.constraints
        rows.append(
            [
                p.name,
                p.value.type.label,
                _cell(p.value.text, full),
                d.range.text if d is not None and d.range is not None else "-",
                "yes" if d is not None and d.read_only else "",
                _cell(about, full),
            ]
        )
    return rows


class _CommandError(Exception):
    """The command cannot go on: its message is printed, its code returned."""

    def __init__(self, message: str, code: int = 1) -> None:
        super().__init__(message)
        self.code = code


def run(args: argparse.Namespace) -> int:
    """List or set parameters; return the exit code."""
    if not args.timeout > 0:
        return _say(f"--timeout must be a positive number of seconds, not {args.timeout:g}", 2)
    try:
        names, pairs = split_assignments(args.items)
        values = _parse_all(pairs)
    except ValueError as exc:
        return _say(str(exc), 2)
    from dbglog._ros._paramclient import ParamClient

    deadline = time.monotonic() + args.timeout
    with ParamClient(timeout=args.timeout) as client:
        if not client.wait_started(max(args.timeout, 10.0)) or client.error is not None:
            return _say(client.error or "ROS 2 did not start", 1)
        try:
            if args.node is None:
                return _list_nodes(client, args.timeout)
            node = _find_node(client, args.node, deadline)
            deadline = time.monotonic() + args.timeout  # found: the same time again for its answers
            if values:
                return _set(client, node, values, deadline)
            return _show(client, node, names, deadline)
        except _CommandError as exc:
            return _say(str(exc), exc.code)


def _say(message: str, code: int) -> int:
    print(f"dbglog params: {message}", file=sys.stderr)
    return code


def _parse_all(pairs: Sequence[tuple[str, str]]) -> dict[str, ParamValue]:
    from dbglog._ros._params import parse_value

    values: dict[str, ParamValue] = {}
    for name, text in pairs:
        try:
            values[name] = parse_value(text)
        except ValueError as exc:
            raise ValueError(f"{name}={text}: {exc}") from None
    return values


def _left(deadline: float) -> float:
    return max(0.0, deadline - time.monotonic())


def _wait(future: Future[T], deadline: float) -> T:
    """The future's result (its client fails it at the deadline; the margin covers a busy machine)."""
    from dbglog._ros._paramclient import ParamError

    try:
        return future.result(timeout=_left(deadline) + 5.0)
    except ParamError as exc:
        raise _CommandError(str(exc)) from None
    except TimeoutError:  # (concurrent.futures') the client's thread itself is stuck
        raise _CommandError("the parameter client did not finish in time") from None


def _empty_graph() -> str:
    return (
        "no node with parameters on the ROS graph "
        f"(ROS_DOMAIN_ID={os.environ.get('ROS_DOMAIN_ID', '0')}): is the robot on the same ROS_DOMAIN_ID, "
        "and does ROS_AUTOMATIC_DISCOVERY_RANGE reach it?"
    )


def _list_nodes(client: ParamClient, timeout: float) -> int:
    """Print every node with parameters and how many it has (asked as each is found; a silent one says so)."""
    from dbglog._ros._paramclient import ParamError

    start = time.monotonic()
    asked: dict[str, Future[list[str]]] = {}
    while True:
        for node in client.nodes():
            if node not in asked:  # each node gets the whole timeout to answer, from when it is found
                asked[node] = client.list_names(node, timeout=timeout)
        if time.monotonic() - start >= min(timeout, _LOOK_S):
            break
        time.sleep(_POLL_S)
    if not asked:
        raise _CommandError(_empty_graph())
    rows = []
    silent = []
    for node, future in sorted(asked.items()):
        try:
            count = str(len(future.result(timeout=timeout + 5.0)))
        except (ParamError, TimeoutError) as exc:
            count = "did not answer"
            silent.append(str(exc))
        rows.append([node, count])
    print(format_table(["node", "parameters"], rows))
    for line in silent:
        print(f"dbglog params: {line}", file=sys.stderr)
    return 0


def _find_node(client: ParamClient, given: str, deadline: float) -> str:
    """The node `given` names, once discovery shows it (else a `_CommandError` saying why, near names too)."""
    from dbglog._ros._params import resolve_node

    direct = given.startswith("/")
    root = "/" + given.strip().strip("/")
    seen: list[str] = []
    since = time.monotonic()
    while True:
        nodes = client.nodes()
        if nodes != seen:
            seen, since = nodes, time.monotonic()
        found = resolve_node(given, nodes)
        # A name found in some namespace is taken once discovery has been quiet a moment: a node of the
        # same name elsewhere, found a little later, would make it ambiguous.
        settled = time.monotonic() - since >= _SETTLE_S or time.monotonic() >= deadline
        if isinstance(found, str):
            if direct or found == root or settled:
                return found
        elif len(found) > 1 and settled:
            raise _CommandError(f"{given!r} names several nodes: {', '.join(found)} (give the whole name)", 2)
        if time.monotonic() >= deadline:
            break
        time.sleep(_POLL_S)
    nodes, everything = client.nodes(), client.graph_nodes()
    on_graph = resolve_node(given, everything)
    if isinstance(on_graph, str):
        raise _CommandError(f"{on_graph} is on the ROS graph but offers no parameter services")
    if not nodes:
        raise _CommandError(f"no node {given} after {client.timeout:g} s: " + _empty_graph())
    base = given.rsplit("/", 1)[-1]
    near = (
        difflib.get_close_matches(given, nodes, n=3, cutoff=0.6)
        or [n for n in nodes if difflib.SequenceMatcher(None, base, n.rsplit("/", 1)[-1]).ratio() >= 0.6][:3]
    )
    hint = (
        f"; did you mean {' or '.join(near)}?" if near else f"; nodes with parameters: {', '.join(nodes[:8])}"
    )
    more = ", ..." if not near and len(nodes) > 8 else ""
    raise _CommandError(f"no node {given} on the ROS graph after {client.timeout:g} s{hint}{more}")


def _show(client: ParamClient, node: str, names: Sequence[str], deadline: float) -> int:
    """Print the node's parameters (all, or `names` with their whole values)."""
    params = _wait(client.fetch(node, timeout=_left(deadline)), deadline)
    if names:
        by_name = {p.name: p for p in params}
        missing = [n for n in names if n not in by_name]
        if missing:
            raise _CommandError(_not_declared(node, missing, list(by_name)))
        params = [by_name[n] for n in dict.fromkeys(names)]
    print(
        format_table(
            ["name", "type", "value", "range", "read-only", "description"],
            parameter_rows(params, full=bool(names)),
        )
    )
    return 0


def _not_declared(node: str, missing: Sequence[str], known: Sequence[str]) -> str:
    parts = []
    for name in missing:
        near = difflib.get_close_matches(name, known, n=3, cutoff=0.6)
        parts.append(name + (f" (did you mean {' or '.join(near)}?)" if near else ""))
    return f"{node} has no parameter {', '.join(parts)}"


def _set(client: ParamClient, node: str, values: dict[str, ParamValue], deadline: float) -> int:
    """Set the parameters; print old -> new for each accepted one, the node's reason for each rejection."""
    names = _wait(client.list_names(node, timeout=_left(deadline)), deadline)
    declared = [n for n in values if n in names]
    old = _wait(client.get(node, declared, timeout=_left(deadline)), deadline) if declared else {}
    results = _wait(client.set(node, values, timeout=max(_left(deadline), 1.0)), deadline)
    code = 0
    for result in results:
        before = old.get(result.name)
        if result.ok:
            was = before.text if before is not None else "(new)"
            print(f"{node} {result.name}: {was} \u2192 {result.value.text}")
            continue
        code = 1
        why = result.reason or "no reason given"
        if result.name not in names:
            why = f"{_not_declared(node, [result.name], names)}; the node said: {why}"
        asked = f"{result.value.text} ({result.value.type.label})"
        print(f"dbglog params: {node} {result.name}: {asked} rejected: {why}", file=sys.stderr)
    return code
