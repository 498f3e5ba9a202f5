"""The experiment: one run on ground truth, pure run specs, streaming/resume, Dask, summary, CSV, plots."""

from __future__ import annotations

import csv
import json
import math

import pytest
from scipy.stats import binomtest, ttest_rel

from clomp.planner import load_scenario
from clomp.runtime.experiment import driver, runner
from clomp.runtime.experiment.results import (
    CSV_COLUMNS,
    markdown_rows,
    summarise,
    table,
    write_csv,
)
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.experiment.runner import (
    SUCCESS_RADIUS,
    ExperimentInterrupted,
    RunSpec,
    experiment_specs,
    load_records,
    run_experiment,
    run_once,
    run_spec,
)
from clomp.runtime.experiment.stats import mcnemar, mean_ci, paired_ttest, wilson


def test_wilson_interval_known_values():
    assert wilson(0, 10) == (0.0, pytest.approx(0.2775, abs=1e-4))
    lo, hi = wilson(5, 10)
    assert (lo, hi) == (pytest.approx(0.2366, abs=1e-4), pytest.approx(0.7634, abs=1e-4))
    assert wilson(0, 0) == (0.0, 1.0)
    with pytest.raises(ValueError):
        wilson(3, 2)


def test_mean_ci_and_paired_ttest_match_scipy():
    m = mean_ci([1.0, 2.0, 3.0, 4.0])
    assert m["mean"] == 2.5 and m["lo"] == pytest.approx(2.5 - 3.182446 * 1.290994 / 2, abs=1e-5)
    a, b = [0, 1, 0, 2, 0], [3, 1, 4, 2, 5]
    got, ref = paired_ttest(a, b), ttest_rel(a, b)
    assert got["t"] == pytest.approx(ref.statistic) and got["p"] == pytest.approx(ref.pvalue)
    assert paired_ttest([0, 0], [0, 0])["t"] is None


def test_mcnemar_counts_discordant_pairs_only():
    a = [1, 1, 1, 1, 1, 1, 0, 1, 1, 0]
    b = [0, 0, 0, 0, 0, 1, 0, 1, 0, 1]
    r = mcnemar(a, b)
    assert (r["b10"], r["b01"]) == (6, 1)
    assert r["p"] == pytest.approx(binomtest(6, 7, 0.5).pvalue)
    assert mcnemar([1, 0], [1, 0])["p"] == 1.0


def test_a_sweep_cell_pairs_each_run_with_its_own_seed():
    """A sweep's cell spans seeds, whose run indices repeat: seed 0's run 0 pairs with seed 0's
    run 0 only. Planning succeeds wherever the baseline fails, so every pair is discordant."""
    def rec(seed, run, condition, ok):
        return {"family": "doorway", "noise": "paper", "seed": seed, "run": run, "condition": condition,
                "success": ok, "reached_goal": ok, "believed_goal": ok, "collisions": 0, "brushes": 0,
                "final_error_m": 0.0, "time_s": 1.0, "wall_s": 0.0}
    recs = [rec(seed, run, c, int((c == "planning") == (seed == 0)))
            for seed in (0, 1) for run in range(3) for c in ("planning", "reactive")]
    m = summarise(recs)["mcnemar_success"]
    assert (m["n"], m["b10"], m["b01"]) == (6, 3, 3)


def test_run_once_measures_on_ground_truth():
    scene = load_scenario("overtaking")
    r = run_once(scene, "planning", 1, noise="paper")
    assert r.reached_goal and r.final_distance <= SUCCESS_RADIUS and r.collisions == 0
    assert r.n_states is not None and r.n_states > 5 and r.planning_time_s is not None and r.planning_time_s > 0
    assert r.planned and r.path[0] == (0.0, 0.0) and r.cpu_s > 0
    with pytest.raises(ValueError):
        run_once(scene, "psychic", 1)


def test_belief_and_ground_truth_are_reported_apart():
    """A robot whose dead reckoning is wrong believes it arrived; the truth says where it is."""
    from clomp.runtime.backends.sim import NoiseConfig

    scene = load_scenario("open")
    skewed = NoiseConfig(range_sd=0.0, dropout=0.0, wheel_sd=0.0, wheel_bias=0.25, drift=0.0)
    r = run_once(scene, "reactive", 3, noise=skewed)
    assert r.believed_goal and not r.reached_goal and r.final_distance > SUCCESS_RADIUS
    assert "truly" in r.reason


