"""A user tells the runtime its drive's calibration (issue #36): ``clomp run --calibration FILE``,
``clomp ros node --calibration FILE``, ``clomp emulate world --calibration-out FILE``.

A robot told nothing keeps the worst case's prior and the shared match floor; one told a drive
whose errors the filter models (``paper``) gets a prior sized to it and no shared floor; one
told error sources the filter does not model (``harsh``) keeps the floor. A file that cannot
be used is a usage error (exit 2) before any device opens. The runs are in simulated time.
"""

from __future__ import annotations

import json
from pathlib import Path

import pytest

import clomp.runtime.cli as cli
from clomp.planner import load_scenario
from clomp.planner.noise import NoiseTerms
from clomp.planner.robot_model import RobotModel
from clomp.runtime.backends.calibration import (CalibrationError, ToldCalibration, calibration_text, load_calibration,
                                                write_calibration)
from clomp.runtime.backends.emulated import EmulatedWorld
from clomp.runtime.backends.sim import SimRobot
from clomp.runtime.estimation.prior import OdometryPrior
from clomp.runtime.interface import Calibrated
from clomp.runtime.supervision import DRIVE_DELAY, SupervisorConfig
from clomp.runtime.supervision.sensing import Sensing
from tests.runtime._simcli import PORTS, record_supervisors, simulate_cli

# -- the file ---------------------------------------------------------------------------------------
BAD = [
    ("c.json", '{"wheel_bias": NaN}', "wheel_bias: expected a finite number >= 0, got nan"),
    ("c.json", '{"wheel_bias": Infinity}', "wheel_bias: expected a finite number >= 0, got inf"),
    ("c.toml", "wheel_sd = nan", "wheel_sd: expected a finite number >= 0, got nan"),
    ("c.json", '{"slip": -0.01}', "slip: expected a finite number >= 0, got -0.01"),
    ("c.toml", "latency = -1", "latency: expected a finite number >= 0, got -1"),
    ("c.json", '{"wheel_bais": 0.01}', "unknown key 'wheel_bais'"),
    ("c.toml", "[noise]\nwheel_sd = 0.1", "unknown key 'noise'"),
    ("c.json", '{"wheel_sd": "0.1"}', "wheel_sd: expected a finite number >= 0, got '0.1'"),
    ("c.json", '{"wheel_sd": true}', "wheel_sd: expected a finite number >= 0, got True"),
    ("c.json", '{"dropout": 1.0}', "dropout: must be below 1"),
    ("c.json", '{"note": 3}', "note: expected a string"),
    ("c.json", "[0.1, 0.2]", "expected an object of noise terms by name, got list"),
    ("c.json", "wheel_sd = 0.1", "not a JSON calibration file"),
    ("c.toml", '{"wheel_sd": 0.1}', "not a TOML calibration file"),
]


@pytest.mark.parametrize("name, text, said", BAD)
def test_a_bad_calibration_file_is_refused_naming_the_key(tmp_path: Path, name: str, text: str, said: str) -> None:
    path = tmp_path / name
    path.write_text(text)
    with pytest.raises(CalibrationError) as err:
        load_calibration(path)
    assert said in str(err.value) and str(path) in str(err.value)


def test_a_missing_file_is_refused(tmp_path: Path) -> None:
    with pytest.raises(CalibrationError, match="no such calibration file"):
        load_calibration(tmp_path / "nope.json")


@pytest.mark.parametrize("preset", ["paper", "harsh"])
@pytest.mark.parametrize("suffix", [".json", ".toml"])
def test_a_written_calibration_reads_back_and_says_what_it_leaves_on(tmp_path: Path, preset: str, suffix: str) -> None:
    terms = NoiseTerms.preset(preset)
    path = write_calibration(tmp_path / f"c{suffix}", terms, f"--noise {preset}")
    assert load_calibration(path) == terms
    text = path.read_text()
    assert ("shared match floor on" in text) is (preset == "harsh")
    assert ("shared match floor is off" in text) is (preset == "paper")


