"""``--resume`` keeps only runs this code made: a folder filled by other code is refused."""

from __future__ import annotations

import json

import pytest

from clomp.runtime.experiment import driver
from clomp.runtime.experiment.provenance import PROVENANCE_FILE, ResumeMismatch, code_version
from clomp.runtime.experiment.runner import run_experiment


@pytest.fixture
def fake_runs(monkeypatch):
    """Runs that cost nothing (the folder logic is under test, not the world): their keys."""
    ran: list[str] = []

    def fake(spec):
        ran.append(spec.key)
        return {"key": spec.key, "run": spec.run, "condition": spec.condition}

    monkeypatch.setattr(driver, "run_spec", fake)
    return ran


def _go(out, resume=False):
    return run_experiment("overtaking", runs=2, seed=3, out=out, resume=resume)


def test_the_folder_names_the_code_and_resume_with_the_same_code_keeps_the_runs(tmp_path, fake_runs):
    _go(tmp_path)
    assert json.loads((tmp_path / PROVENANCE_FILE).read_text())["code"] == code_version()
    assert len(fake_runs) == 4
    assert len(_go(tmp_path, resume=True)) == 4 and len(fake_runs) == 4  # nothing ran again


def test_resume_refuses_runs_another_code_made(tmp_path, fake_runs):
    _go(tmp_path)
    (tmp_path / PROVENANCE_FILE).write_text(json.dumps({"code": "clomp 0.0.1 0123456789abcdef"}))
    with pytest.raises(ResumeMismatch, match="made by clomp 0.0.1 0123456789abcdef, this is clomp"):
        _go(tmp_path, resume=True)
    assert len(fake_runs) == 4  # refused before running anything
    _go(tmp_path)  # without --resume the folder starts afresh, for this code
    assert json.loads((tmp_path / PROVENANCE_FILE).read_text())["code"] == code_version()


def test_a_corrupt_provenance_file_is_refused_and_a_missing_one_keeps_the_runs(tmp_path, fake_runs):
    _go(tmp_path)
    (tmp_path / PROVENANCE_FILE).write_text("{not json")
    with pytest.raises(ResumeMismatch, match="unrecorded code"):
        _go(tmp_path, resume=True)
    (tmp_path / PROVENANCE_FILE).unlink()  # a folder from before provenance was recorded
    assert len(_go(tmp_path, resume=True)) == 4 and len(fake_runs) == 4
    assert (tmp_path / PROVENANCE_FILE).exists()


def test_the_cli_says_so_in_one_line(tmp_path, fake_runs, capsys):
    from clomp.runtime.cli import main

    args = ["experiment", "overtaking", "--runs", "2", "--seed", "3", "--workers", "0", "--out", str(tmp_path),
            "--no-plots", "--json"]
    (tmp_path / "runs.jsonl").write_text("")
    (tmp_path / PROVENANCE_FILE).write_text(json.dumps({"code": "clomp 0.0.1 0123456789abcdef"}))
    assert main([*args, "--resume"]) == 2
    err = capsys.readouterr().err
    assert "--resume" in err and "would mix" in err and "Traceback" not in err
    assert len([line for line in err.splitlines() if line.strip()]) == 1
