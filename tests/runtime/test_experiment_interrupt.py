"""Ctrl-C on the Dask path, as a user meets it: ``clomp experiment --workers 2`` in its own
process group, SIGINT to the group (as a terminal sends it) once the first run has streamed to runs.jsonl; the finished runs are kept
(exit 130), and ``--resume`` runs only the rest."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

pytest.importorskip("distributed")

sys.path.insert(0, str(Path(__file__).parent))
from interrupting import interrupt_after_first_record, records  # noqa: E402

RUNS = 5  # layouts, each in both conditions: far more work than the moment between the first record and SIGINT


def _command(out: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "clomp.runtime.cli", "experiment", "overtaking", "--runs", str(RUNS), "--seed", "3",
            "--noise", "paper", "--max-time", "60", "--workers", "2", "--out", str(out), "--no-plots", *extra]


def test_ctrl_c_on_dask_keeps_the_finished_runs_and_resume_completes(tmp_path):
    out = tmp_path / "exp"
    jsonl = out / "runs.jsonl"
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(_command(out), stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            start_new_session=True)
    stdout, stderr = interrupt_after_first_record(proc, jsonl)  # the whole process group, workers too
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "--resume" in stderr and "Traceback" not in stderr
    kept = records(jsonl)
    keys = [r["key"] for r in kept]
    assert 1 <= len(kept) < 2 * RUNS and len(set(keys)) == len(keys)
    assert (out / "runs.csv").exists()  # what finished is also written out as the CSV

    rc = subprocess.run(_command(out, "--resume", "--json"), capture_output=True, text=True, env=env, timeout=900)
    assert rc.returncode == 0, rc.stderr
    final = records(jsonl)
    assert len(final) == 2 * RUNS and len({r["key"] for r in final}) == 2 * RUNS
    assert final[:len(kept)] == kept  # the runs kept were not run again
    summary = json.loads(rc.stdout)
    assert summary["conditions"]["planning"]["runs"] == RUNS and summary["conditions"]["reactive"]["runs"] == RUNS
