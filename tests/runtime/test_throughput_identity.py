"""Issue #41's speedups of the supervisor's hazard test hold the results bit for bit.

Each cheaper path is held here to a frozen copy of the code it replaced: the hazard test's
point counts (a compiled loop, :func:`clomp.runtime.supervision._contacts_core.sweep_hits`,
for :func:`clomp.runtime.supervision.records.hits` per sweep), and the fused revolutions the
hazard test asks for only when a shallow alarm needs them (they were fused every tick).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner.footprint import body_box, inside
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task
from clomp.runtime.supervision.alarms import Alarms, hazard_hits, range_noise
from clomp.runtime.supervision.planwatch import PlanWatch
from clomp.runtime.supervision.records import hits, scan_to_frame, sweep

M = RobotModel()


def _frozen_hazard_hits(points: np.ndarray, kind: TaskKind, error: float, m: RobotModel, lookahead: float,
                        allowance: float = 0.0) -> tuple[int, int]:
    """hazard_hits as it was before issue #41's compiled count (records.hits per sweep)."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= m.length + error + 0.05] if len(pts) else pts
    if len(pts):
        own = inside(pts[:, 0], np.abs(pts[:, 1]), body_box(m), strict=True)
        pts = pts[~own]
    if len(pts) == 0:
        return 0, 0
    rate = m.turn_rate if kind.is_turn else m.straight_speed
    soon = hits(pts, sweep(kind, min(error, rate * lookahead)), m, allowance)
    return soon, hits(pts, sweep(kind, error), m, allowance)


def _outline_points(m: RobotModel, allowance: float, rng: np.random.Generator) -> np.ndarray:
    """Points on and around the box's outline at a turn's sampled headings: where a
    comparison's last bit decides inside or out."""
    rear, front, half = body_box(m, -allowance)
    th = rng.choice(sweep(TaskKind.LEFT, 1.0)[:, 2], 40)
    u = rng.choice([-rear, front, 0.0, front + 1e-12, -rear - 1e-12], 40)
    v = rng.choice([half, -half, half + 1e-12, 0.01], 40)
    c, s = np.cos(th), np.sin(th)
    out: np.ndarray = np.c_[u * c - v * s, u * s + v * c]
    return out


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), kind=st.sampled_from(list(TaskKind)), error=st.floats(0.0, 1.7),
       allowance=st.sampled_from([0.0, 0.004, 0.03]), n=st.integers(0, 300))
def test_the_compiled_hazard_count_is_the_array_count_bit_for_bit(seed: int, kind: TaskKind, error: float,
                                                                   allowance: float, n: int) -> None:
    rng = np.random.default_rng(seed)
    pts = np.r_[rng.uniform(-0.6, 0.6, (n, 2)), _outline_points(M, allowance, rng)]
    assert hazard_hits(pts, kind, error, M, 0.5, allowance) == _frozen_hazard_hits(pts, kind, error, M, 0.5, allowance)


def test_the_compiled_count_meets_points_on_the_outline_and_misses_a_hair_beyond() -> None:
    """A point exactly on the box's front edge counts, one a hair beyond it does not: the
    count's comparisons are the footprint test's, on the same floating-point values."""
    rear, front, half = body_box(M)
    on, beyond = np.array([[front + 0.1, 0.0]]), np.array([[np.nextafter(front + 0.1, 1.0), 0.0]])
    # the robot's 0.1 m straight sweep ends with its front 0.1 m further on
    assert hazard_hits(on, TaskKind.STRAIGHT, 0.1, M, 0.5)[1] == _frozen_hazard_hits(on, TaskKind.STRAIGHT, 0.1, M, 0.5)[1]
    assert hazard_hits(beyond, TaskKind.STRAIGHT, 0.1, M, 0.5) == _frozen_hazard_hits(beyond, TaskKind.STRAIGHT, 0.1, M, 0.5)


class _EagerWatch(PlanWatch):
    """PlanWatch as it was before issue #41: the last revolutions fused on every hazard test."""

    def hazard(self, clean_scan: np.ndarray | None, scan_pose: Pose, pose: Pose, task: Task, error: float,
               lookahead: float, needed: int) -> str | None:
        if clean_scan is None or len(clean_scan) == 0:
            return None
        self._remember(clean_scan, scan_pose)
        pts = scan_to_frame(clean_scan, scan_pose, pose)
        recent = self._fused(pose) if self.alarms.allowance > 0 else None
        return self.alarms.hazard(pts, task.kind, error, self.model, lookahead, needed, pose, recent)


class _CountingWatch(PlanWatch):
    fusions = 0

    def _fused(self, frame: Pose) -> np.ndarray | None:
        self.fusions += 1
        fused: np.ndarray | None = super()._fused(frame)
        return fused


def _wall_rays(y: float) -> np.ndarray:
    a = np.radians(np.arange(5.0, 175.0, 1.0))
    out: np.ndarray = np.c_[y / np.tan(a), np.full(len(a), y)]
    return out


def _noisy(pts: np.ndarray, sd: float, rng: np.random.Generator) -> np.ndarray:
    r = np.hypot(pts[:, 0], pts[:, 1])
    out: np.ndarray = pts * ((r + rng.normal(0.0, sd, len(r))) / r)[:, None]
    return out


