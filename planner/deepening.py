"""A spent budget searched again, deeper: :func:`plan_deepening`, the one place it is done.

The supervisor plans through it (:mod:`clomp.runtime.supervision.planwatch`), and so do the
one-shot commands (``clomp plan``, ``replay``, ``export``, ``check``): a plan from one scan
is the plan the robot would make there.
"""

from __future__ import annotations

import copy
from typing import Any

from clomp.planner.configurator import Configurator, PlanResult

__all__ = ["DEEPEN", "plan_deepening"]

DEEPEN = 4
"""How many times the budget a spent search is run again with (the supervisor's default
``deepen``): 50 → 200 states."""


def plan_deepening(configurator: Configurator, scan: Any, goal: Any, deepen: int = DEEPEN, back_off: bool = False) -> PlanResult:
    """``configurator.plan(scan, goal)``; when that search spends its budget short of both the
    goal and the frontier (stop reason ``budget``), the same scan is searched again with
    ``deepen`` times the budget (once; ``deepen=1``: never). ``planning_time_s`` covers both
    searches.

    Why: a search whose budget runs out ends its plan at the explored state nearest the
    goal (argmin φ). Behind a U open toward the robot, that state lies inside the U, and the
    closed loop drove in and stood there. The paper's budget of 50 is enough on its recorded
    scans. With the execution world's harsh noise, scattered ranges make more obstacles and
    the search needs more states to get round (``clomp experiment u-trap --noise harsh``,
    seeds 0–2: 21/30 reached with 50, 26/30 with 200). Best-first search is deterministic, so
    the deeper search begins as the first one did. A search that reached the goal, or ended
    at the frontier, returns unchanged.

    ``back_off`` (the supervisor's, :class:`~clomp.runtime.supervision.config.SupervisorConfig`):
    when the plan is empty — no task leads closer and no frontier is in reach, the robot
    would stand — and the configurator plans without REVERSE, the same scan is searched
    again with it offered (``recovery``, :mod:`clomp.planner.recovery`: only from a state
    none of whose tasks is collision-free). Why: a plan that ends at a frontier drives its
    last task into space no ray crossed, and what stood there can leave the robot where no
    turn and no straight is free (``clomp experiment slalom``: beside the first box, facing
    the second). The paper's three tasks cannot get it out; backing off can. The search
    with REVERSE is not deepened: it is to get out of a jam, and deepened it made plans of
    twenty tasks and more that ran half a minute each in a dead end, until the time limit.

    >>> import numpy as np
    >>> plan_deepening(Configurator(), np.zeros((0, 2)), (1.0, 0.0)).stop_reason
    'goal'
    >>> box = np.array([[0.1, y] for y in np.linspace(-0.3, 0.3, 61)] + [[x, s * 0.3] for x in np.linspace(-0.05, 0.1, 16) for s in (-1, 1)])
    >>> plan_deepening(Configurator(), box, (1.0, 0.0)).steps
    []
    >>> [s.task.value for s in plan_deepening(Configurator(), box, (1.0, 0.0), back_off=True).steps][0]
    'REVERSE'
    """
    result = _deepened(configurator, scan, goal, deepen)
    if back_off and not result.steps and not configurator.recovery:
        backing = copy.copy(configurator)
        backing.recovery = True
        spent = result.planning_time_s
        result = backing.plan(scan, goal)
        result.planning_time_s += spent
    return result


def _deepened(configurator: Configurator, scan: Any, goal: Any, deepen: int) -> PlanResult:
    result = configurator.plan(scan, goal)
    if result.stop_reason != "budget" or deepen <= 1:
        return result
    deeper = copy.copy(configurator)
    deeper.max_states = configurator.max_states * deepen
    spent = result.planning_time_s
    result = deeper.plan(scan, goal)
    result.planning_time_s += spent
    return result
