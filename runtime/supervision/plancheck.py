"""Plan checking and recall: the supervisor's use of the cognitive map it already has.

:func:`check_plan` re-simulates the tasks a plan still has to run on the newest scan, from
the estimated pose, with the planner's own core knowledge (``planner.physics.simulate``
on what the scan shows): each task must still be free of obstacles and end where the map
predicted (within ``tolerance``). The supervisor runs it once a revolution; a failed check
sends it to REPLANNING.

:func:`recall` is what REPLANNING tries first: match the current situation to a state of
the existing map — an uninterrupted state whose end pose is where the robot now is
(within ``tolerance``) — extract the plan the map holds from there to its best state, and
keep it only if :func:`check_plan` finds its tasks' disturbances consistent with the new
scan. Only when no state passes does the supervisor explore anew.

Poses: a plan's states are in its *planner frame* (the robot at the time it was made,
``origin`` in the supervisor's frame); the pose and the scan are the supervisor's estimate
now and what the LiDAR sees from it.
"""

from __future__ import annotations

import dataclasses
import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from formal.geometry import compose, relative, wrap_angle
from formal.model import Disturbance, Pose, State, TaskKind
from formal.robust import map_policy, policy_path
from formal.supervisory import Plan, guard
from planner.configurator import PlanResult
from planner.perception import Obstacles, perceive
from planner.physics import simulate
from planner.robot import RobotModel

__all__ = ["CheckResult", "Recall", "check_plan", "perceive_near", "perceive_scan", "recall"]


@dataclass(frozen=True)
class CheckResult:
    """The verdict on a plan's remaining tasks: ``ok``, why not, and the time it took (s)."""

    ok: bool
    reason: str
    tasks: int
    duration_s: float


@dataclass(frozen=True)
class Recall:
    """A plan recalled from an existing map: the new result, the state it starts at, the check."""

    result: PlanResult
    state: int
    check: CheckResult


def perceive_scan(scan: np.ndarray, robot: RobotModel) -> Obstacles:
    """What the planner perceives in ``scan`` (robot frame), as :meth:`Configurator.plan` does."""
    return perceive(scan, robot.sensor_range, robot.cluster_distance,
                    body=(robot.rear_offset, robot.front_offset, robot.width / 2))


def perceive_near(scan: np.ndarray, states: list[State], origin: Pose, pose: Pose, robot: RobotModel) -> Obstacles:
    """:func:`perceive_scan` of only the points that can touch the body along ``states``:
    within a body's reach of the box spanned by the tasks' start and end poses (robot frame
    at ``pose``). A check then perceives a fraction of the scan."""
    pts = np.asarray(scan, dtype=float).reshape(-1, 2)
    if len(pts) == 0 or not states:
        return perceive_scan(pts, robot)
    corners = [relative(pose, compose(origin, p)) for q in states for p in (q.start, q.end)] + [Pose(0.0, 0.0, 0.0)]
    xs, ys = [c.x for c in corners], [c.y for c in corners]
    reach = robot.swept_radius + robot.cluster_distance + 0.05
    near = (pts[:, 0] >= min(xs) - reach) & (pts[:, 0] <= max(xs) + reach) & \
        (pts[:, 1] >= min(ys) - reach) & (pts[:, 1] <= max(ys) + reach)
    return perceive_scan(pts[near], robot)


def _off(a: Pose, b: Pose) -> tuple[float, float]:
    return math.hypot(a.x - b.x, a.y - b.y), abs(wrap_angle(a.theta - b.theta))


