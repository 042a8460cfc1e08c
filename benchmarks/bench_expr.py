"""Benchmark the formula language and the transforms: parse cost, per-evaluation cost, 10k-point batches.

Run: ``.venv/bin/python -m benchmarks.bench_expr`` (``--quick`` for a short run). Each figure is the median
of repeats; the baselines (a plain Python lambda of the same formula, a hand-written numpy expression) are
measured side by side in the same run. The output is Markdown tables.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from functools import partial
from typing import Any

import numpy as np
import numpy.typing as npt

from benchmarks._common import local_ros_env, median_ns_per_call, print_table
from dbglog.viewer._values import _expr
from dbglog.viewer._values._expr import Formula, parse_formula
from dbglog.viewer._values._transforms import TransformChain

F64 = npt.NDArray[np.float64]


@dataclass(frozen=True)
class Case:
    """A formula with the same computation written as a Python lambda and as numpy code."""

    name: str
    text: str
    plain: Callable[[Mapping[str, float]], float]
    numpy: Callable[[Mapping[str, F64]], F64]


CASES = [
    Case("scale", "x * 57.2958", lambda v: v["x"] * 57.2958, lambda c: c["x"] * 57.2958),
    Case(
        "speed",
        "sqrt(linear.x**2 + linear.y**2)",
        lambda v: math.sqrt(v["linear.x"] ** 2 + v["linear.y"] ** 2),
        lambda c: np.sqrt(c["linear.x"] ** 2 + c["linear.y"] ** 2),
    ),
    Case(
        "heading",
        "degrees(atan2(linear.y, linear.x)) if hypot(linear.x, linear.y) > 0.1 else 0",
        lambda v: (
            math.degrees(math.atan2(v["linear.y"], v["linear.x"]))
            if math.hypot(v["linear.x"], v["linear.y"]) > 0.1
            else 0.0
        ),
        lambda c: np.where(
            np.hypot(c["linear.x"], c["linear.y"]) > 0.1,
            np.degrees(np.arctan2(c["linear.y"], c["linear.x"])),
            0.0,
        ),
    ),
    Case(
        "mixed",
        "clamp(round(x * 100, 2) / 3 + min(linear.x, linear.y, 5) - max(x, 1) ** 2, -10, 10)",
        lambda v: min(
            max(round(v["x"] * 100, 2) / 3 + min(v["linear.x"], v["linear.y"], 5) - max(v["x"], 1) ** 2, -10),
            10,
        ),
        lambda c: np.clip(
            np.round(c["x"] * 100, 2) / 3
            + np.minimum(np.minimum(c["linear.x"], c["linear.y"]), 5)
            - np.maximum(c["x"], 1) ** 2,
            -10,
            10,
        ),
    ),
]

VALUES = {"x": 1.234, "linear.x": 3.0, "linear.y": 4.0}


def _median_s(fn: Callable[[], Any], repeats: int) -> float:
    samples = []
    for _ in range(repeats):
        start = time.perf_counter()
        fn()
        samples.append(time.perf_counter() - start)
    return statistics.median(samples)


def _loop(formula: Formula, records: list[dict[str, float]]) -> list[float]:
    return [formula.evaluate(r) for r in records]


def _batch(chain: TransformChain, times: F64, values: F64) -> F64:
    return chain.fresh().apply_array(times, values)


def _us(ns: float) -> str:
    return f"{ns / 1000:.2f}"


def main() -> int:
    """Run the benchmarks and print Markdown tables."""
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--quick", action="store_true", help="fewer calls and repeats")
    args = parser.parse_args()
    local_ros_env()  # no ROS here, but keep the house rule for every benchmark
    calls, repeats = (2_000, 5) if args.quick else (20_000, 9)
    parse_uncached = _expr._parse_cached.__wrapped__

    rows = []
    for case in CASES:
        formula = parse_formula(case.text)
        assert math.isclose(formula.evaluate(VALUES), case.plain(VALUES), rel_tol=1e-12)
        parse_ns = median_ns_per_call(partial(parse_uncached, case.text), calls=calls // 20, repeats=repeats)
        eval_ns = median_ns_per_call(partial(formula.evaluate, VALUES), calls=calls, repeats=repeats)
        plain_ns = median_ns_per_call(partial(case.plain, VALUES), calls=calls, repeats=repeats)
        rows.append(
            [f"`{case.text}`", _us(parse_ns), _us(eval_ns), _us(plain_ns), f"{eval_ns / plain_ns:.1f}×"]
        )
    print_table(
        "Formula cost per call (µs, median)",
        ["formula", "parse + check", "evaluate", "Python lambda (baseline)", "ratio"],
        rows,
    )

    n = 10_000
    rng = np.random.default_rng(7)
    columns = {"x": rng.normal(size=n), "linear.x": rng.normal(size=n), "linear.y": rng.normal(size=n)}
    records = [{k: float(v[i]) for k, v in columns.items()} for i in range(n)]
    batch_repeats = max(3, repeats // 2)
    rows = []
    for case in CASES:
        formula = parse_formula(case.text)
        got = formula.evaluate_array(columns)
        want = case.numpy(columns)
        assert np.allclose(got, want, rtol=1e-9, atol=1e-12, equal_nan=True), case.name
        array_s = _median_s(partial(formula.evaluate_array, columns), batch_repeats)
        numpy_s = _median_s(partial(case.numpy, columns), batch_repeats)
        loop_s = _median_s(partial(_loop, formula, records), batch_repeats)
        rows.append(
            [
                f"`{case.text}`",
                f"{array_s * 1e3:.2f}",
                f"{numpy_s * 1e3:.2f}",
                f"{loop_s * 1e3:.1f}",
            ]
        )
    print_table(
        f"Formula over {n} points (ms, median)",
        ["formula", "evaluate_array", "hand-written numpy (baseline)", "evaluate in a loop"],
        rows,
    )

    chains = {
        "rad2deg": [{"kind": "rad2deg"}],
        "unwrap → rad2deg → avg(5)": [
            {"kind": "unwrap"},
            {"kind": "rad2deg"},
            {"kind": "moving_average", "window": 5},
        ],
        "formula → derivative → clamp": [
            {"kind": "formula", "expr": "x * 57.2958"},
            {"kind": "derivative"},
            {"kind": "clamp", "min": -100, "max": 100},
        ],
    }
    times = np.cumsum(rng.uniform(0.005, 0.015, size=n))
    angles = np.mod(np.cumsum(rng.normal(0, 0.2, size=n)) + math.pi, 2 * math.pi) - math.pi
    rows = []
    for label, spec in chains.items():
        chain = TransformChain.from_json(spec)
        samples = iter(range(10**9))

        def one(chain: TransformChain = chain, samples: Any = samples) -> None:
            i = next(samples) % n
            chain.apply(float(times[i]), float(angles[i]))

        apply_ns = median_ns_per_call(one, calls=calls, repeats=repeats)
        batch_s = _median_s(partial(_batch, chain, times, angles), batch_repeats)
        rows.append([label, _us(apply_ns), f"{batch_s * 1e3:.2f}"])
    print_table(
        f"Transform chains (apply: µs per sample; apply_array: ms per {n} points; medians)",
        ["chain", "apply", "apply_array"],
        rows,
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
