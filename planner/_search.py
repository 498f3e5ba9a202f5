"""One run of Algorithm 1 for :meth:`clomp.planner.configurator.Configurator.build`: the
search's state (the map as it grows, the states already simulated, the priority queue on
φ, the ends found so far) and its loop. See :mod:`clomp.planner.configurator` for the rules.
"""

from __future__ import annotations

import functools
import heapq
import math
from typing import TYPE_CHECKING, Any

import numpy as np

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, State, TaskKind, new_pose, new_state
from clomp.formal.supervisory import FRONTIER, Reset
from clomp.planner.contact import _lane_gap, lane_reach, unobstructed
from clomp.planner.cost import CostContext, chi, default_cost, gamma
from clomp.planner.footprint import Box, body_box
from clomp.planner.perception import Obstacles
from clomp.planner.recovery import RECOVERY_TASKS, Recovery
from clomp.planner.robot_model import RobotModel
from clomp.planner.rollout import _EPS, Outcome, _goal_dead_ahead, _inside_for, frontier_distance, simulate
from clomp.planner.tasks import Task
from clomp.planner.visibility import KnownFree

if TYPE_CHECKING:
    from clomp.planner.configurator import Configurator

__all__: list[str] = []

#: whether a search whose first task reaches the goal is built without the queue (:meth:`_Search._straight_to_goal`;
#: the same map either way: the tests switch it off to compare)
FAST_ROOT = True


_FRONTIER = ((FRONTIER, 1.0),)
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


#: per robot (kept alive here, so its id is not reused): :func:`_root_figures`
_ROOT_FIGURES: dict[int, tuple[RobotModel, tuple[float, float, float, float, float, Box, Box]]] = {}


def _root_figures(robot: RobotModel) -> tuple[float, float, float, float, float, Box, Box]:
    """What q0's STRAIGHT (from the origin, heading 0) needs of ``robot`` (frozen), as
    :func:`clomp.planner.rollout.simulate` and :class:`clomp.planner.contact.Scene` compute it:
    the step, the range within which the rim cannot limit a straight, the room to the rim,
    the room to spin and the local gap, the inflated and the real body."""
    known = _ROOT_FIGURES.get(id(robot))
    if known is not None and known[0] is robot:
        return known[1]
    origin = new_pose(0.0, 0.0, 0.0)
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    sure = robot.sensor_range - math.hypot(origin.x, origin.y) - robot.body_radius
    spin, local_gap = lane_reach(robot)
    figures = (step, sure, frontier_distance(robot, origin), spin, local_gap, body_box(robot, robot.clearance), body_box(robot))
    if len(_ROOT_FIGURES) >= 16:
        _ROOT_FIGURES.clear()
    _ROOT_FIGURES[id(robot)] = (robot, figures)
    return figures


class _Search:
    """One run of Algorithm 1 (:meth:`Configurator.build`): the map as it grows, the
    states already simulated (by task and start pose), the priority queue on φ and the
    ends found so far."""

    def __init__(self, conf: "Configurator", obstacles: Obstacles, g: Disturbance, cleared: Obstacles | None = None) -> None:
        robot = conf.robot
        origin = new_pose(0.0, 0.0, 0.0)
        # CostContext(g, origin, robot), built without the frozen dataclass's three object.__setattr__,
        # its start_distance (a cached property, read by every χ) set as the property computes it
        self.ctx = ctx = object.__new__(CostContext)
        ctx.__dict__.update(goal=g, origin=origin, robot=robot, start_distance=origin.distance_to(g.x, g.y))
        self.cost = cost = conf.cost
        # the cost as one that reads a Rollout: a rollout is priced before its state is built
        self.priced = cost if cost is default_cost or cost is gamma or cost is chi else None
        self.obstacles, self.robot, self.goal = obstacles, robot, g
        self.routes, self.max_states = conf.routes, conf.max_states
        # what the rays crossed (:mod:`clomp.planner.visibility`): a task whose body leaves it is a frontier end
        self.known = KnownFree.from_points(obstacles.points, robot.sensor_range, robot=robot)
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
        if FAST_ROOT and self._straight_to_goal():
            return "goal"
        stop = self._loop()
        return "goal" if self.goal_ids else stop

    def _straight_to_goal(self) -> bool:
        """The search where the first task reaches the goal (most scans of a free way: the
        goal dead ahead, nothing in the lane before it, the body inside known-free space):
        q0's STRAIGHT, built as :meth:`_expand` builds it (the same rollout, to the bit:
        :func:`clomp.planner.rollout.simulate`'s arithmetic on the same figures, one pass of
        the compiled lane test over every point), without the queue, the index and the
        rollout's scene. True when it reached the goal (the map then holds q0 and q1, and
        the search is over); False, with nothing changed, when anything else holds, and the
        search runs as ever. ``tests/planner/test_fast_root.py`` holds the two to the same
        maps, plans and guards."""
        robot, g = self.robot, self.goal
        if self.recovery is not None or self.routes != 1 or self.priced is None or self.max_states < 2:
            return False
        cmap = self.cmap
        q0 = cmap[0]
        start = q0.end
        along = _goal_dead_ahead(robot, start, g)
        if along is None:
            return False
        # rollout._straight, for a goal dead ahead whose run is clear (else False); what depends
        # on the robot alone (q0 stands at the origin) is remembered per robot
        step, sure, room0, spin, local_gap, infl, real = _root_figures(robot)
        far = max(step, along)
        room = room0 if far > sure - 1e-6 and not _inside_for(robot, start.x, start.y, start.theta, far + 1e-6) else math.inf
        run = min(along, room)
        obstacles = self.obstacles
        if len(obstacles):
            gap = _lane_gap()
            if gap is None or max(min(step, room) + spin, run) + 1e-6 <= local_gap:
                return False  # (the scene's local points and the turns' choice: the general search)
            z = np.ascontiguousarray(obstacles.points, dtype=np.float64).view(np.complex128).reshape(-1)
            d, _ = gap(z.real, z.imag, start.x, start.y, math.cos(start.theta), -math.sin(start.theta), infl, real, True)
            if not d >= run:
                return False
        # (a point in the lane beyond the run: contact.cut_straight gives unobstructed's outcome)
        out = unobstructed(Task.straight(robot, start, g, run))
        if run >= room - _EPS and out.distance >= room - 1e-6:
            return False  # the rim of the sensed disc: a frontier
        if not out.end.distance_to(g.x, g.y) <= robot.goal_tolerance or not self.known.clear(out, robot, True):
            return False
        d_i = self.reset.after(q0)
        out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, True, False)
        s = _state(1, out, d_i, self.priced(out, self.ctx))
        cmap.add_state(s)
        cmap.add_transition(0, 1, _STRAIGHT)
        self.index[(_STRAIGHT, round(start.x * 1e6), round(start.y * 1e6), round(start.theta * 1e6))] = 1
        self.goal_ids.add(1)
        return True

    @functools.cached_property
    def goal_seen(self) -> bool:
        """The goal lies inside the sensed disc and where the rays went: a way to it may lie
        inside too (a goal in a shadow, like one beyond the disc, has none: the first frontier
        popped ends the search). Asked when a frontier state is popped (a search that ends at
        its first task never asks)."""
        g = self.goal
        return self.ctx.start_distance <= self.robot.sensor_range and self.known.contains(g.x, g.y)

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

