"""The plan-end rule (:func:`clomp.formal.supervisory.plan_end`).

The tie rule: of states of equal φ (or of equal exploring score) the first created ends
the plan, so no plan ends on a turn that changes nothing. Sending ties to the highest
ident instead (a mutation that survived the other tests) appends a useless final turn to
the plans of two built-in scenarios; these tests fail under it.

The exploring end: when argmin φ is q0 (the robot would stand still) or a local minimum
the search looked past while its cheapest open state is a frontier (the inside of a U),
the plan ends at the frontier state of least goal distance + metres driven. Without it
the pocket's plan is empty and the U-trap's plans end inside the U; these tests fail."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.formal.supervisory import FRONTIER, argmin_phi, exploring_score, extract_plan, is_frontier, plan_end
from clomp.planner import Configurator, PlanResult, builtin_scenarios, load_scan, load_scenario
from clomp.planner.deepening import plan_deepening
from clomp.runtime.experiment.layouts import make_layout

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


# -- the exploring end (issue #39: the known-free rule left plans empty or in a U) -----------------
def pocket(front: float = 0.22, half: float = 0.34, back: float = -0.1, beams: int = 720) -> np.ndarray:
    """A scan from inside a pocket of three thin walls open behind the robot (front wall at
    ``front``, sides at ±``half`` from ``back`` to ``front``), ray-cast here, cropped at 1.1 m."""
    walls = [((front, -half), (front, half)), ((back, half), (front, half)), ((back, -half), (front, -half))]
    pts = []
    for k in range(beams):
        a = 2 * math.pi * k / beams
        ux, uy = math.cos(a), math.sin(a)
        hits = []
        for (x1, y1), (x2, y2) in walls:
            ex, ey = x2 - x1, y2 - y1
            den = ux * ey - uy * ex
            if abs(den) > 1e-12:
                t, s = (x1 * ey - y1 * ex) / den, (x1 * uy - y1 * ux) / den
                if t > 0 and 0 <= s <= 1:
                    hits.append(t)
        if hits and min(hits) <= 1.1:
            pts.append((min(hits) * ux, min(hits) * uy))
    return np.array(pts)


def test_a_robot_in_a_pocket_explores_rather_than_stand_still() -> None:
    """Every task from the start is interrupted or leads farther from the goal behind the
    pocket's wall (argmin φ is q0): the plan ends at a frontier farther from the goal by φ,
    where the closed loop looks round the wall, not at q0 (the empty plan it had)."""
    r = plan_deepening(Configurator(), pocket(), (0.8, 0.0))
    m = r.map
    assert argmin_phi(m).ident == 0
    end = m[r.plan.end]
    assert r.steps and is_frontier(end) and end.cost > m[0].cost
    assert end.task is TaskKind.STRAIGHT and not r.reached_goal


@pytest.mark.parametrize("run", [2, 3, 5])
def test_behind_a_u_the_plan_goes_round_it_not_into_it(run: int) -> None:
    """``clomp experiment u-trap`` seed 0, the layouts the known-free rule lost: argmin φ lies
    inside the U, a state the search looked past (every task from it leads no closer); the
    plan ends instead at a frontier outside the U, where the goal behind it comes into sight."""
    scene = make_layout("u-trap", 0, run).scene
    conf = Configurator()
    r = conf.plan(scene.scan(max_range=conf.robot.sensor_range), tuple(scene.goal_in_robot_frame()))
    walls = scene.raw["obstacles"]
    xs = [p[0] for w in walls for p in (w["from"], w["to"])]
    ys = [p[1] for w in walls for p in (w["from"], w["to"])]

    def inside_u(s: State) -> bool:
        return min(xs) - 0.3 <= s.end.x <= max(xs) and min(ys) <= s.end.y <= max(ys)

    m = r.map
    least = argmin_phi(m)
    assert inside_u(least) and m.successors(least.ident)
    end = m[r.plan.end]
    assert is_frontier(end) and not inside_u(end)


def test_an_exploring_tie_goes_to_the_first_created_frontier() -> None:
    """Two frontier states of equal goal distance + metres driven: the lower ident ends the plan."""
    g = _G
    m = CognitiveMap.from_parts(
        [
            State(0, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.0, 0.0), cost=0.5),
            State(1, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.0, 0.3), distance=0.3, cost=0.51, extra=((FRONTIER, 1.0),)),
            State(2, TaskKind.STRAIGHT, g, None, Pose(0.0, 0.0), Pose(0.0, -0.3), distance=0.3, cost=0.51, extra=((FRONTIER, 1.0),)),
        ],
        [(0, 1), (0, 2)],
        goal=g,
    )
    assert exploring_score(m, m[1]) == exploring_score(m, m[2])
    assert plan_end(m).ident == 1


@pytest.mark.parametrize("name", ["map0012.dat", "map0019.dat", "map0032.dat"])
def test_a_search_cut_short_at_a_frontier_is_not_searched_again(scans_dir: Path, name: str) -> None:
    """Recorded lab scans (2022-11-06) whose search spends its budget of 50 with argmin φ a
    frontier state it would have popped next and stopped at: the plan ends at the frontier
    end (plan_end) and the stop reason is ``frontier``, not ``budget``, so no deeper search
    runs (clomp.planner.deepening deepens only a plan that explores: argmin φ no frontier).
    Deepened, such searches went on to long ways round (clutter, harsh, seed 0, run 8: 143
    states, 17 tasks, and a goal claimed 0.16 m off)."""
    lab = scans_dir.parent / "lab-2022-11-06" / name
    if not lab.is_file():
        pytest.skip(f"recorded scan not found at {lab}")
    scan = load_scan(lab)
    r = Configurator().plan(scan, (1.0, 0.0))
    assert r.n_states >= Configurator().max_states - 2  # went on to the budget
    assert is_frontier(argmin_phi(r.map)) and is_frontier(r.map[r.plan.end])
    assert r.stop_reason == "frontier"
    assert plan_deepening(Configurator(), scan, (1.0, 0.0)).n_states == r.n_states
