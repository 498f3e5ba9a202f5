"""The scene's remembered answers (clomp.planner.contact) are the answers of a pass over all points.

A plan asks the same questions many times: the straight after a turn asks what the turn's
choice of angle already computed, the left and the right turn from one pose are answered by
one array operation, and every question from one position looks only at the points within
reach. Each shortcut must give, to the bit, what a fresh scene computes from every point.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from clomp.formal.model import Pose, TaskKind
from clomp.planner import RobotModel, Task, perceive
from clomp.planner.contact import Scene

ROBOT = RobotModel()


def _scene(rng: np.random.Generator) -> tuple[Scene, Pose]:
    # walls, posts and clutter round a pose, some points within the body's margin
    n = int(rng.integers(5, 400))
    pts = rng.uniform(-1.0, 1.0, (n, 2))
    a = rng.uniform(-math.pi, math.pi)
    wall = np.c_[np.linspace(-1, 1, 120), np.full(120, rng.uniform(0.1, 0.4))] @ np.array(
        [[math.cos(a), math.sin(a)], [-math.sin(a), math.cos(a)]]
    )
    pose = Pose(float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-math.pi, math.pi)))
    # and a few within the body's 1 cm margin at the pose (the start-touching rule)
    m = int(rng.integers(0, 4))
    u = rng.choice([-ROBOT.rear_offset - 0.005, ROBOT.front_offset + 0.005], m)
    v = rng.uniform(-ROBOT.width / 2, ROBOT.width / 2, m)
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    margin = np.c_[pose.x + u * c - v * s, pose.y + u * s + v * c]
    pts = np.vstack([np.round(np.vstack([pts, wall]), 2), margin])
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= 1.05]
    obs = perceive(pts, body=(ROBOT.rear_offset, ROBOT.front_offset, ROBOT.width / 2))
    return Scene(obs, ROBOT), pose


@pytest.mark.parametrize("seed", range(40))
def test_a_gap_remembered_from_a_choice_of_angle_is_the_gap_of_all_points(seed: int) -> None:
    rng = np.random.default_rng(seed)
    scene, pose = _scene(rng)
    heads = [float(h) for h in rng.uniform(-math.pi, math.pi, 6)]
    lengths = [float(v) for v in rng.uniform(0.05, 0.27, 6)]
    fallback = int(rng.integers(0, 6))
    i = scene.first_clear_each(pose, [(heads[:3], lengths[:3], fallback % 3), (heads[3:], lengths[3:], -1)], 0.27)[0]
    fresh = Scene(scene.obstacles, ROBOT)
    for h in heads + [pose.theta]:
        at = Pose(pose.x, pose.y, h)
        exact = fresh._straight_gap(at)
        key = (round(at.x * 1e9), round(at.y * 1e9), round(h * 1e9))
        if key in scene.gaps:
            assert scene.gaps[key] == exact
        if key in scene.clear:
            assert exact[0] > scene.clear[key]  # the way is clear at least that far
        # asked with what it needs to know, the scene answers as all the points do
        for need in (0.1, 0.3, 0.45, math.inf):
            d, k = scene.straight_gap(at, need)
            if k >= 0 or exact[0] < need:
                assert (d, k) == exact
    # the answer itself: the first heading clear for its length, over all points
    clear = [fresh._straight_gap(Pose(pose.x, pose.y, h))[0] >= n - 1e-9 for h, n in zip(heads[:3], lengths[:3])]
    assert i == (clear.index(True) if True in clear else -1)


@pytest.mark.parametrize("seed", range(40))
def test_two_turns_answered_together_are_each_answered_alone(seed: int) -> None:
    rng = np.random.default_rng(100 + seed)
    scene, pose = _scene(rng)
    left = Task.turn(ROBOT, TaskKind.LEFT, pose, None, float(rng.uniform(0.05, math.pi)))
    right = Task.turn(ROBOT, TaskKind.RIGHT, pose, None, float(rng.uniform(0.05, math.pi)))
    together = scene.turn_each([left, right])
    assert scene.turn(right) == together[1]  # remembered, and then forgotten
    assert not scene.turned
    alone = [Scene(scene.obstacles, ROBOT).turn_each([t])[0] for t in (left, right)]
    assert together == alone
