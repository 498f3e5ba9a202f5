"""The plan-end rule as an invariant (invariant 4, GUARD, of :mod:`clomp.formal.invariants`),
over hand-grown maps with frontier states (:func:`clomp.formal.strategies.cognitive_maps`).

Stated here once more, apart from both :func:`clomp.formal.supervisory.plan_end` and the
checker: the plan ends at argmin φ (ties: the lowest ident) unless that state is a
frontier or gains the robot nothing — it is q0, or the search looked past it while its
cheapest open state is a frontier — and the map has a frontier state; then at the
frontier state of least goal distance + metres driven among the frontier states of
lower φ than q0 (all of them when none is; ties: the lowest ident). Whether the budget
cut the search short does not enter. So a plan never stands still while it could
explore, and never ends at a frontier past a detour when one cheaper to reach gains too.
Break ``plan_end`` (end at the first frontier by φ, never explore from q0 or from a local
minimum, pick a frontier that gains nothing while one gains, or send ties to the highest
ident) and these tests fail; break the checker's restatement and the invariant test
fails on the Configurator's own maps.
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
    if least.reached_goal:
        return least.ident
    open_ = [s for s in usable if s.ident != 0 and not s.reached_goal and not m.successors(s.ident)]
    ends = [s for s in open_ if is_frontier(s)]
    if not ends:
        return least.ident
    unexpanded = least.ident != 0 and not m.successors(least.ident)
    stuck = least.ident == 0 or (not unexpanded and is_frontier(min(open_, key=lambda s: (s.cost, s.ident))))
    if is_frontier(least) or stuck:
        gaining = [s for s in ends if s.cost < m[0].cost]
        return min(gaining or ends, key=lambda s: (exploring_score(m, s), s.ident)).ident
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
def test_the_budget_does_not_move_the_end(m: CognitiveMap) -> None:
    """The same maps, recorded as cut short by the budget: the same end (a search cut short
    is searched deeper, :mod:`clomp.planner.deepening`; the rule does not refuse to explore)."""
    end = plan_end(m)
    m.metadata["stop_reason"] = "budget"
    assert plan_end(m).ident == end.ident == _expected(m)
    assert check_map(m) == []


@SETTINGS
@given(cognitive_maps(frontiers=True))
def test_a_frontier_end_gains_when_a_frontier_gains(m: CognitiveMap) -> None:
    """A plan that ends at a frontier while some frontier is nearer the goal by φ than q0
    ends at one of those, and no other such frontier is cheaper by goal distance + metres driven."""
    end = plan_end(m)
    reach = m.reachable()
    gaining = [s for s in m.states() if s.ident in reach and is_frontier(s) and not s.interrupted and s.cost < m[0].cost]
    if is_frontier(end) and gaining:
        assert end.cost < m[0].cost
        assert all(exploring_score(m, end) <= exploring_score(m, s) for s in gaining)


def test_the_end_is_not_the_nearest_frontier_past_a_detour() -> None:
    """q* is a frontier 0.05 m from the goal after 2.9 m of driving; another gains too, 0.6 m
    from it after 0.45 m: the plan ends at the second (the closed loop replans there)."""
    m = CognitiveMap.from_parts(
        [
            State(0, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(0, 0), cost=0.5),
            State(1, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(GOAL.x - 0.05, GOAL.y), distance=2.9, cost=0.05,
                  extra=((FRONTIER, 1.0),)),
            State(2, TaskKind.STRAIGHT, GOAL, None, Pose(0, 0), Pose(GOAL.x - 0.6, GOAL.y), distance=0.45, cost=0.3,
                  extra=((FRONTIER, 1.0),)),
        ],
        [(0, 1), (0, 2)],
        goal=GOAL,
    )
    assert plan_end(m).ident == 2
    assert Invariant.GUARD not in {v.invariant for v in check_map(m)}
    assert Invariant.GUARD in {v.invariant for v in check_map(m, Plan((0, 1)))}


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
    assert v.states == (0, 2) and "frontier end" in v.message
