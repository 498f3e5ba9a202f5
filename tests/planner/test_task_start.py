"""A task's error at its start, as the rollouts read it (Task.start_error), is error_at there."""

from __future__ import annotations

import math

from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task

coord = st.floats(-2.0, 2.0, allow_nan=False)


@settings(max_examples=300, deadline=None)
@given(
    st.sampled_from(list(TaskKind)),
    coord,
    coord,
    st.floats(-math.pi, math.pi, allow_nan=False),
    st.floats(0.0, 1.2) | st.just(0.0),
    st.none() | st.tuples(coord, coord),
)
def test_start_error_is_the_error_at_the_start(kind, x, y, theta, limit, goal):
    robot = RobotModel()
    start = Pose(x, y, theta)
    g = None if goal is None else Disturbance.goal(*goal)
    if kind is TaskKind.STRAIGHT:
        task = Task.straight(robot, start, g, limit)
    elif kind is TaskKind.WAIT:
        task = Task.wait(robot, start, g, limit)
    elif kind is TaskKind.REVERSE:
        task = Task.reverse(robot, start, g, limit)
    else:
        task = Task.turn(robot, kind, start, g, min(limit, math.pi))
    assert task.start_error() == task.error_at(x, y, theta)