def test_run_once_passes_options_to_the_reactive_baseline():
    scene = make_layout("overtaking", 0, 4).scene  # the box lies across the straight line to the goal
    blind = run_once(scene, "reactive", 0, noise="ideal", max_time=30, reactive={"detect": False})
    seeing = run_once(scene, "reactive", 0, noise="ideal", max_time=30)
    assert blind.collisions >= 1 and not blind.reached_goal
    assert seeing.collisions == 0


def test_cul_de_sac_success_is_saying_unreachable():
    rec = run_spec(RunSpec("cul-de-sac", 0, 2, "planning", "ideal", max_time=60))
    assert rec["expect"] == "unreachable" and rec["end_state"] == "UNREACHABLE"
    assert rec["success"] == 1 and rec["reached_goal"] == 0
    rec = run_spec(RunSpec("cul-de-sac", 0, 2, "reactive", "ideal", max_time=20))
    assert rec["success"] == 0


def test_overtaking_run_1_gets_past_the_box_at_paper_noise():
    """Layout 0/1 (passages 0.33 and 0.36 m beside the box): a 2 degree turn overshoot once
    left the robot between box and wall with no free task (UNREACHABLE at every noise level);
    the planning origin's small turn freed it. From the gyro (192a34c) until the plan check
    asked the fused revolutions (7b03dba) a plan ended in the 0.33 m passage, too close to
    the wall to turn; the body can pass there only in a band 1.7 cm wide, so this run stays
    a sensitive one. Without turns of under 1° (issue #39) it stood again with no free task,
    0.32 m from the goal, until a plan that finds none is searched again with REVERSE
    (``SupervisorConfig.back_off``): the robot backs off and goes round."""
    rec = run_spec(RunSpec("overtaking", 0, 1, "planning", "paper"))
    assert (rec["success"], rec["end_state"], rec["collisions"]) == (1, "GOAL_REACHED", 0), rec["reason"]


def test_a_cul_de_sac_recalled_in_a_loop_ends_unreachable_in_time():
    """Layout 0/5: the same recalled continuation, driven five times over 90 s without getting
    closer, ran into the time limit (HALTED); a repeated recall that brought no progress is
    refused and the robot explores anew, until no safe task leads closer (UNREACHABLE at 110 s)."""
    rec = run_spec(RunSpec("cul-de-sac", 0, 5, "planning", "paper"))
    assert (rec["success"], rec["end_state"], rec["collisions"]) == (1, "UNREACHABLE", 0), rec["reason"]


def test_a_run_is_a_pure_function_of_its_spec():
    spec = RunSpec("slalom", 4, 2, "reactive", "paper", 1.0, 30.0)
    a, b = run_spec(spec), run_spec(spec)
    for k in ("wall_s", "cpu_s", "planning_time_s"):
        a.pop(k), b.pop(k)
    assert a == b
    # both conditions of a run meet the same layout
    c = run_spec(RunSpec("slalom", 4, 2, "planning", "paper", 1.0, 30.0))
    assert c["obstacles"] == a["obstacles"] and c["layout"] == a["layout"]


def test_specs_are_validated():
    with pytest.raises(ValueError, match="noise preset"):
        experiment_specs("overtaking", 2, noise="loud")
    with pytest.raises(ValueError, match="runs"):
        experiment_specs("overtaking", 0)
    from clomp.planner.scenarios import ScenarioError

    with pytest.raises(ScenarioError):
        experiment_specs("no-such-family-or-file", 1)


def _small(**kw):
    return run_experiment("overtaking", runs=2, seed=5, noise="paper", max_time=40, **kw)


