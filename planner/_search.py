"""One run of Algorithm 1 for :meth:`clomp.planner.configurator.Configurator.build`: the
search's state (the map as it grows, the states already simulated, the priority queue on
φ, the ends found so far) and its loop. See :mod:`clomp.planner.configurator` for the rules.
"""

from __future__ import annotations

import heapq
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, State, TaskKind, new_state
from clomp.formal.supervisory import FRONTIER, Reset
from clomp.planner.cost import CostContext, Rollout, chi, default_cost, gamma
from clomp.planner.perception import Obstacles
from clomp.planner.recovery import RECOVERY_TASKS, Recovery
from clomp.planner.rollout import Outcome, simulate
from clomp.planner.visibility import KnownFree

if TYPE_CHECKING:
    from clomp.planner.configurator import Configurator

__all__: list[str] = []


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

    def __init__(self, conf: "Configurator", obstacles: Obstacles, g: Disturbance, cleared: Obstacles | None = None) -> None:
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

