"""The probabilistic cognitive map: sampled noisy rollouts and learning from observation."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from clomp.formal import CognitiveMap, check_map
from clomp.formal.model import TaskKind
from clomp.planner import Configurator, load_scenario
from clomp.planner.probabilistic import NoiseError, RolloutNoise, learn_from_scans, preset_names, sample_map


def _scene(name):
    conf = Configurator()
    scene = load_scenario(name)
    return scene.scan(max_range=conf.robot.sensor_range), tuple(scene.goal_in_robot_frame())


def _choices(cmap):
    out = {}
    for t in cmap.transitions():
        out.setdefault((t.source, t.label), []).append(t)
    return out


@pytest.mark.parametrize("name", ["doorway", "overtaking"])
def test_probabilities_are_exactly_k_over_n_and_every_invariant_holds(name):
    scan, goal = _scene(name)
    r = sample_map(scan, goal, samples=12, seed=3)
    assert check_map(r.map) == []
    for ts in _choices(r.map).values():
        assert sum(t.probability for t in ts) == 1
        assert all((t.probability * 12).denominator == 1 for t in ts)
    # the nominal map's choices are all sampled, nothing else leaves a nominal state
    assert set(_choices(r.nominal.map)) == {k for k in _choices(r.map) if k[0] in r.nominal.map}
    assert r.map.metadata["samples"] == 12 and r.map.metadata["noise"] == RolloutNoise().to_dict()


def test_without_noise_every_rollout_is_the_nominal_outcome():
    scan, goal = _scene("overtaking")
    r = sample_map(scan, goal, samples=5, noise="ideal")
    assert r.new_states == 0 and r.probabilistic_choices == 0
    assert r.map.transitions() == r.nominal.map.transitions()


def test_noise_makes_some_outcomes_uncertain_and_the_seed_reproduces_them():
    scan, goal = _scene("doorway")
    a = sample_map(scan, goal, samples=30, seed=0)
    assert a.probabilistic_choices > 0
    assert any(0 < t.probability < 1 for t in a.map.transitions())
    b = sample_map(scan, goal, samples=30, seed=0)
    assert a.map == b.map
    harsh = RolloutNoise(range_sd=0.02, dropout=0.1, wheel_sd=0.08, wheel_bias=0.03, drift=0.02)
    h = sample_map(scan, goal, samples=30, seed=0, noise=harsh)
    assert h.probabilistic_choices > a.probabilistic_choices


def test_under_harsh_noise_some_tasks_collide_with_a_probability_below_one():
    """Overtaking passes the obstacle closely: with a harsh noise some worlds hit it."""
    scan, goal = _scene("overtaking")
    harsh = RolloutNoise(range_sd=0.02, dropout=0.1, wheel_sd=0.08, wheel_bias=0.03, drift=0.02)
    r = sample_map(scan, goal, samples=30, seed=0, noise=harsh)
    hits = [t for t in r.map.transitions() if r.map[t.target].interrupted and t.probability < 1]
    assert hits


def test_noise_presets_come_from_the_file_when_it_exists(tmp_path):
    path = tmp_path / "presets.json"
    path.write_text(json.dumps({"harsh": {"range_sd": 0.02, "wheel_sd": 0.1, "other_field": 3}, "paper": {}}))
    n = RolloutNoise.preset("harsh", path)
    assert (n.range_sd, n.wheel_sd, n.dropout) == (0.02, 0.1, RolloutNoise().dropout)
    with pytest.raises(NoiseError, match="unknown noise preset 'nope'.*harsh, paper"):
        RolloutNoise.preset("nope", path)
    path.write_text(json.dumps({"bad": {"wheel_sd": -1}}))
    with pytest.raises(NoiseError, match="wheel_sd"):
        RolloutNoise.preset("bad", path)
    assert {"paper", "ideal"} <= set(preset_names()) or "paper" in preset_names()


def test_the_paper_preset_is_the_simulated_robots_default_noise():
    from clomp.runtime.backends.sim import NoiseConfig

    paper = RolloutNoise.preset("paper")
    assert paper == RolloutNoise()  # the defaults are the file's paper preset
    five = ("range_sd", "dropout", "wheel_sd", "wheel_bias", "drift")
    assert {k: getattr(paper, k) for k in five} == {k: getattr(NoiseConfig(), k) for k in five}
    harsh = RolloutNoise.preset("harsh")
    assert harsh.wheel_sd == 5 * paper.wheel_sd and harsh.slip == 5 * paper.slip


@pytest.mark.parametrize("bad", [0, -3, 2.5, True, 10**6])  # a million ran for hours (and terabytes)
def test_bad_sample_counts_are_refused(bad):
    with pytest.raises(NoiseError, match="samples"):
        sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=bad)


# -- learning from repeated observation --------------------------------------------------------------------
def test_identical_observations_learn_the_deterministic_map():
    # round the box to a goal the scan sees: the scenario's own stands in the box's shadow,
    # and its search runs on to 50 states, which learn_from_scans's matching (task sequence
    # and end pose within tolerance) does not all tell apart
    scan, goal = _scene("overtaking")[0], (0.8, -0.3)
    learned = learn_from_scans([scan] * 3, goal)
    nominal = Configurator().plan(scan, goal).map
    assert learned.transitions() == nominal.transitions()
    assert learned.metadata["observations"] == 3


def test_consecutive_recorded_scans_update_the_counts_they_observe_again(scans_dir):
    files = sorted(scans_dir.glob("*.dat"))[:12]
    learned = learn_from_scans(files, (1.0, 0.0))
    assert check_map(learned) == []
    choices = _choices(learned)
    first = _choices(Configurator().plan(files[0], (1.0, 0.0)).map)
    # q0's STRAIGHT is observed in every scan: its counts add up to 12
    (q0_straight,) = [ts for (s, k), ts in choices.items() if s == 0 and k is TaskKind.STRAIGHT]
    assert all((t.probability * 12).denominator == 1 for t in q0_straight)
    assert set(first) <= set(choices)
    assert any(0 < t.probability < 1 for t in learned.transitions())
    for ts in choices.values():
        assert sum(t.probability for t in ts) == 1 and len({t.probability.denominator for t in ts}) >= 1
        total = max(Fraction(t.probability).denominator for t in ts)
        assert total <= 12 and not math.isnan(float(total))


# -- sampled as the closed loop runs: the supervisor's hazard test and end tolerance --------------------
def _corridor_wall(y: float) -> np.ndarray:
    """A wall beside the way ahead, ``y`` m to the left of the robot's centre line."""
    xs = np.arange(0.05, 0.9, 0.01)
    return np.c_[xs, np.full(len(xs), y)]


