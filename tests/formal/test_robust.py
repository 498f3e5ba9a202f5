"""Risk-aware plans: Storm's scheduler for Pmax [!collision U goal] against the greedy plan."""

from __future__ import annotations

import pytest

from formal.invariants import map_plan

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")

from formal.robust import follow_tasks, plan_probability, robust_plan  # noqa: E402


def test_the_scheduler_takes_the_sure_detour_the_greedy_plan_does_not(risky_map):
    greedy = map_plan(risky_map)
    assert greedy.states == (0, 1)
    assert plan_probability(risky_map, greedy) == pytest.approx(0.8, abs=1e-12)
    r = robust_plan(risky_map)
    assert r.probability == pytest.approx(1.0, abs=1e-12)
    assert r.plan.states == (0, 3, 4, 5, 6)
    assert r.scheduler[0].value == "LEFT"
    assert plan_probability(risky_map, r.plan) == pytest.approx(1.0, abs=1e-12)


def test_a_plan_that_is_not_a_path_of_the_map_is_refused(risky_map):
    from formal.lts import MapError
    from formal.supervisory import Plan

    with pytest.raises(MapError, match="q0 ↪ q6"):
        plan_probability(risky_map, Plan((0, 6)))


@pytest.mark.parametrize("name", ["doorway", "overtaking", "slalom"])
def test_robust_is_never_below_greedy_on_sampled_maps(name):
    from planner import load_scenario
    from planner.probabilistic import RolloutNoise, sample_map

    scene = load_scenario(name)
    harsh = RolloutNoise(range_sd=0.02, dropout=0.1, wheel_sd=0.08, wheel_bias=0.03, drift=0.02)
    pm = sample_map(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()), samples=20, noise=harsh, seed=1)
    r = robust_plan(pm.map)
    greedy = plan_probability(pm.map, follow_tasks(pm.map, [s.task for s in pm.nominal.steps]))
    assert 0 <= greedy <= r.probability + 1e-12 <= 1 + 1e-12
    # the scheduler's plan is a path of the map that starts at q0
    assert r.plan.states[0] == pm.map.initial_id
    assert all(pm.map.has_transition(a, b) for a, b in r.plan.steps())


def test_the_robust_configurator_hands_a_supervisor_storms_plan():
    from formal import check_map
    from planner import load_scenario
    from planner.probabilistic import RobustConfigurator

    scene = load_scenario("overtaking")
    conf = RobustConfigurator(samples=10, noise="paper")
    r = conf.plan(scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame()))
    assert check_map(r.map, r.plan, r.psi) == [] or all(v.invariant.name == "GUARD" for v in check_map(r.map, r.plan, r.psi))
    assert sum(r.psi.values()) == len(r.plan) - 1 and r.steps
    robust, greedy = conf.last_probabilities  # type: ignore[misc]
    assert 0 <= greedy <= robust + 1e-12


def test_a_nominal_plan_is_carried_onto_a_map_where_its_outcome_never_happened(risky_map):
    """q0's STRAIGHT nominally ended at q1; on a map where it always hits, the same task
    still leads somewhere: the carried plan follows it to its most likely outcome."""
    from formal import CognitiveMap
    from formal.model import TaskKind

    m = CognitiveMap.from_dict(risky_map.to_dict())
    m2 = CognitiveMap.from_parts([s for s in m.states() if s.ident != 1], [t for t in m.transitions() if t.target != 1 and t.source != 0] , goal=m.goal)
    m2.add_transition(0, 2, TaskKind.STRAIGHT)
    m2.add_transition(0, 3, TaskKind.LEFT)
    carried = follow_tasks(m2, [TaskKind.STRAIGHT])
    assert carried.states == (0, 2)
    assert plan_probability(m2, carried) == 0.0 <= robust_plan(m2).probability == pytest.approx(1.0)
