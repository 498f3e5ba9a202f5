"""The planning origin's last-resort small turn (π/8): it frees a robot beside an obstacle.

Overtaking layout 0/1 (seed 0): a 0.28 m box in a 0.97 m corridor leaves passages of
0.33 m and 0.36 m for the 0.18 m body. A 2° turn overshoot put the robot between the box
and the wall, heading 21° towards the wall; from there a turn of π/4 or more faces the
box or the wall, and without the small mark the plan was empty (UNREACHABLE).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner import Configurator
from clomp.planner.perception import perceive
from clomp.planner.rollout import turn_angle
from clomp.planner.robot_model import RobotModel

WEDGED = Pose(0.577, 0.295, 0.373)  # world frame: where run 0/1 halted on main at e43ba57
PI_8 = pytest.approx(math.pi / 8, abs=1e-9)


def _edge(a: tuple[float, float], b: tuple[float, float], n: int) -> list[tuple[float, float]]:
    return [(a[0] + (b[0] - a[0]) * t, a[1] + (b[1] - a[1]) * t) for t in np.linspace(0.0, 1.0, n)]


def _scan(pose: Pose) -> tuple[np.ndarray, tuple[float, float]]:
    """The layout's box and walls as the LiDAR at ``pose`` sees them (1 cm rounding), and the goal."""
    box = [(0.523, -0.113), (0.799, -0.113), (0.799, 0.147), (0.523, 0.147)]
    pts: list[tuple[float, float]] = []
    for i in range(4):
        pts += _edge(box[i], box[(i + 1) % 4], 30)
    pts += _edge((-0.4, 0.4755), (1.5, 0.4755), 190) + _edge((-0.4, -0.4755), (1.5, -0.4755), 190)
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    local = np.array([((x - pose.x) * c + (y - pose.y) * s, -(x - pose.x) * s + (y - pose.y) * c) for x, y in pts])
    local = local[np.hypot(local[:, 0], local[:, 1]) <= 1.1]
    gx, gy = 1.0 - pose.x, 0.0 - pose.y
    return np.round(local, 2), (gx * c + gy * s, -gx * s + gy * c)


def test_a_robot_beside_a_box_turns_a_little_and_drives_on() -> None:
    scan, goal = _scan(WEDGED)
    r = Configurator().plan(scan, goal)
    assert r.steps, "the plan is empty: no task frees the robot"
    first = r.steps[0]
    assert first.task is TaskKind.RIGHT
    assert abs(first.end.theta) == PI_8
    assert r.collision_free
    # it leads towards the goal: the plan ends closer than the robot is now
    end = r.map[r.plan.end].end
    assert math.hypot(goal[0] - end.x, goal[1] - end.y) < math.hypot(*goal) - 0.1


def test_the_small_mark_is_offered_at_the_planning_origin_only() -> None:
    scan, goal = _scan(WEDGED)
    robot = RobotModel()
    obstacles = perceive(scan, robot.sensor_range, robot.cluster_distance,
                         body=(robot.rear_offset, robot.front_offset, robot.width / 2))
    at_origin = turn_angle(TaskKind.RIGHT, Pose(0.0, 0.0, 0.0), Disturbance.goal(*goal), obstacles, robot)
    assert at_origin == PI_8
    # the same pose 1 mm along the heading is a state deeper in a search: the usual marks only
    deeper = turn_angle(TaskKind.RIGHT, Pose(0.001, 0.0, 0.0), Disturbance.goal(*goal), obstacles, robot)
    assert deeper >= math.pi / 4 - 1e-9