def test_records_stream_to_the_folder_and_resume_skips_them(tmp_path):
    seen = []
    recs = _small(out=tmp_path, on_record=lambda r: seen.append(r["key"]))
    assert len(recs) == 4 and len(seen) == 4
    assert [r["key"] for r in load_records(tmp_path / "runs.jsonl")] == seen
    # a crash mid-line leaves half a record: skipped on resume
    with open(tmp_path / "runs.jsonl", "a") as fh:
        fh.write('{"key": "overtaking/5/')
    again = []
    recs2 = _small(out=tmp_path, resume=True, on_record=lambda r: again.append(r))
    assert again == [] and [r["key"] for r in recs2] == [r["key"] for r in recs]
    # more runs: only the new ones run
    more = run_experiment("overtaking", runs=3, seed=5, noise="paper", max_time=40, out=tmp_path,
                          resume=True, on_record=lambda r: again.append(r))
    assert len(more) == 6 and sorted(r["run"] for r in again) == [2, 2]
    # a narrower resume runs nothing new and deletes none of the wider one's finished runs
    fewer = run_experiment("overtaking", runs=1, seed=5, noise="paper", max_time=40, out=tmp_path, resume=True,
                           on_record=lambda r: again.append(r))
    assert len(fewer) == 2 and len(again) == 2
    assert sorted(r["key"] for r in load_records(tmp_path / "runs.jsonl")) == sorted(r["key"] for r in more)


def test_an_experiment_written_to_a_folder_keeps_only_the_plotted_traces_in_memory(tmp_path):
    """Flat memory at scale (issue #43): from run PLOTTED_RUNS on, a record is whole on disk
    and summary-only in memory; the runs the plots draw keep their traces; resuming alike."""
    from clomp.runtime.experiment.runrecords import PLOTTED_RUNS, TRACE_FIELDS

    n = PLOTTED_RUNS + 2
    whole = []
    recs = run_experiment("open", runs=n, noise="ideal", conditions=("reactive",), out=tmp_path,
                          on_record=whole.append)
    on_disk = load_records(tmp_path / "runs.jsonl")
    assert all(set(TRACE_FIELDS) <= r.keys() for r in on_disk + whole)
    for again in (recs, run_experiment("open", runs=n, noise="ideal", conditions=("reactive",), out=tmp_path,
                                       resume=True)):
        assert [r["run"] < PLOTTED_RUNS for r in again] == [bool(set(TRACE_FIELDS) & r.keys()) for r in again]
        assert [{k: v for k, v in r.items() if k not in TRACE_FIELDS} for r in on_disk] == [
            {k: v for k, v in r.items() if k not in TRACE_FIELDS} for r in again]
    assert set(TRACE_FIELDS) <= run_experiment("open", runs=n, noise="ideal", conditions=("reactive",))[-1].keys()


def test_ctrl_c_keeps_what_finished(tmp_path, monkeypatch):
    real = runner.run_spec
    calls = []

    def interrupted_at_third(spec):
        calls.append(spec)
        if len(calls) == 3:
            raise KeyboardInterrupt
        return real(spec)

    monkeypatch.setattr(driver, "run_spec", interrupted_at_third)
    with pytest.raises(ExperimentInterrupted) as exc:
        _small(out=tmp_path)
    assert len(exc.value.records) == 2 and exc.value.total == 4
    assert len(load_records(tmp_path / "runs.jsonl")) == 2
    monkeypatch.setattr(driver, "run_spec", real)
    assert len(_small(out=tmp_path, resume=True)) == 4


def _strip(recs):
    return [{k: v for k, v in r.items() if k not in ("wall_s", "cpu_s", "planning_time_s")} for r in recs]


def test_dask_workers_give_the_same_records_as_this_process():
    local = _small(workers=0)
    on_dask = _small(workers=2)
    assert _strip(on_dask) == _strip(local)


