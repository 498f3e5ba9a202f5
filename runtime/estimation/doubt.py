"""What the estimate cannot vouch for after evidence that the robot moved unlike its model.

Scan matching corrects the estimate only within its reach (correspondences end at a few
centimetres): a robot kicked 0.2 m is matched near its prediction, the surfaces it then
sees join the map where the wrong estimate draws them, and from then on every match agrees
with that map; its covariance, shrunk by those matches, stays small (issue #36: kicked
0.12 m, it ended 0.17 m off believing 1 cm). So the filter's covariance cannot be the only
judge of what the estimate may vouch for. :class:`Doubt` keeps a *floor* under the
position's standard deviation that ordinary matches do not lower, raised by

- a **shock** the IMU's accelerometer measured (:meth:`Doubt.shock`): more than a drive can
  do (its wheels accelerate the body at most at their limit, 1 m/s², plus the centripetal
  v·ω) means an outside force — a kick (tens of m/s²: the body slides 0.1–0.3 m), or a
  jolt (a few m/s²: a collision, or a body stopping dead while its wheels spin, a slip);
- a revolution that matched nothing the map holds, so that the map was re-seeded from a
  dead-reckoned pose, and well-matched revolutions that disagreed with the prediction
  several times in a row (:meth:`Doubt.raise_to`).

Only a wider search (:func:`~clomp.runtime.estimation.confirm.ambiguity`, several starting
guesses) against the surfaces drawn *before* the doubt — those whose own uncertainty is
below :attr:`Doubt.trust` — lowers it (:meth:`Doubt.confirmed`): to how far a pose the
trusted surfaces explain as well lies from the estimate. Surfaces drawn while in doubt
carry it (:class:`~clomp.runtime.estimation.odometry.ScanOdometry` draws them with the
floor), so they are not trusted for it.

>>> d = Doubt()
>>> d.shock(1.2, 3.0)                     # a drive's own acceleration: nothing
(0.0, False)
>>> d.shock(120.0, 10.4)                  # a kick: the floor, and the gain opened as wide
(0.15, True)
>>> d.sd, d.events[-1]
(0.15, (10.4, 'kick', 120.0))
>>> d.confirmed(0.02); d.sd               # the trusted surfaces pin the pose within 2 cm
0.02
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from clomp.formal.model import Pose
from clomp.runtime.estimation.confirm import ambiguity
from clomp.runtime.estimation.icp import ReferenceScan, match_scans

__all__ = ["Doubt", "trusted_check"]


@dataclass
class Doubt:
    """The floor under the position's standard deviation (m, :attr:`sd`) and why it was
    raised (:attr:`events`: ``(time, kind, size)``); see the module docstring.

    ``jolt`` (m/s²): a peak acceleration above this is a shock (3: three times what the
    drive does; the world's drive peaks at 1.9 in normal driving, a slip event at 7.9, a
    kick at 100–200). ``kick`` (m/s²): a shock above this slid the body by up to a push's
    size, ``kick_sd`` (m, one standard deviation; the floor); a smaller one (a slip, a
    bump) by up to ``jolt_sd`` (the filter's uncertainty opened by it, no floor: the
    matches that follow may close it). ``trust`` (m): surfaces drawn at most this
    uncertain count as drawn before the doubt."""

    jolt: float = 3.0
    kick: float = 30.0
    kick_sd: float = 0.15
    jolt_sd: float = 0.05
    trust: float = 0.05
    sd: float = 0.0
    events: list[tuple[float, str, float]] = field(default_factory=list)

    def __post_init__(self) -> None:
        for name in ("jolt", "kick", "kick_sd", "jolt_sd", "trust"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"Doubt: {name} must be a positive number, got {v!r}")

    def shock(self, peak: float, t: float) -> tuple[float, bool]:
        """The accelerometer peaked at ``peak`` m/s² at time ``t``: how far (m, one standard
        deviation) the body may have been moved unseen (0: not a shock), and whether that
        is a floor (a kick) rather than an uncertainty the matches may close (a jolt)."""
        if not (math.isfinite(peak) and peak > self.jolt):
            return 0.0, False
        if peak >= self.kick:
            self.events.append((t, "kick", round(float(peak), 1)))
            self.sd = max(self.sd, self.kick_sd)
            return self.kick_sd, True
        self.events.append((t, "jolt", round(float(peak), 1)))
        return self.jolt_sd, False

    def raise_to(self, sd: float, t: float, why: str) -> None:
        """The estimate may be ``sd`` m off for a reason its filter does not see (``why``)."""
        if math.isfinite(sd) and sd > self.sd:
            self.events.append((t, why, round(float(sd), 3)))
            self.sd = float(sd)

    def confirmed(self, sd: float) -> None:
        """A wider search against the trusted surfaces found the estimate explained, no pose
        farther than ``sd`` (m) explaining them as well: the floor is that."""
        self.sd = max(0.0, float(sd))


def trusted_check(doubt: Doubt, map_points: np.ndarray, map_sds: np.ndarray, points: np.ndarray, pose: Pose, *,
                  min_points: int = 10, sd: float = 0.02, correlation: float = 4.0, sigmas: float = 2.45) -> Pose | None:
    """A revolution ``points`` (robot frame) seen standing at the estimate ``pose``, searched
    for widely (:func:`~clomp.runtime.estimation.confirm.ambiguity`) against the map points
    drawn at most :attr:`Doubt.trust` uncertain (``map_sds[:, 0]``): where they put the robot
    when they fit clearly better elsewhere (the caller relocates), else None; when they
    match at the estimate, ``doubt`` falls to the farther of the match's own offset and the
    farthest pose explaining them as well, as a ``sigmas`` bound. Too few trusted points,
    or no match: the doubt stays.

    >>> room = np.array([[0.8, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.6, 0.6, 61)])
    >>> d = Doubt(sd=0.15)
    >>> trusted_check(d, room, np.zeros((len(room), 2)), room, Pose(0.0, 0.0, 0.0)), d.sd < 0.01
    (None, True)
    """
    keep = np.asarray(map_sds)[:, 0] <= doubt.trust
    if int(keep.sum()) < min_points:
        return None
    ref = ReferenceScan(np.asarray(map_points)[keep])
    amb = ambiguity(ref, points, pose, min_points=min_points, sd=sd, correlation=correlation)
    if amb.better is not None:
        return amb.better
    if not amb.matched:
        return None
    here = match_scans(ref, points, pose, gate=None, min_points=min_points)
    off = math.hypot(here.pose.x - pose.x, here.pose.y - pose.y)
    doubt.confirmed(max(off, amb.distance) / sigmas)
    return None
