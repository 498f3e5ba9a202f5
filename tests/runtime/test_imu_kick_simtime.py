"""The emulated BNO08x feels what the world's body feels (issue #36): ``clomp emulate world``'s
IMU reports the execution world's true horizontal acceleration (plus gravity on z), so a kick
reaches the supervisor over the serial line and raises the estimate's doubt floor
(:class:`clomp.runtime.estimation.doubt.Doubt`), as it does in the execution world itself.
Whole hardware stack in simulated time (tests/runtime/_stack.py)."""

from __future__ import annotations

import math

import pytest

from clomp.formal.geometry import relative

from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from tests.runtime._stack import StackRun, run_stack

T_KICK = 4.0  # simulated seconds into the run: driving its first straight


def _kicked(imu_options: dict | None = None, kick: bool = True) -> StackRun:
    def hook(t: float, run: StackRun) -> None:
        if kick and t - run.started >= T_KICK and "kicked" not in run.notes:
            with run.world._lock:  # the world's own thread is not running (lockstep), but as it would
                run.world.sim.push(0.2, math.pi / 2)  # 0.2 m to the left, world frame
            run.notes["kicked"] = t
        if "kicked" in run.notes and run.supervisor is not None and t >= run.notes["kicked"] + 0.5:
            truth, est = relative(run.world.sim.start_pose, run.world.sim.pose), run.supervisor.pose
            run.notes.setdefault("off", []).append(math.hypot(est.x - truth.x, est.y - truth.y))

    return run_stack("overtaking", imu=True, noise="paper", seed=3, max_time=8.0, hook=hook,
                     imu_options=imu_options or {})


def _kicks(run: StackRun) -> list[tuple[float, str, float]]:
    assert run.supervisor is not None and run.supervisor.estimator is not None
    return [e for e in run.supervisor.estimator.doubt.events if e[1] == "kick"]


def test_a_kick_is_felt_over_the_emulated_imu_and_raises_the_floor() -> None:
    run = _kicked()
    assert "kicked" in run.notes and run.world.sim.pushes
    kicks = _kicks(run)
    assert kicks, run.supervisor.estimator.doubt.events  # type: ignore[union-attr]
    t_felt = kicks[0][0]
    assert kicks[0][2] >= 30.0  # tens of m/s²: a kick, not a jolt
    assert t_felt >= run.notes["kicked"] - 1e-6 - run.started and t_felt <= run.notes["kicked"] + 0.5


def test_the_estimate_moves_by_the_slide_the_imu_measured() -> None:
    """The kick's slide, measured from the reports' accelerations (bno08x_slide), moves the
    estimate: from half a second after the kick on it is within 3 cm of the truth (without
    it the estimate stays 0.2 m off: the one small box of ``overtaking`` cannot place it)."""
    run = _kicked()
    assert run.supervisor is not None and run.supervisor.estimator is not None
    assert any(e[1] == "slid" for e in run.supervisor.estimator.doubt.events)
    off = run.notes["off"]
    assert len(off) >= 10 and max(off) < 0.03, off


def test_without_a_kick_the_emulated_imu_feels_none() -> None:
    run = _kicked(kick=False)
    assert not _kicks(run)


def test_an_imu_reporting_gravity_alone_misses_the_kick() -> None:
    """The emulator as it was (no acceleration source): the kick is not felt, no floor."""
    run = _kicked({"acceleration": None})
    assert run.world.sim.pushes and not _kicks(run)


def test_the_report_carries_the_source_s_acceleration_and_gravity() -> None:
    from clomp.runtime.devices import bno08x_codec as c

    felt = iter([(12.5, -3.0)])
    imu = Bno08xEmulator(lambda: 0.0, acceleration=lambda: next(felt, (0.0, 0.0)))
    imu._t0 = 0.0
    imu._accel = imu._felt()
    imu._emit(0.0, 0.01)
    report, = c.RvcDecoder().feed(bytes(imu._out))
    ax, ay, az = report.accel
    assert (round(ax, 1), round(ay, 1), round(az, 2)) == (12.5, -3.0, 9.81)
    assert imu._felt() == (0.0, 0.0)  # the source said nothing more


def test_a_broken_acceleration_source_does_not_kill_the_device() -> None:
    def bad() -> tuple[float, float]:
        raise RuntimeError("gone")

    imu = Bno08xEmulator(lambda: 0.0, acceleration=bad)
    assert imu._felt() == (0.0, 0.0) and len(imu.source_errors) == 1
    assert Bno08xEmulator(lambda: 0.0, acceleration=lambda: (math.nan, 1.0))._felt() == (0.0, 0.0)


@pytest.mark.slow
def test_a_harsh_run_kicked_on_its_way_ends_at_the_goal() -> None:
    """bench/imu_stack.py's seed 11 (harsh; a 0.115 m push 30 s in, sideways while it drives
    to the goal): the measured slide moves the estimate, the revolution taken during the
    slide is not matched, and the run ends truly within 0.1 m (0.159 m on session 7's code,
    0.148 m with the slide measured but that revolution matched)."""
    run = run_stack("overtaking", imu=True, noise="harsh", seed=11, max_time=90.0)
    assert run.world.sim.pushes and run.supervisor is not None and run.supervisor.estimator is not None
    assert any(e[1] == "slid" for e in run.supervisor.estimator.doubt.events)
    assert run.world.goal_distance <= 0.1
