"""The Configurator (G, D_G, Ψ, R): best-first construction of the cognitive map.

Algorithm 1 of the paper. From the state to expand q_E, every option is simulated
depth-first until a STRAIGHT state is reached or the task is interrupted (D_N ≠ ∅):
STRAIGHT; LEFT then STRAIGHT; RIGHT then STRAIGHT. The frontier states, interrupted
ones included, go into a priority queue ordered by φ = γ + χ and the next q_E is the
one of least φ. It stops when a state reaches D_G, when the least-φ state has no
obstacle-free transition (it was interrupted: ``metadata["stopped_at"]`` names it), or
when the budget (``max_states``, default 50: the authors' planner never needed more
than 60 states on the shared scans, and the same shared scans reach the goal with a
budget of 50 as of 100) is spent. A state on the rim of the sensed disc is not expanded
(what lies beyond is unknown) but stays a candidate end of the plan: when argmin φ is
one, the plan ends there (``frontier``: the goal needs unseen space) and the closed loop
drives there and replans. For a goal inside the disc the search goes on past such a
state (ending it there, as before, gave up on ways round inside the disc: recorded scans
43, 117, 137); for a goal beyond the disc no way inside reaches it, and the first rim
state popped ends the search. States beyond the planning
horizon (a box of half-size ``horizon`` around the start) are kept but not expanded.

Known-free space is what the scan's rays crossed (:mod:`clomp.planner.visibility`): a
task whose swept body leaves it is treated as one that meets the rim — a STRAIGHT is a
frontier state (kept as a candidate end, not expanded, never a goal), a turn is not
available. So a plan's body never passes through space no ray crossed before its last
task, and ``reached_goal`` holds only for a plan wholly inside known-free space. A goal
in a shadow is treated as one beyond the disc: no way inside known-free space reaches it,
and the first frontier state popped ends the search (searching on to the budget cost
more and, in the closed loop, reached the goal in 20 of 28 seeded runs against 21).

γ ∈ [1, 2] on an interrupted state and χ ∈ [0, 1) everywhere, so a hit is popped only
when no free state is left: with the default cost the maps and plans are those of a
search that never queued hits (the same on the 7 scenarios and 20 recorded scans), and
γ's sense (the sooner the hit, the dearer) picks which hit ends the search. Dropping γ
(``cost=chi``) changes 24 of those 27 maps: a hit near the goal becomes the least-φ
state and ends the search, and none of the 20 recorded scans reaches the goal.

The plan ends at argmin φ over the uninterrupted states or, when that is a frontier, q0 or a
local minimum the search looked past (its cheapest open state a frontier), at the frontier of
least goal distance + metres driven, nearer the goal than q0 if one is (:func:`~clomp.formal.supervisory.plan_end`).
The tie rule: of states of equal φ the first created (the lowest ident) wins, so a plan
never ends on a turn in place, whose end is as far from the goal as its parent's (created
before it). No turn turns by nothing: a turn whose chosen angle is below
:data:`clomp.planner.rollout.MIN_TURN` (1°) is not available, so every turn in the map
changes the heading.
A search that spends its budget is searched again deeper by
:func:`clomp.planner.deepening.plan_deepening` (the supervisor's and the commands' way).

A state is determined by its task and its start pose (rollouts are deterministic), so a
task reached twice from the same pose is one state with two incoming transitions: the
map is a graph, and expansion never repeats a simulation.
"""

from __future__ import annotations

import functools
import heapq
import math
import time
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, State, TaskKind, new_state
from clomp.formal.supervisory import FRONTIER, Guard, Plan, Reset, argmin_phi, extract_plan
from clomp.planner import footprint
from clomp.planner.perception import Obstacles, load_scan, perceive
from clomp.planner.recovery import RECOVERY_TASKS, Recovery, cleared_points
from clomp.planner.rollout import Outcome, simulate
from clomp.planner.robot_model import RobotModel
from clomp.planner.visibility import KnownFree

__all__ = [
    "CostContext",
    "CostFunction",
    "Rollout",
    "default_cost",
    "gamma",
    "chi",
    "GOAL_LIMIT_M",
    "PlanningError",
    "PlanResult",
    "Configurator",
    "plan",
]

#: the farthest goal (metres, per coordinate) the planner accepts: beyond it squared distances
#: lose the centimetres the planner works in (at 1e200 they overflow and the plan comes back empty)
GOAL_LIMIT_M = 1.0e6


