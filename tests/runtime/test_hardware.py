"""The hardware robot backend against the device emulators on real pseudo-terminals."""

from __future__ import annotations

import json
import math
import time
from pathlib import Path

import numpy as np
import pytest

from clomp.formal.geometry import dead_reckon
from clomp.formal.model import Pose
from clomp.runtime.devices.emulators import LidarEmulator, MaestroEmulator
from clomp.runtime.backends.hardware import HardwareConfig, HardwareRobot
from clomp.runtime.interface import Robot, RobotFault
from clomp.runtime.clock import ManualClock
from clomp.runtime.records.runlog import RunLog

NEUTRAL = 6000  # 1500 µs in quarter-µs
WALL = np.array([[0.6, y] for y in np.linspace(-0.3, 0.3, 13)])


def stopped(emu: MaestroEmulator) -> bool:
    return emu.targets[0] in (0, NEUTRAL) and emu.targets[1] in (0, NEUTRAL)


@pytest.fixture
def devices():
    with LidarEmulator(lambda: WALL, speed=2.0) as lidar, MaestroEmulator() as maestro:
        yield lidar, maestro


def open_robot(lidar: LidarEmulator, maestro: MaestroEmulator | None, **config) -> HardwareRobot:
    return HardwareRobot(lidar.port, maestro.port if maestro else None, HardwareConfig(**config))


def records(path: Path) -> list[dict]:
    return [json.loads(line) for line in path.read_text().splitlines()]


def test_is_a_robot_and_reads_robot_frame_scans(devices) -> None:
    lidar, maestro = devices
    with open_robot(lidar, maestro) as robot:
        assert isinstance(robot, Robot)
        frame = robot.read_scan(timeout=10.0)
        assert frame is not None
        assert len(frame.points) >= 10
        assert np.allclose(frame.points[:, 0], 0.6, atol=0.01)  # the wall ahead, x forward
        again = robot.read_scan(timeout=0.0)
        assert again is None or again is not frame  # each revolution is returned once
        assert stopped(maestro)  # opening stops the wheels first


def test_speeds_in_metres_per_second_map_to_normalised_servo_speeds(devices) -> None:
    lidar, maestro = devices
    with open_robot(lidar, maestro) as robot:
        robot.set_wheel_speeds(0.1, -0.05)  # max_speed 0.2 m/s
        assert maestro.wait_for(lambda e: e.speeds != (0.0, 0.0), 10.0)
        assert maestro.speeds == pytest.approx((0.5, -0.25), abs=0.01)
        robot.set_wheel_speeds(0.5, -0.5)  # beyond the top speed: saturated
        assert maestro.wait_for(lambda e: e.speeds[0] > 0.9, 10.0)
        assert maestro.speeds == pytest.approx((1.0, -1.0), abs=0.01)
        assert not robot.wheels_stopped
        robot.stop()
        assert robot.wheels_stopped
        assert maestro.wait_for(stopped, 10.0)
    assert stopped(maestro)


def test_dead_reckoning_follows_the_commands_and_can_be_disabled(devices) -> None:
    lidar, maestro = devices
    clock = ManualClock()  # the robot's time under the test's control: no wall-time luck
    # no watchdog: on a loaded machine its real 0.3 s could pass between two commands and
    # stop the wheels (and, rightly, the reckoning); that is the next test's subject
    with HardwareRobot(lidar.port, maestro.port, HardwareConfig(watchdog_timeout=None), clock=clock) as robot:
        assert robot.odometry() == Pose(0.0, 0.0, 0.0)
        robot.set_wheel_speeds(0.1, 0.1)
        clock.advance(0.25)
        robot.set_wheel_speeds(0.1, 0.1)  # the supervisor repeats its command every tick
        clock.advance(0.25)
        robot.stop()
        pose = robot.odometry()
        assert pose.x == pytest.approx(0.05, abs=1e-12)
        assert pose.y == 0.0 and pose.theta == 0.0
        clock.advance(1.0)
        assert robot.odometry() == pose  # stopped: the pose stays
    with open_robot(lidar, maestro, odometry=False) as robot:
        assert robot.odometry() is None


