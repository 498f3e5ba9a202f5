"""The LiDAR stream watch's safety deadline, on device time: a broken stream stops the wheels
within 300 ms of the fault, whatever else the machine is doing.

The same claim is tested end to end on pty emulators in real time (test_hardware.py and
test_run_cli.py), where a fully loaded machine can delay any thread. Here the devices are the
same emulator logic on a :class:`SimLine` (simulated time that moves only while the driver
waits for bytes), so the latency measured is the watch's own windows and timeouts.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.emulators import LidarEmulator, MaestroEmulator
from clomp.runtime.interface import RobotFault
from clomp.runtime.backends.hardware import HardwareConfig, HardwareRobot
from tests.runtime._simline import SimLine

NEUTRAL = 6000  # 1500 µs in quarter-µs
WALL = np.array([[0.6, y] for y in np.linspace(-0.3, 0.3, 13)])


def _stop_time(maestro: MaestroEmulator, t0: float) -> float | None:
    """Device time at which both wheels were last commanded to a stop at or after ``t0``."""
    targets: dict[int, int | None] = {0: None, 1: None}
    for t, ch, target in maestro.events:
        if ch in targets:
            targets[ch] = target
            if t >= t0 and all(v in (0, NEUTRAL) for v in targets.values()):
                return t
    return None


@pytest.mark.parametrize(
    ("fault", "value", "said"),
    [("silent", True, "silent"), ("garbage_rate", 1.0, "corrupt"), ("bad_check_rate", 1.0, "corrupt")],
)
def test_a_broken_stream_stops_the_wheels_within_300_ms_of_device_time(fault: str, value: float, said: str) -> None:
    clock, lock = ManualClock(100.0), threading.RLock()
    lidar = LidarEmulator(lambda: WALL, seed=1, clock=clock.now)  # not started: no pty, no thread
    maestro = MaestroEmulator(clock=clock.now)
    lidar_line = SimLine(lidar, clock, lock=lock, name="sim-lidar")
    motor_line = SimLine(maestro, clock, lock=lock, name="sim-maestro")
    config = HardwareConfig(watchdog_timeout=None)  # the Maestro's watchdog: not under test here
    with HardwareRobot(lidar_line, motor_line, config, clock=clock) as robot:  # the devices read clock.now
        assert robot.read_scan(timeout=30.0) is not None
        robot.set_wheel_speeds(0.1, 0.1)
        with lock:  # no simulated time passes between the command and the fault
            assert _stop_time(maestro, clock.now()) is None
            t0 = lidar.inject(**{fault: value})
        # wait for the stop command itself as the event (the fault is latched before the wheels
        # are commanded, so waiting for the fault alone raced the command); real time only
        # bounds a hang
        give_up = time.monotonic() + 60.0
        while (stop_t := _stop_time(maestro, t0)) is None and time.monotonic() < give_up:
            time.sleep(0.005)
        assert stop_t is not None, "the wheels were never commanded to stop"
        assert robot.fault is not None and said in robot.fault, robot.fault
        assert stop_t - t0 < 0.3, f"wheels stopped {stop_t - t0:.3f} s (device time) after the {fault} fault"


def test_a_silent_lidar_fails_the_start_after_the_start_timeout_of_device_time() -> None:
    """The pty version (test_hardware.py) shows the message; this one how long it takes."""
    clock, lock = ManualClock(100.0), threading.RLock()
    lidar = LidarEmulator(lambda: WALL, silent_after=0, clock=clock.now)
    lidar.silent = True
    maestro = MaestroEmulator(clock=clock.now)
    config = HardwareConfig(watchdog_timeout=None, start_timeout=0.3)
    t0 = clock.now()
    with pytest.raises(RobotFault, match="does not answer"):
        HardwareRobot(SimLine(lidar, clock, lock=lock, name="sim-lidar"),
                      SimLine(maestro, clock, lock=lock, name="sim-maestro"), config,
                      clock=clock)
    assert 0.3 <= clock.now() - t0 <= 0.3 + 0.01 + 1e-9  # not before it, late by at most one read (10 ms)
    assert _stop_time(maestro, t0) is not None  # the wheels were held stopped meanwhile


@pytest.mark.parametrize(("fault", "said"), [("silent", "fell silent"), ("garbage_only", "corrupt")])
def test_an_imu_fault_stops_the_wheels_from_the_imus_reader_within_its_deadline(fault: str, said: str) -> None:
    """Nothing asks the robot's rotation() here: the IMU's reader trips the robot itself
    (Bno08xRvc.on_fault), 0.2 s after the last report plus one read at most."""
    from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator

    clock, lock = ManualClock(100.0), threading.RLock()
    lidar = LidarEmulator(lambda: WALL, seed=1, clock=clock.now)
    maestro = MaestroEmulator(clock=clock.now)
    imu = Bno08xEmulator(lambda: 0.0, seed=1, clock=clock.now)
    # the LiDAR is paused below: its stream watch must not be what trips the robot
    config = HardwareConfig(watchdog_timeout=None, byte_timeout=30.0)
    lidar_line = SimLine(lidar, clock, lock=lock, name="sim-lidar")
    with HardwareRobot(lidar_line, SimLine(maestro, clock, lock=lock, name="sim-maestro"), config, clock=clock,
                       imu_port=SimLine(imu, clock, lock=lock, name="sim-imu")) as robot:
        assert robot.read_scan(timeout=30.0) is not None
        assert robot.imu is not None and robot.imu.wait_for(lambda i: i.decoder.reports >= 20, 30.0)
        lidar_line.running.clear()  # from here only the IMU's reader lets time pass: its deadline alone
        robot.set_wheel_speeds(0.1, 0.1)
        with lock:
            assert _stop_time(maestro, clock.now()) is None
            t0 = imu.inject(**{fault: True})
        give_up = time.monotonic() + 60.0
        while (stop_t := _stop_time(maestro, t0)) is None and time.monotonic() < give_up:
            time.sleep(0.005)
        assert stop_t is not None, "the wheels were never commanded to stop"
        assert robot.fault is not None and said in robot.fault and "IMU" in robot.fault, robot.fault
        assert stop_t - t0 <= 0.2 + 0.02 + 0.001, f"wheels stopped {stop_t - t0:.3f} s after the IMU's {fault}"
        lidar_line.running.set()
