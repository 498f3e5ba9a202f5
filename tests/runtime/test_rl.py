"""The ``rl`` condition end to end: a policy trained in the Gymnasium environment drives experiment runs."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from clomp.planner import load_scenario
from clomp.runtime.cli import main
from clomp.runtime.experiment.onerun import run_once
from clomp.runtime.experiment.policy import DEFAULT_POLICY, LinearPolicy, PolicyError, load_policy, policy_id
from clomp.runtime.experiment.runspec import RunSpec

pytest.importorskip("gymnasium")


def test_a_policy_trained_in_the_environment_drives_an_experiment(tmp_path: Path) -> None:
    from clomp.runtime.gym.train import TRAIN_RUN_BASE, train_linear

    policy, curve = train_linear(("overtaking",), iterations=2, population=4, elite=2, episodes=1, max_steps=20,
                                 noise="ideal", init=LinearPolicy.goal_seeker())
    assert [p["iteration"] for p in curve] == [1, 2] and curve[-1]["steps"] > curve[0]["steps"]
    assert policy.trained["layout_runs_from"] == TRAIN_RUN_BASE  # disjoint from the scored runs 0..N-1
    assert not np.allclose(policy.weights, LinearPolicy.goal_seeker().weights)  # the search moved from where it began
    assert curve[-1]["elite_return"] >= curve[-1]["mean_return"]  # the elite is the best of what was tried
    path = policy.save(tmp_path / "p.json")
    out = tmp_path / "out"
    code = main(["experiment", "overtaking", "--runs", "2", "--condition", "rl", "--policy", str(path),
                 "--workers", "0", "--noise", "ideal", "--out", str(out), "--no-plots", "--json"])
    assert code == 0
    rows = list(csv.DictReader((out / "runs.csv").open()))
    assert [r["condition"] for r in rows] == ["rl", "rl"]
    keys = [json.loads(line)["key"] for line in (out / "runs.jsonl").read_text().splitlines()]
    assert all(k.endswith(f"/policy={policy_id(path)}") for k in keys)
    summary = json.loads((out / "summary.json").read_text())
    assert summary["conditions"]["rl"]["runs"] == 2


def test_the_condition_acts_on_what_the_policy_says() -> None:
    scene = load_scenario("open")
    w = np.zeros((3, 9))
    w[1, 8] = 1.0  # always left: turns on the spot, never arrives
    spin = run_once(scene, "rl", 0, noise="ideal", max_time=20, reactive={"policy": LinearPolicy(w)})
    seek = run_once(scene, "rl", 0, noise="ideal", max_time=60, reactive={"policy": LinearPolicy.goal_seeker()})
    assert (spin.end_state, spin.reached_goal) == ("TIMEOUT", False)
    assert (seek.end_state, seek.reached_goal) == ("GOAL_REACHED", True)
    assert spin.final_distance == pytest.approx(1.0, abs=0.05)  # it never left the start


def test_the_shipped_policy_loads_and_every_bad_file_is_refused(tmp_path: Path) -> None:
    assert load_policy(None).act(np.r_[np.full(64, 1.1), [1.0, 0.0]]) in (0, 1, 2)
    assert policy_id(DEFAULT_POLICY) == "default" and RunSpec("open", 0, 0, "rl").key.endswith("/policy=default")
    bad = tmp_path / "bad.json"
    for text, words in (("{", "not JSON"), ('{"format": "x"}', "not a clomp-policy/1"),
                        ('{"format": "clomp-policy/1", "kind": "linear", "weights": [[1, 2]]}', "weights must be 3")):
        bad.write_text(text)
        with pytest.raises(PolicyError, match=words):
            load_policy(bad)


def test_a_bad_policy_file_is_a_usage_error_not_a_traceback(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    bad = tmp_path / "bad.json"
    bad.write_text("[]")
    code = main(["experiment", "overtaking", "--runs", "1", "--condition", "rl", "--policy", str(bad), "--workers", "0",
                 "--out", str(tmp_path / "o"), "--no-plots"])
    assert code == 2
    assert "--policy" in capsys.readouterr().err


def test_training_layouts_are_never_scored_ones_and_repeat_by_seed() -> None:
    """What a library's training loop (stable-baselines3's auto-reset) sees: the next training
    layout at every reset, from run 1,000,000 on, the same episodes for the same seed."""
    from clomp.runtime.gym.env import ClompEnv
    from clomp.runtime.gym.train import TRAIN_RUN_BASE, TrainingLayouts

    a, b = (TrainingLayouts(ClompEnv("doorway", noise="paper"), seed=4) for _ in range(2))
    firsts = [a.reset()[0] for _ in range(3)]
    assert a.layouts == [(4, TRAIN_RUN_BASE), (4, TRAIN_RUN_BASE + 1), (4, TRAIN_RUN_BASE + 2)]
    assert all(np.array_equal(x, b.reset()[0]) for x in firsts)
    assert a.unwrapped.scene is not None and a.unwrapped.scene.name == f"doorway-4-{TRAIN_RUN_BASE + 2}"