def test_summary_csv_table_and_plots(tmp_path):
    from clomp.runtime.experiment.report import write_plots

    recs = _small()
    s = summarise(recs)
    json.dumps(s, allow_nan=False)
    for name in ("planning", "reactive"):
        c = s["conditions"][name]
        assert c["runs"] == 2 and 0 <= c["reached_goal"] <= 2 and c["collisions"] >= 0 and c["brushes"] >= 0
        lo, hi = c["success_ci95"]
        assert 0 <= lo <= c["success_rate"] <= hi <= 1
        assert c["final_error_median_m"] is not None
    assert "ttest_collisions" in s and "mcnemar_success" in s
    text = table(s, runner.PAPER)
    assert "success (95 % Wilson)" in text and "McNemar" in text and "paper" in text
    assert markdown_rows(s).count("|") == 10
    write_csv(recs, tmp_path / "runs.csv")
    rows = list(csv.DictReader(open(tmp_path / "runs.csv")))
    assert len(rows) == 4 and list(rows[0]) == list(CSV_COLUMNS)
    assert {r["condition"] for r in rows} == {"planning", "reactive"}
    pngs = write_plots(recs, tmp_path)
    assert {p.name for p in pngs} == {"trajectories_planning.png", "trajectories_reactive.png", "collisions.png"}
    assert all(p.stat().st_size > 10_000 for p in pngs)


def test_parquet_holds_the_csvs_rows_typed_with_units(tmp_path):
    """Read back by pyarrow (a real Parquet reader): the CSV's rows and columns, in order, with
    numbers as numbers, empty cells as nulls, and each column's unit and meaning in its field."""
    pq = pytest.importorskip("pyarrow.parquet")
    from clomp.runtime.experiment.results import COLUMN_TYPES, write_parquet

    recs = _small()
    recs[0] = {**recs[0], "time_to_goal_s": None, "reason": "a, \"quoted\" reason"}
    write_csv(recs, tmp_path / "runs.csv")
    t = pq.read_table(write_parquet(recs, tmp_path / "runs.parquet"))
    assert t.column_names == list(CSV_COLUMNS)
    rows = list(csv.DictReader(open(tmp_path / "runs.csv", newline="")))
    got = t.to_pylist()
    assert len(got) == len(rows) == 4
    for want, row in zip(rows, got):
        for k in CSV_COLUMNS:
            v = row[k]
            if want[k] == "":
                assert v is None, k
            elif COLUMN_TYPES[k] == "str":
                assert v == want[k], k
            else:
                assert isinstance(v, int if COLUMN_TYPES[k] == "int" else float) and v == float(want[k]), k
    assert got[0]["time_to_goal_s"] is None and got[0]["reason"] == 'a, "quoted" reason'
    for k, (unit, meaning) in CSV_COLUMNS.items():
        md = t.schema.field(k).metadata
        assert md[b"unit"].decode() == unit and md[b"meaning"].decode() == meaning
    assert str(t.schema.field("collisions").type) == "int64" and str(t.schema.field("final_error_m").type) == "double"


def test_noise_sweep_summary_and_plot(tmp_path):
    from clomp.runtime.experiment.report import write_plots

    recs = run_experiment("overtaking", runs=1, seed=0, noise="paper", noise_scales=(0.0, 2.0), max_time=40)
    s = summarise(recs)
    assert [b["noise_scale"] for b in s["by_noise_scale"]] == [0.0, 2.0]
    assert s["conditions"]["planning"]["runs"] == 2
    assert "success_vs_noise.png" in {p.name for p in write_plots(recs, tmp_path)}


