"""REPLANNING's two ways to a plan, for the supervisor (:mod:`clomp.runtime.supervision.supervisor`):
:func:`recall` (continue a plan of the map the robot already has, from a state that matches
the situation) and :func:`fresh_plan` (explore anew from the fused scan, deepening a search
that spent its budget), each queuing the plan's tasks and starting the first.

>>> from clomp.planner import load_scenario
>>> from clomp.runtime.backends.sim import SimRobot
>>> from clomp.runtime.supervision.supervisor import Supervisor
>>> scene = load_scenario("open")
>>> sup = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame())
>>> recall(sup, scene.scan(), 0.0)     # no plan yet: nothing to recall
False
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections import deque
from typing import TYPE_CHECKING

import numpy as np

from clomp.formal.geometry import relative
from clomp.planner.configurator import PlanningError
from clomp.planner.deepening import plan_deepening
from clomp.runtime.records.runlog import plan_fields
from clomp.runtime.supervision.progress import backs_off
from clomp.runtime.supervision.records import PlanRecord, TimedRecord
from clomp.runtime.supervision.states import Event as E

if TYPE_CHECKING:  # pragma: no cover
    from clomp.runtime.supervision.supervisor import Supervisor

__all__ = ["fresh_plan", "recall"]


def fresh_plan(sup: Supervisor, scan: np.ndarray, goal: tuple[float, float], dist: float, now: float) -> None:
    """Explore anew from ``scan`` to ``goal`` (robot frame, ``dist`` m away) and run the plan."""
    c0 = time.thread_time()
    moving = sup.config.moving
    if moving:  # what appeared where the last plan's scan saw free space: possibly moving (a WAIT first)
        if sup.appearance.stale:
            sup.appearance.renew(scan, sup.pose)
        sup.configurator.transient = sup.appearance.transient(scan, sup.pose)
    try:
        result = plan_deepening(sup.configurator, scan, goal, sup.config.deepen, sup.config.back_off)
    except PlanningError as exc:
        sup._fire(E.NO_PLAN, f"goal unreachable: {exc}")
        return
    finally:
        if moving:
            transient, sup.configurator.transient = sup.configurator.transient, None
            if transient is None:
                sup.appearance.renew(scan, sup.pose)
    took = result.planning_time_s + sup.watch.planned(result)  # indexing the map for recall is part of making it
    sup.fresh_plans.append(TimedRecord(now - (sup._t0 or 0.0), took, True, f"{result.n_states} states", time.thread_time() - c0))
    sup._log("fresh_plan", duration_s=took, states=result.n_states)
    rec = PlanRecord(now - (sup._t0 or 0.0), sup.pose, result)
    sup.plans.append(rec)
    if sup.log is not None:
        sup._log("plan", **plan_fields(result, rec.origin))
    t = now - (sup._t0 or 0.0)
    if backs_off(result, sup.configurator.recovery):
        why = sup.progress.backed_off(dist, t)  # judged in time too: back-offs between frontier plans (issue #36)
    else:
        why = sup.progress.no_safe_task() if not result.steps else sup.progress.planned(result.reached_goal, dist, t)
    if why is not None:
        sup._fire(E.NO_PLAN, why)
        return
    if not result.steps:
        # a verdict from one fused scan: range noise puts points of a surface beside
        # the body into the way. Stand, take fresh revolutions and plan again.
        sup.sensing.stopped()
        return
    sup._plan = rec
    states = result.plan.states
    sup._queue = deque((result.map[t], (s, t)) for s, t in zip(states, states[1:]))
    sup._fire(E.PLANNED, f"plan {len(sup.plans)}: {len(result.steps)} tasks, {result.n_states} states")
    sup.watch.started(sup.pose)
    sup._execute_tick(now)


def recall(sup: Supervisor, scan: np.ndarray, now: float) -> bool:
    """REPLANNING's first try: continue a plan from a state of the map the robot has."""
    last = sup._plan
    found = sup.watch.recall(last, sup.pose, sup.goal, scan, sup.config.end_tolerance, sup.config.max_recalls,
                              now - (sup._t0 or 0.0))
    if found is None or last is None:
        return False
    # the same continuation again, after the robot finished tasks of it, and no closer than
    # when it took it: a loop (a cul-de-sac's zig-zag, recalled five times over 90 s, ran
    # into the time limit). Explore anew instead, where ``patience`` judges progress
    g = relative(sup.pose, sup.goal)
    dist, key = math.hypot(g.x, g.y), (id(found.result.map), found.state)
    done = sum(1 for t in sup.tasks if t.outcome == "done")
    if sup.progress.loops(key, dist, done):
        sup.watch.recalls[-1] = dataclasses.replace(sup.watch.recalls[-1], ok=False, reason="refused: a loop")
        sup.watch.recalls_in_a_row -= 1
        return False
    t, back = now - (sup._t0 or 0.0), backs_off(found.result, sup.configurator.recovery)
    # a recalled plan is judged in time like a fresh one (issue #36)
    why = sup.progress.recalled(dist, None if found.result.reached_goal or back else t)
    if why is None and back:
        why = sup.progress.backed_off(dist, t)  # a recalled back-off counts as one (a pen: backed off, recalled, for ever)
    if why is not None:
        sup._fire(E.NO_PLAN, why)
        return True
    rec = sup._plan = PlanRecord(now - (sup._t0 or 0.0), last.origin, found.result, recalled=True)
    sup.plans.append(rec)
    states = rec.result.plan.states
    k = states.index(found.state)
    sup._queue = deque((rec.result.map[b], (a, b)) for a, b in zip(states[k:], states[k + 1:]))
    sup._fire(E.PLANNED, f"plan {len(sup.plans)} recalled from q{found.state} of the map: {len(sup._queue)} tasks")
    sup.watch.started(sup.pose)
    sup._execute_tick(now)
    return True
