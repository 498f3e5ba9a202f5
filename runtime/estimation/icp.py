"""2-D scan matching: point-to-line ICP with a prior, gating and degeneracy detection.

:func:`match_scans` finds the pose of a *current* scan's frame in a *reference* scan's
frame (x forward, y left, theta counter-clockwise). Each reference point gets the normal
of the line through its neighbours (principal axes of the points within ``normal_radius``;
points with no clear line are left out); each current point is paired with its nearest
reference point (scipy's cKDTree) and the point-to-line distances are minimised by
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
>>> from formal.model import Pose
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

import math
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from formal.model import Pose

__all__ = ["ScanMatch", "ReferenceScan", "match_scans"]


@dataclass(frozen=True)
class ScanMatch:
    """The outcome of one match.

    ``pose``: the current frame in the reference frame (the prior's value in unobservable
    directions; the prior itself when ``ok`` is False). ``unobservable``: the directions the
    scene does not constrain, each ``"x"``, ``"y"``, ``"heading"`` or a mixed direction
    such as ``"0.71x+0.71y"``. ``information_matrix``: ``JᵀWJ`` of the converged match in
    state units (m, rad), summed over the correspondences, with the unobservable
    directions removed — divided by the residual variance, the inverse covariance of the
    pose (what a filter fuses, :mod:`runtime.estimation.ekf`). ``inlier_fraction``: share
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
    """A reference scan prepared once for many matches: its k-d tree and line normals."""

    def __init__(self, points: np.ndarray, normal_radius: float = 0.08, neighbours: int = 12) -> None:
        pts = np.asarray(points, dtype=float).reshape(-1, 2)
        pts = pts[np.all(np.isfinite(pts), axis=1)]
        self.raw = pts
        pts = np.unique(np.round(pts, 4), axis=0)  # quantised scans repeat points: once each
        self.points = pts
        self.normals = np.zeros((len(pts), 2))
        self.line = np.zeros(len(pts), dtype=bool)
        self.tree: cKDTree | None = cKDTree(pts) if len(pts) else None
        if len(pts) < neighbours:
            return
        d, idx = cKDTree(pts).query(pts, k=neighbours, distance_upper_bound=normal_radius)
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
        # a point is usable when it has neighbours; it is on a line when they spread along one
        usable = count >= 4
        line = (big > 0) & (small <= 0.25 * big)
        self.points = pts[usable]
        self.normals = np.c_[-np.sin(angle), np.cos(angle)][usable]
        self.line = line[usable]
        self.tree = cKDTree(self.points) if len(self.points) else None

    def __len__(self) -> int:
        return len(self.points)


def _direction_name(v: np.ndarray) -> str:
    v = v / np.linalg.norm(v)
    k = int(np.argmax(np.abs(v)))
    if abs(v[k]) > 0.95:
        return ("x", "y", "heading")[k]
    v = v if v[k] > 0 else -v
    return "+".join(f"{c:.2f}{n}" for c, n in zip(v, ("x", "y", "heading")) if abs(c) >= 0.05).replace("+-", "-")