def check_plan(
    states: list[State],
    origin: Pose,
    pose: Pose,
    goal: Pose,
    obstacles: Obstacles,
    robot: RobotModel,
    *,
    tolerance: tuple[float, float] = (0.08, 0.3),
    running: bool = False,
) -> CheckResult:
    """Re-simulate ``states`` (planner frame at ``origin``) from ``pose`` among ``obstacles``
    (perceived in the robot frame at ``pose``); see the module docstring.

    ``goal`` is in the supervisor's frame. ``running``: the first state is the task under
    way, checked from the current pose to its predicted end. Each task starts where the
    previous one's rollout ended.
    """
    t0 = time.perf_counter()
    if not states:
        return CheckResult(True, "nothing left to check", 0, time.perf_counter() - t0)
    g = relative(pose, goal)
    goal_d = Disturbance.goal(g.x, g.y)
    start = Pose(0.0, 0.0, 0.0)  # the robot frame now
    worlds: dict[Any, Any] = {}  # the rollouts of one check share one world of the obstacles
    frame = relative(pose, origin)  # the plan's frame seen from the robot now
    for k, q in enumerate(states):
        end = compose(frame, q.end)  # where the map predicted it ends, robot frame
        planned_start = compose(frame, q.start)
        first = k == 0 and running
        if q.task is TaskKind.STRAIGHT:
            along = (end.x - start.x) * math.cos(start.theta) + (end.y - start.y) * math.sin(start.theta)
            length = along if first else math.hypot(end.x - planned_start.x, end.y - planned_start.y)
            if length <= 1e-3:
                start = end
                continue
            out = simulate(TaskKind.STRAIGHT, start, goal_d, obstacles, robot, worlds)
            if out.collided and out.distance < length - tolerance[0]:
                return CheckResult(False, f"task {k + 1} ({q.task.value}) now meets an obstacle after "
                                          f"{out.distance:.2f} of {length:.2f} m", k + 1, time.perf_counter() - t0)
            c, s = math.cos(start.theta), math.sin(start.theta)
            reached = Pose(start.x + c * length, start.y + s * length, start.theta)
        else:
            turn = abs(wrap_angle(end.theta - start.theta))
            if turn <= 1e-3:
                start = end
                continue
            out = simulate(q.task, start, goal_d, obstacles, robot, worlds, angle=turn)
            turned = abs(wrap_angle(out.end.theta - start.theta))
            if out.collided and turned < turn - tolerance[1]:
                return CheckResult(False, f"task {k + 1} ({q.task.value}) now meets an obstacle", k + 1,
                                   time.perf_counter() - t0)
            # a turn the planner would not start at the rim of the disc it saw (unknown space
            # beyond) was accepted when the plan was made: only obstacles make it fail now
            reached = out.end if not out.frontier else Pose(start.x, start.y, start.theta + (turn if q.task is TaskKind.LEFT else -turn))
        d, a = _off(reached, end)
        if d > tolerance[0] or a > tolerance[1]:
            return CheckResult(False, f"task {k + 1} ({q.task.value}) would end {d:.3f} m, {math.degrees(a):.0f}° "
                                      f"from the map's prediction", k + 1, time.perf_counter() - t0)
        start = reached
    return CheckResult(True, f"{len(states)} task(s) still free and on the map", len(states), time.perf_counter() - t0)


def _best_from(result: PlanResult, source: int) -> list[int] | None:
    """The map's plan from ``source``: a path to its least-φ uninterrupted descendant, or,
    on a map that carries Storm's scheduler (a robust plan), the scheduler's path from
    there: the policy is followed in whichever state the robot is found in."""
    cmap = result.map
    policy = map_policy(cmap)
    if policy is not None:
        path = policy_path(cmap, policy, source)
        if len(path) < 2 or cmap[path[-1]].interrupted or cmap[path[-1]].cost >= cmap[source].cost:
            return None  # as below: a continuation must end closer than where the robot is
        return path
    reach = cmap.reachable(source)
    ends = [cmap[i] for i in reach if i != source and not cmap[i].interrupted]
    if not ends:
        return None
    end = min(ends, key=lambda s: (s.cost, s.ident))
    if end.cost >= cmap[source].cost:
        return None  # nothing better than where the robot is
    return cmap.path(end.ident, source)


def recall(
    result: PlanResult,
    origin: Pose,
    pose: Pose,
    goal: Pose,
    obstacles: Obstacles,
    robot: RobotModel,
    *,
    tolerance: tuple[float, float] = (0.04, 0.15),
    check_tolerance: tuple[float, float] = (0.08, 0.3),
) -> tuple[Recall | None, str, float]:
    """Recall a plan from ``result``'s map for the robot at ``pose``; see the module docstring.

    ``tolerance`` is how close (m, rad) a state's end must be to the robot's pose;
    ``check_tolerance`` is :func:`check_plan`'s. Returns (the recall or None, why, seconds).
    """
    t0 = time.perf_counter()
    cmap = result.map
    here = relative(origin, pose)  # planner frame
    reach = cmap.reachable()
    candidates = []
    for q in cmap.states():
        if q.ident not in reach or q.interrupted:
            continue
        d, a = _off(q.end, here)
        if d <= tolerance[0] and a <= tolerance[1]:
            candidates.append((q.cost, d, q.ident))
    if not candidates:
        return None, "no state of the map is where the robot is", time.perf_counter() - t0
    last = "no state of the map leads on from here"
    for _cost, _d, ident in sorted(candidates):
        path = _best_from(result, ident)
        if path is None:
            continue
        states = [cmap[i] for i in path[1:]]
        verdict = check_plan(states, origin, pose, goal, obstacles, robot, tolerance=check_tolerance)
        if not verdict.ok:
            last = f"from q{ident}: {verdict.reason}"
            continue
        # the recalled plan, as a plan of the same map: ρ from q0 through the recalled state
        full = cmap.path(ident)[:-1] + path
        plan = Plan(tuple(full))
        recalled = dataclasses.replace(result, plan=plan, psi=guard(cmap, plan), planning_time_s=time.perf_counter() - t0)
        return Recall(recalled, ident, verdict), f"recalled from q{ident}: {verdict.reason}", time.perf_counter() - t0
    return None, last, time.perf_counter() - t0
