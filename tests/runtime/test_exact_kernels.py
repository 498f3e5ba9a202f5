"""Speed-ups of the estimator's per-revolution arithmetic stay bit-identical to the numpy
they replace (issue #41: throughput without a behaviour change).

Each faster function is compared, bit for bit (``tobytes`` / float equality including
NaN), with its numpy reference on generated inputs: ``_exact.median`` with ``np.median``,
``_exact.ring_neighbours`` with ``np.roll``, ``_exact.unwrap`` with ``np.unwrap``,
``doubt.see_through`` (which now turns only the map points near the robot into its frame)
with the whole-map version it had, and ``ScanOdometry._add`` (which now computes the
uncertainty of the new points only) with its old self.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st
from hypothesis.extra import numpy as hnp

from scipy.spatial import cKDTree

from clomp.formal.geometry import points_from_frame, points_to_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh, eigvalsh, mean, mean_rows, median, nanmedian_columns, ring_neighbours, unwrap
from clomp.runtime.estimation.doubt import see_through
from clomp.runtime.estimation.icp import ReferenceScan
from clomp.runtime.estimation.odometry import ScanOdometry

_floats = st.floats(min_value=-1e3, max_value=1e3, allow_nan=False, allow_infinity=False)


def _same_float(a: float, b: float) -> bool:
    return (math.isnan(a) and math.isnan(b)) or np.float64(a).tobytes() == np.float64(b).tobytes()


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.integers(0, 60), elements=st.floats(allow_infinity=False) | st.sampled_from([0.0, -0.0, 0.5])))
def test_median_is_numpys_bit_for_bit(v: np.ndarray) -> None:
    """Odd and even lengths, repeated values, signed zeros, NaN and the empty array."""
    with np.errstate(all="ignore"):
        import warnings

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)  # numpy warns on an empty array
            ref = float(np.median(v))
    assert _same_float(median(v), ref)


def test_median_of_a_strided_column() -> None:
    """The estimator passes a column of an N×3 array (a strided view)."""
    a = np.random.default_rng(1).normal(size=(301, 3))
    assert _same_float(median(a[:, 1]), float(np.median(a[:, 1])))
    assert _same_float(median(a[:-1, 2]), float(np.median(a[:-1, 2])))


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.tuples(st.integers(1, 12), st.integers(0, 40)),
                  elements=st.floats(0.0, 2.0) | st.sampled_from([np.nan, np.nan, 0.5, -0.0, 1e300])))
def test_nanmedian_columns_is_numpys_bit_for_bit(v: np.ndarray) -> None:
    """The fused revolutions' median range per bearing (a few revolutions × many bins, NaN
    where a revolution saw nothing): odd and even counts, repeats, signed zeros, columns of
    NaN only (numpy warns there; the fusion never asks for them)."""
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        ref = np.nanmedian(v, axis=0)
    got = nanmedian_columns(v)
    assert got.dtype == ref.dtype and got.shape == ref.shape
    assert got.tobytes() == ref.tobytes() or all(_same_float(a, b) for a, b in zip(got.tolist(), ref.tolist()))


@settings(max_examples=300, deadline=None)
@given(st.integers(1, 4), st.integers(0, 2**32 - 1), st.sampled_from([1e-12, 1e-3, 1.0, 1e4]),
       st.sampled_from(["plain", "strided", "nan", "int"]))
def test_eigh_and_eigvalsh_are_numpys_bit_for_bit(n: int, seed: int, scale: float, kind: str) -> None:
    """The small symmetric matrices the estimator decomposes (2×2 scatter, 3×3 information,
    a covariance's 2×2 corner: a strided view); NaN and integer input go to numpy itself."""
    rng = np.random.default_rng(seed)
    a = rng.normal(0.0, scale, (n + 1, n + 1))
    a = (a + a.T) / 2
    m = a[:n, :n] if kind == "strided" else a[:n, :n].copy()
    if kind == "nan":
        m[0, 0] = np.nan
    if kind == "int":
        m = np.round(m * 10).astype(int)
    def same(ours: Any, ref: Any) -> None:
        try:
            want = ref(m)
        except np.linalg.LinAlgError:
            try:
                ours(m)
            except np.linalg.LinAlgError:
                return
            raise AssertionError("numpy raised, ours did not") from None
        got = ours(m)
        pairs = zip(got, want) if isinstance(got, tuple) else [(got, want)]
        for g, w in pairs:
            assert g.dtype == w.dtype and g.shape == w.shape and g.tobytes() == w.tobytes()

    same(eigh, np.linalg.eigh)
    same(eigvalsh, np.linalg.eigvalsh)


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.tuples(st.integers(1, 300), st.just(2)),
                  elements=st.floats(-10, 10) | st.sampled_from([0.0, -0.0, 1e-300, 0.01])), st.booleans())
