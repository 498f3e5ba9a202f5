"""2-D scan matching: point-to-line ICP with a prior, gating and degeneracy detection.

:func:`match_scans` finds the pose of a *current* scan's frame in a *reference* scan's
frame (x forward, y left, theta counter-clockwise). Each reference point gets the normal
of the line through its neighbours (principal axes of the points within ``normal_radius``;
points with no clear line are left out); each current point is paired with its nearest
reference point (a uniform grid, searched by the compiled loop of
:mod:`clomp.runtime.estimation._icp_core`) and the point-to-line distances are minimised by
Gauss–Newton with Huber weights, starting from the ``prior`` (dead reckoning).

Degeneracy: the information matrix ``H = JᵀWJ`` of the converged match (rotation scaled
by ``lever`` metres so that the three axes compare) says how well each direction of
(x, y, theta) is pinned down. Eigen-directions with too little information per
correspondence (``min_information``) are *unobservable* — a single straight wall leaves
the translation along it free; no returns leave everything free. There the solution keeps
the prior's value (the update is solved only in the observable subspace), and the result
names the unobservable directions in words.

Gating: a match that disagrees with the prior by more than ``gate`` (metres, radians) is
rejected (``ok`` False, with the reason) — a wrong data association under heavy noise
must not teleport the robot.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> ref = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 51)] + [[x, 0.5] for x in np.linspace(0.0, 1.0, 51)])
>>> cur = ref - [0.05, 0.0]          # the robot moved 5 cm forward
>>> m = match_scans(ref, cur, Pose(0.0, 0.0, 0.0))
>>> m.ok, round(m.pose.x, 3), abs(round(m.pose.y, 3)), m.unobservable
(True, 0.05, 0.0, ())
>>> wall = np.array([[x, 0.5] for x in np.linspace(-1.0, 1.0, 101)])
>>> match_scans(wall, wall, Pose(0.1, 0.0, 0.0)).unobservable   # along the wall: keep the prior
('x',)
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.estimation._icp_core import cell_keys, grid_index, icp_iterations
from clomp.runtime.jit import interruptible

__all__ = ["ScanMatch", "ReferenceScan", "direction_name", "match_scans", "neighbour_lines"]

# the reference grid's cell (m): about the first iteration's correspondence distance
_CELL = 0.1


@dataclass(frozen=True)
class ScanMatch:
    """The outcome of one match.

    ``pose``: the current frame in the reference frame (the prior's value in unobservable
    directions; the prior itself when ``ok`` is False). ``unobservable``: the directions the
    scene does not constrain, each ``"x"``, ``"y"``, ``"heading"`` or a mixed direction
    such as ``"0.71x+0.71y"``. ``information_matrix``: ``JᵀWJ`` of the converged match in
    state units (m, rad), summed over the correspondences, with the unobservable
    directions removed — divided by the residual variance, the inverse covariance of the
    pose (what a filter fuses, :mod:`clomp.runtime.estimation.ekf`). ``inlier_fraction``: share
    of the current points paired within the final correspondence distance; ``rmse``:
    their point-to-line RMS (m).
    """

    pose: Pose
    ok: bool
    reason: str
    correspondences: int
    inlier_fraction: float
    rmse: float
    iterations: int
    unobservable: tuple[str, ...]
    information: tuple[float, float, float]
    information_matrix: tuple[tuple[float, float, float], ...] = ((0.0, 0.0, 0.0),) * 3

    @property
    def degenerate(self) -> bool:
        """True when at least one direction is unobservable."""
        return bool(self.unobservable)


class ReferenceScan:
    """A reference scan prepared once for many matches: its line normals and the grid the
    compiled matcher searches (``tree``, a k-d tree of its points, is built on first use)."""

    def __init__(self, points: np.ndarray, normal_radius: float = 0.08, neighbours: int = 12) -> None:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        self.raw = pts
        pts = np.unique(np.round(pts, 4), axis=0)  # quantised scans repeat points: once each
        self.points = pts
        self.normals = np.zeros((len(pts), 2))
        self.line = np.zeros(len(pts), dtype=bool)
        if len(pts) < neighbours:
            self._set_rows()
            return
        count, line, angle = neighbour_lines(pts, normal_radius, neighbours)
        # a point is usable when it has neighbours; it is on a line when they spread along one
        usable = count >= 4
        self.points = pts[usable]
        self.normals = np.c_[-np.sin(angle), np.cos(angle)][usable]
        self.line = line[usable]
        self._set_rows()

    @functools.cached_property
    def tree(self) -> cKDTree | None:
        """A k-d tree of the points (None when there are none), for callers' own queries:
        the matcher itself searches the grid."""
        return cKDTree(self.points) if len(self.points) else None

    def _set_rows(self) -> None:
        """Each point's two residual directions — its normal (and nothing) on a line, x and y
        elsewhere — and the grid the compiled matcher (:mod:`._icp_core`) searches, with the
        points sorted by its cells."""
        n = len(self.points)
        rows = np.zeros((n, 2, 2))
        rows[:, 0, 0], rows[:, 1, 1] = 1.0, 1.0
        rows[self.line, 0, :] = self.normals[self.line]
        rows[self.line, 1, 1] = 0.0
        real = np.ones((n, 2), dtype=bool)
        real[self.line, 1] = False
        starts, self._grid = grid_index(self.points, _CELL)
        order = np.argsort(cell_keys(self.points, self._grid), kind="stable")
        self._starts = starts
        self._sorted = (np.ascontiguousarray(self.points[order]), np.ascontiguousarray(rows[order]),
                        np.ascontiguousarray(real[order]))

    def __len__(self) -> int:
        return len(self.points)


def neighbour_lines(points: np.ndarray, radius: float, neighbours: int,
                    line_ratio: float = 0.25) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The line test of each point's neighbourhood: for every row of ``points`` (N×2; N and
    ``neighbours`` at least 2),
    how many of its ``neighbours`` nearest points lie within ``radius`` (itself included),
    whether they spread along a line (the spread across it at most ``line_ratio`` of the
    spread along, the principal axes of their scatter) and that line's direction (rad).

    The matcher (:class:`ReferenceScan`, within 8 cm) gives a point on a line its normal;
    :func:`~clomp.runtime.estimation.observability.shape_information` (within 0.2 m) asks the
    same of the scene's shape; the compiled screen
    :func:`~clomp.runtime.estimation._shape_core.shape_estimate` repeats it for speed (a test
    holds the two together).

    >>> import numpy as np
    >>> s = np.linspace(0.0, 0.5, 11)
    >>> corner = np.r_[np.c_[s, np.zeros(11)], np.c_[np.zeros(10), s[1:]]]   # two walls meet at 0
    >>> count, line, angle = neighbour_lines(corner, 0.12, 8)
    >>> int(count[5]), bool(line[5]), round(float(angle[5]), 3), round(float(angle[15]), 3)
    (5, True, 0.0, 1.571)
    >>> bool(line[0])                                  # the corner itself lies on no line
    False
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    d, idx = cKDTree(pts).query(pts, k=min(neighbours, len(pts)), distance_upper_bound=radius)
    near = np.isfinite(d)
    count = near.sum(axis=1)
    nb = pts[np.where(near, idx, 0)]  # N×k×2, padded with point 0 where no neighbour
    wts = near[..., None].astype(float)
    mean = (nb * wts).sum(axis=1) / np.maximum(count, 1)[:, None]
    q = (nb - mean[:, None, :]) * wts
    sxx, syy, sxy = (q[..., 0] ** 2).sum(1), (q[..., 1] ** 2).sum(1), (q[..., 0] * q[..., 1]).sum(1)
    # eigenvalues of [[sxx, sxy], [sxy, syy]]: the line's spread and the spread across it
    half_tr, det = (sxx + syy) / 2, sxx * syy - sxy**2
    root = np.sqrt(np.maximum(half_tr**2 - det, 0.0))
    big, small = half_tr + root, half_tr - root
    angle = 0.5 * np.arctan2(2 * sxy, sxx - syy)  # direction of the line
    line = (big > 0) & (small <= line_ratio * big)
    return count, line, angle


def direction_name(v: np.ndarray) -> str:
    """The name of a direction ``v`` of (x, y, heading): ``"x"``, ``"y"`` or ``"heading"``
    when one axis holds more than 0.95 of it, else its components (sign chosen so the largest
    is positive; those under 0.05 left out). Shared by the matcher's and the shape check's
    (:mod:`~clomp.runtime.estimation.observability`) unobservable directions.

    >>> direction_name(np.array([0.0, -2.0, 0.1])), direction_name(np.array([1.0, -1.0, 0.0]))
    ('y', '0.71x-0.71y')
    """
    v = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) > 0.95:
        return ("x", "y", "heading")[k]
    v = v if v[k] > 0 else -v
    return "+".join(f"{c:.2f}{n}" for c, n in zip(v, ("x", "y", "heading")) if abs(c) >= 0.05).replace("+-", "-")


def match_scans(
    reference: np.ndarray | ReferenceScan,
    current: np.ndarray,
    prior: Pose,
    *,
    max_iterations: int = 20,
    max_distance: float = 0.15,
    final_distance: float = 0.04,
    huber: float = 0.01,
    lever: float = 0.5,
    min_information: float = 0.02,
    min_points: int = 40,
    min_inlier_fraction: float = 0.3,
    max_rmse: float = 0.02,
    gate: tuple[float, float] | None = (0.2, 0.35),
) -> ScanMatch:
    """Match ``current`` (N×2, its own frame) to ``reference`` starting from ``prior``.

    See the module docstring. ``max_distance`` is the first iteration's correspondence
    distance, shrinking to ``final_distance``; ``huber`` the Huber threshold (m);
    ``lever`` the length (m) that makes a rotation comparable to a translation;
    ``min_information`` the least information per correspondence of an observable
    direction; ``gate`` (translation m, rotation rad) the largest disagreement with the
    prior accepted (None: no gating).
    """
    ref = reference if isinstance(reference, ReferenceScan) else ReferenceScan(reference)
    cur = np.asarray(current, dtype=float).reshape(-1, 2)
    cur = cur[np.all(np.isfinite(cur), axis=1)]
    every = ("x", "y", "heading")

    def fail(reason: str, n: int = 0, frac: float = 0.0, rmse: float = math.nan, it: int = 0,
             info: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ScanMatch:
        return ScanMatch(prior, False, reason, n, frac, rmse, it, every, info)

    if len(cur) < min_points or len(ref) < min_points or len(ref) == 0:
        return fail(f"too few points to match ({len(cur)} current, {len(ref)} reference)")
    pts, rows, real = ref._sorted
    stopped, x, lam, vecs, n_used, it, dist, n_final, rmse = interruptible(
        icp_iterations, pts, rows, real, ref._starts, *ref._grid, np.ascontiguousarray(cur), np.array([prior.x, prior.y, prior.theta], dtype=float),
        int(max_iterations), float(max_distance), float(final_distance), float(huber), float(lever), float(min_information),
        int(min_points))  # one signature: the loop is compiled once, whatever numbers the caller passes
    if stopped:
        return fail(f"too few correspondences ({n_used}) within {dist:.2f} m", n_used, n_used / len(cur), it=it)
    info = tuple(float(v) for v in np.sort(lam / max(n_used, 1)))
    seen = lam / max(n_used, 1) >= min_information
    h_obs = (vecs[:, seen] * lam[seen]) @ vecs[:, seen].T  # the observable part, rotation scaled by lever
    scale = np.array([1.0, 1.0, lever])
    h_state = h_obs * scale[:, None] * scale[None, :]
    imat = tuple(tuple(float(v) for v in row) for row in h_state)
    unobservable = tuple(direction_name(vecs[:, k]) for k in range(3) if lam[k] / max(n_used, 1) < min_information)
    frac = n_final / len(cur)
    pose = Pose(float(x[0]), float(x[1]), float(x[2]))
    if len(unobservable) == 3:
        return ScanMatch(prior, False, "no direction is observable in this scene", n_final, frac, rmse, it, every, info)  # type: ignore[arg-type]
    if frac < min_inlier_fraction:
        return ScanMatch(prior, False, f"only {frac:.0%} of the points match", n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    if not (rmse <= max_rmse):
        return ScanMatch(prior, False, f"residual {rmse * 100:.1f} cm too large", n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    if gate is not None:
        dt = math.hypot(pose.x - prior.x, pose.y - prior.y)
        da = abs(wrap_angle(pose.theta - prior.theta))
        if dt > gate[0] or da > gate[1]:
            return ScanMatch(prior, False, f"disagrees with the prior by {dt * 100:.0f} cm, {math.degrees(da):.0f}°: rejected",
                             n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    reason = "matched" if not unobservable else f"matched; unobservable: {', '.join(unobservable)} (kept from the prior)"
    return ScanMatch(pose, True, reason, n_final, frac, rmse, it, unobservable, info, imat)  # type: ignore[arg-type]