class PlanningError(ValueError):
    """The planning problem is ill-posed (goal inside an obstacle, at the robot, NaN …).

    >>> try:
    ...     Configurator().plan(np.zeros((0, 2)), (0.0, 0.0))
    ... except PlanningError as exc:
    ...     print(exc)
    goal (0, 0) is at the robot's own position (within 0.05 m)
    """


@dataclass(frozen=True)
class CostContext:
    """What a cost function may know besides the state: the goal, the start and the robot.

    >>> ctx = CostContext(Disturbance.goal(3.0, 4.0), Pose(0.0, 0.0), RobotModel())
    >>> ctx.start_distance
    5.0
    """

    goal: Disturbance
    origin: Pose
    robot: RobotModel

    @functools.cached_property
    def start_distance(self) -> float:
        """d0 = ‖D_G − start‖, the normaliser of χ (computed once per context)."""
        return self.origin.distance_to(self.goal.x, self.goal.y)


#: a cost function of the best-first search: (state, context) -> cost, lower explored first
CostFunction = Callable[[State, CostContext], float]


class Rollout(Protocol):
    """What γ and χ read of a state: where its task started and ended, and what
    interrupted it. A :class:`State` is one; so is the rollout a state is about to be
    built from (:class:`clomp.planner.engine.Outcome`), which lets the Configurator price
    a rollout with the very functions below before it builds the state.

    >>> from clomp.planner.engine import Outcome
    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> out = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.5, 0.0), 0.5, 2.5, 25, None, False)
    >>> default_cost(out, ctx) == default_cost(State(1, TaskKind.STRAIGHT, ctx.goal, None, out.start, out.end), ctx)
    True
    """

    @property
    def start(self) -> Pose: ...

    @property
    def end(self) -> Pose: ...

    @property
    def d_n(self) -> Disturbance | None: ...


def gamma(state: Rollout, ctx: CostContext) -> float:
    """γ(q), the past cost: 0 when the task was not interrupted; otherwise
    ``2 − min(d_N, r)/r`` ∈ [1, 2], with d_N the distance from the start of the task to
    the point where D_N interrupted it and r the sensor range (the paper's "normalised
    distance from the start of the task to D_N": the sooner the hit, the dearer).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> clear = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.27, 0))
    >>> gamma(clear, ctx)
    0.0
    >>> hit = State(2, TaskKind.STRAIGHT, ctx.goal, Disturbance.goal(0.0, 0.0), Pose(0, 0), Pose(0.0, 0))
    >>> gamma(hit, ctx)   # hit at once: the dearest
    2.0
    """
    if state.d_n is None:
        return 0.0
    r = ctx.robot.sensor_range
    d = state.start.distance_to(state.d_n.x, state.d_n.y)
    return 2.0 - min(d, r) / r


def chi(state: Rollout, ctx: CostContext) -> float:
    """χ(q), the heuristic future cost: ``d / (d + d0)`` ∈ [0, 1), with d the distance
    from the end of the task to D_G and d0 that from the start of planning: 0 at the
    goal, 1/2 where planning began, approaching 1 far away (normalised so that any
    uninterrupted state costs less than any interrupted one).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> far = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.0, 0))
    >>> near = State(2, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.9, 0))
    >>> chi(near, ctx) < chi(far, ctx)
    True
    """
    d = state.end.distance_to(ctx.goal.x, ctx.goal.y)
    d0 = ctx.start_distance
    return d / (d + d0) if d + d0 > 0 else 0.0


def default_cost(state: Rollout, ctx: CostContext) -> float:
    """φ(q) = γ(q) + χ(q) (Hart, Nilsson & Raphael 1968, in the paper's §2.2).

    >>> ctx = CostContext(Disturbance.goal(1.0, 0.0), Pose(0.0, 0.0), RobotModel())
    >>> q = State(1, TaskKind.STRAIGHT, ctx.goal, None, Pose(0, 0), Pose(0.5, 0))
    >>> default_cost(q, ctx) == gamma(q, ctx) + chi(q, ctx)
    True
    """
    return gamma(state, ctx) + chi(state, ctx)