def test_cli_json_keeps_the_table_shape(tmp_path, capsys):
    from clomp.runtime.cli import main

    rc = main(["experiment", "overtaking", "--runs", "2", "--seed", "5", "--workers", "0", "--max-time", "40",
               "--out", str(tmp_path), "--json", "--no-plots"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    for name in ("planning", "reactive"):
        assert {"runs", "reached_goal", "collisions", "brushes", "final_error_median_m"} <= set(s["conditions"][name])
    assert (tmp_path / "runs.csv").exists() and (tmp_path / "runs_schema.md").exists()
    assert s["files"]["parquet"] == str(tmp_path / "runs.parquet")
    assert main(["experiment", "--runs", "0", "--out", str(tmp_path)]) == 2
    assert main(["experiment", "--noise-sweep", "1,x", "--out", str(tmp_path)]) == 2
    assert main(["experiment", "maze", "--out", str(tmp_path)]) == 2


@pytest.mark.slow
def test_the_papers_claim_holds():
    """Issue #9's acceptance: planning 10/10 with <= 3 collisions + brushes; reactive <= 2/10, 4-20 collisions."""
    recs = run_experiment("overtaking", runs=10, seed=0, noise="paper", workers=2)
    c = summarise(recs)["conditions"]
    assert c["planning"]["reached_goal"] == 10 and c["planning"]["collisions"] + c["planning"]["brushes"] <= 3
    assert c["reactive"]["reached_goal"] <= 2 and 4 <= c["reactive"]["collisions"] <= 20
    assert math.isfinite(c["planning"]["planning_time_s"]["mean"])


@pytest.mark.slow
def test_a_killed_worker_loses_no_run(tmp_path):
    """SIGKILL one of two worker processes mid-experiment: every run is still there, once, unchanged."""
    import logging
    import os
    import signal

    from distributed import Client, LocalCluster

    cluster = LocalCluster(n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None,
                           silence_logs=logging.ERROR)
    client = Client(cluster)
    killed = []

    def kill_one(_rec):
        if not killed:
            pid = sorted(client.run(os.getpid).values())[0]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)

    try:
        recs = run_experiment("overtaking", runs=6, seed=2, noise="paper", max_time=40, scheduler=cluster.scheduler_address,
                              out=tmp_path, on_record=kill_one)
    finally:
        client.close()
        cluster.close()
    assert killed
    keys = [r["key"] for r in load_records(tmp_path / "runs.jsonl")]
    assert len(keys) == len(set(keys)) == 12 and len(recs) == 12
    assert _strip(recs) == _strip(run_experiment("overtaking", runs=6, seed=2, noise="paper", max_time=40))


def test_a_run_that_raises_does_not_cost_the_others(tmp_path, monkeypatch):
    from clomp.runtime.experiment.runner import RunsFailed

    real = runner.run_spec

    def broken_second_layout(spec):
        if spec.run == 1 and spec.condition == "reactive":
            raise ZeroDivisionError("a bug")
        return real(spec)

    monkeypatch.setattr(driver, "run_spec", broken_second_layout)
    with pytest.raises(RunsFailed, match="1 run.*failed.*overtaking/5/1/reactive.*ZeroDivisionError: a bug") as exc:
        _small(out=tmp_path)
    assert len(exc.value.records) == 3 and len(load_records(tmp_path / "runs.jsonl")) == 3
    assert json.loads((tmp_path / "errors.jsonl").read_text())["error"] == "ZeroDivisionError: a bug"
    monkeypatch.setattr(driver, "run_spec", real)
    assert len(_small(out=tmp_path, resume=True)) == 4 and not (tmp_path / "errors.jsonl").exists()


def test_both_conditions_take_the_same_estimate():
    # --feedback applies to the reactive baseline too: the same robot with the same sensing
    from clomp.formal.geometry import compose
    from clomp.formal.model import Pose
    from clomp.runtime.experiment.layouts import make_layout
    from clomp.runtime.backends.world import WorldNoise

    scene = make_layout("corridor", 0, 0).scene
    errors = {}
    for fb in ("scan", "none"):
        r = run_once(scene, "reactive", 0, noise=WorldNoise(wheel_bias=0.05, wheel_sd=0.01), feedback=fb, keep_report=True,
                     max_time=13)  # straight steps and quarter turns along the corridor
        _, x, y, th = r.report.trajectory[-1]
        est = compose(scene.start, Pose(x, y, th))
        errors[fb] = math.hypot(est.x - r.final_pose[0], est.y - r.final_pose[1])
    assert errors["scan"] < 0.02 < 0.1 < errors["none"]


def test_a_run_that_raises_in_a_dask_batch_does_not_cost_its_batch():
    from clomp.runtime.experiment.driver import _run_batch

    specs = [RunSpec("open", 0, k, "reactive", "ideal") for k in range(3)]

    def second_breaks(spec):
        if spec.run == 1:
            raise ZeroDivisionError("a bug")
        return {"key": spec.key}

    got = _run_batch(second_breaks, specs)
    assert [(k, r is not None, e) for k, r, e in got] == [
        (specs[0].key, True, None), (specs[1].key, False, "ZeroDivisionError: a bug"), (specs[2].key, True, None)]
