"""The known-free space's compiled loops (:mod:`clomp.planner._free_kernels`) against
:class:`clomp.planner.visibility.KnownFree`'s numpy and Python statements: the same table,
bit for bit, and the same answer to every straight and turn asked; and perception's compiled pass
(:func:`clomp.planner._kernels.kept_points`) against its numpy statements."""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.planner import _kernels, footprint, load_scan, perception, visibility
from clomp.planner.robot_model import RobotModel
from clomp.planner.visibility import KnownFree

SCANS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans"
ROBOT = RobotModel()
BODY = footprint.body_box(ROBOT)
SLOTS = [s for s in KnownFree.__slots__ if s != "_table"]
OBSTACLE_FIELDS = ("points", "starts", "boxes", "centres", "radii", "exempt")
same_rounding = pytest.mark.skipif(not _kernels.ROUNDS_AS_NUMPY, reason="numpy rounds otherwise on this host")


def _numpy_table(points: np.ndarray, monkeypatch: pytest.MonkeyPatch) -> KnownFree:
    with monkeypatch.context() as m:
        m.setattr(visibility, "_free", lambda: None)
        free = KnownFree.from_points(points, ROBOT.sensor_range, robot=ROBOT)
    assert free._table is None
    return free


def _assert_same_table(points: np.ndarray, monkeypatch: pytest.MonkeyPatch) -> KnownFree:
    got, ref = KnownFree.from_points(points, ROBOT.sensor_range, robot=ROBOT), _numpy_table(points, monkeypatch)
    assert got._table is not None
    for name in SLOTS:
        a, b = getattr(got, name), getattr(ref, name)
        if isinstance(b, np.ndarray):
            assert a.dtype == b.dtype and a.shape == b.shape and a.tobytes() == b.tobytes(), name
        else:
            assert a == b, name
    return got


def _assert_same_straights(free: KnownFree, poses: list[tuple[float, float, float, float, bool]]) -> None:
    for x, y, theta, distance, start_known in poses:
        start = Pose(x, y, theta)
        got = free.straight_clear(start, distance, ROBOT, start_known)
        rear = -ROBOT.front_offset if start_known else ROBOT.rear_offset
        ref = (start_known and distance <= 0.0) or free._straight_clear(start, rear, ROBOT.front_offset + max(distance, 0.0), ROBOT.width / 2)
        assert got == ref, (x, y, theta, distance, start_known)


def _assert_same_points(free: KnownFree, points: np.ndarray) -> None:
    for x, y in points.tolist():
        assert free.contains(x, y) == free._contains(x, y), (x, y)


def _assert_same_turns(free: KnownFree, turns: list[tuple[float, float, float, float]]) -> None:
    for x, y, theta, angle in turns:
        start = Pose(x, y, theta)
        got, ref = free.turn_clear(start, angle, ROBOT), free._turn_clear(start, angle, ROBOT, math.hypot(x, y))
        assert got == ref, (x, y, theta, angle)


# scenes: posts and wall pieces at random, rounded to the centimetre as recorded scans are
_piece = st.tuples(st.floats(-3.2, 3.2), st.floats(0.0, 1.5), st.floats(0.05, 1.3), st.integers(1, 60), st.booleans())
_pose = st.tuples(st.floats(-0.9, 0.9), st.floats(-0.9, 0.9), st.floats(-3.2, 3.2), st.sampled_from([0.0, 0.05, 0.27, 0.8]), st.booleans())


def _scene(pieces: list[tuple[float, float, float, int, bool]]) -> np.ndarray:
    parts = []
    for start, span, radius, n, rounded in pieces:
        a = start + np.linspace(0.0, span, n)
        p = np.c_[radius * np.cos(a), radius * np.sin(a)]
        parts.append(np.round(p, 2) if rounded else p)
    return np.concatenate(parts)


_turn = st.tuples(
    st.floats(-0.9, 0.9), st.floats(-0.9, 0.9), st.floats(-3.2, 3.2),
    st.sampled_from([1.0, -1.0]).flatmap(lambda sign: st.sampled_from([0.39, 0.79, 1.18, 1.57, 3.14]).map(lambda a: sign * a)),
)