def test_a_watchdog_stop_stops_the_dead_reckoning_too(devices, tmp_path: Path) -> None:
    """A stalled control loop: no command for the watchdog's timeout, the Maestro stops the
    wheels on its own, and the robot must not go on believing it drives."""
    lidar, maestro = devices
    clock = ManualClock()  # the robot's time; the watchdog keeps its own (real) clock
    with RunLog(tmp_path / "log.jsonl") as log:
        with HardwareRobot(lidar.port, maestro.port, HardwareConfig(watchdog_timeout=0.05), clock=clock,
                           log=log) as robot:
            robot.set_wheel_speeds(0.1, 0.1)
            clock.advance(0.2)
            driver = robot.maestro
            assert driver is not None
            deadline = time.monotonic() + 10.0  # a bound for a broken watchdog, not a timing window
            while driver.watchdog_stops < 1 and time.monotonic() < deadline:
                driver.wait_watchdog(1, timeout=1.0)
            assert driver.watchdog_stops >= 1  # counted only after the robot was told
            assert maestro.wait_for(stopped, 5.0)  # and the device got neutral
            pose = robot.odometry()
            # it drove until the stop: at the robot's time 0 or 0.2, by when the watchdog woke
            assert 0.0 <= pose.x <= 0.02 + 1e-12 and pose.y == 0.0
            clock.advance(10.0)
            assert robot.odometry() == pose  # and not one metre further after it
            # (that reckoning follows commands again is the other reckoning tests' subject:
            # here the 0.05 s watchdog could rightly stop a resumed command on a loaded machine)
    motor = [r for r in records(tmp_path / "log.jsonl") if r["event"] == "motor"]
    assert any(r.get("reason") == "watchdog" and r["left"] == 0.0 for r in motor)


def test_dead_reckoning_is_the_shared_geometry_step_bit_for_bit(devices) -> None:
    """The hardware robot believes what the supervisor's dead reckoning would compute from the
    same commands (clomp.formal.geometry.dead_reckon), through turns past ±180° included."""
    lidar, maestro = devices
    clock = ManualClock()
    rng = np.random.default_rng(3)  # 200 commands, mostly turning: the heading winds round many times
    commands = [((float(a), float(b)), float(dt)) for a, b, dt in
                zip(rng.uniform(-0.2, 0.1, 200), rng.uniform(-0.1, 0.2, 200), rng.uniform(0.05, 0.5, 200))]
    expected = Pose(0.0, 0.0, 0.0)
    with HardwareRobot(lidar.port, maestro.port, HardwareConfig(watchdog_timeout=None), clock=clock) as robot:
        for (left, right), dt in commands:
            robot.set_wheel_speeds(left, right)
            t = clock.now()
            clock.advance(dt)
            expected = dead_reckon(expected, left, right, robot.model.wheel_base, clock.now() - t)
            assert robot.odometry() == expected
        robot.stop()
    assert abs(expected.theta) <= math.pi and expected != Pose(0.0, 0.0, 0.0)


def test_dry_run_holds_the_wheels_stopped_but_reads_and_reckons(devices, tmp_path: Path) -> None:
    lidar, maestro = devices
    with RunLog(tmp_path / "log.jsonl") as log:
        robot = HardwareRobot(lidar.port, maestro.port, HardwareConfig(dry_run=True), log=log)
        with robot:
            assert robot.read_scan(timeout=10.0) is not None
            for _ in range(3):
                robot.set_wheel_speeds(0.1, 0.1)
                time.sleep(0.1)
            assert robot.odometry().x > 0.02  # where it would be
    assert maestro.events and all(target == NEUTRAL for _, _, target in maestro.events)
    motor = [r for r in records(tmp_path / "log.jsonl") if r["event"] == "motor"]
    assert any(r["left"] == 0.1 and r["sent"] == [0.0, 0.0] and r["dry_run"] for r in motor)


