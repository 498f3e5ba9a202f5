"""The one intermediate model every exporter renders: states, choices, labels, rewards.

:func:`export_model` extracts an :class:`ExportModel` in one of two kinds:

- ``"mdp"`` — the unsupervised map: every state, and at each state one nondeterministic
  choice per task the Configurator explored (the action is the task kind), whose
  branches are the map's transitions with that label;
- ``"dtmc"`` — the supervised system: Ψ applied, so at each state only the task of the
  plan is enabled; the states are those reachable under Ψ. The policy it fixes is the
  *plan's*: the map's own plan ρ (``metadata["plan"]``, the Configurator's best-first
  plan) unless ``plan=`` names another; every state off ρ is absorbing.
  :func:`induced_model` fixes another policy instead, a task per state (e.g. Storm's
  optimal scheduler, ``clomp export --model dtmc --policy storm``).

States without an outgoing choice (collisions, the goal, unexpanded frontier states)
get one absorbing self-loop, action ``stay``, so that the models are well-formed; the
model records them in ``self_loops``. Labels: ``init``, ``goal`` (reached the goal, not
interrupted), ``collision`` (interrupted, D_N ≠ ∅), ``plan`` (states of ρ) and
``goal_in_map``: a fact about the whole map (it holds a goal state reachable from q0: the
Configurator found a way), carried by q0 alone because the property files evaluate
every formula at the initial state (``!"goal_in_map" | P>=1 [F "goal"]``); it does not
say that the goal is reachable from a state (``P>0 [F "goal"]`` says that). Rewards ``distance`` (metres) and ``time`` (seconds) are
earned on choices: the expected distance / duration of the task started.

>>> from clomp.formal.model import Disturbance, Pose, State
>>> g = Disturbance.goal(1.0, 0.0)
>>> cmap = CognitiveMap(goal=g)
>>> q0 = cmap.add_state(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)))
>>> q1 = cmap.add_state(State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0)))
>>> _ = cmap.add_transition(0, 1)
>>> m = export_model(cmap, "mdp")
>>> len(m.states), [c.action for c in m.choices[0]], m.self_loops
(2, ['STRAIGHT'], (1,))
"""

from __future__ import annotations

from dataclasses import dataclass
from fractions import Fraction
from collections.abc import Mapping
from typing import Any, Literal

import networkx as nx

from clomp.formal.lts import CognitiveMap, MapError
from clomp.formal.model import State, TaskKind
from clomp.formal.supervisory import Guard, Plan

__all__ = ["Choice", "ExportError", "ExportModel", "LABELS", "ModelKind", "STAY", "export_model", "induced_model"]

ModelKind = Literal["mdp", "dtmc"]
STAY = "stay"
"""The action of the absorbing self-loop added to a state without successors."""



class ExportError(MapError):
    """A map cannot be exported (empty, no q0, probabilities that do not sum to 1, …)."""


@dataclass(frozen=True, slots=True)
class Choice:
    """One choice of a state: an action (task kind or ``stay``) and its distribution.

    ``branches`` are (target index, exact probability) pairs; ``distance`` and ``time``
    the expected reward of taking the choice; ``guarded`` is Ψ (1 on a plan step).
    """

    action: str
    branches: tuple[tuple[int, Fraction], ...]
    distance: float = 0.0
    time: float = 0.0
    guarded: bool = False


@dataclass(frozen=True)
class ExportModel:
    """The intermediate model every renderer draws from (indices 0 … n−1, by ident)."""

    kind: ModelKind
    states: tuple[State, ...]
    initial: int
    choices: tuple[tuple[Choice, ...], ...]
    labels: Mapping[str, frozenset[int]]
    self_loops: tuple[int, ...]
    plan: Plan
    goal: tuple[float, float] | None
    title: str | None = None
    """What the model is when it is not a cognitive map (e.g. the supervisor's machine);
    its states then need only an ``ident`` and a ``name``."""
    policy: str = "plan"
    """Whose choices a DTMC fixes: ``"plan"`` (Ψ of the plan ρ) or the name of the
    scheduler :func:`induced_model` applied (e.g. ``"Storm's scheduler"``)."""

    @property
    def n_states(self) -> int:
        """Number of states."""
        return len(self.states)

    @property
    def n_choices(self) -> int:
        """Number of choices (rows of an MDP's matrix)."""
        return sum(len(c) for c in self.choices)

    @property
    def n_transitions(self) -> int:
        """Number of (choice, target) entries: the map's transitions plus the self-loops."""
        return sum(len(ch.branches) for cs in self.choices for ch in cs)

    def state_labels(self, index: int) -> list[str]:
        """The labels of the state at ``index``, sorted."""
        return sorted(name for name, members in self.labels.items() if index in members)


LABELS = ("init", "goal", "collision", "plan", "goal_in_map")


