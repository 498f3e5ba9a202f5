"""The Configurator on the built-in scenarios, on recorded scans, and on bad input."""

from __future__ import annotations

import json

import numpy as np
import pytest

from clomp.formal.model import TaskKind
from clomp.formal.supervisory import Guard
from clomp.planner import Configurator, PlanningError, RobotModel, load_scan, load_scenario, plan, simulate
from clomp.planner.configurator import chi, default_cost, gamma
from clomp.planner.rollout import World


def _plan_scenario(name: str, **kw):
    scene = load_scenario(name)
    return Configurator(**kw).plan(scene.scan(), tuple(scene.goal_in_robot_frame()))


def test_overtaking_turns_around_the_obstacle_towards_the_goal():
    r = _plan_scenario("overtaking")
    # the goal stands in the box's shadow: the last straight drives into space no ray
    # crossed, so the plan ends there as a frontier (the closed loop looks again on the way)
    assert not r.reached_goal and r.collision_free and r.stop_reason == "frontier"
    assert 10 <= r.n_states <= 200
    kinds = [s.task for s in r.steps]
    assert TaskKind.LEFT in kinds or TaskKind.RIGHT in kinds
    # the plan passes beside the obstacle, not through it
    assert max(abs(s.end.y) for s in r.steps) >= 0.2
    end = r.map[r.plan.end].end
    assert end.distance_to(1.0, 0.0) <= r.robot.goal_tolerance


def test_resimulating_the_plan_in_a_fresh_world_gives_the_same_poses():
    r = _plan_scenario("overtaking")
    for s in r.steps:
        out = simulate(s.task, s.start, r.goal, r.obstacles, r.robot)
        assert out.d_n is None
        assert out.end == s.end
        # and the pose is free in a world holding every obstacle
        w = World(r.obstacles, r.robot)
        w.place(out.end)
        assert w.contact() is None


def test_open_is_a_single_straight():
    r = _plan_scenario("open")
    assert r.reached_goal
    assert {s.task for s in r.steps} == {TaskKind.STRAIGHT}


def test_corridor_reaches_the_goal_in_one_clear_run():
    # walls beside the way do not cut the straight into steps: nothing is in its corridor
    r = _plan_scenario("corridor")
    assert r.reached_goal and r.collision_free
    assert [s.task for s in r.steps] == [TaskKind.STRAIGHT]


def test_blocked_gives_the_best_partial_plan():
    r = _plan_scenario("blocked")
    assert not r.reached_goal
    assert r.collision_free
    assert r.stop_reason in ("exhausted", "budget")
    end = r.map[r.plan.end]
    uninterrupted = [s for s in r.map.states() if not s.interrupted]
    assert end.cost == min(s.cost for s in uninterrupted)
    # the partial plan gets closer to the goal than the start
    assert end.end.distance_to(1.0, 0.0) < 1.0


def test_guard_is_one_exactly_on_the_plan():
    r = _plan_scenario("overtaking")
    steps = set(r.plan.steps())
    psi = Guard(r.map, r.plan).table()
    assert sum(psi.values()) == len(steps)
    assert all(v == ((t.source, t.target) in steps) for t, v in psi.items())
    assert r.psi == psi


def test_budget_is_respected_and_stops_with_a_reason():
    r = _plan_scenario("overtaking", max_states=12)
    assert r.n_states <= 12
    assert r.stop_reason == "budget"
    assert r.collision_free


def test_cost_is_a_parameter():
    calls = []

    def cost(state, ctx):
        calls.append(state.ident)
        return default_cost(state, ctx)

    r = _plan_scenario("overtaking", cost=cost)
    assert r.steps and len(calls) == r.n_states


