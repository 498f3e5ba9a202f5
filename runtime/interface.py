"""The robot interface: the only thing the supervisor sees of a robot.

Every backend (the simulated robot, the hardware robot over serial ports, a replay)
implements :class:`Robot`. Wheel speeds are linear speeds of the wheel contact points
in metres per second (positive drives forward); poses are in the odometry frame the
backend chose at start-up (x forward, y left, theta counter-clockwise). Time is the
backend's :class:`~clomp.runtime.clock.Clock`: a simulated backend keeps simulated time and
is its own clock (``now``, ``sleep``), which the supervisor then runs on
(:func:`~clomp.runtime.clock.clock_for`); the hardware robot takes one clock, wall time by default.
"""

from __future__ import annotations

import math

from typing import Protocol, runtime_checkable

import numpy as np

from clomp.formal.model import Pose
from clomp.runtime.devices.bno08x_slide import Slide
from clomp.runtime.devices.frame import ScanFrame

__all__ = ["ScanFrame", "Robot", "RobotFault", "TurnSensing", "ShockSensing", "SlideSensing", "OdometryUncertainty", "Calibrated",
           "finite_goal", "has_heading_sensor"]


class RobotFault(RuntimeError):
    """A backend cannot go on: a device vanished, a sensor fell silent, a bad reply.

    >>> try:
    ...     raise RobotFault("LiDAR unplugged")
    ... except RuntimeError as exc:
    ...     print(exc)
    LiDAR unplugged
    """


@runtime_checkable
class Robot(Protocol):
    """What a robot backend offers the supervisor.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> robot = SimRobot(load_scenario("open"), seed=0)
    >>> isinstance(robot, Robot)
    True
    >>> frame = robot.read_scan(timeout=1.0); robot.set_wheel_speeds(0.1, 0.1); robot.stop()
    >>> frame.points.shape[1]
    2
    """

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The newest full scan not returned before, or None if none arrived in ``timeout`` s."""
        ...

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels (m/s). Must be called at least every control tick."""
        ...

    def stop(self) -> None:
        """Stop the wheels now. Safe to call at any time, repeatedly, also after a fault."""
        ...

    def odometry(self) -> Pose | None:
        """The pose estimate of the backend, or None when it has no odometry."""
        ...

    def close(self) -> None:
        """Stop and release the devices."""
        ...


@runtime_checkable
class TurnSensing(Protocol):
    """A backend that measures its own rotation (a rate gyro; the paper's robot measured it
    by its camera's optic flow). Optional: the supervisor's estimator takes the heading from
    it when a backend has it, and from the wheels otherwise.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends import make_world_robot
    >>> isinstance(make_world_robot(load_scenario("open"), "paper", seed=0), TurnSensing)
    True
    """

    def rotation(self) -> float | None:
        """The heading turned since start-up (rad, counter-clockwise), as the sensor
        integrates it; None when the sensor has nothing (yet)."""
        ...


@runtime_checkable
class ShockSensing(Protocol):
    """A backend whose IMU's accelerometer reports shocks: an outside force (a kick, a
    collision, a body stopping dead while its wheels spin) shows as an acceleration no
    drive makes. Optional: the supervisor's estimator then doubts what it cannot vouch for
    (:mod:`clomp.runtime.estimation.doubt`).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends import make_world_robot
    >>> isinstance(make_world_robot(load_scenario("open"), "paper", seed=0), ShockSensing)
    True
    """

    def peak_acceleration(self) -> float | None:
        """The largest horizontal acceleration (m/s²) since the last call; None when the
        sensor has nothing."""
        ...


@runtime_checkable
class SlideSensing(Protocol):
    """A backend whose IMU measures how far a kick slid the body (its accelerations
    integrated over the slide; :class:`~clomp.runtime.devices.bno08x_slide.SlideWatch`).
    Optional: the supervisor's estimator then moves the estimate by each slide and does not
    match the revolutions taken during it (:meth:`~clomp.runtime.estimation.odometry.ScanOdometry.slid`).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> isinstance(SimRobot(load_scenario("open"), seed=0), SlideSensing)
    False
    """

    def slides(self) -> list[Slide] | None:
        """The slides measured since the last call (oldest first); None when the backend
        has no sensor for them (then it never will)."""
        ...


@runtime_checkable
class OdometryUncertainty(Protocol):
    """A backend whose odometry reports its own uncertainty (a ROS base's ``/odom``
    covariance). Optional: the supervisor's estimator then takes no less noise for a step
    than the base reports (:mod:`clomp.runtime.estimation.reported`), its own model's otherwise.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> isinstance(SimRobot(load_scenario("open"), seed=0), OdometryUncertainty)
    False
    """

    def odometry_covariance(self) -> tuple[np.ndarray | None, np.ndarray | None]:
        """The newest odometry's (pose, twist) covariance, each planar 3×3 (x, y, yaw; the
        pose's in the odometry frame, the twist's in the base frame), None where unknown."""
        ...


@runtime_checkable
class Calibrated(Protocol):
    """A backend that tells the estimator its drive's calibration (issue #36), as a robot's
    maker or a calibration run would: the standard deviations its errors are drawn from
    (the terms of a :class:`~clomp.planner.noise.NoiseTerms`, by name), never this run's draws. Optional: the
    estimator's wheel prior is then sized to it
    (:meth:`~clomp.runtime.estimation.prior.OdometryPrior.from_noise`), the worst case's otherwise,
    and also when the robot has no heading sensor and is told of error sources the filter does
    not model (``harsh``: its heading errors would look small).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> isinstance(SimRobot(load_scenario("open"), seed=0), Calibrated)
    False
    """

    def calibration(self) -> dict[str, float]:
        """The noise terms the robot's drive and sensors are specified to (standard deviations, by name)."""
        ...


def has_heading_sensor(robot: object) -> bool:
    """Whether ``robot`` carries a heading sensor (a gyro, an IMU), whether or not it has
    reported yet: its ``heading_sensor`` attribute when it says (a bool), else whether its
    :meth:`TurnSensing.rotation` has a value now.

    Why: the estimator's wheel prior depends on it (a robot without one, told of errors the
    filter does not model, keeps the worst-case wheels), and it is chosen when the
    supervisor is built, before an IMU's first report has arrived: asking the reading alone
    would take a robot with an IMU for one without.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends import make_world_robot
    >>> scene = load_scenario("open")
    >>> has_heading_sensor(make_world_robot(scene, "harsh", seed=0)), has_heading_sensor(make_world_robot(scene, "harsh", seed=0, gyro=False))
    (True, False)
    """
    declared = getattr(robot, "heading_sensor", None)
    if isinstance(declared, bool):
        return declared
    return isinstance(robot, TurnSensing) and robot.rotation() is not None


def finite_goal(goal: tuple[float, float]) -> tuple[float, float]:
    """``goal`` as two floats; ValueError when it is not two finite numbers.

    Every controller (the supervisor, the reactive baseline) checks its goal with it.

    >>> finite_goal((1, 0.5))
    (1.0, 0.5)
    """
    try:
        gx, gy = (float(v) for v in goal)
    except (TypeError, ValueError):
        raise ValueError(f"goal must be two numbers x, y, got {goal!r}") from None
    if not (math.isfinite(gx) and math.isfinite(gy)):
        raise ValueError(f"goal must be finite, got {goal!r}")
    return gx, gy
