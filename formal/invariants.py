"""The invariants of a cognitive map, checked one by one with the states involved.

:func:`check_map` returns every violated invariant (an empty list for a good map), so a
user who builds a map by hand, or a test that breaks one on purpose, learns *which*
property fails and *where*, not just that something is wrong. The invariants are:

1. ``INITIAL`` — the map has one initial state q0 and every state is reachable from it;
2. ``INTERRUPTED_ABSORBING`` — no transition leaves an interrupted state (D_N ≠ ∅);
3. ``RESET`` — R: every successor of an uninterrupted state is contingent on D_G (D_I = D_G);
4. ``GUARD`` — Ψ is 1 exactly on the plan's transitions, and the guarded map is a single
   path from q0 that ends at the plan end of :func:`clomp.formal.supervisory.plan_end`,
   restated here: q* = argmin φ over the uninterrupted reachable states, ties → lowest
   ident; but when q* is no goal, the map has a frontier state and q* is a frontier, or
   q0, or a state the search looked past whose cheapest open state (uninterrupted,
   reachable, no goal, no successor) is a frontier — the frontier state of least goal
   distance + metres driven among those of lower φ than q0 (all when none is), ties →
   lowest ident (a frontier end cheapest to reach and near the goal, not the nearest past
   a detour; the plan explores rather than stand still or stop in a local minimum); the
   budget does not enter;
5. ``TURN_THEN_STRAIGHT`` — every uninterrupted turn is followed by a straight, and only
   by straights (Algorithm 1's frontier rule: a frontier state is STRAIGHT or interrupted);
6. ``PROBABILITY`` — for every (state, task) the outgoing probabilities are in (0, 1] and
   sum to exactly 1.

>>> from clomp.formal.model import Disturbance, Pose, State, TaskKind
>>> g = Disturbance.goal(1.0, 0.0)
>>> m = CognitiveMap.from_parts(
...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
...      State(1, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.57), cost=0.5)],
...     [(0, 1)], goal=g)
>>> [(v.invariant.name, v.states) for v in check_map(m)]
[('TURN_THEN_STRAIGHT', (1,))]
"""

from __future__ import annotations

import enum
from collections import defaultdict
from collections.abc import Mapping
from dataclasses import dataclass
from fractions import Fraction

from clomp.formal.lts import CognitiveMap, MapError, Transition
from clomp.formal.model import TaskKind
from clomp.formal.supervisory import Guard, Plan, exploring_score, extract_plan, is_frontier

__all__ = [
    "Invariant",
    "Violation",
    "InvariantError",
    "check_map",
    "assert_map_valid",
    "map_plan",
]


class Invariant(enum.IntEnum):
    """The invariants of a cognitive map, numbered as in the module docstring.

    >>> Invariant(2).name
    'INTERRUPTED_ABSORBING'
    """

    INITIAL = 1
    INTERRUPTED_ABSORBING = 2
    RESET = 3
    GUARD = 4
    TURN_THEN_STRAIGHT = 5
    PROBABILITY = 6


@dataclass(frozen=True, slots=True)
class Violation:
    """One violated invariant: which, where (state idents) and a sentence saying why.

    >>> str(Violation(Invariant.INITIAL, (3,), "1 state(s) not reachable from q0"))
    '[1 INITIAL] 1 state(s) not reachable from q0 (q3)'
    """

    invariant: Invariant
    states: tuple[int, ...]
    message: str

    def __str__(self) -> str:
        where = ", ".join(f"q{i}" for i in self.states)
        return f"[{self.invariant.value} {self.invariant.name}] {self.message}" + (f" ({where})" if where else "")


class InvariantError(MapError):
    """Raised by :func:`assert_map_valid`; ``violations`` lists every failure.

    >>> err = InvariantError([Violation(Invariant.INITIAL, (), "the map has no initial state q0")])
    >>> isinstance(err, MapError), len(err.violations)
    (True, 1)
    """

    def __init__(self, violations: list[Violation]) -> None:
        self.violations = violations
        super().__init__("; ".join(str(v) for v in violations))


def map_plan(cmap: CognitiveMap) -> Plan:
    """The plan recorded in the map's metadata (the Configurator's choice), else :func:`extract_plan`."""
    recorded = cmap.metadata.get("plan")
    if recorded:
        try:
            return Plan(tuple(int(i) for i in recorded))
        except (TypeError, ValueError):
            raise MapError(f"metadata 'plan' is not a list of state idents: {recorded!r}") from None
    return extract_plan(cmap)


