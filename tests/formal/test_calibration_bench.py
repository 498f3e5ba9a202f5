"""``bench/calibration.py``: its calibration table and its refusals (the runs themselves
are measured, not tested: see docs/calibration.md)."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest


@pytest.fixture
def calibration(bench_script: Callable[[str], ModuleType]) -> ModuleType:
    return bench_script("calibration")


def test_the_table_bins_predictions_and_sets_the_wilson_interval_beside_them(calibration: ModuleType) -> None:
    rows = calibration.calibration_rows([0.05, 0.1, 0.5, 0.55, 0.9, 1.0, float("nan")], [1, 1, 0, 1, 1, 1, 0])
    assert [(r["bin"], r["n"], r["successes"]) for r in rows] == [("0.0-0.2", 2, 2), ("0.4-0.6", 2, 1), ("0.8-1.0", 2, 2)]
    low = rows[0]
    assert low["mean_predicted"] == pytest.approx(0.075) and low["wilson"][0] == pytest.approx(0.342, abs=1e-3)
    assert low["inside"] is False and rows[1]["inside"] is True  # 0.075 below [34 %, 100 %]; 0.525 in [9 %, 91 %]


@pytest.mark.parametrize("argv", [["--layouts", "0"], ["--families", "nowhere"], ["--noise", "stormy"]])
def test_bad_options_are_refused_before_any_run(argv: list[str], capsys: pytest.CaptureFixture[str], calibration: ModuleType) -> None:
    with pytest.raises(SystemExit) as exc:
        calibration.main(argv)
    assert exc.value.code == 2 and "error:" in capsys.readouterr().err


def test_greedy_and_robust_runs_written_apart_merge_per_layout(tmp_path: Path, capsys: pytest.CaptureFixture[str], calibration: ModuleType) -> None:
    """The calibration's greedy runs and the paired robust runs come from separate runs
    of the bench (``--conditions``); ``--summary`` pairs them by noise, family and layout."""
    import json

    a, b = tmp_path / "greedy.jsonl", tmp_path / "robust.jsonl"
    key = {"family": "doorway", "run": 3, "noise": "paper"}
    a.write_text(json.dumps({**key, "greedy": {"ok": 1}}) + "\n" + json.dumps({**key, "run": 4, "greedy": {"ok": 0}}) + "\n")
    b.write_text(json.dumps({**key, "robust": {"ok": 0}}) + "\n")
    merged = calibration.read_records([str(a), str(b)])
    assert [(p["run"], sorted(k for k in p if k in ("greedy", "robust"))) for p in merged] == [(3, ["greedy", "robust"]), (4, ["greedy"])]
    assert calibration.main(["--summary", str(tmp_path / "missing.jsonl")]) == 2 and "error:" in capsys.readouterr().err


def test_resume_leaves_out_the_layouts_the_out_file_holds(tmp_path: Path, calibration: ModuleType) -> None:
    """``--resume``: a sweep run in stages continues where ``--out`` stops; a layout
    whose asked condition is missing (a robust run after greedy ones) is still to do."""
    import json

    out = tmp_path / "runs.jsonl"
    out.write_text("".join(json.dumps(r) + "\n" for r in (
        {"noise": "harsh", "family": "u-trap", "run": 0, "greedy": {"ok": 1}},
        {"noise": "harsh", "family": "doorway", "run": 1, "greedy": {"ok": 0}})))
    b = calibration
    base = ["--layouts", "2", "--families", "u-trap", "doorway", "--noise", "harsh", "--out", str(out)]
    assert b._todo(b._parse([*base, "--conditions", "greedy", "--resume"])) == [("doorway", 0, "harsh"), ("u-trap", 1, "harsh")]
    assert len(b._todo(b._parse([*base, "--conditions", "greedy", "robust", "--resume"]))) == 4
    assert len(b._todo(b._parse([*base, "--conditions", "greedy"]))) == 4  # without --resume: everything


def test_resume_needs_an_out_file(capsys: pytest.CaptureFixture[str], calibration: ModuleType) -> None:
    with pytest.raises(SystemExit) as exc:
        calibration.main(["--resume"])
    assert exc.value.code == 2 and "--out" in capsys.readouterr().err
