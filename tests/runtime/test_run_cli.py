"""``clomp run`` end to end.

Its behaviour on faults, signals and a dry run (exit status, messages, run-log records, the
wheels commanded to stop) is tested on the whole hardware stack in simulated time: ``clomp run``
in this process, the real drivers and supervisor against the device emulators on simulated
lines (tests/runtime/_simcli.py), so no outcome depends on how busy the machine is and the
stop is timed on the emulators' own clock. What needs real processes and pseudo-terminals (a
SIGKILLed run, ``clomp emulate world`` serving ``clomp run``) runs them, the world in a process
of its own (clomp.runtime.backends.emulated) as real devices would be, and waits only for events
(a line printed, the wheels commanded, an exit), each bounded by :data:`HANG` only against a
hang. The real-time runs to the goal over ptys are slow tests; their simulated-time twins are
in test_stack_simtime.py."""

from __future__ import annotations

import inspect
import math
import signal
import subprocess
import sys
import time
from pathlib import Path
from typing import Any

import pytest

import clomp.runtime.cli as cli
from clomp.runtime.backends.emulated import EmulatedWorldProcess
from clomp.runtime.records.runlog import read_log
from tests.runtime._ptycli import HANG, RUN_MODULE, clomp, read_lines, stop_world
from tests.runtime._simcli import PORTS, simulate_cli
from tests.runtime._stack import StackRun, at, wheels_stopped_at

NEUTRAL = 6000


@pytest.fixture
def run_registered(monkeypatch: pytest.MonkeyPatch) -> None:
    """Make ``clomp run`` available to in-process ``cli.main`` calls."""
    if RUN_MODULE not in cli._COMMAND_MODULES:
        monkeypatch.setattr(cli, "_COMMAND_MODULES", [*cli._COMMAND_MODULES, RUN_MODULE])


