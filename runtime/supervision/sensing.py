"""What the supervisor knows of where the robot is and what it sees: :class:`Sensing`.

The pose estimate (dead reckoning, corrected once a revolution by scan matching with
``feedback="scan"``: :class:`~clomp.runtime.estimation.odometry.ScanOdometry`), the newest
revolution, the last *clean* one (not smeared by a turn) with the pose it was taken at
(what the hazard test and the plan check read), and the still revolutions taken since the
wheels last stopped (what a plan starts from, fused). The supervisor's state machine
decides what to do with them; this class only keeps them.

>>> from clomp.planner import load_scenario
>>> from clomp.planner.robot_model import RobotModel
>>> from clomp.runtime.backends.sim import SimRobot
>>> from clomp.runtime.supervision.config import SupervisorConfig
>>> robot = SimRobot(load_scenario("open"), seed=0)
>>> s = Sensing(robot, RobotModel(), SupervisorConfig(feedback="none"))
>>> s.start(0.0)
Pose(x=0.0, y=0.0, theta=0.0)
>>> s.take(robot.read_scan(timeout=1.0), 0.1, (0.0, 0.0), still=True) is None, s.since_stop, s.ready()
(True, 1, True)
"""

from __future__ import annotations

import dataclasses
from collections import deque

import numpy as np

from clomp.formal.geometry import dead_reckon
from clomp.formal.model import Pose
from clomp.planner.noise import NoiseTerms
from clomp.planner.perception import validate_scan
from clomp.planner.robot_model import RobotModel
from clomp.runtime.estimation.fusion import fuse_revolutions
from clomp.runtime.estimation.odometry import FeedbackRecord, ScanOdometry
from clomp.runtime.estimation.prior import OdometryPrior
from clomp.runtime.interface import (Calibrated, OdometryUncertainty, Robot, ScanFrame, ShockSensing, SlideSensing,
                                     TurnSensing, has_heading_sensor)
from clomp.runtime.supervision.config import SupervisorConfig

__all__ = ["Sensing", "crop_far", "turning"]

_FAR = 1.05
"""Returns beyond the planning horizon (``sensor_range``) × this are cropped where a
revolution comes in, once, and counted (``Sensing.cropped``): a LiDAR that sees farther
than the horizon (an A1 sees 12 m) would otherwise carry them through every plan's
perception, which crops them too, silently. Within it they are kept, as before."""


def crop_far(frame: ScanFrame, sensor_range: float) -> tuple[ScanFrame, int]:
    """``frame`` without its returns beyond ``sensor_range`` × 1.05 (see ``_FAR``; their
    times and qualities with them) and how many there were; ``frame`` itself when none.

    >>> f, n = crop_far(ScanFrame(np.array([[0.5, 0.0], [3.0, 0.0]]), 1.0, point_times=np.array([-0.1, 0.0])), 1.1)
    >>> f.points.tolist(), f.point_times.tolist(), n
    ([[0.5, 0.0]], [-0.1], 1)
    """
    pts = np.asarray(frame.points, dtype=float)
    far = np.einsum("ij,ij->i", pts, pts) > (sensor_range * _FAR) ** 2
    if not far.any():
        return frame, 0
    near = ~far
    times = None if frame.point_times is None else np.asarray(frame.point_times)[near]
    quality = None if frame.quality is None else np.asarray(frame.quality)[near]
    return dataclasses.replace(frame, points=pts[near], point_times=times, quality=quality), int(np.count_nonzero(far))


def turning(cmd: tuple[float, float]) -> bool:
    """True when the wheel speeds ``cmd`` turn the body (they differ).

    >>> turning((0.1, 0.1)), turning((-0.1, 0.1))
    (False, True)
    """
    vl, vr = cmd
    return abs(vr - vl) > 1e-9


