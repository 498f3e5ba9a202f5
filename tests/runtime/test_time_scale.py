"""``clomp run --time-scale K``: the hardware robot hands the supervisor revolutions on its
ScaledClock, not on the wall time the LiDAR's driver stamps them with (issue #36: at K = 2
two runs of ten missed; the supervisor took every revolution for one of another clock and
de-skewed the turns by wall seconds, half the motion). (The IMU's turn limit needs no such
care: the driver times reports by their index, 100 a second, and the emulated world at K
sends 100 K a second of wall time, so the index counts the world's seconds.)"""

from __future__ import annotations

import numpy as np

from clomp.runtime.backends.hardware import HardwareConfig, HardwareRobot, on_clock
from clomp.runtime.clock import ManualClock, ScaledClock, WallClock
from clomp.runtime.devices.emulators import LidarEmulator, MaestroEmulator
from clomp.runtime.interface import ScanFrame

WALL = np.array([[0.6, y] for y in np.linspace(-0.3, 0.3, 13)])


def test_a_revolution_moves_onto_a_scaled_clock() -> None:
    clock = ScaledClock(2.0)
    wall_stamp = clock._origin + 3.0  # 3 s of wall time after the clock started: 6 s on it
    frame = on_clock(ScanFrame(WALL, wall_stamp, point_times=np.linspace(-0.09, 0.0, len(WALL))), clock)
    assert abs(frame.timestamp - 6.0) < 1e-9
    assert frame.point_times is not None and np.allclose(frame.point_times, np.linspace(-0.18, 0.0, len(WALL)))
    assert np.array_equal(frame.points, WALL)


def test_on_a_wall_or_simulated_clock_a_revolution_is_left_as_it_is() -> None:
    frame = ScanFrame(WALL, 12.5, point_times=np.linspace(-0.18, 0.0, len(WALL)))
    assert on_clock(frame, WallClock()) is frame  # devices stamp wall time: the same clock
    assert on_clock(frame, ManualClock(12.5)) is frame  # devices read the simulated clock itself


def test_the_hardware_robot_on_a_scaled_clock_delivers_revolutions_on_it() -> None:
    clock = ScaledClock(2.0)
    with LidarEmulator(lambda: WALL, speed=2.0) as lidar, MaestroEmulator() as maestro, \
            HardwareRobot(lidar.port, maestro.port, HardwareConfig(), clock=clock) as robot:
        frame = robot.read_scan(timeout=10.0)
        now = clock.now()
    assert frame is not None
    # on the clock (seconds since it started, doubled), not on time.monotonic (the host's uptime)
    assert 0.0 < frame.timestamp <= now

