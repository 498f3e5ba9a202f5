"""The plan-end tie rule (:func:`clomp.formal.supervisory.plan_end`): of states of equal φ
the first created ends the plan, so no plan ends on a turn that changes nothing.

Sending ties to the highest ident instead (a mutation that survived the other tests)
appends a useless final turn to the plans of two built-in scenarios; these tests fail
under it."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.formal.supervisory import extract_plan, plan_end
from clomp.planner import Configurator, PlanResult, builtin_scenarios, load_scenario

_G = Disturbance.goal(1.0, 0.0)


def _tie_map(cost: float) -> CognitiveMap:
    """q0 → q1 (STRAIGHT) → q2 (LEFT in place at q1's end): q1 and q2 tie on φ."""
    end = Pose(0.3, 0.0, 0.0)
    return CognitiveMap.from_parts(
        [
            State(0, TaskKind.STRAIGHT, _G, None, Pose(0.0, 0.0), Pose(0.0, 0.0), cost=0.5),
            State(1, TaskKind.STRAIGHT, _G, None, Pose(0.0, 0.0), end, cost=cost),
            State(2, TaskKind.LEFT, _G, None, end, Pose(end.x, end.y, 1.2), cost=cost),
        ],
        [(0, 1), (1, 2)],
        goal=_G,
    )


def test_a_tie_goes_to_the_first_created_state_not_to_the_turn_after_it() -> None:
    m = _tie_map(0.4)
    assert plan_end(m).ident == 1
    assert extract_plan(m).states == (0, 1)


@given(st.floats(0.0, 0.99, allow_nan=False), st.integers(2, 6))
def test_among_equal_costs_the_lowest_ident_ends_the_plan(cost: float, n: int) -> None:
    """n states one after another from q0, all of the same φ (below q0's): q1 wins."""
    states = [State(0, TaskKind.STRAIGHT, _G, None, Pose(0.0, 0.0), Pose(0.0, 0.0), cost=1.0)]
    states += [State(i, TaskKind.STRAIGHT, _G, None, Pose(0.0, 0.0), Pose(0.1 * i, 0.0), cost=cost) for i in range(1, n)]
    m = CognitiveMap.from_parts(states, [(0, i) for i in range(1, n)], goal=_G)
    assert plan_end(m).ident == 1


def _useless_final_turn(result: PlanResult) -> bool:
    """The plan's last task is a turn whose end is as far from the goal as its parent's."""
    states = result.plan.states
    if len(states) < 2:
        return False
    last, parent = result.map[states[-1]], result.map[states[-2]]
    if last.task is TaskKind.STRAIGHT:
        return False
    g = result.goal
    return math.isclose(last.end.distance_to(g.x, g.y), parent.end.distance_to(g.x, g.y), abs_tol=1e-12)


@pytest.mark.parametrize("name", builtin_scenarios())
def test_no_built_in_plan_ends_on_a_turn_that_changes_nothing(name: str) -> None:
    scene = load_scenario(name)
    r = Configurator().plan(scene.scan(), tuple(scene.goal_in_robot_frame()))
    assert not _useless_final_turn(r), [s.task.value for s in r.steps]


@pytest.mark.parametrize("name", ["blocked", "cul-de-sac"])
def test_the_scenarios_with_a_tied_end_keep_the_straight_that_ends_their_plan(name: str) -> None:
    """In these two the plan's end ties with a turn in place after it (the case the rule decides)."""
    scene = load_scenario(name)
    r = Configurator().plan(scene.scan(), tuple(scene.goal_in_robot_frame()))
    end = r.map[r.plan.end]
    assert end.task is TaskKind.STRAIGHT
    tied = [s for s in r.map.successors(end.ident) if s.task is not TaskKind.STRAIGHT and s.cost == end.cost]
    assert tied, "no tied turn after the plan's end: the case this test is about is gone"


def test_no_plan_on_the_recorded_corridor_ends_on_a_turn_that_changes_nothing(scans_dir: Path) -> None:
    """Ties sent to the highest state append a useless turn to the plans of 27 of these 279 scans."""
    conf = Configurator()
    useless = [f.name for f in sorted(scans_dir.glob("*.dat")) if _useless_final_turn(conf.plan(f, (1.0, 0.0)))]
    assert useless == []
