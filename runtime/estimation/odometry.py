"""Scan odometry: dead reckoning corrected by matching each revolution against a local map.

:class:`ScanOdometry` keeps the robot's pose in the supervisor's frame. Between scans it
dead-reckons (from the wheel speeds commanded, or from the backend's own odometry). For
each new revolution it

1. looks up the estimate at the revolution's timestamp (a short history is kept, so a
   scan read a tick late is matched where it was taken) and, when the frame says when
   each point was measured, *de-skews* the revolution with the estimated motion;
2. matches it (:func:`~clomp.runtime.estimation.icp.match_scans`, point-to-line ICP) against
   the *local map* — the points of the revolutions matched so far, in the supervisor's
   frame on a 1 cm grid, within ``map_radius`` of the robot — with the dead-reckoned pose
   as the prior. A match that disagrees wildly with the prior is rejected (gating), and
   directions the scene leaves unobservable (one straight wall, a single face) keep the
   prior's value;
3. fuses the match with the prediction in a small Kalman filter
   (:class:`~clomp.runtime.estimation.ekf.OdometryFilter`: the pose and the odometry's
   systematic errors, learnt from the matches), each direction weighted by how well the
   scene pins it down, and carries the correction through the kept history to now;
4. adds the matched revolution to the map (a face seen from a new side joins the faces
   seen before, so the estimate stays tied to the first scan instead of drifting from
   scan to scan), unless it sees past the surfaces the map holds
   (:func:`~clomp.runtime.estimation.seethrough.see_through_along`: the robot is not where the
   estimate puts it). A revolution that matches nothing the map holds re-seeds it.

When nothing matches, the estimate stays dead reckoning; the record says why.

>>> import numpy as np
>>> from clomp.formal.model import Pose
>>> from clomp.runtime.devices.frame import ScanFrame
>>> room = np.array([[1.0, y] for y in np.linspace(-0.6, 0.6, 61)] + [[x, 0.6] for x in np.linspace(-0.5, 1.0, 76)])
>>> odo = ScanOdometry(wheel_base=0.15)
>>> odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
>>> odo.update(ScanFrame(room, 0.0)).source          # the first scan seeds the map
'map'
>>> for k in range(1, 11):
...     odo.advance(k / 10, (0.1, 0.1))                 # dead reckoning believes 0.1 m ...
>>> r = odo.update(ScanFrame(room - [0.08, 0.0], 1.0))  # ... the walls say 0.08 m
>>> r.ok, 0.08 < odo.pose.x < 0.1                      # fused, weighted by their uncertainty
(True, True)
"""

from __future__ import annotations

import dataclasses
import math
from collections import deque
from dataclasses import dataclass

import numpy as np
from scipy.spatial import cKDTree

from clomp.formal.geometry import relative, wheel_twist, wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.estimation.confirm import Ambiguity, ambiguity
from clomp.runtime.estimation.doubt import Doubt, trusted_check
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.evidence import Evidence, evidence_sd, match_evidence, start_evidence
from clomp.runtime.estimation.faces import FaceCompass
from clomp.runtime.estimation.fusion import fuse_revolutions, range_spread
from clomp.runtime.estimation._history import PoseHistory, deskew
from clomp.runtime.estimation._icp_core import warm_up
from clomp.runtime.estimation._localmap import LocalMap
from clomp.runtime.estimation.icp import ReferenceScan, ScanMatch, match_scans
from clomp.runtime.estimation.prior import OdometryPrior
from clomp.runtime.estimation.relocalise import KickMemory, Relocalisation
from clomp.runtime.estimation.reported import OdometryCovariance, step_noise_floor
from clomp.runtime.estimation.standing import StandingSeed
from clomp.runtime.estimation.vouch import start_ambiguity

__all__ = ["ScanOdometry", "FeedbackRecord", "deskew"]


@dataclass(frozen=True)
class FeedbackRecord:
    """What one revolution did to the estimate.

    ``source``: ``"map"`` when the scan was matched against the local map, or
    ``"dead-reckoning"`` when no match was accepted (``reason`` says why). ``correction``:
    (dx, dy, dtheta) applied to the estimate at the scan's time (supervisor frame).
    ``unobservable``: directions the scene left to dead reckoning.
    """

    time: float
    ok: bool
    source: str
    reason: str
    correction: tuple[float, float, float]
    unobservable: tuple[str, ...]
    map_updated: bool


