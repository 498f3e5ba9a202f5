"""A base's reported odometry covariance (a ROS ``/odom``'s pose and twist covariance) as the
least prediction noise of the estimator: the conversion from the message, the step's floor,
and the filter never taking less noise than the base reports (runtime/estimation/reported.py,
runtime/ros/convert.py). Without rclpy: messages are stand-ins with the same fields. The
in-process test through RosRobot and the supervisor's Sensing is in test_ros_node.py."""

from __future__ import annotations

import math
from types import SimpleNamespace as M
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.estimation.reported import psd_max, step_noise_floor
from clomp.runtime.ros.convert import odometry_covariance, planar_covariance


def ros_cov(xx: float = 0.0, yy: float = 0.0, yawyaw: float = 0.0, xyaw: float = 0.0, zz: float = 0.0) -> list[float]:
    c = [0.0] * 36
    c[0], c[7], c[35], c[14] = xx, yy, yawyaw, zz
    c[5] = c[30] = xyaw
    return c


def msg(pose_cov: list[float], twist_cov: list[float]) -> Any:
    return M(pose=M(covariance=pose_cov), twist=M(covariance=twist_cov))


def is_psd(m: np.ndarray, tol: float = 1e-12) -> bool:
    return bool(np.linalg.eigvalsh((m + m.T) / 2)[0] >= -tol)


# -- the conversion ---------------------------------------------------------------------------
def test_the_planar_block_is_x_y_and_yaw_of_the_six_by_six() -> None:
    pose, twist = odometry_covariance(msg(ros_cov(0.04, 0.09, 0.01, xyaw=0.002, zz=99.0), ros_cov(0.0, 0.0, 0.25)))
    assert pose is not None and twist is not None
    assert pose.tolist() == [[0.04, 0.0, 0.002], [0.0, 0.09, 0.0], [0.002, 0.0, 0.01]]  # z's 99 is not planar
    assert np.diag(twist).tolist() == [0.0, 0.0, 0.25]


def test_unknown_covariances_leave_the_model_its_own_noise() -> None:
    unknown = [[0.0] * 36, [-1.0] + [0.0] * 35, ros_cov(math.nan, 0.01, 0.01), ros_cov(-0.01, 0.01, 0.01),
               ros_cov(zz=5.0)]  # zeros; REP 145's -1; not finite; a negative variance; nothing planar
    for c in unknown:
        assert planar_covariance(c) is None, c
    assert planar_covariance([0.1] * 35) is None  # not 6×6
    assert odometry_covariance(msg([0.0] * 36, [0.0] * 36)) == (None, None)


# -- the step's floor --------------------------------------------------------------------------
covs = st.lists(st.floats(-1.0, 1.0), min_size=9, max_size=9).map(lambda v: np.asarray(v).reshape(3, 3)).map(
    lambda a: a @ a.T)


@settings(max_examples=60, deadline=None)
@given(covs, covs)
def test_psd_max_is_no_smaller_than_either(a: np.ndarray, b: np.ndarray) -> None:
    m = psd_max(a, b)
    assert is_psd(m - a, 1e-9) and is_psd(m - b, 1e-9)


@settings(max_examples=60, deadline=None)
@given(covs, covs, covs, st.floats(-math.pi, math.pi), st.floats(0.01, 1.0))
def test_the_floor_covers_the_twist_and_the_growth_of_the_pose_covariance(
        before: np.ndarray, grown: np.ndarray, twist: np.ndarray, heading: float, dt: float) -> None:
    floor = step_noise_floor(before, before + grown, twist, heading, dt)
    assert floor is not None and is_psd(floor, 1e-9)
    assert is_psd(floor - twist * dt * dt, 1e-9)
    c, s = math.cos(heading), math.sin(heading)
    j = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])  # odometry frame -> robot frame
    assert is_psd(floor - j @ grown @ j.T, 1e-9)


def test_a_pose_covariance_that_does_not_grow_adds_nothing() -> None:
    fixed = np.diag([0.01, 0.01, 0.01])
    assert np.allclose(step_noise_floor(fixed, fixed, None, 0.3, 0.1), 0.0)
    assert np.allclose(step_noise_floor(fixed, fixed * 0.5, None, 0.3, 0.1), 0.0)  # shrank: nothing either
    assert step_noise_floor(None, fixed, None, 0.0, 0.1) is None  # no earlier one: no growth known


# -- the filter takes at least that noise ------------------------------------------------------
@settings(max_examples=40, deadline=None)
@given(covs, st.floats(-0.2, 0.2), st.floats(-1.0, 1.0), st.floats(-math.pi, math.pi))
def test_a_prediction_step_is_never_less_noisy_than_the_floor(floor: np.ndarray, v: float, w: float,
                                                            heading: float) -> None:
    f = OdometryFilter(0.15)
    f.reset(Pose(0.0, 0.0, heading))
    before = f.P[:3, :3].copy()
    f.predict(v, w, 0.1, None, floor * 1e-4)
    c, s = math.cos(heading), math.sin(heading)
    j = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])  # robot frame -> the estimate's
    assert is_psd(f.P[:3, :3] - before - j @ (floor * 1e-4) @ j.T, 1e-12)
    assert is_psd(f.honest[:3, :3] - j @ (floor * 1e-4) @ j.T, 1e-12)


def drive(covariance: tuple[np.ndarray | None, np.ndarray | None] | None, steps: int = 30) -> ScanOdometry:
    """1 cm forward per 0.1 s step by the base's odometry (no scans), reporting ``covariance``."""
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    for i in range(steps + 1):
        odo.advance(0.1 * i, (0.1, 0.1), Pose(0.01 * i, 0.0, 0.0), None, covariance)
    return odo


def test_the_estimator_widens_by_a_reported_twist_covariance_and_not_by_an_unknown_one() -> None:
    own = drive(None).position_sd()
    assert drive((None, None)).position_sd() == own  # unknown: the model's own noise, bit for bit
    twist = np.diag([0.2**2, 0.2**2, 0.3**2])  # a base that knows its speed to 0.2 m/s only
    wide = drive((None, twist)).position_sd()
    assert wide >= math.sqrt(30 * (0.2 * 0.1) ** 2) * 0.999 > own * 3
    tiny = drive((None, twist * 1e-8)).position_sd()  # a base surer than the model: the model's noise stays
    assert tiny >= own * 0.999


def test_the_estimator_widens_by_a_growing_pose_covariance() -> None:
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    for i in range(31):  # the base's own pose covariance grows by (1 cm)² in y each step
        cov = np.diag([0.0, 1e-4 * i, 0.0])
        odo.advance(0.1 * i, (0.1, 0.1), Pose(0.01 * i, 0.0, 0.0), None, (cov, None))
    assert odo.position_sd() >= math.sqrt(30 * 1e-4) * 0.999
