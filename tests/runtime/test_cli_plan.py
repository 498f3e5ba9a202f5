"""``clomp plan`` as a user runs it: the console script, JSON out, one-line errors."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest


def clomp(*args: str, cwd=None) -> subprocess.CompletedProcess[str]:
    """Run the installed console script (as a user does), or the module when not installed."""
    script = Path(sys.executable).with_name("clomp")
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli"]
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=120, cwd=cwd)


def test_plan_overtaking_json():
    p = clomp("plan", "--scenario", "overtaking", "--json")
    # a partial plan: the goal stands in the box's shadow (no ray crossed it), so the plan
    # goes round the box and ends at the frontier beside it, unclaimed
    assert p.returncode == 1, p.stderr
    d = json.loads(p.stdout)
    assert d["reached_goal"] is False and d["collision_free"] is True and d["stop_reason"] == "frontier"
    assert 10 <= d["states"] <= 200 and d["transitions"] >= d["states"] - 1
    assert isinstance(d["planning_time_s"], float)
    assert {s["task"] for s in d["plan"]} >= {"STRAIGHT"}
    assert any(s["task"] in ("LEFT", "RIGHT") for s in d["plan"])
    for s in d["plan"]:
        assert len(s["start"]) == 3 and len(s["end"]) == 3


def test_plan_readable_and_blocked_exit_one():
    p = clomp("plan", "--scenario", "blocked")
    assert p.returncode == 1  # ran, goal not reached
    assert "does NOT reach the goal" in p.stdout
    p = clomp("plan", "--scenario", "blocked", "--json")
    assert json.loads(p.stdout)["reached_goal"] is False


def test_plan_scan_file_and_folder(tmp_path, scans_dir):
    p = clomp("plan", "--scan", str(scans_dir / "map0001.dat"), "--goal", "1.0,0.0", "--json")
    one = json.loads(p.stdout)
    assert "plan" in one
    assert p.returncode == (0 if one["reached_goal"] else 1), p.stderr  # 1: ran, goal not reached
    folder = tmp_path / "few"
    folder.mkdir()
    for name in ("map0001.dat", "map0100.dat", "map0250.dat"):
        (folder / name).write_bytes((scans_dir / name).read_bytes())
    p = clomp("plan", "--scan", str(folder), "--goal", "1.0,0.0", "--json")
    assert p.returncode == 0, p.stderr
    *lines, summary = [json.loads(x) for x in p.stdout.splitlines()]
    assert summary["summary"]["scans"] == 3
    assert [x["scan"].rsplit("/", 1)[-1] for x in lines] == ["map0001.dat", "map0100.dat", "map0250.dat"]
    assert all("reached_goal" in x for x in lines)


@pytest.mark.parametrize(
    "args, needle",
    [
        (["--scan", "/nonexistent/scan.dat"], "no such file"),
        (["--scenario", "atlantis"], "unknown scenario"),
        (["--scenario", "overtaking", "--goal", "0,0"], "robot's own position"),
        (["--scenario", "overtaking", "--goal", "nan,0"], "finite"),
        (["--scenario", "overtaking", "--goal", "1e200,0"], "beyond"),
        (["--scenario", "overtaking", "--goal", "1"], "X,Y"),
        (["--scenario", "overtaking", "--robust", "--samples", "1000000"], "--samples: expected a whole number from 1 to 2,000"),
        (["--scenario", "overtaking", "--samples", "0"], "--samples"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(args, needle):
    p = clomp("plan", *args)
    assert p.returncode == 2
    assert needle in p.stderr
    assert "Traceback" not in p.stderr
    assert len(p.stderr.strip().splitlines()) == 1


def test_a_goal_inside_an_obstacle_is_planned_towards_and_reported(tmp_path):
    # a recorded scan: only what the sensor saw is known (a scenario's goal is checked
    # against its true obstacles and refused instead; see test_cli_conventions)
    from clomp.planner import load_scenario

    scan = tmp_path / "overtaking.dat"
    np.savetxt(scan, load_scenario("overtaking").scan(max_range=1.1))
    p = clomp("plan", "--scan", str(scan), "--goal", "0.45,0", "--json")
    assert p.returncode == 1, p.stderr  # ran, goal not reached
    out = json.loads(p.stdout)
    assert out["goal_blocked"] is True and out["reached_goal"] is False
    readable = clomp("plan", "--scan", str(scan), "--goal", "0.45,0")
    assert "goal is inside a perceived obstacle" in readable.stdout


@pytest.mark.parametrize("content, needle", [("0.5 0.1\nfoo\n", ":2:"), ("nan 0.2\n", "not finite")])
def test_malformed_scan_files(tmp_path, content, needle):
    f = tmp_path / "bad.dat"
    f.write_text(content)
    p = clomp("plan", "--scan", str(f), "--goal", "1.0,0.0")
    assert p.returncode == 2 and needle in p.stderr and "Traceback" not in p.stderr
