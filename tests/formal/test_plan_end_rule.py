"""The plan-end rule as an invariant (invariant 4, GUARD, of :mod:`clomp.formal.invariants`),
over hand-grown maps with frontier states (:func:`clomp.formal.strategies.cognitive_maps`).

Stated here once more, apart from both :func:`clomp.formal.supervisory.plan_end` and the
checker: the plan ends at argmin φ (ties: the lowest ident) unless that state gains the
robot nothing — it is q0, or the search looked past it while its cheapest open state is a
frontier (in a map whose search its budget did not cut short) — and the map has a
frontier state; then at the frontier state of least goal
distance + metres driven (ties: the lowest ident). So a plan never stands still while it
could explore. Break ``plan_end`` (never explore from q0, or from a local minimum, or
send ties to the highest ident) and these tests fail; break the checker's restatement and
the invariant test fails on the Configurator's own maps.
"""

from __future__ import annotations

from hypothesis import HealthCheck, given, settings

from clomp.formal import CognitiveMap, Plan, Pose, State, TaskKind
from clomp.formal.invariants import Invariant, check_map
from clomp.formal.strategies import GOAL, cognitive_maps
from clomp.formal.supervisory import FRONTIER, exploring_score, extract_plan, is_frontier, plan_end

SETTINGS = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _expected(m: CognitiveMap) -> int:
    reach = m.reachable()
    usable = [s for s in m.states() if s.ident in reach and not s.interrupted]
    least = min(usable, key=lambda s: (s.cost, s.ident))
    has_next = bool(m.successors(least.ident))
    if least.reached_goal or (least.ident != 0 and not has_next):
        return least.ident
    open_ = [s for s in usable if s.ident != 0 and not s.reached_goal and not m.successors(s.ident)]
    ends = [s for s in open_ if is_frontier(s)]
    cut_short = m.metadata.get("stop_reason") == "budget"
    if ends and (least.ident == 0 or (not cut_short and is_frontier(min(open_, key=lambda s: (s.cost, s.ident))))):
        return min(ends, key=lambda s: (exploring_score(m, s), s.ident)).ident
    return least.ident


@SETTINGS
@given(cognitive_maps(frontiers=True))
def test_the_plan_ends_where_the_rule_says(m: CognitiveMap) -> None:
    end = plan_end(m)
    assert end.ident == _expected(m)
    assert not end.interrupted
    assert check_map(m) == []  # the checker's restatement agrees


@SETTINGS
@given(cognitive_maps(frontiers=True))
def test_a_search_cut_short_by_its_budget_ends_in_its_local_minimum(m: CognitiveMap) -> None:
    """The same maps, recorded as cut short by the budget: only q0 explores."""
    m.metadata["stop_reason"] = "budget"
    end, least = plan_end(m), min((s for s in m.states() if not s.interrupted and s.ident in m.reachable()),
                                  key=lambda s: (s.cost, s.ident))
    assert end.ident == _expected(m)
    assert end.ident == least.ident or least.ident == 0
    assert check_map(m) == []


@SETTINGS
@given(cognitive_maps(frontiers=True))
def test_a_plan_never_stands_still_while_a_frontier_is_in_the_map(m: CognitiveMap) -> None:
    reach = m.reachable()
    frontiers = [s for s in m.states() if s.ident in reach and is_frontier(s) and not s.interrupted]
    if frontiers:
        assert len(extract_plan(m)) > 1


def _explore_map() -> CognitiveMap:
    """q0 (φ 0.5) → q1 (φ 0.57, farther, expanded no further) and q2 (φ 0.51, a frontier)."""
    return CognitiveMap.from_parts(
        [
            State(0, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(0, 0), cost=0.5),
            State(1, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(-0.3, 0), distance=0.3, cost=0.57),
            State(2, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(0, 0.3), distance=0.3, cost=0.51,
                  extra=((FRONTIER, 1.0),)),
        ],
        [(0, 1), (0, 2)],
        goal=GOAL,
    )


def test_the_checker_refuses_an_empty_plan_where_the_rule_explores() -> None:
    m = _explore_map()
    assert extract_plan(m).states == (0, 2)
    (v,) = [v for v in check_map(m, Plan((0,))) if v.invariant is Invariant.GUARD]
    assert v.states == (0, 2) and "exploring frontier" in v.message