def _straight_collision_chance(scan, hazard, seed=0):
    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE

    pm = sample_map(scan, (0.8, 0.0), samples=20, noise="harsh", seed=seed, tolerance=SUPERVISOR_TOLERANCE, hazard=hazard)
    ts = [t for t in pm.map.out_transitions(0) if t.label is TaskKind.STRAIGHT]
    return sum(t.probability for t in ts if pm.map[t.target].interrupted)


def test_the_hazard_rule_interrupts_rollouts_that_pass_close_to_a_wall_under_range_noise():
    """The supervisor stops a task when 2 returns of a revolution fall inside the body on
    its way; at harsh noise (2.5 cm range noise, the wheels drifting sideways) a wall 6 cm
    from the body does that often, one 31 cm away never. Contacts alone (no hazard
    rule) never interrupt this straight."""
    from clomp.planner.probabilistic import HazardRule

    close, far = _corridor_wall(0.09 + 0.06), _corridor_wall(0.09 + 0.31)
    assert _straight_collision_chance(close, None) == 0
    assert _straight_collision_chance(close, HazardRule()) >= Fraction(1, 4)
    assert _straight_collision_chance(far, HazardRule()) == 0
    with pytest.raises(NoiseError, match="hazard points"):
        HazardRule(points=0)


def test_the_supervisors_noise_allowance_spares_a_grazed_wall_not_a_wall_in_the_way():
    """With the supervisor's allowance (3 cm at harsh) a wall the body grazes under
    range noise stops fewer rollouts than with any 2 points inside the body, and a
    stop there is a hazard stop, named in the map's stops; at paper noise the allowance
    is 3 x 5 mm less the 1 cm clearance."""
    from clomp.formal.retry import map_stops
    from clomp.planner.probabilistic import HazardRule, RolloutNoise

    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE
    from dataclasses import replace

    # harsh range noise with small wheel errors (the closed loop's sideways drift, no length
    # or turn bias): the body grazes the wall, it does not drive into it
    noise = replace(RolloutNoise.preset("harsh"), wheel_bias=0.005, drift=0.002, turn_sd=0.066)
    rule = HazardRule.supervisor(noise)
    assert rule.allowance == pytest.approx(0.03)  # 3 x 2.5 cm less 1 cm, at most 3 cm
    close = _corridor_wall(0.09 + 0.04)

    def stopped(scan, hazard):
        pm = sample_map(scan, (0.8, 0.0), samples=20, noise=noise, seed=0, tolerance=SUPERVISOR_TOLERANCE, hazard=hazard)
        return sum(t.probability for t in pm.map.out_transitions(0) if pm.map[t.target].interrupted), pm

    (strict, pm), (lenient, _) = stopped(close, HazardRule()), stopped(close, rule)
    assert lenient < strict - Fraction(1, 10) and strict >= Fraction(1, 2)
    paper = HazardRule.supervisor(RolloutNoise.preset("paper"))  # 5 mm range noise
    assert paper.allowance == pytest.approx(0.005)
    stops = map_stops(pm.map.metadata)
    assert stops and all(pm.map[q].interrupted and src == 0 for q, src in stops.items())
    with pytest.raises(NoiseError, match="allowance"):
        HazardRule(allowance=float("nan"))