@dataclass
class PlanResult:
    """The outcome of planning: the cognitive map, the plan and its figures.

    >>> r = Configurator().plan(np.zeros((0, 2)), (1.0, 0.0))
    >>> r.reached_goal, r.collision_free, [s.task.value for s in r.steps]
    (True, True, ['STRAIGHT'])
    >>> r.to_dict()["reached_goal"]
    True
    """

    map: CognitiveMap
    plan: Plan
    goal: Disturbance
    obstacles: Obstacles
    robot: RobotModel
    planning_time_s: float
    stop_reason: str
    psi: dict[Any, int] = field(default_factory=dict)
    goal_blocked: bool = False

    @property
    def reached_goal(self) -> bool:
        """True when the plan ends within the goal tolerance."""
        return self.map[self.plan.end].reached_goal and not self.goal_blocked

    @property
    def collision_free(self) -> bool:
        """True when no state of the plan was interrupted."""
        return not any(self.map[i].interrupted for i in self.plan.states)

    @property
    def steps(self) -> list[State]:
        """The planned tasks q1 … qn."""
        return self.plan.tasks(self.map)

    @property
    def n_states(self) -> int:
        """The number of states, ``|Q|``."""
        return len(self.map)

    @property
    def transitions(self) -> int:
        """The number of transitions, ``|↪|``."""
        return self.map.n_transitions

    def to_dict(self) -> dict[str, Any]:
        """The JSON summary printed by ``clomp plan --json``."""
        return {
            "plan": [
                {
                    "task": s.task.value,
                    "start": [round(v, 6) for v in s.start.as_list()],
                    "end": [round(v, 6) for v in s.end.as_list()],
                    "state": s.ident,
                }
                for s in self.steps
            ],
            "reached_goal": self.reached_goal,
            "collision_free": self.collision_free,
            "states": self.n_states,
            "transitions": self.transitions,
            "planning_time_s": self.planning_time_s,
            "goal": [self.goal.x, self.goal.y],
            "obstacles": len(self.obstacles),
            "stop_reason": self.stop_reason,
            "goal_blocked": self.goal_blocked,
        }


