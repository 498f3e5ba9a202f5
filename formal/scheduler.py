"""Risk-aware plans: Storm's optimal scheduler for reaching the goal without a collision.

On a (probabilistic) cognitive map exported as an MDP, Storm computes
``Pmax=? [!"collision" U "goal"]`` — the best probability, over every way of choosing
tasks, of reaching the goal before any collision — and a scheduler that attains it.

The scheduler is a *policy*: a task for every state, whichever outcome of the previous
task the robot lands in. Its value (``probability``) counts every outcome; a plan ρ is
one path of it. :func:`robust_plan` returns both: the policy (``scheduler``, also
:func:`policy_path` from any state) and the path the robot starts on (from q0, the task
the scheduler picks, then its most likely outcome, until the goal or a state without
choice), with ``path_probability``, the chance that this very path happens and ends at
the goal. The runtime executes the policy: a task that ends in another outcome sends
the supervisor to REPLANNING, whose recall finds the map's state the robot is in and
continues with the scheduler's choice there (:func:`policy_path` on the map's
``metadata["scheduler"]``, see :func:`attach_policy`).

:func:`plan_probability` evaluates any plan the same way: the supervised DTMC (Ψ
enables the plan's task on its states; every other state is absorbing) checked with
``P=? [!"collision" U "goal"]``. The scheduler's value is at least every plan's, the
greedy best-first plan's included, since a plan is one (partial) scheduler.

stormpy is needed (``pip install -e '.[verify]'``).
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterable, Mapping
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Any

import networkx as nx

from clomp.formal.checking import require_stormpy
from clomp.formal.export import STAY, ExportModel, ModelKind, export_model, write_drn
from clomp.formal.invariants import map_plan
from clomp.formal.lts import CognitiveMap, MapError
from clomp.formal.model import TaskKind
from clomp.formal.retry import OFFS_KEY, STOPS_KEY, map_offs, map_stops, retry_model
from clomp.formal.supervisory import Guard, Plan

__all__ = [
    "SAFE_GOAL",
    "RobustPlan",
    "robust_plan",
    "plan_probability",
    "follow_tasks",
    "policy_path",
    "policy_probability",
    "TARGET",
    "policy_states",
    "path_probability",
    "attach_policy",
    "map_policy",
    "POLICY_KEY",
    "scheduler_record",
    "ModelPolicy",
    "model_policy",
    "model_scheduler_record",
]

POLICY_KEY = "scheduler"
"""The key of a map's ``metadata`` under which :func:`attach_policy` keeps the scheduler."""

SAFE_GOAL = '!"collision" U "goal"'
"""The path formula of a safe arrival: the goal, with no collision before it."""

TARGET = "target"
"""The label of the states a robust plan aims at when they are given (``target=``)."""


@dataclass(frozen=True)
class RobustPlan:
    """Storm's optimum: the scheduler's value ``probability`` (every outcome counted),
    the scheduler (a task per map state: the policy), the path it starts on (``plan``:
    most likely outcomes) and ``path_probability``, the chance of that path itself."""

    probability: float
    scheduler: dict[int, TaskKind]
    plan: Plan
    path_probability: float = 0.0


def _build(cmap: CognitiveMap, kind: ModelKind, plan: Plan | None = None,
           target: Iterable[int] | None = None, retries: int = 0) -> tuple[Any, ExportModel, Any]:
    stormpy = require_stormpy()
    m = export_model(cmap, kind, plan)
    if target is not None:
        wanted = set(target)
        m = replace(m, labels={**m.labels, TARGET: frozenset(k for k, s in enumerate(m.states) if s.ident in wanted)})
    if retries:
        m = retry_model(m, map_stops(cmap.metadata), retries, map_offs(cmap.metadata) or None)
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.drn"
        write_drn(m, path)
        model = stormpy.build_model_from_drn(str(path))
    return stormpy, m, model


def _formula(target: Iterable[int] | None) -> str:
    return SAFE_GOAL if target is None else f'!"collision" U "{TARGET}"'


def _value_at(result: Any, k: int) -> float:
    return float(result.at(k)) if hasattr(result, "at") else float(result[k])


