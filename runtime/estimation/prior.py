"""What the estimator is told of its robot's drive: the wheel-calibration prior (issue #36).

The filter (:class:`~clomp.runtime.estimation.ekf.OdometryFilter`) learns the drive's
systematic errors, but until a scan has shown them it can only believe its prior. Along a
direction the scene leaves unobserved (a corridor's axis) the prior is all there is: the
95 % position bound at the goal is the prior's forward scale times the distance driven. A
prior sized for the worst robot (today's defaults, :meth:`OdometryPrior.worst`) makes a
well-calibrated robot that truly stands at the goal unable to say so (the ``corridor``
layouts at ``paper`` noise: 32 of 50 runs within 0.03 m of the goal ended GOAL_UNCONFIRMED
with bounds of 0.09-0.30 m). A real robot is told its calibration — its wheels' tolerance,
how much they slip on its floor, how fast its drive answers a command — and so is the
execution world's robot (:class:`~clomp.runtime.interface.Calibrated`): the noise terms it
draws its errors from, never the draws themselves. :meth:`OdometryPrior.from_noise` turns
them into the filter's prior standard deviations with a margin (``margin``: how much
worse than told the robot may be), so that a robot told nothing keeps the worst-case
prior and one told ``harsh`` gets about it. It is told how late its drive answers a
command, too (``delay``): dead reckoning on the commands as sent runs ahead of a body that
starts 0.1 s late, and the filter, believing its prediction, learnt the lead as a wheel
scale (-13 % on ``overtaking`` at ``harsh``, seed 3 run 2, which then ended 0.115 m from the
goal it claimed).

A robot without a heading sensor (no gyro, no IMU) whose maker tells it of error sources the
filter does not model (:data:`~clomp.planner.noise.UNMODELLED_FIELDS`: a wheel bias that
wanders, slip events, pushes, on in ``harsh``) keeps the worst-case wheels all the same
(``heading=False`` in :meth:`OdometryPrior.from_noise`), but not a delay of 0: the body's
lateness is no heading error, and without it every start's lead was learnt as a forward scale
(appearing 22/0 without the gyro: -0.11 in its first 0.15 m, truly about -0.02; it claimed the
goal 0.125 m off). Its heading is what the wheels and the
matches against a map drawn from its own estimate make of it, and that is no better for
knowing the drive's terms: on the sample of every family × seeds 0-4 at ``harsh`` without the
gyro, the told prior and delay made 5 of 60 runs claim the goal 0.10-0.21 m off with a bound
of 12-23 mm (a 10 % wheel mismatch the scans left unlearnt: the heading 6-16° off, the
filter's 1-2°), where the worst case claimed none.

>>> from clomp.planner.noise import UNMODELLED_FIELDS, NoiseTerms
>>> p, h = OdometryPrior.from_noise(NoiseTerms.preset("paper")), OdometryPrior.from_noise(NoiseTerms.preset("harsh"))
>>> round(p.calibration_sd[0], 3), round(h.calibration_sd[0], 3), OdometryPrior.worst().calibration_sd[0]
(0.013, 0.065, 0.06)
>>> OdometryPrior.from_noise(NoiseTerms.preset("harsh"), heading=False) == OdometryPrior.worst()   # and admits more
False
>>> OdometryPrior.from_noise(NoiseTerms.preset("harsh"), heading=False).calibration_sd == OdometryPrior.worst().calibration_sd
True
>>> OdometryPrior.from_noise(NoiseTerms.preset("paper"), heading=False) == p   # nothing unmodelled told
True
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any

from clomp.planner.noise import UNMODELLED_FIELDS, NoiseTerms

__all__ = ["UNSEEN_WALK", "OdometryPrior", "slip_walk"]

# what a robot without a heading sensor, told of error sources the filter does not model,
# admits beyond its model (m per √m driven, rad per √m driven, rad per √rad turned): the
# filter's :attr:`~clomp.runtime.estimation.ekf.OdometryFilter.honest` covariance only
UNSEEN_WALK: tuple[float, float, float] = (0.05, 0.03, 0.03)

_HALF_NORMAL_MEAN = math.sqrt(2.0 / math.pi)  # E|N(0, 1)|: the mean share of speed a slip takes, per unit
_HALF_NORMAL_SD = math.sqrt(1.0 - 2.0 / math.pi)  # and its spread


def slip_walk(told: NoiseTerms, speed: float = 0.1) -> float:
    """The position error slip events leave (m per √m driven): ``slip_rate`` events a second of
    driving, each a ``slip_duration`` in which the wheels turn and the body stands, so the
    odometry counts ``speed * slip_duration`` the body did not go; per metre driven at
    ``speed`` that is ``slip_rate / speed`` events, a variance of ``slip_rate * speed *
    slip_duration**2``. The filter does not model them (a wheel scale learnt from the matches
    does not know when the next one comes), and a match against surfaces the slipping estimate
    drew cannot show them: :attr:`~clomp.runtime.estimation.ekf.OdometryFilter.honest` admits them
    (issue #36, corridor 52/0 at ``harsh`` with the gyro: the estimate 0.12 m ahead along the
    corridor after 1.07 m, the bound 0.029 m, the goal claimed truly 0.104 m off).

    >>> round(slip_walk(NoiseTerms.preset("harsh")), 4), slip_walk(NoiseTerms.preset("paper"))
    (0.0354, 0.0)
    """
    return told.slip_duration * math.sqrt(max(told.slip_rate, 0.0) * max(speed, 0.0))


@dataclass(frozen=True)
class OdometryPrior:
    """The filter's prior on the drive (see the module): ``calibration_sd`` of (s, k, c, d),
    ``calibration_walk`` (per √s while moving), ``wheel_noise`` (relative, per step of
    each wheel) and ``delay`` (s): how long after a command the body follows it (the
    actuation latency and half the wheels' ramp), by which
    :class:`~clomp.runtime.estimation.odometry.ScanOdometry` delays the commands it
    dead-reckons with (0, told nothing: the body is taken to follow at once).
    ``turn_asymmetry``: half the told difference of a gyro's gain between the two ways of
    turning, with the margin (0, told nothing), admitted per radian turned
    (:meth:`~clomp.runtime.estimation.ekf.OdometryFilter._floor_turn`).
    """

    calibration_sd: tuple[float, float, float, float] = (0.06, 0.06, 0.3, 0.02)
    calibration_walk: tuple[float, float, float, float] = (0.002, 0.002, 0.01, 0.001)
    wheel_noise: float = 0.15
    delay: float = 0.0
    honest_walk: tuple[float, float, float] = (0.0, 0.0, 0.0)
    turn_asymmetry: float = 0.0
    shared_floor: bool = True
    """Whether a match's floor counts as error the revolutions share
    (:class:`~clomp.runtime.estimation.ekf.OdometryFilter` ``shared_floor``): on for a robot told
    nothing or told of error sources the filter does not model (their drift draws the map the
    matches meet); off for one told its drive follows the model (``paper``: there the floor kept
    every corridor run truly 1 cm from the goal unconfirmed)."""

    @classmethod
    def worst(cls) -> OdometryPrior:
        """The prior of a robot told nothing: sized for the worst preset (``harsh``)."""
        return cls()

    @classmethod
    def from_noise(cls, told: NoiseTerms, wheel_base: float = 0.15, *, margin: float = 1.5,
                   wheel_accel: float = 1.0, speed: float = 0.1, heading: bool = True) -> OdometryPrior:
        """The prior of a robot told its drive's noise terms ``told`` (standard deviations of
        its errors; :class:`~clomp.planner.noise.NoiseTerms`), each ``margin`` times what they
        imply: the forward and turn scale from the wheels' bias (their mean) and slip (its
        mean loss, a bias the prior's mean of 0 leaves), the curvature from the bias's
        difference over ``wheel_base``, the drift as told, the per-step noise from the
        per-tick error and slip's spread, the walk from ``bias_walk``, the delay from
        the latency and the ramp to ``speed`` at ``wheel_accel`` (m/s²; a told time, no margin). A turn-scale prior
        also covers a gyro's scale error (``rate_scale``, ``rate_asymmetry``): the filter's
        turn scale is the gyro's when there is one. ``heading`` False: the robot has no heading
        sensor; told any error source the filter does not model (:data:`~clomp.planner.noise.UNMODELLED_FIELDS`),
        it keeps :meth:`worst`'s wheels (see the module: its heading errors would look small) with
        the told delay and :data:`UNSEEN_WALK` admitted.

        >>> q = OdometryPrior.from_noise(NoiseTerms.preset("ideal"))
        >>> all(v > 0 for v in q.calibration_sd), q.wheel_noise > 0
        (True, True)
        >>> [OdometryPrior.from_noise(NoiseTerms.preset(p)).shared_floor for p in ("paper", "harsh")], OdometryPrior.worst().shared_floor
        ([False, True], True)
        """
        if not (math.isfinite(margin) and margin > 0 and wheel_base > 0 and wheel_accel > 0):
            raise ValueError("margin, wheel_base and wheel_accel must be positive")
        m, worst = float(margin), cls.worst()
        delay = told.latency + speed / (2.0 * wheel_accel)
        if not heading and any(getattr(told, name) > 0 for name in UNMODELLED_FIELDS):
            # the worst-case wheels, but the body's told lateness all the same (see the module)
            return dataclasses.replace(worst, honest_walk=UNSEEN_WALK, delay=delay)
        scale = math.hypot(told.wheel_bias / math.sqrt(2.0), _HALF_NORMAL_MEAN * told.slip)
        gyro = math.hypot(told.rate_scale, told.rate_asymmetry)
        curvature = told.wheel_bias * math.sqrt(2.0) / wheel_base
        # never below a floor: a robot told it is perfect may still be a little off, and a
        # prior of 0 would make the filter deaf to what the scans show of it
        floor = (0.002, 0.002, 0.01, 0.0005)
        sd = tuple(max(f, m * v) for f, v in zip(floor, (scale, max(scale, gyro), curvature, told.drift)))
        walk_s = told.bias_walk / math.sqrt(2.0)
        walk = (max(worst.calibration_walk[0] / 4, m * walk_s), max(worst.calibration_walk[1] / 4, m * walk_s),
                max(worst.calibration_walk[2] / 4, m * told.bias_walk * math.sqrt(2.0) / wheel_base),
                worst.calibration_walk[3] / 4)
        noise = max(0.01, m * math.hypot(told.wheel_sd, _HALF_NORMAL_SD * told.slip))
        # a gyro's gain turning one way differs from the other's by ``rate_asymmetry``: each
        # way half of it from the one gain the filter learns
        unmodelled = any(getattr(told, name) > 0 for name in UNMODELLED_FIELDS)
        return cls((sd[0], sd[1], sd[2], sd[3]), walk, noise, delay, turn_asymmetry=m * told.rate_asymmetry / 2.0,
                   honest_walk=(m * slip_walk(told, speed), 0.0, 0.0), shared_floor=unmodelled)

    def filter_kwargs(self) -> dict[str, Any]:
        """The :class:`~clomp.runtime.estimation.ekf.OdometryFilter` keyword arguments it sets."""
        return {"calibration_sd": self.calibration_sd, "calibration_walk": self.calibration_walk,
                "wheel_noise": self.wheel_noise, "honest_walk": self.honest_walk,
                "turn_asymmetry": self.turn_asymmetry, "shared_floor": self.shared_floor}