def _rows(ref: ReferenceScan, cur: np.ndarray, moved: np.ndarray, idx: np.ndarray, c: float, s: float,
          lever: float) -> tuple[np.ndarray, np.ndarray]:
    """Residuals and Jacobian rows: point-to-line where the reference point lies on a line,
    point-to-point (two rows) elsewhere (corners, small objects)."""
    cx, cy = cur[:, 0], cur[:, 1]
    dp = np.empty_like(cur)  # d(moved)/d(theta)
    dp[:, 0] = -s * cx - c * cy
    dp[:, 1] = c * cx - s * cy
    diff = moved - ref.points[idx]
    line = ref.line[idx]
    nrm = ref.normals[idx[line]]
    n_line = len(nrm)
    pt = ~line
    k = len(idx) - n_line
    r = np.empty(n_line + 2 * k)
    jac = np.zeros((n_line + 2 * k, 3))
    r[:n_line] = np.einsum("ij,ij->i", nrm, diff[line])
    jac[:n_line, :2] = nrm
    jac[:n_line, 2] = np.einsum("ij,ij->i", nrm, dp[line]) / lever
    r[n_line:] = diff[pt].reshape(-1)
    j_pt = jac[n_line:]
    j_pt[0::2, 0] = 1.0
    j_pt[1::2, 1] = 1.0
    dpp = dp[pt]
    j_pt[0::2, 2] = dpp[:, 0] / lever
    j_pt[1::2, 2] = dpp[:, 1] / lever
    return r, jac


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
    x = np.array([prior.x, prior.y, prior.theta], dtype=float)
    every = ("x", "y", "heading")

    def fail(reason: str, n: int = 0, frac: float = 0.0, rmse: float = math.nan, it: int = 0,
             info: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> ScanMatch:
        return ScanMatch(prior, False, reason, n, frac, rmse, it, every, info)

    if len(cur) < min_points or len(ref) < min_points or ref.tree is None:
        return fail(f"too few points to match ({len(cur)} current, {len(ref)} reference)")
    dist = max_distance
    it = 0
    lam = np.zeros(3)
    vecs = np.eye(3)
    n_used = 0
    cx, cy = np.ascontiguousarray(cur[:, 0]), np.ascontiguousarray(cur[:, 1])
    moved = np.empty_like(cur)
    for it in range(1, max_iterations + 1):
        c, s = math.cos(x[2]), math.sin(x[2])
        moved[:, 0] = x[0] + c * cx - s * cy
        moved[:, 1] = x[1] + s * cx + c * cy
        d, idx = ref.tree.query(moved, distance_upper_bound=dist)
        use = np.isfinite(d)
        n_used = int(np.count_nonzero(use))
        if n_used < min_points:
            return fail(f"too few correspondences ({n_used}) within {dist:.2f} m", n_used, n_used / len(cur), it=it)
        r, jac = _rows(ref, cur[use], moved[use], idx[use], c, s, lever)
        a = np.abs(r)
        w = np.where(a <= huber, 1.0, huber / np.maximum(a, 1e-12))
        jw = (jac * w[:, None]).T
        h = jw @ jac
        g = jw @ r
        lam, vecs = np.linalg.eigh(h)
        observable = lam / n_used >= min_information
        step = np.zeros(3)
        for k in range(3):
            if observable[k]:
                step -= vecs[:, k] * (vecs[:, k] @ g) / lam[k]
        step[2] /= lever
        x += step
        x[2] = math.atan2(math.sin(x[2]), math.cos(x[2]))
        dist = max(final_distance, dist * 0.7)
        if np.linalg.norm(step[:2]) < 1e-5 and abs(step[2]) < 1e-5 and dist <= final_distance:
            break
    info = tuple(float(v) for v in np.sort(lam / max(n_used, 1)))
    seen = lam / max(n_used, 1) >= min_information
    h_obs = (vecs[:, seen] * lam[seen]) @ vecs[:, seen].T  # the observable part, rotation scaled by lever
    scale = np.array([1.0, 1.0, lever])
    h_state = h_obs * scale[:, None] * scale[None, :]
    imat = tuple(tuple(float(v) for v in row) for row in h_state)
    unobservable = tuple(_direction_name(vecs[:, k]) for k in range(3) if lam[k] / max(n_used, 1) < min_information)
    # final quality
    c, s = math.cos(x[2]), math.sin(x[2])
    moved[:, 0] = x[0] + c * cx - s * cy
    moved[:, 1] = x[1] + s * cx + c * cy
    d, idx = ref.tree.query(moved, distance_upper_bound=final_distance)
    use = np.isfinite(d)
    frac = float(use.mean())
    rmse = float(np.sqrt(np.mean(_rows(ref, cur[use], moved[use], idx[use], c, s, lever)[0] ** 2))) if use.any() else math.nan
    pose = Pose(float(x[0]), float(x[1]), float(x[2]))
    n_final = int(use.sum())
    if len(unobservable) == 3:
        return ScanMatch(prior, False, "no direction is observable in this scene", n_final, frac, rmse, it, every, info)  # type: ignore[arg-type]
    if frac < min_inlier_fraction:
        return ScanMatch(prior, False, f"only {frac:.0%} of the points match", n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    if not (rmse <= max_rmse):
        return ScanMatch(prior, False, f"residual {rmse * 100:.1f} cm too large", n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    if gate is not None:
        dt = math.hypot(pose.x - prior.x, pose.y - prior.y)
        da = abs(math.atan2(math.sin(pose.theta - prior.theta), math.cos(pose.theta - prior.theta)))
        if dt > gate[0] or da > gate[1]:
            return ScanMatch(prior, False, f"disagrees with the prior by {dt * 100:.0f} cm, {math.degrees(da):.0f}°: rejected",
                             n_final, frac, rmse, it, unobservable, info)  # type: ignore[arg-type]
    reason = "matched" if not unobservable else f"matched; unobservable: {', '.join(unobservable)} (kept from the prior)"
    return ScanMatch(pose, True, reason, n_final, frac, rmse, it, unobservable, info, imat)  # type: ignore[arg-type]
