"""The face compass: faces found in noisy points, the heading measured against them."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from formal.model import Pose
from runtime.estimation.ekf import OdometryFilter
from runtime.estimation.faces import FaceCompass, find_faces


def _rotate(points: np.ndarray, angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return points @ np.array([[c, s], [-s, c]])


def _corner(rng: np.random.Generator, sd: float) -> np.ndarray:
    """Two faces of a box (0.3 m and 0.25 m) meeting at a corner, with noise."""
    a = np.c_[np.full(40, 0.5), np.linspace(-0.1, 0.2, 40)]
    b = np.c_[np.linspace(0.52, 0.75, 30), np.full(30, -0.1)]
    return np.r_[a, b] + rng.normal(0.0, sd, (70, 2))


@settings(max_examples=30, deadline=None)
@given(st.floats(-math.pi, math.pi), st.integers(0, 1000))
def test_faces_are_found_at_their_true_directions_whatever_the_rotation(angle: float, seed: int) -> None:
    faces = find_faces(_rotate(_corner(np.random.default_rng(seed), 0.005), angle), 0.015)
    assert len(faces) == 2
    for f in faces:
        off = (f.angle - angle) % (math.pi / 2)
        assert min(off, math.pi / 2 - off) < math.radians(3), math.degrees(off)


@settings(max_examples=30, deadline=None)
@given(st.floats(-0.05, 0.05), st.floats(-0.3, 0.3), st.integers(0, 1000))
def test_the_compass_measures_the_heading_error_not_the_position(error: float, turned: float, seed: int) -> None:
    """Seen from a pose turned by ``turned`` whose estimate is off by ``error`` rad in heading
    and 3 cm sideways, the compass reads the heading error, within 2°."""
    rng = np.random.default_rng(seed)
    compass = FaceCompass()
    assert compass.seed([_corner(rng, 0.005) for _ in range(3)], Pose(0.0, 0.0, 0.0), 0.005) == 2
    seen = _rotate(_corner(rng, 0.005), turned)  # the scene in the robot's frame, robot turned by -turned
    estimate = Pose(0.0, 0.02, -turned - error)
    got = compass.measure(seen, estimate, 0.005)
    assert got is not None
    assert abs(got[0] - error) < math.radians(2), (math.degrees(got[0]), math.degrees(error))


def test_a_face_off_the_prior_beyond_three_sigma_is_left_out() -> None:
    rng = np.random.default_rng(3)
    compass = FaceCompass()
    compass.seed([_corner(rng, 0.005)], Pose(0.0, 0.0, 0.0), 0.005)
    seen = _corner(rng, 0.005)
    assert compass.measure(seen, Pose(0.0, 0.0, 0.3), 0.005) is not None        # no prior: read
    assert compass.measure(seen, Pose(0.0, 0.0, 0.3), 0.005, prior_sd=0.01) is None  # 17° off a 0.6° prior


def test_faces_join_only_while_the_heading_is_known() -> None:
    rng = np.random.default_rng(4)
    compass = FaceCompass(grow_revolutions=3)
    compass.seed([np.c_[np.full(40, 0.5), np.linspace(-0.2, 0.2, 40)]], Pose(0.0, 0.0, 0.0), 0.005)
    new = np.c_[np.linspace(-0.3, 0.3, 40), np.full(40, 0.6)]
    for _ in range(3):
        assert compass.grow(new + rng.normal(0, 0.005, new.shape), Pose(0, 0, 0), math.radians(10), 0.005) == 0
    added = [compass.grow(new + rng.normal(0, 0.005, new.shape), Pose(0, 0, 0), math.radians(1), 0.005) for _ in range(3)]
    assert sum(added) == 1 and len(compass.faces) == 2


def test_a_heading_measurement_teaches_the_curvature_and_refuses_nan() -> None:
    f = OdometryFilter(0.15)
    for _ in range(20):
        f.predict(0.1, 0.0, 0.1)
    assert f.correct_heading(math.nan, 0.01) == (False, 0.0)
    ok, _ = f.correct_heading(-0.03, 0.01)
    assert ok and f.calibration[2] < 0 and f.pose.theta < 0
    assert not f.correct_heading(1.0, 0.001)[0]  # far beyond the gate
