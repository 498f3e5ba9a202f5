"""One run of one condition, measured on the world's ground truth: :func:`run_once` and its :class:`RunResult`.

:func:`run_once` drives one condition (``"planning"``: the :class:`~clomp.runtime.supervision.supervisor.
Supervisor` with a :class:`~clomp.planner.Configurator`; ``"reactive"``: the :class:`~clomp.runtime.
experiment.reactive.ReactiveController`) on a fresh robot of the execution world
(:func:`~clomp.runtime.experiment.groundtruth.make_robot`) and measures it on the world's ground
truth: contact episodes (:mod:`clomp.runtime.experiment.contacts`) and the true final distance
to the goal.

Success (``success``): for a family whose goal can be reached, the robot truly ends
within :data:`SUCCESS_RADIUS` of it (ground truth, whatever the controller believed);
for one whose goal cannot be reached (cul-de-sac), the controller stops by itself saying
so (``UNREACHABLE``) with no collision.
"""

from __future__ import annotations

import math
import os
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clomp.formal.geometry import compose, relative
from clomp.formal.model import Pose
from clomp.planner.configurator import Configurator
from clomp.planner.scenarios import Scene
from clomp.runtime.backends.sim import NoiseConfig
from clomp.runtime.backends.world import WorldNoise, make_world_robot, push_speed
from clomp.runtime.experiment.contacts import ContactCount, Episode, Push, contact_episodes, mark_pushed
from clomp.runtime.experiment.groundtruth import make_robot
from clomp.runtime.experiment.layouts import shape_distance
from clomp.runtime.experiment.plots import RunTrace
from clomp.runtime.experiment.dwa import DwaController
from clomp.runtime.experiment.reactive import ReactiveController
from clomp.runtime.experiment.rl import RlController
from clomp.runtime.experiment.runspec import check_condition
from clomp.runtime.records.runlog import RunLog
from clomp.runtime.supervision.supervisor import Supervisor, SupervisorConfig

__all__ = ["SUCCESS_RADIUS", "RunResult", "moving_counts", "run_contacts", "run_once", "world_pushes"]

SUCCESS_RADIUS = 0.1
"""Ground-truth distance (m) to the goal within which a run reached it: twice the planner's
goal tolerance (0.05 m), about half the body's width; the paper gives none."""


@dataclass
class RunResult:
    """One run of one condition, measured on the world's ground truth (world frame).

    >>> from clomp.planner import load_scenario
    >>> r = run_once(load_scenario("open"), "planning", 0, noise="ideal")
    >>> r.condition, r.reached_goal, r.collisions, r.final_distance < SUCCESS_RADIUS
    ('planning', True, 0, True)
    """

    condition: str
    run: int
    seed: int
    scene: Scene
    end_state: str
    reason: str
    reached_goal: bool
    believed_goal: bool
    final_distance: float
    episodes: list[Episode]
    contacts: list[tuple[float, float]]
    time_s: float
    time_to_goal_s: float | None
    planning_time_s: float | None
    n_states: int | None
    plans: int
    path: list[tuple[float, float]]
    estimate: list[tuple[float, float]]
    planned: list[list[tuple[float, float]]]
    wall_s: float
    cpu_s: float
    final_pose: tuple[float, float, float] = (0.0, 0.0, 0.0)
    counters: dict[str, int | None] = field(default_factory=dict)
    report: Any = field(default=None, repr=False)
    times: list[float] = field(default_factory=list, repr=False)  # the time (s) of each point of ``path``
    headings: list[float] = field(default_factory=list, repr=False)  # the true heading (rad) at each point of ``path``
    moving: dict[str, int] | None = None
    """With moving bodies (issue #42): ``static_collisions``, ``moving_collisions``,
    ``moving_brushes`` and ``robot_caused_collisions`` (:func:`moving_counts`); else None."""

    @property
    def collisions(self) -> int:
        """Contact episodes that are not brushes and not pushed contacts: the robot's own."""
        return ContactCount(tuple(self.episodes)).collisions

    @property
    def pushed_contacts(self) -> int:
        """Collision episodes an external push of the world slid the body into
        (:func:`~clomp.runtime.experiment.contacts.mark_pushed`), counted apart from :attr:`collisions`."""
        return ContactCount(tuple(self.episodes)).pushed

    @property
    def brushes(self) -> int:
        """Short, shallow contact episodes."""
        return ContactCount(tuple(self.episodes)).brushes

    def trace(self) -> RunTrace:
        """The run as a picture: its outcome in words (:func:`~clomp.runtime.experiment.plots.outcome_words`),
        the scan points every plan saw (placed by the estimate it planned from; without a kept
        report, the noise-free scan from the start) and the time along the path."""
        from clomp.runtime.experiment.plots import outcome_title, start_scan

        title, tone = outcome_title(self.run, self.end_state, self.reached_goal, self.final_distance, self.collisions,
                                    self.brushes, reason=self.reason)
        st = self.scene.start
        poses = [(st.x, st.y, st.theta), self.final_pose]
        scan, label = start_scan(self.scene), "LiDAR scan at the start (noise-free)"
        plans = getattr(self.report, "plans", None)
        if plans:
            scan = [_world(st, rec.to_frame(Pose(x, y, 0.0))) for rec in plans for x, y in rec.result.obstacles.points.tolist()]
            label = "scan points the planner saw"
        return RunTrace(self.scene, title, self.path, self.contacts, self.planned, self.estimate, poses,
                        self.reached_goal, tone, scan, label, list(self.times), list(self.headings))


