"""What one scan match vouches for by itself: a position bound that does not depend on the gain (issue #36).

The filter's :attr:`~clomp.runtime.estimation.ekf.OdometryFilter.honest` covariance is the
true covariance of an estimate made with the *gain's* covariance ``P``; when ``honest``
admits more than ``P`` (a slip walk, the shared match floor, the map's drawing error) the gain
weights the matches as if the prediction were better than ``honest`` says, so a match can
hardly lower ``honest`` however sharp it is: at ``harsh`` the 95 % bound at the goal stood at
0.16 m (with the gyro) and 0.37 m (without) on runs truly 1-6 cm off, and 32 of 755 runs
truly at the goal with the gyro claimed it.

A match is a measurement ``z`` of the pose in the map's frame whose own error is its
covariance: the information of its points, the floor its revolutions share, and how wrong
the surfaces it met were drawn (each map point as uncertain as the estimate that drew it:
0 for the start's seed, whose error against the start frame is only the sensor's). Whatever
the gain made of it, the estimate ``x̂`` is then off from the truth ``x`` by at most
``|x̂ - z| + |z - x|``: the first is known, the second is within ``sigmas`` of the match's
position standard deviation 95 % of the time. That holds while the body has not moved since
the revolution (:class:`Evidence` keeps the odometer then: whatever was driven since is
added whole) and only for a match that observes every direction (a corridor's axis left to
dead reckoning is no evidence). The surfaces' error counts by its *mean* over the points
met, not the median the filter's ``map_sd`` takes: a match's error is about the mean of the
surfaces' errors when they share a drift.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> ev = match_evidence(Pose(1.0, 0.0, 0.0), np.diag([1e6, 1e6, 1e6]), (0.01, 0.01, 0.02), (0.0, 0.0), 3.0)
>>> round(ev.sd, 4)                                        # the floor, the points' own error tiny
0.01
>>> round(evidence_sd(ev, Pose(1.0245, 0.0, 0.0), 3.0), 4)   # the estimate 2.45 cm from the match
0.02
>>> evidence_sd(ev, Pose(1.0, 0.0, 0.0), 3.5) > 0.2        # driven 0.5 m since: added whole
True
>>> match_evidence(Pose(1.0, 0.0, 0.0), np.diag([1e6, 0.0, 1e6]), (0.01, 0.01, 0.02), (0.0, 0.0), 3.0) is None
True
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh, eigvalsh
from clomp.runtime.estimation.icp import ReferenceScan, match_scans
from clomp.runtime.estimation.observability import observed_information

__all__ = ["BOUND_SIGMAS", "Evidence", "evidence_sd", "match_evidence", "start_evidence"]

BOUND_SIGMAS = 2.45
"""Standard deviations of a 95 % position bound (the supervisor's ``vouch_sigmas``): the
known parts of :func:`evidence_sd` (metres, not standard deviations) are divided by it."""


@dataclass(frozen=True)
class Evidence:
    """One match's measurement of the position: ``x``, ``y`` (m, the map's frame), ``sd`` (m,
    its standard deviation, the larger axis), ``odometer`` (m driven, counting turns at the
    wheel base, when the revolution was matched) and ``revolution``."""

    x: float
    y: float
    sd: float
    odometer: float
    revolution: int = -1
    """The index of the revolution's record (:attr:`~clomp.runtime.estimation.odometry.ScanOdometry.records`), -1 unknown."""
    source: str = "match"
    """``"match"``: the filter's match against the whole map; ``"start"``: against the start's surfaces (:func:`start_evidence`)."""


def match_evidence(z: Pose, information: Sequence[Sequence[float]] | np.ndarray, floor: Sequence[float],
                   map_sd: Sequence[float], odometer: float, min_information: float = 1e-9) -> Evidence | None:
    """The evidence of a match at ``z`` with ``information`` (3×3, inverse covariance of its
    points, pose units), the shared ``floor`` (m, m, rad) and the surfaces' error ``map_sd``
    (m, rad; their mean over the points met) — None unless every direction is observed."""
    info = np.asarray(information, dtype=float).reshape(3, 3)
    lam, vecs = eigh((info + info.T) / 2)
    if not bool(np.all(lam > min_information)) or not np.all(np.isfinite(lam)):
        return None
    cov = (vecs / lam) @ vecs.T
    fl = np.square(np.asarray(floor, dtype=float).reshape(3))
    ms = (float(map_sd[0]) ** 2, float(map_sd[0]) ** 2, float(map_sd[1]) ** 2)
    pos = cov[:2, :2] + np.diag(fl[:2]) + np.diag(ms[:2])
    sd = math.sqrt(max(float(eigvalsh((pos + pos.T) / 2)[-1]), 0.0))
    if not math.isfinite(sd):
        return None
    return Evidence(float(z.x), float(z.y), sd, float(odometer))