class Run:
    """A ``clomp run`` subprocess against an emulated world; never outlives its test."""

    def __init__(self, world: EmulatedWorldProcess, log: Path, *extra: str, goal: str = "1.0,0.0") -> None:
        self.log = log
        argv = clomp("run", "--lidar", world.lidar_port, "--motors", world.motor_port, "--goal", goal,
                     "--log", str(log), *extra)
        self.proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                                     cwd=log.parent)
        self.stdout = self.stderr = ""

    def finish(self, timeout: float = HANG) -> int:
        """Wait for the exit (``timeout``: a hang, a failure)."""
        try:
            self.stdout, self.stderr = self.proc.communicate(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.stdout, self.stderr = self.proc.communicate()
            pytest.fail(f"clomp run did not end within {timeout} s:\n{self.stderr}")
        return self.proc.returncode

    def records(self) -> list[dict[str, Any]]:
        return list(read_log(self.log))


def wait_driving(world: EmulatedWorldProcess, run: Run) -> None:
    """Wait for the event: the wheels commanded to move (or the run ended, a failure)."""
    ok = world.maestro.wait_for(lambda e: e.speeds != (0.0, 0.0) or run.proc.poll() is not None, HANG)
    if not ok or run.proc.poll() is not None:
        run.finish()
        pytest.fail(f"the robot never drove (exit {run.proc.returncode}):\n{run.stderr}")


def assert_clean_failure(stderr: str, rc: int, wheels: str = "wheels stopped") -> None:
    assert rc != 0
    assert "Traceback" not in stderr
    lines = [line for line in stderr.splitlines() if line.strip()]
    assert lines and wheels in lines[-1], stderr


# ---------------------------------------------------------------------------- end to end


def assert_honest_end(run: Run, rc: int, truly: float, start: float) -> None:
    """What a run to the goal over ptys in real time owes whatever the machine's load (issue #36):
    it ends at the goal (exit 0) only when the world puts it truly within 0.1 m, or it ends
    unconfirmed (exit 1) with its estimated distance and the 95 % bound of it in the last line and
    the log; and it drove toward the goal (truly nearer than the ``start`` distance).

    How near it gets is not asserted here. In real time that measures the scheduler as much as the
    software: without an IMU, overtaking at --time-scale 2 ended truly 0.21, 0.24 and 0.54 m off
    (all unconfirmed, each inside its stated bound) at load 10.6-10.9 on 2026-12-07, and passed
    ``<= 0.12`` only on a quieter machine. The same drivers and supervisor on an injected clock
    assert it (test_stack_simtime.py: the same run every time); bench/imu_stack.py --pty measures it."""
    assert rc in (0, 1), run.stderr
    said = (run.stdout + run.stderr).lower()
    stop = run.records()[-1]
    if rc == 0:
        assert "goal reached" in said and stop["status"] == "GOAL_REACHED", said
        assert truly <= 0.1, f"a false success: exit 0, truly {truly:.3f} m from the goal"
    else:
        assert "goal unconfirmed" in said and "95 % bound" in said and stop["status"] == "GOAL_UNCONFIRMED", said
        assert stop["distance"] >= 0.0 and stop["bound"] > 0.0, stop
    assert truly < start, f"truly {truly:.3f} m from the goal, {start:.3f} m at the start"


def _overtaking(tmp_path: Path, scale: float) -> None:
    with EmulatedWorldProcess("overtaking", time_scale=scale) as world:
        run = Run(world, tmp_path / "run.jsonl", "--time-scale", f"{scale:g}", "--max-time", "80")
        rc = run.finish()
        assert_honest_end(run, rc, world.goal_distance, 1.0)
        assert world.collisions == 0
        assert world.maestro.speeds == (0.0, 0.0)
        assert world.error is None and world.lidar.error is None and world.maestro.error is None
    recs = run.records()
    events = {r["event"] for r in recs}
    assert {"run", "device", "start", "scan", "plan", "state", "task", "motor", "stop"} <= events
    assert recs[-1]["event"] == "stop" and recs[-1]["status"] == ("GOAL_REACHED" if rc == 0 else "GOAL_UNCONFIRMED")
    assert any(r["event"] == "motor" and r["left"] > 0 for r in recs)
    assert recs[0]["event"] == "run" and recs[0]["lidar"] == world.lidar_port


@pytest.mark.slow  # real time over ptys; the default suite runs it in simulated time (test_stack_simtime.py)
def test_overtaking_over_ptys_at_double_speed_claims_the_goal_only_when_truly_there(tmp_path: Path) -> None:
    """The whole stack on the paper's scenario; world, LiDAR pace and controller clock ×2."""
    _overtaking(tmp_path, 2.0)


@pytest.mark.slow
def test_overtaking_over_ptys_in_real_time_claims_the_goal_only_when_truly_there(tmp_path: Path) -> None:
    _overtaking(tmp_path, 1.0)


@pytest.mark.slow  # real time over ptys: kept out of the default suite on a loaded machine
def test_the_hardware_stack_closes_the_loop_in_the_harsh_world(tmp_path: Path) -> None:
    """clomp run over the emulated devices in front of the execution world with every noise
    term x5 and 0.1 s latency: scan feedback corrects the pose, plans are checked once a
    revolution, and the robot truly reaches the goal."""
    with EmulatedWorldProcess("corridor", noise="harsh", seed=1, time_scale=2.0) as world:
        start = world.goal_distance
        run = Run(world, tmp_path / "run.jsonl", "--time-scale", "2", "--max-time", "90")
        rc = run.finish()
        assert_honest_end(run, rc, world.goal_distance, start)
        assert world.collisions == 0
    recs = run.records()
    feedback = [r for r in recs if r["event"] == "feedback"]
    assert feedback and sum(r["ok"] for r in feedback) > len(feedback) / 2
    assert any(r["event"] == "check" for r in recs)


@pytest.mark.slow  # real time over ptys; the default suite runs it in simulated time (test_stack_simtime.py)
def test_a_little_line_garbage_is_tolerated_and_the_run_still_works(tmp_path: Path) -> None:
    faults = {"garbage_rate": 0.02, "bad_check_rate": 0.01, "seed": 7}
    with EmulatedWorldProcess("open", time_scale=2.0, lidar_options=faults) as world:
        # --max-time is a safety stop, not the test's window: at load ~15 the first plan of a
        # fresh process took 37 s (0.18 s on a quiet machine) and a 30 s stop ended the run
        # before it moved; the run's own end (the goal, or unconfirmed) is the event awaited.
        run = Run(world, tmp_path / "run.jsonl", "--time-scale", "2", "--max-time", "240", goal="0.5,0.0")
        rc = run.finish()
        p = world.pose
        assert_honest_end(run, rc, math.hypot(p.x - 0.5, p.y), 0.5)
        assert world.lidar.garbage_bytes_sent > 0
    assert not any(r["event"] == "fault" for r in run.records())


def test_dry_run_plans_on_real_scans_but_never_moves_the_wheels(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    sim = simulate_cli(monkeypatch, "open")
    log = tmp_path / "run.jsonl"
    rc = cli.main(["run", *PORTS, "--goal", "1.0,0.0", "--log", str(log), "--dry-run", "--max-time", "1.5"])
    out, err = capsys.readouterr()
    assert rc == 0, err  # a dry run ends at its time limit
    assert sim.elapsed >= 1.5  # of simulated time: the limit, not a fault, ended it
    assert sim.world.maestro.events and all(target == NEUTRAL for _, _, target in sim.world.maestro.events)
    assert sim.world.pose.x == pytest.approx(0.0, abs=1e-9)
    recs = list(read_log(log))
    assert recs[0]["dry_run"] is True
    scans = [r for r in recs if r["event"] == "scan"]
    plans = [r for r in recs if r["event"] == "plan"]
    # the A1's ~5.5 revolutions/s for 1.5 s of simulated time (9 measured), every one planned
    assert sim.robot is not None and len(scans) >= 8 and len(plans) == len(scans) == sim.robot.scans
    assert all(p["reached_goal"] and p["tasks"] == ["STRAIGHT"] for p in plans)  # open: one clear run
    assert f"dry run: {len(scans)} scans planned" in out
    assert not any(r["event"] == "motor" and r.get("sent") not in (None, [0.0, 0.0]) for r in recs)
    # the hardware run's log converts like a simulated one: a LaserScan per scan, a Path per plan
    from clomp.runtime.records.mcap_writer import write_mcap

    counts = write_mcap(recs, tmp_path / "run.mcap").counts
    assert counts["/scan"] == len(scans) and counts["/plan"] == len(plans) == counts["/obstacles"]


# ---------------------------------------------------------------------------------- faults
# ``clomp run`` in this process on simulated time (tests/runtime/_simcli.py): each fault comes
# at T_FAULT s of the run, while the wheels turn (``at`` checks), and nothing waits on the wall clock.

T_FAULT = 3.0  # simulated seconds: driving the first straight (it stands ~1.8 s to seed its map)
TICK = 0.1  # the supervisor's control period (RobotModel.tick)


def _sim_run(log: Path, *extra: str) -> int:
    return cli.main(["run", *PORTS, "--goal", "1.0,0.0", "--log", str(log), "--max-time", "30", *extra])


def _log_time(sim: StackRun, t: float) -> float:
    """Simulated time ``t`` as the run log's ``t`` (seconds since the log opened)."""
    return t - float(sim.notes["log_t0"])


def test_ctrl_c_stops_the_wheels_logs_why_and_exits_non_zero(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    """A real SIGINT, sent by this process to itself while the wheels turn: clomp run's own
    handler turns it into the halt; the wheels stop in that same instant and stay stopped."""
    import os

    sim = simulate_cli(monkeypatch, "open", hook=at(T_FAULT, lambda sim: os.kill(os.getpid(), signal.SIGINT)))
    log = tmp_path / "run.jsonl"
    rc = _sim_run(log)
    t_fault = sim.notes["t_fault"]
    assert wheels_stopped_at(sim.world.maestro, t_fault) == t_fault  # before any more time passed
    assert sim.world.maestro.speeds == (0.0, 0.0)
    assert rc == 130
    assert_clean_failure(capsys.readouterr().err, rc)
    stop = [r for r in read_log(log) if r["event"] == "stop"]
    assert len(stop) == 1 and "SIGINT" in stop[0]["reason"] and stop[0]["status"] == "HALTED"


@pytest.mark.parametrize(
    ("fault", "said"),
    [("garbage", "corrupt"), ("bad_check", "corrupt"), ("silent", "silent")],
)
def test_a_broken_lidar_stream_stops_the_wheels_and_says_why(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None,
    fault: str, said: str,
) -> None:
    """The stream goes wrong while the wheels turn: clomp run stops them within the watch's
    300 ms (here on the simulated clock, as test_hardware_deadlines.py times the deadline
    itself), says why and exits 3."""
    changes: dict[str, dict[str, float | bool]] = {
        "garbage": {"garbage_rate": 1.0}, "bad_check": {"bad_check_rate": 1.0}, "silent": {"silent": True}}
    change = changes[fault]

    def inject(sim: StackRun) -> None:
        sim.notes["t_inject"] = sim.world.lidar.inject(**change)  # the device's time of the fault

    sim = simulate_cli(monkeypatch, "open", hook=at(T_FAULT, inject))
    log = tmp_path / "run.jsonl"
    rc = _sim_run(log)
    t0 = sim.notes["t_inject"]
    assert 0.0 <= wheels_stopped_at(sim.world.maestro, t0) - t0 <= 0.3  # stopped after the fault, and stayed stopped
    assert rc == 3  # a device fault
    err = capsys.readouterr().err
    assert_clean_failure(err, rc)
    assert said in err
    recs = list(read_log(log))
    faults = [r for r in recs if r["event"] == "fault"]
    assert faults and all(said in r["reason"] for r in faults)
    assert faults[0]["t"] >= _log_time(sim, t0)
    assert recs[-1]["event"] == "stop" and recs[-1]["status"] == "HALTED"


def test_the_motor_controller_vanishing_is_detected_within_a_tick(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    """Nothing can be sent over a vanished port (the Maestro's own serial timeout must stop the
    servos): what the software owes is to notice at its next command, log why, and exit."""
    sim = simulate_cli(monkeypatch, "open", hook=at(T_FAULT, lambda sim: sim.world.maestro.vanish()))
    log = tmp_path / "run.jsonl"
    rc = _sim_run(log)
    assert rc == 3  # a device fault
    err = capsys.readouterr().err
    assert_clean_failure(err, rc, wheels="could NOT command the wheels to stop")
    assert "motor controller" in err
    recs = list(read_log(log))
    fault = next(r for r in recs if r["event"] == "fault")
    assert fault["source"] == "motors"
    t_fault = _log_time(sim, sim.notes["t_fault"])
    assert 0.0 <= fault["t"] - t_fault <= TICK + 1e-6, (fault["t"], t_fault)  # at the next command
    assert any(r["event"] == "motor" and "could not stop" in r.get("error", "") for r in recs)


def test_an_exception_inside_planning_halts_with_the_wheels_stopped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    from clomp.planner.configurator import Configurator

    raised: list[float] = []
    sim = simulate_cli(monkeypatch, "open")

    def broken_plan(self: Any, scan: Any, goal: Any) -> Any:
        raised.append(sim.clock.now())
        raise RuntimeError("boom in the planner")

    monkeypatch.setattr(Configurator, "plan", broken_plan)
    log = tmp_path / "run.jsonl"
    rc = _sim_run(log)
    assert raised and wheels_stopped_at(sim.world.maestro, raised[0]) == raised[0]  # stopped at the raise
    err = capsys.readouterr().err
    assert rc == 1 and "Traceback" not in err and "boom in the planner" in err
    faults = [r for r in read_log(log) if r["event"] == "fault"]
    assert faults and "RuntimeError: boom in the planner" in faults[0]["reason"]


def test_a_signal_landing_inside_a_supervisor_step_keeps_its_name(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    """The Ctrl-C race made deterministic: SIGINT arrives while the supervisor is planning
    (inside Supervisor.step, which aborts first); the log must still say SIGINT."""
    import os

    from clomp.planner.configurator import Configurator

    real_plan = Configurator.plan

    def plan_then_ctrl_c(self: Any, scan: Any, goal: Any) -> Any:
        result = real_plan(self, scan, goal)
        os.kill(os.getpid(), signal.SIGINT)  # delivered before the next bytecode of this thread
        return result

    monkeypatch.setattr(Configurator, "plan", plan_then_ctrl_c)
    sim = simulate_cli(monkeypatch, "open")
    log = tmp_path / "run.jsonl"
    rc = _sim_run(log)
    assert sim.world.maestro.speeds == (0.0, 0.0)
    err = capsys.readouterr().err
    assert rc == 130 and "Traceback" not in err and "SIGINT" in err
    stop = [r for r in read_log(log) if r["event"] == "stop"]
    assert len(stop) == 1 and stop[0]["reason"] == "interrupted by SIGINT" and stop[0]["status"] == "HALTED"


# ------------------------------------------------- a real process killed: only the board stops the wheels


@pytest.mark.parametrize("serial_timeout", [None, 0.5])
def test_after_sigkill_only_the_maestros_own_serial_timeout_stops_the_wheels(
    tmp_path: Path, serial_timeout: float | None
) -> None:
    """SIGKILL leaves no handler to run: a new board (timeout off) keeps the wheels turning;
    with the board's serial timeout set, the Maestro itself sends them home. A real ``clomp
    run`` over ptys, killed once the wheels turn; every wait is for an event (the wheels
    commanded, the process gone, the board's own clock passing), bounded only against a hang."""
    with EmulatedWorldProcess("open", serial_timeout=serial_timeout) as world:
        run = Run(world, tmp_path / "run.jsonl")
        wait_driving(world, run)
        run.proc.kill()
        run.finish()
        emu = world.maestro
        if serial_timeout is None:
            # two seconds of the device's own time after the last byte, still driving
            assert emu.wait_for(lambda e: e.clock() - e.last_byte_at >= 2.0, HANG)
            assert emu.speeds != (0.0, 0.0) and not emu.timed_out
        else:
            assert emu.wait_for(lambda e: e.speeds == (0.0, 0.0), HANG)
            assert emu.timed_out and emu.error_code & (1 << 5)  # the serial-timeout error bit
            stopped_at = emu.events[-1][0]
            assert stopped_at - emu.last_byte_at >= serial_timeout  # the board's doing, not the driver's
    assert run.proc.returncode == -signal.SIGKILL


# ------------------------------------------------------------------------- user errors


def test_start_up_errors_are_one_line_and_still_logged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str], run_registered: None
) -> None:
    monkeypatch.chdir(tmp_path)
    rc = cli.main(["run", "--lidar", str(tmp_path / "ttyUSB9"), "--motors", str(tmp_path / "ttyACM9"),
                   "--goal", "1.0,0.0"])
    out, err = capsys.readouterr()
    assert rc == 2 and err.count("\n") == 1 and "clomp: error:" in err and "ttyACM9" in err
    logs = list((tmp_path / "clomp-runs").glob("run-*.jsonl"))
    assert len(logs) == 1 and f"log: {Path('clomp-runs') / logs[0].name}" in out  # default: timestamped
    recs = list(read_log(logs[0]))
    assert [r["event"] for r in recs] == ["run", "fault", "stop"]

    # an IMU port that does not exist is a typo too (exit 2), named; the IMU is opened before the LiDAR
    rc = cli.main(["run", "--lidar", "loop://", "--dry-run", "--imu", str(tmp_path / "ttyIMU9"), "--goal", "1,0"])
    err = capsys.readouterr().err
    assert rc == 2 and err.count("\n") == 1 and "IMU" in err and "ttyIMU9" in err, err

    for argv, said in [
        (["--lidar", "x", "--goal", "1,0"], "--motors"),
        (["--lidar", "x", "--motors", "y", "--goal", "1;0"], "--goal"),
        (["--lidar", "x", "--motors", "y", "--goal", "1,0", "--max-time", "-1"], "--max-time"),
        (["--lidar", "x", "--motors", "y", "--goal", "1,0", "--left-channel", "1"], "different"),
    ]:
        assert cli.main(["run", *argv]) == 2
        assert said in capsys.readouterr().err


def test_emulate_world_serves_a_whole_stack_a_user_can_run(tmp_path: Path) -> None:
    """Real processes over ptys, in real time (scale 1: the least a loaded machine must keep up
    with): the world prints its ports and the command to run (lines waited for), the run goes
    to its end (its exit waited for), and the world's summary says where the robot truly is."""
    import clomp.runtime.cli.emulate as emulate

    if "add_emulate_world" in inspect.getsource(emulate):
        argv = clomp("emulate", "world", "--scenario", "open")
    else:  # not wired into `clomp emulate` yet: the same parser, stand-alone
        code = ("import argparse, sys; from clomp.runtime.cli.run import add_emulate_world; "
                "p = argparse.ArgumentParser(); add_emulate_world(p.add_subparsers(required=True)); "
                "a = p.parse_args(sys.argv[1:]); raise SystemExit(a.func(a))")
        argv = [sys.executable, "-c", code, "world", "--scenario", "open"]
    world = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        lines = read_lines(world, 4)
        ports = dict(line.split(": ", 1) for line in lines)
        assert ports["run"].startswith("clomp run --lidar ") and f"--imu {ports['imu']}" in ports["run"]
        run = subprocess.run(
            clomp("run", "--lidar", ports["lidar"], "--motors", ports["motors"], "--goal", "0.3,0",
                  "--log", str(tmp_path / "run.jsonl")),
            capture_output=True, text=True, timeout=HANG,
        )
        assert run.returncode == 0, run.stderr
    finally:
        out, err = stop_world(world)
    assert world.returncode == 0, err
    x = float(out.split("robot at (", 1)[1].split(",", 1)[0])
    assert x == pytest.approx(0.3, abs=0.06) and "0 collision(s)" in out


def test_a_second_ctrl_c_while_the_emulated_world_stops_still_gives_its_summary(
        monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]) -> None:
    """Ctrl-C pressed twice (or sent by a shell and by ``timeout``): the second one lands while
    the world stops; it is ignored, the world still stops and the summary still comes. The
    signals are real and sent by the process to itself at those two moments (no timing)."""
    import os

    import clomp.runtime.realtime as realtime
    import clomp.runtime.backends.emulated as emulated
    from clomp.formal.model import Pose

    class World:
        scene, pose, goal_distance, collisions, error = None, Pose(0.1, 0.0, 0.0), 0.9, 0, None
        stopped = 0

        def __init__(self, *args: Any, **kwargs: Any) -> None:
            pass

        def start(self) -> None:
            pass

        def stop(self) -> None:
            os.kill(os.getpid(), signal.SIGINT)  # the second Ctrl-C, while stopping
            World.stopped += 1

    def serve(world: Any, args: Any) -> None:
        os.kill(os.getpid(), signal.SIGINT)  # the first Ctrl-C, while serving
        time.sleep(5.0)  # interrupted at once by the first
        raise AssertionError("the first Ctrl-C did not interrupt serving")

    monkeypatch.setattr(emulated, "EmulatedWorld", World)
    monkeypatch.setattr(realtime, "favour_this_thread", lambda **kw: None)
    monkeypatch.setattr("clomp.runtime.cli.run._serve_world", serve)
    assert cli.main(["emulate", "world", "--scenario", "open"]) == 0
    out = capsys.readouterr().out
    assert World.stopped == 1 and "robot at (0.100, 0.000, 0°), 0.900 m from the goal, 0 collision(s)" in out