def check_map(
    cmap: CognitiveMap,
    plan: Plan | None = None,
    psi: Mapping[Transition, int] | None = None,
) -> list[Violation]:
    """Every violated invariant of ``cmap``, in invariant order; [] when the map is good.

    ``plan`` defaults to :func:`map_plan`; ``psi`` (a table Transition → {0, 1}) defaults
    to the table of that plan's :class:`~clomp.formal.supervisory.Guard`. Passing the ``psi`` a planner
    produced checks that table instead of one computed here.

    >>> from clomp.formal.model import Disturbance, Pose, State, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap(goal=g)
    >>> _ = m.add_state(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5))
    >>> _ = m.add_state(State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.3, 0), cost=0.2))
    >>> check_map(m)
    [Violation(invariant=<Invariant.INITIAL: 1>, states=(1,), message='1 state(s) not reachable from q0')]
    >>> _ = m.add_transition(0, 1)
    >>> check_map(m)
    []
    """
    out: list[Violation] = []
    if len(cmap) == 0:
        return [Violation(Invariant.INITIAL, (), "the map is empty: it has no initial state")]
    q0 = cmap.initial_id
    if q0 is None or q0 not in cmap:
        return [Violation(Invariant.INITIAL, (), "the map has no initial state q0")]
    reach = cmap.reachable()  # once: a BFS over the whole map
    unreachable = tuple(s.ident for s in cmap.states() if s.ident not in reach)
    if unreachable:
        out.append(Violation(Invariant.INITIAL, unreachable, f"{len(unreachable)} state(s) not reachable from q{q0}"))
    out += _interrupted_absorbing(cmap)
    out += _reset(cmap)
    out += _guard(cmap, plan, psi)
    out += _turn_then_straight(cmap)
    out += _probability(cmap)
    return out


def assert_map_valid(cmap: CognitiveMap, plan: Plan | None = None, psi: Mapping[Transition, int] | None = None) -> None:
    """Raise :class:`InvariantError` listing every violation when ``cmap`` breaks an invariant.

    >>> assert_map_valid(CognitiveMap())
    Traceback (most recent call last):
    ...
    clomp.formal.invariants.InvariantError: ...the map is empty...
    """
    violations = check_map(cmap, plan, psi)
    if violations:
        raise InvariantError(violations)


def _interrupted_absorbing(cmap: CognitiveMap) -> list[Violation]:
    bad = tuple(s.ident for s in cmap.states() if s.interrupted and cmap.out_transitions(s.ident))
    if not bad:
        return []
    return [Violation(Invariant.INTERRUPTED_ABSORBING, bad, "transitions leave interrupted state(s) (D_N ≠ ∅), where R is undefined")]


def _reset(cmap: CognitiveMap) -> list[Violation]:
    if cmap.goal is None:
        return [Violation(Invariant.RESET, (), "the map has no goal D_G, so R has no value")]
    bad = sorted(
        {t.target for t in cmap.transitions() if not cmap[t.source].interrupted and cmap[t.target].d_i != cmap.goal}
    )
    if not bad:
        return []
    return [Violation(Invariant.RESET, tuple(bad), "successor(s) of an uninterrupted state are not contingent on D_G (D_I ≠ D_G)")]


