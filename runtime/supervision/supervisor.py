"""The supervisor: executes the Configurator's plans closed-loop on a robot and replans.

It follows the state machine of :mod:`clomp.runtime.supervision.states` (IDLE → PLANNING →
EXECUTING ⇄ REPLANNING → GOAL_REACHED / GOAL_UNCONFIRMED / UNREACHABLE, any → HALTED on a fault
or abort).

Each control tick (:meth:`Supervisor.step`) reads the newest scan, updates the pose
estimate and acts on the state. The estimate (``feedback="scan"``, the default) is
dead reckoning from the commanded wheel speeds (or the backend's odometry) corrected once
a revolution by matching the scan against a local map
(:class:`clomp.runtime.estimation.odometry.ScanOdometry`); ``feedback="none"`` is dead
reckoning alone. The goal, the remaining plan and every task's error signal come from it.

- PLANNING: wheels stopped, plan from the newest scan to the goal seen from the estimate
  (the planner's frame: the robot then), queue the plan's tasks and start the first. At
  the start, with scan feedback, only after ``start_scans`` revolutions: the estimator's
  map, its face compass and the LiDAR's noise are measured on them (the start fixes the
  frame, so what is seen there is the best known; see :mod:`clomp.runtime.estimation.faces`).
- EXECUTING: run the current task as a closed loop (:class:`clomp.planner.tasks.Task`): it ends
  by its own end criterion; a task may start only over a transition of the map that the
  guard Ψ enables. Every tick, a point of the newest scan in the body's path (an obstacle
  in the way, or a collision imminent within ``lookahead`` s) interrupts the task. Every
  revolution, the running task and the queued ones are *checked*: tested against the new
  scan's points from the estimate (:func:`clomp.runtime.supervision.plancheck.check_plan`); one that
  now meets an obstacle or would end off the map's prediction sends the supervisor to
  REPLANNING, and so does a task that ended far from the prediction or a plan that ended
  short of the goal. A plan that ends at the goal by the estimate taken while driving
  goes to REPLANNING too (with scan feedback): the robot stands, the still revolutions
  correct the estimate, and the goal is declared (or approached anew) on the settled one,
  within ``goal_radius`` (default: the planner's goal tolerance, 0.05 m; 0.08 m before).
  A revolution that moves the estimate farther than ``replan_jump`` (a re-localisation
  after a push, a large correction) ends the running task too: it was set from the belief
  before the jump, a changed belief is a new disturbance, and the Configurator plans anew.
- At the goal by the estimate, the estimate must vouch for it (issue #36): GOAL_REACHED
  only when the distance plus the 95 % bound of the position (``vouch_sigmas`` standard
  deviations of :meth:`~clomp.runtime.estimation.odometry.ScanOdometry.position_sd`: the
  filter's covariance with what it cannot see of itself) is within ``vouch_radius``
  (0.1 m); otherwise the run ends GOAL_UNCONFIRMED, the distance and the bound in its
  reason, its report and the log's ``stop`` record (``distance``, ``bound``). The bound has a
  floor after evidence that the robot moved unlike its model (an IMU shock, a revolution
  seeing past the map: :mod:`clomp.runtime.estimation.doubt`) that only a wide search at
  the goal, against the map drawn before it, lowers.
- REPLANNING: after the wheels settled, from ``fuse_scans`` revolutions fused into one
  (median range per bearing), first *recall*: match the situation to a state of the map
  it already has and continue the map's plan from there if the new scan agrees
  (:func:`clomp.runtime.supervision.plancheck.recall`); only when that fails, explore anew
  (at most ``max_recalls`` recalls in a row). A search that spends the configurator's
  budget is run again with ``deepen`` (4) times the budget
  (:func:`clomp.planner.deepening.plan_deepening`): the plan of a spent budget can end
  inside a U-trap. The hazard test, the check and recall are
  :class:`clomp.runtime.supervision.planwatch.PlanWatch`'s.
- any exception (a device fault, a silent sensor, a scan with NaN, a planner crash) →
  HALTED, wheels stopped in the same tick. The wheels turn only in EXECUTING, and
  :meth:`Supervisor.run` stops them on every exit path (also Ctrl-C).

Checks, recalls and fresh plans are kept with their times and logged. UNREACHABLE (wheels
stopped): ``confirm`` plans in a row, each from revolutions taken afresh, find no safe task
(one fused scan at ``harsh`` can put a surface beside the body 2-4 cm into its way);
``patience`` (6) plans in a row bring the robot no closer (with 3, three of ten harsh slalom
runs gave up 5-8 s in, the estimate within 1 cm of the truth); ``max_stuck`` plans in a row
end before it moved at all; or ``max_plans`` fresh plans were made.

The settings named above (``start_scans``, ``patience``, ...) are the fields of one
object, :class:`~clomp.runtime.supervision.config.SupervisorConfig`. The parts, one noun a module:
the state machine (:mod:`~clomp.runtime.supervision.states`), the settings
(:mod:`~clomp.runtime.supervision.config`), the pose estimate and the revolutions kept
(:mod:`~clomp.runtime.supervision.sensing`), the counts behind UNREACHABLE
(:mod:`~clomp.runtime.supervision.progress`), one task's start and end
(:mod:`~clomp.runtime.supervision.execution`), the hazard test, plan check and recall
(:mod:`~clomp.runtime.supervision.planwatch`), REPLANNING's recall and fresh plan
(:mod:`~clomp.runtime.supervision.replanning`), the end at the goal
(:mod:`~clomp.runtime.supervision.goal`) and what is recorded
(:mod:`~clomp.runtime.supervision.records`); this module drives them tick by tick.
"""