def test_the_hazard_test_fuses_only_when_a_shallow_alarm_asks_and_decides_as_before() -> None:
    """Harsh range noise (2.5 cm) on walls from well inside the body's path to well clear of
    it, the robot drifting towards and away: every verdict and every count of deferred
    alarms is the eager watch's, while most ticks (no alarm, or a deep one) fuse nothing."""
    rng = np.random.default_rng(11)
    lazy, eager = _CountingWatch(M, lambda *a, **k: None), _EagerWatch(M, lambda *a, **k: None)
    ticks = 0
    for gap in (0.05, 0.015, 0.005, -0.01, -0.03, 0.1):
        for k in range(15):
            at = Pose(0.01 * k, 0.05 - 0.025 * (k % 3), 0.02 * math.sin(k))
            rev = _noisy(_wall_rays(M.width / 2 + gap - at.y), 0.025, rng)
            task = Task.straight(M, at, Disturbance.goal(2.0, at.y), 1.0)
            for w in (lazy, eager):
                w.alarms.revolution(rev)
            for error in (0.27, 0.1):  # two ticks a revolution, as the supervisor asks
                ticks += 1
                assert lazy.hazard(rev, at, at, task, error, 0.5, 2) == eager.hazard(rev, at, at, task, error, 0.5, 2)
                assert (lazy.alarms.deferred, lazy.alarms._dismissed) == (eager.alarms.deferred, eager.alarms._dismissed)
    assert lazy.alarms.allowance > 0.01  # harsh: the fused revolutions were in play
    assert 0 < lazy.fusions < ticks / 2, (lazy.fusions, ticks)


def _frozen_map_queries(map_points: np.ndarray, seen: np.ndarray, new_surface: float) -> tuple[np.ndarray, np.ndarray]:
    """The local map's two k-d tree queries as they were before issue #41's grid: which
    points are new surfaces (no map point within ``new_surface``), and each point's map
    point within 5 cm (-1: none), the balanced tree choosing where two are equally near."""
    from scipy.spatial import cKDTree

    tree = cKDTree(map_points, balanced_tree=False, compact_nodes=False)
    d, _ = tree.query(seen, distance_upper_bound=new_surface)
    new = ~np.isfinite(d)
    d2, idx2 = tree.query(seen, k=2, distance_upper_bound=0.05)
    d, idx = d2[:, 0], idx2[:, 0]
    if bool((np.isfinite(d) & (d == d2[:, 1])).any()):
        d, idx = cKDTree(map_points).query(seen, distance_upper_bound=0.05)
    return new, np.where(np.isfinite(d), idx, -1)


def _grid_map_queries(map_points: np.ndarray, seen: np.ndarray, new_surface: float) -> tuple[np.ndarray, np.ndarray]:
    """The same two answers from LocalMap's grid search (as its _add and _map_sd ask)."""
    from clomp.runtime.estimation._localmap import LocalMap

    lm = LocalMap()
    lm._map_points = map_points
    return lm._nearest(seen, new_surface)[0] < 0, lm._met(seen)


@settings(max_examples=150, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), n_map=st.integers(1, 3000), n=st.integers(0, 400),
       spread=st.sampled_from([0.2, 1.0, 2.5]))
def test_the_local_maps_grid_search_finds_what_its_k_d_tree_found(seed: int, n_map: int, n: int, spread: float) -> None:
    """Map points on the map's 1 cm grid (unique), revolution points anywhere near them, some
    exactly on map points, between two (equally near) or a bound away along an axis."""
    rng = np.random.default_rng(seed)
    cells = np.unique(np.round(rng.uniform(-spread, spread, (n_map, 2)) / 0.01), axis=0)
    map_points = cells * 0.01
    picks = map_points[rng.integers(0, len(map_points), 4)]
    special = np.r_[picks, picks + [0.005, 0.0], picks + [0.05, 0.0], picks + [0.0, 0.03], picks + [0.03, 0.0]]
    seen = np.r_[rng.uniform(-spread - 0.1, spread + 0.1, (n, 2)), special]
    got, want = _grid_map_queries(map_points, seen, 0.03), _frozen_map_queries(map_points, seen, 0.03)
    assert np.array_equal(got[0], want[0])
    assert np.array_equal(got[1], want[1])


@settings(max_examples=60, deadline=None)
@given(st.lists(st.floats(0.0, 0.05), min_size=1, max_size=25), st.integers(1, 12))
def test_the_allowance_computed_once_a_revolution_is_the_median_every_tick(noises: list[float], window: int) -> None:
    """:class:`Alarms` keeps its noise median until the next revolution: asked every tick,
    it is ``np.median`` of the window then, bit for bit (issue #41)."""
    a = Alarms(window=window)
    window_now: deque[float] = deque(maxlen=window)
    rng = np.random.default_rng(len(noises))
    for sd in noises:
        ang = np.linspace(-1.0, 1.0, 60)
        r = 0.6 / np.cos(ang) + rng.normal(0.0, sd, 60)
        pts = np.c_[r * np.cos(ang), r * np.sin(ang)]
        a.revolution(pts)
        window_now.append(range_noise(pts))
        for _ in range(2):  # two ticks in a revolution
            med = float(np.median(window_now))
            assert a.noise == med
            assert a.allowance == min(max(a.k * med - a.clearance, 0.0), a.cap)
