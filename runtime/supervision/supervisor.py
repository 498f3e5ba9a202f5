"""The supervisor: executes the Configurator's plans closed-loop on a robot and replans.

It follows the state machine of :mod:`runtime.supervision.machine` (IDLE → PLANNING →
EXECUTING ⇄ REPLANNING → GOAL_REACHED / UNREACHABLE, any → HALTED on a fault or abort).

Each control tick (:meth:`Supervisor.step`) reads the newest scan, updates the pose
estimate (the backend's odometry when it has one, else dead reckoning from the commanded
wheel speeds) and acts on the state:

- PLANNING / REPLANNING: with the wheels stopped, wait for a scan taken after the stop,
  plan from it to the goal seen from the pose estimate (the planner's frame is the robot
  at that moment), queue the plan's tasks in the supervisor's frame and start the first.
- EXECUTING: run the current task as a closed loop (:class:`planner.tasks.Task`): its
  error signal comes from the pose estimate and the goal in the supervisor's frame, and
  it ends by its own end criterion. A task may start only over a transition of the map
  that the guard Ψ enables. The task is interrupted (→ REPLANNING) when the newest scan
  puts a point in the body's path (an obstacle in the way, or a collision imminent within
  ``lookahead`` s), or when it ends far from where the map predicted; a plan that ends
  short of the goal is followed by a new one.
- any exception (a device fault, a silent sensor, a scan with NaN, a planner crash) →
  HALTED with the wheels stopped in the same tick. The wheels turn only in EXECUTING,
  and :meth:`Supervisor.run` stops them on every exit path (also Ctrl-C).

The goal is unreachable (→ UNREACHABLE, wheels stopped) when the planner finds no safe
task that leads closer to it, when ``patience`` plans in a row bring the robot no closer,
or after ``max_plans`` plans.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from formal.model import Disturbance, Pose, State, TaskKind
from planner.configurator import Configurator, PlanningError, PlanResult
from planner.perception import validate_scan
from planner.physics import make_task
from planner.robot import RobotModel
from formal.geometry import compose, dead_reckon, points_from_frame, points_to_frame, relative, wrap_angle
from planner.tasks import Task
from runtime.clock import Clock, clock_for
from runtime.records.runlog import RunLogLike, plan_fields
from runtime.robot import Robot, RobotFault, finite_goal
from runtime.supervision.machine import (
    MOTOR_STATES,
    TERMINAL,
    TRANSITIONS,
    Event,
    SupervisorState,
    TransitionRecord,
)

__all__ = [
    "GuardViolation",
    "PlanRecord",
    "Supervisor",
    "SupervisorReport",
    "TaskRecord",
]


S, E = SupervisorState, Event


class GuardViolation(RuntimeError):
    """A task was about to start over a transition the guard Ψ does not enable."""


def _points_to_frame(points: np.ndarray, source: Pose, target: Pose) -> np.ndarray:
    """Points in the frame of a robot at ``source`` → the frame of a robot at ``target``."""
    if len(points) == 0:
        return points
    return points_from_frame(points, relative(target, source))


# -- records ------------------------------------------------------------------------------
@dataclass(frozen=True)
class PlanRecord:
    """One plan: when, from which pose estimate (the planner frame's origin), and what."""

    time: float
    origin: Pose
    result: PlanResult

    def to_frame(self, p: Pose) -> Pose:
        """A pose of the plan (planner frame) in the supervisor's frame."""
        return compose(self.origin, p)


@dataclass
class TaskRecord:
    """One task the supervisor started: its plan step, the guard's verdict and its run."""

    plan_index: int
    state: State
    transition: tuple[int, int]
    psi: int
    start_time: float
    start_pose: Pose
    predicted_end: Pose
    end_time: float | None = None
    end_pose: Pose | None = None
    outcome: str = "running"


@dataclass
class SupervisorReport:
    """The outcome of :meth:`Supervisor.run`.

    >>> SupervisorReport(SupervisorState.HALTED, "LiDAR unplugged", 1.5, [], [], [], [], (1.0, 0.0)).reached_goal
    False
    """

    state: SupervisorState
    reason: str
    time_s: float
    plans: list[PlanRecord]
    tasks: list[TaskRecord]
    transitions: list[TransitionRecord]
    trajectory: list[tuple[float, float, float, float]]
    goal: tuple[float, float]

    @property
    def reached_goal(self) -> bool:
        """True when the supervisor ended in GOAL_REACHED."""
        return self.state is S.GOAL_REACHED

    @property
    def replans(self) -> int:
        """Plans made after the first."""
        return max(0, len(self.plans) - 1)


# -- the supervisor -------------------------------------------------------------------------
class Supervisor:
    """Runs plans of a :class:`~planner.Configurator` closed-loop on a :class:`~runtime.robot.Robot`.

    ``goal`` is (x, y) in the robot's frame at start (x forward, y left). ``clock``
    defaults to the robot itself when it keeps (simulated) time, else the wall clock.

    >>> from planner import load_scenario
    >>> from runtime.robots.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> report = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=60)
    >>> report.state.value, report.replans
    ('GOAL_REACHED', 0)
    """

    def __init__(
        self,
        robot: Robot,
        goal: tuple[float, float],
        configurator: Configurator | None = None,
        *,
        clock: Clock | None = None,
        goal_radius: float = 0.08,
        scan_timeout: float = 1.0,
        max_plans: int = 30,
        patience: int = 3,
        min_progress: float = 0.03,
        end_tolerance: tuple[float, float] = (0.08, 0.3),
        lookahead: float = 0.5,
        hazard_points: int = 2,
        settle_scans: int = 2,
        log: RunLogLike | None = None,
    ) -> None:
        gx, gy = finite_goal(goal)
        self.robot = robot
        self.configurator = configurator or Configurator()
        self.model: RobotModel = self.configurator.robot
        self.clock: Clock = clock_for(robot, clock)
        self.goal_radius = goal_radius
        self.scan_timeout = scan_timeout
        self.max_plans = max_plans
        self.patience = patience
        self.min_progress = min_progress
        self.end_tolerance = end_tolerance
        self.lookahead = lookahead
        self.hazard_points = hazard_points
        self.settle_scans = settle_scans
        self._goal_robot = (gx, gy)
        self.log = log

        self.state = S.IDLE
        self.reason = ""
        self.transitions: list[TransitionRecord] = []
        self.plans: list[PlanRecord] = []
        self.tasks: list[TaskRecord] = []
        self.trajectory: list[tuple[float, float, float, float]] = []
        self.pose = Pose(0.0, 0.0, 0.0)
        self.goal = Pose(gx, gy)
        self._cmd = (0.0, 0.0)
        self._t0: float | None = None
        self._last_update = 0.0
        self._last_scan_at = 0.0
        self._scan: np.ndarray | None = None
        self._clean_scan: np.ndarray | None = None
        self._scan_pose = self.pose
        self._turned = False
        self._scans_since_stop = 0
        self._moved = False
        self._queue: deque[tuple[State, tuple[int, int]]] = deque()
        self._task: Task | None = None
        self._record: TaskRecord | None = None
        self._plan: PlanRecord | None = None
        self._best = math.inf
        self._stalled = 0

    # -- public -------------------------------------------------------------------------------
    @property
    def terminal(self) -> bool:
        """True in GOAL_REACHED, UNREACHABLE or HALTED."""
        return self.state in TERMINAL

    @property
    def commanded(self) -> tuple[float, float]:
        """The wheel speeds the supervisor last commanded ((0, 0) once stopped)."""
        return self._cmd

    def goal_in_robot_frame(self) -> tuple[float, float]:
        """The goal seen from the current pose estimate (x forward, y left)."""
        g = relative(self.pose, self.goal)
        return g.x, g.y

    def start(self) -> None:
        """IDLE → PLANNING: fix the supervisor's frame at the robot's present pose."""
        if self.state is not S.IDLE:
            return
        now = self.clock.now()
        self._t0 = now
        self._last_update = now
        self._last_scan_at = now
        odo = self.robot.odometry()
        self.pose = odo if odo is not None else Pose(0.0, 0.0, 0.0)
        self.goal = compose(self.pose, Pose(*self._goal_robot))
        self._log("start", goal=[self.goal.x, self.goal.y], robot=self.model.to_dict())
        self._fire(E.START, "started")

    def step(self) -> SupervisorState:
        """Run one control tick; never raises except KeyboardInterrupt (after halting)."""
        if self.terminal:
            return self.state
        try:
            if self.state is S.IDLE:
                self.start()
            self._tick()
        except KeyboardInterrupt as exc:
            # a signal handler may say which signal it was (clomp run raises
            # KeyboardInterrupt("interrupted by SIGINT")): that reason goes in the log
            self.abort(str(exc) or "interrupted")
            raise
        except Exception as exc:  # every other failure is a fault: halt, wheels stopped
            self.fault(f"{type(exc).__name__}: {exc}")
        return self.state

    def fault(self, reason: str) -> None:
        """Any non-terminal state → HALTED, wheels stopped now."""
        self._halt(E.FAULT, reason)

    def abort(self, reason: str = "aborted") -> None:
        """Stop on request (Ctrl-C, a time limit): → HALTED, wheels stopped now."""
        self._halt(E.ABORT, reason)

    def run(self, max_time: float | None = None) -> SupervisorReport:
        """Tick until a terminal state (or ``max_time`` s of clock time → HALTED)."""
        tick = self.model.tick
        try:
            t_start = self.clock.now()
            while not self.terminal:
                t = self.clock.now()
                if max_time is not None and t - t_start >= max_time:
                    self.abort(f"time limit of {max_time:g} s reached")
                    break
                self.step()
                if self.terminal:
                    break
                self.clock.sleep(t + tick - self.clock.now())
        finally:
            self._stop_wheels()
        return self.report()

    def report(self) -> SupervisorReport:
        """What happened so far."""
        t = 0.0 if self._t0 is None else self._last_update - self._t0
        return SupervisorReport(
            self.state,
            self.reason,
            t,
            list(self.plans),
            list(self.tasks),
            list(self.transitions),
            list(self.trajectory),
            (self.goal.x, self.goal.y),
        )

    # -- machinery -------------------------------------------------------------------------------
    def _fire(self, event: Event, reason: str) -> None:
        target = TRANSITIONS.get((self.state, event))
        if target is None:
            raise RuntimeError(f"no transition from {self.state.value} on {event.value}")
        source = self.state
        if source in MOTOR_STATES and target not in MOTOR_STATES:  # formal.machine: where wheels may turn
            self._stop_wheels()
            self._scans_since_stop = 0
            self._end_task(reason if event is not E.NEXT_TASK else "done")
            self._queue.clear()
        self.state = target
        self.reason = reason
        self.transitions.append(TransitionRecord(self._now(), source, event, target, reason))
        if source is not target:
            self._log("state", **{"from": source.value, "to": target.value, "trigger": event.value, "reason": reason})
        if event is E.FAULT:
            self._log("fault", reason=reason)
        if target in TERMINAL:
            self._log("stop", reason=reason, status=target.value)

    def _halt(self, event: Event, reason: str) -> None:
        self._stop_wheels()
        if self.terminal:
            return
        if self._record is not None:
            self._end_task(reason)
        self._queue.clear()
        self._fire(event, reason)

    def _stop_wheels(self) -> None:
        self._cmd = (0.0, 0.0)
        try:
            self.robot.stop()
        except Exception as exc:  # the device may be gone; the state still says stopped
            self.reason = f"{self.reason}; stop failed: {type(exc).__name__}: {exc}" if self.reason else str(exc)

    def _log(self, event: str, **fields: Any) -> None:
        if self.log is None:
            return
        try:
            self.log.write(event, **fields)
        except Exception:  # a full disk must not stop the robot's safety logic
            self.log = None

    def _now(self) -> float:
        try:
            return self.clock.now() - (self._t0 or 0.0)
        except Exception:  # pragma: no cover - a clock that fails still lets us record
            return math.nan

    def _tick(self) -> None:
        now = self.clock.now()
        self._update_pose(now)
        frame = self.robot.read_scan(timeout=0.0)
        if frame is not None:
            self._scan = validate_scan(frame.points, "scan")
            if self.log is not None:
                g = relative(self.pose, self.goal)
                self._log("scan", points=self._scan, goal=[g.x, g.y], pose=self.pose.as_list())
            self._last_scan_at = now
            self._scans_since_stop += 1
            if not self._turned:
                # a revolution taken while the robot turned is smeared: keep the last clean one
                self._clean_scan, self._scan_pose = self._scan, self.pose
            self._turned = self._turning()
        elif now - self._last_scan_at > self.scan_timeout:
            raise RobotFault(f"sensor silent: no scan for {now - self._last_scan_at:.2f} s")
        if self.state in (S.PLANNING, S.REPLANNING):
            self._plan_tick(now)
        elif self.state is S.EXECUTING:
            self._execute_tick(now)
        self.trajectory.append((now - (self._t0 or 0.0), self.pose.x, self.pose.y, self.pose.theta))

    def _update_pose(self, now: float) -> None:
        dt = now - self._last_update
        self._last_update = now
        odo = self.robot.odometry()
        self.pose = odo if odo is not None else dead_reckon(self.pose, *self._cmd, self.model.wheel_base, dt)

    # -- planning ---------------------------------------------------------------------------------
    def _plan_tick(self, now: float) -> None:
        need = self.settle_scans if self._moved else 1
        if self._scan is None or self._scans_since_stop < need:
            return  # wait for a scan taken with the wheels stopped
        g = relative(self.pose, self.goal)
        dist = math.hypot(g.x, g.y)
        if dist <= self.goal_radius:
            self._fire(E.AT_GOAL, f"at the goal ({dist:.3f} m)")
            return
        if len(self.plans) >= self.max_plans:
            self._fire(E.NO_PLAN, f"gave up after {len(self.plans)} plans")
            return
        try:
            result = self.configurator.plan(self._scan, (g.x, g.y))
        except PlanningError as exc:
            self._fire(E.NO_PLAN, f"goal unreachable: {exc}")
            return
        rec = PlanRecord(now - (self._t0 or 0.0), self.pose, result)
        self.plans.append(rec)
        if self.log is not None:
            self._log("plan", **plan_fields(result, rec.origin))
        if not result.steps:
            self._fire(E.NO_PLAN, "goal unreachable: no safe task leads closer to the goal")
            return
        end = result.map[result.plan.end].end
        predicted = end.distance_to(result.goal.x, result.goal.y)
        if result.reached_goal or min(dist, predicted) < self._best - self.min_progress:
            self._stalled = 0
        else:
            self._stalled += 1
            if self._stalled >= self.patience:
                self._fire(E.NO_PLAN, f"goal unreachable: {self._stalled} plans in a row brought it no closer")
                return
        self._best = min(self._best, dist, predicted)
        self._plan = rec
        states = result.plan.states
        self._queue = deque((result.map[t], (s, t)) for s, t in zip(states, states[1:]))
        self._fire(E.PLANNED, f"plan {len(self.plans)}: {len(result.steps)} tasks, {result.states} states")
        self._execute_tick(now)

    # -- execution ----------------------------------------------------------------------------------
    def _start_next(self, now: float) -> bool:
        if not self._queue:
            return False
        assert self._plan is not None
        q, step = self._queue.popleft()
        result = self._plan.result
        psi = max((v for t, v in result.psi.items() if (t.source, t.target) == step), default=0)
        if psi != 1:
            raise GuardViolation(f"Ψ(q{step[0]} ↪ q{step[1]}) = {psi}: the plan does not enable this task")
        goal_d = Disturbance.goal(self.goal.x, self.goal.y)
        predicted_end = self._plan.to_frame(q.end)
        if q.task is TaskKind.STRAIGHT:
            # drive what the map planned: a straight cut at the rim of the sensed disc (a
            # frontier) must not run on into unseen space
            limit = q.distance if q.distance > 0 else make_task(q.task, result.obstacles, self.model, q.start, result.goal).limit
            task = Task.straight(self.model, self.pose, goal_d, limit)
        else:
            turn = wrap_angle(predicted_end.theta - self.pose.theta)
            angle = turn if q.task is TaskKind.LEFT else -turn
            if angle < -math.pi / 2:  # wrapped: a turn of nearly pi
                angle += 2 * math.pi
            task = Task.turn(self.model, q.task, self.pose, goal_d, min(max(angle, 0.0), math.pi))
        self._task = task
        self._task_ticks = 0
        self._record = TaskRecord(len(self.plans) - 1, q, step, psi, now - (self._t0 or 0.0), self.pose, predicted_end)
        self.tasks.append(self._record)
        self._log("task", task=q.task.value, phase="start", pose=self.pose.as_list())
        return True

    def _end_task(self, outcome: str) -> None:
        if self._record is not None and self._record.end_time is None:
            self._record.end_time = self._now()
            self._record.end_pose = self.pose
            self._record.outcome = outcome
            phase = "end" if outcome == "done" else "interrupted"
            self._log("task", task=self._record.state.task.value, phase=phase, pose=self.pose.as_list(), reason=outcome)
        self._record = None
        self._task = None

    def _execute_tick(self, now: float) -> None:
        if self._task is None and not self._start_next(now):
            self._plan_ended()
            return
        task = self._task
        assert task is not None and self._record is not None
        e = task.error(self.pose)
        if task.done(e):
            off = self._end_error(self._record.predicted_end)
            if off is not None:
                self._fire(E.DISAGREE, f"task ended far from the map's prediction ({off})")
                return
            self._end_task("done")
            if not self._start_next(now):
                self._plan_ended()
                return
            self._fire(E.NEXT_TASK, f"next task {self._task.kind.value}")  # type: ignore[union-attr]
            task = self._task
            assert task is not None
            e = task.error(self.pose)
        hazard = self._hazard(task, e)
        if hazard is not None:
            self._fire(E.DISAGREE, hazard)
            return
        self._task_ticks += 1
        if self._task_ticks > 2 * task.max_ticks() + 10:
            self._fire(E.DISAGREE, "task overran its expected duration")
            return
        vl, vr = task.wheel_speeds(e)
        if self.state not in MOTOR_STATES:  # the machine's table forbids the wheels here
            raise GuardViolation(f"the wheels may not turn in {self.state.value}")
        self.robot.set_wheel_speeds(vl, vr)
        if self.log is not None and (vl, vr) != self._cmd:
            self._log("motor", left=vl, right=vr)
        self._cmd = (vl, vr)
        self._turned = self._turned or self._turning()
        if vl != 0 or vr != 0:
            self._moved = True

    def _turning(self) -> bool:
        vl, vr = self._cmd
        return abs(vr - vl) > 1e-9

    def _plan_ended(self) -> None:
        g = relative(self.pose, self.goal)
        dist = math.hypot(g.x, g.y)
        if dist <= self.goal_radius:
            self._fire(E.AT_GOAL, f"plan done at the goal ({dist:.3f} m)")
        else:
            self._fire(E.PLAN_SHORT, f"plan done {dist:.3f} m short of the goal")

    def _end_error(self, predicted: Pose) -> str | None:
        d = self.pose.distance_to(predicted.x, predicted.y)
        a = abs(wrap_angle(self.pose.theta - predicted.theta))
        if d > self.end_tolerance[0] or a > self.end_tolerance[1]:
            return f"{d:.3f} m, {math.degrees(a):.0f}° off"
        return None

    def _hazard(self, task: Task, error: float) -> str | None:
        """A reason to interrupt when the newest scan has points in the body's remaining path."""
        if self._clean_scan is None or len(self._clean_scan) == 0:
            return None
        pts = _points_to_frame(self._clean_scan, self._scan_pose, self.pose)
        m = self.model
        near = np.hypot(pts[:, 0], pts[:, 1]) <= m.length + error + 0.05
        pts = pts[near]
        if len(pts) == 0:
            return None
        poses = _sweep(task.kind, error)
        soon = _sweep(task.kind, min(error, (m.straight_speed if task.kind is TaskKind.STRAIGHT else m.turn_rate) * self.lookahead))
        if _hits(pts, soon, m) >= self.hazard_points:
            return "collision imminent: the scan shows an obstacle against the body's next move"
        if _hits(pts, poses, m) >= self.hazard_points:
            return "an obstacle the plan did not predict is in the way"
        if self._queue and self._plan is not None:
            return self._plan_hazard(pts)
        return None

    def _plan_hazard(self, pts: np.ndarray) -> str | None:
        """Check the tasks still queued against the newest scan (points in the robot frame)."""
        assert self._plan is not None
        m = self.model
        world = _points_to_frame(pts, self.pose, Pose(0.0, 0.0, 0.0))  # → the supervisor's frame
        for k, (q, _step) in enumerate(self._queue, 1):
            a, b = self._plan.to_frame(q.start), self._plan.to_frame(q.end)
            amount = a.distance_to(b.x, b.y) if q.task is TaskKind.STRAIGHT else abs(wrap_angle(b.theta - a.theta))
            local = _sweep(q.task, amount)
            rel = _points_to_frame(world, Pose(0.0, 0.0, 0.0), a)
            if _hits(rel, local, m) >= self.hazard_points:
                return f"an obstacle the plan did not predict is in the way of the task {k} ahead ({q.task.value})"
        return None


def _sweep(kind: TaskKind, amount: float) -> np.ndarray:
    """Sample poses (x, y, theta; current robot frame) of the remaining motion of a task."""
    if kind is TaskKind.STRAIGHT:
        n = max(2, int(math.ceil(amount / 0.02)) + 1)
        xs = np.linspace(0.0, max(amount, 0.0), n)
        line: np.ndarray = np.c_[xs, np.zeros(n), np.zeros(n)]
        return line
    n = max(2, int(math.ceil(amount / math.radians(5))) + 1)
    th = np.linspace(0.0, max(amount, 0.0), n) * (1 if kind is TaskKind.LEFT else -1)
    spin: np.ndarray = np.c_[np.zeros(n), np.zeros(n), th]
    return spin


def _hits(points: np.ndarray, poses: np.ndarray, m: RobotModel) -> int:
    """How many points lie inside the (uninflated) body at any of ``poses``."""
    inside = np.zeros(len(points), dtype=bool)
    for x, y, th in poses:
        local = points_to_frame(points, (x, y, th))
        u, v = local[:, 0], local[:, 1]
        inside |= (u >= -m.rear_offset) & (u <= m.front_offset) & (np.abs(v) <= m.width / 2)
    return int(inside.sum())
