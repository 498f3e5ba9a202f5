"""The odometry filter: fusion weighted by what a match observes, calibration, gating."""

from __future__ import annotations

import math

import numpy as np

import pytest

from clomp.formal.geometry import drive, wrap_angle
from clomp.formal.model import Pose
from clomp.planner.scenarios import parse_scenario
from clomp.runtime.estimation import match_scans
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.backends import make_world_robot


def _drive_truth(pose: Pose, v: float, w: float, dt: float, curve: float) -> Pose:
    return drive(pose, v, w + curve * v, dt)


# a fix along a wall: the position to 5 mm, the heading to 0.1 degrees
WALL_FIX = np.diag([1 / 0.005**2, 1 / 0.005**2, 1 / math.radians(0.1) ** 2])
# a fix on one small box: the position only, rotation about the box left to it
BOX_FIX = np.diag([1 / 0.005**2, 1 / 0.005**2, 0.0])


def _fixed_drive(f: OdometryFilter, fix: np.ndarray, curve: float) -> Pose:
    """10 s straight at 0.1 m/s on wheels that curve ``curve`` rad/m, a fix every 0.2 s."""
    truth = Pose(0.0, 0.0, 0.0)
    for k in range(100):
        truth = _drive_truth(truth, 0.1, 0.0, 0.1, curve)
        f.predict(0.1, 0.0, 0.1)
        if k % 2 == 1:
            p = f.pose
            f.correct((truth.x - p.x, truth.y - p.y, wrap_angle(truth.theta - p.theta)), fix)
    return truth


def test_calibration_learns_a_curving_drive_and_predicts_it_afterwards() -> None:
    """Wheels that curve a straight command (0.3 rad/m): fixes that pin the heading while
    driving (a wall) teach the filter the curvature, so dead reckoning after the fixes stop
    drifts far less than an uncalibrated filter's."""
    curve = 0.3
    learnt, naive = OdometryFilter(0.15), OdometryFilter(0.15)
    truth = _fixed_drive(learnt, WALL_FIX, curve)
    assert abs(learnt.calibration[2] + learnt.calibration[3] / 0.1 - curve) < 0.1
    # from the same true pose, 1 m more without any fix
    naive.P[:3, :3] = learnt.P[:3, :3]
    for f in (learnt, naive):
        f.shift(Pose(truth.x, truth.y, truth.theta))
    for _ in range(100):
        truth = _drive_truth(truth, 0.1, 0.0, 0.1, curve)
        for f in (learnt, naive):
            f.predict(0.1, 0.0, 0.1)
    err = {n: math.hypot(f.pose.x - truth.x, f.pose.y - truth.y) for n, f in (("learnt", learnt), ("naive", naive))}
    assert err["learnt"] < 0.3 * err["naive"], err


def test_fixes_that_leave_the_heading_to_the_position_teach_no_calibration() -> None:
    """The paper-noise regression: fixes on one small box (position only) corrected the pose
    and taught the wheels a curvature they do not have (the map's own errors, learnt back).
    Now they correct the pose and teach nothing; the same drive with the heading pinned
    learns. The heading's information decides (``heading_sd``), not the fix's position."""
    box, wall = OdometryFilter(0.15), OdometryFilter(0.15)
    truth = _fixed_drive(box, BOX_FIX, 0.3)
    assert box.calibration == (0.0, 0.0, 0.0, 0.0)
    assert math.hypot(box.pose.x - truth.x, box.pose.y - truth.y) < 0.02  # the pose is still corrected
    _fixed_drive(wall, WALL_FIX, 0.3)
    assert wall.calibration[2] > 0.15
    assert box.heading_sd(BOX_FIX) == math.inf and wall.heading_sd(WALL_FIX) < math.radians(0.2)
    # the gate off (None): the position alone teaches again, as before
    old = OdometryFilter(0.15, learn_heading_sd=None)
    _fixed_drive(old, BOX_FIX, 0.3)
    assert old.calibration[2] > 0.1


