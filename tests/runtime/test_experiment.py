"""The experiment: layouts, the paired t-test, the summary, CSV and plots; the paper's claim (slow)."""

from __future__ import annotations

import csv
import json
import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from scipy.stats import ttest_rel

from planner import load_scenario
from runtime.experiment.runner import SUCCESS_RADIUS, jitter_scene, paired_ttest, run_experiment, run_once


@given(seed=st.integers(0, 10_000))
@settings(max_examples=30, deadline=None)
def test_jitter_moves_and_scales_boxes_within_bounds(seed):
    base = load_scenario("slalom")
    scene = jitter_scene(base, np.random.default_rng(seed))
    for a, b in zip(base.raw["obstacles"], scene.raw["obstacles"]):
        assert a["type"] == b["type"]
        if a["type"] != "box":
            assert a == b
            continue
        assert all(abs(p - q) <= 0.05 + 1e-4 for p, q in zip(a["center"], b["center"]))
        assert all(0.8 - 1e-3 <= q / p <= 1.5 + 1e-3 for p, q in zip(a["size"], b["size"]))
    assert scene.goal == base.goal and scene.start == base.start


def test_jitter_is_reproducible():
    base = load_scenario("overtaking")
    a = jitter_scene(base, np.random.default_rng([0, 3]))
    b = jitter_scene(base, np.random.default_rng([0, 3]))
    assert a.raw == b.raw and a.raw != base.raw


def test_paired_ttest_matches_scipy():
    a, b = [0, 1, 0, 2, 0], [3, 1, 4, 2, 5]
    got = paired_ttest(a, b)
    ref = ttest_rel(a, b)
    assert got["t"] == pytest.approx(ref.statistic) and got["p"] == pytest.approx(ref.pvalue)


@pytest.mark.parametrize("a, b, note", [([0, 0, 0], [0, 0, 0], "no difference"), ([0, 0, 0], [2, 2, 2], "differs by -2")])
def test_paired_ttest_degenerate_is_defined(a, b, note):
    got = paired_ttest(a, b)
    assert got["t"] is None and got["p"] is None and note in got["note"]
    json.dumps(got, allow_nan=False)


def test_run_once_measures_on_ground_truth():
    scene = load_scenario("overtaking")
    r = run_once(scene, "planning", 1)
    assert r.reached_goal and r.final_distance <= SUCCESS_RADIUS and r.collisions == 0
    assert r.states is not None and r.states > 5 and r.planning_time_s is not None and r.planning_time_s > 0
    assert r.planned and r.path[0] == (0.0, 0.0)
    assert r.time_to_goal_s == pytest.approx(r.time_s)
    with pytest.raises(ValueError):
        run_once(scene, "psychic", 1)


def test_small_experiment_summary_csv_and_plots(tmp_path):
    res = run_experiment("overtaking", runs=2, seed=5, jobs=1, max_time=60)
    s = res.summary()
    json.dumps(s, allow_nan=False)
    for name in ("planning", "reactive"):
        c = s["conditions"][name]
        assert c["runs"] == 2 and 0 <= c["reached_goal"] <= 2 and c["collisions"] >= 0
        for key in ("planning_time_s", "states", "time_to_goal_s"):
            assert set(c[key]) == {"mean", "sd"}
    assert s["conditions"]["reactive"]["planning_time_s"] == {"mean": None, "sd": None}
    assert "ttest_collisions" in s
    # the same layouts in both conditions
    lay = {(r.run, json.dumps(r.scene.raw)) for r in res.runs}
    assert len(lay) == 2
    table = res.table()
    assert "runs reaching the goal" in table and "paper" in table and "t-test" in table
    res.write_csv(tmp_path / "runs.csv")
    rows = list(csv.DictReader(open(tmp_path / "runs.csv")))
    assert len(rows) == 4 and {r["condition"] for r in rows} == {"planning", "reactive"}
    pngs = res.write_plots(tmp_path)
    assert len(pngs) == 2 and all(p.stat().st_size > 10_000 for p in pngs)


@pytest.mark.slow
def test_the_papers_claim_holds():
    """10 layouts: planning reaches the goal every time without collision; the reactive loop fails."""
    res = run_experiment("overtaking", runs=10, seed=0, jobs=2)
    c = res.summary()["conditions"]
    assert c["planning"]["reached_goal"] == 10 and c["planning"]["collisions"] == 0
    assert c["reactive"]["reached_goal"] < 10 and c["reactive"]["collisions"] > 0
    assert math.isfinite(c["planning"]["planning_time_s"]["mean"])
