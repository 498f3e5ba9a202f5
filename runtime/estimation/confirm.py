"""Is the estimate the only pose that explains what the robot sees? :func:`ambiguity`.

The scan matcher corrects the estimate only within its reach (its correspondences end at
a few centimetres): a robot pushed 0.2 m, or one whose heading slipped, is matched near
its prediction against surfaces that joined the map where the estimate put them, and the
filter's covariance, updated by those matches, stays small (issue #36: 0.1–0.9 m off
while believing 1 cm). Before it vouches for the goal the supervisor asks a wider
question: started from several guesses around the estimate (steps of the position and
of the heading), does the revolution match the map *elsewhere* as well as it does at the
estimate? An alternative that pairs as many points as closely means the scene cannot
tell the two apart (a corridor's axis) or the map holds the surfaces twice (once where
they are, once where the estimate drew them after the push): either way the estimate
cannot vouch for its position to better than that alternative's distance.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> from clomp.runtime.estimation.icp import ReferenceScan
>>> corner = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 51)] + [[x, 0.5] for x in np.linspace(0.0, 1.0, 51)])
>>> ambiguity(ReferenceScan(corner), corner, Pose(0.0, 0.0, 0.0)).distance   # a corner pins the pose
0.0
>>> wall = np.array([[x, 0.5] for x in np.linspace(-3.0, 3.0, 301)])
>>> ambiguity(ReferenceScan(wall), wall[100:200], Pose(0.0, 0.0, 0.0)).distance > 0.1   # along one wall: anywhere
True
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from scipy.spatial import cKDTree

from clomp.formal.model import Pose
from clomp.runtime.estimation.icp import ReferenceScan, match_scans

__all__ = ["Ambiguity", "ambiguity", "GUESSES"]

GUESSES: tuple[tuple[float, float, float], ...] = tuple(
    [(r * math.cos(a), r * math.sin(a), 0.0) for r in (0.12, 0.25) for a in np.arange(8) * math.pi / 4]
    + [(0.0, 0.0, h) for h in (-0.5, -0.25, 0.25, 0.5)]
)
"""The starting guesses (dx, dy in the map frame, m; dtheta, rad) around the estimate:
two rings of eight steps (a push slides the body 0.1-0.3 m) and four turns (a heading
off by 15-30° is what the wheels alone leave after a few turns at ``harsh``)."""


@dataclass(frozen=True)
class Ambiguity:
    """The outcome of :func:`ambiguity`: ``distance`` (m), how far from the estimate the
    farthest alternative lies that explains the revolution as well (0: none); ``inliers``:
    the share of the revolution's points the match at the estimate pairs; ``alternatives``:
    how many guesses converged to such an alternative; ``matched``: whether the revolution
    matched the map at the estimate at all (False: nothing to vouch with); ``better``: the
    alternative that explains it clearly better than the estimate (None: none does), and
    ``gain``, its misfit less the estimate's (negative: better)."""

    distance: float
    inliers: float
    alternatives: int
    matched: bool
    better: Pose | None = None
    gain: float = 0.0


def _cost(tree: cKDTree, points: np.ndarray, pose: Pose, reach: float, sd: float) -> float:
    """The revolution's misfit at ``pose``: each point's squared distance to the nearest map
    point, in ``sd``, no more than ``reach`` counted (a point with no partner costs as much
    as one at ``reach``: it saw something the map does not hold there)."""
    c, s = math.cos(pose.theta), math.sin(pose.theta)
    world = points @ np.array([[c, s], [-s, c]]) + (pose.x, pose.y)
    d, _ = tree.query(world, distance_upper_bound=reach)
    d = np.minimum(d, reach)
    return float(np.sum(d * d)) / (sd * sd)


def ambiguity(reference: ReferenceScan, points: np.ndarray, pose: Pose, *,
              guesses: tuple[tuple[float, float, float], ...] = GUESSES, min_points: int = 10,
              sd: float = 0.01, correlation: float = 4.0, margin: float = 6.0, reach: float = 3.0,
              apart: float = 0.04, better: float = 30.0,
              far_enough: float = 0.05, least_gain: float = -math.inf) -> Ambiguity:
    """How far from ``pose`` the revolution ``points`` (robot frame) matches ``reference``
    (map frame) as well as at ``pose``; see the module docstring. The ICP from each guess
    converges somewhere; that pose is an alternative when its misfit (each point's
    squared distance to the map in ``sd``, at most ``reach`` of them; :func:`_cost`), divided by
    ``correlation`` (neighbouring points share the map's errors), exceeds the match at the
    estimate's by no more than ``margin`` (6: the 95 % point of chi-square with 2 degrees
    of freedom) and it lies more than ``apart`` (m) from it. A revolution that does not
    match at the estimate at all is not ``matched`` (its distance: infinite). An alternative
    whose misfit is lower than the estimate's by more than ``better`` (in the same units) is
    ``better`` and lies more than ``far_enough`` (m) from
    the estimate is ``better``: the revolution says the robot is there, not where the estimate puts it.
    ``least_gain``: an alternative fitting better than the estimate by more than this is not
    counted as explaining it *as well* (default: every one is)."""
    here = match_scans(reference, points, pose, gate=None, min_points=min_points)
    tree = reference.tree
    if not here.ok or tree is None:
        return Ambiguity(math.inf, here.inlier_fraction, 0, False)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    base = _cost(tree, pts, here.pose, reach * sd, sd)
    best, n = 0.0, 0
    better_pose: Pose | None = None
    better_gain = 0.0
    for dx, dy, dth in guesses:
        prior = Pose(here.pose.x + dx, here.pose.y + dy, here.pose.theta + dth)
        alt = match_scans(reference, points, prior, gate=None, min_points=min_points)
        if not alt.ok or math.hypot(alt.pose.x - here.pose.x, alt.pose.y - here.pose.y) <= apart:
            continue
        gain = (_cost(tree, pts, alt.pose, reach * sd, sd) - base) / correlation
        if least_gain <= gain <= margin:
            n += 1
            best = max(best, math.hypot(alt.pose.x - pose.x, alt.pose.y - pose.y))
        far = math.hypot(alt.pose.x - pose.x, alt.pose.y - pose.y) > far_enough
        if far and gain <= -better and (better_pose is None or gain < better_gain):
            better_pose, better_gain = alt.pose, gain
    return Ambiguity(best, here.inlier_fraction, n, True, better_pose, better_gain)
