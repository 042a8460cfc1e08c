"""A plain Python script with no ROS code: dbglog publishes its values on ROS 2 topics anyway.

Run: ``.venv/bin/python examples/plain_script.py [--steps N]``; ``DBGLOG=off`` makes every call a no-op.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

import dbglog


def simulate(steps: int, dt: float) -> float:
    """Integrate a damped spring and log its state at each step; return the final position."""
    x, v = 1.0, 0.0
    for step in range(steps):
        a = -4.0 * x - 0.3 * v
        v += a * dt
        x += v * dt
        dbglog.logfloat("spring/x", x)
        dbglog.logfloat("spring/v", v)
        dbglog.logint("spring/step", step)
        dbglog.log("spring/energy", {"kinetic": 0.5 * v * v, "potential": 2.0 * x * x})
        dbglog.logstring("spring/phase", "out" if x > 0 else "in", throttle=0.5)
        if __debug__:  # removed from the bytecode under python -O
            dbglog.logfloat("spring/amplitude", math.hypot(x, v / 2.0))
        time.sleep(dt)
    return x


def main(argv: list[str] | None = None) -> int:
    """Run the simulation and print dbglog's counters."""
    parser = argparse.ArgumentParser(description="plain script logging with dbglog")
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--dt", type=float, default=0.02)
    args = parser.parse_args(argv)
    final = simulate(args.steps, args.dt)
    dbglog.flush(1.0)
    s = dbglog.stats()
    print(
        f"x={final:.4f} enabled={dbglog.enabled} calls={s.calls} published={s.published} dropped={s.dropped}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
