"""Code for the watch tests to find lines in: functions, methods, nested code, decorators, threads.

Each watched line ends with a marker comment (``# L:name``) that the tests look up.
"""

from __future__ import annotations

import functools
import threading
import time
from collections.abc import Callable


def plain(n: int) -> int:
    total = 0
    for i in range(n):
        total += i  # L:plain
    return total


class Robot:
    def __init__(self) -> None:
        self.speed = 0.0

    def step(self, dt: float) -> float:
        self.speed += dt  # L:method
        return self.speed

    @property
    def fast(self) -> bool:
        return self.speed > 1  # L:property

    @staticmethod
    def helper(x: float) -> float:
        return x * 2  # L:static


def outer(k: int) -> Callable[[int], int]:
    def inner(v: int) -> int:
        return v + k  # L:inner

    return inner


def _deco(fn: Callable[[int], int]) -> Callable[[int], int]:
    @functools.wraps(fn)
    def wrapper(x: int) -> int:
        return fn(x)

    return wrapper


@_deco
def decorated(x: int) -> int:
    y = x + 1  # L:decorated
    return y * 1


def make_callbacks(n: int) -> list[Callable[[], int]]:
    callbacks: list[Callable[[], int]] = []
    for j in range(n):

        def callback(j: int = j) -> int:
            return j * 10  # L:loopfn

        callbacks.append(callback)
    return callbacks


def squares(xs: list[int]) -> list[int]:
    return [x * x for x in xs]  # L:comp


def spin(stop: threading.Event, out: list[int]) -> None:
    n = 0
    while not stop.is_set():
        n += 1
        out.append(n)  # L:thread
        time.sleep(0.001)


# L:comment (a comment holds no code)
CONSTANT = 1