def test_cost_definition():
    r = _plan_scenario("overtaking")
    from clomp.planner.configurator import CostContext

    ctx = CostContext(r.goal, r.map.initial.start, r.robot)
    for s in r.map.states():
        assert s.cost == pytest.approx(gamma(s, ctx) + chi(s, ctx))
        if s.interrupted:
            assert 1.0 <= s.cost < 3.0
        else:
            assert 0.0 <= s.cost < 1.0
    assert chi(r.map.initial, ctx) == pytest.approx(0.5)


def test_same_input_gives_an_identical_map():
    a = _plan_scenario("overtaking")
    b = _plan_scenario("overtaking")
    assert json.dumps(a.map.to_dict()) == json.dumps(b.map.to_dict())


def test_json_round_trip(tmp_path):
    from clomp.formal.lts import CognitiveMap

    r = _plan_scenario("overtaking")
    p = tmp_path / "map.json"
    r.map.write_json(p)
    assert CognitiveMap.read_json(p) == r.map


@pytest.mark.parametrize(
    "goal, message",
    [
        ((0.0, 0.0), "robot's own position"),
        ((float("nan"), 0.0), "finite"),
        ((1e200, 0.0), "beyond 1e\\+06 m"),  # squared distances overflowed: an empty plan came back
        ((0.0, -2e6), "beyond 1e\\+06 m"),
    ],
)
def test_ill_posed_goals(goal, message):
    scene = load_scenario("overtaking")
    with pytest.raises(PlanningError, match=message):
        Configurator().plan(scene.scan(), goal)


def test_a_goal_given_as_a_disturbance_is_bounded_too():
    from clomp.formal import Disturbance

    with pytest.raises(PlanningError, match="beyond"):
        Configurator().plan(load_scenario("overtaking").scan(), Disturbance.goal(1e200, 0.0))


def test_a_goal_inside_a_perceived_obstacle_is_a_situation_not_an_error():
    # the goal on the overtaking box's face: plan towards it, end at the closest reachable
    # state, and say the goal is blocked
    scene = load_scenario("overtaking")
    r = Configurator().plan(scene.scan(), (0.45, 0.0))
    assert r.goal_blocked and not r.reached_goal
    assert r.to_dict()["goal_blocked"] is True and r.to_dict()["reached_goal"] is False
    assert r.collision_free and r.steps
    end = r.map[r.plan.end].end
    assert end.distance_to(0.45, 0.0) < 0.45  # it got closer than where it started
    free = Configurator().plan(scene.scan(), (1.0, 0.0))
    assert not free.goal_blocked and free.to_dict()["goal_blocked"] is False


def test_something_touching_the_robot_does_not_pin_it():
    # returns at the robot's rear-right corner (as in recorded scans 138-230): driving
    # forward moves away from them, turning right would push into them
    r = plan(np.array([[-0.15, -0.09], [-0.15, -0.1], [-0.15, -0.11]]), goal=(1.0, 0.0))
    assert r.reached_goal and r.collision_free
    assert {s.task for s in r.steps} == {TaskKind.STRAIGHT}


def test_every_recorded_scan_plans(scans_dir):
    conf = Configurator()
    files = sorted(scans_dir.glob("*.dat"))
    assert len(files) == 279
    reached = 0
    for f in files:
        r = conf.plan(f, (1.0, 0.0))
        assert r.collision_free
        assert 1 <= r.n_states <= conf.max_states
        reached += r.reached_goal
    empty = [f for f in files if load_scan(f).size == 0]
    assert len(empty) >= 40 and reached >= len(empty)


def test_robot_model_is_configurable_and_validated():
    with pytest.raises(ValueError, match="wheel_base"):
        RobotModel(wheel_base=-1)
    r = plan(np.zeros((0, 2)), goal=(0.0, 1.0), robot=RobotModel(turn_angle=np.pi / 2))
    assert r.reached_goal
    assert [s.task for s in r.steps] == [TaskKind.LEFT, TaskKind.STRAIGHT]


