"""The Configurator's supervisory functions over a cognitive map: plan ρ, guard Ψ, reset R.

- ρ, the plan: a path q0 … qn of the map whose last state has the least cost φ among
  the states the plan may end in (those not interrupted, D_N = ∅) — or, when that
  state is a frontier or gains the robot nothing (it is q0, or a local minimum the search
  looked past), the frontier state of least goal distance plus metres driven among those
  nearer the goal than q0 (:func:`plan_end`, :func:`frontier_end`).
- Ψ: ↪ → {1, 0}, the guard: 1 on the transitions of ρ, 0 elsewhere (the supervisory
  control pattern of Ramadge & Wonham: which events the supervisor enables).
- R: ↪ → **D**, the reset: the disturbance injected as D_I of the target of a
  transition, D_G when the source was not interrupted; undefined otherwise.

Each has one API, an object over a map: :class:`Guard` (Ψ of one plan; its table, the
``psi`` a plan result carries, comes from :meth:`Guard.table`) and :class:`Reset` (R;
:meth:`Reset.after` is its one definition, which the Configurator applies while it grows
a map, before the target state exists).
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, replace
from typing import Any

from clomp.formal.lts import CognitiveMap, MapError, Transition
from clomp.formal.model import Disturbance, State

__all__ = ["Plan", "ResetUndefined", "Guard", "Reset", "FRONTIER", "is_frontier", "argmin_phi", "exploring_score", "frontier_end", "plan_end", "extract_plan"]


class ResetUndefined(MapError):
    """R is undefined on a transition leaving an interrupted state (D_N ≠ ∅).

    >>> issubclass(ResetUndefined, MapError)
    True
    """


@dataclass(frozen=True, slots=True)
class Plan:
    """A plan ρ: the idents of a path q0 … qn in a cognitive map.

    >>> rho = Plan((0, 2, 5))
    >>> len(rho), rho.end, rho.steps()
    (3, 5, [(0, 2), (2, 5)])
    """

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


FRONTIER = "frontier"
"""The label (a key of :attr:`~clomp.formal.model.State.extra`) of a frontier state: one
whose task's body leaves the space the scan showed free (the sensed disc's rim, or space
no ray crossed); it is never expanded and never a goal (see :func:`plan_end`)."""


def is_frontier(state: State) -> bool:
    """True when ``state`` is a frontier state (labelled :data:`FRONTIER`).

    >>> from clomp.formal.model import Pose, TaskKind
    >>> q = State(1, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(0.3, 0), extra=((FRONTIER, 1.0),))
    >>> is_frontier(q), is_frontier(State(2, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(0.3, 0)))
    (True, False)
    """
    return any(k == FRONTIER for k, _ in state.extra)


def argmin_phi(cmap: CognitiveMap, reach: set[int] | None = None) -> State:
    """argmin φ over the uninterrupted states reachable from q0 (``reach``: those idents,
    when known); ties → lowest ident; q0 when there is none.

    >>> from clomp.formal.model import Pose, TaskKind
    >>> m = CognitiveMap.from_parts([State(0, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(0, 0), cost=0.5)], [])
    >>> argmin_phi(m).ident
    0
    """
    reach = cmap.reachable() if reach is None else reach
    best: State | None = None
    for s in cmap.states():  # by ident: the first of equal cost is the lowest ident
        if s.d_n is None and s.ident in reach and (best is None or s.cost < best.cost):
            best = s
    return cmap.initial if best is None else best


def exploring_score(cmap: CognitiveMap, state: State) -> float:
    """What the plan-end rule ranks frontier states by when it explores (:func:`plan_end`):
    the distance (m) from the state's end to the goal plus the metres driven along the
    shortest path from q0 to it (A*'s f = g + h in metres: the frontier nearest the goal
    that is cheapest to reach).

    >>> from clomp.formal.model import Pose, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.0, 0.3), distance=0.3)], [(0, 1)], goal=g)
    >>> round(exploring_score(m, m[1]), 4)   # 1.044 to the goal + 0.3 driven
    1.344
    """
    goal = cmap.goal
    ahead = 0.0 if goal is None else state.end.distance_to(goal.x, goal.y)
    return ahead + sum(cmap[i].distance for i in cmap.path(state.ident)[1:])


def plan_end(cmap: CognitiveMap) -> State:
    """The state a plan ends in: argmin φ over the states a plan may end in (reachable
    from q0, not interrupted), unless that state is a frontier or gains the robot nothing;
    then the frontier state of :func:`frontier_end`. Ties → lowest ident.

    **The rule.** Let q* be argmin φ (q0 when every other reachable state is interrupted).

    1. q* reached the goal, or the map has no frontier state, or the budget left q* (no
       frontier) unexpanded: the plan ends at q*.
    2. q* is a frontier state: the plan ends at a frontier, the one of :func:`frontier_end`
       — of the frontier states nearer the goal by φ than q0, the one of least goal
       distance plus metres driven (:func:`exploring_score`, A*'s f: the way on from a
       frontier is unknown and at least its distance to the goal). φ alone counts only
       the distance left, so the search's first frontier may lie past a long detour: in
       ``clomp experiment clutter`` such plans began with a turn and straights away from
       the goal, the closed loop replanned after the first of them, the gain was lost and
       the robot ended farther off or wedged between posts (paper run 1).
    3. Otherwise q* is q0 or a state the search expanded, and every task from it led no
       closer by φ. The plan *explores* — it ends at the frontier of :func:`frontier_end`
       (any frontier when none is nearer the goal than q0) — when

       a. q* is q0: the robot would otherwise stand still (an empty plan); or
       b. the cheapest state the search left open (reachable, not interrupted, not a goal,
          without successors) is a frontier state: the search looked past every state
          cheaper than the frontier, so no way inside known-free space leads below it,
          and q* is a local minimum of φ there (the inside of a U). Driving to q* gains
          no distance, and the next plan from there searches the same known-free space
          and stops in it (``clomp experiment u-trap``: the robot drove into the U and
          stood there).

       Otherwise (a cheaper open state is no frontier: a way closer may lie past it) the
       plan ends at q*.

    A frontier state is uninterrupted (the simulated body met no sensed obstacle), so
    what lies ahead of it is unknown, not known to be blocked: the closed loop drives
    there and looks round the shadow, as the paper's robot, whose map is rebuilt every
    revolution, would. The rule does not ask whether the search was cut short by its
    budget: a search cut short whose plan explores
    (argmin φ is no frontier) keeps the stop reason ``budget``
    (:meth:`clomp.planner.configurator.Configurator.build`), and the supervisor and the
    one-shot commands search it again four times deeper (:mod:`clomp.planner.deepening`);
    on the recorded corridor scan 43 the deeper search reaches the goal.

    That the runtime cannot shuttle between frontiers for ever is the supervisor's to
    bound (:class:`clomp.runtime.supervision.progress.Progress`: plans that bring the robot
    no closer, and an exploring plan back to where one ended before).

    **The tie rule.** Of states of equal φ (or of equal score) the first created, the
    lowest ident, ends the plan. So no plan ends on a turn that changes nothing: a final
    LEFT or RIGHT turns in place, its end is as far from the goal as its parent's and,
    uninterrupted, its φ equals the parent's; the parent, created before it, wins the
    tie and the useless turn is dropped. (Sending ties to the highest ident instead
    appends such a turn to the plans of the ``blocked`` and ``cul-de-sac`` scenarios;
    ``tests/planner/test_plan_end.py`` holds the rule.) A frontier state is a STRAIGHT
    (a turn that would leave known-free space is not available), so a frontier end is
    never a turn either.

    >>> from clomp.formal.model import Pose, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap(goal=g)
    >>> for i, cost in enumerate((0.9, 0.4, 0.2)):
    ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.1 * i, 0), cost=cost))
    >>> _ = m.add_transition(0, 1); _ = m.add_transition(1, 2)
    >>> plan_end(m).ident
    2

    Every task from q0 leads farther; one of them reaches a frontier: the plan explores.

    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(-0.3, 0), distance=0.3, cost=0.57),
    ...      State(2, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0.3), distance=0.3, cost=0.51,
    ...            extra=((FRONTIER, 1.0),))], [(0, 1), (0, 2)], goal=g)
    >>> plan_end(m).ident
    2
    """
    reach = cmap.reachable()
    best = argmin_phi(cmap, reach)
    q0 = cmap.initial_id
    if best.reached_goal or cmap.goal is None:
        return best
    open_ = [s for s in cmap.states() if s.ident in reach and s.ident != q0 and s.d_n is None
             and not s.reached_goal and not cmap.out_transitions(s.ident)]
    ends = [s for s in open_ if is_frontier(s)]
    looked_past = best.ident == q0 or bool(cmap.out_transitions(best.ident))
    if not ends or (not looked_past and not is_frontier(best)):
        return best  # no frontier, or a state the budget left unexpanded (a deeper search looks past it)
    if looked_past and best.ident != q0 and not is_frontier(min(open_, key=lambda s: (s.cost, s.ident))):
        return best  # a way closer may lie past the cheapest open state
    return frontier_end(cmap, ends)


def frontier_end(cmap: CognitiveMap, ends: list[State] | None = None) -> State:
    """The frontier state a plan that ends at the frontier ends in (:func:`plan_end`): of the
    frontier states nearer the goal by φ than q0 (all of them when none is), the one of least
    :func:`exploring_score` (goal distance + metres driven: A*'s f), ties → lowest ident.
    ``ends``: the map's frontier states, when known. ValueError when the map has none.

    >>> from clomp.formal.model import Pose, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> def frontier(i, x, y, driven, cost):
    ...     return State(i, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(x, y), distance=driven, cost=cost,
    ...                  extra=((FRONTIER, 1.0),))
    >>> q0 = State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5)
    >>> detour, back, ahead = frontier(1, 0.9, 0.5, 2.5, 0.34), frontier(2, -0.2, 0, 0.2, 0.55), frontier(3, 0.6, 0, 0.6, 0.29)
    >>> frontier_end(CognitiveMap.from_parts([q0, detour, back, ahead], [(0, 1), (0, 2), (0, 3)], goal=g)).ident
    3
    >>> frontier_end(CognitiveMap.from_parts([q0, detour, back], [(0, 1), (0, 2)], goal=g)).ident
    1

    The first: 0.4 m to the goal + 0.6 m driven beats 0.51 + 2.5 (a detour). The second: the
    detour still, not the frontier behind the robot (1.2 + 0.2), which gains nothing.
    """
    if ends is None:
        reach = cmap.reachable()
        ends = [s for s in cmap.states() if s.ident in reach and s.d_n is None and is_frontier(s)
                and not cmap.out_transitions(s.ident)]
    if not ends:
        raise ValueError("the map has no frontier state")
    q0 = cmap.initial.cost
    gains = [s for s in ends if s.cost < q0] or ends
    return min(gains, key=lambda s: (exploring_score(cmap, s), s.ident))


def extract_plan(cmap: CognitiveMap) -> Plan:
    """ρ: the shortest path from q0 to :func:`plan_end` through uninterrupted states.

    >>> from clomp.formal.model import Disturbance, Pose, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap(goal=g)
    >>> for i, cost in enumerate((0.9, 0.4, 0.2)):
    ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.1 * i, 0), cost=cost))
    >>> _ = m.add_transition(0, 1); _ = m.add_transition(1, 2)
    >>> extract_plan(m)
    Plan(states=(0, 1, 2))
    """
    end = plan_end(cmap)
    return Plan(tuple(cmap.path(end.ident)))


class Guard:
    """Ψ: ↪ → {0, 1} as an object: the supervisory control pattern of one plan on one map.

    The domain is every transition of the map; the codomain is {0, 1}. Ψ(t) = 1 exactly
    when t is a step of the plan ρ, so the supervisor enables one task per state of ρ and
    disables every other option the Configurator explored. Usable on a map built by hand:

    >>> from clomp.formal.model import Disturbance, Pose, State, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> m = CognitiveMap.from_parts(
    ...     [State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0), cost=0.5),
    ...      State(1, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(1, 0), cost=0.0),
    ...      State(2, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.57), cost=0.5)],
    ...     [(0, 1), (0, 2)], goal=g)
    >>> psi = Guard(m, extract_plan(m))
    >>> [psi(t) for t in psi.domain]
    [1, 0]
    >>> [t.target for t in psi.enabled(0)]
    [1]
    >>> sorted((t.target, v) for t, v in psi.table().items())
    [(1, 1), (2, 0)]
    """

    codomain: frozenset[int] = frozenset({0, 1})

    def __init__(self, cmap: CognitiveMap, plan: Plan) -> None:
        self.cmap = cmap
        self.plan = plan
        self._steps = frozenset(plan.steps())
        for s, t in plan.steps():
            if not cmap.has_transition(s, t):
                raise MapError(f"plan step q{s} ↪ q{t} is not a transition of the map")

    @property
    def domain(self) -> list[Transition]:
        """The transitions Ψ is defined on: all of ↪, in the map's stable order."""
        return self.cmap.transitions()

    def __call__(self, transition: Transition | tuple[int, int]) -> int:
        """Ψ(t): 1 when ``transition`` is a step of the plan, 0 otherwise.

        Raises :class:`MapError` for a pair that is not a transition of the map (outside
        the domain).
        """
        if isinstance(transition, Transition):
            s, t = transition.source, transition.target
            if s not in self.cmap or transition not in self.cmap.out_transitions(s):
                raise MapError(f"{transition} is not a transition of the map")
        else:
            s, t = transition
            if not self.cmap.has_transition(s, t):
                raise MapError(f"no transition q{s} ↪ q{t}")
        return int((s, t) in self._steps)

    def enabled(self, ident: int) -> list[Transition]:
        """The transitions out of q_ident that Ψ enables (at most one for a plan)."""
        return [t for t in self.cmap.out_transitions(ident) if (t.source, t.target) in self._steps]

    def table(self, like: Mapping[Transition, int] | None = None) -> dict[Transition, int]:
        """Ψ as a table: every transition of the map (in the map's order) → 0 or 1.

        ``like``: a table of the same map (e.g. the guard of another plan on it) whose
        keys are reused, in its order, with only the plan's steps set to 1: the keys'
        hashes are not computed again. A ``like`` that does not cover the map is ignored.

        >>> from clomp.formal.model import Pose, TaskKind
        >>> g = Disturbance.goal(1.0, 0.0)
        >>> m = CognitiveMap(goal=g)
        >>> for i in range(3):
        ...     _ = m.add_state(State(i, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0.1 * i, 0)))
        >>> _ = m.add_transition(0, 1); _ = m.add_transition(0, 2)
        >>> psi = Guard(m, Plan((0, 2))).table()
        >>> sorted((t.target, v) for t, v in psi.items())
        [(1, 0), (2, 1)]
        >>> Guard(m, Plan((0, 1))).table(like=psi) == Guard(m, Plan((0, 1))).table()
        True
        """
        steps = self._steps
        if like is None or len(like) != self.cmap.n_transitions:
            return {t: int((t.source, t.target) in steps) for t in self.cmap.transitions()}
        out = dict.fromkeys(like, 0)
        for s, target in steps:
            for t in self.cmap.out_transitions(s):
                if t.target == target:
                    out[t] = 1
        return out

    def __repr__(self) -> str:
        return f"Guard(plan={list(self.plan.states)}, |↪|={self.cmap.n_transitions})"