class Configurator:
    """Builds cognitive maps by best-first simulation and extracts plans from them.

    >>> import numpy as np
    >>> r = Configurator().plan(np.zeros((0, 2)), goal=(1.0, 0.0))
    >>> [s.task.value for s in r.steps], r.reached_goal
    (['STRAIGHT'], True)
    """

    def __init__(
        self,
        robot: RobotModel | None = None,
        cost: CostFunction = default_cost,
        max_states: int = 50,
        horizon: float = 1.2,
        routes: int = 1,
        recovery: bool = False,
    ) -> None:
        if max_states < 1:
            raise ValueError("max_states must be at least 1")
        if not (math.isfinite(horizon) and horizon > 0):
            raise ValueError("horizon must be a positive number of metres")
        if isinstance(routes, bool) or not isinstance(routes, int) or routes < 1:
            raise ValueError("routes must be a whole number >= 1")
        self.robot = robot or RobotModel()
        self.cost = cost
        self.max_states = int(max_states)
        self.horizon = float(horizon)
        self.routes = routes
        self.recovery = bool(recovery)
        """Plan with WAIT and REVERSE too (issue #42; off by default: static worlds plan as
        before): :mod:`clomp.planner.recovery` says when they are offered."""
        self.transient: np.ndarray | None = None
        """With ``recovery``: a boolean mask over the next scan :meth:`plan` is given, True
        on the points that appeared where earlier scans saw free space (possibly moving;
        set by the supervisor, used once by :meth:`plan`): a WAIT is offered, and the world
        after it has none of them."""
        """How many ends the search collects before it stops: 1 (Algorithm 1) stops at the
        first goal state (a popped frontier state is kept, not expanded, and the search
        goes on when the goal lies inside the sensed disc, else it ends there); more keep searching for alternative routes (a goal state or popped
        frontier is then kept, not expanded, and counts as one), e.g. for a risk-aware
        choice among them (:class:`clomp.planner.robust.RobustConfigurator`)."""

    # -- inputs ---------------------------------------------------------------------
    def _goal(self, goal: Disturbance | tuple[float, float], obstacles: Obstacles) -> tuple[Disturbance, bool]:
        if isinstance(goal, Disturbance):
            g = goal
        else:
            try:
                gx, gy = (float(v) for v in goal)
            except (TypeError, ValueError):
                raise PlanningError(f"goal must be two numbers x, y, got {goal!r}") from None
            if not (math.isfinite(gx) and math.isfinite(gy)):
                raise PlanningError(f"goal must be finite, got ({gx}, {gy})")
            g = Disturbance.goal(gx, gy)
        if not (abs(g.x) <= GOAL_LIMIT_M and abs(g.y) <= GOAL_LIMIT_M):
            raise PlanningError(f"goal ({g.x:g}, {g.y:g}) is beyond {GOAL_LIMIT_M:g} m: not a place to plan to")
        if math.hypot(g.x, g.y) <= self.robot.goal_tolerance:
            raise PlanningError(
                f"goal ({g.x:g}, {g.y:g}) is at the robot's own position (within {self.robot.goal_tolerance} m)"
            )
        # a goal inside what the scan shows is a situation, not bad input: plan towards it
        # (the plan ends at the closest reachable state) and say so
        return g, obstacles.contains_point(g.x, g.y) is not None

    # -- Algorithm 1 ------------------------------------------------------------------
    def build(self, obstacles: Obstacles, goal: Disturbance | tuple[float, float],
              cleared: Obstacles | None = None) -> PlanResult:
        """Construct the cognitive map for ``goal`` among ``obstacles`` and extract ρ.

        ``stop_reason`` is ``goal`` (a state reached D_G), ``frontier`` (the plan ends at a
        frontier state, argmin φ or an exploring end of :func:`~clomp.formal.supervisory.plan_end`,
        where the body leaves the space the scan showed free: the goal needs unseen space,
        and the closed loop drives there and replans), ``budget``
        (``max_states`` spent) or ``exhausted`` (no obstacle-free transition left). ``goal_blocked`` is True when
        the goal lies inside a perceived obstacle: the plan then ends at the reachable
        state closest to it and ``reached_goal`` is False. ``cleared`` (with ``recovery``):
        the obstacles once what is transient has gone, the world after a WAIT.
        """
        t0 = time.perf_counter()
        g, blocked = self._goal(goal, obstacles)
        search = _Search(self, obstacles, g, cleared)
        stop = search.run()
        cmap = search.cmap
        p = extract_plan(cmap, stop == "budget")
        # a plan that ends at the frontier: ``frontier`` — unless the search spent its budget
        # and the plan explores (argmin φ is no frontier): still ``budget``, so that a deeper
        # search (:mod:`clomp.planner.deepening`) may find a way closer first
        if not cmap[p.end].reached_goal and p.end in search.frontier_ids and not (
            stop == "budget" and p.end != (q := argmin_phi(cmap).ident) and q not in search.frontier_ids
        ):
            stop = "frontier"
        psi = Guard(cmap, p).table()
        cmap.metadata.update(
            {
                "robot": self.robot.to_dict(),
                "horizon": search.horizon,
                "max_states": self.max_states,
                "stop_reason": stop,
                "goal_blocked": blocked,
                "plan": list(p.states),
                # the boxes as an array (a copy: a snapshot, as the lists were), written as
                # lists by CognitiveMap.to_dict: a plan no longer pays for nested lists of
                # ~700 floats (8 % of a plan's time) that only a written map reads
                "obstacles": obstacles.boxes.copy(),
            }
        )
        elapsed = time.perf_counter() - t0
        return PlanResult(cmap, p, g, obstacles, self.robot, elapsed, stop, psi, blocked)

    def plan(
        self,
        scan: np.ndarray | str | Any,
        goal: Disturbance | tuple[float, float],
    ) -> PlanResult:
        """Perceive ``scan`` (array or file) and plan to ``goal``; see :meth:`build`.

        ``planning_time_s`` covers perception and map construction.
        """
        t0 = time.perf_counter()
        # a float N×2 array goes to perception as it is: perception validates it where it
        # must (some point not kept: a nan or inf never is), with the same ScanError
        if type(scan) is np.ndarray and scan.dtype == np.float64 and scan.ndim == 2 and scan.shape[1] == 2:
            pts: np.ndarray = scan
        else:
            pts = load_scan(scan)
        r = self.robot
        obstacles = perceive(pts, r.sensor_range, r.cluster_distance, body=footprint.body_box(r))
        cleared = None
        if self.recovery:  # the world after a WAIT: the scan without what appeared (issue #42)
            kept, self.transient = cleared_points(pts, self.transient), None
            if kept is not None:
                with warnings.catch_warnings():  # the scan's warnings were given once, above
                    warnings.simplefilter("ignore")
                    cleared = perceive(kept, r.sensor_range, r.cluster_distance, body=footprint.body_box(r))
        result = self.build(obstacles, goal, cleared)
        result.planning_time_s = time.perf_counter() - t0
        return result