def test_mean_rows_is_numpys_bit_for_bit(v: np.ndarray, masked: bool) -> None:
    """fit_line's centre: the mean of N×2 points (a masked selection, as refine_line passes)."""
    if masked:
        v = v[np.arange(len(v)) % 3 != 1] if len(v) > 2 else v
    assert mean_rows(v).tobytes() == v.mean(axis=0).tobytes()


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.integers(1, 400), elements=st.floats(-10, 10) | st.sampled_from([0.0, -0.0, 1e-300, 0.01])))
def test_mean_is_numpys_bit_for_bit(v: np.ndarray) -> None:
    """refine_line's and measure's 1-d means (lengths past numpy's 8-way unrolled blocks)."""
    assert _same_float(mean(v), float(np.mean(v)))
    assert _same_float(mean(v[::2]), float(np.mean(v[::2])))


@settings(max_examples=200, deadline=None)
@given(hnp.arrays(np.bool_, st.integers(0, 12)), st.integers(0, 15))
def test_ring_neighbours_are_np_roll(a: np.ndarray, reach: int) -> None:
    got = ring_neighbours(a, reach)
    want = [np.roll(a, s) for k in range(1, reach + 1) for s in (k, -k)]
    assert len(got) == len(want)
    for g, w in zip(got, want):
        assert g.dtype == w.dtype and g.tobytes() == w.tobytes()


@settings(max_examples=300, deadline=None)
@given(hnp.arrays(np.float64, st.integers(0, 40),
                  elements=st.floats(-20, 20) | st.sampled_from([0.0, -0.0, math.pi, -math.pi, 3.0, -3.0, math.nan])))
def test_unwrap_is_numpys_bit_for_bit(p: np.ndarray) -> None:
    """Small steps (the fast path), half-turn steps exactly (numpy's boundary case), wraps and NaN."""
    assert unwrap(p).tobytes() == np.unwrap(p).tobytes()


def test_unwrap_of_a_heading_history() -> None:
    """A heading that turns through ±pi in small steps, with a -0.0 in it."""
    th = np.concatenate(([-0.0, 0.0, -0.0], np.cumsum(np.full(400, 0.02)) - 1.0))
    wrapped = np.arctan2(np.sin(th), np.cos(th))
    for p in (th, wrapped, wrapped[::-1], th[:3]):
        assert unwrap(p).tobytes() == np.unwrap(p).tobytes()


def _see_through_reference(map_points: np.ndarray, points: np.ndarray, pose: Pose, *, margin: float = 0.1,
                           bins: int = 180, reach: float = 1.2, empty: float = 0.9) -> tuple[int, int]:
    """``doubt.see_through`` as it was before issue #41 (the whole map turned, ``np.roll``)."""
    if not len(map_points) or not len(points):
        return 0, 0
    local = points_to_frame(np.asarray(map_points, dtype=float).reshape(-1, 2), pose)
    mx, my = local[:, 0], local[:, 1]
    mr = np.hypot(mx, my)
    near = mr <= reach
    width = 2 * math.pi / bins

    def profile(x: np.ndarray, y: np.ndarray, r: np.ndarray) -> np.ndarray:
        k = np.floor((np.arctan2(y, x) + math.pi) / width).astype(int) % bins
        out = np.full(bins, np.inf)
        np.minimum.at(out, k, r)
        return out

    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    seen = profile(pts[:, 0], pts[:, 1], np.hypot(pts[:, 0], pts[:, 1]))
    drawn = profile(mx[near], my[near], mr[near])
    both = np.isfinite(seen) & np.isfinite(drawn)
    past = both & (seen > drawn + margin)
    past &= np.roll(past, 1) & np.roll(past, -1)
    gone = ~np.isfinite(seen) & (drawn <= empty)
    gone &= np.roll(gone, 1) & np.roll(gone, -1) & np.roll(gone, 2) & np.roll(gone, -2)
    through = past | gone
    return int(through.sum()), int(np.isfinite(drawn).sum())