def evidence_sd(ev: Evidence, pose: Pose, odometer: float, sigmas: float = BOUND_SIGMAS) -> float:
    """The position standard deviation ``ev`` vouches for at the estimate ``pose`` with the
    odometer at ``odometer``: its own, plus the estimate's distance from it and what was driven
    since, each over ``sigmas`` (so that ``sigmas`` times the figure is the bound
    ``|x̂ - z| + driven + sigmas · sd``)."""
    known = math.hypot(pose.x - ev.x, pose.y - ev.y) + max(odometer - ev.odometer, 0.0)
    return ev.sd + known / sigmas


def start_evidence(map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, at: Pose, odometer: float, *,
                   sd: float, correlation: float, floor_factor: float = 0.75, min_points: int = 10,
                   drawn_within: float = 0.002, facing: float = 0.3) -> Evidence | None:
    """The evidence of a revolution ``points`` (robot frame) seen from about ``at`` matched
    against the start's surfaces alone: the map points (``map_points``, N×2, with their
    ``map_sds`` rows: m, rad, the bearing each was drawn along) drawn within ``drawn_within`` m
    of uncertainty and seen now from the side they were drawn from (the cosine of the angle
    between the bearings above ``facing``: an object's far face would pair with the near one
    by the object's unknown depth). The match's residual is believed no smaller than ``sd``
    (m), ``correlation`` neighbouring points count as one, and its floor is ``floor_factor``
    of the residual, as :class:`~clomp.runtime.estimation.odometry.ScanOdometry` weighs its
    matches; directions the scene's shape leaves unobserved are taken out
    (:func:`~clomp.runtime.estimation.observability.observed_information`). None when too few
    start points face the robot, the match fails, or it leaves a direction unobserved.

    >>> wall = np.array([[1.0, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.5, 1.0, 76)])
    >>> sds = np.column_stack((np.zeros(len(wall)), np.zeros(len(wall)), np.arctan2(wall[:, 1], wall[:, 0])))
    >>> ev = start_evidence(wall, sds, wall - [0.1, 0.0], Pose(0.11, 0.0, 0.0), 1.0, sd=0.01, correlation=4.0)
    >>> abs(ev.x - 0.1) < 0.005, ev.sd < 0.01
    (True, True)
    """
    sds = np.asarray(map_sds, dtype=float)
    start = sds[:, 0] <= drawn_within
    if int(start.sum()) < 2 * min_points or len(points) < min_points:
        return None
    ref = np.asarray(map_points, dtype=float)[start]
    now = np.arctan2(ref[:, 1] - at.y, ref[:, 0] - at.x)
    ref = ref[np.cos(now - sds[start, 2]) > facing]
    if len(ref) < 2 * min_points:
        return None
    reference = ReferenceScan(ref)
    m = match_scans(reference, points, at, min_points=min_points, gate=None)
    if not m.ok:
        return None
    seen = np.asarray(points, dtype=float).reshape(-1, 2)
    tree = reference.tree
    assert tree is not None  # the reference holds points
    d, _ = tree.query(points_from_frame(seen, m.pose), distance_upper_bound=0.04)
    info, lost = observed_information(np.asarray(m.information_matrix), seen, m.pose, np.isfinite(d))
    if lost:
        return None
    s2 = max(m.rmse, sd) ** 2 * correlation
    fl = floor_factor * max(m.rmse, sd / 4)
    ev = match_evidence(m.pose, np.asarray(info) / s2, (fl, fl, fl / 0.5), (0.0, 0.0), odometer)
    return None if ev is None else dataclasses.replace(ev, source="start")
