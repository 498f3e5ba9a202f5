"""The paper's baseline: a single reactive closed loop with one-loop-ahead disturbance detection.

One controller runs for the whole trip, on the same :class:`~runtime.robot.Robot`
interface as the supervisor. Every control tick it reads the newest scan, updates the
pose estimate (odometry, else dead reckoning from the commanded wheel speeds) and
predicts where the body will be one loop ahead (``ahead_ticks`` control ticks of the
motion it is about to command). If scan points fall inside the body there — a
disturbance one loop ahead — it spins in place away from them (to the side with fewer
points) instead; otherwise it drives toward the goal, steering in proportion to the
goal's bearing (spinning towards it first when it lies far off the heading). It has no
map and no memory: it cannot plan around an obstacle, only bounce off its edge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from formal.geometry import compose, relative, wrap_angle
from formal.model import Pose
from planner.perception import validate_scan
from planner.robot import RobotModel
from runtime.robot import Robot, RobotFault
from runtime.clock import Clock, clock_for
from runtime.supervision.supervisor import finite_goal

__all__ = ["ReactiveController", "ReactiveReport"]


@dataclass
class ReactiveReport:
    """The outcome of :meth:`ReactiveController.run`.

    ``state`` is ``"GOAL_REACHED"``, ``"TIMEOUT"`` or ``"HALTED"`` (a fault); ``avoid_ticks``
    counts the ticks spent turning away from a disturbance.
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
    """Drive to ``goal`` (robot frame at start) with one closed loop; see the module docstring."""

    def __init__(
        self,
        robot: Robot,
        goal: tuple[float, float],
        model: RobotModel | None = None,
        *,
        clock: Clock | None = None,
        goal_radius: float = 0.08,
        ahead_ticks: int = 1,
        gain: float = 1.5,
        hazard_points: int = 2,
        scan_timeout: float = 1.0,
    ) -> None:
        self.robot = robot
        self.model = model or RobotModel()
        self.clock: Clock = clock_for(robot, clock)
        self.goal_radius = goal_radius
        self.ahead_ticks = ahead_ticks
        self.gain = gain
        self.hazard_points = hazard_points
        self.scan_timeout = scan_timeout
        self._goal_robot = finite_goal(goal)
        self.pose = Pose(0.0, 0.0, 0.0)
        self.goal = Pose(*self._goal_robot)
        self.trajectory: list[tuple[float, float, float, float]] = []
        self.avoid_ticks = 0
        self._cmd = (0.0, 0.0)
        self._scan = np.zeros((0, 2))
        self._scan_pose = self.pose

    def run(self, max_time: float = 120.0) -> ReactiveReport:
        """Loop until the goal, a fault (→ HALTED) or ``max_time`` s (→ TIMEOUT); wheels stopped on exit."""
        tick = self.model.tick
        t0 = self.clock.now()
        last = t0
        last_scan = t0
        odo = self.robot.odometry()
        self.pose = odo if odo is not None else Pose(0.0, 0.0, 0.0)
        self.goal = compose(self.pose, Pose(*self._goal_robot))
        state, reason = "TIMEOUT", f"time limit of {max_time:g} s reached"
        try:
            while True:
                now = self.clock.now()
                self._dead_reckon(now - last)
                last = now
                self.trajectory.append((now - t0, self.pose.x, self.pose.y, self.pose.theta))
                if now - t0 >= max_time:
                    break
                frame = self.robot.read_scan(timeout=0.0)
                if frame is not None:
                    self._scan = validate_scan(frame.points, "scan")
                    self._scan_pose = self.pose
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
        bearing = math.atan2(g.y, g.x)
        spin = m.turn_wheel_speed
        if abs(bearing) > math.radians(60):
            wheels = (-spin, spin) if bearing > 0 else (spin, -spin)
        else:
            v = min(m.straight_speed, math.hypot(g.x, g.y) / m.tick)
            w = max(-m.turn_rate, min(m.turn_rate, self.gain * bearing))
            wheels = (v - w * m.wheel_base / 2, v + w * m.wheel_base / 2)
        blocked, side = self._disturbance_ahead(wheels)
        if not blocked:
            return wheels
        self.avoid_ticks += 1
        # spin away from the side the disturbance is on
        return (-spin, spin) if side < 0 else (spin, -spin)

    def _disturbance_ahead(self, wheels: tuple[float, float]) -> tuple[bool, float]:
        """(any points inside the body one loop ahead?, mean lateral position of those points)."""
        if len(self._scan) == 0:
            return False, 0.0
        m = self.model
        rel = relative(self.pose, self._scan_pose)
        c, s = math.cos(rel.theta), math.sin(rel.theta)
        pts = np.c_[rel.x + c * self._scan[:, 0] - s * self._scan[:, 1], rel.y + s * self._scan[:, 0] + c * self._scan[:, 1]]
        vl, vr = wheels
        v, w = (vl + vr) / 2, (vr - vl) / m.wheel_base
        dt = self.ahead_ticks * m.tick
        th = w * dt
        x, y = v * dt * math.cos(th / 2), v * dt * math.sin(th / 2)
        ct, st = math.cos(th), math.sin(th)
        dx, dy = pts[:, 0] - x, pts[:, 1] - y
        u, vv = ct * dx + st * dy, -st * dx + ct * dy
        inside = (u >= -m.rear_offset) & (u <= m.front_offset) & (np.abs(vv) <= m.width / 2)
        if int(inside.sum()) < self.hazard_points:
            return False, 0.0
        return True, float(pts[inside, 1].mean())

    def _dead_reckon(self, dt: float) -> None:
        odo = self.robot.odometry()
        if odo is not None:
            self.pose = odo
            return
        vl, vr = self._cmd
        if dt <= 0 or (vl == 0 and vr == 0):
            return
        m = self.model
        v, w = (vl + vr) / 2, (vr - vl) / m.wheel_base
        p = self.pose
        th = p.theta + w * dt / 2
        self.pose = Pose(p.x + v * dt * math.cos(th), p.y + v * dt * math.sin(th), wrap_angle(p.theta + w * dt))

    def _stop(self) -> None:
        self._cmd = (0.0, 0.0)
        try:
            self.robot.stop()
        except Exception:  # the device may be gone: nothing more to do
            pass