def test_outcomes_within_the_supervisors_end_tolerance_are_one_state():
    """The supervisor continues a plan whose task ended within 0.08 m / 0.3 rad of the
    prediction: grouped so, a choice has fewer, larger outcome groups than at 3 cm."""
    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE

    scan, goal = _scene("doorway")
    fine = sample_map(scan, goal, samples=20, noise="harsh", seed=2)
    coarse = sample_map(scan, goal, samples=20, noise="harsh", seed=2, tolerance=SUPERVISOR_TOLERANCE)
    assert len(coarse.map) < len(fine.map)
    nominal_q0 = [t for t in coarse.map.out_transitions(0) if t.label is TaskKind.STRAIGHT]
    fine_q0 = [t for t in fine.map.out_transitions(0) if t.label is TaskKind.STRAIGHT]
    assert max(t.probability for t in nominal_q0) >= max(t.probability for t in fine_q0)


def test_a_plans_target_is_the_goal_or_else_the_progress_of_the_best_first_plan():
    from clomp.planner.robust import plan_target

    scan, goal = _scene("doorway")
    pm = sample_map(scan, goal, samples=10, noise="paper", seed=0)
    n = pm.nominal
    near = plan_target(pm.map, n.map[n.plan.end].end, n.goal)
    assert near and all(pm.map[q].end.distance_to(*goal) <= 0.1 and not pm.map[q].interrupted for q in near)
    far_goal = (3.0, 0.0)  # beyond the sensed disc: no state reaches it
    pm = sample_map(np.zeros((0, 2)), far_goal, samples=4, noise="paper", seed=0)
    n = pm.nominal
    frontier = plan_target(pm.map, n.map[n.plan.end].end, n.goal)
    d = n.map[n.plan.end].end.distance_to(*far_goal)
    assert n.plan.end in frontier
    assert all(pm.map[q].end.distance_to(*far_goal) <= d + 0.03 and not pm.map[q].interrupted for q in frontier)


def test_a_best_first_plans_own_end_is_its_target_when_the_search_expanded_it():
    """A search that spent its budget ends its plan at argmin φ, which it may have
    expanded: that end is progress the plan surely makes (before, only leaves were
    targets, and the plan's P was 0; calibration bench, paper doorway 1)."""
    from clomp.formal.model import Disturbance, Pose, State
    from clomp.planner.robust import plan_target

    g = Disturbance.goal(3.0, 0.0)
    o = Pose(0, 0)
    cmap = CognitiveMap.from_parts([
        State(0, TaskKind.STRAIGHT, g, None, o, o),
        State(1, TaskKind.STRAIGHT, g, None, o, Pose(1.0, 0)),          # the plan's end, expanded
        State(2, TaskKind.LEFT, g, None, Pose(1.0, 0), Pose(1.0, 0, 0.5)),  # a turn in place there
        State(3, TaskKind.STRAIGHT, g, None, Pose(1.0, 0), Pose(0.6, 0.5)),  # a leaf that falls back
    ], [(0, 1), (1, 2), (1, 3)], goal=g)
    assert plan_target(cmap, Pose(1.0, 0), g) == {1, 2}