def robust_plan(
    cmap: CognitiveMap,
    target: Iterable[int] | None = None,
    prefer: Mapping[int, TaskKind] | None = None,
    margin: float = 0.0,
    retries: int = 0,
) -> RobustPlan:
    """``Pmax=? [!"collision" U "goal"]`` on the MDP of ``cmap`` with Storm, its scheduler
    and the plan that follows it along the most likely outcomes.

    ``target``: the states to reach instead of the goal states (labelled ``target``; e.g.
    a plan's progress states when the goal lies beyond the map). ``prefer``: a task per
    state (e.g. the best-first plan's) kept wherever its chance is within ``margin`` of
    the optimum: Storm's scheduler picks arbitrarily among equally good choices, and a
    sampled probability k/N is only an estimate, so a detour is taken only where it is
    safer by more than ``margin``. ``probability`` is then the value of the policy that
    is returned (equal to Storm's Pmax when ``margin`` is 0). ``retries``: a stop of the
    map's ``metadata["stops"]`` is retried up to that many times, as the supervisor
    replans after one (:func:`clomp.formal.retry.retry_model`); the policy is the scheduler's
    choice with every retry still left (the one a fresh plan starts with).

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)],
    ...     [(0, 1)], goal=g)
    >>> r = robust_plan(m)  # needs stormpy
    >>> r.probability, r.plan.states
    (1.0, (0, 1))
    """
    if not (math.isfinite(margin) and 0 <= margin <= 1):
        raise MapError(f"margin must be a probability in [0, 1], got {margin!r}")
    goal_set = None if target is None else frozenset(target)
    stormpy, m, model = _build(cmap, "mdp", target=goal_set, retries=retries)
    prop = stormpy.parse_properties(f"Pmax=? [{_formula(goal_set)}]")[0]
    result = stormpy.model_checking(model, prop, extract_scheduler=True)
    sched = result.get_scheduler() if hasattr(result, "get_scheduler") else result.scheduler
    init = int(model.initial_states[0])
    probability = _value_at(result, init)
    values = [_value_at(result, k) for k in range(m.n_states)]
    # a DRN keeps the file's state and choice order: Storm state k is the export's state k
    choice: dict[int, TaskKind] = {}
    kept = False
    for k, s in enumerate(m.states):
        if s.ident not in cmap:  # a copy with fewer retries left (clomp.formal.retry)
            continue
        row = m.choices[k]
        j = int(sched.get_choice(k).get_deterministic_choice())
        action = row[j].action
        if action not in TaskKind.__members__:
            continue
        choice[s.ident] = TaskKind(action)
        want = None if prefer is None else prefer.get(s.ident)
        if want is not None and want is not choice[s.ident]:
            q = [sum(float(p) * values[t] for t, p in ch.branches) for ch in row if ch.action == want.value]
            if q and q[0] >= values[k] - margin - 1e-12:
                choice[s.ident] = want
                kept = True
    if goal_set is not None:  # the policy has arrived in a target: it starts nothing there
        choice = {q: t for q, t in choice.items() if q not in goal_set}
    plan = Plan(tuple(policy_path(cmap, choice, stop=goal_set)))
    if kept:
        probability = policy_probability(cmap, choice, goal_set, retries)
    return RobustPlan(probability, choice, plan, path_probability(cmap, plan, goal_set))


def policy_probability(cmap: CognitiveMap, scheduler: Mapping[int, TaskKind], target: Iterable[int] | None = None,
                       retries: int = 0) -> float:
    """The value of a policy: ``P=? [!"collision" U "goal"]`` (or ``"target"``) of the map
    when each state starts only the task ``scheduler`` names (others: absorbing), by Storm;
    ``retries`` as in :func:`robust_plan`.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> policy_probability(m, {0: TaskKind.STRAIGHT}), policy_probability(m, {})
    (1.0, 0.0)
    """
    sub = CognitiveMap(goal=cmap.goal)
    for st in cmap.states():
        sub.add_state(st)
    sub.set_initial(cmap.initial.ident)
    for key in (STOPS_KEY, OFFS_KEY):  # the stops (and offs), for the retries; not the plan, whose steps the policy may not take
        if key in cmap.metadata:
            sub.metadata[key] = cmap.metadata[key]
    for t in cmap.transitions():
        if scheduler.get(t.source) is t.label:
            sub.add_transition(t.source, t.target, t.label, t.probability)
    goal_set = None if target is None else frozenset(target)
    stormpy, _m, model = _build(sub, "mdp", target=goal_set, retries=retries)
    prop = stormpy.parse_properties(f"Pmax=? [{_formula(goal_set)}]")[0]
    result = stormpy.model_checking(model, prop)
    return _value_at(result, int(model.initial_states[0]))


def policy_path(cmap: CognitiveMap, scheduler: Mapping[int, TaskKind], source: int | None = None,
                stop: Iterable[int] | None = None) -> list[int]:
    """The path a policy starts on from ``source`` (default q0): the scheduler's task,
    then its most likely outcome (ties: the lower ident), until an interrupted or goal
    state (or one of ``stop``), a state without a choice, or a state seen before.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> policy_path(m, {0: TaskKind.STRAIGHT})
    [0, 1]
    """
    start = cmap.initial.ident if source is None else source
    ends = set() if stop is None else set(stop)
    path: list[int] = [start]
    seen = {start}
    while True:
        q = path[-1]
        s = cmap[q]
        if q != start and (s.interrupted or s.reached_goal or q in ends):
            break
        task = scheduler.get(q)
        ts = [t for t in cmap.out_transitions(q) if t.label is task] if task is not None else []
        if not ts or s.interrupted:
            break
        best = max(ts, key=lambda t: (t.probability, -t.target))
        if best.target in seen:
            break
        seen.add(best.target)
        path.append(best.target)
    return path


