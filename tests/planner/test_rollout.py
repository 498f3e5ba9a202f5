"""Core knowledge: rollouts in the pymunk world, collisions, and the shortcuts around the engine."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import PAPER_TASKS, Disturbance, Pose, TaskKind
from clomp.planner import RobotModel, Task, perceive, simulate
from clomp.planner.perception import Obstacles
from clomp.planner.engine import World, _rollout
from clomp.planner.contact import unobstructed
from clomp.planner.rollout import in_the_way, straight_limit

ROBOT = RobotModel()
GOAL = Disturbance.goal(1.0, 0.0)


def _box(cx, cy, sx, sy):
    return np.array([[cx - sx / 2, cy - sy / 2], [cx + sx / 2, cy - sy / 2], [cx + sx / 2, cy + sy / 2], [cx - sx / 2, cy + sy / 2]])


def test_straight_hits_a_wall_and_names_it():
    obs = Obstacles.from_boxes([_box(0.5, 0.0, 0.02, 0.4), _box(0.0, 0.8, 0.1, 0.1)])
    out = simulate(TaskKind.STRAIGHT, Pose(0, 0, 0), GOAL, obs, ROBOT.with_(step_length=1.0))
    assert out.collided and out.d_n.ident == 0
    # the contact is on the wall's face and the robot stopped just before it
    assert out.d_n.x == pytest.approx(0.49, abs=0.011)
    front = out.end.x + ROBOT.front_offset + ROBOT.clearance
    assert 0.48 - 0.011 <= front <= 0.49
    w = World(obs, ROBOT)
    w.place(out.end)
    assert w.contact() is None


def test_turn_collides_with_something_beside_the_rear():
    # a box left of the rear: a right (clockwise) spin swings the rear-left corner into it,
    # a left spin swings it away
    obs = Obstacles.from_boxes([_box(-0.12, 0.16, 0.06, 0.06)])
    fixed = ROBOT.with_(free_turns=False)  # quarter turns, as the authors' planner
    right = simulate(TaskKind.RIGHT, Pose(0, 0, 0), GOAL, obs, fixed)
    left = simulate(TaskKind.LEFT, Pose(0, 0, 0), GOAL, obs, fixed)
    assert right.collided and right.d_n.ident == 0
    assert 0 < -right.end.theta < math.pi / 2
    assert not left.collided and left.end.theta == pytest.approx(math.pi / 2)


def test_straight_stops_when_the_goal_comes_abeam():
    goal = Disturbance.goal(0.2, 0.3)
    out = simulate(TaskKind.STRAIGHT, Pose(0, 0, 0), goal, Obstacles.from_boxes([]), ROBOT)
    assert out.end.x == pytest.approx(0.2)
    assert not out.reached_goal


def test_clear_run_to_a_goal_dead_ahead_is_one_task_else_a_step():
    empty = Obstacles.from_boxes([])
    assert straight_limit(empty, ROBOT, Pose(0, 0, 0), GOAL) == pytest.approx(1.0)
    blocked = Obstacles.from_boxes([_box(0.6, 0.0, 0.05, 0.2)])
    assert straight_limit(blocked, ROBOT, Pose(0, 0, 0), GOAL) == ROBOT.step_length
    assert straight_limit(empty, ROBOT, Pose(0, 0, math.pi / 2), GOAL) == ROBOT.step_length


def test_corridor_filter_keeps_what_is_in_the_way_only():
    obs = Obstacles.from_boxes([_box(0.5, 0.0, 0.05, 0.05), _box(0.5, 0.5, 0.05, 0.05), _box(-0.6, 0.0, 0.05, 0.05)])
    assert in_the_way(obs, ROBOT, Pose(0, 0, 0), TaskKind.STRAIGHT, 0.27 + 0.2).tolist() == [0]
    assert in_the_way(obs, ROBOT, Pose(0, 0, math.pi / 4), TaskKind.STRAIGHT, 0.8).tolist() == [1]
    assert in_the_way(obs, ROBOT, Pose(0, 0, 0), TaskKind.LEFT, 0.0).tolist() == []


def test_rollouts_are_deterministic():
    obs = perceive(np.c_[np.full(30, 0.45), np.linspace(-0.2, 0.2, 30)])
    a = [simulate(k, Pose(0.1, -0.05, 0.3), GOAL, obs, ROBOT) for k in PAPER_TASKS]
    b = [simulate(k, Pose(0.1, -0.05, 0.3), GOAL, obs, ROBOT) for k in PAPER_TASKS]
    assert a == b


poses = st.builds(Pose, st.floats(-0.5, 0.5), st.floats(-0.5, 0.5), st.floats(-3.1, 3.1))


@settings(max_examples=100, deadline=None)
@given(poses, st.sampled_from(list(PAPER_TASKS)), st.floats(0.05, 0.6))
def test_closed_form_equals_the_tick_loop(start, kind, limit):
    """With nothing in the way, the O(1) outcome is what the controller does tick by tick."""
    task = Task.straight(ROBOT, start, GOAL, limit) if kind is TaskKind.STRAIGHT else Task.turn(ROBOT, kind, start, GOAL)
    fast, slow = unobstructed(task), _rollout(task, None)
    assert fast.ticks == slow.ticks
    assert fast.duration == pytest.approx(slow.duration)
    assert fast.end.x == pytest.approx(slow.end.x, abs=1e-9)
    assert fast.end.y == pytest.approx(slow.end.y, abs=1e-9)
    assert math.isclose(math.cos(fast.end.theta - slow.end.theta), 1.0, abs_tol=1e-12)


@settings(max_examples=150, deadline=None)
@given(
    poses,
    st.sampled_from(list(PAPER_TASKS)),
    st.lists(st.tuples(st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(0.02, 0.2), st.floats(0.02, 0.2)), min_size=1, max_size=4),
)
def test_a_clear_sweep_means_no_tick_collides(start, kind, boxes):
    """Soundness of the one-query sweep: when it says clear, no tick of the real rollout touches."""
    obs = Obstacles.from_boxes([_box(*b) for b in boxes])
    world = World(obs, ROBOT)
    world.place(start)
    if world.contact() is not None:
        return
    task = Task.straight(ROBOT, start, None, 0.4) if kind is TaskKind.STRAIGHT else Task.turn(ROBOT, kind, start)
    clear = world.sweep_is_clear(task)
    ticked = _rollout(task, World(obs, ROBOT))
    if clear:
        assert not ticked.collided
    if ticked.collided:
        assert not clear


@settings(max_examples=60, deadline=None)
@given(
    st.lists(st.tuples(poses, st.sampled_from(list(PAPER_TASKS))), min_size=2, max_size=8),
    st.lists(st.tuples(st.floats(-0.8, 0.8), st.floats(-0.8, 0.8), st.floats(0.02, 0.2), st.floats(0.02, 0.2)), min_size=1, max_size=4),
)
def test_a_reused_world_gives_the_outcomes_of_fresh_ones(rollouts, boxes):
    """Reusing one world per set of obstacles (as the Configurator does) changes no outcome."""
    obs = Obstacles.from_boxes([_box(*b) for b in boxes])
    cache: dict = {}
    for start, kind in rollouts:
        assert simulate(kind, start, GOAL, obs, ROBOT, cache) == simulate(kind, start, GOAL, obs, ROBOT)
