"""The probabilistic cognitive map: sampled noisy rollouts and learning from observation."""

from __future__ import annotations

import json
import math
from fractions import Fraction

import numpy as np
import pytest

from formal import check_map
from formal.model import TaskKind
from planner import Configurator, load_scenario
from planner.probabilistic import NoiseError, RolloutNoise, learn_from_scans, preset_names, sample_map


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
    from runtime.robots.sim import NoiseConfig

    paper = RolloutNoise.preset("paper")
    assert paper == RolloutNoise()  # the defaults are the file's paper preset
    five = ("range_sd", "dropout", "wheel_sd", "wheel_bias", "drift")
    assert {k: getattr(paper, k) for k in five} == {k: getattr(NoiseConfig(), k) for k in five}
    harsh = RolloutNoise.preset("harsh")
    assert harsh.wheel_sd == 5 * paper.wheel_sd and harsh.slip == 5 * paper.slip


@pytest.mark.parametrize("bad", [0, -3, 2.5, True])
def test_bad_sample_counts_are_refused(bad):
    with pytest.raises(NoiseError, match="samples"):
        sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=bad)


# -- learning from repeated observation --------------------------------------------------------------------
def test_identical_observations_learn_the_deterministic_map():
    scan, goal = _scene("overtaking")
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
