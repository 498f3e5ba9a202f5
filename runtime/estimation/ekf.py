"""A small extended Kalman filter: dead reckoning that calibrates itself on scan matches.

Wheel odometry errs in two ways: at random (each tick's wheel speed, slip) and
*systematically* (one wheel a little larger than the other, a drive that loses a few per
cent on the floor, a heading that creeps while the wheels turn). The systematic part is
what makes dead reckoning drift far — a 3 % wheel mismatch curves a 1 m straight by
10° — and it is the same all run long, so a filter can learn it (odometry
self-calibration, as in Martinelli et al., *Simultaneous localization and odometry self
calibration for mobile robot*, Autonomous Robots 2007).

:class:`OdometryFilter` keeps the state

    ``[x, y, theta, s, k, c, d]``

— the pose (supervisor frame) and four calibration terms of the motion model

    ``v' = v (1 + s)``, ``w' = w (1 + k) + c v + d`` (``d`` only while the wheels turn)

(``s`` the forward scale, ``k`` the turn scale, ``c`` the curvature a straight command
gets from mismatched wheels (rad/m), ``d`` a heading drift (rad/s)), with its covariance.
:meth:`predict` propagates both over a control step with the commanded (or measured)
wheel speeds; its random part is ``wheel_noise`` of each wheel's distance.

A robot with a rate gyro gives :meth:`predict` the rotation it measured over the step
(``turned``): the heading then follows the gyro, ``theta' = theta + (turned - b dt) (1 + k)``
(gyrodometry: the wheels for distance, the gyro for rotation), ``k`` now the gyro's scale
and ``b`` an eighth state, the gyro's zero-rate offset (rad/s), with ``rate_noise``
(rad/√s) of angle random walk. Standing still, :meth:`zero_rate` measures ``b``: what the
gyro reads then is its offset.
:meth:`correct` takes a scan match as a measurement of the pose *in the directions the
scene observes* (the eigen-directions of the match's information matrix), each with its
variance, and updates the calibration terms through their correlation with the pose:
a robot that matched its straight drive against a wall learns how its wheels curve, and
the next straight — where a small box may leave the heading unobservable — curves less.

Matches are made against a map drawn from the estimate itself, so the map carries the
estimate's errors of when it was drawn; the gain ignores that (it would weaken every
match), but :attr:`OdometryFilter.honest` counts it: a second covariance, propagated with
the same motion and updated with the same gain, whose measurement noise adds the map's
own (``map_sd`` of :meth:`OdometryFilter.correct`). The Joseph form gives the true
covariance of an estimate for whatever gain made it, so ``honest`` is what the estimate can
vouch for (issue #36: ``P`` at the goal said 3-5 mm on runs truly 0.1-0.3 m off). The
Joseph form takes the map's error as independent of the estimate's, but the map was drawn
by the estimate: an estimate matched to it carries its error, so in the directions a match
observes ``honest`` is not let below the map's own (without that floor each match shrank
it, the surfaces drawn next carried the shrunk figure, and at ``harsh`` without the gyro a
heading drifting 10-14° kept an honest 1.3°: slalom 0/3 claimed the goal 0.24 m off).

A match that leaves a direction with a share of heading unobserved (rotation about one
small box, which looks like a step sideways) moves the pose only along the directions it
observes; the others keep dead reckoning (the gain's share in them, which the pose's
correlations would give, is dropped — a small box ahead observes the distance to it, and
must not turn the heading by the prior's uncertainty about it). A pure translation left
unobserved (a corridor's axis) keeps the full gain.

The calibration is learnt only from a match that pins the heading by itself
(:meth:`OdometryFilter.heading_sd`, at most ``learn_heading_sd``: a long wall, a
corridor, faces far apart). A match that leaves rotation to the position (one small box:
turning about it looks like stepping sideways) corrects the pose but teaches nothing:
the map it is matched against was drawn from the estimate itself, so its errors would be
learnt as wheels that curve, and the learnt curvature would turn every later straight
the wrong way (at the ``paper`` noise it taught -0.25 to -0.44 rad/m to wheels of about
±0.05 and left runs 0.1-0.3 m from the goal they believed they had reached).

With a gyro the turn scale ``k`` is the gyro's gain, and a turn shows it: once the heading has
turned ``turn_learn_after`` (rad) since it was last pinned sharply, a match pinning the heading
within ``turn_learn_sd`` teaches ``k`` alone (issue #36: at ``harsh`` among posts the matches
pinned it to 0.9-1.6°, never 0.5°, and a gain 8.9 % high turned the heading 10° off in one turn
on the spot). What the gain may have made of the rotation since the last sharp pin is admitted
in :attr:`honest`, whatever the matches say (:meth:`OdometryFilter._floor_turn`): they are made
against surfaces the turning estimate drew, and show part of its error at best.

>>> import math
>>> f = OdometryFilter(wheel_base=0.15, match_floor=(0.0, 0.0, 0.0))
>>> for _ in range(10):
...     f.predict(0.1, 0.0, 0.1)                 # 1 s straight at 0.1 m/s
>>> round(f.pose.x, 3), f.sigma_xy > 0
(0.1, True)
>>> g = OdometryFilter(wheel_base=0.15, match_floor=(0.0, 0.0, 0.0)); g.P, g.x = f.P.copy(), f.x.copy()
>>> ok, d2 = f.correct((0.0, 0.003, 0.05), [[1e6, 0, 0], [0, 1e6, 0], [0, 0, 1e6]])
>>> ok, f.calibration[2] > 0                      # it curved left, the heading says so: learnt
(True, True)
>>> ok, d2 = g.correct((0.0, 0.003, 0.05), [[1e6, 0, 0], [0, 1e6, 0], [0, 0, 0]])
>>> ok, round(g.pose.y, 3), g.calibration         # the position alone: corrected, nothing learnt
(True, 0.003, (0.0, 0.0, 0.0, 0.0))
>>> h = OdometryFilter(wheel_base=0.15)
>>> for _ in range(10):
...     h.predict(0.1, 0.0, 0.1, turned=0.01)      # the gyro: 0.1 rad turned in 1 s
>>> round(h.pose.theta, 3)
0.1
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from clomp.formal.geometry import midpoint_step, wrap_angle
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import eigh, eigvalsh
from clomp.runtime.estimation.reported import psd_max, rotate_covariance

__all__ = ["OdometryFilter"]

_N = 8  # x, y, theta, s, k, c, d, b (the gyro's offset)


class OdometryFilter:
    """Pose and odometry calibration (see the module docstring).

    ``wheel_noise``: relative standard deviation of each wheel's distance per
    :meth:`predict` step (random part). ``calibration_sd``: prior standard deviations of
    (s, k, c, d); ``calibration_walk``: how fast (per √s while moving) they may change.
    ``gate``: the largest squared Mahalanobis distance of a match from the prediction
    that is accepted (per observed direction). ``match_floor``: standard deviations
    (m, m, rad) added to every match's own: the map it is matched against has errors of
    its own that do not average out over revolutions, so no match is believed closer.
    ``learn_heading_sd`` (rad): the calibration learns only from a match whose
    :meth:`heading_sd` is at most this (None: from every match after motion).
    ``hold_unobserved``: a match that leaves a direction unobserved in which the heading
    has a share (over 0.3 of it, state units) moves the pose only along the directions it
    observes (False: the full gain, which moves the unobserved ones too, through their
    correlation with the observed). ``rate_noise`` (rad/√s), ``rate_offset_sd`` (rad/s,
    prior) and ``rate_offset_walk`` (rad/s per √s): the gyro's white noise and offset, when
    :meth:`predict` is given its rotation. ``honest_walk``: (m per √m driven, rad per √m
    driven, rad per √rad turned) added to :attr:`honest` only, never to ``P``: what the
    model does not hold and matches against a map the estimate drew cannot show (0: none).
    ``turn_learn_sd`` (rad; None: never) and ``turn_learn_after`` (rad): with a gyro, the turn
    scale alone is learnt from a match pinning the heading within ``turn_learn_sd`` once the
    heading turned ``turn_learn_after`` since it was last pinned sharply. ``turn_asymmetry``
    (relative): how much the gyro's gain one way may differ from the one gain learnt (half the
    told difference between the two ways), admitted in :attr:`honest` per radian turned.
    ``shared_floor``: :attr:`honest` is not let below a match's floor (``match_floor`` or its
    ``floor``) in the directions it observes: the floor is the error the revolutions share, which
    fusing more of them does not average out (False: only below the map's, as before issue #36's
    bound coverage bench).
    """

    def __init__(
        self,
        wheel_base: float,
        *,
        wheel_noise: float = 0.15,
        calibration_sd: tuple[float, float, float, float] = (0.06, 0.06, 0.3, 0.02),
        calibration_walk: tuple[float, float, float, float] = (0.002, 0.002, 0.01, 0.001),
        gate: float = 16.0,
        match_floor: tuple[float, float, float] = (0.015, 0.015, 0.017),
        learn_heading_sd: float | None = math.radians(0.5),
        hold_unobserved: bool = True,
        rate_noise: float = 0.0025,
        rate_offset_sd: float = 0.05,
        rate_offset_walk: float = 0.0005,
        slip_noise: float = 0.0,
        turn_noise: float = 0.0,
        path_heading_noise: float = 0.0,
        honest_walk: tuple[float, float, float] = (0.0, 0.0, 0.0),
        turn_learn_sd: float | None = math.radians(1.5),
        turn_learn_after: float = 0.5,
        turn_asymmetry: float = 0.0,
        shared_floor: bool = True,
    ) -> None:
        if not (math.isfinite(wheel_base) and wheel_base > 0):
            raise ValueError(f"wheel_base must be positive, got {wheel_base!r}")
        self.wheel_base = float(wheel_base)
        self.wheel_noise = float(wheel_noise)
        self.calibration_sd = tuple(float(v) for v in calibration_sd)
        self.calibration_walk = tuple(float(v) for v in calibration_walk)
        self.gate = float(gate)
        self.learn_heading_sd = None if learn_heading_sd is None else float(learn_heading_sd)
        self.hold_unobserved = bool(hold_unobserved)
        self.rate_noise = float(rate_noise)
        self.rate_offset_sd = float(rate_offset_sd)
        self.rate_offset_walk = float(rate_offset_walk)
        self.slip_noise = float(slip_noise)
        self.turn_noise = float(turn_noise)
        self.path_heading_noise = float(path_heading_noise)
        self.honest_walk = tuple(float(v) for v in honest_walk)
        self.turn_learn_sd = None if turn_learn_sd is None else float(turn_learn_sd)
        self.turn_learn_after = float(turn_learn_after)
        self.turn_asymmetry = float(turn_asymmetry)
        self.shared_floor = bool(shared_floor)
        self.match_floor = np.square(np.asarray(match_floor, dtype=float))
        # no learnt term beyond three prior standard deviations: a wrong association must
        # not teach the filter wheels no robot has
        self.calibration_bound = 3.0 * np.asarray((*self.calibration_sd, self.rate_offset_sd), dtype=float)
        self.x = np.zeros(_N)
        self.P = np.zeros((_N, _N))
        self.reset(Pose(0.0, 0.0, 0.0))

    def reset(self, pose: Pose, keep_calibration: bool = False) -> None:
        """Start at ``pose`` (known exactly); the calibration is forgotten unless kept."""
        cal, pcal = self.x[3:].copy(), self.P[3:, 3:].copy()
        self.x = np.zeros(_N)
        self.x[:3] = (pose.x, pose.y, pose.theta)
        self.P = np.zeros((_N, _N))
        if keep_calibration:
            self.x[3:], self.P[3:, 3:] = cal, pcal
        else:
            self.P[3:, 3:] = np.diag(np.square((*self.calibration_sd, self.rate_offset_sd)))
        self.P[:3, :3] = np.eye(3) * 1e-10
        self.honest = self.P.copy()
        self.turn_unfixed = 0.0  # rad the gyro turned since the heading was last pinned sharply
        self.turn_gain_error = 0.0  # rad: what the gain, as uncertain as it was, may have made of it
        self.turn_rotation = 0.0  # rad turned either way since then (what the asymmetry may make of it)

    @property
    def pose(self) -> Pose:
        """The estimated pose."""
        return Pose(float(self.x[0]), float(self.x[1]), float(self.x[2]))

    @property
    def calibration(self) -> tuple[float, float, float, float]:
        """The estimated (s, k, c, d)."""
        s, k, c, d = (float(v) for v in self.x[3:7])
        return s, k, c, d

    @property
    def rate_offset(self) -> float:
        """The estimated zero-rate offset of the gyro (rad/s; 0 until it is measured)."""
        return float(self.x[7])

    @property
    def sigma_xy(self) -> float:
        """Standard deviation of the position (m, the larger axis)."""
        return float(math.sqrt(max(eigvalsh(self.P[:2, :2])[-1], 0.0)))

    @property
    def honest_sigma_xy(self) -> float:
        """Standard deviation of the position (m, the larger axis) by :attr:`honest`."""
        return float(math.sqrt(max(eigvalsh(self.honest[:2, :2])[-1], 0.0)))

    @property
    def sigma_theta(self) -> float:
        """Standard deviation of the heading (rad)."""
        return float(math.sqrt(max(self.P[2, 2], 0.0)))

    def heading_sd(self, information: Sequence[Sequence[float]] | np.ndarray) -> float:
        """How well a match pins the heading (rad, standard deviation): its information
        ``information`` (3×3, state units) together with what the filter knows of the position,
        the heading's marginal. A long wall or two faces far apart pin it to a fraction of a
        degree; a small box, whose faces leave rotation about it to the position, to degrees.

        >>> f = OdometryFilter(0.15)
        >>> f.P[:2, :2] = np.eye(2) * 0.01**2                            # position known to 1 cm
        >>> round(math.degrees(f.heading_sd(np.diag([1e6, 1e6, 1e6]))), 2)  # heading measured: 0.06°
        0.06
        >>> f.heading_sd(np.diag([1e6, 1e6, 0.0])) == math.inf          # no heading information
        True
        """
        info = np.asarray(information, dtype=float).reshape(3, 3)
        info = (info + info.T) / 2
        try:
            prior = np.linalg.inv(self.P[:2, :2] + np.eye(2) * 1e-12)
        except np.linalg.LinAlgError:  # pragma: no cover - P is positive definite plus the jitter
            prior = np.zeros((2, 2))
        pp = info[:2, :2] + prior
        marginal = float(info[2, 2] - info[2, :2] @ np.linalg.solve(pp, info[:2, 2]))
        return math.inf if not marginal > 0 else 1.0 / math.sqrt(marginal)

    def inflate(self, position: Sequence[float], heading: float) -> None:
        """Raise the uncertainty by a disagreement the evidence showed: ``position`` (dx, dy, m)
        and ``heading`` (rad) added to the covariance (and to :attr:`honest`)."""
        d = np.asarray(position, dtype=float).reshape(2)
        for m in (self.P, self.honest):
            m[:2, :2] += np.outer(d, d)
            m[2, 2] += heading**2

    def admit(self, error: Sequence[float]) -> None:
        """The evidence showed the estimate off by ``error`` (dx, dy, dtheta): :attr:`honest`
        holds at least that much along it from now on (what the estimate can vouch for
        never again forgets a disagreement its matches showed; ``P``, the gain's, is left).

        >>> f = OdometryFilter(0.15)
        >>> f.admit((0.1, 0.0, 0.05)); round(f.honest_sigma_xy, 3), round(math.sqrt(f.honest[2, 2]), 3)
        (0.1, 0.05)
        """
        d = np.asarray(error, dtype=float).reshape(3)
        n = float(math.hypot(d[0], d[1]))
        if n > 0:
            u = d[:2] / n
            have = float(u @ self.honest[:2, :2] @ u)
            if have < n * n:
                self.honest[:2, :2] += (n * n - have) * np.outer(u, u)
        self.honest[2, 2] = max(float(self.honest[2, 2]), float(d[2]) ** 2)

    def widen_position(self, sd: float) -> None:
        """The position may be off by ``sd`` (m) more than the filter knew (a kick, a measured
        slide, a move seen standing): both covariances, the gain's and the vouching one, grow
        by ``sd²`` in x and y; a non-finite or non-positive ``sd`` changes nothing.

        >>> f = OdometryFilter(0.15)
        >>> before = f.honest[0, 0]; f.widen_position(0.1); round(float(f.honest[0, 0] - before), 6)
        0.01
        """
        if math.isfinite(sd) and sd > 0:
            for m in (self.P, self.honest):
                m[:2, :2] += np.eye(2) * sd * sd

    def shift(self, pose: Pose) -> None:
        """Move the pose estimate to ``pose`` (an outside correction), keeping the covariance."""
        self.x[:3] = (pose.x, pose.y, pose.theta)

    def predict(self, v: float, w: float, dt: float, turned: float | None = None,
                floor: np.ndarray | None = None) -> None:
        """Propagate over ``dt`` s at the commanded linear speed ``v`` and turn rate ``w``;
        ``turned`` (rad): the rotation a gyro measured over the same ``dt``, which then
        gives the heading instead of the wheels (also standing, when the body may still
        coast). ``floor`` (3×3, x forward, y left, yaw in the robot frame at the step's
        start): the least noise of the step's pose, what a base reported for its own odometry
        (:func:`~clomp.runtime.estimation.reported.step_noise_floor`); the model's noise is
        raised to it where it is smaller (:func:`~clomp.runtime.estimation.reported.psd_max`)."""
        if not dt > 0:
            return
        moving = v != 0.0 or w != 0.0
        if not moving and turned is None and floor is None:
            return
        x, y, th, s, k, c, d, b = self.x
        m = 1.0 if moving else 0.0
        vt = v * (1 + s)
        if turned is None:
            dth = (w * (1 + k) + c * v + d * m) * dt
            dwt = np.array([0.0, 0.0, 0.0, 0.0, w, v, m, 0.0]) * dt  # d(dth)/d(state)
        else:
            # ``b`` is what the gyro reads standing (:meth:`zero_rate` measures it so): the
            # offset comes off the reading before the gain scales it (issue #36: with the
            # offset taken after the gain, a gain learnt at 1.108 left 0.0063 rad/s of a
            # 0.085 rad/s offset uncorrected, the heading 12° off in 37 s; slalom seed 3
            # through the whole stack with --imu claimed the goal 0.153 m off)
            dth = (turned - b * dt) * (1 + k)
            dwt = np.array([0.0, 0.0, 0.0, 0.0, turned - b * dt, 0.0, 0.0, -dt * (1 + k)])
        self.x[:3] = midpoint_step(x, y, th, vt * dt, dth)  # the one integrator: formal.geometry
        thm = th + dth / 2  # the step's heading, for its Jacobian
        cs, sn = math.cos(thm), math.sin(thm)
        f = np.eye(_N)
        f[0, 2], f[1, 2] = -vt * dt * sn, vt * dt * cs
        f[0, 3], f[1, 3] = v * dt * cs, v * dt * sn
        f[0, :] += -vt * dt * sn * dwt / 2
        f[1, :] += vt * dt * cs * dwt / 2
        f[2, :] += dwt
        # random wheel error: each wheel's distance is good to wheel_noise
        bw = self.wheel_base
        left, right = abs(v - w * bw / 2) * dt, abs(v + w * bw / 2) * dt
        var_l, var_r = (self.wheel_noise * left) ** 2, (self.wheel_noise * right) ** 2
        var_d, var_th = (var_l + var_r) / 4, (var_l + var_r) / bw**2
        cov_dth = (var_r - var_l) / (2 * bw)
        if turned is not None:  # the heading is the gyro's: its white noise, not the wheels'
            var_th, cov_dth = self.rate_noise**2 * dt, 0.0
        g = np.array([[cs, 0.0], [sn, 0.0], [0.0, 1.0]])
        q = np.zeros((_N, _N))
        q[:3, :3] = g @ np.array([[var_d, cov_dth], [cov_dth, var_th]]) @ g.T
        # what the model does not hold (slip events, a bias that wanders, a gain that differs
        # by direction): a random walk of the position per metre driven and of the heading
        # per radian turned and per metre driven
        dist, rot = abs(vt) * dt, abs(dth)
        q[0, 0] += self.slip_noise**2 * dist
        q[1, 1] += self.slip_noise**2 * dist
        q[2, 2] += self.turn_noise**2 * rot + self.path_heading_noise**2 * dist
        if floor is not None:  # never less than the base says its own odometry is uncertain
            q[:3, :3] = psd_max(q[:3, :3], rotate_covariance(np.asarray(floor, dtype=float).reshape(3, 3), th))
        q[3:7, 3:7] = np.diag(np.square(self.calibration_walk)) * dt * m
        q[7, 7] = self.rate_offset_walk**2 * dt
        self.P = f @ self.P @ f.T + q
        if any(self.honest_walk):
            # what neither the model nor its matches can show (a slip, a bias that wanders,
            # a map drawn by the same drifting estimate): admitted, never believed (the gain is P's)
            q = q.copy()
            q[0, 0] += self.honest_walk[0] ** 2 * dist
            q[1, 1] += self.honest_walk[0] ** 2 * dist
            q[2, 2] += self.honest_walk[1] ** 2 * dist + self.honest_walk[2] ** 2 * rot
        self.honest = f @ self.honest @ f.T + q
        if turned is not None:
            self.turn_unfixed += float(dth)
            # each step's rotation at the gain's uncertainty then: a gain learnt later does not
            # undo what it made of the turns before (signed: one gain, a turn back undoes it);
            # the gain's difference by direction, which the filter does not model, does not cancel
            self.turn_gain_error += math.sqrt(max(float(self.P[4, 4]), 0.0)) * float(dth)
            self.turn_rotation += abs(float(dth))
            self._floor_turn()

    def _floor_turn(self) -> None:
        """:attr:`honest`'s heading at least what the gyro's gain may have made of the rotation
        since the heading was last pinned sharply: each step's rotation times the gain's
        standard deviation then (signed, :attr:`turn_gain_error`: a gain learnt later does not
        undo the error it made before), plus ``turn_asymmetry`` times the rotation either way
        (:attr:`turn_rotation`). Matches that do not pin the heading by themselves, made against
        surfaces the turning estimate drew, do not show it (issue #36, clutter 15/0 with the
        gyro: a gain 8.9 % high, never learnt, turned the heading 10° off in one turn on the
        spot while the honest heading said 0.9-1.7°; the goal was claimed 0.155 m off).

        >>> f = OdometryFilter(0.15, turn_learn_sd=None)
        >>> for _ in range(30):
        ...     f.predict(0.0, 0.5, 0.1, turned=0.05)        # 1.5 rad on the spot, no match
        >>> round(f.turn_gain_error / (0.06 * 1.5), 2), bool(f.honest[2, 2] >= f.turn_gain_error**2)   # its sd times the turn
        (1.0, True)
        """
        need = (abs(self.turn_gain_error) + self.turn_asymmetry * self.turn_rotation) ** 2
        if need > self.honest[2, 2]:
            self.honest[2, 2] = need

    def _pinned(self, heading_sd: float) -> None:
        """A heading measurement of ``heading_sd`` (rad) was fused: sharp enough to learn from
        (``learn_heading_sd``), it pins the heading and the gyro's rotation counts from here;
        otherwise :meth:`_floor_turn` keeps what the gain may have made of the rotation."""
        if heading_sd <= (math.radians(0.5) if self.learn_heading_sd is None else self.learn_heading_sd):
            self.turn_unfixed = self.turn_gain_error = self.turn_rotation = 0.0
        else:
            self._floor_turn()

    def zero_rate(self, turned: float, dt: float) -> None:
        """The robot is known to stand still over ``dt`` s, in which the gyro measured
        ``turned`` (rad): that is its offset times ``dt`` and noise. The heading stays; the
        offset is learnt (and the heading errors it caused, through their correlation).

        >>> f = OdometryFilter(0.15)
        >>> for _ in range(20):
        ...     f.zero_rate(0.003, 0.1)                  # reads 0.03 rad/s standing
        >>> round(f.rate_offset, 3), f.pose.theta
        (0.03, 0.0)
        """
        if not (dt > 0 and math.isfinite(turned)):
            return
        self.P[7, 7] += self.rate_offset_walk**2 * dt
        r = self.rate_noise**2 / dt
        nu = turned / dt - float(self.x[7])
        s = float(self.P[7, 7]) + r
        k = self.P[:, 7] / s
        self.x = self.x + k * nu
        self.x[3:] = np.clip(self.x[3:], -self.calibration_bound, self.calibration_bound)
        self.x[2] = wrap_angle(float(self.x[2]))
        ikh = np.eye(_N) - np.outer(k, np.eye(_N)[7])
        self.P = ikh @ self.P @ ikh.T + np.outer(k, k) * r
        self.honest[7, 7] += self.rate_offset_walk**2 * dt
        self.honest = ikh @ self.honest @ ikh.T + np.outer(k, k) * r

    def correct_heading(self, offset: float, sd: float) -> tuple[bool, float]:
        """Update with a heading measured directly: ``offset`` (rad, measured minus the
        estimate) with standard deviation ``sd`` (rad), as a compass gives it against faces
        fixed in this frame (:class:`~clomp.runtime.estimation.faces.FaceCompass`). The position
        follows through its correlation with the heading, and the calibration learns from
        it (the faces carry no error of the estimate, unlike a map drawn from it). Returns
        (accepted, squared Mahalanobis distance); beyond ``gate``, rejected.

        >>> f = OdometryFilter(0.15)
        >>> for _ in range(20):
        ...     f.predict(0.1, 0.0, 0.1)
        >>> ok, d2 = f.correct_heading(0.02, 0.01)
        >>> ok, round(f.pose.theta, 3) > 0, f.calibration[2] > 0   # turned, and learnt that straights curve left
        (True, True, True)
        """
        nu = wrap_angle(float(offset))
        if not (math.isfinite(nu) and math.isfinite(sd) and sd > 0):
            return False, 0.0
        s = float(self.P[2, 2]) + sd * sd
        d2 = nu * nu / s
        if d2 > self.gate:
            return False, d2
        k = self.P[:, 2] / s
        self.x = self.x + k * nu
        self.x[3:] = np.clip(self.x[3:], -self.calibration_bound, self.calibration_bound)
        self.x[2] = wrap_angle(float(self.x[2]))
        ikh = np.eye(_N) - np.outer(k, np.eye(_N)[2])
        self.P = ikh @ self.P @ ikh.T + np.outer(k, k) * sd * sd  # Joseph form
        self.honest = ikh @ self.honest @ ikh.T + np.outer(k, k) * sd * sd
        self._pinned(sd)
        return True, d2

    def correct(self, innovation: Sequence[float] | np.ndarray, information: Sequence[Sequence[float]] | np.ndarray,
                min_information: float = 1e-9, floor: Sequence[float] | None = None,
                learn: bool = True, map_sd: tuple[float, float] = (0.0, 0.0)) -> tuple[bool, float]:
        """Update with a measured pose offset ``innovation`` (dx, dy, dtheta: measured minus
        predicted) whose information matrix (3×3, inverse covariance, state units) is
        ``information``; directions with less information than ``min_information`` are
        not measured; ``floor`` (m, m, rad) replaces ``match_floor`` for this match.
        ``learn`` False corrects the pose only and leaves the calibration as it is (a
        revolution seen again from where the last one was matched tells nothing new
        about the wheels: its errors are the map's, repeated). ``map_sd`` (m, rad): how
        wrong the map the match was made against may be (the estimate's own uncertainty
        when its surfaces were drawn): the gain does not count it, :attr:`honest` does.
        Returns (accepted, squared Mahalanobis distance per direction)."""
        nu = np.asarray(innovation, dtype=float).reshape(3)
        nu[2] = wrap_angle(float(nu[2]))
        info = np.asarray(information, dtype=float).reshape(3, 3)
        info = (info + info.T) / 2
        lam, vecs = eigh(info)  # np.linalg.eigh bit for bit, cheaper (_exact; issue #41)
        keep = lam > min_information
        if not keep.any() or not np.all(np.isfinite(nu)):
            return False, 0.0
        u = vecs[:, keep]  # 3×m observed directions
        h = np.zeros((u.shape[1], _N))
        h[:, :3] = u.T
        fl = self.match_floor if floor is None else np.square(np.asarray(floor, dtype=float))
        r = np.diag(1.0 / lam[keep] + np.einsum("ik,i,ik->k", u, fl, u))
        z = u.T @ nu
        s = h @ self.P @ h.T + r
        s_inv = np.linalg.inv(s)
        d2 = float(z @ s_inv @ z) / len(z)
        if d2 > self.gate:
            return False, d2
        kgain = self.P @ h.T @ s_inv
        pinned = self.heading_sd(info)
        turn_only = (learn and self.turn_learn_sd is not None and pinned <= self.turn_learn_sd
                     and abs(self.turn_unfixed) >= self.turn_learn_after)
        if learn and self.learn_heading_sd is not None:
            # the calibration is learnt only from a match that pins the heading by itself: one
            # that leaves rotation to the position (one small box) would teach the wheels the
            # errors of the map it is matched against, and the learnt curvature would turn
            # the next straight the wrong way
            learn = pinned <= self.learn_heading_sd
        if self.hold_unobserved and np.any(np.abs(vecs[2, ~keep]) > 0.3):
            # the pose moves only along the directions the match observes: the others keep
            # dead reckoning. Through its correlations the gain would otherwise turn the
            # heading on a match that leaves rotation to the position (one small box), by
            # the prior's heading uncertainty rather than by what the scene shows. (A
            # corridor's axis, a translation, keeps the full gain: holding it too cost the
            # named slalom scene through the supervisor's patience, for no paper run.)
            kgain[:3, :] = u @ (u.T @ kgain[:3, :])
        if not learn:
            keep = kgain[4, :].copy()
            kgain[3:, :] = 0.0  # Joseph form below keeps P right for any gain
            if turn_only:
                kgain[4, :] = keep
        self.x = self.x + kgain @ z
        self.x[3:] = np.clip(self.x[3:], -self.calibration_bound, self.calibration_bound)
        self.x[2] = wrap_angle(float(self.x[2]))
        ikh = np.eye(_N) - kgain @ h
        self.P = ikh @ self.P @ ikh.T + kgain @ r @ kgain.T  # Joseph form: stays symmetric, PSD
        # the same gain, with the map's own error in the measurement: the Joseph form gives
        # the covariance of this estimate for any gain, so ``honest`` is what it truly is
        r_map = h[:, :3] @ np.diag([map_sd[0] ** 2, map_sd[0] ** 2, map_sd[1] ** 2]) @ h[:, :3].T
        if turn_only and not learn:
            kgain[4, :] = 0.0
            ikh = np.eye(_N) - kgain @ h
        self.honest = ikh @ self.honest @ ikh.T + kgain @ (r + r_map) @ kgain.T
        # the match's floor is the part of its error the revolutions share (the surfaces met, the
        # matcher's own bias): fused revolution after revolution as if independent it averages
        # down in ``honest`` too, and the 95 % bound it gave at harsh with the gyro covered the
        # true error in 73 % of revolutions under 2 cm (bench/bound_coverage.py; claims 1.2 cm
        # sure, truly 2-6 cm off). The estimate cannot be known better than it, on top of the
        # map's drawing error
        shared = np.diag(fl) if self.shared_floor else np.zeros((3, 3))
        self._not_below_map(u, np.diag([map_sd[0] ** 2, map_sd[0] ** 2, map_sd[1] ** 2]) + shared)
        self._pinned(pinned)
        return True, d2

    def _not_below_map(self, u: np.ndarray, map_cov: np.ndarray) -> None:
        """In the directions ``u`` (3×m, pose units) a match observed, raise :attr:`honest`
        to at least ``map_cov`` (3×3, the map's own error): an estimate matched to a map it
        drew itself shares the map's error and cannot be known better than it."""
        have = u.T @ self.honest[:3, :3] @ u
        lack = u.T @ map_cov @ u - have
        lam, vecs = eigh((lack + lack.T) / 2)
        pos = lam > 0
        if pos.any():
            add = u @ (vecs[:, pos] * lam[pos]) @ vecs[:, pos].T @ u.T
            self.honest[:3, :3] += add