@pytest.mark.parametrize("name", ["overtaking", "doorway"])
def test_carried_poses_make_a_turns_error_reach_the_straight_after_it(name):
    """Every turn turns 20 % too far and nothing else is noisy. Each turn still falls into
    its nominal state (within the supervisor's 0.3 rad), so without ``carry`` the straight
    after it is rolled out from the turn's recorded end and always lands where planned;
    with ``carry`` it starts where the turn truly ended, heading off, and misses."""
    from dataclasses import replace

    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE

    scene = load_scenario(name)
    scan, goal = scene.scan(max_range=1.1), tuple(scene.goal_in_robot_frame())
    noise = replace(RolloutNoise.preset("ideal"), turn_mean=0.2)

    def after_turns(carry: bool) -> list[Fraction]:
        pm = sample_map(scan, goal, samples=6, noise=noise, seed=0, tolerance=SUPERVISOR_TOLERANCE, carry=carry)
        nominal = pm.nominal.map
        return [sum((u.probability for u in pm.map.out_transitions(t.source) if u.label is t.label and u.target == t.target),
                    Fraction(0))
                for t in nominal.transitions()
                if t.label is TaskKind.STRAIGHT and nominal[t.source].task.is_turn and t.source in pm.map]

    reset, carried = after_turns(False), after_turns(True)
    assert reset and all(p == 1 for p in reset)
    assert any(p < 1 for p in carried)
    assert sample_map(scan, goal, samples=2, noise=noise, carry=True).map.metadata["carry"] is True


def test_a_carried_task_gets_the_supervisors_limit_from_where_the_robot_stands():
    """A turn turns to the planned heading, a straight drives the planned length."""
    from clomp.formal.model import Disturbance, Pose, State
    from clomp.planner.probabilistic import _aimed_limit

    g = Disturbance.goal(1.0, 0.0)
    left = State(1, TaskKind.LEFT, g, None, Pose(0, 0, 0), Pose(0, 0, 1.0))
    assert _aimed_limit(TaskKind.LEFT, Pose(0.02, 0.0, 0.1), left) == pytest.approx(0.9)
    right = State(2, TaskKind.RIGHT, g, None, Pose(0, 0, 0), Pose(0, 0, -1.0))
    assert _aimed_limit(TaskKind.RIGHT, Pose(0.0, 0.0, -0.2), right) == pytest.approx(0.8)
    ahead = State(3, TaskKind.STRAIGHT, g, None, Pose(0, 0, 0), Pose(0.4, 0, 0), distance=0.4)
    assert _aimed_limit(TaskKind.STRAIGHT, Pose(0.0, 0.05, 0.1), ahead) == pytest.approx(0.4)
    hit = State(4, TaskKind.STRAIGHT, g, Disturbance.goal(0.3, 0.0), Pose(0, 0, 0), Pose(0.2, 0, 0), distance=0.2)
    assert _aimed_limit(TaskKind.STRAIGHT, Pose(0, 0, 0), hit) is None  # a contact is no length to drive


def test_the_closed_loops_mean_errors_bias_turns_and_straights():
    """``turn_mean`` and ``straight_mean``: a turn / a straight truly does that much more
    than it was told (the world's closed loop, bench/rollout_calibration.py); the
    presets leave them at 0, and a mean beyond ±0.5 is refused."""
    from dataclasses import replace

    from clomp.formal.model import Disturbance, Pose
    from clomp.planner.perception import perceive
    from clomp.planner.rollout import simulate
    from clomp.planner.probabilistic import _rollout, _World
    from clomp.planner.robot_model import RobotModel

    robot = RobotModel()
    empty = perceive(np.zeros((0, 2)), robot.sensor_range, robot.cluster_distance)
    goal, start = Disturbance.goal(3.0, 0.0), Pose(0.0, 0.0, 0.0)
    ideal = RolloutNoise.preset("ideal")
    biased = replace(ideal, turn_mean=0.1, straight_mean=-0.2)
    world = _World(empty, 0.0, 0.0, 0.0, np.random.default_rng(0))
    turn, straight = simulate(TaskKind.LEFT, start, goal, empty, robot), simulate(TaskKind.STRAIGHT, start, goal, empty, robot)
    assert _rollout(TaskKind.LEFT, start, goal, world, robot, biased).end.theta == pytest.approx(1.1 * turn.end.theta, rel=0.03)
    assert _rollout(TaskKind.STRAIGHT, start, goal, world, robot, biased).end.x == pytest.approx(0.8 * straight.end.x, rel=0.03)
    assert _rollout(TaskKind.LEFT, start, goal, world, robot, ideal).end.theta == pytest.approx(turn.end.theta, rel=0.03)
    assert RolloutNoise.preset("harsh").turn_mean == 0 == RolloutNoise.preset("harsh").straight_mean
    for bad in ({"turn_mean": 0.6}, {"straight_mean": -0.5}, {"straight_sd": -0.1}, {"turn_mean": math.nan}):
        with pytest.raises(NoiseError, match="noise"):
            replace(ideal, **bad)