def moving_counts(robot: Any) -> dict[str, int]:
    """The contacts of a world with moving bodies counted apart (issue #42): collisions with the
    static obstacles, collisions and brushes with the moving bodies, and of those collisions the
    ones the robot caused (in some sample of the episode its wheels drove it into the body).

    >>> from clomp.planner.scenarios import load_scenario
    >>> from clomp.runtime.backends.world import make_world_robot
    >>> w = make_world_robot(load_scenario("open"), "ideal", seed=0, movers=[{"kind": "person", "path": [[0, 0.5, 0.0]]}])
    >>> w.set_wheel_speeds(0.1, 0.1); w.sleep(4.0)
    >>> moving_counts(w)
    {'static_collisions': 0, 'moving_collisions': 1, 'moving_brushes': 0, 'robot_caused_collisions': 1}
    """
    static, moving = robot.contact_traces()
    stat = ContactCount(tuple(contact_episodes(static)))
    eps = contact_episodes([(t, d) for t, d, _ in moving])
    caused = 0
    for e in eps:
        if not e.brush and any(c for t, _, c in moving if e.start_s <= t <= e.end_s):
            caused += 1
    count = ContactCount(tuple(eps))
    return {"static_collisions": stat.collisions, "moving_collisions": count.collisions,
            "moving_brushes": count.brushes, "robot_caused_collisions": caused}


def world_pushes(robot: Any, path: list[tuple[float, float, float, float]]) -> list[Push]:
    """The world's external pushes of a run (none for a robot that cannot be pushed), each
    with its slide time on open floor (``2 d / v0``, the kick ``v0`` of
    :func:`~clomp.runtime.backends.world.push_speed`) and the body's true position then
    (``path``: the ground truth, ``(t, x, y, theta)``)."""
    out = []
    times = [p[0] for p in path]
    for k in getattr(robot, "pushes", None) or []:
        v0 = push_speed(k.distance, robot.body)
        i = min(max(int(np.searchsorted(times, k.time)), 0), len(path) - 1)
        out.append(Push(k.time, 2.0 * k.distance / v0 if v0 > 0 else 0.0, k.direction, path[i][1], path[i][2]))
    return out


def run_contacts(robot: Any, scene: Scene, truth: list[tuple[float, float, float, float]] | None = None
                 ) -> tuple[list[Episode], list[tuple[float, float]]]:
    """A run's contact episodes (ground truth), those an external push slid the body into
    marked (:func:`~clomp.runtime.experiment.contacts.mark_pushed`), and where each began
    (the obstacle point nearest the body then, world frame). ``truth``: the ground-truth
    path, ``(t, x, y, theta)`` (default: the robot's own).

    >>> from clomp.planner import load_scenario
    >>> from clomp.runtime.backends.world import make_world_robot
    >>> w = make_world_robot(load_scenario("overtaking"), "ideal", seed=0)
    >>> w.sleep(0.5); w.push(0.5, 0.0); w.sleep(2.0)        # slid 0.5 m along +x into the box
    >>> [(e.kind, e.pushed) for e in run_contacts(w, load_scenario("overtaking"))[0]]
    [('collision', True)]
    """
    truth = _ground_truth_path(robot, robot.ground_truth_pose()) if truth is None else truth
    episodes = contact_episodes(robot.contact_trace())
    contacts = [_contact_point(scene, truth, e.start_s) for e in episodes]
    return mark_pushed(episodes, world_pushes(robot, truth), contacts), contacts


def _world(start: Pose, p: Pose) -> tuple[float, float]:
    w = compose(start, p)
    return (w.x, w.y)


def _count(report: Any, name: str) -> int | None:
    v = getattr(report, name, None)
    if v is None:
        return None
    if isinstance(v, (int, np.integer)):
        return int(v)
    try:
        return len(v)
    except TypeError:
        return None


