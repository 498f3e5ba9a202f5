"""What the goal's own revolution cannot vouch for, whatever the filter believes (issue #36).

The filter's covariance is only as honest as the matches that shrank it, and two kinds of
scene fool a match in a way no later match can show:

- **A direction the scene leaves blind.** Between a corridor's walls nothing pins the
  position along them, but a single noisy revolution makes the walls' bands look like
  blobs, each matched point to point and each claiming to pin the position along the
  walls too. The map drawn from the estimate drifts with it, every match agrees, and the
  filter keeps a few centimetres where the truth is a decimetre off (``corridor`` 1/4 at
  ``harsh`` without the gyro: the filter learnt a forward scale of -0.089 from such matches,
  truly about 0, and claimed the goal 0.137 m off with a 95 % bound of 0.081 m).
  :func:`blind_floor` judges the revolutions fused standing at the goal, dense enough for
  the shape test to see lines as lines
  (:func:`~clomp.runtime.estimation.observability.shape_information`): along a translation
  they leave unobserved the prior is all there is, so the bound is at least ``sigmas``
  times the prior's forward-scale uncertainty times the way from the start along it (the
  start is the one pose known exactly).
- **A scene aliased against the surfaces seen first.** The surfaces drawn at the start,
  before any doubt (:attr:`~clomp.runtime.estimation.doubt.Doubt.trust`), carry the least
  error; the map drawn since follows the estimate. When the start's surfaces explain the
  goal's revolution as well at a pose a decimetre away (``overtaking`` layout 78 at
  ``paper``: the box's faces repeat along the way by 13.5 cm; after a doubt opened the gain
  the estimate jumped onto the alias, and claimed the goal 0.141 m off with a bound of 6 mm),
  the estimate cannot vouch for better than that distance. :func:`start_ambiguity` searches widely from several
  guesses (:func:`~clomp.runtime.estimation.confirm.ambiguity`) at a margin of 15 (the
  99.95 % point of chi-square with 2 degrees of freedom: only what the start's surfaces
  clearly tell apart is told apart).

Both are floors under the bound the supervisor vouches with
(:func:`~clomp.runtime.supervision.goal.at_goal`); neither changes the estimate.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> xs = np.linspace(-1.0, 1.0, 201)
>>> walls = np.r_[np.c_[xs, np.full(201, 0.3)], np.c_[xs, np.full(201, -0.3)]]   # robot frame, at the goal
>>> floor, along = blind_floor(walls, Pose(1.3, 0.0, 0.0), Pose(0.0, 0.0, 0.0), scale_sd=0.06)
>>> round(floor, 3), along           # 2.45 x 0.06 x 1.3 m along the blind axis
(0.191, 'x')
>>> corner = np.r_[walls, np.c_[np.full(61, 0.9), np.linspace(-0.3, 0.3, 61)]]
>>> blind_floor(corner, Pose(1.3, 0.0, 0.0), Pose(0.0, 0.0, 0.0), scale_sd=0.06)   # an end wall pins it
(0.0, '')
"""

from __future__ import annotations

import math

import numpy as np

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh
from clomp.runtime.estimation.confirm import ambiguity
from clomp.runtime.estimation.icp import ReferenceScan, direction_name
from clomp.runtime.estimation.observability import shape_information

__all__ = ["START_MARGIN", "blind_floor", "start_ambiguity", "trusted_surfaces"]

START_MARGIN = 15.0
"""The misfit margin (chi-square units, after the matcher's correlation) within which a pose
explains the goal's revolution as well as the estimate against the start's surfaces."""


def blind_floor(points: np.ndarray, pose: Pose, start: Pose, scale_sd: float, *, sigmas: float = 2.45,
                min_information: float = 0.02, radius: float = 0.2) -> tuple[float, str]:
    """The least 95 % bound (m) the revolution ``points`` (robot frame, seen at the estimate
    ``pose``) leaves the position, and the direction that sets it ('' when none): along each
    translation whose structural information per point
    (:func:`~clomp.runtime.estimation.observability.shape_information`, the matcher's units)
    is below ``min_information`` (the matcher's own threshold), ``sigmas`` × ``scale_sd`` (the
    prior's forward-scale uncertainty) × the way from ``start`` along it. A revolution with
    no usable structure at all is blind in every direction. See the module docstring."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    way = np.array([pose.x - start.x, pose.y - start.y])
    world = points_from_frame(pts, pose) if len(pts) else pts
    h, n = shape_information(world, (pose.x, pose.y), radius=radius)
    if n == 0:
        return sigmas * scale_sd * float(np.hypot(*way)), "x, y"
    lam, vec = eigh(h[:2, :2] / n)
    floor, name = 0.0, ""
    for k in range(2):
        if lam[k] >= min_information:
            continue
        u = vec[:, k]
        f = sigmas * scale_sd * abs(float(way @ u))
        if f > floor:
            floor, name = f, direction_name(np.array([u[0], u[1], 0.0]))
    return floor, name


def trusted_surfaces(map_points: np.ndarray, map_sds: np.ndarray, pose: Pose, trust: float) -> np.ndarray:
    """Which map points were drawn at most ``trust`` uncertain (``map_sds[:, 0]``) and, when
    ``map_sds[:, 2]`` gives the bearing each was seen along, face a robot at ``pose`` from
    the side they were seen (a box's front face is not its back)."""
    sds = np.asarray(map_sds, dtype=float)
    pts = np.asarray(map_points, dtype=float)
    keep: np.ndarray = sds[:, 0] <= trust
    if sds.shape[1] > 2:
        toward = np.arctan2(pts[:, 1] - pose.y, pts[:, 0] - pose.x)
        keep &= np.cos(toward - sds[:, 2]) > 0.0
    return keep


def start_ambiguity(map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, pose: Pose, *, trust: float,
                    sd: float, correlation: float, min_points: int = 10, least_inliers: float = 0.5,
                    margin: float = START_MARGIN, better: float = 30.0) -> float:
    """How far from the estimate ``pose`` a pose lies that explains the revolution ``points``
    (robot frame) as well against the surfaces drawn before any doubt
    (:func:`trusted_surfaces`), within ``margin`` (:func:`~clomp.runtime.estimation.confirm.ambiguity`),
    in m; 0 when they pin it, or when they cannot judge (too few of them, no match at the
    estimate, or one pairing less than ``least_inliers`` of the revolution: what the start
    never saw says nothing here). A pose fitting *clearly better*, by more than ``better``, is
    not counted: where the start's surfaces end short of what the goal's revolution sees, a
    pose that slides the revolution back onto their drawn extent pairs more of it (at
    ``harsh``, ``overtaking``'s side walls drawn to 1 m from the start and seen to 1.6 m from
    the goal put such a pose 0.27 m behind estimates truly 1-6 cm from the goal, by 50-100)."""
    if map_points is None or map_sds is None or len(map_points) == 0:
        return 0.0
    keep = trusted_surfaces(map_points, map_sds, pose, trust)
    if int(keep.sum()) < min_points:
        return 0.0
    ref = ReferenceScan(np.asarray(map_points, dtype=float)[keep])
    amb = ambiguity(ref, points, pose, min_points=min_points, sd=sd, correlation=correlation, margin=margin,
                    better=better, least_gain=-better)
    if not amb.matched or amb.inliers < least_inliers or not math.isfinite(amb.distance):
        return 0.0
    return float(amb.distance)
