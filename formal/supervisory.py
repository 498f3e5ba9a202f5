"""The Configurator's supervisory functions over a cognitive map: plan ρ, guard Ψ, reset R.

- ρ, the plan: a path q0 … qn of the map whose last state has the least cost φ among
  the states the plan may end in (those not interrupted, D_N = ∅).
- Ψ: ↪ → {1, 0}, the guard: 1 on the transitions of ρ, 0 elsewhere (the supervisory
  control pattern of Ramadge & Wonham: which events the supervisor enables).
- R: ↪ → **D**, the reset: the disturbance injected as D_I of the target of a
  transition, D_G when the source was not interrupted; undefined otherwise.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from formal.lts import CognitiveMap, MapError, Transition
from formal.model import Disturbance, State, TaskKind

__all__ = ["Plan", "ResetUndefined", "guard", "reset", "plan_end", "extract_plan"]


class ResetUndefined(MapError):
    """R is undefined on a transition leaving an interrupted state (D_N ≠ ∅)."""


@dataclass(frozen=True, slots=True)
class Plan:
    """A plan ρ: the idents of a path q0 … qn in a cognitive map."""

    states: tuple[int, ...]

    def __post_init__(self) -> None:
        if not self.states:
            raise ValueError("a plan holds at least q0")

    def __len__(self) -> int:
        return len(self.states)

    def __iter__(self):  # type: ignore[no-untyped-def]
        return iter(self.states)

    @property
    def end(self) -> int:
        """The ident of qn."""
        return self.states[-1]

    def steps(self) -> list[tuple[int, int]]:
        """The transitions of the plan as (source, target) pairs."""
        return list(zip(self.states, self.states[1:]))

    def tasks(self, cmap: CognitiveMap) -> list[State]:
        """The states the plan executes, q1 … qn (q0 is the present task)."""
        return [cmap[i] for i in self.states[1:]]

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form."""
        return {"states": list(self.states)}


def reset(cmap: CognitiveMap, source: int, target: int) -> Disturbance:
    """R(q_source, q_target): the disturbance D'_I injected into the target's task.

    Defined only on transitions of the map leaving an uninterrupted state, where it is
    the map's goal D_G. Raises :class:`ResetUndefined` when the source was interrupted
    and :class:`MapError` when there is no such transition or the map has no goal.
    """
    if not cmap.has_transition(source, target):
        raise MapError(f"no transition q{source} ↪ q{target}")
    if cmap[source].interrupted:
        raise ResetUndefined(f"R(q{source}, q{target}) is undefined: q{source} was interrupted (D_N ≠ ∅)")
    if cmap.goal is None:
        raise MapError("the map has no goal D_G")
    return cmap.goal


def guard(cmap: CognitiveMap, plan: Plan) -> dict[Transition, int]:
    """Ψ: every transition of the map mapped to 1 if it is a step of ``plan``, else 0."""
    steps = set(plan.steps())
    for s, t in steps:
        if not cmap.has_transition(s, t):
            raise MapError(f"plan step q{s} ↪ q{t} is not a transition of the map")
    return {t: int((t.source, t.target) in steps) for t in cmap.transitions()}


def plan_end(cmap: CognitiveMap) -> State:
    """argmin φ over the states a plan may end in (not interrupted); ties → lowest ident.

    Only states reachable from q0 count. When every reachable state but q0 is
    interrupted, the plan ends at q0 (the empty plan).
    """
    reach = cmap.reachable()
    candidates = [s for s in cmap.states() if s.ident in reach and not s.interrupted]
    if not candidates:
        return cmap.initial
    return min(candidates, key=lambda s: (s.cost, s.ident))


def extract_plan(cmap: CognitiveMap) -> Plan:
    """ρ: the shortest path from q0 to :func:`plan_end` through uninterrupted states."""
    end = plan_end(cmap)
    return Plan(tuple(cmap.path(end.ident)))


def plan_tasks(cmap: CognitiveMap, plan: Plan) -> list[TaskKind]:
    """The task kinds the plan starts, in order."""
    return [cmap[i].task for i in plan.states[1:]]