def test_a_term_left_out_is_zero_and_a_note_is_free_text(tmp_path: Path) -> None:
    (tmp_path / "c.toml").write_text('note = "trimmed 2026-12"\nwheel_sd = 0.02\n')
    assert load_calibration(tmp_path / "c.toml") == NoiseTerms(wheel_sd=0.02)


# -- the prior it builds ---------------------------------------------------------------------------
class _ToldSimRobot(ToldCalibration, SimRobot):
    def __init__(self, terms: NoiseTerms) -> None:
        self.tell(terms)
        super().__init__(load_scenario("open"), seed=0)


@pytest.mark.parametrize("preset, floor", [("paper", False), ("harsh", True)])
def test_a_told_robot_gets_the_prior_of_its_terms(preset: str, floor: bool) -> None:
    """Sized to the told terms (no heading sensor here); the shared floor only for told error
    sources the filter does not model; a robot told nothing keeps the worst case."""
    terms, model = NoiseTerms.preset(preset), RobotModel()
    robot = _ToldSimRobot(terms)
    assert isinstance(robot, Calibrated)
    est = Sensing(robot, model, SupervisorConfig()).estimator
    want = OdometryPrior.from_noise(terms, model.wheel_base, speed=model.straight_speed, heading=False)
    assert est is not None and est.prior == want and want.shared_floor is floor
    untold = Sensing(SimRobot(load_scenario("open"), seed=0), model, SupervisorConfig()).estimator
    assert untold is not None and untold.prior == OdometryPrior.worst() and untold.prior != want


def test_a_told_robot_with_an_imu_gets_the_heading_prior_before_its_first_report() -> None:
    """``clomp run --imu --calibration`` told ``harsh``: the supervisor is built before the
    IMU's first report, yet the prior is the one with a heading sensor (not the worst-case
    wheels a robot without one keeps), because the robot carries the IMU. Through the real
    drivers in simulated time; the run is cut at 0.5 s."""
    from tests.runtime._stack import run_stack

    terms, model = NoiseTerms.preset("harsh"), RobotModel()
    run = run_stack("overtaking", max_time=0.5, imu=True, calibration=terms, noise="harsh")
    assert run.robot is not None and run.robot.heading_sensor and run.supervisor is not None
    estimator = run.supervisor.sensing.estimator
    with_heading = OdometryPrior.from_noise(terms, model.wheel_base, speed=model.straight_speed, heading=True)
    without = OdometryPrior.from_noise(terms, model.wheel_base, speed=model.straight_speed, heading=False)
    assert with_heading != without
    assert estimator is not None and estimator.prior == with_heading
    no_imu = run_stack("overtaking", max_time=0.5, calibration=terms, noise="harsh")
    assert no_imu.supervisor is not None and not no_imu.robot.heading_sensor
    assert no_imu.supervisor.sensing.estimator.prior == without


# -- clomp run --calibration ----------------------------------------------------------------------------
@pytest.mark.parametrize("name, text, said", BAD[:6])
def test_clomp_run_refuses_a_bad_file_before_any_device_opens(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], name: str, text: str,
        said: str) -> None:
    (tmp_path / name).write_text(text)
    sim = simulate_cli(monkeypatch, "open")
    rc = cli.main(["run", *PORTS, "--goal", "1,0", "--log", str(tmp_path / "run.jsonl"),
                   "--calibration", str(tmp_path / name)])
    assert rc == 2
    err = capsys.readouterr().err
    assert "--calibration" in err and said in err
    assert sim.robot is None and not (tmp_path / "run.jsonl").exists()