class ScanOdometry(LocalMap, KickMemory, StandingSeed, PoseHistory):
    """The pose estimate (supervisor frame) from dead reckoning and scan matching.

    ``map_radius`` (m): how much of the map around the robot is kept; ``map_resolution``
    (m): its grid; ``new_surface`` (m): a matched point this far from every map point is
    a surface seen for the first time and joins the map; ``min_overlap``: a revolution
    that failed to match with less than this share of its points on the map re-seeds the
    map. ``gate``: the largest disagreement (m, rad) between a match and the prediction
    ever accepted; the gate in force is 3 cm and 0.05 rad plus three standard deviations
    of the filter's pose, up to ``gate`` (and the filter rejects a match inconsistent with
    its covariance). ``min_points``: the fewest points a revolution needs to seed the map
    or be matched (a small box at 0.6 m shows 10–30); ``min_points_unstamped``: the same
    for a revolution without per-point times, which cannot be de-skewed (it is matched
    only where the scene is rich, and never while turning). ``match_sd`` (m): the least residual
    a match's covariance is computed with; ``correlation``: how many neighbouring points
    count as one independent measurement (adjacent rays see the same map errors);
    ``floor_factor``: no match is believed closer than this share of its residual (m; the
    heading: per 0.5 m of lever), however many points it has. ``seed_revolutions``: while
    the robot has not moved since :meth:`reset`, the seed is the last this many
    revolutions fused (median range per bearing): the start pose fixes the frame, so the
    map's first surfaces are the best known. The same still revolutions measure the LiDAR's
    range noise (:func:`~clomp.runtime.estimation.fusion.range_spread`, :attr:`range_sd`): a match's
    residual is believed no smaller than ``noise_factor`` times it (a scan point and the map
    point it meets each carry that noise). The residual a match reports is measured only
    over the points it paired within a few centimetres and so understates a noisy sensor:
    at 2.5 cm of range noise it read about 1 cm, the filter believed each match to a
    fraction of a degree while the estimate drifted 5-13° from the truth, and scan feedback
    reached the goal of the ``slalom`` layouts less often than dead reckoning alone (1 of
    10 against 7 of 10 at seed 0, every other noise term at ``paper``). ``still_after`` (s):
    how long after the wheels were commanded to stop the body is taken to stand (the
    latency and the deceleration end within it), so that a gyro's reading is its offset.
    ``relocalise_after``: well-matched revolutions in a row, rejected as too far from the
    prediction and agreeing with one another within ``agree`` (m, rad), after which the
    filter's uncertainty is raised by their disagreement so that the next is taken (0, the
    default: never. With 2, the hardware stack's overtaking run in simulated time ended
    0.21 m from the goal instead of 0.06: the matches it then took were wrong ones). How far
    the estimate may be off, all told, is :meth:`position_sd`, which counts such a
    disagreement while it lasts. ``prior``: what it is told of the drive
    (:class:`~clomp.runtime.estimation.prior.OdometryPrior`: the filter's calibration prior,
    and how late the body follows a command; default the worst case, told nothing).
    """

    evidence: Evidence | None
    """What the last match observing every direction vouches for by itself (:meth:`vouched_sd`)."""
    evidence_share = 0.5
    """A match's surfaces vouch only when drawn at most this share as uncertain as the estimate is now."""

    def __init__(
        self,
        wheel_base: float,
        *,
        map_radius: float = 2.5,
        map_resolution: float = 0.01,
        new_surface: float = 0.03,
        min_overlap: float = 0.1,
        gate: tuple[float, float] = (0.2, 0.35),
        history_s: float = 3.0,
        min_points: int = 10,
        min_points_unstamped: int = 40,
        match_sd: float = 0.01,
        correlation: float = 4.0,
        floor_factor: float = 0.75,
        seed_revolutions: int = 10,
        noise_factor: float = math.sqrt(2.0),
        compass: bool = True,
        still_after: float = 0.5,
        relocalise_after: int = 0,
        agree: tuple[float, float] = (0.05, 0.1),
        admit_after: int = 0,
        prior: OdometryPrior | None = None,
    ) -> None:
        if not (math.isfinite(wheel_base) and wheel_base > 0):
            raise ValueError(f"wheel_base must be positive, got {wheel_base!r}")
        self.wheel_base = float(wheel_base)
        self.map_radius = map_radius
        self.map_resolution = map_resolution
        self.new_surface = new_surface
        self.min_overlap = min_overlap
        self.gate = gate
        self.history_s = history_s
        self.min_points = int(min_points)
        self.min_points_unstamped = int(min_points_unstamped)
        self.match_sd = float(match_sd)
        self.correlation = float(correlation)
        self.floor_factor = float(floor_factor)
        self.seed_revolutions = max(1, int(seed_revolutions))
        self.noise_factor = float(noise_factor)
        self.range_sd: float | None = None  # m, measured from the still revolutions of the seed
        self.prior = prior or OdometryPrior.worst()
        self.filter = OdometryFilter(self.wheel_base, **self.prior.filter_kwargs())
        self._commands: deque[tuple[float, float, float]] = deque()  # (since, v, w) as commanded, for ``prior.delay``
        self.pose = Pose(0.0, 0.0, 0.0)
        self._t = 0.0
        self._twist = (0.0, 0.0)
        self._history: deque[tuple[float, Pose]] = deque()
        self._map: ReferenceScan | None = None
        self._map_points: np.ndarray | None = None
        self._map_tree: cKDTree | None = None  # of _map_points, built when first asked after a change
        self._map_sds: np.ndarray | None = None  # per map point: (m, rad) how wrong its drawing estimate was; the bearing it was seen along
        self._odo: Pose | None = None
        self._rot: float | None = None  # the gyro's reading at the last advance
        self._still_since: float | None = 0.0  # since when the wheels are commanded still
        self.still_after = float(still_after)
        self.relocalise_after = int(relocalise_after)
        self.agree = agree
        self.admit_after = int(admit_after)
        self.records: list[FeedbackRecord] = []
        self.last_points = np.zeros((0, 2))
        self._moved_since = 0.0  # m (or wheel-base radians) driven since the last accepted match
        self._last_stamp: float | None = None
        self._seed: list[np.ndarray] | None = []
        self._seed_pose = self.pose
        self.compass: FaceCompass | None = FaceCompass() if compass else None
        self._honesty_reset()
        warm_up()  # the compiled matcher is ready before the robot moves

    # -- dead reckoning -------------------------------------------------------------------------
    def reset(self, pose: Pose, t: float) -> None:
        """Start at ``pose`` at time ``t``; forget the map."""
        self.pose, self._t = pose, float(t)
        self.filter.reset(pose)
        self._history = deque([(self._t, pose)])
        self._commands = deque([(self._t, 0.0, 0.0)])
        self._map = None
        self._map_points = self._map_tree = self._map_sds = None
        self._odo = None
        self._odo_cov: np.ndarray | None = None  # the odometry's pose covariance at _odo, when reported
        self._rot = None
        self._still_since = self._t
        self._moved_since = 0.0
        self._last_stamp = None
        self._seed = []
        self._seed_pose = pose
        self._honesty_reset()
        if self.compass is not None:
            self.compass.reset()

    def advance(self, t: float, wheels: tuple[float, float], odometry: Pose | None = None,
                rotation: float | None = None, covariance: OdometryCovariance | None = None) -> None:
        """Dead-reckon to time ``t``: from the backend's ``odometry`` when given (its change
        since the last call), else from the ``wheels`` (m/s) commanded since the last call;
        ``rotation`` (rad): the heading turned since start-up by the backend's gyro
        (:class:`~clomp.runtime.interface.TurnSensing`), which then gives the heading. Once the wheels
        have been commanded still for ``still_after`` s (and the odometry, when given, does
        not move), the gyro's reading measures its offset instead (:meth:`OdometryFilter.zero_rate`).
        ``covariance``: the odometry's own (pose, twist) covariance, when the backend reports one
        (:class:`~clomp.runtime.interface.OdometryUncertainty`): the step's noise is then no
        smaller than it (:func:`~clomp.runtime.estimation.reported.step_noise_floor`)."""
        dt = float(t) - self._t
        turned = None
        if rotation is not None:
            if self._rot is not None and math.isfinite(rotation):
                turned = float(rotation) - self._rot
            self._rot = float(rotation) if math.isfinite(rotation) else None
        v, w = wheel_twist(wheels[0], wheels[1], self.wheel_base)
        if v != 0.0 or w != 0.0:
            self._still_since = None
        elif self._still_since is None:
            self._still_since = self._t
        still = dt > 0 and turned is not None and self._still_since is not None \
            and self._t - self._still_since >= self.still_after
        if odometry is not None:
            step = relative(self._odo, odometry) if self._odo is not None else None
            if still and (step is None or math.hypot(step.x, step.y) + abs(step.theta) < 1e-9):
                self.filter.zero_rate(turned, dt)  # type: ignore[arg-type]  # standing: the gyro reads its offset
            elif step is not None and dt > 0:
                floor = None if covariance is None or self._odo is None else \
                    step_noise_floor(self._odo_cov, covariance[0], covariance[1], self._odo.theta, dt)
                self.filter.predict(step.x / dt, step.theta / dt, dt, turned, floor)
                self._moved_since += math.hypot(step.x, step.y) + abs(step.theta) * self.wheel_base
                self._odometer += math.hypot(step.x, step.y) + abs(step.theta) * self.wheel_base
            self._odo = odometry
            self._odo_cov = None if covariance is None else covariance[0]
            self._twist = (v, w)
        else:
            if self.prior.delay > 0:  # the body follows the commands late: dead-reckon on them as it does
                v, w = self._delayed(t, v, w)
            self._twist = (v, w)
            if still:
                self.filter.zero_rate(turned, dt)  # type: ignore[arg-type]
            elif dt > 0 and (v != 0.0 or w != 0.0 or turned is not None):
                self.filter.predict(v, w, dt, turned)
                self._moved_since += (abs(v) + abs(w) * self.wheel_base) * dt
                self._odometer += (abs(v) + abs(w) * self.wheel_base) * dt
        self.pose = self.filter.pose
        if dt > 0:
            self._t = float(t)
            self._history.append((self._t, self.pose))
            while len(self._history) > 2 and self._history[1][0] < self._t - self.history_s:
                self._history.popleft()

    # -- scans ------------------------------------------------------------------------------------
    def update(self, frame: ScanFrame, twist: tuple[float, float] | None = None) -> FeedbackRecord:
        """Correct the estimate with one revolution; ``twist`` (v, w) during it for de-skewing
        (default: the one last dead-reckoned)."""
        v, w = self._twist if twist is None else twist
        raw = np.asarray(frame.points, dtype=float).reshape(-1, 2)
        if twist is None and self._rot is not None and frame.point_times is not None and len(raw):
            points = self._deskew_along(raw, np.asarray(frame.point_times, dtype=float), frame.timestamp)
        else:
            points = deskew(raw, frame.point_times, v, w)
        self.last_points = points
        # a revolution without per-point times was taken over the period before its stamp:
        # on average half a period earlier (taken as that)
        stamp = frame.timestamp
        period = min(max(stamp - self._last_stamp, 0.0), 0.3) if self._last_stamp is not None else 0.0
        self._last_stamp = stamp
        at = self.pose_at(stamp - period / 2 if frame.point_times is None else stamp)
        # without per-point times a revolution taken while turning is smeared by the turn;
        # one taken while a kick slid the body is not matched either (KickMemory.in_slide)
        smeared = frame.point_times is None and abs(w) > 1e-3 and self._map is not None
        if smeared or self.in_slide(stamp):
            why = "taken while turning, without point times: smeared" if smeared else "taken in a kick's slide: not matched"
            rec = FeedbackRecord(stamp, False, "dead-reckoning", why, (0.0, 0.0, 0.0), ("x", "y", "heading") if smeared else (), False)
            self.records.append(rec)
            return rec
        if self._seed is not None and (self._moved_since > 0.0 or self._twist != (0.0, 0.0)):
            if self.compass is not None and self._seed:  # the faces seen standing fix the compass
                self.compass.seed(self._seed[-self.seed_revolutions:], self._seed_pose, self.range_sd)
            self._seed = None  # the robot moved: the seed is fixed
        if self._seed is not None and len(points):
            # still at the start pose, which fixes the frame: each revolution seen from there
            # joins the seed, fused (median range per bearing), so the map's surfaces are
            # less noisy than one revolution's and a small face's direction better known
            self._check_standing(points, stamp)  # one showing it was moved restarts it
            self._seed.append(points)
            self._seed_pose = at
            n = min(len(self._seed), self.seed_revolutions)
            spread = range_spread(self._seed[-n:])
            if spread is not None:
                self.range_sd = spread
            seeded = self._add(fuse_revolutions(self._seed[-n:]), at, reseed=True)
            reason = (f"the map's seed: {n} still revolution{'s' if n > 1 else ''} fused" if seeded
                      else f"{len(points)} points: too few to seed the map")
            rec = FeedbackRecord(frame.timestamp, seeded, "map" if seeded else "dead-reckoning", reason, (0.0, 0.0, 0.0),
                                 () if seeded else ("x", "y", "heading"), seeded)
            self.records.append(rec)
            return rec
        if self._map is None:
            seeded = self._add(points, at, reseed=True)
            reason = "first revolution: the map's seed" if seeded else f"{len(points)} points: too few to seed the map"
            rec = FeedbackRecord(frame.timestamp, seeded, "map" if seeded else "dead-reckoning", reason, (0.0, 0.0, 0.0),
                                 () if seeded else ("x", "y", "heading"), seeded)
            self.records.append(rec)
            return rec
        if self.kick_pending(stamp):  # after a shock: the map drawn before it, searched widely
            jumped = self.relocalise_after_kick(points, at)
            res = self.last_relocalisation
            if res is not None and res.pose is not None:
                now = self.pose_at(stamp)
                rec = FeedbackRecord(stamp, True, "map", f"{'re-localised' if jumped else 'confirmed'} after a kick: {res.why}",
                                     (now.x - at.x, now.y - at.y, wrap_angle(now.theta - at.theta)), (), True)
                self.records.append(rec)
                return rec
        # a match may move the estimate only as far as the filter's uncertainty explains
        # (3 sigma, at least 3 cm and 0.05 rad, at most ``gate``)
        f = self.filter
        gate = (min(self.gate[0], 0.03 + 3 * f.sigma_xy), min(self.gate[1], 0.05 + 3 * f.sigma_theta))
        least = self.min_points if frame.point_times is not None else self.min_points_unstamped
        match = match_scans(self._map, points, at, gate=None, min_points=least)
        match = self._observed(self._gated(match, at, gate), points)
        corrected = at
        reason = match.reason
        ok = match.ok
        if ok:
            # the match measures the pose in the directions the scene observes: fused with
            # the prediction by the filter, whose calibration learns from it
            z = match.pose
            sd2 = max(match.rmse, self.match_sd, self.noise_factor * (self.range_sd or 0.0)) ** 2 * self.correlation
            info = np.asarray(match.information_matrix) / sd2
            before = f.pose
            # the map's own errors do not average out: no match is believed closer than
            # about its residual (1.5 cm and 1.7° under 2 cm of residual, 4 mm under 5 mm)
            fl = self.floor_factor * max(match.rmse, self.match_sd / 2)
            self.last_map_sd = self._map_sd(points, z)
            ok, d2 = f.correct((z.x - at.x, z.y - at.y, wrap_angle(z.theta - at.theta)), info,
                               floor=(fl, fl, fl / 0.5), learn=self._moved_since > 0.0, map_sd=self.last_map_sd)
            if ok:
                corrected = self._carry(before, at, frame.timestamp)
                self._moved_since = 0.0
                self._evidence(z, info, fl, points, at)
                self.rejected_in_a_row = 0
            else:
                reason = f"{match.reason}, but inconsistent with the prediction (d² {d2:.0f}): rejected"
                self._disagreed(z, at)
        match = dataclasses.replace(match, ok=ok)
        # the map grows by what a matched revolution saw; a revolution that matched nothing
        # because the map does not cover what it sees re-seeds it (dead-reckoned)
        lost = not match.ok and match.inlier_fraction < self.min_overlap and "too few points" not in match.reason
        if lost:
            # nothing the map holds was seen: the estimate may be off by as much as the
            # matcher reaches (a push, a slip), and the map it re-seeds carries that
            self.reseeds += 1
            self.evidence = None
            self.filter.honest[:2, :2] += np.eye(2) * self.gate[0] ** 2
            self.filter.honest[2, 2] += self.gate[1] ** 2
            self.doubt.raise_to(self.gate[0], stamp, "re-seeded")
        bad, moved = self.doubt.judge(self._map_points, points, corrected, stamp) \
            if self._map_points is not None else (False, False)
        if moved:  # it stands elsewhere than the estimate: the gain opened as after a kick
            self.evidence = None
            self.filter.P[:2, :2] += np.eye(2) * self.doubt.kick_sd ** 2
        added = self._add(points, corrected, reseed=lost) if (match.ok or lost) and not bad else False
        if self.compass is not None and self.compass.seeded:
            corrected, reason = self._steer(points, corrected, frame.timestamp, reason)
        d = (corrected.x - at.x, corrected.y - at.y, wrap_angle(corrected.theta - at.theta))
        rec = FeedbackRecord(frame.timestamp, match.ok, "map" if match.ok else "dead-reckoning", reason, d,
                             match.unobservable, added)
        self.records.append(rec)
        return rec

    # -- honesty: what the covariance alone does not say --------------------------------------------
    def _honesty_reset(self) -> None:
        self.disagreement: tuple[float, float, float] | None = None  # the last well-matched revolution rejected
        self.rejected_in_a_row = 0  # well-matched revolutions in a row that disagreed with the prediction
        self.relocalised = 0  # times the estimate gave way to such a run of matches
        self.reseeds = 0  # times a revolution matching nothing re-seeded the map
        self.last_map_sd = (0.0, 0.0)  # how wrong the surfaces the last match met may be (m, rad)
        self.doubt = Doubt()  # the floor under position_sd that only a wider search lowers
        self._before_doubt: tuple[np.ndarray, np.ndarray] | None = None  # the map when a shock was felt
        self._kicked_at = 0.0  # when (odometry time)
        self._slide_span = None  # a kick's slide (KickMemory.in_slide)
        self.last_relocalisation: Relocalisation | None = None  # the last search against it
        self.evidence = None  # the last match observing every direction (vouched_sd)
        self._odometer = 0.0  # m driven (turns at the wheel base) since reset: what the evidence ages by

    def shock(self, peak: float) -> None:
        """The IMU's accelerometer peaked at ``peak`` m/s² (:class:`~clomp.runtime.estimation.doubt.Doubt`):
        a shock opens the filter's position uncertainty by how far it may have moved the body
        (so the next matches may pull the estimate there) and keeps it as a floor."""
        sd, _shocked = self.doubt.shock(peak, self._t)
        if sd > 0:
            self.evidence = None  # the body may have moved since the last match showed it
            self.remember_before_doubt()  # what was drawn before it: what re-localises after it
            self.felt(sd)
            self.filter.widen_position(sd)

    def confirm_doubt(self, points: np.ndarray) -> Pose | None:
        """In doubt (:attr:`doubt`), a revolution ``points`` seen standing here is searched
        for widely against the surfaces drawn before the doubt
        (:func:`~clomp.runtime.estimation.doubt.trusted_check`): the pose they put the robot
        at when clearly elsewhere (to relocate to), else None, the doubt lowered to how far
        from the estimate they leave the position."""
        if self.doubt.sd <= 0 or self._map_points is None or self._map_sds is None:
            return None
        sd = max(2 * self.match_sd, self.noise_factor * (self.range_sd or 0.0))
        return trusted_check(self.doubt, self._map_points, self._map_sds, points, self.pose, min_points=self.min_points,
                             sd=sd, correlation=self.correlation)

    def _gated(self, match: ScanMatch, prior: Pose, gate: tuple[float, float]) -> ScanMatch:
        """The matcher's gate, applied here so that a well-matched revolution it rejects is kept
        (:meth:`_disagreed`): the same test and reason as :func:`match_scans` with ``gate``."""
        if not match.ok:
            return match
        dt = math.hypot(match.pose.x - prior.x, match.pose.y - prior.y)
        da = abs(wrap_angle(match.pose.theta - prior.theta))
        if dt <= gate[0] and da <= gate[1]:
            return match
        self._disagreed(match.pose, prior)
        return dataclasses.replace(match, pose=prior, ok=False, information_matrix=((0.0, 0.0, 0.0),) * 3,
                                   reason=f"disagrees with the prior by {dt * 100:.0f} cm, {math.degrees(da):.0f}°: rejected")

    def _disagreed(self, z: Pose, at: Pose) -> None:
        """A revolution that matched the map well was rejected as too far from the prediction
        ``at`` (it says ``z``). Several in a row that agree with one another mean the robot was
        moved or its model is wrong: the filter's uncertainty is raised by the disagreement,
        so that the next such match is taken (the estimate believes the evidence), and until
        then the disagreement counts in :meth:`position_sd`."""
        d = (z.x - at.x, z.y - at.y, wrap_angle(z.theta - at.theta))
        prev = self.disagreement
        same = prev is not None and self.rejected_in_a_row > 0 and math.hypot(d[0] - prev[0], d[1] - prev[1]) \
            <= self.agree[0] and abs(wrap_angle(d[2] - prev[2])) <= self.agree[1]
        self.rejected_in_a_row = self.rejected_in_a_row + 1 if same else 1
        self.disagreement = d
        self.evidence = None  # a well-matched revolution says otherwise: the last one's may be stale
        if self.rejected_in_a_row >= 3:  # shown three times: the estimate may be that far off
            self.doubt.raise_to(math.hypot(d[0], d[1]), self._t, "disagreed")
        if self.admit_after and self.rejected_in_a_row >= self.admit_after:
            self.filter.admit(d)  # shown off by this much: what it can vouch for remembers it
        if self.relocalise_after and self.rejected_in_a_row >= self.relocalise_after:
            self.filter.inflate(d[:2], math.hypot(d[2], self.agree[1]))
            self.filter.P[:2, :2] += np.eye(2) * self.agree[0] ** 2
            self.relocalised += 1
            self.rejected_in_a_row = 0

    @property
    def start_pose(self) -> Pose:
        """Where the robot stood when it seeded the map: the one pose known exactly."""
        return self._seed_pose

    def start_ambiguity(self, points: np.ndarray) -> float:
        """How far from the estimate a pose explains a revolution ``points`` (robot frame) as
        well against the surfaces drawn before any doubt
        (:func:`~clomp.runtime.estimation.vouch.start_ambiguity`, m; 0 when they pin it or
        cannot judge)."""
        if self._map_points is None or self._map_sds is None:
            return 0.0
        sd = max(2 * self.match_sd, self.noise_factor * (self.range_sd or 0.0))
        return start_ambiguity(self._map_points, self._map_sds, points, self.pose, trust=self.doubt.trust, sd=sd,
                               correlation=self.correlation, min_points=self.min_points)

    def ambiguity(self, points: np.ndarray) -> Ambiguity:
        """How far from the estimate a revolution ``points`` seen standing here (robot frame)
        matches the map as well (:func:`~clomp.runtime.estimation.confirm.ambiguity`); not
        ``matched`` before there is a map."""
        if self._map is None:
            return Ambiguity(math.inf, 0.0, 0, False)
        sd = max(2 * self.match_sd, self.noise_factor * (self.range_sd or 0.0))  # the map's own errors too
        return ambiguity(self._map, points, self.pose, min_points=self.min_points, sd=sd, correlation=self.correlation)

    def relocate(self, pose: Pose) -> None:
        """The revolutions say the robot is at ``pose``, not where the estimate puts it (a wider
        search found it, :meth:`ambiguity`): the estimate moves there and its uncertainty,
        the gain's and the vouching one, grows by the jump (and the jump is admitted)."""
        here = self.pose
        d = (pose.x - here.x, pose.y - here.y, wrap_angle(pose.theta - here.theta))
        self.filter.shift(pose)
        self.filter.inflate(d[:2], abs(d[2]))
        self.filter.admit(d)
        self.pose = pose
        self._history = deque([(self._t, pose)])
        self.relocalised += 1

    def position_sd(self) -> float:
        """How well the position is known (m, one standard deviation, the larger axis): the
        filter's :attr:`~clomp.runtime.estimation.ekf.OdometryFilter.honest` covariance, which
        counts that the map's surfaces were drawn from the estimate, and the disagreement of
        well-matched revolutions rejected just now (:attr:`disagreement`).

        >>> odo = ScanOdometry(wheel_base=0.15)
        >>> odo.position_sd() < 1e-4
        True
        """
        var = max(self.vouched_sd() ** 2, self.doubt.sd ** 2)
        if self.rejected_in_a_row > 0 and self.disagreement is not None:
            var += self.disagreement[0] ** 2 + self.disagreement[1] ** 2
        return math.sqrt(var)

    def _evidence(self, z: Pose, info: np.ndarray, floor: float, points: np.ndarray, at: Pose) -> None:
        """An accepted match at ``z`` (``info``: its information, ``floor``: its shared floor) of the
        revolution ``points`` seen from ``at``: what it vouches for by itself (:attr:`evidence`,
        :func:`~clomp.runtime.estimation.evidence.match_evidence`) when it was seen standing,
        observes every direction and the robot has a heading sensor; and the same revolution
        matched against the start's surfaces alone (:func:`~clomp.runtime.estimation.evidence.start_evidence`),
        the tighter of the two kept."""
        if self._twist != (0.0, 0.0):
            # only a revolution seen standing (driving, corridor 1/4 with the gyro claimed on
            # arrival truly 0.093 m off, the estimate 0.081 m off and its bound 0.083 m, before the
            # standing revolutions saw surfaces stand before the map's)
            return
        # without a heading sensor the surfaces drawn on the way drift with the heading further than
        # their drawn figure says (harsh, no gyro: slalom 0/3 truly 0.15 m off, the match's own
        # evidence 0.06 m, honest 0.09 m): only the start's surfaces vouch for it
        # and only from surfaces known clearly better than the estimate now (their mean drawing
        # error at most ``evidence_share`` of honest's): surfaces drawn about as uncertain as the
        # estimate inherit whatever honest missed when drawing them, and their evidence only
        # trades honest's accounting for its own (corridor 1/4 with the gyro: 7 % below honest,
        # a claim truly 0.093 m off with the estimate's error at 98 % of its bound)
        drawn = self.last_map_mean[0] <= self.evidence_share * self.filter.honest_sigma_xy
        got = match_evidence(z, info, (floor, floor, floor / 0.5), self.last_map_mean, self._odometer) \
            if self._rot is not None and drawn else None
        if self._map_points is not None and self._map_sds is not None:
            sd = max(self.match_sd, self.noise_factor * (self.range_sd or 0.0))
            start = start_evidence(self._map_points, self._map_sds, points, at, self._odometer, sd=sd,
                                   correlation=self.correlation, floor_factor=self.floor_factor, min_points=self.min_points)
            if start is not None and (got is None or evidence_sd(start, self.pose, self._odometer)
                                      < evidence_sd(got, self.pose, self._odometer)):
                got = start
        if got is not None:
            self.evidence = dataclasses.replace(got, revolution=len(self.records))

    def vouched_sd(self) -> float:
        """The filter's part of :meth:`position_sd` (m): its :attr:`~clomp.runtime.estimation.ekf.OdometryFilter.honest`
        figure, or what the last match observing every direction vouches for by itself when
        that is less (:mod:`~clomp.runtime.estimation.evidence`: its own error, the estimate's
        distance from it and what was driven since).

        >>> odo = ScanOdometry(wheel_base=0.15)
        >>> odo.vouched_sd() == odo.filter.honest_sigma_xy
        True
        """
        honest = self.filter.honest_sigma_xy
        if self.evidence is None:
            return honest
        return min(honest, evidence_sd(self.evidence, self.pose, self._odometer))

    def _steer(self, points: np.ndarray, at: Pose, stamp: float, reason: str) -> tuple[Pose, str]:
        """The compass (:class:`~clomp.runtime.estimation.faces.FaceCompass`): the heading measured
        on the faces this revolution sees, fused; then the faces it shows for the first time
        may join. Returns the estimate at ``stamp`` after it, and the record's reason."""
        assert self.compass is not None
        got = self.compass.measure(points, at, self.range_sd, self.filter.sigma_theta)
        if got is not None:
            offset, sd, n = got
            before = self.filter.pose
            ok, _d2 = self.filter.correct_heading(offset, sd)
            if ok:
                at = self._carry(before, at, stamp)
            reason += (f"; compass: {n} face{'s' if n > 1 else ''}, {math.degrees(offset):+.1f}° "
                       f"(sd {math.degrees(sd):.1f}°){'' if ok else ', rejected'}")
        self.compass.grow(points, at, self.filter.sigma_theta, self.range_sd)
        return at, reason
