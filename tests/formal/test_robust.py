"""Risk-aware plans: Storm's scheduler for Pmax [!collision U goal] against the greedy plan."""

from __future__ import annotations

import pytest

from clomp.formal.invariants import map_plan

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")

from clomp.formal.scheduler import follow_tasks, plan_probability, robust_plan  # noqa: E402


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
    from clomp.formal.lts import MapError
    from clomp.formal.supervisory import Plan

    with pytest.raises(MapError, match="q0 ↪ q6"):
        plan_probability(risky_map, Plan((0, 6)))


@pytest.mark.parametrize("name", ["doorway", "overtaking", "slalom"])
def test_robust_is_never_below_greedy_on_sampled_maps(name):
    from clomp.planner import load_scenario
    from clomp.planner.probabilistic import RolloutNoise, sample_map

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
    from clomp.formal import check_map
    from clomp.planner import load_scenario
    from clomp.planner.robust import RobustConfigurator

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
    from clomp.formal import CognitiveMap
    from clomp.formal.model import TaskKind

    m = CognitiveMap.from_dict(risky_map.to_dict())
    m2 = CognitiveMap.from_parts([s for s in m.states() if s.ident != 1], [t for t in m.transitions() if t.target != 1 and t.source != 0] , goal=m.goal)
    m2.add_transition(0, 2, TaskKind.STRAIGHT)
    m2.add_transition(0, 3, TaskKind.LEFT)
    carried = follow_tasks(m2, [TaskKind.STRAIGHT])
    assert carried.states == (0, 2)
    assert plan_probability(m2, carried) == 0.0 <= robust_plan(m2).probability == pytest.approx(1.0)


def _two_outcome_map(risky_map):
    """risky_map with the detour's LEFT ending in two outcomes: q3 (3 in 5) and q7 (2 in
    5, turned short); from q7 a STRAIGHT still reaches the goal (q8), while the map's
    least-cost descendant of q7 is a RIGHT that gets nowhere (q9)."""
    from fractions import Fraction

    from clomp.formal import CognitiveMap
    from clomp.formal.model import Pose, State, TaskKind

    m = CognitiveMap.from_dict(risky_map.to_dict())
    g = m.goal
    m2 = CognitiveMap.from_parts(
        [*m.states(),
         State(7, TaskKind.LEFT, g, None, Pose(0, 0), Pose(0, 0, 1.2), cost=0.5),
         State(8, TaskKind.STRAIGHT, g, None, Pose(0, 0, 1.2), Pose(1, 0.03, 0), distance=1.0, cost=0.3, reached_goal=True),
         State(9, TaskKind.RIGHT, g, None, Pose(0, 0, 1.2), Pose(0, 0, 0.2), cost=0.2)],
        [], goal=g)
    for t in m.transitions():
        if (t.source, t.target) != (0, 3):
            m2.add_transition(t.source, t.target, t.label, t.probability)
    m2.add_transition(0, 3, TaskKind.LEFT, Fraction(3, 5))
    m2.add_transition(0, 7, TaskKind.LEFT, Fraction(2, 5))
    m2.add_transition(7, 8, TaskKind.STRAIGHT)
    m2.add_transition(7, 9, TaskKind.RIGHT)
    return m2


def test_the_printed_path_has_its_own_probability_beside_the_policys_value(risky_map):
    """The scheduler's value counts every outcome; its most likely path is one of them."""
    from clomp.formal.scheduler import path_probability, policy_states

    m = _two_outcome_map(risky_map)
    r = robust_plan(m)
    assert r.probability == pytest.approx(1.0, abs=1e-12)
    assert r.plan.states == (0, 3, 4, 5, 6)
    assert r.path_probability == pytest.approx(0.6, abs=1e-12) == path_probability(m, r.plan)
    assert r.scheduler[7].value == "STRAIGHT"
    assert policy_states(m, r.scheduler) == [0, 3, 4, 5, 6, 7, 8]
    # the greedy plan's own path: STRAIGHT to q1 (4 in 5)
    assert path_probability(m, map_plan(m)) == pytest.approx(0.8)