def _guard(cmap: CognitiveMap, plan: Plan | None, psi: Mapping[Transition, int] | None) -> list[Violation]:
    out: list[Violation] = []
    try:
        rho = map_plan(cmap) if plan is None else plan
    except MapError as exc:
        return [Violation(Invariant.GUARD, (), f"no plan: {exc}")]
    missing = [(s, t) for s, t in rho.steps() if s not in cmap or t not in cmap or not cmap.has_transition(s, t)]
    if missing:
        states = tuple(sorted({i for st in missing for i in st}))
        return [Violation(Invariant.GUARD, states, f"plan step(s) {missing} are not transitions of the map")]
    table = dict(Guard(cmap, rho).table() if psi is None else psi)
    domain = set(cmap.transitions())
    if set(table) != domain:
        extra = sorted({t.source for t in set(table) ^ domain})
        out.append(Violation(Invariant.GUARD, tuple(extra), "Ψ is not defined on exactly the map's transitions"))
    odd = sorted({t.source for t, v in table.items() if v not in (0, 1)})
    if odd:
        out.append(Violation(Invariant.GUARD, tuple(odd), "Ψ takes a value other than 0 or 1"))
    on = {t for t, v in table.items() if v == 1}
    steps = set(rho.steps())
    wrong = sorted({t.source for t in on if (t.source, t.target) not in steps} | {s for s, t in steps if not any((u.source, u.target) == (s, t) for u in on)})
    if wrong:
        out.append(Violation(Invariant.GUARD, tuple(wrong), "Ψ = 1 is not exactly the plan's transitions"))
    # the guarded map: follow Ψ = 1 from q0; it must be one path, without branches or cycles
    q0 = cmap.initial_id
    if q0 is None:
        out.append(Violation(Invariant.GUARD, (), "the map has no initial state to start the guarded path from"))
        return out
    if rho.states[0] != q0:
        out.append(Violation(Invariant.GUARD, (rho.states[0],), f"the plan does not start at q{q0}"))
    enabled: dict[int, set[int]] = defaultdict(set)
    for t in on:
        enabled[t.source].add(t.target)
    branching = tuple(sorted(s for s, ts in enabled.items() if len(ts) > 1))
    if branching:
        out.append(Violation(Invariant.GUARD, branching, "Ψ enables more than one successor: the guarded map is not a single path"))
    path, cur = [q0], q0
    while len(enabled.get(cur, ())) == 1:
        (cur,) = enabled[cur]
        if cur in path:
            out.append(Violation(Invariant.GUARD, tuple(path[path.index(cur):]), "the guarded map has a cycle"))
            break
        path.append(cur)
    stray = tuple(sorted(set(enabled) - set(path)))
    if stray:
        out.append(Violation(Invariant.GUARD, stray, "Ψ enables transitions off the path from q0"))
    end = path[-1]
    want, why = _plan_end(cmap, q0)
    if end != want:
        out.append(Violation(Invariant.GUARD, (end, want), f"the guarded path ends at q{end} (φ={cmap[end].cost:.6g}), "
                                                          f"not at {why} q{want} (φ={cmap[want].cost:.6g})"))
    return out


def _plan_end(cmap: CognitiveMap, q0: int) -> tuple[int, str]:
    """The end the plan-end rule names (invariant 4, stated apart from ``plan_end``'s code) and what it is."""
    reach = cmap.reachable()
    key = lambda s: (s.cost, s.ident)  # noqa: E731 - ties: the lowest ident
    best = min((s for s in cmap.states() if s.ident in reach and not s.interrupted), key=key, default=cmap[q0])
    if best.reached_goal or cmap.goal is None:
        return best.ident, "argmin φ"
    leaves = [s for s in cmap.states() if s.ident in reach and s.ident != q0 and not s.interrupted and not s.reached_goal
              and not cmap.out_transitions(s.ident)]
    frontiers = [s for s in leaves if is_frontier(s)]
    expanded = best.ident != q0 and bool(cmap.out_transitions(best.ident))
    if frontiers and (is_frontier(best) or best.ident == q0 or (expanded and is_frontier(min(leaves, key=key)))):
        gaining = [s for s in frontiers if s.cost < cmap[q0].cost]
        pick = min(gaining or frontiers, key=lambda s: (exploring_score(cmap, s), s.ident))
        return pick.ident, "the frontier end"
    return best.ident, "argmin φ"


def _turn_then_straight(cmap: CognitiveMap) -> list[Violation]:
    bad = []
    for s in cmap.states():
        if not s.task.is_turn or s.interrupted:
            continue
        out = cmap.out_transitions(s.ident)
        if not out or any(cmap[t.target].task is not TaskKind.STRAIGHT or t.label is not TaskKind.STRAIGHT for t in out):
            bad.append(s.ident)
    if not bad:
        return []
    return [Violation(Invariant.TURN_THEN_STRAIGHT, tuple(bad), "an uninterrupted turn is not followed by straight(s) only")]


def _probability(cmap: CognitiveMap) -> list[Violation]:
    sums: dict[tuple[int, TaskKind], Fraction] = defaultdict(Fraction)
    bad: set[int] = set()
    for t in cmap.transitions():
        p = Fraction(t.probability)
        if not 0 < p <= 1:
            bad.add(t.source)
        sums[(t.source, t.label)] += p
    bad |= {s for (s, _), total in sums.items() if total != 1}
    if not bad:
        return []
    return [Violation(Invariant.PROBABILITY, tuple(sorted(bad)), "outgoing probabilities of a (state, task) are not in (0, 1] or do not sum to 1")]