def path_probability(cmap: CognitiveMap, plan: Plan, target: Iterable[int] | None = None) -> float:
    """The chance that ``plan``'s path itself happens and ends at the goal (or in
    ``target``) without a collision: the product of its branches' probabilities if its
    last state is a goal state (none of its states interrupted), else 0. At most the
    policy's value, which also counts the other outcomes from which the goal is reached.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> path_probability(m, Plan((0, 1)))
    1.0
    """
    end = cmap[plan.end]
    arrived = end.reached_goal if target is None else plan.end in set(target)
    if not arrived or any(cmap[i].interrupted for i in plan.states):
        return 0.0
    p = 1.0
    for a, b in plan.steps():
        task = cmap[b].task
        p *= float(sum(t.probability for t in cmap.out_transitions(a) if t.target == b and t.label is task))
    return p


def policy_states(cmap: CognitiveMap, scheduler: dict[int, TaskKind]) -> list[int]:
    """The states the policy can visit from q0 (every outcome of each chosen task, not
    just the most likely one), sorted; where it acts, ``scheduler`` names the task.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> policy_states(m, {0: TaskKind.STRAIGHT})
    [0, 1]
    """
    q0 = cmap.initial.ident
    acts = {q: task.value for q, task in scheduler.items()
            if q in cmap and not cmap[q].interrupted and (q == q0 or not cmap[q].reached_goal)}
    followed = nx.subgraph_view(cmap.to_networkx(), filter_edge=lambda u, v, k: acts.get(u) == k)
    return sorted(nx.descendants(followed, q0) | {q0})


def attach_policy(cmap: CognitiveMap, scheduler: dict[int, TaskKind]) -> None:
    """Keep ``scheduler`` in ``cmap.metadata[POLICY_KEY]`` (JSON-ready: ident → task
    name), so that whoever continues on this map (the supervisor's recall) follows the
    policy rather than the map's least-cost path; :func:`map_policy` reads it back.

    >>> m = CognitiveMap()
    >>> attach_policy(m, {0: TaskKind.LEFT})
    >>> m.metadata[POLICY_KEY], map_policy(m)
    ({'0': 'LEFT'}, {0: <TaskKind.LEFT: 'LEFT'>})
    """
    cmap.metadata[POLICY_KEY] = {str(q): task.value for q, task in sorted(scheduler.items())}


def map_policy(cmap: CognitiveMap) -> dict[int, TaskKind] | None:
    """The scheduler :func:`attach_policy` kept on ``cmap``, or None (see there).

    >>> map_policy(CognitiveMap()) is None
    True
    """
    raw = cmap.metadata.get(POLICY_KEY)
    if not isinstance(raw, dict):
        return None
    return {int(q): TaskKind(v) for q, v in raw.items()}


