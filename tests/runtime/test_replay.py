"""``clomp replay`` over folders and run logs, and the run log itself."""

from __future__ import annotations

import io
import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.records.runlog import LogError, RunLog, read_log, scans_from_log


def clomp(*args: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("clomp")
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli"]
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=300)


def test_runlog_round_trip_and_truncated_tail(tmp_path):
    p = tmp_path / "run.jsonl"
    with RunLog(p) as log:
        log.write("start", goal=[1.0, 0.0])
        log.write("scan", points=np.array([[0.5, 0.1], [0.6, 0.1]]), goal=(1.0, 0.0), pose=[0, 0, 0])
        log.write("motor", left=0.1, right=float("nan"))
    with open(p, "a") as fh:
        fh.write('{"t": 3.0, "event": "sc')  # a run cut short mid-line
    recs = list(read_log(p))
    assert [r["event"] for r in recs] == ["start", "scan", "motor"]
    assert recs[2]["right"] is None  # NaN is not valid JSON: written as null
    (label, pts, goal), = list(scans_from_log(p))
    assert pts.tolist() == [[0.5, 0.1], [0.6, 0.1]] and goal == (1.0, 0.0)


def test_runlog_to_a_file_object_and_bad_lines(tmp_path):
    buf = io.StringIO()
    RunLog(buf).write("fault", reason="lidar silent")
    assert json.loads(buf.getvalue())["reason"] == "lidar silent"
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"event": "scan"}\nnot json\n{"event": "stop"}\n')
    with pytest.raises(LogError, match=":2:"):
        list(read_log(bad))


def test_replay_folder_json_summary(tmp_path, scans_dir):
    folder = tmp_path / "scans"
    folder.mkdir()
    names = ["map0001.dat", "map0140.dat", "map0240.dat"]
    for n in names:
        (folder / n).write_bytes((scans_dir / n).read_bytes())
    p = clomp("replay", str(folder), "--json")
    assert p.returncode == 0, p.stderr
    lines = [json.loads(x) for x in p.stdout.splitlines()]
    assert [x["scan"] for x in lines[:-1]] == names
    for x in lines[:-1]:
        assert {"scan", "reached_goal", "states", "planning_time_s"} <= set(x)
    s = lines[-1]["summary"]
    assert s["scans"] == 3 and s["plans"] >= 2
    assert 0 < s["median_planning_time_s"] <= s["p90_planning_time_s"]


def test_replay_a_run_log(tmp_path):
    p = tmp_path / "run.jsonl"
    with RunLog(p) as log:
        log.write("scan", points=[], goal=[1.0, 0.0])
        log.write("motor", left=0.1, right=0.1)
        log.write("scan", points=[[0.45, y] for y in np.linspace(-0.1, 0.1, 11)], goal=[0.8, 0.0])
    r = clomp("replay", str(p), "--json")
    assert r.returncode == 0, r.stderr
    lines = [json.loads(x) for x in r.stdout.splitlines()]
    assert len(lines) == 3
    assert lines[0]["plan"] == ["STRAIGHT"] and lines[0]["reached_goal"]
    # the goal stands in the wall's shadow: a plan round it to the frontier, never a claim of the goal
    assert not lines[1]["reached_goal"] and len(lines[1]["plan"]) > 1
    assert lines[2]["summary"]["scans"] == 2


def test_replay_bad_sources(tmp_path):
    p = clomp("replay", str(tmp_path / "nothing"))
    assert p.returncode == 2 and "no such file" in p.stderr and "Traceback" not in p.stderr
    empty = tmp_path / "empty"
    empty.mkdir()
    p = clomp("replay", str(empty))
    assert p.returncode == 2 and "no scan files" in p.stderr
    bad = tmp_path / "bad.dat"
    bad.write_text("garbage")
    p = clomp("replay", str(bad))
    assert p.returncode == 2 and "Traceback" not in p.stderr


def test_replay_all_recorded_scans(scans_dir):
    p = clomp("replay", str(scans_dir), "--json")
    assert p.returncode == 0
    summary = json.loads(p.stdout.splitlines()[-1])["summary"]
    assert summary["scans"] == 279 and summary["errors"] == 0


def test_replay_reports_a_bad_scan_and_goes_on(tmp_path):
    folder = tmp_path / "mixed"
    folder.mkdir()
    (folder / "map0001.dat").write_text("0.5 0.1\n")
    (folder / "map0002.dat").write_text("0.5 oops\n")
    p = clomp("replay", str(folder), "--json")
    assert p.returncode == 0 and "Traceback" not in p.stderr  # every scan processed
    lines = [json.loads(x) for x in p.stdout.splitlines()]
    assert "error" in lines[1] and "map0002.dat:1" in lines[1]["error"]
    assert lines[-1]["summary"]["errors"] == 1 and lines[-1]["summary"]["plans"] == 1