def _ground_truth_path(robot: Any, pose: Pose) -> list[tuple[float, float, float, float]]:
    for name in ("ground_truth_trajectory", "trajectory"):
        v = getattr(robot, name, None)
        if callable(v):
            v = v()
        if v:
            return [(float(a), float(b), float(c), float(d)) for a, b, c, d in v]
    return [(0.0, pose.x, pose.y, pose.theta)]


def _contact_point(scene: Scene, path: list[tuple[float, float, float, float]], t: float) -> tuple[float, float]:
    """Where the body touched at time ``t``: the obstacle point nearest the true position then."""
    times = [p[0] for p in path]
    k = min(max(int(np.searchsorted(times, t)), 0), len(path) - 1)
    x, y = path[k][1], path[k][2]
    best, where = math.inf, (x, y)
    for s in scene.shapes:
        d = shape_distance(s, x, y)
        if d < best:
            best = d
            if s.kind == "circle":
                cx, cy = s.center
                r = math.hypot(x - cx, y - cy) or 1.0
                where = (cx + s.radius * (x - cx) / r, cy + s.radius * (y - cy) / r)
            else:
                v = s.vertices
                bq, bp = math.inf, (x, y)
                for i in range(len(v)):
                    ax, ay = v[i]
                    ex, ey = v[(i + 1) % len(v)][0] - ax, v[(i + 1) % len(v)][1] - ay
                    u = max(0.0, min(1.0, ((x - ax) * ex + (y - ay) * ey) / (ex * ex + ey * ey)))
                    q = (ax + u * ex, ay + u * ey)
                    dq = math.hypot(x - q[0], y - q[1])
                    if dq < bq:
                        bq, bp = dq, q
                where = bp
    return (float(where[0]), float(where[1]))


class _TruthLog:
    """A simulated run's log: scan and task records also carry the ground truth pose
    (in the odometry frame, the robot's start), what a viewer shows beside the estimate."""

    def __init__(self, log: RunLog, robot: Any, start: Pose) -> None:
        self._log, self._robot, self._start = log, robot, start

    def write(self, event: str, **fields: Any) -> None:
        if event in ("scan", "task"):
            fields["truth"] = relative(self._start, self._robot.ground_truth_pose()).as_list()
        self._log.write(event, **fields)


def _open_log(dest: str | os.PathLike[str], robot: Any, scene: Scene, condition: str, seed: int,
              noise: str | NoiseConfig | WorldNoise | None, goal: tuple[float, ...]) -> RunLog:
    runlog = RunLog(dest, clock=robot)  # the robot keeps the simulated time
    runlog.write("run", simulated=True, scenario=scene.name, condition=condition, seed=seed,
                 noise=noise if isinstance(noise, str) else ("scene" if noise is None else "custom"),
                 goal=list(goal), wall=time.time())
    return runlog


