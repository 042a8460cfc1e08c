"""Real rclpy nodes with parameters for the tests: ranges with steps, read-only, a rejecting callback, and a
node whose services are on the graph but never answer (it never spins). No mocks."""

from __future__ import annotations

import threading
from types import TracebackType
from typing import Any, Self

import rclpy
from rcl_interfaces.msg import (
    FloatingPointRange,
    IntegerRange,
    ParameterDescriptor,
    SetParametersResult,
)
from rclpy.context import Context
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

__all__ = ["CURSED", "ParamNodes"]

CURSED = 5.0
"""The value of ``kp`` the nodes' own on-set-parameters callback rejects."""


def _declare(node: Node) -> None:
    """Declare the test parameters on `node`."""
    node.declare_parameter(
        "kp",
        1.25,
        ParameterDescriptor(
            description="proportional gain",
            floating_point_range=[FloatingPointRange(from_value=0.0, to_value=10.0, step=0.25)],
        ),
    )
    node.declare_parameter(
        "count",
        10,
        ParameterDescriptor(
            description="samples averaged",
            integer_range=[IntegerRange(from_value=0, to_value=100, step=5)],
            additional_constraints="a multiple of 5",
        ),
    )
    node.declare_parameter("frame", "base_link", ParameterDescriptor(read_only=True, description="fixed"))
    node.declare_parameter("gains", [1.0, 2.0])
    node.declare_parameter("names", ["a", "b"])
    node.declare_parameter("enabled", True)
    node.declare_parameter("label", "hello")

    def refuse_cursed(params: list[Parameter]) -> SetParametersResult:
        for p in params:
            if p.name == "kp" and p.value == CURSED:
                return SetParametersResult(successful=False, reason=f"kp={CURSED} makes the arm oscillate")
        return SetParametersResult(successful=True)

    node.add_on_set_parameters_callback(refuse_cursed)


class ParamNodes:
    """Nodes on the graph for a test module: `/<ns>/<name>` and `/<other>/<name>` answer (same parameters),
    `/<name>_hung` has parameter services that never answer.

    Args:
        name: the nodes' base name (unique per test module).
        namespace: the first node's namespace.
        other: the second node's namespace (two nodes of one name make a bare name ambiguous).
    """

    def __init__(self, name: str, namespace: str = "/robot", other: str = "/arm") -> None:
        self.context = Context()
        rclpy.init(context=self.context)
        self.node = Node(name, namespace=namespace, context=self.context)
        self.twin = Node(name, namespace=other, context=self.context)
        for node in (self.node, self.twin):
            _declare(node)
        self.fqn = self.node.get_fully_qualified_name()
        self.twin_fqn = self.twin.get_fully_qualified_name()
        self._executor = SingleThreadedExecutor(context=self.context)
        self._executor.add_node(self.node)
        self._executor.add_node(self.twin)
        self.hung_context = Context()
        rclpy.init(context=self.hung_context)
        self.hung = Node(f"{name}_hung", context=self.hung_context)  # never spun: its services never answer
        self.hung.declare_parameter("kp", 1.0)
        self.hung_fqn = self.hung.get_fully_qualified_name()
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f"{name}-spin", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        try:
            while not self._stop.is_set() and self.context.ok():
                self._executor.spin_once(timeout_sec=0.05)
        except ExternalShutdownException:
            pass

    def set_own(self, name: str, value: Any) -> None:
        """The node changes its own parameter (as a node's code does)."""
        result = self.node.set_parameters([Parameter(name, value=value)])[0]
        assert result.successful, result.reason

    def value(self, name: str) -> Any:
        """The node's current value of `name`."""
        return self.node.get_parameter(name).value

    def close(self) -> None:
        """Stop spinning and shut both contexts down."""
        self._stop.set()
        self._thread.join(timeout=5)
        self._executor.shutdown(timeout_sec=1)
        for node in (self.node, self.twin):
            node.destroy_node()
        self.hung.destroy_node()
        for context in (self.context, self.hung_context):
            if context.ok():
                rclpy.shutdown(context=context)

    def __enter__(self) -> Self:
        return self

    def __exit__(
        self, et: type[BaseException] | None, ev: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.close()