def _room(rng: np.random.Generator, n: int) -> np.ndarray:
    """A map like the estimator's: points on a 1 cm grid, walls and boxes over a few metres."""
    walls = []
    for _ in range(6):
        a, b = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        t = np.linspace(0, 1, n // 6)[:, None]
        walls.append(a + t * (b - a))
    return np.unique(np.round(np.concatenate(walls) / 0.01), axis=0) * 0.01


@settings(max_examples=150, deadline=None)
@given(st.integers(0, 2**32 - 1), _floats.map(lambda v: v / 500), _floats.map(lambda v: v / 500),
       st.floats(-math.pi, math.pi), st.sampled_from([0.0, 0.05, 0.2]), st.sampled_from([1.2, 0.3, 5.0]))
def test_see_through_is_the_whole_map_version(seed: int, x: float, y: float, th: float, off: float, reach: float) -> None:
    """Random rooms, poses (some on a grid line, some far from the map), scans seen from
    nearby (so that some bearings look through), several reaches."""
    rng = np.random.default_rng(seed)
    room = _room(rng, 900)
    pose = Pose(x, y, th)
    scan = points_to_frame(room + [off, -off], pose)
    scan = scan[np.hypot(scan[:, 0], scan[:, 1]) < 3.0]
    scan = scan[rng.random(len(scan)) > 0.2]  # some bearings without a return
    assert see_through(room, scan, pose, reach=reach) == _see_through_reference(room, scan, pose, reach=reach)


def test_see_through_on_points_just_outside_the_square() -> None:
    """Map points at exactly ``reach`` along an axis, and just beyond: the pre-filter's
    square keeps every point the whole-map version would count."""
    reach = 1.2
    ring = np.array([[reach, 0.0], [0.0, -reach], [-reach, 0.0], [reach + 1e-9, 0.0], [0.0, reach + 1e-7],
                     [0.848528137423857, 0.848528137423857], [0.8485281374238571, -0.8485281374238571]])
    for th in (0.0, 1e-9, math.pi / 4, -math.pi / 3):
        pose = Pose(0.3, -0.2, th)
        world = ring + [0.3, -0.2]
        scan = points_to_frame(world * 1.05, pose)
        assert see_through(world, scan, pose, reach=reach) == _see_through_reference(world, scan, pose, reach=reach)


def _add_reference(odo: ScanOdometry, points: np.ndarray, pose: Pose, reseed: bool) -> bool:
    """``ScanOdometry._add`` as it was before issue #41 (every point's uncertainty computed,
    then the known ones dropped)."""
    if len(points) < odo.min_points:
        return False
    world = points_from_frame(points, pose)
    hon = odo.filter.honest
    pos_var = max(float(np.linalg.eigvalsh(hon[:2, :2])[-1]), odo.doubt.sd ** 2)
    th_var = max(float(hon[2, 2]), 0.0)
    rng2 = np.einsum("ij,ij->i", points, points)
    sds = np.c_[np.sqrt(pos_var + rng2 * th_var), np.full(len(points), math.sqrt(th_var)),
                np.arctan2(world[:, 1] - pose.y, world[:, 0] - pose.x)]
    old = odo._map_points if (odo._map_points is not None and not reseed) else np.zeros((0, 2))
    old_sds = odo._map_sds if (odo._map_sds is not None and not reseed) else np.zeros((0, 3))
    if len(old) and odo._map is not None and len(odo._map):
        if odo._map_tree is None:
            odo._map_tree = cKDTree(old)
        d, _ = odo._map_tree.query(world, distance_upper_bound=odo.new_surface)
        world, sds = world[~np.isfinite(d)], sds[~np.isfinite(d)]
        if len(world) == 0:
            return False
    cells, first = np.unique(np.round(np.r_[old, world] / odo.map_resolution), axis=0, return_index=True)
    merged = cells * odo.map_resolution
    merged_sds = np.r_[old_sds, sds][first]
    near = np.hypot(merged[:, 0] - pose.x, merged[:, 1] - pose.y) <= odo.map_radius
    merged, merged_sds = merged[near], merged_sds[near]
    if odo._map_points is not None and not reseed and len(merged) == len(odo._map_points):
        return False
    odo._map_points, odo._map_tree, odo._map_sds = merged, None, merged_sds
    odo._map = ReferenceScan(merged)
    return True


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_the_map_grows_as_before(seed: int) -> None:
    """A map grown by twelve revolutions from poses drifting through a room (some seeing
    nothing new, some re-seeding, the filter's uncertainty growing): the same points, the
    same per-point uncertainties, bit for bit, and the same answers."""
    rng = np.random.default_rng(seed)
    room = _room(rng, 1200)
    new, ref = ScanOdometry(wheel_base=0.15, compass=False), ScanOdometry(wheel_base=0.15, compass=False)
    pose = Pose(0.0, 0.0, 0.0)
    for k in range(12):
        pose = Pose(pose.x + rng.normal(0, 0.1), pose.y + rng.normal(0, 0.1), pose.theta + rng.normal(0, 0.2))
        seen = points_to_frame(room, pose)
        seen = seen[(np.hypot(seen[:, 0], seen[:, 1]) < 2.0) & (rng.random(len(seen)) < 0.5)]
        seen = seen + rng.normal(0, 0.004, seen.shape)
        for odo in (new, ref):
            odo.filter.honest[:3, :3] = np.diag([1e-4 * k, 2e-4 * k, 1e-3 * k])
        reseed = k == 0 or rng.random() < 0.1
        assert new._add(seen, pose, reseed) == _add_reference(ref, seen, pose, reseed)
        assert new._map_points is not None and ref._map_points is not None and ref._map_sds is not None
        assert new._map_points.tobytes() == ref._map_points.tobytes()
        assert new._map_sds is not None and new._map_sds.tobytes() == ref._map_sds.tobytes()


def _map_sd_reference(odo: ScanOdometry, points: np.ndarray, pose: Pose) -> tuple[float, float]:
    """``ScanOdometry._map_sd`` as it was before issue #41 (scipy's default tree, ``np.median``)."""
    if odo._map_points is None or odo._map_sds is None or not len(odo._map_points) or not len(points):
        return (0.0, 0.0)
    d, idx = cKDTree(odo._map_points).query(points_from_frame(points, pose), distance_upper_bound=0.05)
    hit = np.isfinite(d)
    if not hit.any():
        return (0.0, 0.0)
    sds = odo._map_sds[idx[hit]]
    return (float(np.median(sds[:, 0])), float(np.median(sds[:, 1])))


def _odometry_with_map(points: np.ndarray, sds: np.ndarray) -> ScanOdometry:
    odo = ScanOdometry(wheel_base=0.15, compass=False)
    odo._map_points, odo._map_sds, odo._map_tree = points, sds, None
    return odo


@settings(max_examples=40, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(-math.pi, math.pi))
def test_map_sd_is_the_default_trees(seed: int, th: float) -> None:
    """Random maps on the 1 cm grid, revolutions near them: the same medians, bit for bit."""
    rng = np.random.default_rng(seed)
    room = _room(rng, 1500)
    odo = _odometry_with_map(room, rng.uniform(0, 0.1, (len(room), 3)))
    pose = Pose(*rng.normal(0, 0.3, 2), th)
    seen = points_to_frame(room[rng.random(len(room)) < 0.3], pose) + rng.normal(0, 0.01, (1, 2))
    got, want = odo._map_sd(seen, pose), _map_sd_reference(odo, seen, pose)
    assert all(_same_float(a, b) for a, b in zip(got, want))


def test_map_sd_with_equidistant_map_points() -> None:
    """Points exactly between two or four map points (binary fractions, so the distances tie
    exactly), each map point with its own uncertainty: the one scipy's default tree picks."""
    g = np.arange(-20, 21) * 0.0625
    grid = np.array([(x, y) for x in g for y in g])
    sds = np.column_stack((np.arange(len(grid)) * 1e-3, np.arange(len(grid))[::-1] * 1e-3, np.zeros(len(grid))))
    odo = _odometry_with_map(grid, sds)
    h = 0.03125
    centres = np.array([(x + h, y + h) for x in g[:-1] for y in g[:-1]])  # four map points at the same distance
    edges = np.array([(x + h, y) for x in g[:-1] for y in g])  # two
    for pts in (centres, edges, np.r_[centres[::3], edges[::5]]):
        got, want = odo._map_sd(pts, Pose(0.0, 0.0, 0.0)), _map_sd_reference(odo, pts, Pose(0.0, 0.0, 0.0))
        assert all(_same_float(a, b) for a, b in zip(got, want))
