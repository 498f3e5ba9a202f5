"""The rollout tested in blocks of ticks is the engine's tick loop, bit for bit (issue #40's
robust-vs-greedy sweep needed robust runs cheaper without changing one of them)."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.geometry import points_to_frame, points_to_frames
from clomp.formal.model import Pose, TaskKind
from clomp.planner.engine import World
from clomp.planner.perception import perceive
from clomp.planner.probabilistic import _NoisyTask
from clomp.planner.robot_model import RobotModel
from clomp.planner.tick_blocks import rollout_in_blocks

ROBOT = RobotModel()


def _task(kind: TaskKind, start: Pose, limit: float, seed: int, sd: float = 0.1, slip: float = 0.05) -> _NoisyTask:
    rng = np.random.default_rng(seed)
    return _NoisyTask(kind, ROBOT, start, limit, None, False, 0.01, -0.02, sd, 0.01, rng, slip)


@settings(max_examples=120, deadline=None)
@given(
    pts=st.lists(st.tuples(st.floats(-0.8, 0.8), st.floats(-0.8, 0.8)), min_size=0, max_size=40),
    kind=st.sampled_from([TaskKind.STRAIGHT, TaskKind.LEFT, TaskKind.RIGHT]),
    theta=st.floats(-math.pi, math.pi),
    limit=st.floats(0.0, 1.0),
    seed=st.integers(0, 2**16),
    block=st.sampled_from([1, 2, 5, 48]),
    errors=st.sampled_from([(0.1, 0.05), (0.1, 0.0), (0.0, 0.05), (0.0, 0.0)]),
)
def test_blocks_give_the_engine_outcome_and_leave_the_generator_where_it_does(pts, kind, theta, limit, seed, block, errors):
    obstacles = perceive(np.array(pts, dtype=float).reshape(-1, 2))
    start = Pose(0.0, 0.0, theta)
    lim = limit * (math.pi if kind.is_turn else 1.0)
    a, b = _task(kind, start, lim, seed, *errors), _task(kind, start, lim, seed, *errors)
    wa, wb = World(obstacles, ROBOT), World(obstacles, ROBOT)
    ref = wa.rollout(a)
    got = rollout_in_blocks(b, wb, block)
    assert got == ref
    assert a.rng.bit_generator.state == b.rng.bit_generator.state
    assert tuple(wa.body.position) == tuple(wb.body.position) and wa.body.angle == wb.body.angle


def test_contacts_are_met_mid_block_and_the_draws_after_them_given_back():
    obstacles = perceive(np.array([[0.3, y] for y in np.linspace(-0.2, 0.2, 21)]))
    a, b = _task(TaskKind.STRAIGHT, Pose(0, 0, 0), 1.0, 7), _task(TaskKind.STRAIGHT, Pose(0, 0, 0), 1.0, 7)
    ref = World(obstacles, ROBOT).rollout(a)
    assert ref.d_n is not None and 0 < ref.ticks
    assert rollout_in_blocks(b, World(obstacles, ROBOT), ref.ticks + 10) == ref
    assert a.rng.bit_generator.state == b.rng.bit_generator.state


@given(st.lists(st.tuples(st.floats(-5, 5), st.floats(-5, 5), st.floats(-7, 7)), min_size=1, max_size=5))
def test_points_to_frames_is_points_to_frame_per_pose(poses):
    pts = np.array([[0.3, -0.2], [1.5, 2.0], [-0.7, 0.1]])
    u, v = points_to_frames(pts, [p[0] for p in poses], [p[1] for p in poses], [p[2] for p in poses])
    for i, p in enumerate(poses):
        one = points_to_frame(pts, p)
        assert u[i].tolist() == one[:, 0].tolist() and v[i].tolist() == one[:, 1].tolist()