class Sensing:
    """The pose estimate and the revolutions the supervisor keeps (see the module docstring).

    ``pose``: the estimate (supervisor frame); ``estimator``: the scan matcher with scan
    feedback, else None; ``scan``: the newest revolution; ``clean_scan`` / ``scan_pose``:
    the newest revolution not smeared by a turn and where it was taken; ``since_stop``:
    revolutions since the wheels last stopped; ``still``: the last of them taken standing;
    ``cropped``: the returns cropped beyond the sensor range (see ``_FAR``).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> s = Sensing(SimRobot(load_scenario("open"), seed=0), RobotModel(), SupervisorConfig())
    >>> s.estimator is not None, s.ready()
    (True, False)
    """

    def __init__(self, robot: Robot, model: RobotModel, config: SupervisorConfig) -> None:
        self.robot = robot
        self._rotation = robot.rotation if isinstance(robot, TurnSensing) else lambda: None  # a gyro, when it has one
        # the odometry's own covariance, when the backend reports one (a ROS base's /odom)
        self._odo_cov = robot.odometry_covariance if isinstance(robot, OdometryUncertainty) else lambda: None
        self._shock = robot.peak_acceleration if isinstance(robot, ShockSensing) else lambda: None  # an accelerometer
        self._slides = robot.slides if isinstance(robot, SlideSensing) else lambda: None  # a kick's slide (an IMU)
        self.config = config
        self.wheel_base = model.wheel_base
        # a robot told its calibration (the execution world) sizes the wheel prior to it (issue #36),
        # unless it has no heading sensor and is told of errors the filter does not model; whether
        # it has one is what it carries, not whether the sensor has spoken yet (an IMU's first
        # report comes after the supervisor is built)
        prior = OdometryPrior.from_noise(NoiseTerms(**robot.calibration()), model.wheel_base,
                                         speed=model.straight_speed, heading=has_heading_sensor(robot)) \
            if isinstance(robot, Calibrated) else None
        if config.drive_delay is not None:  # told how late the drive follows (clomp run --drive-delay)
            prior = dataclasses.replace(prior or OdometryPrior.worst(), delay=config.drive_delay)
        self.estimator: ScanOdometry | None = ScanOdometry(model.wheel_base, prior=prior) \
            if config.feedback == "scan" else None
        if self.estimator is not None:  # its slides measured (clomp run --imu): the revolutions in one are not matched
            self.estimator.slide_sensing = self._slides() is not None
        self.pose = Pose(0.0, 0.0, 0.0)
        self.scan: np.ndarray | None = None
        self.clean_scan: np.ndarray | None = None
        self.scan_pose = self.pose
        self.turned = False
        self.moved = False
        self.since_stop = 0
        self.still: deque[np.ndarray] = deque(maxlen=config.fused_revolutions)
        self.last_update = 0.0
        self.last_scan_at = 0.0
        self.sensor_range = model.sensor_range
        self.cropped = 0  # returns cropped beyond the sensor range so far (crop_far)

    def start(self, now: float) -> Pose:
        """Fix the frame at the robot's present pose (its odometry's, else the origin) at ``now``."""
        self.last_update = self.last_scan_at = now
        odo = self.robot.odometry()
        self.pose = odo if odo is not None else Pose(0.0, 0.0, 0.0)
        if self.estimator is not None:
            self.estimator.reset(self.pose, now)
            self.estimator.advance(now, (0.0, 0.0), odo, self._rotation(), self._odo_cov())
        return self.pose

    def update_pose(self, now: float, cmd: tuple[float, float]) -> None:
        """Dead-reckon the estimate to ``now`` (the wheels were commanded ``cmd``)."""
        dt = now - self.last_update
        self.last_update = now
        odo = self.robot.odometry()
        if self.estimator is not None:
            self.estimator.advance(now, cmd, odo, self._rotation(), self._odo_cov())
            peak = self._shock()
            if peak is not None:
                self.estimator.shock(peak)  # an outside force: what it moved the body by is doubted
            for slide in self._slides() or ():  # how far it slid: the estimate moves by it
                self.estimator.slid(slide.distance, slide.bearing, slide.turned, slide.duration, sd=slide.sd)
            self.pose = self.estimator.pose
            return
        self.pose = odo if odo is not None else dead_reckon(self.pose, *cmd, self.wheel_base, dt)

    def take(self, frame: ScanFrame, now: float, cmd: tuple[float, float], still: bool) -> FeedbackRecord | None:
        """Keep a new revolution (read at ``now``); with scan feedback correct the estimate by
        it and return what that did. ``still``: it counts among the still revolutions."""
        frame, far = crop_far(dataclasses.replace(frame, points=validate_scan(frame.points, "scan")), self.sensor_range)
        self.cropped += far  # beyond the planning horizon: cropped here, once (see _FAR)
        scan = self.scan = frame.points
        rec = self._feedback(frame, now) if self.estimator is not None else None
        self.last_scan_at = now
        self.since_stop += 1
        if still:
            self.still.append(scan)
        # a revolution taken while turning is smeared: keep the last clean one, unless
        # _feedback de-skewed it (it then set the clean scan at its estimated pose)
        if not self.turned and (self.estimator is None or frame.point_times is None):
            self.clean_scan, self.scan_pose = scan, self.pose
        self.turned = turning(cmd)
        return rec

    def _feedback(self, frame: ScanFrame, now: float) -> FeedbackRecord:
        """Correct the pose estimate with this revolution (scan matching against the local map)."""
        assert self.estimator is not None
        if not (now - 1.0 <= frame.timestamp <= now + 1e-6):  # another clock: take it as now
            frame = dataclasses.replace(frame, timestamp=now)
        rec = self.estimator.update(frame)
        self.pose = self.estimator.pose
        if frame.point_times is not None:
            self.clean_scan, self.scan_pose = self.estimator.last_points, self.estimator.pose_at(frame.timestamp)
        return rec

    def position_bound(self, sigmas: float) -> float | None:
        """``sigmas`` standard deviations of the position estimate (m), what the estimate
        can vouch for (:meth:`~clomp.runtime.estimation.odometry.ScanOdometry.position_sd`);
        None without scan feedback (dead reckoning alone carries no uncertainty).

        >>> from clomp.planner import load_scenario
        >>> from clomp.runtime.backends.sim import SimRobot
        >>> s = Sensing(SimRobot(load_scenario("open"), seed=0), RobotModel(), SupervisorConfig())
        >>> s.position_bound(2.45) < 0.001
        True
        """
        return None if self.estimator is None else sigmas * self.estimator.position_sd()

    def better_pose(self) -> Pose | None:
        """Where the revolutions seen standing here say the robot is when they fit the map
        clearly better there than at the estimate (a wider search from several guesses:
        :meth:`~clomp.runtime.estimation.odometry.ScanOdometry.ambiguity`); None when they
        do not, or without scan feedback."""
        if self.estimator is None or self.scan is None:
            return None
        return self.estimator.ambiguity(self.planning_scan()).better

    def confirm_doubt(self) -> Pose | None:
        """In doubt, the revolutions seen standing here searched for widely against the map
        drawn before it (:meth:`~clomp.runtime.estimation.odometry.ScanOdometry.confirm_doubt`):
        where they put the robot when clearly elsewhere, else None."""
        if self.estimator is None or self.scan is None:
            return None
        return self.estimator.confirm_doubt(self.planning_scan())

    def relocate(self, pose: Pose) -> None:
        """Move the estimate to ``pose`` (:meth:`better_pose`), its uncertainty raised by the jump."""
        assert self.estimator is not None
        self.estimator.relocate(pose)
        self.pose = self.estimator.pose

    def drove(self, cmd: tuple[float, float]) -> None:
        """The wheels were commanded ``cmd``: a turn smears the revolution under way."""
        self.turned = self.turned or turning(cmd)
        if cmd[0] != 0 or cmd[1] != 0:
            self.moved = True

    def stopped(self) -> None:
        """The wheels stopped (or a plan must be made afresh): count still revolutions anew."""
        self.since_stop = 0
        self.still.clear()

    def ready(self) -> bool:
        """Enough revolutions since the stop to plan: after driving, ``settle_scans`` for the
        wheels to settle and the fused ones; at the start, ``start_revolutions`` (the map's seed)."""
        cfg = self.config
        need = cfg.settle_scans + cfg.fused_revolutions - 1 if self.moved else cfg.start_revolutions
        return self.scan is not None and self.since_stop >= need

    def planning_scan(self) -> np.ndarray:
        """The scan a plan starts from: the still revolutions fused, or the newest alone."""
        assert self.scan is not None
        if self.moved and self.config.fused_revolutions > 1 and len(self.still) > 1:
            return fuse_revolutions(list(self.still))
        return self.scan

    def seconds_silent(self, now: float) -> float:
        """How long no revolution has come (s), at ``now``.

        >>> from clomp.planner import load_scenario
        >>> from clomp.runtime.backends.sim import SimRobot
        >>> s = Sensing(SimRobot(load_scenario("open"), seed=0), RobotModel(), SupervisorConfig())
        >>> s.seconds_silent(2.5)
        2.5
        """
        return now - self.last_scan_at