def run_once(
    scene: Scene,
    condition: str = "planning",
    seed: int | None = 0,
    *,
    run: int = 0,
    noise: str | NoiseConfig | WorldNoise | None = None,
    noise_scale: float = 1.0,
    max_time: float = 120.0,
    expect: str = "reach",
    configurator: Configurator | None = None,
    keep_report: bool = False,
    log: str | os.PathLike[str] | None = None,
    feedback: str = "scan",
    reactive: dict[str, Any] | None = None,
    gyro: bool = True,
    supervisor: SupervisorConfig | None = None,
    movers: tuple[Any, ...] = (),
    moving: bool | None = None,
) -> RunResult:
    """Run one condition in ``scene`` on a fresh robot; see the module docstring.

    ``noise``: a preset name (``ideal``, ``paper``, ``harsh``; the execution world of
    :func:`~clomp.runtime.experiment.groundtruth.make_robot`), a :class:`~clomp.runtime.backends.sim.NoiseConfig`
    for the simulated robot, a :class:`~clomp.runtime.backends.world.WorldNoise` for the execution
    world with those terms, or None for the simulated robot with the scene's own noise.
    ``log``: a file for the run log (the supervisor's records, as ``clomp run`` writes
    them, in simulated time, with the ground truth beside each scan and task record).
    ``feedback``: both conditions' pose estimate (the same robot, the same sensing) —
    ``"scan"`` (scan matching, the default) or ``"none"`` (dead reckoning alone).
    ``reactive``: keyword arguments for the ReactiveController (``bench/experiment_reactive.py``)
    or its dwa/rl subclass (``{"policy": path}`` for ``rl``).
    ``gyro`` False: the execution world's robot without its rate gyro (the paper's robot).
    ``supervisor``: the planning condition's settings (default: ``SupervisorConfig(feedback=feedback)``).
    ``movers``: bodies that move or appear in the world (issue #42; the execution world's
    ``noise`` only: a preset or a WorldNoise). ``moving`` (default: whether there are movers):
    the planning condition plans with WAIT and REVERSE (``Configurator(recovery=True)``,
    ``SupervisorConfig(moving=True)``) unless ``configurator`` / ``supervisor`` say otherwise.

    >>> from clomp.planner import load_scenario
    >>> r = run_once(load_scenario("open"), "reactive", 0, noise="ideal")
    >>> r.reached_goal, r.collisions, r.brushes
    (True, 0, 0)
    """
    check_condition(condition)
    if not (math.isfinite(max_time) and max_time > 0):  # a simulated run needs an end
        raise ValueError(f"max_time must be a finite positive number of seconds, got {max_time!r}")
    moving = bool(movers) if moving is None else bool(moving)
    conf = configurator or (Configurator(recovery=True) if moving else Configurator())
    seed_ = 0 if seed is None else int(seed)
    robot: Any
    if isinstance(noise, str):
        robot = make_robot(scene, noise=noise, noise_scale=noise_scale, seed=seed_, model=conf.robot, gyro=gyro,
                           movers=movers)
    elif isinstance(noise, WorldNoise):
        robot = make_world_robot(scene, noise, seed=seed_, robot=conf.robot, gyro=gyro, movers=movers)
    elif movers:
        raise ValueError("moving bodies need the execution world (noise='paper', ... or a WorldNoise)")
    else:
        from clomp.runtime.experiment.groundtruth import _TracedSimRobot

        robot = _TracedSimRobot(scene, conf.robot, noise=noise, seed=seed)
    start = scene.start
    goal = tuple(scene.goal_in_robot_frame())
    t0, c0 = time.perf_counter(), time.thread_time()
    planned: list[list[tuple[float, float]]] = []
    plan_time = states = None
    plans = 0
    report: Any
    if condition == "planning":
        runlog = _open_log(log, robot, scene, condition, seed_, noise, goal) if log is not None else None
        try:
            cfg = supervisor if supervisor is not None else SupervisorConfig(feedback=feedback, moving=moving)
            sup = Supervisor(robot, goal, conf, config=cfg,  # type: ignore[arg-type]
                             log=None if runlog is None else _TruthLog(runlog, robot, start))
            report = sup.run(max_time=max_time)
        finally:
            if runlog is not None:
                runlog.close()
        for rec in report.plans:
            planned.append([_world(start, rec.to_frame(rec.result.map[i].end)) for i in rec.result.plan.states])
        if report.plans:
            plan_time = report.plans[0].result.planning_time_s
            states = report.plans[0].result.n_states
        plans = len(report.plans)
        end_state, reason = report.state.value, report.reason
    else:
        opts: dict[str, Any] = {"model": conf.robot, "feedback": feedback, **(reactive or {})}
        controller = {"dwa": DwaController, "rl": RlController}.get(condition, ReactiveController)
        report = controller(robot, goal, **opts).run(max_time=max_time)
        end_state, reason = report.state, report.reason
    wall, cpu = time.perf_counter() - t0, time.thread_time() - c0
    true = robot.ground_truth_pose()
    dist = math.hypot(true.x - scene.goal[0], true.y - scene.goal[1])
    believed = bool(report.reached_goal)  # it claimed the goal (GOAL_REACHED; not GOAL_UNCONFIRMED)
    truth = _ground_truth_path(robot, true)
    episodes, contacts = run_contacts(robot, scene, truth)
    if expect == "unreachable":  # a pushed contact fails it too (the robot must stop clear and say so)
        reached = end_state == "UNREACHABLE" and not any(not e.brush for e in episodes)
    else:
        reached = dist <= SUCCESS_RADIUS
    if report.reached_goal and dist > SUCCESS_RADIUS:
        reason = f"{reason}, but truly {dist:.3f} m from the goal"
    path = [(x, y) for _, x, y, _ in truth[::10]] + [(true.x, true.y)]
    times = [t for t, _, _, _ in truth[::10]] + [float(report.time_s)]
    headings = [th for _, _, _, th in truth[::10]] + [true.theta]
    estimate = [_world(start, Pose(x, y, th)) for _, x, y, th in report.trajectory]
    counters = {name: _count(report, name) for name in ("checks", "recalls", "fresh_plans")}
    return RunResult(
        condition, run, seed_, scene, end_state, reason, reached, believed, dist, episodes, contacts,
        report.time_s, report.time_s if reached and expect == "reach" else None, plan_time, states, plans, path,
        estimate, planned, wall, cpu, (true.x, true.y, true.theta), counters, report if keep_report else None, times,
        headings, moving_counts(robot) if movers else None,
    )