def test_a_direction_the_match_does_not_observe_keeps_the_prediction() -> None:
    """A match that only pins y (a wall ahead of nothing) moves y, never x."""
    f = OdometryFilter(0.15)
    for _ in range(10):
        f.predict(0.1, 0.0, 0.1)
    before = f.pose
    ok, _ = f.correct((0.05, 0.01, 0.0), np.diag([0.0, 1e6, 0.0]))
    assert ok
    assert f.pose.x == before.x and f.pose.y != before.y


def test_a_match_turns_no_direction_it_leaves_unobserved() -> None:
    """After a turn the heading and the position are correlated: a match that observes only
    the distance ahead (one small face) moves x and leaves y and the heading to dead
    reckoning. With the full gain (``hold_unobserved=False``) the same match turned the
    heading by 1.2 degrees it never saw: the paper-noise regression's other half."""
    moved = {}
    for hold in (True, False):
        f = OdometryFilter(0.15) if hold else OdometryFilter(0.15, hold_unobserved=False)  # the default holds
        for v, w in [(0.1, 0.0)] * 10 + [(0.0, 0.8)] * 10 + [(0.1, 0.0)] * 10:
            f.predict(v, w, 0.1)
        before = f.pose
        assert f.correct((0.01, 0.0, 0.0), np.diag([1e6, 0.0, 0.0]))[0]
        moved[hold] = (f.pose.x - before.x, f.pose.y - before.y, f.pose.theta - before.theta)
    assert moved[True][0] > 0.003 and moved[True][1:] == (0.0, 0.0)
    assert abs(moved[False][2]) > math.radians(1.0)
    # a corridor's axis left unobserved (a translation, no heading in it) keeps the full gain
    f, g = OdometryFilter(0.15), OdometryFilter(0.15, hold_unobserved=False)
    for h in (f, g):
        for v, w in [(0.1, 0.0)] * 10 + [(0.0, 0.8)] * 10 + [(0.1, 0.0)] * 10:
            h.predict(v, w, 0.1)
        h.correct((0.0, 0.01, 0.0), np.diag([0.0, 1e6, 1e6]))
    assert f.pose == g.pose


def test_a_match_far_outside_the_covariance_is_rejected() -> None:
    f = OdometryFilter(0.15)
    f.predict(0.1, 0.0, 0.1)
    before = f.pose
    ok, d2 = f.correct((0.5, 0.0, 0.0), np.diag([1e6, 1e6, 1e6]))
    assert not ok and d2 > f.gate and f.pose == before


def test_standing_still_leaves_the_covariance_alone() -> None:
    f = OdometryFilter(0.15)
    p0 = f.P.copy()
    f.predict(0.0, 0.0, 5.0)
    assert np.array_equal(f.P, p0) and f.pose == Pose(0.0, 0.0, 0.0)


def test_icp_information_is_empty_along_a_corridor() -> None:
    """The information matrix a match hands the filter has next to nothing along a corridor's
    axis (the walls' normals, fitted to ranges rounded to 1 cm, tilt by about a milliradian,
    which leaves it near 1e-6 of the information across)."""
    doc = {"goal": [1.0, 0.0], "obstacles": [{"type": "wall", "from": [-3.0, 0.35], "to": [3.0, 0.35]},
                                             {"type": "wall", "from": [-3.0, -0.35], "to": [3.0, -0.35]}]}
    scene = parse_scenario(doc, "corridor")
    a = make_world_robot(scene, "paper", seed=0).read_scan()
    b = make_world_robot(scene, "paper", seed=1, start=Pose(0.03, 0.0, 0.0)).read_scan()
    assert a is not None and b is not None
    m = match_scans(a.points, b.points, Pose(0.05, 0.0, 0.0))
    info = np.asarray(m.information_matrix)
    assert m.unobservable == ("x",)
    assert info[0, 0] < 1e-5 * info[1, 1] and info[1, 1] > 0