def test_a_recall_on_a_robust_map_follows_the_scheduler_where_the_robot_landed(risky_map):
    """The runtime executes the scheduler as a policy: from the outcome the robot is found
    in (q7), the recall continues with the scheduler's task, not the map's least-cost path."""
    from types import SimpleNamespace

    from clomp.formal.scheduler import attach_policy, map_policy
    from clomp.runtime.supervision.plancheck import _best_from

    m = _two_outcome_map(risky_map)
    assert _best_from(SimpleNamespace(map=m), 7) == [7, 9]  # least-φ descendant: a dead end
    r = robust_plan(m)
    attach_policy(m, r.scheduler)
    assert map_policy(type(m).from_dict(m.to_dict())) == r.scheduler  # kept through JSON
    assert _best_from(SimpleNamespace(map=m), 7) == [7, 8]
    assert _best_from(SimpleNamespace(map=m), 8) is None  # at the goal: nothing to continue
    # a continuation that ends no closer than where the robot is (q5: φ 0.55 ≥ q3's 0.5) is
    # no recall, as with the least-cost path: it would loop recalls that make no progress
    from clomp.formal.model import TaskKind

    attach_policy(m, {3: TaskKind.STRAIGHT, 4: TaskKind.RIGHT})
    assert _best_from(SimpleNamespace(map=m), 3) is None


def test_a_detour_is_taken_only_where_it_is_safer_by_more_than_the_margin(risky_map):
    """Storm's choice among near-equal options is arbitrary and k/N is an estimate: with
    the best-first plan preferred, the scheduler leaves it only for a gain above margin,
    and the probability reported is the value of the policy returned."""
    from clomp.formal.model import TaskKind
    from clomp.formal.scheduler import policy_probability

    prefer = {0: TaskKind.STRAIGHT}
    kept = robust_plan(risky_map, prefer=prefer, margin=0.25)  # the detour gains 0.2 < 0.25
    assert kept.plan.states == (0, 1) and kept.probability == pytest.approx(0.8)
    assert policy_probability(risky_map, kept.scheduler) == pytest.approx(0.8)
    left = robust_plan(risky_map, prefer=prefer, margin=0.1)
    assert left.plan.states == (0, 3, 4, 5, 6) and left.probability == pytest.approx(1.0)
    with pytest.raises(Exception, match="margin"):
        robust_plan(risky_map, margin=2.0)


def test_a_target_replaces_the_goal_label_and_the_policy_stops_there(risky_map):
    """A target that is not the goal (e.g. a frontier the plan makes progress to): Storm
    checks !collision U "target", and the policy starts nothing once it has arrived."""
    r = robust_plan(risky_map, target={4})
    assert r.probability == pytest.approx(1.0)
    assert r.plan.states == (0, 3, 4) and 4 not in r.scheduler
    assert plan_probability(risky_map, map_plan(risky_map), target={4}) == 0.0


@pytest.mark.parametrize("goal", [(0.8, -0.3), (0.8, 0.3)])
def test_a_search_for_more_routes_extends_algorithm_1s_map_with_alternatives(goal):
    """routes=1 is Algorithm 1 (the first goal state ends the search); more routes go on
    from the same queue, so the best-first map is a prefix of the larger one and the
    larger one holds more ends (goal states or frontiers) for Storm to choose among."""
    from clomp.planner import Configurator, load_scenario

    # round the overtaking box to goals the scan sees (the scenario's own, and the
    # doorway's, stand in a shadow: no plan claims them)
    scan = load_scenario("overtaking").scan(max_range=1.1)
    one = Configurator().plan(scan, goal)
    three = Configurator(max_states=100, routes=3).plan(scan, goal)
    assert set(one.map.transitions()) <= set(three.map.transitions())
    assert all(three.map[s.ident].end == s.end for s in one.map.states())

    def ends(r):
        return sum(1 for s in r.map.states() if s.reached_goal and not s.interrupted)

    assert ends(one) == 1 and ends(three) >= 2
    with pytest.raises(ValueError, match="routes"):
        Configurator(routes=0)