# -- the closed loop: a contact the plan check sees coming is a stop (clomp.planner.hazard) -----------------
def _straight_outcomes(scan, hazard):
    """(contacts, stops, map) of q0's STRAIGHT toward a goal 0.8 m ahead, 20 harsh rollouts."""
    from clomp.formal.retry import map_stops
    from clomp.planner.probabilistic import SUPERVISOR_TOLERANCE

    pm = sample_map(scan, (0.8, 0.0), samples=20, noise="harsh", seed=0, tolerance=SUPERVISOR_TOLERANCE, hazard=hazard)
    stops = map_stops(pm.map.metadata)
    ts = [t for t in pm.map.out_transitions(0) if t.label is TaskKind.STRAIGHT]
    contact = sum((t.probability for t in ts if pm.map[t.target].interrupted and t.target not in stops), Fraction(0))
    stop = sum((t.probability for t in ts if t.target in stops), Fraction(0))
    return contact, stop, pm


def test_closed_loop_contacts_the_check_sees_coming_are_stops_not_collisions():
    """A wall that closes in on the way ahead (11 cm beside the centre line at its far
    end, 20 at its near one): at harsh noise some rollouts of the straight drift into it
    far along (0.6-0.7 m). Open loop (the default rule) each is a contact, a collision;
    with ``contacts=True`` the plan check sees the wall on the rest of the task before
    the body reaches it, so each is a stop (a replan, not a collision) and no contact
    is left; the free outcomes are the same rollouts either way."""
    from clomp.planner.probabilistic import HazardRule

    xs = np.arange(0.05, 0.9, 0.01)
    wall = np.c_[xs, 0.2 - 0.09 * (xs - 0.05) / 0.85]
    contact_open, stop_open, pm_open = _straight_outcomes(wall, HazardRule())
    assert contact_open >= Fraction(1, 10)
    assert all(pm_open.map[t.target].distance > 0.5 for t in pm_open.map.out_transitions(0)
               if t.label is TaskKind.STRAIGHT and pm_open.map[t.target].interrupted and pm_open.map[t.target].distance > 0)
    contact, stop, pm = _straight_outcomes(wall, HazardRule(contacts=True))
    assert contact == 0 and stop == stop_open + contact_open
    free = sorted((str(t.probability), round(pm.map[t.target].distance, 6)) for t in pm.map.out_transitions(0)
                  if t.label is TaskKind.STRAIGHT and not pm.map[t.target].interrupted)
    assert free == sorted((str(t.probability), round(pm_open.map[t.target].distance, 6)) for t in pm_open.map.out_transitions(0)
                          if t.label is TaskKind.STRAIGHT and not pm_open.map[t.target].interrupted)
    with pytest.raises(NoiseError, match="hazard contacts"):
        HazardRule(contacts="yes")  # type: ignore[arg-type]


def test_closed_loop_maps_name_their_outcomes_off_the_maps_prediction_and_the_default_map_is_unchanged():
    """With ``contacts=True`` the map names its new free leaves (a task ended beyond the
    supervisor's tolerance of every state: the plan check replans there) with the state
    the task aimed at; the default rule's map has no such key and the same transitions
    as before this rule existed (the contacts' test draws nothing from its worlds)."""
    from clomp.formal.retry import OFFS_KEY, map_offs
    from clomp.planner.probabilistic import HazardRule, SUPERVISOR_TOLERANCE

    scan, goal = _scene("overtaking")
    closed = sample_map(scan, goal, samples=10, noise="harsh", seed=1, tolerance=SUPERVISOR_TOLERANCE,
                        hazard=HazardRule(contacts=True), carry=True)
    offs = map_offs(closed.map.metadata)
    assert offs
    for leaf, aim in offs.items():
        s = closed.map[leaf]
        assert not s.interrupted and not closed.map.out_transitions(leaf) and not closed.map[aim].interrupted
        assert any(t.target == leaf and closed.map[aim].task is s.task for t in closed.map.transitions())
    plain = sample_map(scan, goal, samples=10, noise="harsh", seed=1, tolerance=SUPERVISOR_TOLERANCE,
                       hazard=HazardRule(), carry=True)
    assert OFFS_KEY not in plain.map.metadata
