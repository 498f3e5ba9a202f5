"""The planner's compiled loops (:mod:`clomp.planner._kernels`) against their numpy statements
(perception's ``_cut`` and ``_boxes``; ``Scene._straight_gap_numpy``): the same figures, bit for bit."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose, TaskKind
from clomp.planner import _kernels, contact, footprint, load_scan, perception
from clomp.planner._kernels import near_boxes, surfaces_and_boxes
from clomp.planner.contact import Scene
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task

SCANS = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "scans"
FIELDS = ("points", "starts", "boxes", "centres", "radii")
# the loops give numpy's figures only where numpy rounds as they do (elsewhere perception and
# the straight gap keep the numpy statements: tested below)
same_rounding = pytest.mark.skipif(not _kernels.ROUNDS_AS_NUMPY, reason="numpy rounds otherwise on this host")


def _both(points: np.ndarray, pad: float = 0.002, cluster: float = 0.1) -> tuple[list[np.ndarray], list[np.ndarray]] | None:
    robot = RobotModel()
    with warnings.catch_warnings():  # returns beyond the range: cropped, which is not under test here
        warnings.simplefilter("ignore", perception.ScanWarning)
        kept = perception._kept(points, robot.sensor_range, footprint.body_box(robot))
    if not isinstance(kept, tuple):
        return None
    pts, keep, exempt = kept
    got = surfaces_and_boxes(pts, keep.copy(), len(pts) > perception._DEDUPE_FROM, cluster, pad, perception._PIECE, perception._THIN)
    z, step = perception._along_surfaces(pts, keep)
    ref = perception._boxes(*perception._cut(z, step, cluster), pad, exempt)
    return [np.asarray(getattr(ref, f)) for f in FIELDS], list(got)


def _assert_bitwise(pair: tuple[list[np.ndarray], list[np.ndarray]] | None) -> None:
    if pair is None:
        return
    for name, a, b in zip(FIELDS, *pair):
        assert a.shape == b.shape and a.tobytes() == b.tobytes(), name


# surfaces: arcs, walls and scattered posts (thick pieces are halved; breaks at the ±π bearing)
_surface = st.tuples(
    st.floats(-3.2, 3.2), st.floats(0.05, 2.5), st.floats(0.15, 1.3), st.floats(-0.3, 0.3), st.integers(1, 120),
    st.sampled_from([0.0, 0.001, 0.01]),
)


def _scan(surfaces: list[tuple[float, float, float, float, int, float]], seed: int) -> np.ndarray:
    """The points of generated surfaces (arcs bent by a sine, with noise), in their order."""
    rng = np.random.default_rng(seed)
    parts = []
    for start, span, radius, bend, n, noise in surfaces:
        a = start + np.linspace(0.0, span, n)
        r = radius + bend * np.sin(3 * a) + rng.normal(0.0, noise + 1e-12, n)
        parts.append(np.c_[r * np.cos(a), r * np.sin(a)])
    return np.concatenate(parts)


@same_rounding
@settings(max_examples=150, deadline=None)
@given(st.lists(_surface, min_size=1, max_size=6), st.integers(0, 2**32 - 1), st.sampled_from([0.002, 0.0005, 0.03]), st.booleans())
def test_compiled_surfaces_and_boxes_are_numpys_to_the_bit(surfaces, seed, pad, rounded):
    pts = _scan(surfaces, seed)
    if rounded:  # as the recorded scans: centimetres, with repeats
        pts = np.round(pts, 2)
    _assert_bitwise(_both(pts, pad=pad))


@same_rounding
@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_compiled_surfaces_and_boxes_match_on_the_shared_scans():
    files = sorted(SCANS.glob("*/*.dat"))[::7]
    assert files
    for f in files:
        _assert_bitwise(_both(load_scan(f)))


@pytest.mark.parametrize("pad", [0.0, -0.001, float("nan")])
def test_the_compiled_loop_refuses_a_pad_that_is_not_positive(pad):
    # with no pad an extent keeps the sign of a zero, which only perception's numpy path writes
    with pytest.raises(ValueError, match="pad must be positive"):
        surfaces_and_boxes(np.zeros((1, 2)), np.ones(1, dtype=bool), False, 0.1, pad, 0.08, 0.0075)


@settings(max_examples=300, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 400), st.floats(0.1, 2 * np.pi), st.floats(-np.pi, np.pi),
       st.booleans(), st.sampled_from([0.0, 1e-3, 0.03]), st.sampled_from([None, 2]))
def test_the_bearing_order_is_numpys_stable_argsort(seed, n, span, start, clockwise, jitter, rounded):
    # a scan's bearings as a sensor sweeps them (either way round, over a whole turn or less,
    # wrapping at ±π or not), with jitter and repeats (rounded points): the one order by
    # (bearing, index) whichever way the loop finds it (turned at the wrap or not, insertion
    # sort or merge sort)
    rng = np.random.default_rng(seed)
    a = start + np.linspace(0.0, span, n) * (-1.0 if clockwise else 1.0) + rng.normal(0.0, jitter + 1e-300, n)
    r = rng.uniform(0.2, 1.1, n)
    x, y = r * np.cos(a), r * np.sin(a)
    if rounded is not None:
        x, y = np.round(x, rounded), np.round(y, rounded)
    bearing = np.arctan2(y, x)
    assert _kernels._stable_order(bearing).tolist() == bearing.argsort(kind="stable").tolist()


def _scene(points: np.ndarray) -> Scene | None:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", perception.ScanWarning)
        obs = perception.perceive(points, body=footprint.body_box(RobotModel()))
    return Scene(obs, RobotModel()) if len(obs) else None


def _assert_gaps_agree(scene: Scene, poses: list[Pose]) -> None:
    for pose in poses:
        for near in (None, scene.near(pose.x, pose.y)):
            got, ref = scene._straight_gap(pose, near), scene._straight_gap_numpy(pose, near)
            assert type(got[1]) is int and np.float64(got[0]).tobytes() == np.float64(ref[0]).tobytes() and got[1] == ref[1]


@same_rounding
@settings(max_examples=100, deadline=None)
@given(st.lists(_surface, min_size=1, max_size=5), st.integers(0, 2**32 - 1),
       st.lists(st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-3.2, 3.2)), min_size=1, max_size=8))
def test_the_compiled_straight_gap_is_numpys_to_the_bit(surfaces, seed, poses):
    scene = _scene(np.round(_scan(surfaces, seed), 2))
    if scene is not None:
        # the planning origin (points inside the inflated body at the start) and elsewhere
        _assert_gaps_agree(scene, [Pose(0.0, 0.0, 0.0), *(Pose(x, y, t) for x, y, t in poses)])


@same_rounding
@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_the_compiled_straight_gap_matches_on_the_shared_scans():
    headings = np.linspace(-np.pi, np.pi, 9)
    for f in sorted(SCANS.glob("*/*.dat"))[::11]:
        scene = _scene(load_scan(f))
        if scene is not None:
            _assert_gaps_agree(scene, [Pose(x, y, t) for x in (0.0, 0.27) for y in (0.0, -0.1) for t in headings])


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 2**32 - 1), st.integers(1, 60), st.sampled_from([0.0, 0.01, 0.3]))
def test_the_compiled_box_filter_is_numpys(seed, m, margin):
    rng = np.random.default_rng(seed)
    centres = np.round(rng.uniform(-1.0, 1.0, (m, 2)), 2)
    radii = np.round(rng.uniform(0.0, 0.3, m), 2)
    for x, y in [*np.round(rng.uniform(-1.2, 1.2, (5, 2)), 2).tolist(), *centres[:2].tolist(), (centres[0, 0] + radii[0], centres[0, 1])]:
        ref = np.flatnonzero(np.hypot(centres[:, 0] - x, centres[:, 1] - y) <= radii + margin + 1e-12).tolist()
        assert near_boxes(centres, radii, x, y, margin) == ref


def test_where_numpy_rounds_otherwise_the_numpy_statements_run(monkeypatch):
    wall = np.c_[np.full(41, 0.5), np.linspace(-0.2, 0.2, 41)]
    compiled = perception.perceive(wall)
    monkeypatch.setattr(_kernels, "ROUNDS_AS_NUMPY", False)
    def not_called(*args: object) -> None:
        raise AssertionError("a compiled loop ran where numpy rounds otherwise")

    for name in ("surfaces_and_boxes", "kept_points", "boxes_of", "lane_gap", "lane_gaps", "turn_hits"):
        monkeypatch.setattr(_kernels, name, not_called)
    for cached in (perception._compiled, contact._lane_gap, contact._lane_gaps, contact._turn_hits):
        cached.cache_clear()
    try:
        plain = perception.perceive(wall)
        scene = Scene(plain, RobotModel())
        assert scene._straight_gap(Pose(0.0, 0.0, 0.0)) == scene._straight_gap_numpy(Pose(0.0, 0.0, 0.0))
    finally:
        for cached in (perception._compiled, contact._lane_gap, contact._lane_gaps, contact._turn_hits):
            cached.cache_clear()
    for f in FIELDS:
        assert np.asarray(getattr(plain, f)).tobytes() == np.asarray(getattr(compiled, f)).tobytes()



def _assert_least_gaps_agree(scene: Scene, poses: list[Pose], monkeypatch: pytest.MonkeyPatch) -> None:
    heads = [float(h) for h in np.linspace(-np.pi, np.pi, 13)]
    for pose in poses:
        near, dz, body = scene.near(pose.x, pose.y)
        if not len(near):
            continue
        got = scene._least_gaps(dz, heads, body)
        with monkeypatch.context() as m:
            m.setattr(contact, "_lane_gaps", lambda: None)
            ref = scene._least_gaps(dz, heads, body)
        assert np.array(got[0]).tobytes() == np.array(ref[0]).tobytes()
        # the point met, where one is (a heading with none in its lane has no column to name)
        assert [k for k, d in zip(got[1], got[0]) if np.isfinite(d)] == [k for k, d in zip(ref[1], ref[0]) if np.isfinite(d)]


@same_rounding
@settings(max_examples=60, deadline=None)
@given(st.lists(_surface, min_size=1, max_size=5), st.integers(0, 2**32 - 1),
       st.lists(st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-3.2, 3.2)), min_size=1, max_size=6))
def test_the_compiled_gaps_of_many_headings_are_numpys_to_the_bit(surfaces, seed, poses):
    scene = _scene(np.round(_scan(surfaces, seed), 2))
    if scene is not None:
        with pytest.MonkeyPatch.context() as monkeypatch:
            _assert_least_gaps_agree(scene, [Pose(0.0, 0.0, 0.0), *(Pose(x, y, t) for x, y, t in poses)], monkeypatch)


@same_rounding
@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_the_compiled_gaps_of_many_headings_match_on_the_shared_scans(monkeypatch):
    for f in sorted(SCANS.glob("*/*.dat"))[::13]:
        scene = _scene(load_scan(f))
        if scene is not None:
            _assert_least_gaps_agree(scene, [Pose(x, y, 0.0) for x in (0.0, 0.27) for y in (0.0, -0.1)], monkeypatch)


def _assert_turns_agree(scene: Scene, poses: list[Pose], monkeypatch: pytest.MonkeyPatch) -> None:
    robot = RobotModel()
    for pose in poses:
        near, dz, body = scene.near(pose.x, pose.y)
        dx, dy = dz.real.copy(), dz.imag.copy()
        sel = (dx * dx + dy * dy <= scene.radius2).nonzero()[0]
        if not len(sel):
            continue
        tasks = [Task.turn(robot, kind, pose, None, angle) for kind, angle in
                 ((TaskKind.LEFT, np.pi / 2), (TaskKind.RIGHT, 3 * np.pi / 8), (TaskKind.LEFT, 0.0), (TaskKind.RIGHT, np.pi))]
        got = scene._turns(tasks, near.take(sel), dx.take(sel), dy.take(sel))
        with monkeypatch.context() as m:
            m.setattr(contact, "_turn_hits", lambda: None)
            ref = scene._turns(tasks, near.take(sel), dx.take(sel), dy.take(sel))
        assert got == ref, pose


@same_rounding
@settings(max_examples=80, deadline=None)
@given(st.lists(_surface, min_size=1, max_size=5), st.integers(0, 2**32 - 1),
       st.lists(st.tuples(st.floats(-0.6, 0.6), st.floats(-0.6, 0.6), st.floats(-3.2, 3.2)), min_size=1, max_size=6))
def test_the_compiled_turn_contacts_are_numpys(surfaces, seed, poses):
    # points near the body: the start-touching rule (held to the real body, tested between ticks) is exercised
    scan = np.round(_scan(surfaces, seed), 2) * 0.35
    scene = _scene(scan)
    if scene is not None:
        with pytest.MonkeyPatch.context() as monkeypatch:
            _assert_turns_agree(scene, [Pose(0.0, 0.0, 0.0), *(Pose(x * 0.3, y * 0.3, t) for x, y, t in poses)], monkeypatch)


@same_rounding
@pytest.mark.skipif(not SCANS.is_dir(), reason="the shared recorded scans are not here")
def test_the_compiled_turn_contacts_match_on_the_shared_scans(monkeypatch):
    for f in sorted(SCANS.glob("*/*.dat"))[::13]:
        scene = _scene(load_scan(f))
        if scene is not None:
            _assert_turns_agree(scene, [Pose(x, y, t) for x in (0.0, 0.27) for y in (0.0, -0.1) for t in (0.0, 1.0, -2.0)], monkeypatch)