def follow_tasks(cmap: CognitiveMap, tasks: list[TaskKind]) -> Plan:
    """The plan that starts ``tasks`` in turn from q0 of ``cmap``, following at each
    step the choice of that task to its most likely outcome; it ends early where the
    choice does not exist. This is how a plan made on another map (e.g. the nominal,
    noise-free one) is carried onto a probabilistic map whose outcomes differ.

    >>> from clomp.formal.model import Disturbance, Pose, State
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


def plan_probability(cmap: CognitiveMap, plan: Plan | None = None, target: Iterable[int] | None = None,
                     retries: int = 0) -> float:
    """``P=? [!"collision" U "goal"]`` (or ``"target"``, the states of ``target``) of the
    supervised system that follows ``plan`` (default: the map's own plan, the
    Configurator's best-first one); ``retries`` as in :func:`robust_plan`."""
    rho = map_plan(cmap) if plan is None else plan
    Guard(cmap, rho)  # Ψ of the plan: MapError when a step is not a transition of the map
    goal_set = None if target is None else frozenset(target)
    stormpy, m, model = _build(cmap, "dtmc", rho, target=goal_set, retries=retries)
    prop = stormpy.parse_properties(f"P=? [{_formula(goal_set)}]")[0]
    result = stormpy.model_checking(model, prop)
    init = int(model.initial_states[0])
    return float(result.at(init)) if hasattr(result, "at") else float(result[init])


def scheduler_record(cmap: CognitiveMap, best: RobustPlan) -> dict[str, Any]:
    """Storm's optimal scheduler of :func:`robust_plan` as a JSON-ready record: the
    property, its value at q0, the plan it starts on, and per map state it chooses in
    (map order) the state's valuation (``pose``: where the state's task ended, x y theta;
    ``task``: the task that led there) and the chosen action (a task kind).

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> scheduler_record(m, robust_plan(m))["states"]  # needs stormpy
    [{'state': 'q0', 'ident': 0, 'pose': [0.0, 0.0, 0.0], 'task': 'STRAIGHT', 'action': 'STRAIGHT'}]
    """
    return {
        "property": f"Pmax=? [{SAFE_GOAL}]",
        "probability": best.probability,
        "plan": [f"q{i}" for i in best.plan.states],
        "states": [
            {"state": f"q{s.ident}", "ident": s.ident, "pose": [float(v) for v in s.end.as_list()], "task": s.task.value,
             "action": best.scheduler[s.ident].value}
            for s in cmap.states() if s.ident in best.scheduler
        ],
    }


@dataclass(frozen=True)
class ModelPolicy:
    """Storm's optimal scheduler of an exported MDP (e.g. the closed loop's model, whose
    states are map states × replans used): its value at the initial state, the
    property, and the chosen action per state ident (a task, or ``retry``)."""

    probability: float
    formula: str
    choose: dict[int, str]


def model_policy(m: ExportModel, formula: str = f"Pmax=? [{SAFE_GOAL}]") -> ModelPolicy:
    """Storm's optimal scheduler for ``formula`` on the MDP ``m`` itself (not a map's
    export: e.g. :func:`clomp.formal.retry.loop_model`'s product, where a stop's one
    action is ``retry``). States whose one choice is ``stay`` choose nothing.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g)
    >>> p = model_policy(export_model(m, "mdp"))  # needs stormpy
    >>> p.probability, p.choose
    (1.0, {0: 'STRAIGHT'})
    """
    if m.kind != "mdp":
        raise MapError("a scheduler resolves the choices of an MDP")
    stormpy = require_stormpy()
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "m.drn"
        write_drn(m, path)
        model = stormpy.build_model_from_drn(str(path))
    result = stormpy.model_checking(model, stormpy.parse_properties(formula)[0], extract_scheduler=True)
    sched = result.get_scheduler() if hasattr(result, "get_scheduler") else result.scheduler
    choose: dict[int, str] = {}
    for k, s in enumerate(m.states):  # a DRN keeps the file's state and choice order
        action = m.choices[k][int(sched.get_choice(k).get_deterministic_choice())].action
        if action != STAY:
            choose[s.ident] = action
    return ModelPolicy(_value_at(result, int(model.initial_states[0])), formula, choose)


def model_scheduler_record(m: ExportModel, best: ModelPolicy, span: int | None = None) -> dict[str, Any]:
    """:func:`model_policy`'s scheduler as a JSON-ready record, as :func:`scheduler_record`
    writes a map's: the property, its value, the path it starts on (most likely
    outcomes) and per state that chooses (the model's order) its valuation (``pose``
    where its task ended, ``task`` that led there) and ``action``. With ``span`` (the
    closed loop's ident offset per replan, :func:`clomp.formal.retry.retry_model`) each
    state also names its ``map_state`` and ``replans_used``.

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = export_model(CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True)], [(0, 1)], goal=g), "mdp")
    >>> model_scheduler_record(m, ModelPolicy(1.0, "Pmax=? [F goal]", {0: "STRAIGHT"}), span=2)["states"]
    [{'state': 'q0', 'ident': 0, 'map_state': 'q0', 'replans_used': 0, 'pose': [0.0, 0.0, 0.0], 'task': 'STRAIGHT', 'action': 'STRAIGHT'}]
    """
    states = []
    for s in m.states:
        if s.ident not in best.choose:
            continue
        row: dict[str, Any] = {"state": f"q{s.ident}", "ident": s.ident}
        if span is not None:
            row.update(map_state=f"q{s.ident % span}", replans_used=s.ident // span)
        row.update(pose=[float(v) for v in s.end.as_list()], task=s.task.value, action=best.choose[s.ident])
        states.append(row)
    return {"property": best.formula, "probability": best.probability, "plan": [f"q{i}" for i in _model_path(m, best.choose)],
            "states": states}


def _model_path(m: ExportModel, choose: Mapping[int, str]) -> list[int]:
    """The idents along the path ``choose`` starts on from ``m``'s initial state: the
    chosen action's most likely branch (ties: the lower index), until a state that
    chooses nothing or one seen before."""
    k, path, seen = m.initial, [m.states[m.initial].ident], {m.initial}
    while (action := choose.get(m.states[k].ident)) is not None:
        ch = next((c for c in m.choices[k] if c.action == action), None)
        if ch is None or not ch.branches:
            break
        k = max(ch.branches, key=lambda b: (b[1], -b[0]))[0]
        if k in seen:
            break
        seen.add(k)
        path.append(m.states[k].ident)
    return path