from __future__ import annotations

import math
from collections import deque
from typing import Any


from clomp.formal.model import Pose, State, TaskKind
from clomp.planner.configurator import Configurator
from clomp.planner.robot_model import RobotModel
from clomp.formal.geometry import compose, relative, wrap_angle
from clomp.planner.tasks import Task
from clomp.runtime.clock import Clock, clock_for
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.supervision.config import SupervisorConfig
from clomp.runtime.supervision.execution import GuardViolation, end_error, guard, jumped, task_for
from clomp.runtime.supervision.goal import at_goal, confirm_tick, relocated_at_goal
from clomp.runtime.supervision.moving import Appearance, wait_tick
from clomp.runtime.supervision.planwatch import PlanWatch
from clomp.runtime.supervision.pushaway import move_tick, push_tick
from clomp.runtime.supervision.replanning import fresh_plan, recall
from clomp.runtime.supervision.progress import Progress
from clomp.runtime.supervision.records import PlanRecord, SupervisorReport, TaskRecord, TimedRecord
from clomp.runtime.records.runlog import RunLogLike
from clomp.runtime.interface import Robot, RobotFault, ScanFrame, finite_goal
from clomp.runtime.supervision.sensing import Sensing
from clomp.runtime.supervision.states import MOTOR_STATES, TERMINAL, TRANSITIONS, Event, SupervisorState, TransitionRecord

__all__ = ["GuardViolation", "PlanRecord", "Supervisor", "SupervisorConfig", "SupervisorReport", "TaskRecord", "TimedRecord"]


S, E = SupervisorState, Event


