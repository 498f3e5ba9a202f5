"""Command-line conventions a user relies on: arguments as typed, exit statuses, help text."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.cli import EXIT_STATUS, main


@pytest.mark.parametrize("argv", [["--goal", "-0.8,0"], ["--goal=-0.8,0"], ["--goal", "-.5,-0.2"]])
def test_a_negative_goal_is_taken_as_typed(capsys: pytest.CaptureFixture[str], argv: list[str]) -> None:
    rc = main(["plan", "--scenario", "open", *argv, "--json"])
    out = json.loads(capsys.readouterr().out)
    assert rc == 0
    assert out["goal"][0] < 0


# ------------------------------------------------------------------ one exit-status convention


def _rc(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    rc = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return rc, out, err


@pytest.mark.parametrize(
    ("argv", "status"),
    [
        (["--scenario", "corridor"], 0),  # the plan reaches the goal
        (["--scenario", "overtaking"], 1),  # a partial plan: the goal stands in the box's shadow
        (["--scenario", "blocked"], 1),  # a partial plan: ran, goal not reached
        (["--scenario", "blocked", "--json"], 1),
        (["--scenario", "overtaking", "--goal", "0.5,0"], 2),  # the box's centre (only its face is seen)
        (["--scenario", "overtaking", "--goal", "0,0"], 2),
        (["--scan", "/nonexistent/scan.dat"], 2),
    ],
)
def test_plan_exit_status(capsys: pytest.CaptureFixture[str], argv: list[str], status: int) -> None:
    rc, _, err = _rc(capsys, "plan", *argv)
    assert rc == status, err
    if status == 2:
        assert err.startswith("clomp: error: ") and len(err.splitlines()) == 1


def test_a_scenario_goal_inside_a_true_obstacle_is_refused_before_planning(capsys: pytest.CaptureFixture[str]) -> None:
    rc, _, err = _rc(capsys, "plan", "--scenario", "overtaking", "--goal", "0.5,0")
    assert rc == 2 and "inside an obstacle of scenario 'overtaking'" in err
    rc, _, err = _rc(capsys, "export", "--scenario", "overtaking", "--goal", "0.5,0", "-f", "json", "-o", "-")
    assert rc == 2 and "inside an obstacle" in err


def _folder(tmp_path: Path, scans_dir: Path) -> Path:
    d = tmp_path / "scans"
    d.mkdir()
    for name in ("map0001.dat", "map0100.dat"):
        (d / name).write_bytes((scans_dir / name).read_bytes())
    (d / "README.txt").write_text("These scans were recorded on 2023-10-25.\n")
    (d / "map0050.dat").write_text("0.5 0.1\nnot a point\n")
    return d


@pytest.mark.parametrize("command", ["plan", "replay"])
def test_a_folder_run_never_stops_at_one_scan(tmp_path: Path, scans_dir: Path, capsys: pytest.CaptureFixture[str],
                                              command: str) -> None:
    d = _folder(tmp_path, scans_dir)
    argv = ["plan", "--scan", str(d)] if command == "plan" else ["replay", str(d)]
    rc, out, _ = _rc(capsys, *argv, "--json")
    assert rc == 0  # every scan processed, whatever each outcome
    lines = [json.loads(x) for x in out.splitlines()]
    *scans, summary = lines
    assert [Path(x["scan"]).name for x in scans] == ["README.txt", "map0001.dat", "map0050.dat", "map0100.dat"]
    errors = {Path(x["scan"]).name: x["error"] for x in scans if "error" in x}
    assert set(errors) == {"README.txt", "map0050.dat"} and ":2:" in errors["map0050.dat"]
    s = summary["summary"]
    assert s["scans"] == 4 and s.get("error", s.get("errors")) == 2
    rc, out, _ = _rc(capsys, *argv)  # readable: one line per scan, the returns beyond the horizon, the summary
    assert rc == 0 and len(out.splitlines()) == 6 and out.splitlines()[-1].startswith("summary: 4 scans")
    assert out.splitlines()[-2].startswith("beyond the 1.1 m planning horizon, cropped: ")
    assert "2 errors" in out.splitlines()[-1]


def test_replaying_a_successful_run_log_counts_arrival_as_an_outcome(tmp_path: Path, scans_dir: Path,
                                                                     capsys: pytest.CaptureFixture[str]) -> None:
    from clomp.runtime.records.runlog import RunLog

    pts = np.loadtxt(scans_dir / "map0100.dat").reshape(-1, 2)
    log = tmp_path / "run.jsonl"
    with RunLog(log) as rl:
        rl.write("scan", points=pts, goal=[1.0, 0.0], pose=[0.0, 0.0, 0.0])
        rl.write("scan", points=pts, goal=[0.02, 0.01], pose=[0.98, 0.0, 0.0])  # arrived: within 5 cm
    rc, out, err = _rc(capsys, "replay", str(log), "--json")
    assert rc == 0, err
    first, second, summary = (json.loads(x) for x in out.splitlines())
    assert "error" not in second and second["outcome"] == "at_goal" and second["reached_goal"] is True
    assert summary["summary"]["errors"] == 0 and summary["summary"]["at_goal"] == 1


# (not "open": with nothing in sight the estimate cannot vouch for the goal, GOAL_UNCONFIRMED, exit 1)
@pytest.mark.parametrize(("scenario", "extra", "status"), [("overtaking", [], 0), ("blocked", ["--max-time", "10"], 1)])
def test_simulate_exit_status(tmp_path: Path, capsys: pytest.CaptureFixture[str], scenario: str, extra: list[str],
                              status: int) -> None:
    rc, out, err = _rc(capsys, "simulate", "--scenario", scenario, "--out", str(tmp_path), "--json", *extra)
    assert rc == status, err
    d = json.loads(out)
    assert d["reached_goal"] is (status == 0)


_SCENARIO_COMMANDS = [
    ["plan"], ["plan", "--robust"], ["export", "-f", "json", "-o", "-"], ["check"], ["simulate"], ["demo"],
    ["emulate", "lidar"], ["emulate", "world"],
]


@pytest.mark.parametrize("command", _SCENARIO_COMMANDS, ids=" ".join)
@pytest.mark.parametrize("source", ["atlantis", "broken.json", "missing.json"])
def test_every_command_reads_scenario_the_same_way(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                   capsys: pytest.CaptureFixture[str], command: list[str],
                                                   source: str) -> None:
    """``--scenario NAME|FILE`` that cannot be loaded: the library's own message, as one line, exit 2, whichever command."""
    from clomp.planner.scenarios import ScenarioError, load_scenario

    monkeypatch.chdir(tmp_path)
    (tmp_path / "broken.json").write_text("{not json", encoding="utf-8")
    with pytest.raises(ScenarioError) as want:
        load_scenario(source)
    rc, _, err = _rc(capsys, *command, "--scenario", source)
    assert (rc, err) == (2, f"clomp: error: {want.value}\n")


