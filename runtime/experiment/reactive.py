"""The paper's baseline: one closed-loop controller with one-loop-ahead disturbance detection.

The paper contrasts planning with "a reactive control strategy which uses a single
closed-loop controller", drawn in its figure 3B as "one-loop-ahead disturbance
detection"; it "never reached the target" and "collided 8 times" in 10 runs. The paper
describes it no further, so this follows the authors' public code for that condition
(``glafratta/collision-simulation``: ``reactive_target.cpp`` runs the Configurator with
``planning = 0``, as ``target.cpp`` does with its no-planning option from 2024-10-09; the
loop is ``Configurator::Spawner``'s non-planning branch, ``Configurator::changeTask``'s
``else`` branch and ``Task::H``; state of October 2024),
on the same :class:`~clomp.runtime.interface.Robot` interface as the supervisor, with no plan and
no map. The repository's README names the tasks: "go straight, turn left/right 90
degrees". One task runs at a time:

- **straight** (the default task): drives at the straight task's speed (0.1 m/s) for one
  step, ``step_length`` = 0.27 m (the Configurator's ``simulationStep``, twice the body's
  larger half-size; ``motorStep`` counts it out). While it runs, every tick looks *one
  loop ahead*: one step of the straight, ``look_ahead`` = ``step_length`` by default, or
  less when the goal is nearer, through the body's corridor —
  ``front_offset < x <= front_offset + min(goal distance, look_ahead)``,
  ``|y| <= width / 2 + clearance``. (``simulate`` passes ``simulationStep`` to
  ``Task::willCollide``, which ends the simulated straight once it has covered that
  distance, or the goal's distance in time; ``target.cpp``, the planning and reactive
  runs of October 2024, sets it to 0.27 m, ``reactive_target.cpp`` to 0.27 m or 0.5 m.
  ``BOX2DRANGE`` = 1 m, :data:`WINDOW`, only bounds the simulated world.)
  ``hazard_points`` (2) or more scan points there are a predicted crash (ours: a single
  point may be noise), and the task changes at once;
- **avoid**: a crash predicted → a turn in place of ``turn_angle`` = 90° (``SAFE_ANGLE``)
  at the turn tasks' rate (0.58 rad/s), chosen by ``Task::H`` from the angle of the
  crashed-into body (here the centre of the corridor points' lateral extent). As their
  code ran, that angle is never negative (below), so the turn is always to the *right*,
  whichever side the obstacle is on; ``sides="signed"`` turns away from it, as their
  comments meant. A turn runs to its end without looking (``Spawner`` returns while a
  turn is under way): the rectangular body swings its rear, 0.18 m behind the axle,
  through whatever is beside it;
- after any turn, one **straight** step (``changeTask``: after a turn, a default task
  with no disturbance);
- after a straight step ends, **pursue** the goal (``changeTask``: the goal task; the
  goal is a disturbance on the same loop): more than 0.1 rad off the heading (``Task::H``'s
  dead band) → a 90° turn, then a straight step; otherwise another straight step. The
  run starts with this choice. As their code ran, the turn is always to the *left*
  (towards the goal with ``sides="signed"``).

So it steers only in quarter turns: it cannot curve onto the goal, and it re-aims only
after each 0.27 m step. A turn ends where the pose estimate has turned 90° and a step
where it has moved 0.27 m, or either after three times its nominal duration (the authors
count motor callbacks, open loop; with ``feedback="none"`` the estimate is that count). It stops when it believes it is within
``goal_radius`` of the goal (the model's goal tolerance, 0.05 m, where the planning
condition's tasks end; the authors' is 0.02 m for both conditions).

Where this departs from the authors' code, and why:

- None in ``Task::H``'s sides: ``Disturbance::getAngle`` returns ``acos(...)``, never
  negative, in every version of their code from May 2024 on, the runs of October 2024
  included. So ``Task::H`` avoids to the right and pursues to the left whatever the
  side; the paper's reactive figures come from that loop, and it is the default
  (``sides="as-coded"``). The code's comments ("If the angle >0 means that Disturbance 1
  is to the left") say a sign was meant: ``sides="signed"`` is that loop, for probes.
- ``detect=False`` is their code before 2024-10-09 (commit 3fa42f0, "fixed reactive
  test"; the same day ``target.cpp`` got its no-planning option), whose reactive branch
  simulated the task in a world with no bodies, so it never predicted a crash: a blind
  pursuer.
- Their goal task also ends once the robot is 1 m (``BOX2DRANGE``) from where it started,
  and ``reactive_target.cpp``'s ``set_target`` then returns no value; neither is copied.
- Pose: as the planning condition's supervisor (the same robot, sensing and estimate, so
  a difference between the conditions is planning's): with ``feedback="scan"`` (the
  default) dead reckoning from the commanded wheel speeds (or the robot's odometry), the
  heading from the robot's gyro when it has one (it then stands ``start_still`` s first, as
  the planning robot stands for its first scans, so that the gyro's offset is measured),
  corrected once a revolution by matching the scan against a local map
  (:class:`~clomp.runtime.estimation.odometry.ScanOdometry`); with ``feedback="none"`` dead
  reckoning alone (the authors' reactive dead-reckons). The newest (de-skewed) scan is
  moved into the body frame each tick.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> scene = load_scenario("open")
>>> ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(60).state
'GOAL_REACHED'
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from clomp.formal.geometry import compose, dead_reckon, points_from_frame, relative, wrap_angle
from clomp.formal.model import Pose
from clomp.planner.perception import validate_scan
from clomp.planner.robot_model import RobotModel
from clomp.runtime.clock import Clock, clock_for
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.interface import Robot, RobotFault, ScanFrame, TurnSensing, finite_goal
from clomp.runtime.supervision.sensing import crop_far

__all__ = ["PURSUE_DEAD_BAND", "WINDOW", "ReactiveController", "ReactiveReport"]

WINDOW = 1.0
"""The authors' ``BOX2DRANGE`` (m): the window their simulated world spans; a probe's longest look-ahead."""
PURSUE_DEAD_BAND = 0.1
"""Goal bearing (rad) beyond which the goal task turns towards the goal (``Task::H``)."""


@dataclass
class ReactiveReport:
    """The outcome of :meth:`ReactiveController.run`.

    ``state`` is ``"GOAL_REACHED"``, ``"TIMEOUT"`` or ``"HALTED"`` (a fault); ``avoid_ticks``
    counts the ticks spent turning away from a disturbance; ``tasks`` lists
    ``(time_s, task)`` for each task begun (``"straight"``, ``"left"``, ``"right"``, the
    turns suffixed ``"/avoid"`` or ``"/pursue"``).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> report = ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=60)
    >>> report.state, report.avoid_ticks, report.tasks[0][1]
    ('GOAL_REACHED', 0, 'straight')
    """

    state: str
    reason: str
    time_s: float
    trajectory: list[tuple[float, float, float, float]]
    goal: tuple[float, float]
    avoid_ticks: int
    tasks: list[tuple[float, str]] = dataclasses.field(default_factory=list)

    @property
    def reached_goal(self) -> bool:
        """True when the loop ended at the goal."""
        return self.state == "GOAL_REACHED"


class ReactiveController:
    """Drive to ``goal`` (robot frame at start) with one closed loop; see the module docstring.

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
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
        hazard_points: int = 2,
        scan_timeout: float = 1.0,
        feedback: str = "scan",
        sides: str = "as-coded",
        detect: bool = True,
        start_still: float = 1.0,
    ) -> None:
        if sides not in ("signed", "as-coded"):
            raise ValueError(f"sides must be 'signed' or 'as-coded', got {sides!r}")
        self.sides = sides
        self.detect = bool(detect)
        if feedback not in ("scan", "none"):
            raise ValueError(f"feedback must be 'scan' or 'none', got {feedback!r}")
        self.robot = robot
        self.model = model or RobotModel()
        self.clock: Clock = clock_for(robot, clock)
        self.goal_radius = self.model.goal_tolerance if goal_radius is None else float(goal_radius)
        self.step = float(self.model.step_length or self.model.length)
        self.look_ahead = self.step if look_ahead is None else float(look_ahead)
        for name, v in (("goal_radius", self.goal_radius), ("look_ahead", self.look_ahead)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive finite number, got {v!r}")
        if hazard_points < 1:
            raise ValueError(f"hazard_points must be at least 1, got {hazard_points!r}")
        self.hazard_points = int(hazard_points)
        self.scan_timeout = scan_timeout
        self._goal_robot = finite_goal(goal)
        self.pose = Pose(0.0, 0.0, 0.0)
        self.goal = Pose(*self._goal_robot)
        self.trajectory: list[tuple[float, float, float, float]] = []
        self.tasks: list[tuple[float, str]] = []
        self.avoid_ticks = 0
        self._task = "straight"  # "straight", "left" or "right"
        self._avoiding = False
        self._task_start = self.pose
        self._task_ticks = 0
        self._cmd = (0.0, 0.0)
        self._scan = np.zeros((0, 2))
        self._scan_pose = self.pose
        self.feedback = feedback
        self.estimator: ScanOdometry | None = ScanOdometry(self.model.wheel_base) if feedback == "scan" else None
        self._rotation = robot.rotation if isinstance(robot, TurnSensing) else lambda: None  # the same gyro as the planner's
        self.start_still = float(start_still)

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
            self.estimator.advance(t0, (0.0, 0.0), odo, self._rotation())
        self.goal = compose(self.pose, Pose(*self._goal_robot))
        self._t0 = t0
        self._pursue(t0)
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
                if self.estimator is not None and now - t0 < self.start_still and self._rotation() is not None:
                    vl, vr = 0.0, 0.0  # stand while the gyro's offset is measured, as the planning robot does
                else:
                    vl, vr = self._control(g, now)
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
        return ReactiveReport(state, reason, last - t0, list(self.trajectory), (self.goal.x, self.goal.y),
                              self.avoid_ticks, list(self.tasks))

    # -- the loop ---------------------------------------------------------------------------
    def _begin(self, task: str, now: float, why: str = "") -> None:
        self._task, self._avoiding = task, why == "avoid"
        self._task_start, self._task_ticks = self.pose, 0
        self.tasks.append((round(now - self._t0, 9), task + (f"/{why}" if why and task != "straight" else "")))

    def _pursue(self, now: float) -> None:
        """The goal task (``Task::H`` with the goal as disturbance): quarter turn towards it, or straight."""
        g = relative(self.pose, self.goal)
        bearing = math.atan2(g.y, g.x)
        if abs(bearing) > PURSUE_DEAD_BAND:
            self._begin("left" if bearing > 0 or self.sides == "as-coded" else "right", now, "pursue")
        else:
            self._begin("straight", now)

    def _task_done(self) -> bool:
        m = self.model
        if self._task == "straight":
            moved = math.hypot(self.pose.x - self._task_start.x, self.pose.y - self._task_start.y)
            return moved >= self.step - m.straight_speed * m.tick / 2 or self._task_ticks >= 3 * self.step / (m.straight_speed * m.tick)
        turned = abs(wrap_angle(self.pose.theta - self._task_start.theta))
        return turned >= m.turn_angle - m.turn_rate * m.tick / 2 or self._task_ticks >= 3 * m.turn_angle / (m.turn_rate * m.tick)

    def _control(self, g: Pose, now: float) -> tuple[float, float]:
        m = self.model
        if self._task_done():
            if self._task == "straight":
                self._pursue(now)
            else:
                self._begin("straight", now)
        if self._task == "straight":
            side = self._disturbance_ahead(math.hypot(g.x, g.y))
            if side is not None:  # a crash one loop ahead: turn away from it
                self._begin("right" if side > 0 or self.sides == "as-coded" else "left", now, "avoid")
        self._task_ticks += 1
        if self._task == "straight":
            return (m.straight_speed, m.straight_speed)
        if self._avoiding:
            self.avoid_ticks += 1
        spin = m.turn_wheel_speed
        return (-spin, spin) if self._task == "left" else (spin, -spin)

    def _disturbance_ahead(self, goal_distance: float) -> float | None:
        """Lateral centre (m, left +) of the scan points in the body's corridor over the
        straight's next ``look_ahead`` (at most to the goal), or None when fewer than
        ``hazard_points`` points are there."""
        if len(self._scan) == 0 or not self.detect:
            return None
        m = self.model
        reach = min(goal_distance, self.look_ahead)
        pts = points_from_frame(self._scan, relative(self.pose, self._scan_pose))
        x, y = pts[:, 0], pts[:, 1]
        inside = (x > m.front_offset) & (x <= m.front_offset + reach) & (np.abs(y) <= m.width / 2 + m.clearance)
        if int(inside.sum()) < self.hazard_points:
            return None
        yi = y[inside]
        return float((yi.min() + yi.max()) / 2)

    def _dead_reckon(self, now: float, dt: float) -> None:
        odo = self.robot.odometry()
        if self.estimator is not None:
            self.estimator.advance(now, self._cmd, odo, self._rotation())
            self.pose = self.estimator.pose
            return
        self.pose = odo if odo is not None else dead_reckon(self.pose, *self._cmd, self.model.wheel_base, dt)

    def _take_scan(self, frame: ScanFrame, now: float) -> None:
        """Keep the newest revolution (and, with scan feedback, correct the estimate by it,
        as the supervisor does: a de-skewed revolution is kept at the pose of its timestamp)."""
        # returns beyond the sensor range are cropped as the supervisor crops them
        frame, _far = crop_far(dataclasses.replace(frame, points=validate_scan(frame.points, "scan")),
                               self.model.sensor_range)
        scan = frame.points
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