def test_dry_run_needs_no_motor_port(devices) -> None:
    lidar, _ = devices
    with open_robot(lidar, None, dry_run=True) as robot:
        robot.set_wheel_speeds(0.1, 0.1)
        robot.stop()
        assert robot.read_scan(timeout=10.0) is not None
    with pytest.raises(ValueError, match="motor port"):
        open_robot(lidar, None)


def test_ports_that_cannot_be_opened_are_robot_faults(devices, tmp_path: Path) -> None:
    lidar, maestro = devices
    with pytest.raises(RobotFault, match="LiDAR port .*missing"):
        HardwareRobot(str(tmp_path / "missing"), maestro.port)
    assert stopped(maestro)
    with pytest.raises(RobotFault, match="motor controller.*missing"):
        HardwareRobot(lidar.port, str(tmp_path / "missing"))


def test_an_unhealthy_or_silent_lidar_fails_at_start(devices) -> None:
    _, maestro = devices
    with LidarEmulator(lambda: WALL, health_status=2, health_error_code=0x8001) as sick:
        with pytest.raises(RobotFault, match="health status 2"):
            HardwareRobot(sick.port, maestro.port)
    with LidarEmulator(lambda: WALL, silent_after=0) as mute:
        mute.silent = True
        t0 = time.monotonic()
        with pytest.raises(RobotFault, match="does not answer"):
            HardwareRobot(mute.port, maestro.port, HardwareConfig(start_timeout=0.3))
        # not before the timeout; how late, on device time: test_hardware_deadlines.py
        assert time.monotonic() - t0 >= 0.3
    assert stopped(maestro)


@pytest.mark.parametrize("fault", ["silent", "garbage", "bad_check", "vanish"])
def test_a_broken_lidar_stream_trips_the_robot_and_stops_the_wheels(devices, fault: str, tmp_path: Path) -> None:
    lidar, maestro = devices
    with RunLog(tmp_path / "log.jsonl") as log, HardwareRobot(lidar.port, maestro.port, log=log) as robot:
        assert robot.read_scan(timeout=10.0) is not None
        robot.set_wheel_speeds(0.1, 0.1)
        assert maestro.wait_for(lambda e: not stopped(e), 10.0)
        if fault == "silent":
            lidar.silent = True
        elif fault == "garbage":
            lidar.garbage_rate = 1.0
        elif fault == "bad_check":
            lidar.bad_check_rate = 1.0
        else:
            lidar.vanish()
        assert maestro.wait_for(stopped, 10.0)  # a bound for a hang, not a timing window
        # the stop is the trip's: how soon it comes (the 300 ms deadline) is tested on device
        # time in test_hardware_deadlines.py, not on this machine's wall clock
        give_up = time.monotonic() + 10.0  # waits for the trip; bounds only a hang
        while robot.fault is None and time.monotonic() < give_up:
            time.sleep(0.01)
        assert robot.fault is not None and "LiDAR" in robot.fault
        with pytest.raises(RobotFault, match="LiDAR") as err:
            robot.read_scan(timeout=0.5)
        with pytest.raises(RobotFault):
            robot.set_wheel_speeds(0.1, 0.1)  # a tripped robot does not drive again
        assert stopped(maestro)
    faults = [r for r in records(tmp_path / "log.jsonl") if r["event"] == "fault"]
    assert faults and faults[0]["reason"] == str(err.value)
    # the trip itself stopped the wheels (the driver's watchdog would too, 0.3 s later)
    after = list(records(tmp_path / "log.jsonl"))
    after = after[after.index(faults[0]):]
    assert any(r["event"] == "motor" and r.get("reason") == "fault" for r in after)
    expected = {"silent": "silent", "garbage": "corrupt", "bad_check": "corrupt", "vanish": "failed"}[fault]
    assert expected in faults[0]["reason"]