@pytest.mark.parametrize("name", ["open", "corridor"])
def test_where_the_scheduler_keeps_the_best_first_tasks_the_plan_is_the_best_first_plan(name):
    """Not the path of most likely outcomes (at harsh noise on these scenes another outcome
    group is the likelier one): the supervisor then drives the nominal states' predicted
    ends, exactly as with the plain Configurator."""
    from clomp.planner import Configurator, load_scenario
    from clomp.planner.robust import RobustConfigurator

    from clomp.planner.probabilistic import RolloutNoise

    scene = load_scenario(name)
    scan, goal = scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame())
    harsh = RolloutNoise.preset("harsh")  # the preset's own wheels (the closed loop's terms are milder)
    c = RobustConfigurator(samples=10, noise=harsh).sample(scan, goal)
    assert all(c.robust.scheduler.get(a) is c.pm.map[b].task for a, b in c.greedy.steps())
    assert c.robust.plan.states != c.greedy.states  # the most likely outcomes' path differs
    r = RobustConfigurator(samples=10, noise=harsh).plan(scan, goal)
    plain = Configurator().plan(scan, goal)
    assert r.plan.states == plain.plan.states
    assert [r.map[q].end for q in r.plan.states] == [plain.map[q].end for q in plain.plan.states]


def _stubbed_choice(risky_map):
    """A RobustChoice on ``risky_map``: the best-first plan is the risky STRAIGHT (q0 → q1,
    value 0.8), the scheduler's the sure detour (value 1.0)."""
    import numpy as np

    from clomp.formal.supervisory import Plan
    from clomp.planner import Configurator
    from clomp.planner.configurator import PlanResult
    from clomp.planner.perception import perceive
    from clomp.planner.probabilistic import ProbabilisticMap, RolloutNoise
    from clomp.planner.robust import RobustChoice

    robot = Configurator().robot
    greedy = PlanResult(risky_map, Plan((0, 1)), risky_map.goal, perceive(np.zeros((0, 2)), robot.sensor_range),
                        robot, 0.0, "test")
    pm = ProbabilisticMap(risky_map, greedy, 5, RolloutNoise(), 0.0, 0.0, 0)
    return RobustChoice(pm, greedy, greedy.plan, {1, 6}, robust_plan(risky_map, {1, 6}), 0.8)


@pytest.mark.parametrize(("values", "confirm", "decision"), [
    ((0.85, 0.8), True, "rejected"),   # safer on the second look by less than the margin
    ((0.8, 0.9), True, "rejected"),    # less safe on the second look
    ((0.95, 0.8), True, "confirmed"),  # safer by more than the margin: the detour is taken
    (None, False, "deviated"),         # no second look: the scheduler's plan as it is
])
def test_a_deviation_from_the_best_first_plan_is_taken_only_when_fresh_rollouts_confirm_it(risky_map, values, confirm, decision):
    """The scheduler's maximum over k/N estimates is biased upwards: its detour replaces the
    best-first plan only where an independent map also finds it safer by more than the
    margin; otherwise the plan is the plain Configurator's result, unchanged."""
    import numpy as np

    from clomp.planner.robust import RobustConfigurator

    seeds: list[int] = []

    class Stubbed(RobustConfigurator):
        def sample(self, scan, goal):
            self._calls += 1
            self.last_probabilities = (1.0, 0.8)
            self.predictions.append(self.last_probabilities)
            return _stubbed_choice(risky_map)

        def confirm_deviation(self, points, goal, c, seed):
            seeds.append(seed)
            return values

    conf = Stubbed(samples=5, margin=0.1, confirm=confirm, seed=7)
    r = conf.plan(np.zeros((0, 2)), (1.0, 0.0))
    assert conf.decisions == [decision]
    if decision == "rejected":
        assert r.plan.states == (0, 1) and r.map is risky_map and "scheduler" not in r.map.metadata
        assert conf.last_probabilities == conf.predictions[-1] == (0.8, 0.8)
        assert conf.confirmations == [values]
    else:
        assert r.plan.states == (0, 3, 4, 5, 6) and r.map.metadata["scheduler"]["0"] == "LEFT"
        assert conf.last_probabilities == (1.0, 0.8)
    if confirm:  # the second look's worlds are not the plan's own
        assert seeds and seeds[0] != 7


