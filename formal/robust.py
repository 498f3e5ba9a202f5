"""Risk-aware plans: Storm's optimal scheduler for reaching the goal without a collision.

On a (probabilistic) cognitive map exported as an MDP, Storm computes
``Pmax=? [!"collision" U "goal"]`` — the best probability, over every way of choosing
tasks, of reaching the goal before any collision — and a scheduler that attains it.
:func:`robust_plan` turns that scheduler into a plan ρ (from q0, the task the scheduler
picks, then its most likely outcome, until the goal or a state without choice) and
:func:`plan_probability` evaluates any plan the same way: the supervised DTMC (Ψ
enables the plan's task on its states; every other state is absorbing) checked with
``P=? [!"collision" U "goal"]``. The scheduler's value is at least every plan's, the
greedy best-first plan's included, since a plan is one (partial) scheduler.

stormpy is needed (``pip install -e '.[verify]'``).
"""

from __future__ import annotations

import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from formal.checking import require_stormpy
from formal.export import ExportModel, ModelKind, export_model, write_drn
from formal.invariants import map_plan
from formal.lts import CognitiveMap, MapError
from formal.model import TaskKind
from formal.supervisory import Plan

__all__ = ["SAFE_GOAL", "RobustPlan", "robust_plan", "plan_probability", "follow_tasks"]

SAFE_GOAL = '!"collision" U "goal"'
"""The path formula of a safe arrival: the goal, with no collision before it."""


@dataclass(frozen=True)
class RobustPlan:
    """Storm's optimum: the probability, the scheduler (task per map state) and its plan."""

    probability: float
    scheduler: dict[int, TaskKind]
    plan: Plan


def _build(cmap: CognitiveMap, kind: ModelKind, plan: Plan | None = None) -> tuple[Any, ExportModel, Any]:
    stormpy = require_stormpy()
    m = export_model(cmap, kind, plan)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.drn"
        write_drn(m, path)
        model = stormpy.build_model_from_drn(str(path))
    return stormpy, m, model


def robust_plan(cmap: CognitiveMap) -> RobustPlan:
    """``Pmax=? [!"collision" U "goal"]`` on the MDP of ``cmap`` with Storm, its scheduler
    and the plan that follows it along the most likely outcomes.

    >>> from formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)],
    ...     [(0, 1)], goal=g)
    >>> r = robust_plan(m)  # needs stormpy
    >>> r.probability, r.plan.states
    (1.0, (0, 1))
    """
    stormpy, m, model = _build(cmap, "mdp")
    prop = stormpy.parse_properties(f"Pmax=? [{SAFE_GOAL}]")[0]
    result = stormpy.model_checking(model, prop, extract_scheduler=True)
    sched = result.get_scheduler() if hasattr(result, "get_scheduler") else result.scheduler
    init = int(model.initial_states[0])
    probability = float(result.at(init)) if hasattr(result, "at") else float(result[init])
    # a DRN keeps the file's state and choice order: Storm state k is the export's state k
    choice: dict[int, TaskKind] = {}
    for k, s in enumerate(m.states):
        row = m.choices[k]
        j = int(sched.get_choice(k).get_deterministic_choice())
        action = row[j].action
        if action in TaskKind.__members__:
            choice[s.ident] = TaskKind(action)
    q0 = cmap.initial.ident
    path: list[int] = [q0]
    seen = {q0}
    while True:
        q = path[-1]
        s = cmap[q]
        if q != q0 and (s.interrupted or s.reached_goal):
            break
        task = choice.get(q)
        if task is None:
            break
        ts = [t for t in cmap.out_transitions(q) if t.label is task]
        best = max(ts, key=lambda t: (t.probability, -t.target))
        if best.target in seen:
            break
        seen.add(best.target)
        path.append(best.target)
    return RobustPlan(probability, choice, Plan(tuple(path)))


def follow_tasks(cmap: CognitiveMap, tasks: list[TaskKind]) -> Plan:
    """The plan that starts ``tasks`` in turn from q0 of ``cmap``, following at each
    step the choice of that task to its most likely outcome; it ends early where the
    choice does not exist. This is how a plan made on another map (e.g. the nominal,
    noise-free one) is carried onto a probabilistic map whose outcomes differ.

    >>> from formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0))], [(0, 1)], goal=g)
    >>> follow_tasks(m, [TaskKind.STRAIGHT, TaskKind.LEFT]).states
    (0, 1)
    """
    path = [cmap.initial.ident]
    for task in tasks:
        ts = [t for t in cmap.out_transitions(path[-1]) if t.label is task]
        if not ts or cmap[path[-1]].interrupted:
            break
        best = max(ts, key=lambda t: (t.probability, -t.target))
        if best.target in path:
            break
        path.append(best.target)
    return Plan(tuple(path))


def plan_probability(cmap: CognitiveMap, plan: Plan | None = None) -> float:
    """``P=? [!"collision" U "goal"]`` of the supervised system that follows ``plan``
    (default: the map's own plan, the Configurator's best-first one)."""
    rho = map_plan(cmap) if plan is None else plan
    for s, t in rho.steps():
        if not cmap.has_transition(s, t):
            raise MapError(f"plan step q{s} ↪ q{t} is not a transition of the map")
    stormpy, m, model = _build(cmap, "dtmc", rho)
    prop = stormpy.parse_properties(f"P=? [{SAFE_GOAL}]")[0]
    result = stormpy.model_checking(model, prop)
    init = int(model.initial_states[0])
    return float(result.at(init)) if hasattr(result, "at") else float(result[init])