@pytest.mark.parametrize("command", ["simulate", "experiment"])
@pytest.mark.parametrize("value", ["nan", "inf", "-5", "0"])
def test_a_time_limit_that_never_ends_or_never_starts_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                 command: str, value: str) -> None:
    # NaN compares false with every clock reading: a run under it would never time out
    where = ["--scenario", "open"] if command == "simulate" else ["open", "--runs", "1", "--workers", "0"]
    rc, out, err = _rc(capsys, command, *where, "--out", str(tmp_path), "--max-time", value)
    assert rc == 2, out
    assert err.startswith("clomp: error: --max-time: ") and len(err.splitlines()) == 1


def test_export_says_what_it_wrote(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    dest = tmp_path / "m.prism"
    rc, out, err = _rc(capsys, "export", "--scenario", "overtaking", "-f", "prism", "-o", str(dest))
    assert rc == 0 and dest.is_file() and err == ""
    assert out.startswith(f"wrote {dest} (prism, mdp, ") and "states)" in out
    rc, out, err = _rc(capsys, "export", "--scenario", "overtaking", "-f", "json", "-o", "-")
    assert rc == 0 and json.loads(out) and err == ""  # standard output holds only the model
    rc, _, err = _rc(capsys, "export", "--scenario", "overtaking", "-f", "prism", "-o", str(tmp_path / "no" / "m"))
    assert rc == 2 and "does not exist" in err


def test_run_start_up_device_fault_is_3_and_a_missing_port_is_2(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from clomp.runtime.devices.maestro_emulator import MaestroEmulator
    from clomp.runtime.devices.rplidar_emulator import LidarEmulator

    log = str(tmp_path / "run.jsonl")
    with LidarEmulator(health_status=2, health_error_code=0x8001) as sick, MaestroEmulator() as maestro:
        rc, _, err = _rc(capsys, "run", "--lidar", sick.port, "--motors", maestro.port, "--goal", "1,0", "--log", log)
    assert rc == 3 and "health" in err and len(err.strip().splitlines()) == 1
    rc, _, err = _rc(capsys, "run", "--lidar", str(tmp_path / "ttyUSB9"), "--motors", str(tmp_path / "ttyACM9"),
                     "--goal", "1,0", "--log", log)
    assert rc == 2 and "clomp: error:" in err


# ------------------------------------------------------------------------- what a user reads


def test_version(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["--version"])
    assert exc.value.code == 0
    assert capsys.readouterr().out.startswith("clomp ")


@pytest.mark.parametrize("command", ["demo", "plan", "replay", "simulate", "experiment", "export", "convert", "check", "emulate", "run"])
def test_help_is_plain_text_and_ends_with_the_exit_statuses(capsys: pytest.CaptureFixture[str], command: str) -> None:
    with pytest.raises(SystemExit):
        main([command, "--help"])
    out = capsys.readouterr().out
    assert "``" not in out
    tail = out[out.rindex("exit status:"):]
    for code in ("0", "2", "130"):
        assert f"\n  {code} " in tail
    assert EXIT_STATUS[command][0] in tail


def test_an_unknown_option_shows_the_commands_own_usage(capsys: pytest.CaptureFixture[str]) -> None:
    with pytest.raises(SystemExit) as exc:
        main(["simulate", "--goal", "1,0"])
    err = capsys.readouterr().err
    assert exc.value.code == 2
    assert err.startswith("usage: clomp simulate ") and "unrecognized arguments: --goal 1,0" in err


def test_counts_are_spelled_for_one_and_many(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    one = tmp_path / "one.dat"
    one.write_text("0.6 0.3\n")  # one return: one obstacle box
    _, out, _ = _rc(capsys, "plan", "--scan", str(one), "--goal", "1,0")
    assert "1 obstacle box," in out and "1 obstacle boxes" not in out
    two = tmp_path / "two.dat"
    two.write_text("0.6 0.3\n0.6 -0.3\n")
    _, out, _ = _rc(capsys, "plan", "--scan", str(two), "--goal", "1,0")
    assert "2 obstacle boxes," in out


def test_the_library_refuses_a_time_limit_that_never_ends() -> None:
    from clomp.planner import load_scenario
    from clomp.runtime.experiment.reactive import ReactiveController
    from clomp.runtime.experiment.runner import run_once
    from clomp.runtime.backends.sim import SimRobot
    from clomp.runtime.supervision.supervisor import Supervisor

    scene = load_scenario("open")
    with pytest.raises(ValueError, match="max_time"):
        run_once(scene, "planning", 0, noise="ideal", max_time=float("nan"))
    with pytest.raises(ValueError, match="max_time"):
        run_once(scene, "planning", 0, noise="ideal", max_time=float("inf"))
    # the supervisor, on hardware too, halts at once rather than drive without an end
    report = Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=float("nan"))
    assert report.state.name == "HALTED" and "time limit" in report.reason
    with pytest.raises(ValueError, match="max_time"):
        ReactiveController(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run(max_time=float("nan"))
