"""Hypothesis strategies for cognitive maps, without a planner (in the spirit of ``hypothesis.extra``).

:func:`cognitive_maps` grows a map by hand the way Algorithm 1 grows one, so that an
exporter, a checker or a supervisor can be property-tested on maps that hold every
invariant of :func:`clomp.formal.check_map` — with ``probabilistic=True`` a task may have several
outcomes (the probabilities of each choice sum to 1). Maps planned in generated scenes
are :func:`clomp.planner.strategies.planned_maps`. Requires ``hypothesis``.

>>> from hypothesis import given, settings
>>> from clomp.formal import check_map
>>> @settings(max_examples=10, deadline=None)
... @given(cognitive_maps(probabilistic=True))
... def test_grown_maps_are_valid(m):
...     assert check_map(m) == []
>>> test_grown_maps_are_valid()
"""

from __future__ import annotations

from dataclasses import replace
from fractions import Fraction

from hypothesis import strategies as st

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import PAPER_TASKS, Disturbance, DisturbanceKind, Pose, State, TaskKind
from clomp.formal.supervisory import FRONTIER

__all__ = ["GOAL", "OBSTACLE", "cognitive_maps"]

GOAL = Disturbance.goal(1.0, 0.0)
"""The goal D_G of the generated maps."""
OBSTACLE = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0, ((0.45, -0.1), (0.55, -0.1), (0.55, 0.1), (0.45, 0.1)), 0)
"""The disturbance D_N that interrupts the generated maps' interrupted states."""


def _state(ident: int, task: TaskKind, interrupted: bool, cost: float) -> State:
    return State(ident, task, GOAL, OBSTACLE if interrupted else None, Pose(0, 0), Pose(0.1 * ident, 0), cost=cost)


@st.composite
def cognitive_maps(
    draw: st.DrawFn, probabilistic: bool = False, max_expansions: int = 5, frontiers: bool = False
) -> CognitiveMap:
    """A map grown like Algorithm 1 grows one.

    From q0 (an uninterrupted STRAIGHT), up to ``max_expansions`` times an uninterrupted
    frontier state is expanded with one to three options: STRAIGHT, or a turn followed by a
    STRAIGHT unless the turn was interrupted; any task may be interrupted (D_N =
    :data:`OBSTACLE`, cost ≥ 1, so a plan never ends there). With ``probabilistic`` each
    option has one to three outcomes with rational probabilities summing to 1. With
    ``frontiers`` some STRAIGHT states left unexpanded are labelled frontier states
    (:data:`clomp.formal.supervisory.FRONTIER`: the body left known-free space), so the
    plan may end at one (the exploring end of :func:`clomp.formal.supervisory.plan_end`).

    >>> from hypothesis import find
    >>> len(find(cognitive_maps(), lambda m: len(m) >= 4)) >= 4
    True
    """
    m = CognitiveMap(goal=GOAL)
    m.add_state(_state(0, TaskKind.STRAIGHT, False, 0.5))
    costs = st.floats(0.0, 0.99)

    def add(task: TaskKind) -> State:
        hit = draw(st.booleans())
        return m.add_state(_state(len(m), task, hit, 1 + draw(costs) if hit else draw(costs)))

    frontier = [0]
    for _ in range(draw(st.integers(0, max_expansions))):
        if not frontier:
            break
        e = frontier.pop(draw(st.integers(0, len(frontier) - 1)))
        for kind in draw(st.lists(st.sampled_from(PAPER_TASKS), min_size=1, max_size=3, unique=True)):
            n = draw(st.integers(1, 3)) if probabilistic else 1
            weights = draw(st.lists(st.integers(1, 5), min_size=n, max_size=n))
            for w in weights:
                first = add(kind)
                m.add_transition(e, first.ident, kind, Fraction(w, sum(weights)))
                last = first
                if kind.is_turn and not first.interrupted:
                    last = add(TaskKind.STRAIGHT)
                    m.add_transition(first.ident, last.ident)
                if not last.interrupted:
                    frontier.append(last.ident)
    if frontiers:
        for i in frontier:
            s = m[i]
            if i != 0 and s.task is TaskKind.STRAIGHT and draw(st.booleans()):
                m.replace_state(replace(s, extra=((FRONTIER, 1.0),)))
    return m
