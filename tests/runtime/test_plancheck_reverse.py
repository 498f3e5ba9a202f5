"""REVERSE in the once-a-revolution plan check (issue #42): a REVERSE task is checked against
the points of the scan *behind* the body (the A1 sees all round), by the planner's rule for a
straight driven rear first; :func:`resimulate_plan` (the planner's REVERSE rollout) agrees."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.planner.robot_model import RobotModel
from clomp.runtime.supervision.checkgeometry import _legs
from clomp.runtime.supervision.plancheck import check_plan, perceive_scan, resimulate_plan

ORIGIN = Pose(0.0, 0.0, 0.0)
GOAL = Disturbance.goal(1.0, 0.0)
M = RobotModel()
TOL = (0.08, 0.3)


def _reverse(distance: float = 0.15) -> list[State]:
    return [State(1, TaskKind.REVERSE, GOAL, None, ORIGIN, Pose(-distance, 0.0, 0.0), distance=distance)]


def _wall(x: float, y: float, th: float, half: float = 0.12, n: int = 25) -> np.ndarray:
    t = np.linspace(-half, half, n)
    return np.c_[x - t * math.sin(th), y + t * math.cos(th)]


def _sweeps(pts: np.ndarray, legs, m: RobotModel, tol: float) -> bool:
    """Brute force: does the real body, backed off in 2 mm steps up to ``tol`` before each
    REVERSE leg's end, cover a point not already under it at the leg's start?"""
    for g in legs:
        if g.kind is not TaskKind.REVERSE or g.amount <= 1e-3:
            continue
        x0, y0, th = g.start
        c, s = math.cos(th), math.sin(th)

        def under(x: float, y: float, c: float = c, s: float = s) -> np.ndarray:
            dx, dy = pts[:, 0] - x, pts[:, 1] - y
            u, v = dx * c + dy * s, -dx * s + dy * c
            return (u > -m.rear_offset) & (u < m.front_offset) & (np.abs(v) < m.width / 2)

        start = under(x0, y0)
        for d in np.linspace(0.0, max(g.amount - tol, 0.0), max(2, int((g.amount - tol) / 0.002) + 1)):
            if (under(x0 - c * d, y0 - s * d) & ~start).any():
                return True
    return False


def test_a_wall_behind_fails_a_reverse_a_wall_ahead_does_not():
    behind = _wall(-0.25, 0.0, 0.0)  # 7 cm behind the rear
    v = check_plan(_reverse(), ORIGIN, ORIGIN, Pose(1.0, 0.0), behind, M)
    assert not v.ok and v.reason == "task 1 (REVERSE) now meets an obstacle behind after 0.05 of 0.15 m", v.reason
    ahead = _wall(0.12, 0.0, 0.0)  # 3 cm ahead of the front: what a REVERSE backs off from
    assert check_plan(_reverse(), ORIGIN, ORIGIN, Pose(1.0, 0.0), ahead, M).ok
    far = _wall(-0.45, 0.0, 0.0)  # beyond the 0.15 m it backs off
    assert check_plan(_reverse(), ORIGIN, ORIGIN, Pose(1.0, 0.0), far, M).ok


def test_the_check_and_the_planners_reverse_rollout_agree_behind():
    for x, ok in ((-0.25, False), (-0.45, True), (-0.3, True)):  # -0.3: 0.11 m of room, within the tolerance
        wall = _wall(x, 0.0, 0.0)
        fast = check_plan(_reverse(), ORIGIN, ORIGIN, Pose(1.0, 0.0), wall, M)
        slow = resimulate_plan(_reverse(), ORIGIN, ORIGIN, Pose(1.0, 0.0), perceive_scan(wall, M), M)
        assert fast.ok is slow.ok is ok, (x, fast.reason, slow.reason)
        assert fast.tasks == slow.tasks


@given(distance=st.floats(0.03, 0.15), wx=st.floats(-0.6, 0.2), wy=st.floats(-0.25, 0.25), wth=st.floats(0.0, math.pi),
       dx=st.floats(-0.03, 0.03), dy=st.floats(-0.03, 0.03), dth=st.floats(-0.1, 0.1),
       following=st.booleans())
@settings(max_examples=150, deadline=None)
def test_a_check_that_passes_a_reverse_leaves_no_point_behind_in_its_way(distance, wx, wy, wth, dx, dy, dth, following):
    """Whatever the wall (anywhere round the body, at any angle) and the pose error: when the
    check passes a REVERSE (alone, or followed by a STRAIGHT), the real body backed off along
    it from the estimated pose covers no point (up to the tolerance before its end)."""
    steps = _reverse(distance)
    if following:
        steps.append(State(2, TaskKind.STRAIGHT, GOAL, None, Pose(-distance, 0.0, 0.0), Pose(0.2, 0.0, 0.0), distance=0.2 + distance))
    pose = Pose(dx, dy, dth)
    pts = _wall(wx, wy, wth)
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) > 0.01]
    from clomp.formal.geometry import relative

    rel = relative(pose, ORIGIN)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    seen = np.c_[rel.x + c * pts[:, 0] - s * pts[:, 1], rel.y + s * pts[:, 0] + c * pts[:, 1]]  # robot frame at pose
    v = check_plan(steps, ORIGIN, pose, Pose(1.0, 0.0), seen, M, tolerance=TOL)
    if v.ok:
        assert not _sweeps(seen, _legs(steps, rel, False), M, TOL[0]), v.reason
