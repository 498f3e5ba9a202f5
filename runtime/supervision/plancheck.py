"""Plan checking and recall: the supervisor's use of the cognitive map it already has.

:func:`check_plan` tests the tasks a plan still has to run against the newest scan, from
the estimated pose: each task must still be free of the scan's points and end where the
map predicted (within ``tolerance``); a REVERSE is checked against the points behind it. The test is the planner's own geometry in closed
form (:mod:`clomp.planner.rollout`: the footprint inflated by the robot's ``clearance``
translated along a straight, spun through every tick heading of a turn, the
start-touching rule; :mod:`clomp.runtime.supervision.checkgeometry`), done for all remaining
tasks at once on the raw points: no perception (clustering into boxes) and no rollout
objects, so a check costs a few array operations, however many tasks remain. The supervisor runs it once a revolution; a
failed check sends it to REPLANNING. :func:`resimulate_plan` is the same verdict from the
planner's :func:`clomp.planner.rollout.simulate` on perceived obstacles (kept as the reference
the tests compare against).

:func:`recall` is what REPLANNING tries first: match the current situation to a state of
the existing map — an uninterrupted state whose end pose is where the robot now is
(within ``tolerance``), looked up in a grid of the map's end poses
(:class:`RecallIndex`, built once per map) — extract the plan the map holds from there
to its best state, and keep it only if :func:`check_plan` finds its tasks free on the new
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

from clomp.formal.geometry import compose, relative, wrap_angle
from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.formal.scheduler import map_policy, policy_path
from clomp.formal.supervisory import Guard, Plan
from clomp.planner import footprint
from clomp.planner.configurator import PlanResult
from clomp.planner.perception import Obstacles, perceive
from clomp.planner.recovery import simulate_reverse
from clomp.planner.rollout import simulate
from clomp.planner.robot_model import RobotModel
from clomp.runtime.supervision.checkgeometry import _ends_off, _Leg, _legs, _points, _straight_contacts, _turn_contacts

_STRAIGHT = TaskKind.STRAIGHT  # looked up once: a member lookup is a descriptor call
_REVERSE = TaskKind.REVERSE

__all__ = [
    "CheckResult",
    "Recall",
    "RecallIndex",
    "check_plan",
    "perceive_near",
    "perceive_scan",
    "recall",
    "resimulate_plan",
]


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
    return perceive(scan, robot.sensor_range, robot.cluster_distance, body=footprint.body_box(robot))


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
    seen: Obstacles | np.ndarray,
    robot: RobotModel,
    *,
    tolerance: tuple[float, float] = (0.08, 0.3),
    running: bool = False,
    allowance: float = 0.0,
) -> CheckResult:
    """Test ``states`` (planner frame at ``origin``) from ``pose`` against ``seen``: the
    scan's points (N×2, robot frame at ``pose``) or perceived obstacles; see the module
    docstring.

    ``goal`` (the supervisor's frame) is kept for the signature :func:`resimulate_plan`
    shares; the geometry does not need it. ``running``: the first state is the task under
    way, checked from the current pose to its predicted end. A task fails when it meets a
    point more than ``tolerance`` before its end (m for a straight, rad for a turn) or
    would end farther than ``tolerance`` from the map's prediction. ``allowance`` (m): a
    point must lie that much inside the inflated body to count (the sensor's noise).

    >>> from clomp.formal.model import Disturbance
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> step = State(1, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.5, 0.0), distance=0.5)
    >>> o = Pose(0.0, 0.0, 0.0)
    >>> check_plan([step], o, o, Pose(1.0, 0.0), np.zeros((0, 2)), RobotModel()).ok
    True
    >>> wall = np.c_[np.full(21, 0.4), np.linspace(-0.2, 0.2, 21)]
    >>> check_plan([step], o, o, Pose(1.0, 0.0), wall, RobotModel()).reason
    'task 1 (STRAIGHT) now meets an obstacle after 0.29 of 0.50 m'
    """
    del goal  # the straights run their planned length whatever the goal
    t0 = time.perf_counter()
    if not states:
        return CheckResult(True, "nothing left to check", 0, time.perf_counter() - t0)
    return _check(states, relative(pose, origin), _points(seen, robot), robot, tolerance, running, allowance, t0)


def _check(states: list[State], frame: Pose, z: np.ndarray, robot: RobotModel, tolerance: tuple[float, float],
           running: bool, allowance: float, t0: float) -> CheckResult:
    """:func:`check_plan` on the scan's points ``z`` (complex, robot frame), with the plan's
    frame seen from the robot. The verdict names the first task that is blocked or ends off
    the map's prediction, so no task after the first that ends off needs a contact test."""
    legs = _legs(states, frame, running)
    offs: list[tuple[float, float] | None] = [None] * len(legs)
    straights: list[_Leg] = []
    reverses: list[_Leg] = []
    turns: list[_Leg] = []
    for g in legs:
        if g.amount > 1e-3:
            if g.kind is _STRAIGHT:
                straights.append(g)
            elif g.kind is _REVERSE:  # backwards: against the points behind (the A1 sees all round)
                reverses.append(g)
            else:
                turns.append(g)
            off = offs[g.k] = _ends_off(g, tolerance)
            if off is not None:  # the verdict: this task at the latest, so none after it needs testing
                break
    blocked: dict[int, float] = {}
    if z.size:
        for legs_, back in ((straights, False), (reverses, True)):
            if legs_:
                for g, d in zip(legs_, _straight_contacts(z, legs_, robot, allowance, backwards=back)):
                    if d < g.amount - tolerance[0]:
                        blocked[g.k] = d
        first = min(blocked, default=len(legs))
        turns = [g for g in turns if g.k < first]
        if turns:
            for g, turned in zip(turns, _turn_contacts(z, turns, robot, allowance)):
                if turned < g.amount - tolerance[1]:
                    blocked[g.k] = turned
    return _verdict(legs, blocked, len(states), offs, t0)


def _verdict(legs: list[_Leg], blocked: dict[int, float], n: int, offs: list[tuple[float, float] | None],
             t0: float) -> CheckResult:
    """The check's result: the first leg (in order) that is ``blocked`` (where it meets a
    point) or ends off the map's prediction (``offs``: :func:`_ends_off` per leg) fails the plan."""
    for g in legs:
        k = g.k
        off = offs[k]
        if k not in blocked and off is None:
            continue
        name = f"task {k + 1} ({g.kind.value})"
        if k in blocked:
            if g.kind is _STRAIGHT or g.kind is _REVERSE:
                behind = " behind" if g.kind is _REVERSE else ""
                why = f"{name} now meets an obstacle{behind} after {max(blocked[k], 0.0):.2f} of {g.amount:.2f} m"
            else:
                why = f"{name} now meets an obstacle"
            return CheckResult(False, why, k + 1, time.perf_counter() - t0)
        assert off is not None
        return CheckResult(False, f"{name} would end {off[0]:.3f} m, {math.degrees(off[1]):.0f}° "
                                  f"from the map's prediction", k + 1, time.perf_counter() - t0)
    return CheckResult(True, f"{n} task(s) still free and on the map", n, time.perf_counter() - t0)


def resimulate_plan(
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
    """:func:`check_plan`'s verdict by re-simulating each task with the planner's
    :func:`clomp.planner.rollout.simulate` among perceived ``obstacles`` (the reference; slower).

    Each task starts where the previous one's rollout ended; a straight's rollout is the
    planner's (cut into steps, at the rim of the sensed disc), so it sees no further.
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
        if q.task is TaskKind.WAIT:  # stands where the map says
            start = end
            continue
        if q.task is TaskKind.REVERSE:  # backs off against what is behind: the planner's REVERSE rollout
            behind = (start.x - end.x) * math.cos(start.theta) + (start.y - end.y) * math.sin(start.theta)
            length = behind if first else math.hypot(end.x - planned_start.x, end.y - planned_start.y)
            back = simulate_reverse(start, goal_d, obstacles, robot, distance=length) if length > 1e-3 else None
            if back is not None and back.d_n is not None and back.distance < length - tolerance[0]:
                return CheckResult(False, f"task {k + 1} ({q.task.value}) now meets an obstacle behind after "
                                          f"{back.distance:.2f} of {length:.2f} m", k + 1, time.perf_counter() - t0)
            c, s = math.cos(start.theta), math.sin(start.theta)
            start = Pose(start.x - c * length, start.y - s * length, start.theta)
            continue
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


class RecallIndex:
    """The states of one map a recall may start from, indexed by end pose.

    The uninterrupted states reachable from q0 go into a grid of ``cell`` m squares by
    where they end (planner frame), so a recall looks up the few cells around the robot
    instead of scanning the map; the map's continuation from each state is worked out
    once and remembered. Given the map's plan ρ (ending at the least-φ state), the
    continuation from each state of ρ is the rest of ρ, known at once. ``build_s``: the
    seconds building the index took.

    >>> from clomp.formal.lts import CognitiveMap
    >>> from clomp.formal.model import Disturbance
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=1.0),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.3, 0), cost=0.5),
    ...      State(2, TaskKind.STRAIGHT, g, None, Pose(0.3, 0), Pose(0.6, 0), cost=0.2)], [(0, 1), (1, 2)], goal=g)
    >>> RecallIndex(m).near(Pose(0.31, 0.0, 0.0))
    [1]
    """

    def __init__(self, cmap: Any, cell: float = 0.04, plan: Plan | None = None, psi: dict[Any, int] | None = None) -> None:
        t0 = time.perf_counter()
        self.map = cmap
        self.cell = cell
        self._grid: dict[tuple[int, int], list[tuple[int, float, float, float, float]]] = {}  # ident, end pose, φ
        best: State | None = None
        for i in cmap.reachable():
            q = cmap[i]
            if not q.interrupted:
                self._grid.setdefault(self._key(q.end.x, q.end.y), []).append((i, q.end.x, q.end.y, q.end.theta, q.cost))
                if i != cmap.initial_id and (best is None or (q.cost, q.ident) < (best.cost, best.ident)):
                    best = q
        self._paths: dict[int, list[int] | None] = {}
        self._prefix: dict[int, list[int]] = {}
        if plan is not None and map_policy(cmap) is None and best is not None and plan.states[-1] == best.ident:
            # ρ ends at the map's least-φ state, so from each of its states the map's plan
            # leads on along ρ (the same end :func:`_best_from` finds, by ρ's own path)
            states = list(plan.states)
            for k, ident in enumerate(states[:-1]):
                self._prefix[ident] = states[:k + 1]
                self._paths[ident] = states[k:] if best.cost < cmap[ident].cost else None
        self._psi = psi  # a guard of this map, whose keys the recalled plans' guards reuse
        self.build_s = time.perf_counter() - t0  # how long building it took (s)

    def guard(self, result: PlanResult, plan: Plan) -> dict[Any, int]:
        """Ψ of ``plan`` on ``result``'s map (:meth:`clomp.formal.supervisory.Guard.table`),
        reusing the keys of the guard given with the index, else of the result's."""
        like = self._psi if result.map is self.map and self._psi is not None else result.psi
        return Guard(result.map, plan).table(like=like)

    def _key(self, x: float, y: float) -> tuple[int, int]:
        return math.floor(x / self.cell), math.floor(y / self.cell)

    def near(self, here: Pose, tolerance: tuple[float, float] = (0.04, 0.15)) -> list[int]:
        """The indexed states ending within ``tolerance`` of ``here`` (planner frame), least φ first."""
        cx, cy = self._key(here.x, here.y)
        r = max(1, math.ceil(tolerance[0] / self.cell))
        found = []
        grid, hx, hy, hth = self._grid, here.x, here.y, here.theta
        for i in range(cx - r, cx + r + 1):
            for j in range(cy - r, cy + r + 1):
                for ident, x, y, th, cost in grid.get((i, j), ()):
                    d = math.hypot(x - hx, y - hy)
                    if d <= tolerance[0] and abs(wrap_angle(th - hth)) <= tolerance[1]:
                        found.append((cost, d, ident))
        return [ident for _c, _d, ident in sorted(found)]

    def continuation(self, result: PlanResult, source: int) -> list[int] | None:
        """The map's plan from ``source`` (see :func:`_best_from`), remembered."""
        if source not in self._paths:
            self._paths[source] = _best_from(result, source)
        return self._paths[source]

    def prefix(self, ident: int) -> list[int]:
        """A path of the map from q0 to ``ident``: along ρ when ``ident`` is on it."""
        known = self._prefix.get(ident)
        return list(known) if known is not None else self.map.path(ident)


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
    seen: Obstacles | np.ndarray,
    robot: RobotModel,
    *,
    tolerance: tuple[float, float] = (0.04, 0.15),
    check_tolerance: tuple[float, float] = (0.08, 0.3),
    index: RecallIndex | None = None,
    allowance: float = 0.0,
) -> tuple[Recall | None, str, float]:
    """Recall a plan from ``result``'s map for the robot at ``pose``; see the module docstring.

    ``seen``: the scan's points (robot frame at ``pose``) or perceived obstacles.
    ``tolerance`` is how close (m, rad) a state's end must be to the robot's pose;
    ``check_tolerance`` and ``allowance`` are :func:`check_plan`'s. ``index``: the map's
    :class:`RecallIndex` when the caller keeps one (built here otherwise). Returns (the
    recall or None, why, seconds).
    """
    t0 = time.perf_counter()
    cmap = result.map
    if index is None or index.map is not cmap:
        index = RecallIndex(cmap, plan=result.plan)
    here = relative(origin, pose)  # planner frame
    candidates = index.near(here, tolerance)
    if not candidates:
        return None, "no state of the map is where the robot is", time.perf_counter() - t0
    last = "no state of the map leads on from here"
    z, frame = None, relative(pose, origin)  # the scan's points, made once for every candidate
    for ident in candidates:
        path = index.continuation(result, ident)
        if path is None:
            continue
        states = [cmap[i] for i in path[1:]]
        if z is None:
            z = _points(seen, robot)
        c0 = time.perf_counter()
        verdict = _check(states, frame, z, robot, check_tolerance, False, allowance, c0) if states else \
            CheckResult(True, "nothing left to check", 0, 0.0)
        if not verdict.ok:
            last = f"from q{ident}: {verdict.reason}"
            continue
        # the recalled plan, as a plan of the same map: ρ from q0 through the recalled state
        full = index.prefix(ident)[:-1] + path
        plan = Plan(tuple(full))
        recalled = dataclasses.replace(result, plan=plan, psi=index.guard(result, plan), planning_time_s=time.perf_counter() - t0)
        return Recall(recalled, ident, verdict), f"recalled from q{ident}: {verdict.reason}", time.perf_counter() - t0
    return None, last, time.perf_counter() - t0
