"""The demo robot's pure simulations: arena walls, the turning head and its distractions."""

from __future__ import annotations

import math

from hypothesis import given
from hypothesis import strategies as st

from dbglog._demo._sim import ARENA_SIZE, SoundScene, Turtle, wrap_angle


@given(st.floats(min_value=-1e6, max_value=1e6, allow_nan=False))
def test_wrap_angle_range(a: float) -> None:
    """Wrapped angles lie in (-pi, pi] and differ from the input by whole turns."""
    w = wrap_angle(a)
    assert -math.pi < w <= math.pi
    assert math.isclose(math.cos(w), math.cos(a), abs_tol=1e-6)


def test_turtle_stays_in_arena_and_counts_hits() -> None:
    """Driving for a simulated five minutes keeps the turtle inside and reports numbered wall hits."""
    turtle = Turtle()
    hits = []
    for i in range(30_000):
        linear, angular = turtle.autopilot(i * 0.01)
        hit = turtle.step(0.01, linear, angular)
        assert 0.0 <= turtle.x <= ARENA_SIZE
        assert 0.0 <= turtle.y <= ARENA_SIZE
        if hit:
            hits.append(hit)
    assert hits, "a wandering turtle meets a wall in five minutes"
    assert [h.count for h in hits] == list(range(1, len(hits) + 1))
    assert {h.wall for h in hits} <= {"north", "south", "east", "west"}


def test_turtle_bounces_off_the_west_wall() -> None:
    """Heading west into the wall reflects the heading east and reports the west wall."""
    turtle = Turtle(x=0.05, y=5.0, theta=math.pi)
    hit = turtle.step(0.1, 1.0, 0.0)
    assert hit is not None
    assert hit.wall == "west"
    assert turtle.x == 0.0
    assert math.cos(turtle.theta) > 0.99


def test_turtle_speed_is_clamped() -> None:
    """Commands beyond the turtle's limits are clamped."""
    turtle = Turtle()
    turtle.step(0.01, 50.0, -50.0)
    assert turtle.linear == turtle.max_speed
    assert turtle.angular == -3.0


def test_head_turns_toward_the_speaker() -> None:
    """After the speaker talks, the head faces it and its relative azimuth shrinks toward zero."""
    scene = SoundScene()
    readings = []
    for i in range(600):  # 60 s at 10 Hz
        r = scene.step(i * 0.1, 0.1)
        if r is not None:
            readings.append((i * 0.1, r))
    speaker = [r for t, r in readings if r.source == "speaker"]
    assert speaker
    assert abs(speaker[0].azimuth) > math.radians(30)
    assert min(abs(r.azimuth) for r in speaker[len(speaker) // 2 :]) < math.radians(10)
    assert all(0.0 <= r.confidence <= 1.0 for _, r in readings)
    assert all(-math.pi < r.azimuth <= math.pi for _, r in readings)


def test_weak_readings_distract_a_turning_head() -> None:
    """A weak reading while turning pulls the target halfway toward it; when still, it is ignored."""
    scene = SoundScene()
    scene.target_yaw = math.radians(60)
    from dbglog._demo._sim import SoundReading

    scene._react(SoundReading(math.radians(-40), 0.0, 0.45, "fan"))
    assert scene.target_yaw is not None
    assert math.isclose(math.degrees(scene.target_yaw), 10.0, abs_tol=1e-6)
    still = SoundScene()
    still._react(SoundReading(math.radians(-40), 0.0, 0.45, "fan"))
    assert still.target_yaw is None