# -- the supervisor -------------------------------------------------------------------------
class Supervisor:
    """Runs plans of a :class:`~clomp.planner.Configurator` closed-loop on a :class:`~clomp.runtime.interface.Robot`.

    ``goal`` is (x, y) in the robot's frame at start (x forward, y left). ``config``: its
    settings (:class:`~clomp.runtime.supervision.config.SupervisorConfig`; the defaults when
    None). ``clock`` defaults to the robot itself when it keeps (simulated) time, else the
    wall clock. ``log`` receives the run's records (:mod:`clomp.runtime.records.runlog`).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.sim import SimRobot
    >>> scene = load_scenario("open")
    >>> report = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=60)
    >>> report.state.value, report.replans       # nothing in sight: dead reckoning cannot vouch for 0.1 m
    ('GOAL_UNCONFIRMED', 0)
    >>> round(report.goal_bound, 2)
    0.48
    >>> Supervisor(SimRobot(scene, seed=0), (1.0, 0.0), config=SupervisorConfig(feedback="none")).estimator is None
    True
    """

    def __init__(
        self,
        robot: Robot,
        goal: tuple[float, float],
        configurator: Configurator | None = None,
        *,
        config: SupervisorConfig | None = None,
        clock: Clock | None = None,
        log: RunLogLike | None = None,
    ) -> None:
        gx, gy = finite_goal(goal)
        self.config = cfg = config or SupervisorConfig()
        self.robot = robot
        self.configurator = configurator or Configurator()
        self.model: RobotModel = self.configurator.robot
        self.clock: Clock = clock_for(robot, clock)
        self.goal_radius = self.model.goal_tolerance if cfg.goal_radius is None else float(cfg.goal_radius)  # the plan's own
        self._goal_robot = (gx, gy)
        self.log = log
        self.sensing = Sensing(robot, self.model, cfg)  # the pose estimate and the revolutions kept
        self.progress = Progress(cfg)  # the counts behind UNREACHABLE

        self.state = S.IDLE
        self.reason = ""
        self.transitions: list[TransitionRecord] = []
        self.plans: list[PlanRecord] = []
        self.tasks: list[TaskRecord] = []
        self.trajectory: list[tuple[float, float, float, float]] = []
        self.goal = Pose(gx, gy)
        self._cmd = (0.0, 0.0)
        self._t0: float | None = None
        self._queue: deque[tuple[State, tuple[int, int]]] = deque()
        self._task: Task | None = None
        self._record: TaskRecord | None = None
        self._plan: PlanRecord | None = None
        self.fresh_plans: list[TimedRecord] = []
        self._check_due = False
        self._relocations = 0  # times the estimate moved at the goal (_relocated_at_goal)
        self._goal_end: tuple[float, float | None] | None = None  # (distance, 95 % bound) when it ended at the goal
        self._approaches = 0  # times CONFIRMING sent it to the goal again (clomp.runtime.supervision.goal)
        self._confirm_seen = 0  # revolutions standing CONFIRMING has judged
        self._confirm_blind = False  # a revolution seen confirming left a direction of the position unobserved
        self._confirm_honest = 0.0  # the filter's position sd (m) when confirming began
        self._confirm_from = 0  # the estimator's revolution records when confirming began
        self._claim_floor: tuple[float, str, float] = (0.0, "", 0.0)  # goal.claim_floor's parts: unobserved, along, start
        self.watch = PlanWatch(self.model, self._log)  # hazard test, plan check, recall (clomp.runtime.supervision.planwatch)
        self.alarms = self.watch.alarms
        self.checks, self.recalls = self.watch.checks, self.watch.recalls
        self.appearance = Appearance(self.model)  # what appeared since the last plan (``moving`` only)
        self._push_events = 0  # the estimator's doubt events looked at (clomp.runtime.supervision.pushaway)
        self._pushed_at: float | None = None  # when a push was felt that is still to be judged
        self._seen_at: float | None = None  # when a revolution saw through the map, no jump of the estimate yet
        self._away: Task | None = None  # MOVING_AWAY's move
        self._away_ticks = 0
        self._away_left: float | None = None  # what the move had left last tick (a jump re-anchors it)
        self._jump: str | None = None  # the estimate jumped at this tick's revolution while a task ran (how far)
        self._jumped_at: float | None = None  # when the estimate last jumped (push evidence, clomp.runtime.supervision.pushaway)

    # -- public -------------------------------------------------------------------------------
    @property
    def terminal(self) -> bool:
        """True in GOAL_REACHED, GOAL_UNCONFIRMED, UNREACHABLE or HALTED."""
        return self.state in TERMINAL

    @property
    def pose(self) -> Pose:
        """The pose estimate (the supervisor's frame: the robot at start)."""
        return self.sensing.pose

    @pose.setter
    def pose(self, pose: Pose) -> None:
        self.sensing.pose = pose

    @property
    def estimator(self) -> ScanOdometry | None:
        """The scan matcher correcting the estimate (``feedback="scan"``), else None."""
        return self.sensing.estimator

    @estimator.setter
    def estimator(self, estimator: ScanOdometry | None) -> None:
        self.sensing.estimator = estimator

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
        self.sensing.start(now)
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
                if max_time is not None and not t - t_start < max_time:  # a NaN limit ends it too
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
        t = 0.0 if self._t0 is None else self.sensing.last_update - self._t0
        return SupervisorReport(
            self.state,
            self.reason,
            t,
            list(self.plans),
            list(self.tasks),
            list(self.transitions),
            list(self.trajectory),
            (self.goal.x, self.goal.y),
            list(self.estimator.records) if self.estimator is not None else [],
            list(self.checks),
            list(self.recalls),
            list(self.fresh_plans),
            None if self._goal_end is None else self._goal_end[0],
            None if self._goal_end is None else self._goal_end[1],
        )

    # -- machinery -------------------------------------------------------------------------------
    def _fire(self, event: Event, reason: str) -> None:
        target = TRANSITIONS.get((self.state, event))
        if target is None:
            raise RuntimeError(f"no transition from {self.state.value} on {event.value}")
        source = self.state
        if source in MOTOR_STATES and target not in MOTOR_STATES:  # clomp.formal.control: where wheels may turn
            self._stop_wheels()
            self.sensing.stopped()
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
            extra = {} if self._goal_end is None else {"distance": self._goal_end[0], "bound": self._goal_end[1]}
            self._log("stop", reason=reason, status=target.value, **extra)

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
        self._jump = None
        self.sensing.update_pose(now, self._cmd)
        frame = self.robot.read_scan(timeout=0.0)
        if frame is not None:
            self._take(frame, now)
        elif self.sensing.seconds_silent(now) > self.config.scan_timeout:
            raise RobotFault(f"sensor silent: no scan for {self.sensing.seconds_silent(now):.2f} s")
        if push_tick(self, now, frame is not None):
            pass  # pushed against an obstacle: it started moving away (clomp.runtime.supervision.pushaway)
        elif self.state in (S.PLANNING, S.REPLANNING):
            self._plan_tick(now)
        elif self.state is S.EXECUTING:
            self._execute_tick(now)
        elif self.state is S.CONFIRMING:
            confirm_tick(self, now)
        elif self.state is S.MOVING_AWAY:
            move_tick(self, now)
        self.trajectory.append((now - (self._t0 or 0.0), self.pose.x, self.pose.y, self.pose.theta))

    def _take(self, frame: ScanFrame, now: float) -> None:
        """A new revolution: the estimate takes it, the log and the alarms see it, and a plan
        check is due once a revolution while executing."""
        self._check_due = self.state in MOTOR_STATES
        before = self.pose
        rec = self.sensing.take(frame, now, self._cmd, still=not self._check_due)
        jump = jumped(before, self.pose, self.config.replan_jump)
        if jump is not None:
            self._jumped_at = now
            self._jump = jump if self.state is S.EXECUTING and self._task is not None else None
        if self.log is not None:
            if rec is not None:
                self._log("feedback", ok=rec.ok, source=rec.source, reason=rec.reason, correction=list(rec.correction),
                          unobservable=list(rec.unobservable), map_updated=rec.map_updated, pose=self.pose.as_list())
            g = relative(self.pose, self.goal)
            self._log("scan", points=self.sensing.scan, goal=[g.x, g.y], pose=self.pose.as_list())
        assert self.sensing.scan is not None
        self.alarms.revolution(self.sensing.scan)

    # -- planning ---------------------------------------------------------------------------------
    def _plan_tick(self, now: float) -> None:
        if not self.sensing.ready():
            return  # let driving settle, then take ``fuse_scans`` revolutions (at the start, ``start_scans``: the map's seed)
        g = relative(self.pose, self.goal)
        dist = math.hypot(g.x, g.y)
        if dist <= self.goal_radius and relocated_at_goal(self, now):
            g = relative(self.pose, self.goal)
            dist = math.hypot(g.x, g.y)
        if self._ends_before_planning(dist):
            return
        scan = self.sensing.planning_scan()
        waited_out = self.config.moving and self.appearance.stale  # a WAIT timed out: plan round what stayed
        if waited_out:
            self.progress.world_changed(self.config.wait_timeout)  # it stood that long: not search time
        if self.state is S.REPLANNING and not waited_out and recall(self, scan, now):
            return
        fresh_plan(self, scan, (g.x, g.y), dist, now)

    def _ends_before_planning(self, dist: float) -> bool:
        """At the goal, out of plans, or stuck: fire the end and say so."""
        cfg = self.config
        if dist <= self.goal_radius:
            at_goal(self, dist, "at the goal")
            return True
        if len(self.fresh_plans) >= cfg.max_plans:
            self._fire(E.NO_PLAN, f"gave up after {len(self.fresh_plans)} plans")
            return True
        stuck = self.watch.stalled(self.pose, cfg.min_progress) if self.state is S.REPLANNING else 0
        if stuck >= cfg.max_stuck:  # standing by an obstacle, interrupted again and again: a defined end
            self._fire(E.NO_PLAN, f"goal unreachable: no progress, {stuck} plans in a row ended before the robot moved "
                                  f"{cfg.min_progress:g} m (last: {self.reason})")
            return True
        return False

    # -- execution ----------------------------------------------------------------------------------
    def _start_next(self, now: float) -> bool:
        if not self._queue:
            return False
        assert self._plan is not None
        q, step = self._queue.popleft()
        psi = guard(self._plan.result, step)
        predicted_end = self._plan.to_frame(q.end)
        task = task_for(q, self._plan.result, predicted_end, self.model, self.pose, self.goal, self.config.wait_timeout + 1.0)
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
        if self._jump is not None:  # set from the belief before: a new disturbance, the Configurator plans anew
            self._fire(E.DISAGREE, f"the estimate jumped {self._jump} while the task ran: planning from the new one")
            return
        e = task.error(self.pose)
        if task.done(e):
            off = end_error(self.pose, self._record.predicted_end, self.config.end_tolerance)
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
        if self._check_due:
            self._check_due = False
            verdict = self._check_remaining()
            if verdict is not None and not verdict.ok:
                self._fire(E.DISAGREE, f"plan check: {verdict.reason}")
                return
        self._task_ticks += 1
        if self._task_ticks > 2 * task.max_ticks() + 10:
            self._fire(E.DISAGREE, "task overran its expected duration")
            return
        vl, vr = task.wheel_speeds(e, wrap_angle(self.pose.theta - task.start.theta))  # a STRAIGHT holds its heading
        if self.state not in MOTOR_STATES:  # the machine's table forbids the wheels here
            raise GuardViolation(f"the wheels may not turn in {self.state.value}")
        # the old command drove until now: a long tick (a plan made under load) is not the new one's
        self.sensing.update_pose(self.clock.now(), self._cmd)
        self.robot.set_wheel_speeds(vl, vr)
        if self.log is not None and (vl, vr) != self._cmd:
            self._log("motor", left=vl, right=vr)
        self._cmd = (vl, vr)
        self.sensing.drove(self._cmd)

    def _plan_ended(self) -> None:
        g = relative(self.pose, self.goal)
        dist = math.hypot(g.x, g.y)
        if dist <= self.goal_radius and self.estimator is None:
            at_goal(self, dist, "plan done at the goal")
        elif dist <= self.goal_radius:
            # the estimate taken while driving: stand, let the still revolutions correct it,
            # and decide on the settled pose (REPLANNING ends at the goal or approaches anew)
            self._fire(E.PLAN_SHORT, f"plan done at the goal by the moving estimate ({dist:.3f} m): settling")
        else:
            self._fire(E.PLAN_SHORT, f"plan done {dist:.3f} m short of the goal")

    def _hazard(self, task: Task, error: float) -> str | None:
        """A reason to interrupt: the newest scan has points in the body's remaining path (a
        WAIT: it waited out its time with the way ahead still blocked)."""
        if task.kind is TaskKind.WAIT:  # stands, watching the way ahead (clomp.runtime.supervision.moving)
            self._check_due = False
            return wait_tick(self, task)
        s, cfg = self.sensing, self.config
        return self.watch.hazard(s.clean_scan, s.scan_pose, self.pose, task, error, cfg.lookahead, cfg.hazard_points)

    def _check_remaining(self) -> TimedRecord | None:
        """Test the running task and the queued ones against the newest revolution."""
        s = self.sensing
        if self._plan is None or self._record is None or s.clean_scan is None:
            return None
        states = [self._record.state] + [q for q, _ in self._queue]
        return self.watch.check(states, self._plan, s.scan_pose, self.goal, s.clean_scan, self.config.end_tolerance,
                                self._now())