def test_a_little_garbage_is_resynchronised_and_tolerated() -> None:
    with LidarEmulator(lambda: WALL, speed=2.0, garbage_rate=0.02, bad_check_rate=0.01, seed=3) as lidar, \
            MaestroEmulator() as maestro, HardwareRobot(lidar.port, maestro.port) as robot:
        frames = []
        give_up = time.monotonic() + 60.0  # frames are counted, not timed: this only bounds a hang
        while len(frames) < 5 and time.monotonic() < give_up:
            frame = robot.read_scan(timeout=0.5)
            if frame is not None:
                frames.append(frame)
        assert robot.fault is None
        assert lidar.garbage_bytes_sent > 0 and robot.lidar.dropped_bytes > 0
        assert len(frames) >= 5
        assert all(np.allclose(f.points[:, 0], 0.6, atol=0.01) for f in frames)


def test_a_vanished_motor_controller_is_a_fault_and_stop_says_so(devices, tmp_path: Path) -> None:
    lidar, maestro = devices
    with RunLog(tmp_path / "log.jsonl") as log:
        robot = HardwareRobot(lidar.port, maestro.port, log=log)
        robot.set_wheel_speeds(0.1, 0.1)
        maestro.vanish()
        with pytest.raises(RobotFault, match="motor controller on .* failed"):
            robot.set_wheel_speeds(0.1, 0.1)
        with pytest.raises(RobotFault, match="could not stop the wheels"):
            robot.stop()
        assert not robot.wheels_stopped  # nobody may believe they are
        robot.close()  # never raises
        robot.close()
        assert not robot.wheels_stopped
    recs = records(tmp_path / "log.jsonl")
    assert any(r["event"] == "fault" and r["source"] == "motors" for r in recs)
    assert any(r["event"] == "motor" and "could not stop" in r.get("error", "") for r in recs)


def test_non_finite_speeds_stop_the_wheels(devices) -> None:
    lidar, maestro = devices
    with open_robot(lidar, maestro) as robot:
        robot.set_wheel_speeds(0.1, 0.1)
        assert maestro.wait_for(lambda e: not stopped(e), 10.0)
        with pytest.raises(RobotFault, match="non-finite"):
            robot.set_wheel_speeds(math.nan, 0.1)
        assert maestro.wait_for(stopped, 10.0)  # sent before the raise; real time only bounds a hang


def test_config_rejects_nonsense() -> None:
    from clomp.runtime.devices.maestro import WheelConfig

    with pytest.raises(ValueError, match="different Maestro channels"):
        HardwareConfig(left=WheelConfig(2), right=WheelConfig(2, -1))
    with pytest.raises(ValueError, match="byte_timeout"):
        HardwareConfig(byte_timeout=0)
    with pytest.raises(ValueError, match="garbage_fraction"):
        HardwareConfig(garbage_fraction=1.5)


def test_reverse_drives_both_servos_backwards_and_wait_holds_them_stopped(devices) -> None:
    """The motor law of a REVERSE (negative wheel speeds) and of a WAIT (zero) reach the
    Maestro as they are (issue #42)."""
    from clomp.formal.model import Disturbance
    from clomp.planner.robot_model import RobotModel
    from clomp.planner.tasks import Task

    lidar, maestro = devices
    model, start, goal = RobotModel(), Pose(0.0, 0.0), Disturbance.goal(1.0, 0.0)
    back = Task.reverse(model, start, goal, 0.15)
    wait = Task.wait(model, start, goal, 2.0)
    with open_robot(lidar, maestro) as robot:
        robot.set_wheel_speeds(*back.wheel_speeds(back.error(start)))
        assert maestro.wait_for(lambda e: e.speeds != (0.0, 0.0), 10.0)
        assert maestro.speeds == pytest.approx((-0.5, -0.5), abs=0.01)
        robot.set_wheel_speeds(*wait.wheel_speeds(wait.error(start)))
        assert maestro.wait_for(stopped, 10.0)
