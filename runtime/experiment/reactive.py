"""The paper's baseline: one closed-loop controller with one-loop-ahead disturbance detection.

The paper contrasts planning with "a reactive control strategy which uses a single
closed-loop controller", drawn in its figure 3B as "one-loop-ahead disturbance
detection". This is that controller, on the same :class:`~runtime.robot.Robot`
interface as the supervisor, with no plan and no map. Every control tick it

1. updates its pose estimate *as the planning condition's supervisor does*: with
   ``feedback="scan"`` (the default) dead reckoning from the commanded wheel speeds (or the
   robot's odometry) corrected once a revolution by matching the scan against a local map
   (:class:`~runtime.estimation.odometry.ScanOdometry`, the supervisor's estimator); with
   ``feedback="none"`` dead reckoning alone. The two conditions are the same robot with the
   same sensing and the same estimate, so a difference between them is planning's, not
   the estimate's. It then moves the newest (de-skewed) scan into the body frame;
2. looks *one loop ahead*: the loop is one straight task of the planner, so the
   look-ahead is the corridor the body sweeps over one straight step —
   ``front_offset < x <= front_offset + look_ahead``, ``|y| <= width / 2 + clearance``
   with ``look_ahead`` = the model's ``step_length`` (0.27 m, one body length, the
   authors' step; DESIGN.md). ``hazard_points`` (2) or more scan points there are a
   disturbance (a single point may be noise);
3. if there is one, spins in place at the turn tasks' rate (0.58 rad/s) *away from the
   nearest such point* (it is left of the heading → turn right, and the reverse) and
   keeps that direction until the corridor is clear;
4. otherwise drives towards the goal at the straight task's speed (0.1 m/s), steering
   in proportion to the goal's bearing (``gain`` 1.5 /s, saturated at the turn rate; the
   straight task's error signal is that bearing) and spinning towards the goal first
   when it lies more than 60° off the heading.

It stops when it believes it is within ``goal_radius`` of the goal (the model's goal
tolerance, 0.05 m: the same the planner's tasks end at). It cannot plan round an
obstacle, only bounce off its edge: with nothing remembered, turning back towards the
goal brings the obstacle back into view.

>>> from planner import load_scenario
>>> from runtime.robots.sim import SimRobot
>>> scene = load_scenario("open")
>>> ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(60).state
'GOAL_REACHED'
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from formal.geometry import compose, dead_reckon, points_from_frame, relative
from formal.model import Pose
from planner.perception import validate_scan
from planner.robot import RobotModel
from runtime.clock import Clock, clock_for
from runtime.estimation.odometry import ScanOdometry
from runtime.robot import Robot, RobotFault, ScanFrame, finite_goal

__all__ = ["ReactiveController", "ReactiveReport"]


@dataclass
class ReactiveReport:
    """The outcome of :meth:`ReactiveController.run`.

    ``state`` is ``"GOAL_REACHED"``, ``"TIMEOUT"`` or ``"HALTED"`` (a fault); ``avoid_ticks``
    counts the ticks spent turning away from a disturbance.

    >>> from planner import load_scenario
    >>> from runtime.robots.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> report = ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=60)
    >>> report.state, report.avoid_ticks
    ('GOAL_REACHED', 0)
    """

    state: str
    reason: str
    time_s: float
    trajectory: list[tuple[float, float, float, float]]
    goal: tuple[float, float]
    avoid_ticks: int

    @property
    def reached_goal(self) -> bool:
        """True when the loop ended at the goal."""
        return self.state == "GOAL_REACHED"


class ReactiveController:
    """Drive to ``goal`` (robot frame at start) with one closed loop; see the module docstring.

    >>> from planner import load_scenario
    >>> from runtime.robots.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=60).state
    'GOAL_REACHED'
    """

    def __init__(
        self,
        robot: Robot,
        goal: tuple[float, float],
        model: RobotModel | None = None,
        *,
        clock: Clock | None = None,
        goal_radius: float | None = None,
        look_ahead: float | None = None,
        gain: float = 1.5,
        hazard_points: int = 2,
        scan_timeout: float = 1.0,
        feedback: str = "scan",
    ) -> None:
        if feedback not in ("scan", "none"):
            raise ValueError(f"feedback must be 'scan' or 'none', got {feedback!r}")
        self.robot = robot
        self.model = model or RobotModel()
        self.clock: Clock = clock_for(robot, clock)
        self.goal_radius = self.model.goal_tolerance if goal_radius is None else float(goal_radius)
        self.look_ahead = float(look_ahead if look_ahead is not None else (self.model.step_length or self.model.length))
        for name, v in (("goal_radius", self.goal_radius), ("look_ahead", self.look_ahead), ("gain", gain)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if hazard_points < 1:
            raise ValueError(f"hazard_points must be at least 1, got {hazard_points!r}")
        self.gain = float(gain)
        self.hazard_points = int(hazard_points)
        self.scan_timeout = scan_timeout
        self._goal_robot = finite_goal(goal)
        self.pose = Pose(0.0, 0.0, 0.0)
        self.goal = Pose(*self._goal_robot)
        self.trajectory: list[tuple[float, float, float, float]] = []
        self.avoid_ticks = 0
        self._avoid_dir = 0.0  # +1 turning left, -1 right, 0 not avoiding
        self._cmd = (0.0, 0.0)
        self._scan = np.zeros((0, 2))
        self._scan_pose = self.pose
        self.feedback = feedback
        self.estimator: ScanOdometry | None = ScanOdometry(self.model.wheel_base) if feedback == "scan" else None

    def run(self, max_time: float = 120.0) -> ReactiveReport:
        """Loop until the goal, a fault (→ HALTED) or ``max_time`` s (→ TIMEOUT); wheels stopped on exit.

        ValueError for a ``max_time`` that is NaN (it would never end the run) or not positive."""
        if not max_time > 0:
            raise ValueError(f"max_time must be a positive number of seconds, got {max_time!r}")
        tick = self.model.tick
        t0 = self.clock.now()
        last = t0
        last_scan = t0
        odo = self.robot.odometry()
        self.pose = odo if odo is not None else Pose(0.0, 0.0, 0.0)
        if self.estimator is not None:
            self.estimator.reset(self.pose, t0)
            self.estimator.advance(t0, (0.0, 0.0), odo)
        self.goal = compose(self.pose, Pose(*self._goal_robot))
        state, reason = "TIMEOUT", f"time limit of {max_time:g} s reached"
        try:
            while True:
                now = self.clock.now()
                self._dead_reckon(now, now - last)
                last = now
                self.trajectory.append((now - t0, self.pose.x, self.pose.y, self.pose.theta))
                if now - t0 >= max_time:
                    break
                frame = self.robot.read_scan(timeout=0.0)
                if frame is not None:
                    self._take_scan(frame, now)
                    last_scan = now
                elif now - last_scan > self.scan_timeout:
                    raise RobotFault(f"sensor silent: no scan for {now - last_scan:.2f} s")
                g = relative(self.pose, self.goal)
                if math.hypot(g.x, g.y) <= self.goal_radius:
                    state, reason = "GOAL_REACHED", f"at the goal ({math.hypot(g.x, g.y):.3f} m)"
                    break
                vl, vr = self._control(g)
                self.robot.set_wheel_speeds(vl, vr)
                self._cmd = (vl, vr)
                self.clock.sleep(now + tick - self.clock.now())
        except KeyboardInterrupt:
            self._stop()
            raise
        except Exception as exc:
            state, reason = "HALTED", f"{type(exc).__name__}: {exc}"
        finally:
            self._stop()
        return ReactiveReport(state, reason, last - t0, list(self.trajectory), (self.goal.x, self.goal.y), self.avoid_ticks)

    # -- the loop ---------------------------------------------------------------------------
    def _control(self, g: Pose) -> tuple[float, float]:
        m = self.model
        spin = m.turn_wheel_speed
        nearest_y = self._disturbance_ahead()
        if nearest_y is not None:
            if self._avoid_dir == 0.0:  # turn away from the nearest point, and keep to it until clear
                self._avoid_dir = -1.0 if nearest_y > 0 else 1.0
            self.avoid_ticks += 1
            return (-spin, spin) if self._avoid_dir > 0 else (spin, -spin)
        self._avoid_dir = 0.0
        bearing = math.atan2(g.y, g.x)
        if abs(bearing) > math.radians(60):
            return (-spin, spin) if bearing > 0 else (spin, -spin)
        v = min(m.straight_speed, math.hypot(g.x, g.y) / m.tick)
        w = max(-m.turn_rate, min(m.turn_rate, self.gain * bearing))
        return (v - w * m.wheel_base / 2, v + w * m.wheel_base / 2)

    def _disturbance_ahead(self) -> float | None:
        """Lateral position (m, left +) of the nearest scan point in the body's corridor one
        straight step ahead, or None when fewer than ``hazard_points`` points are there."""
        if len(self._scan) == 0:
            return None
        m = self.model
        pts = points_from_frame(self._scan, relative(self.pose, self._scan_pose))
        x, y = pts[:, 0], pts[:, 1]
        inside = (x > m.front_offset) & (x <= m.front_offset + self.look_ahead) & (np.abs(y) <= m.width / 2 + m.clearance)
        if int(inside.sum()) < self.hazard_points:
            return None
        xi, yi = x[inside], y[inside]
        return float(yi[int(np.argmin(np.hypot(xi, yi)))])

    def _dead_reckon(self, now: float, dt: float) -> None:
        odo = self.robot.odometry()
        if self.estimator is not None:
            self.estimator.advance(now, self._cmd, odo)
            self.pose = self.estimator.pose
            return
        self.pose = odo if odo is not None else dead_reckon(self.pose, *self._cmd, self.model.wheel_base, dt)

    def _take_scan(self, frame: ScanFrame, now: float) -> None:
        """Keep the newest revolution (and, with scan feedback, correct the estimate by it,
        as the supervisor does: a de-skewed revolution is kept at the pose of its timestamp)."""
        scan = validate_scan(frame.points, "scan")
        if self.estimator is None:
            self._scan, self._scan_pose = scan, self.pose
            return
        if not (now - 1.0 <= frame.timestamp <= now + 1e-6):  # another clock: take it as now
            frame = dataclasses.replace(frame, timestamp=now)
        self.estimator.update(dataclasses.replace(frame, points=scan))
        self.pose = self.estimator.pose
        if frame.point_times is not None:
            self._scan, self._scan_pose = self.estimator.last_points, self.estimator.pose_at(frame.timestamp)
        else:
            self._scan, self._scan_pose = scan, self.pose

    def _stop(self) -> None:
        self._cmd = (0.0, 0.0)
        try:
            self.robot.stop()
        except Exception:  # the device may be gone: nothing more to do
            pass
