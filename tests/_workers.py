"""Keep parallel test workers (pytest-xdist) apart: one ROS domain and one X display each."""

from __future__ import annotations

from collections.abc import Mapping

__all__ = ["MAX_DOMAIN", "private_display", "worker_domain", "worker_index"]

# Fast DDS maps a domain to UDP ports 7400 + 250 * domain (+ offsets): 232 is the last that fits.
MAX_DOMAIN = 232
# Worker k runs on the session's domain + k * _STRIDE: .ci/run gives its two suites domains 1-45 and
# 51-95, so with two workers each no two of the four share one.
_STRIDE = 100


def worker_index(env: Mapping[str, str]) -> int:
    """Return this process's pytest-xdist worker number (``gw3`` is 3), 0 when not a worker."""
    name = env.get("PYTEST_XDIST_WORKER", "")
    if not name:
        return 0
    if not (name.startswith("gw") and name[2:].isdigit()):
        raise ValueError(f"PYTEST_XDIST_WORKER={name!r}: expected gw<number>")
    return int(name[2:])


def worker_domain(base: int, env: Mapping[str, str]) -> int:
    """Return the ROS domain of this worker: the session's `base` for the first, apart for the others.

    Raises:
        ValueError: the worker's domain would be past what Fast DDS can map to ports.
    """
    domain = base + _STRIDE * worker_index(env)
    if not 0 <= domain <= MAX_DOMAIN:
        raise ValueError(
            f"ROS_DOMAIN_ID {base} with worker {env.get('PYTEST_XDIST_WORKER')!r} gives domain {domain}, "
            f"outside 0-{MAX_DOMAIN}: run fewer workers or a lower ROS_DOMAIN_ID"
        )
    return domain


def private_display(env: Mapping[str, str]) -> bool:
    """Return whether GUI tests need an X display of their own: several workers would share one screen."""
    return int(env.get("PYTEST_XDIST_WORKER_COUNT", "1") or "1") > 1
