"""Pure simulations behind the demo nodes (no ROS): deterministic given a seed, so they are testable."""

from __future__ import annotations

import math
import random
from dataclasses import dataclass, field

__all__ = ["ARENA_SIZE", "SoundReading", "SoundScene", "Turtle", "WallHit", "wrap_angle"]

ARENA_SIZE = 11.0
"""The arena is a square from 0 to this many metres on both axes (like turtlesim's)."""


def wrap_angle(a: float) -> float:
    """Wrap an angle in radians to (-pi, pi]."""
    wrapped = math.remainder(a, math.tau)
    return math.pi if wrapped == -math.pi else wrapped


@dataclass(frozen=True, slots=True)
class WallHit:
    """The turtle touched a wall."""

    wall: str
    """``north``, ``south``, ``east`` or ``west``."""
    count: int
    x: float
    y: float


@dataclass(slots=True)
class Turtle:
    """A unicycle robot in a walled arena, driven by an autopilot unless commanded from outside."""

    x: float = 3.0
    y: float = 1.2
    theta: float = -1.9
    linear: float = 0.0
    """Current forward speed (m/s)."""
    angular: float = 0.0
    """Current turn rate (rad/s)."""
    hits: int = 0
    seed: int = 7
    max_speed: float = 2.0
    _rng: random.Random = field(init=False, repr=False)
    _phase: float = field(init=False, default=0.0, repr=False)

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)

    def autopilot(self, t: float) -> tuple[float, float]:
        """Return the (linear, angular) command of a wandering driver at time `t` (seconds)."""
        linear = 1.2 + 0.6 * math.sin(0.37 * t) + self._rng.gauss(0.0, 0.05)
        angular = 0.9 * math.sin(0.23 * t + 1.0) + 0.4 * math.sin(1.3 * t) + self._rng.gauss(0.0, 0.05)
        return linear, angular

    def step(self, dt: float, linear: float, angular: float) -> WallHit | None:
        """Drive for `dt` seconds with the given command; return the wall hit, if any."""
        self.linear = max(-self.max_speed, min(self.max_speed, linear))
        self.angular = max(-3.0, min(3.0, angular))
        self.theta = wrap_angle(self.theta + self.angular * dt)
        self.x += self.linear * math.cos(self.theta) * dt
        self.y += self.linear * math.sin(self.theta) * dt
        wall = None
        if self.x < 0.0:
            self.x, wall = 0.0, "west"
            self.theta = wrap_angle(math.pi - self.theta)
        elif self.x > ARENA_SIZE:
            self.x, wall = ARENA_SIZE, "east"
            self.theta = wrap_angle(math.pi - self.theta)
        if self.y < 0.0:
            self.y, wall = 0.0, "south"
            self.theta = wrap_angle(-self.theta)
        elif self.y > ARENA_SIZE:
            self.y, wall = ARENA_SIZE, "north"
            self.theta = wrap_angle(-self.theta)
        if wall is None:
            return None
        self.hits += 1
        return WallHit(wall, self.hits, self.x, self.y)

    def wall_distance(self) -> float:
        """Return the distance to the nearest wall (m)."""
        return min(self.x, self.y, ARENA_SIZE - self.x, ARENA_SIZE - self.y)


@dataclass(frozen=True, slots=True)
class SoundReading:
    """One output of the localizer, relative to the head."""

    azimuth: float
    """Radians, positive to the left, relative to where the head faces, in (-pi, pi]."""
    elevation: float
    confidence: float
    """0..1."""
    source: str
    """Which source produced it (for tests; a real localizer would not know)."""


@dataclass(slots=True)
class _Source:
    name: str
    azimuth: float
    """World azimuth (rad)."""
    elevation: float
    loudness: float
    """0..1: how confident a reading of it tends to be."""
    period: float
    duty: float
    """Fraction of each period the source is sounding."""
    offset: float


@dataclass(slots=True)
class SoundScene:
    """A robot head (like NAO's) that turns toward confident sounds and gets distracted by weaker ones.

    A loud speaker talks in bursts at +60 deg; a weaker noise source (a fan) hums at -40 deg; a door slams
    now and then at 150 deg. The localizer's readings are noisy and relative to the head, so while the head
    turns the azimuth of a fixed source sweeps toward zero.
    """

    seed: int = 11
    head_yaw: float = 0.0
    """World yaw of the head (rad)."""
    target_yaw: float | None = None
    turn_rate: float = 1.2
    """Maximum head turn rate (rad/s)."""
    confident: float = 0.6
    """Readings at least this confident make the head turn toward them."""
    distraction: float = 0.3
    """While turning, readings at least this confident (but below `confident`) pull the target halfway."""
    _rng: random.Random = field(init=False, repr=False)
    _sources: list[_Source] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        self._rng = random.Random(self.seed)
        self._sources = [
            _Source("speaker", math.radians(60), math.radians(15), 0.9, period=6.0, duty=0.5, offset=0.0),
            _Source("fan", math.radians(-40), math.radians(-5), 0.38, period=1.0, duty=1.0, offset=0.0),
            _Source("door", math.radians(150), math.radians(0), 0.8, period=11.0, duty=0.08, offset=4.0),
        ]

    def _active(self, t: float) -> list[_Source]:
        return [s for s in self._sources if ((t + s.offset) % s.period) < s.duty * s.period]

    @property
    def turning(self) -> bool:
        """Whether the head is still turning toward a target."""
        return self.target_yaw is not None

    def step(self, t: float, dt: float) -> SoundReading | None:
        """Advance the head by `dt`, then return the localizer's reading at time `t` (None: silence)."""
        if self.target_yaw is not None:
            error = wrap_angle(self.target_yaw - self.head_yaw)
            move = max(-self.turn_rate * dt, min(self.turn_rate * dt, error))
            self.head_yaw = wrap_angle(self.head_yaw + move)
            if abs(error - move) < math.radians(2):
                self.target_yaw = None
        active = self._active(t)
        if not active:
            return None
        # The loudest active source usually wins; sometimes a weaker one is heard instead.
        weights = [s.loudness**2 for s in active]
        source = self._rng.choices(active, weights=weights)[0]
        confidence = max(0.0, min(1.0, source.loudness + self._rng.gauss(0.0, 0.12)))
        noise = math.radians(12) * (1.2 - confidence)
        azimuth = wrap_angle(source.azimuth - self.head_yaw + self._rng.gauss(0.0, noise))
        elevation = source.elevation + self._rng.gauss(0.0, noise / 2)
        reading = SoundReading(azimuth, elevation, confidence, source.name)
        self._react(reading)
        return reading

    def _react(self, reading: SoundReading) -> None:
        world = wrap_angle(self.head_yaw + reading.azimuth)
        if reading.confidence >= self.confident:
            self.target_yaw = world
        elif self.turning and reading.confidence >= self.distraction and self.target_yaw is not None:
            # Distracted: the weaker sound pulls the goal halfway toward itself.
            self.target_yaw = wrap_angle(self.target_yaw + wrap_angle(world - self.target_yaw) / 2)
