"""``clomp run`` tells its estimator how late the drive follows a command (issue #36).

Over the hardware path the robot is told nothing of its drive (no :class:`Calibrated`
backend), and the estimator used to dead-reckon on the commands as sent (delay 0): the body
starts late, and every start's lead of the commands over it was learnt from the scans as a
wrong forward scale. ``clomp run`` now takes a documented default
(:data:`~clomp.runtime.supervision.config.DRIVE_DELAY`, ``--drive-delay`` to change it), with
or without ``--imu``. All in simulated time.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import pytest

import clomp.runtime.cli as cli
from clomp.planner import load_scenario
from clomp.planner.robot_model import RobotModel
from clomp.runtime.backends.sim import SimRobot
from clomp.runtime.estimation.prior import OdometryPrior
from clomp.runtime.supervision import DRIVE_DELAY, SupervisorConfig
from clomp.runtime.supervision.sensing import Sensing
from tests.runtime._simcli import PORTS, record_supervisors, simulate_cli
from tests.runtime.test_start_lead import _hops

_RUN_MODULE = "clomp.runtime.cli.run"


def test_told_only_the_default_delay_a_worst_case_robot_does_not_learn_the_lead_as_a_scale() -> None:
    """The harsh drive (0.1 s latency, a 1 m/s² ramp: 0.15 s in all) with exact wheels, the
    estimator told nothing but ``clomp run``'s default delay: the forward scale it learns from
    three starts stays near 0 (taken as 0, it learns about -0.07: the test below)."""
    learnt = _hops(dataclasses.replace(OdometryPrior.worst(), delay=DRIVE_DELAY))
    assert abs(learnt) < 0.03, learnt


def test_told_no_delay_the_same_robot_learns_the_lead_as_a_scale() -> None:
    """What the default guards against: the worst-case prior with delay 0 (``clomp run`` before)."""
    assert _hops(OdometryPrior.worst()) < -0.04


def test_the_supervisor_config_gives_the_estimator_its_delay() -> None:
    """A backend told nothing (not Calibrated) keeps the worst-case prior with the configured delay."""
    robot = SimRobot(load_scenario("open"), seed=0)
    told = Sensing(robot, RobotModel(), SupervisorConfig(drive_delay=0.12))
    assert told.estimator is not None and told.estimator.prior == dataclasses.replace(OdometryPrior.worst(), delay=0.12)
    untold = Sensing(robot, RobotModel(), SupervisorConfig())
    assert untold.estimator is not None and untold.estimator.prior == OdometryPrior.worst()
    with pytest.raises(ValueError, match="drive_delay"):
        SupervisorConfig(drive_delay=-0.1)


@pytest.mark.parametrize("extra, delay, odometry", [((), DRIVE_DELAY, False), (("--drive-delay", "0"), 0.0, True)])
def test_clomp_run_dead_reckons_the_commands_late_by_its_drive_delay(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, extra: tuple[str, ...], delay: float, odometry: bool) -> None:
    """``clomp run`` without ``--imu``: by default the estimator reckons the commands itself,
    DRIVE_DELAY late (the hardware robot's dead reckoning on the commands as sent is not used);
    ``--drive-delay 0`` is the run as before."""
    if _RUN_MODULE not in cli._COMMAND_MODULES:
        monkeypatch.setattr(cli, "_COMMAND_MODULES", [*cli._COMMAND_MODULES, _RUN_MODULE])
    made = record_supervisors(monkeypatch)
    sim = simulate_cli(monkeypatch, "open")
    rc = cli.main(["run", *PORTS, "--goal", "1.0,0.0", "--log", str(tmp_path / "run.jsonl"), "--max-time", "2.5",
                   *extra])
    assert rc == 1  # the time limit
    assert sim.robot is not None and sim.robot.config.odometry is odometry
    estimator = made[0].sensing.estimator
    assert estimator is not None and estimator.prior.delay == delay
