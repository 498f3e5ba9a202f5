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
map is a graph, and expansion never repeats a simulation. The search itself runs in
:mod:`clomp.planner._search`; one whose first task, q0's STRAIGHT, reaches the goal (most scans
of a free way) is built there without the queue, into the same map, plan and Ψ.
"""

from __future__ import annotations

import math
import time
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, State
from clomp.formal.supervisory import Guard, Plan, argmin_phi, extract_plan
from clomp.planner import footprint
from clomp.planner._search import _Search
from clomp.planner.cost import CostContext, CostFunction, Rollout, chi, default_cost, gamma
from clomp.planner.perception import Obstacles, load_scan, perceive
from clomp.planner.recovery import cleared_points
from clomp.planner.robot_model import RobotModel
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
        p = extract_plan(cmap)
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