@pytest.mark.parametrize("preset", ["paper", "harsh"])
def test_clomp_run_tells_the_estimator_the_file(tmp_path: Path, monkeypatch: pytest.MonkeyPatch, preset: str) -> None:
    """The supervisor's estimator gets the told terms' prior, with their delay (latency and
    ramp) unless ``--drive-delay`` is given; the run log records what it was told."""
    terms, model = NoiseTerms.preset(preset), RobotModel()
    path = write_calibration(tmp_path / "drive.toml", terms)
    made = record_supervisors(monkeypatch)
    sim = simulate_cli(monkeypatch, "open")
    rc = cli.main(["run", *PORTS, "--goal", "1.0,0.0", "--log", str(tmp_path / "run.jsonl"), "--max-time", "2.5",
                   "--calibration", str(path)])
    assert rc == 1  # the time limit
    assert sim.robot is not None and sim.robot.calibration() == terms.to_dict()
    assert sim.robot.config.odometry is False  # it reckons the commands itself, late by the told delay
    estimator = made[0].sensing.estimator
    want = OdometryPrior.from_noise(terms, model.wheel_base, speed=model.straight_speed, heading=False)
    assert estimator is not None and estimator.prior == want
    assert want.delay > 0 and want.shared_floor is (preset == "harsh")
    run = json.loads((tmp_path / "run.jsonl").read_text().splitlines()[0])
    assert run["event"] == "run" and run["calibration"] == terms.to_dict()


def test_a_given_drive_delay_overrides_the_told_one(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    path = write_calibration(tmp_path / "drive.json", NoiseTerms.preset("paper"))
    made = record_supervisors(monkeypatch)
    simulate_cli(monkeypatch, "open")
    rc = cli.main(["run", *PORTS, "--goal", "1.0,0.0", "--log", str(tmp_path / "run.jsonl"), "--max-time", "1",
                   "--calibration", str(path), "--drive-delay", "0.2"])
    assert rc == 1
    prior = made[0].sensing.estimator.prior
    assert prior.delay == 0.2 and prior.shared_floor is False and DRIVE_DELAY != 0.2


# -- clomp ros node --calibration, clomp emulate world --calibration-out ----------------------------------
def test_clomp_ros_node_refuses_a_bad_file_before_ros_starts(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "c.json").write_text('{"drift": -1}')
    assert cli.main(["ros", "node", "--goal", "1,0", "--calibration", str(tmp_path / "c.json")]) == 2
    assert "drift: expected a finite number >= 0" in capsys.readouterr().err


def test_the_emulated_world_tells_its_terms() -> None:
    assert EmulatedWorld("open", noise="harsh", seed=0).calibration == NoiseTerms.preset("harsh")
    assert EmulatedWorld("open").calibration is None  # the older simulated robot: no terms to tell


def test_emulate_world_without_the_execution_world_has_no_calibration_to_write(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    assert cli.main(["emulate", "world", "--scenario", "open", "--calibration-out", str(tmp_path / "c.toml")]) == 2
    assert "needs the execution world" in capsys.readouterr().err
    assert not (tmp_path / "c.toml").exists()


def test_the_note_of_a_json_file_says_where_the_terms_came_from() -> None:
    note = json.loads(calibration_text(NoiseTerms.preset("harsh"), "json", "clomp emulate world --noise harsh"))["note"]
    assert note.startswith("the drive's noise terms") and "--noise harsh" in note and "bias_walk" in note


def test_emulate_world_writes_its_calibration_and_the_run_command_takes_it(tmp_path: Path) -> None:
    """As a user runs it: ``clomp emulate world --noise paper --calibration-out FILE`` writes the
    world's terms, says where, and prints the ``clomp run`` command with ``--calibration FILE``
    (the world is stopped by Ctrl-C before any run: a wait for lines, never for a time)."""
    import subprocess

    from tests.runtime._ptycli import clomp, read_lines, stop_world

    out = tmp_path / "world.toml"
    world = subprocess.Popen(clomp("emulate", "world", "--scenario", "open", "--noise", "paper", "--seed", "3",
                                   "--calibration-out", str(out)),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        said = dict(line.split(": ", 1) for line in read_lines(world, 5))
    finally:
        _, err = stop_world(world)
    assert world.returncode == 0, err
    assert said["calibration"] == str(out) and said["run"].endswith(f"--calibration {out}")
    assert load_calibration(out) == NoiseTerms.preset("paper")
    assert "shared match floor is off" in out.read_text()