def export_model(cmap: CognitiveMap, kind: ModelKind = "mdp", plan: Plan | None = None) -> ExportModel:
    """Extract the MDP (unsupervised) or DTMC (supervised, Ψ applied) of ``cmap``.

    ``plan`` defaults to the one recorded by the Configurator (else extracted). Raises
    :class:`ExportError` for an empty map, a map without q0, a distribution that does not
    sum to 1, or (for the DTMC) a guard that enables two tasks in one state.
    """
    from clomp.formal.invariants import map_plan

    if kind not in ("mdp", "dtmc"):
        raise ExportError(f"unknown model kind {kind!r}: expected 'mdp' or 'dtmc'")
    if len(cmap) == 0:
        raise ExportError("cannot export an empty map")
    if cmap.initial_id is None or cmap.initial_id not in cmap:
        raise ExportError("cannot export a map without an initial state")
    rho = map_plan(cmap) if plan is None else plan
    psi = Guard(cmap, rho).table()
    groups = _groups(cmap)
    q0 = cmap.initial_id
    if kind == "mdp":
        idents = [s.ident for s in cmap.states()]
        enabled = groups
    else:
        enabled = {}
        for s, by_label in groups.items():
            on = {lab: ts for lab, ts in by_label.items() if any(psi[t] for t in ts)}
            if len(on) > 1:
                raise ExportError(f"Ψ enables {len(on)} tasks in q{s}: the supervised system is not a DTMC")
            enabled[s] = on
        tasks = {s: {lab.value for lab in on} for s, on in enabled.items()}  # the edge keys Ψ enables
        supervised = nx.subgraph_view(cmap.to_networkx(), filter_edge=lambda u, v, k: k in tasks[u])
        idents = sorted(nx.descendants(supervised, q0) | {q0})
    index = {ident: k for k, ident in enumerate(idents)}
    choices: list[tuple[Choice, ...]] = []
    loops: list[int] = []
    for k, ident in enumerate(idents):
        row: list[Choice] = []
        for label in sorted(enabled.get(ident, {}), key=lambda lab: list(TaskKind).index(lab)):
            ts = enabled[ident][label]
            total = sum((t.probability for t in ts), Fraction(0))
            if total != 1 or any(not 0 < t.probability <= 1 for t in ts):
                raise ExportError(
                    f"probabilities of ({cmap[ident].label}, {label.value}) sum to {total}, not 1: "
                    f"{[str(t.probability) for t in ts]}"
                )
            row.append(
                Choice(
                    label.value,
                    tuple((index[t.target], t.probability) for t in ts),
                    float(sum(t.probability * Fraction(cmap[t.target].distance) for t in ts)),
                    float(sum(t.probability * Fraction(cmap[t.target].duration) for t in ts)),
                    any(psi[t] for t in ts),
                )
            )
        if not row:
            row.append(Choice(STAY, ((k, Fraction(1)),)))
            loops.append(k)
        choices.append(tuple(row))
    states = tuple(cmap[i] for i in idents)
    reach = cmap.reachable()
    goal_in_map = any(cmap[i].reached_goal and not cmap[i].interrupted for i in reach)
    labels = {
        "init": frozenset({index[q0]}),
        "goal": frozenset(k for k, s in enumerate(states) if s.reached_goal and not s.interrupted),
        "collision": frozenset(k for k, s in enumerate(states) if s.interrupted),
        "plan": frozenset(index[i] for i in rho.states if i in index),
        "goal_in_map": frozenset({index[q0]}) if goal_in_map else frozenset(),
    }
    goal = None if cmap.goal is None else (cmap.goal.x, cmap.goal.y)
    return ExportModel(kind, states, index[q0], tuple(choices), labels, tuple(loops), rho, goal)


def _groups(cmap: CognitiveMap) -> dict[int, dict[TaskKind, list[Any]]]:
    out: dict[int, dict[TaskKind, list[Any]]] = {s.ident: {} for s in cmap.states()}
    for t in cmap.transitions():
        out[t.source].setdefault(t.label, []).append(t)
    return out


def induced_model(m: ExportModel, choose: Mapping[int, str], policy: str = "scheduler") -> ExportModel:
    """The DTMC that the MDP ``m`` becomes when each state takes the action ``choose``
    names for its ident (a state without one, or whose action is not among its choices,
    is absorbing): only the states reachable from the initial state, renumbered in their
    order in ``m``; labels as in ``m`` (``plan`` still marks ``m.plan``).

    >>> from clomp.formal.model import Disturbance, Pose, State
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> cmap = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), reached_goal=True),
    ...      State(2, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.5))], [(0, 1), (0, 2)], goal=g)
    >>> d = induced_model(export_model(cmap, "mdp"), {0: "LEFT"})
    >>> d.kind, [s.ident for s in d.states], d.choices[0][0].action, d.labels["goal"]
    ('dtmc', [0, 2], 'LEFT', frozenset())
    """
    if m.kind != "mdp":
        raise ExportError("a scheduler resolves the choices of an MDP: export the map as an mdp first")
    picked: dict[int, Choice | None] = {}
    for k, row in enumerate(m.choices):
        want = choose.get(m.states[k].ident)
        picked[k] = next((ch for ch in row if ch.action == want), None)
    g = nx.DiGraph()
    g.add_node(m.initial)
    g.add_edges_from((k, j) for k, ch in picked.items() if ch is not None for j, _ in ch.branches)
    keep = sorted(nx.descendants(g, m.initial) | {m.initial})
    index = {k: n for n, k in enumerate(keep)}
    choices: list[tuple[Choice, ...]] = []
    loops: list[int] = []
    for n, k in enumerate(keep):
        ch = picked[k]
        if ch is None:
            choices.append((Choice(STAY, ((n, Fraction(1)),)),))
            loops.append(n)
        else:
            choices.append((Choice(ch.action, tuple((index[j], p) for j, p in ch.branches), ch.distance, ch.time, True),))
    labels = {name: frozenset(index[k] for k in members if k in index) for name, members in m.labels.items()}
    return ExportModel("dtmc", tuple(m.states[k] for k in keep), index[m.initial], tuple(choices), labels,
                       tuple(loops), m.plan, m.goal, m.title, policy)