def test_the_second_look_values_plans_on_rollouts_of_its_own():
    """confirm_deviation samples a new map (other worlds: other outcome counts) and values
    both plans there the same way: carried by their tasks, the optimum elsewhere, so the
    best-first plan measured against itself is a tie."""
    from dataclasses import replace

    from clomp.planner import load_scenario
    from clomp.planner.robust import RobustConfigurator

    scene = load_scenario("corridor")
    scan, goal = scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame())
    conf = RobustConfigurator(samples=10, noise="harsh")
    c = conf.sample(scan, goal)
    same = replace(c, robust=replace(c.robust, plan=c.greedy))
    v_r, v_g = conf.confirm_deviation(scan, goal, same, seed=12345)
    assert v_r == pytest.approx(v_g) and 0 <= v_g <= 1
    values = {conf.confirm_deviation(scan, goal, same, seed=s)[1] for s in range(4)}
    assert len(values) > 1  # fresh rollouts: the estimate moves with the seed


def test_the_robust_configurator_backs_off_where_the_best_first_one_does():
    """The supervisor's back-off plans a jam again with ``recovery`` set on a copy of its
    configurator (plan_deepening(back_off=True)); the robust configurator's own searches
    dropped it, so a robust run stood (or said UNREACHABLE) where a best-first one backed
    off (found by the calibration bench, docs/calibration.md)."""
    import numpy as np

    from clomp.formal.model import TaskKind
    from clomp.planner.deepening import plan_deepening
    from clomp.planner.robust import RobustConfigurator

    box = np.array([[0.1, y] for y in np.linspace(-0.3, 0.3, 61)] + [[x, s * 0.3] for x in np.linspace(-0.05, 0.1, 16) for s in (-1, 1)])
    conf = RobustConfigurator(samples=2, noise="ideal")
    assert plan_deepening(conf, box, (1.0, 0.0)).steps == []
    steps = plan_deepening(conf, box, (1.0, 0.0), back_off=True).steps
    assert steps and steps[0].task is TaskKind.REVERSE


def test_an_exploring_plans_target_is_the_frontier_not_the_inside_of_a_u():
    """The best-first plan ends at a frontier (the goal lies beyond what the scan shows);
    a state inside a U lies nearer the goal but is no frontier. Only frontier outcomes are
    the target: before, the inside of the U was a target as good as the frontier, Storm
    found it surer, and robust runs drove into the trap (u-trap, harsh: robust 27/39 vs
    greedy 32/39). A noisy outcome of the frontier's own choice counts as the frontier."""
    from clomp.formal.lts import CognitiveMap
    from clomp.formal.model import Disturbance, Pose, State, TaskKind
    from clomp.formal.supervisory import FRONTIER
    from clomp.planner.robust import frontier_outcomes, plan_target

    g = Disturbance.goal(1.2, 0.0)
    o = Pose(0, 0)
    rim = ((FRONTIER, 1.0),)
    cmap = CognitiveMap.from_parts([
        State(0, TaskKind.STRAIGHT, g, None, o, o),
        State(1, TaskKind.RIGHT, g, None, o, Pose(0, 0, -0.8)),
        State(2, TaskKind.STRAIGHT, g, None, Pose(0, 0, -0.8), Pose(0.5, -0.5, -0.8), extra=rim),  # round the arm
        State(3, TaskKind.STRAIGHT, g, None, o, Pose(0.6, 0.0)),  # into the U: 0.6 m from the goal
        State(4, TaskKind.STRAIGHT, g, None, Pose(0, 0, -0.8), Pose(0.52, -0.52, -0.8)),  # the frontier's task, off its state
    ], [(0, 1), (1, 2), (0, 3), (1, 4)], goal=g)
    end = cmap[2].end
    assert end.distance_to(g.x, g.y) > cmap[3].end.distance_to(g.x, g.y)
    assert frontier_outcomes(cmap) == {2, 4}
    assert plan_target(cmap, end, g) == {2, 4}
    assert plan_target(cmap, end, g, frontier=False) == {2, 3, 4}  # the rule before: the U's inside too