def test_a_match_seen_again_while_standing_corrects_the_pose_but_teaches_nothing() -> None:
    """Revolutions taken from where the last one was matched repeat the map's errors:
    with ``learn=False`` the pose moves and the calibration stays as it was."""
    f, g = OdometryFilter(0.15, match_floor=(0.0, 0.0, 0.0)), OdometryFilter(0.15, match_floor=(0.0, 0.0, 0.0))
    for _ in range(10):
        for h in (f, g):
            h.predict(0.1, 0.0, 0.1)
    before, cal = f.pose, f.calibration
    assert f.correct((0.01, 0.0, 0.0), np.diag([1e6, 1e6, 1e6]), learn=False)[0]
    assert g.correct((0.01, 0.0, 0.0), np.diag([1e6, 1e6, 1e6]))[0]
    assert f.pose.x > before.x + 0.003 and f.pose == g.pose  # the pose is corrected alike
    assert f.calibration == cal and g.calibration != cal    # only g learnt from it


def test_learnt_terms_stay_within_three_prior_deviations() -> None:
    """Wheels that curve ten times more than the prior allows teach the filter a
    curvature at its bound (3 prior sd), never beyond."""
    f = OdometryFilter(0.15)
    _fixed_drive(f, WALL_FIX, 3.0)
    bound = 3 * np.asarray(f.calibration_sd)
    cal = np.asarray(f.calibration)
    assert np.all(np.abs(cal) <= bound + 1e-12), cal
    assert cal[2] == pytest.approx(bound[2]), cal  # the curvature learnt as far as it may go


def test_what_the_model_does_not_hold_grows_the_uncertainty_by_distance_and_turn():
    """slip_noise (m/√m) on the position per metre driven, turn_noise (rad/√rad) on the heading
    per radian turned (issue #36's knobs; 0 by default: the filter as before)."""
    from clomp.runtime.estimation.ekf import OdometryFilter

    def driven(**kw):
        f = OdometryFilter(0.15, **kw)
        for _ in range(10):
            f.predict(0.1, 0.0, 0.1)  # 0.1 m straight
        for _ in range(10):
            f.predict(0.0, 1.0, 0.1, turned=0.1)  # 1 rad turned, the gyro's
        return f

    base, slip, turn = driven(), driven(slip_noise=0.1), driven(turn_noise=0.1)
    assert slip.P[1, 1] - base.P[1, 1] > 0.9 * 0.1**2 * 0.1  # 0.1 m at (0.1 m/√m)² across the path
    assert turn.P[2, 2] - base.P[2, 2] > 0.9 * 0.1**2 * 1.0  # 1 rad at (0.1 rad/√rad)²
    assert slip.honest[1, 1] == slip.P[1, 1] and OdometryFilter(0.15).slip_noise == 0.0


def test_the_honest_walk_is_admitted_never_believed() -> None:
    """``honest_walk`` grows :attr:`honest` by its terms per metre driven and radian turned,
    and leaves the estimate and its gain (``P``) bit for bit as without it (issue #36: at
    ``harsh`` without the gyro the position crept 0.02 → 0.09 m along a doorless room while
    the admitted uncertainty grew only to 0.017 m)."""
    plain, walked = OdometryFilter(0.15), OdometryFilter(0.15, honest_walk=(0.03, 0.02, 0.01))
    for f in (plain, walked):
        for _ in range(50):
            f.predict(0.1, 0.2, 0.2)  # 1 m driven, 2 rad turned
        f.correct((0.001, -0.002, 0.001), WALL_FIX)
    assert np.array_equal(plain.x, walked.x) and np.array_equal(plain.P, walked.P)
    before = OdometryFilter(0.15, honest_walk=(0.03, 0.02, 0.01))
    for _ in range(50):
        before.predict(0.1, 0.2, 0.2)
    unwalked = OdometryFilter(0.15)
    for _ in range(50):
        unwalked.predict(0.1, 0.2, 0.2)
    grown = np.diag(before.honest[:3, :3] - unwalked.honest[:3, :3])
    # the position's share is at least its walk over the metre (the heading's spreads it further)
    assert grown[0] + grown[1] >= 2 * 0.03**2 * 0.999
    assert math.isclose(grown[2], 0.02**2 * 1.0 + 0.01**2 * 2.0, rel_tol=1e-6)
    assert walked.honest_sigma_xy > plain.honest_sigma_xy