class Reset:
    """R: ↪ → **D** as an object: what the Configurator injects as D_I of a transition's target.

    R(q1, q2) = D_G when q1 was not interrupted (D_N = ∅); R is undefined on transitions
    leaving an interrupted state, because the Configurator never continues after a
    collision. The codomain is {D_G}. :meth:`after` is the one definition (R of
    whatever task follows a state, which need not be in the map yet); :meth:`inject`
    applies it to a pair of states that are not (yet) in a map, which is how a map is
    grown by hand:

    >>> from clomp.formal.model import Disturbance, Pose, State, TaskKind
    >>> g = Disturbance.goal(1.0, 0.0)
    >>> q0 = State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0))
    >>> q1 = Reset(CognitiveMap(goal=g)).inject(q0, State(1, TaskKind.LEFT, None, None, Pose(0, 0), Pose(0, 0, 1.57)))
    >>> q1.d_i == g
    True
    """

    def __init__(self, cmap: CognitiveMap) -> None:
        self.cmap = cmap

    @property
    def codomain(self) -> frozenset[Disturbance]:
        """{D_G}, or the empty set for a map without a goal."""
        return frozenset() if self.cmap.goal is None else frozenset({self.cmap.goal})

    def is_defined(self, transition: Transition) -> bool:
        """True when R is defined on ``transition``: its source is not interrupted and the map has a goal."""
        return self.cmap.goal is not None and not self.cmap[transition.source].interrupted

    @property
    def domain(self) -> list[Transition]:
        """The transitions R is defined on."""
        return [t for t in self.cmap.transitions() if self.is_defined(t)]

    @property
    def undefined(self) -> list[Transition]:
        """The transitions R is undefined on (none in a well-formed map, by invariant 2)."""
        return [t for t in self.cmap.transitions() if not self.is_defined(t)]

    def after(self, source: State) -> Disturbance:
        """R applied to the task that follows ``source``: the D_I to inject, the map's D_G.

        Raises :class:`ResetUndefined` when ``source`` was interrupted (D_N ≠ ∅) and
        :class:`MapError` when the map has no goal.

        >>> from clomp.formal.model import Pose, TaskKind
        >>> g = Disturbance.goal(1.0, 0.0)
        >>> R = Reset(CognitiveMap(goal=g))
        >>> R.after(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0))) == g
        True
        >>> R.after(State(1, TaskKind.STRAIGHT, g, Disturbance.goal(0.5, 0.0), Pose(0, 0), Pose(0.4, 0)))
        Traceback (most recent call last):
        ...
        clomp.formal.supervisory.ResetUndefined: R(q1, ·) is undefined: q1 was interrupted (D_N ≠ ∅)
        """
        if source.interrupted:
            raise ResetUndefined(f"R(q{source.ident}, ·) is undefined: q{source.ident} was interrupted (D_N ≠ ∅)")
        goal = self.cmap.goal
        if goal is None:
            raise MapError("the map has no goal D_G")
        return goal

    def __call__(self, transition: Transition | tuple[int, int]) -> Disturbance:
        """R(t) on a transition of the map: D'_I injected into the target's task.

        Raises :class:`ResetUndefined` where R is undefined (the source was interrupted)
        and :class:`MapError` when there is no such transition or the map has no goal.

        >>> from clomp.formal.model import Pose, TaskKind
        >>> g = Disturbance.goal(1.0, 0.0)
        >>> m = CognitiveMap(goal=g)
        >>> _ = m.add_state(State(0, TaskKind.STRAIGHT, g, None, Pose(0, 0), Pose(0, 0)))
        >>> _ = m.add_state(State(1, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.57)))
        >>> _ = m.add_transition(0, 1, TaskKind.LEFT)
        >>> Reset(m)((0, 1)) == g
        True
        """
        s, t = (transition.source, transition.target) if isinstance(transition, Transition) else transition
        if not self.cmap.has_transition(s, t):
            raise MapError(f"no transition q{s} ↪ q{t}")
        return self.after(self.cmap[s])

    def inject(self, source: State, target: State) -> State:
        """``target`` with D_I set to R(source, target) = D_G; raises :class:`ResetUndefined`
        when ``source`` was interrupted and :class:`MapError` when the map has no goal."""
        return replace(target, d_i=self.after(source))

    def __repr__(self) -> str:
        return f"Reset(D_G={self.cmap.goal!r})"