@settings(max_examples=150, deadline=None)
@given(st.lists(_piece, min_size=0, max_size=6), st.lists(_pose, min_size=1, max_size=12), st.lists(_turn, min_size=1, max_size=8))
def test_the_compiled_table_and_tests_are_the_numpy_ones(pieces, poses, turns):
    with pytest.MonkeyPatch.context() as monkeypatch:
        points = _scene(pieces) if pieces else np.zeros((0, 2))
        free = _assert_same_table(points, monkeypatch)
        _assert_same_straights(free, [(0.0, 0.0, 0.0, 1.0, True), *poses])
        _assert_same_turns(free, [(0.0, 0.0, 0.0, 1.57), (0.27, 0.0, 0.0, -0.79), *turns])
        _assert_same_points(free, np.array([(x, y) for x, y, *_ in poses] + [(1.0, 0.0), (0.0, 0.0)]))
        if len(points):  # on and just behind the returns
            _assert_same_points(free, np.concatenate((points[:20], points[:20] * 1.001)))


@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_the_compiled_table_and_tests_match_on_the_shared_scans(monkeypatch):
    rng = np.random.default_rng(5)
    files = sorted(SCANS.glob("*/*.dat"))[::9]
    assert files
    for f in files:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", perception.ScanWarning)
            scan = load_scan(f)
            kept = perception.perceive(scan, body=BODY).points
        for points in (kept, scan):  # as the planner builds it, and a raw scan (cropped by the table)
            free = _assert_same_table(points, monkeypatch)
            poses = [(*rng.uniform(-0.8, 0.8, 2), rng.uniform(-math.pi, math.pi), rng.choice([0.0, 0.27, 0.6]), bool(rng.integers(2))) for _ in range(40)]
            _assert_same_straights(free, [(0.0, 0.0, 0.0, 1.0, True), *poses])
            turns = [(*rng.uniform(-0.8, 0.8, 2), rng.uniform(-math.pi, math.pi), rng.choice([-1, 1]) * rng.uniform(0.02, math.pi)) for _ in range(30)]
            _assert_same_turns(free, turns)
            _assert_same_points(free, np.concatenate((rng.uniform(-1.2, 1.2, (200, 2)), points[::7], points[::7] * 1.001)))


def test_a_body_given_in_whole_numbers_keeps_the_numpy_table():
    # the compiled loops are typed for floats; a body of ints is answered by the statements
    free = KnownFree(np.array([[0.5, 0.0], [0.5, 0.01]]), 1.1, body=(1, 1, 1))
    assert free._table is None and free.contains(0.3, 0.0)


def _assert_same_obstacles(points: np.ndarray, monkeypatch: pytest.MonkeyPatch, **options: float) -> None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", perception.ScanWarning)
        got = perception.perceive(points, body=BODY, **options)
        with monkeypatch.context() as m:
            m.setattr(perception, "_compiled", lambda: None)
            ref = perception.perceive(points, body=BODY, **options)
    for name in OBSTACLE_FIELDS:
        a, b = getattr(got, name), getattr(ref, name)
        if isinstance(b, np.ndarray):
            assert a.shape == b.shape and a.tobytes() == b.tobytes(), name
        else:
            assert a == b, name


@same_rounding
@settings(max_examples=100, deadline=None)
@given(st.lists(_piece, min_size=1, max_size=6), st.sampled_from([1, 2]), st.sampled_from([0.002, 0.0005]))
def test_perceptions_compiled_pass_is_its_numpy_statements(pieces, repeat, pad):
    # repeats (a recorded scan's) are dropped before the sort from 512 points on; some
    # returns lie inside the body (exempt) or beyond the horizon (cropped)
    points = np.repeat(np.concatenate((_scene(pieces), [[0.05, 0.0], [3.0, 0.0]])), repeat, axis=0)
    with pytest.MonkeyPatch.context() as monkeypatch:
        _assert_same_obstacles(points, monkeypatch, pad=pad)


@same_rounding
@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_perceptions_compiled_pass_matches_on_the_shared_scans(monkeypatch):
    for f in sorted(SCANS.glob("*/*.dat"))[::5]:
        _assert_same_obstacles(load_scan(f), monkeypatch)


def test_a_scan_with_a_nan_is_refused_by_the_compiled_pass_too():
    with pytest.raises(perception.ScanError):
        perception.perceive(np.array([[0.5, 0.0], [math.nan, 0.1]]), body=BODY)
