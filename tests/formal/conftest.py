"""Hand-built models for the formal tests: a one-state model and a probabilistic MDP."""

from __future__ import annotations

from fractions import Fraction

import pytest

from clomp.formal import CognitiveMap, Disturbance, DisturbanceKind, Pose, State, TaskKind


@pytest.fixture
def one_state_map() -> CognitiveMap:
    """A plan that is only q0 (no safe task): one state, no transition."""
    g = Disturbance.goal(1.0, 0.0)
    return CognitiveMap.from_parts([State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5)], [], goal=g)

@pytest.fixture
def branching_map() -> CognitiveMap:
    """q0's STRAIGHT ends in three outcomes (1/5 collision, 3/10 short, 1/2 goal) with
    different distances, and LEFT is a sure alternative: an MDP with probabilistic branches."""
    g = Disturbance.goal(1.0, 0.0)
    hit = Disturbance(DisturbanceKind.OBSTACLE, 0.3, 0.0, ident=1)
    s = [
        State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
        State(1, TaskKind.STRAIGHT, g, hit, Pose(0, 0), Pose(0.2, 0), distance=0.2, duration=1.0, cost=1.5),
        State(2, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.6, 0), distance=0.6, duration=3.0, cost=0.3),
        State(3, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1.0, 0), distance=1.0, duration=5.0, cost=0.0, reached_goal=True),
        State(4, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.0), distance=0.0, duration=2.0, cost=0.5),
    ]
    m = CognitiveMap.from_parts(s, [], goal=g)
    m.add_transition(0, 1, TaskKind.STRAIGHT, Fraction(1, 5))
    m.add_transition(0, 2, TaskKind.STRAIGHT, Fraction(3, 10))
    m.add_transition(0, 3, TaskKind.STRAIGHT, Fraction(1, 2))
    m.add_transition(0, 4, TaskKind.LEFT)
    m.add_transition(2, 3, TaskKind.STRAIGHT)
    m.metadata["plan"] = [0, 2, 3]
    return m


@pytest.fixture
def risky_map() -> CognitiveMap:
    """Greedy best-first takes the short STRAIGHT that hits the obstacle 1 time in 5; the
    detour LEFT, STRAIGHT, RIGHT, STRAIGHT always arrives. Plan (φ): q0 → q1."""
    g = Disturbance.goal(1.0, 0.0)
    hit = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0, ident=1)
    s = [
        State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
        State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), distance=1.0, cost=0.0, reached_goal=True),
        State(2, TaskKind.STRAIGHT, g, hit, Pose(0, 0), Pose(0.4, 0), distance=0.4, cost=1.5),
        State(3, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.57), cost=0.5),
        State(4, TaskKind.STRAIGHT, g, None, Pose(0, 0, 1.57), Pose(0, 0.3, 1.57), distance=0.3, cost=0.55),
        State(5, TaskKind.RIGHT, g, None, Pose(0, 0.3, 1.57), Pose(0, 0.3, 0), cost=0.55),
        State(6, TaskKind.STRAIGHT, g, None, Pose(0, 0.3, 0), Pose(1, 0.02, 0), distance=1.1, cost=0.01, reached_goal=True),
    ]
    m = CognitiveMap.from_parts(s, [], goal=g)
    m.add_transition(0, 1, TaskKind.STRAIGHT, Fraction(4, 5))
    m.add_transition(0, 2, TaskKind.STRAIGHT, Fraction(1, 5))
    for a, b in ((0, 3), (3, 4), (4, 5), (5, 6)):
        m.add_transition(a, b)
    return m