def test_map_equality_and_json_keep_every_transition(tmp_path):
    from clomp.formal.lts import CognitiveMap

    r = _plan_scenario("overtaking")
    p = tmp_path / "m.json"
    r.map.write_json(p)
    back = CognitiveMap.read_json(p)
    assert back.transitions() == r.map.transitions() and back.n_transitions == r.transitions
    # a map that lost one transition is not equal to the original
    d = r.map.to_dict()
    d["transitions"] = d["transitions"][:-1]
    assert CognitiveMap.from_dict(d) != r.map


# -- γ in the search (Algorithm 1: interrupted frontier states enter the queue) -------------------
def _plan_scenario(name, **options):
    from clomp.planner import Configurator, load_scenario

    conf = Configurator(**options)
    scene = load_scenario(name)
    return conf.plan(scene.scan(max_range=conf.robot.sensor_range), tuple(scene.goal_in_robot_frame()))


def test_interrupted_frontier_states_end_the_search_when_they_are_least_phi():
    """A cul-de-sac exhausts its free options; the search ends by popping the least-φ
    state, an interrupted one (no obstacle-free transition), not by an empty queue.
    With the authors' quarter turns: free turns may turn round towards the corridor's
    open end behind the robot and explore it until the budget is spent."""
    from clomp.planner.configurator import CostContext, default_cost

    r = _plan_scenario("cul-de-sac", robot=RobotModel(free_turns=False))
    assert r.stop_reason == "exhausted"
    stop = r.map[r.map.metadata["stopped_at"]]
    assert stop.interrupted
    hits = [s for s in r.map.states() if s.interrupted]
    assert stop.cost == min(s.cost for s in hits)
    ctx = CostContext(r.goal, r.map.initial.start, r.robot)
    assert all(s.cost == default_cost(s, ctx) for s in r.map.states())
    # γ ≥ 1 > χ: every interrupted state is dearer than every uninterrupted one
    assert min(s.cost for s in hits) >= 1 > max(s.cost for s in r.map.states() if not s.interrupted)


@pytest.mark.parametrize("name", ["overtaking", "doorway", "slalom"])
def test_dropping_gamma_ends_the_search_at_a_collision(name):
    """φ = χ alone: a hit close to the goal is cheaper than a free detour, so the search
    stops at it and the goal is never reached (γ made no difference before the change)."""
    from clomp.planner.configurator import chi

    full = _plan_scenario(name)
    # slalom's goal lies beyond the sensor range: an honest plan ends at the frontier
    assert full.reached_goal or full.stop_reason == "frontier"
    r = _plan_scenario(name, cost=chi)
    assert not r.reached_goal and r.map[r.map.metadata["stopped_at"]].interrupted


def test_flipping_the_sign_of_gamma_ends_the_search_at_a_collision():
    from clomp.planner.configurator import chi, gamma

    r = _plan_scenario("overtaking", cost=lambda s, c: chi(s, c) - gamma(s, c))
    assert not r.reached_goal and r.map[r.map.metadata["stopped_at"]].interrupted


def test_the_sense_of_gamma_decides_which_hit_ends_the_search():
    """γ = 2 − d/r: the sooner the hit, the dearer. Reversed (1 + d/r), a different hit
    of the cul-de-sac is the least-φ state that ends the search."""
    from clomp.planner.configurator import chi, gamma

    def reversed_gamma(s, ctx):
        return chi(s, ctx) + (0.0 if s.d_n is None else 3.0 - gamma(s, ctx))

    quarter = RobotModel(free_turns=False)  # the search exhausts (see the test above)
    default = _plan_scenario("cul-de-sac", robot=quarter)
    flipped = _plan_scenario("cul-de-sac", robot=quarter, cost=reversed_gamma)
    a, b = default.map[default.map.metadata["stopped_at"]], flipped.map[flipped.map.metadata["stopped_at"]]
    assert a.ident != b.ident
    d = lambda s: s.start.distance_to(s.d_n.x, s.d_n.y)  # noqa: E731
    assert d(a) > d(b)  # the default stops at the later hit, the reversed γ at the sooner one
