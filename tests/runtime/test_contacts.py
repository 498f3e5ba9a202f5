"""The contact-episode counter on hand-made traces: what counts as one collision, what as a brush."""

from __future__ import annotations

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.runtime.experiment.contacts import (
    BRUSH_DEPTH_M,
    PUSH_MARGIN_S,
    ContactCount,
    Episode,
    Push,
    contact_episodes,
    count_contacts,
    mark_pushed,
)

TICK = 0.02


def grind(t0: float, seconds: float, depth: float) -> list[tuple[float, float]]:
    return [(t0 + k * TICK, depth) for k in range(int(round(seconds / TICK)) + 1)]


def test_one_long_grind_is_one_collision():
    c = count_contacts(grind(1.0, 6.0, 0.004))
    assert (c.collisions, c.brushes) == (1, 0)
    assert c.episodes[0].duration_s == pytest.approx(6.0)


def test_two_light_touches_two_seconds_apart_are_two_brushes():
    c = count_contacts(grind(1.0, 0.1, 0.003) + grind(3.1, 0.1, 0.002))
    assert (c.collisions, c.brushes) == (0, 2)


def test_touches_less_than_a_second_apart_are_one_episode():
    # bouncing off a box: contact, 0.6 s free, contact again, 0.9 s free, contact
    trace = grind(1.0, 0.1, 0.002) + grind(1.7, 0.1, 0.002) + grind(2.7, 0.1, 0.002)
    eps = contact_episodes(trace)
    assert len(eps) == 1 and eps[0].samples == len(trace)
    # the merged episode lasts 1.8 s: a collision, not a brush
    assert eps[0].kind == "collision"


def test_a_gap_of_exactly_one_second_separates():
    assert len(contact_episodes([(0.0, 0.001), (1.0, 0.001)])) == 2
    assert len(contact_episodes([(0.0, 0.001), (0.999, 0.001)])) == 1


def test_deep_short_contact_is_a_collision():
    assert count_contacts(grind(0.0, 0.1, 0.02)).collisions == 1


def test_shallow_but_long_contact_is_a_collision():
    assert count_contacts(grind(0.0, 0.5, 0.001)).collisions == 1
    assert count_contacts(grind(0.0, 0.48, 0.001)).brushes == 1


def test_no_contact_no_episode():
    assert count_contacts([]).episodes == ()


@pytest.mark.parametrize("bad, match", [
    ([(0.0,)], "expected"), ([(float("nan"), 0.0)], "finite"), ([(0.0, -0.1)], "penetration"),
    ([(1.0, 0.0), (0.5, 0.0)], "goes back"), (["xy"], "expected"),
])
def test_bad_traces_are_refused_with_the_sample_named(bad, match):
    with pytest.raises(ValueError, match=match):
        count_contacts(bad)


@given(st.lists(st.tuples(st.floats(0, 100), st.floats(0, 0.05)), max_size=60))
@settings(max_examples=80, deadline=None)
def test_every_sample_in_exactly_one_episode_and_episodes_a_second_apart(samples):
    trace = sorted(samples)
    eps = contact_episodes(trace)
    assert sum(e.samples for e in eps) == len(trace)
    gaps = sum(b[0] - a[0] >= 1.0 for a, b in zip(trace, trace[1:]))
    assert len(eps) == (gaps + 1 if trace else 0)
    for a, b in zip(eps, eps[1:]):
        assert b.start_s - a.end_s >= 1.0
    for e in eps:
        assert e.brush == (e.max_penetration_m < BRUSH_DEPTH_M and e.duration_s < 0.5)


# -- pushed contacts (what a push of the world slid the body into), counted apart ----------------
def _world_run(actions):
    from clomp.planner import load_scenario
    from clomp.runtime.backends.world import make_world_robot
    from clomp.runtime.experiment.onerun import run_contacts

    scene = load_scenario("overtaking")  # a box 0.36 m ahead of the body's front
    w = make_world_robot(scene, "ideal", seed=0)
    for act in actions:
        act(w)
    return run_contacts(w, scene)[0]


def test_a_push_into_the_box_is_a_pushed_contact_not_a_collision():
    eps = _world_run([lambda w: w.sleep(0.5), lambda w: w.push(0.5, 0.0),
                      lambda w: w.set_wheel_speeds(0.05, 0.05), lambda w: w.sleep(1.5)])
    c = ContactCount(tuple(eps))
    assert (c.collisions, c.pushed) == (0, 1), eps


def test_driving_into_the_box_stays_a_collision_even_after_a_push_away():
    eps = _world_run([lambda w: w.sleep(0.5), lambda w: w.push(0.2, 3.14159),   # pushed back, away from the box
                      lambda w: w.sleep(0.5), lambda w: w.set_wheel_speeds(0.2, 0.2), lambda w: w.sleep(4.0)])
    c = ContactCount(tuple(eps))
    assert (c.collisions, c.pushed) == (1, 0), eps


def test_a_contact_after_the_slide_is_the_robots_own():
    late = Episode(10.0 + 0.23 + PUSH_MARGIN_S + 0.01, 12.0, 0.02, 100, False)
    on_time = Episode(10.2, 12.0, 0.02, 100, False)
    brush = Episode(10.1, 10.2, 0.002, 5, True)
    push = Push(10.0, 0.23, 0.0, 0.0, 0.0)
    got = mark_pushed([late, on_time, brush, on_time], [push], [(0.3, 0.0)] * 3 + [(-0.3, 0.0)])  # the last behind
    assert [e.pushed for e in got] == [False, True, False, False]
    c = ContactCount(tuple(got))
    assert (c.collisions, c.pushed, c.brushes) == (2, 1, 1)
