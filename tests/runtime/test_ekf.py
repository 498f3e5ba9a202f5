"""The odometry filter: fusion weighted by what a match observes, calibration, gating."""

from __future__ import annotations

import math

import numpy as np

import pytest

from formal.geometry import drive, wrap_angle
from formal.model import Pose
from planner.scenarios import parse_scenario
from runtime.estimation import match_scans
from runtime.estimation.ekf import OdometryFilter
from runtime.robots import make_world_robot


def _drive_truth(pose: Pose, v: float, w: float, dt: float, curve: float) -> Pose:
    return drive(pose, v, w + curve * v, dt)


def test_calibration_learns_a_curving_drive_and_predicts_it_afterwards() -> None:
    """Wheels that curve a straight command (0.3 rad/m): position fixes while driving teach
    the filter the curvature, so dead reckoning after the fixes stop drifts far less than
    an uncalibrated filter's."""
    curve = 0.3
    learnt, naive = OdometryFilter(0.15), OdometryFilter(0.15)
    truth = Pose(0.0, 0.0, 0.0)
    fix = np.diag([1 / 0.005**2, 1 / 0.005**2, 0.0])  # position only: the heading is never measured
    for k in range(100):  # 10 s at 0.1 m/s, a position fix every 0.2 s
        truth = _drive_truth(truth, 0.1, 0.0, 0.1, curve)
        for f in (learnt, naive):
            f.predict(0.1, 0.0, 0.1)
        if k % 2 == 1:
            p = learnt.pose
            learnt.correct((truth.x - p.x, truth.y - p.y, 0.0), fix)
    assert abs(learnt.calibration[2] + learnt.calibration[3] / 0.1 - curve) < 0.1
    # from the same true pose, 1 m more without any fix
    for f in (learnt, naive):
        f.shift(Pose(truth.x, truth.y, truth.theta))
    for _ in range(100):
        truth = _drive_truth(truth, 0.1, 0.0, 0.1, curve)
        for f in (learnt, naive):
            f.predict(0.1, 0.0, 0.1)
    err = {n: math.hypot(f.pose.x - truth.x, f.pose.y - truth.y) for n, f in (("learnt", learnt), ("naive", naive))}
    assert err["learnt"] < 0.3 * err["naive"], err


def test_a_direction_the_match_does_not_observe_keeps_the_prediction() -> None:
    """A match that only pins y (a wall ahead of nothing) moves y, never x."""
    f = OdometryFilter(0.15)
    for _ in range(10):
        f.predict(0.1, 0.0, 0.1)
    before = f.pose
    ok, _ = f.correct((0.05, 0.01, 0.0), np.diag([0.0, 1e6, 0.0]))
    assert ok
    assert f.pose.x == before.x and f.pose.y != before.y


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
    """The information matrix a match hands the filter has nothing along a corridor's axis."""
    doc = {"goal": [1.0, 0.0], "obstacles": [{"type": "wall", "from": [-3.0, 0.35], "to": [3.0, 0.35]},
                                             {"type": "wall", "from": [-3.0, -0.35], "to": [3.0, -0.35]}]}
    scene = parse_scenario(doc, "corridor")
    a = make_world_robot(scene, "paper", seed=0).read_scan()
    b = make_world_robot(scene, "paper", seed=1, start=Pose(0.03, 0.0, 0.0)).read_scan()
    assert a is not None and b is not None
    m = match_scans(a.points, b.points, Pose(0.05, 0.0, 0.0))
    info = np.asarray(m.information_matrix)
    assert m.unobservable == ("x",)
    assert info[0, 0] < 1e-6 * info[1, 1] and info[1, 1] > 0


def test_a_match_seen_again_while_standing_corrects_the_pose_but_teaches_nothing() -> None:
    """Revolutions taken from where the last one was matched repeat the map's errors:
    with ``learn=False`` the pose moves and the calibration stays as it was."""
    f, g = OdometryFilter(0.15, match_floor=(0.0, 0.0, 0.0)), OdometryFilter(0.15, match_floor=(0.0, 0.0, 0.0))
    for _ in range(10):
        for h in (f, g):
            h.predict(0.1, 0.0, 0.1)
    before, cal = f.pose, f.calibration
    assert f.correct((0.01, 0.0, 0.0), np.diag([1e6, 1e6, 0.0]), learn=False)[0]
    assert g.correct((0.01, 0.0, 0.0), np.diag([1e6, 1e6, 0.0]))[0]
    assert f.pose.x > before.x + 0.003 and f.pose == g.pose  # the pose is corrected alike
    assert f.calibration == cal and g.calibration != cal    # only g learnt from it


def test_learnt_terms_stay_within_three_prior_deviations() -> None:
    """Wheels that curve ten times more than the prior allows teach the filter a
    curvature at its bound (3 prior sd), never beyond."""
    f = OdometryFilter(0.15)
    truth = Pose(0.0, 0.0, 0.0)
    fix = np.diag([1 / 0.005**2, 1 / 0.005**2, 0.0])
    for k in range(100):
        truth = _drive_truth(truth, 0.1, 0.0, 0.1, 3.0)
        f.predict(0.1, 0.0, 0.1)
        if k % 2 == 1:
            p = f.pose
            f.correct((truth.x - p.x, truth.y - p.y, wrap_angle(truth.theta - p.theta)), fix)
    bound = 3 * np.asarray(f.calibration_sd)
    cal = np.asarray(f.calibration)
    assert np.all(np.abs(cal) <= bound + 1e-12), cal
    assert cal[2] == pytest.approx(bound[2]), cal  # the curvature learnt as far as it may go