_FRONTIER = ((FRONTIER, 1.0),)
#: the cost functions that read only what a :class:`Rollout` has (priced before the state is built)
_ROLLOUT_COSTS: tuple[Callable[[Rollout, CostContext], float], ...] = (default_cost, gamma, chi)
_STRAIGHT = TaskKind.STRAIGHT
_KINDS = (TaskKind.STRAIGHT, TaskKind.LEFT, TaskKind.RIGHT)


def _state(ident: int, out: Outcome, d_i: Disturbance, cost: float) -> State:
    return new_state(
        ident,
        out.task,
        d_i,
        out.d_n,
        out.start,
        out.end,
        out.distance,
        out.duration,
        cost,
        out.reached_goal,
        _FRONTIER if out.frontier else (),
    )


class _Search:
    """One run of Algorithm 1 (:meth:`Configurator.build`): the map as it grows, the
    states already simulated (by task and start pose), the priority queue on φ and the
    ends found so far."""

    def __init__(self, conf: Configurator, obstacles: Obstacles, g: Disturbance, cleared: Obstacles | None = None) -> None:
        robot = conf.robot
        origin = Pose(0.0, 0.0, 0.0)
        self.ctx = ctx = CostContext(g, origin, robot)
        self.cost = cost = conf.cost
        # the cost as one that reads a Rollout: a rollout is priced before its state is built
        self.priced = next((f for f in _ROLLOUT_COSTS if f is cost), None)
        self.obstacles, self.robot, self.goal = obstacles, robot, g
        self.routes, self.max_states = conf.routes, conf.max_states
        # what the rays crossed (:mod:`clomp.planner.visibility`): a task whose body leaves it is a frontier end
        self.known = KnownFree.from_points(obstacles.points, robot.sensor_range, robot=robot)
        # inside the sensed disc and where the rays went: a way to it may lie inside too (a
        # goal in a shadow, like one beyond the disc, has none: the first frontier popped ends it)
        self.goal_seen = ctx.start_distance <= robot.sensor_range and self.known.contains(g.x, g.y)
        self.horizon = max(conf.horizon, abs(g.x) + robot.length, abs(g.y) + robot.length)
        self.cmap = CognitiveMap(goal=g)
        self.reset = Reset(self.cmap)  # R, the one reset of formal
        q0 = new_state(0, _STRAIGHT, g, None, origin, origin, 0.0, 0.0, 0.0, False, ())
        q0 = new_state(0, _STRAIGHT, g, None, origin, origin, 0.0, 0.0, cost(q0, ctx), False, ())
        self.cmap.add_state(q0)
        self.index: dict[tuple[Any, ...], int] = {}
        self.frontier_ids: set[int] = set()
        self.worlds: dict[Any, Any] = {}
        self.pq: list[tuple[float, int]] = [(q0.cost, 0)]
        self.ends = 0  # popped frontier states, and with goal_ids the routes found (``routes``)
        self.goal_ids: set[int] = set()
        self.recovery = Recovery(cleared) if conf.recovery else None  # WAIT and REVERSE (issue #42)

    def push(self, s: State) -> None:
        """Queue ``s`` for expansion: by φ, a WAIT first (look past the wait before a detour)."""
        heapq.heappush(self.pq, (0.0 if s.task is TaskKind.WAIT else s.cost, s.ident))

    def run(self) -> str:
        """Pop least-φ states and expand them until the search ends; the stop reason
        (``goal`` whenever a goal state was found, even with fewer routes than asked for)."""
        stop = self._loop()
        return "goal" if self.goal_ids else stop

    def _loop(self) -> str:
        pq, cmap, frontier_ids = self.pq, self.cmap, self.frontier_ids
        while pq:
            _, qe_id = heapq.heappop(pq)
            if qe_id in frontier_ids:
                # the state lies on the rim of what the scan saw: what is beyond is unknown,
                # so it is not expanded. With one route and the goal inside the disc it stays
                # a candidate end of the plan (argmin φ, where the closed loop drives and
                # replans) while the search goes on for a way to the goal inside the disc;
                # a goal beyond the disc has none, and the search ends here
                self.ends += 1
                if (self.routes == 1 and self.goal_seen) or self.ends + len(self.goal_ids) < self.routes:
                    continue
                if cmap[qe_id].cost >= cmap[0].cost:
                    # a frontier no better than where the robot stands: search on for a better
                    # end, as far as the budget goes (a shadowed goal behind a U or a box just
                    # ahead); if none, the plan explores to the best frontier (plan_end)
                    continue
                return "frontier"
            qe = cmap[qe_id]
            if qe.interrupted:
                # Algorithm 1's end: the least-φ state has no obstacle-free transition
                # (R is undefined after a hit), so nothing cheaper is left to expand
                cmap.metadata["stopped_at"] = qe_id
                return "exhausted"
            stop = self._expand(qe)
            if stop is not None:
                return stop
        return "exhausted"

    def _expand(self, qe: State) -> str | None:
        """Simulate every option from ``qe`` (STRAIGHT; LEFT then STRAIGHT; RIGHT then
        STRAIGHT) and queue the fresh frontier states; ``budget`` or ``goal`` when the
        search ends here, else None."""
        cmap = self.cmap
        free = False  # some option from qe ends collision-free (else a REVERSE is offered)
        for kind in _KINDS:
            turn = kind is not _STRAIGHT
            if len(cmap) + (2 if turn else 1) > self.max_states:
                return "budget"
            first, fresh = self._child(qe, kind)
            if first is None:
                continue
            end = first
            if turn and first.d_n is None:
                second, fresh = self._child(first, _STRAIGHT)
                assert second is not None
                end = second
            free = free or end.d_n is None
            if end.reached_goal:
                self.goal_ids.add(end.ident)
                if self.ends + len(self.goal_ids) >= self.routes:
                    return "goal"
                continue
            # every frontier state enters PQ with φ = γ + χ, interrupted ones too; a free
            # one beyond the planning horizon is kept but not queued
            if fresh and (end.interrupted or (abs(end.end.x) <= self.horizon and abs(end.end.y) <= self.horizon)):
                heapq.heappush(self.pq, (end.cost, end.ident))
        return None if self.recovery is None else self.recovery.expand(self, qe, free)

    def _child(self, parent: State, kind: TaskKind) -> tuple[State | None, bool]:
        """The state of ``kind`` started where ``parent`` ended (simulated once), and whether
        it is new; None when the task is not available (a turn that would leave the sensed disc)."""
        p = parent.end
        k: tuple[Any, ...] = (kind, round(p.x * 1e6), round(p.y * 1e6), round(p.theta * 1e6))
        cmap = self.cmap
        rec, obstacles, worlds, layer = self.recovery, self.obstacles, self.worlds, False
        if rec is not None:
            obstacles, worlds, layer = rec.world(self, parent)
            k = k + (1,) if layer else k
        known = self.index.get(k)
        if known is not None:
            if known < 0:
                return None, False
            cmap.add_transition(parent.ident, known, kind)
            return cmap[known], False
        d_i = self.reset.after(parent)  # R(q1, q2) = D_G, undefined (raises) when q1 was interrupted
        if rec is not None and kind in RECOVERY_TASKS:
            got = rec.outcome(kind, p, d_i, obstacles, self.robot)
            if got is None:  # a REVERSE whose end leaves the sensed disc: not available
                self.index[k] = -1
                return None, False
            out = got
        else:
            out = simulate(kind, p, d_i, obstacles, self.robot, worlds)
            # (the body at the task's start is known: the root's stands there, any other's ended
            # the task before, which passed this test)
            if out.d_n is None and (out.reached_goal or not out.frontier) and not self.known.clear(out, self.robot, True):
                # the body would pass through space no ray crossed (a shadow): like the rim of
                # the disc, a STRAIGHT ends the way there (a frontier end, never a goal), a
                # turn is not available
                out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, False, True)
        if out.frontier and kind is not _STRAIGHT:
            self.index[k] = -1
            return None, False
        ident = len(cmap)
        priced = self.priced
        phi = priced(out, self.ctx) if priced is not None else self.cost(_state(ident, out, d_i, 0.0), self.ctx)
        s = _state(ident, out, d_i, phi)
        cmap.add_state(s)
        cmap.add_transition(parent.ident, ident, kind)
        self.index[k] = ident
        if layer:
            rec.after_wait.add(ident)  # type: ignore[union-attr]
        if out.frontier:
            self.frontier_ids.add(ident)
        return s, True


def plan(
    scan: Any,
    goal: tuple[float, float] | Disturbance = (1.0, 0.0),
    robot: RobotModel | None = None,
    **options: Any,
) -> PlanResult:
    """Plan from a scan (N×2 array, text or .npy file) to ``goal`` (robot frame).

    >>> import numpy as np
    >>> plan(np.zeros((0, 2)), goal=(1.0, 0.0)).reached_goal
    True
    """
    return Configurator(robot=robot, **options).plan(scan, goal)


