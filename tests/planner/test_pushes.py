"""The world's external pushes in the probabilistic map's rollouts (clomp.planner.pushes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose, TaskKind
from clomp.planner.engine import Outcome
from clomp.planner.noise import NoiseError
from clomp.planner.probabilistic import sample_map
from clomp.planner.pushes import Pushes, push_outcome
from clomp.planner.robot_model import RobotModel

WALL = np.array([[x, 0.25] for x in np.linspace(-0.5, 1.5, 201)])


def test_the_presets_pushes_are_the_worlds():
    assert Pushes.preset("harsh") == Pushes(0.02, 0.2)
    assert not Pushes.preset("paper").active and not Pushes.preset("harsh-modelled").active
    with pytest.raises(NoiseError):
        Pushes(-1.0, 0.2)


def test_inactive_pushes_leave_the_map_as_it_was():
    """No draw is taken without pushes: the map is the one sampled without the term (a
    tolerance of 1 mm keeps every rollout's own end, so one draw more would show)."""
    kw = dict(samples=6, noise="harsh", seed=3, carry=True, tolerance=(0.001, 0.001))
    a = sample_map(WALL, (0.8, -0.6), **kw)
    assert len(a.map) > 12
    b = sample_map(WALL, (0.8, -0.6), pushes=Pushes.preset("paper"), **kw)
    assert a.map.to_dict() == b.map.to_dict()


def test_a_push_beside_a_wall_ends_some_rollouts_in_it():
    """Pushed often enough, a straight along a wall 0.25 m off meets it in some noisy
    worlds (a collision outcome), never in the open."""
    pushes = Pushes(rate=0.5, size=0.2)
    near = sample_map(WALL, (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True, pushes=pushes)
    assert any(s.interrupted for s in near.map.states()), "no push met the wall"
    assert near.map.metadata["pushes"] == [0.5, 0.2]
    open_ = sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True, pushes=pushes)
    assert not any(s.interrupted for s in open_.map.states())
    assert len(open_.map) > len(sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True).map)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), duration=st.floats(0.1, 30.0))
def test_a_push_either_meets_an_obstacle_or_moves_the_end_by_its_slide(seed, duration):
    out = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.5, 0.0), 0.5, duration, 50, None, False)
    got = push_outcome(out, WALL, RobotModel(), Pushes(0.2, 0.2), np.random.default_rng(seed))
    if got is out:
        return
    if got.d_n is not None:
        assert got.end.y > 0.0  # slid towards the wall, where it met it
    else:
        moved = math.hypot(got.end.x - out.end.x, got.end.y - out.end.y)
        assert 0.1 - 1e-9 <= moved <= 0.3 + 1e-9
