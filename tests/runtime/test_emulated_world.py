"""The emulated world: wheel commands take effect when they arrive, and the world can run in a
process of its own (the face the ``clomp run`` end-to-end tests use)."""

from __future__ import annotations

import os
import time

import numpy as np
import pytest

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.rplidar import RPLidar
from clomp.runtime.realtime import NICENESS
from clomp.runtime.backends.emulated import EmulatedWorld, EmulatedWorldProcess
from clomp.runtime.backends.sim import NoiseConfig
from tests.runtime._simline import SimLine


def test_a_wheel_command_drives_the_world_from_the_moment_it_arrived() -> None:
    """Between ticks too: the world is brought up to the command's arrival at the old speeds,
    so the distance driven is the speed times the time between the commands, not a tick's worth."""
    world = EmulatedWorld("open", noise=NoiseConfig.ideal(), tick=3600.0)  # the world thread never ticks
    with world:
        vmax = world.model.max_speed
        before_go = time.monotonic()
        world._on_speeds(0.5, 0.5)  # what the Maestro emulator calls on a decoded command
        after_go = time.monotonic()
        time.sleep(0.2)
        before_stop = time.monotonic()
        world._on_speeds(0.0, 0.0)
        after_stop = time.monotonic()
        x = world.pose.x
    assert 0.5 * vmax * (before_stop - after_go) <= x <= 0.5 * vmax * (after_stop - before_go)


def test_the_world_in_its_own_process_answers_like_the_one_in_this_process() -> None:
    with EmulatedWorldProcess("open", seed=3) as world:
        assert world.alive and world.lidar_port.startswith("/dev/") and world.motor_port.startswith("/dev/")
        assert world.scene.name == "open" and world.collisions == 0 and world.error is None
        assert world.maestro.speeds == (0.0, 0.0) and world.maestro.running
        world.lidar.garbage_rate = 0.25  # a fault switched on in the child
        assert world.lidar.garbage_rate == 0.25
        assert world.lidar.wait_for(lambda e: e.clock() > 0 and e.passes > 3, 10.0)
        with pytest.raises(AttributeError):
            getattr(world.lidar, "no_such_attribute")  # noqa: B009 - the read is the test
        if os.geteuid() == 0:  # may raise its priority: it did
            assert world.scheduling == "realtime"
        else:
            assert world.scheduling in ("normal", f"nice {NICENESS}", "realtime")
    assert not world.alive
    world.stop()  # idempotent


def test_a_world_that_cannot_start_says_why_in_the_parent() -> None:
    with pytest.raises(Exception, match="no-such-scenario"):
        EmulatedWorldProcess("no-such-scenario").start()


def test_the_emulated_lidar_sends_each_revolution_when_the_world_measured_it() -> None:
    """Through the A1's bytes and the real driver: a revolution reaches the driver when the
    world's LiDAR finished it (within a physics step and the emulator's tick, not a
    revolution later), with the points the world measured (to the 1 cm grid's angle), and,
    once the driver has timed a revolution, with each point's time from its place in the
    sweep — so a revolution taken while turning is de-skewed on the hardware stack too."""
    clock = ManualClock(100.0)
    world = EmulatedWorld("overtaking", noise="harsh", seed=1, clock=clock)
    world._on_speeds(0.2, 0.6)  # from t = 100: driving along a curve, every revolution skewed
    lidar = RPLidar(SimLine(world.lidar, clock, name="sim-lidar"), motor_control="none", clock=clock.now)
    try:
        frames = []
        for _ in range(6):
            got = lidar.read_scan(timeout=2.0, newest=False)
            frames.append((got, world.sim.newest_revolution()))
    finally:
        lidar.close()
    assert frames[0][0].point_times is None  # no period measured yet: no times rather than wrong ones
    for k, (got, truth) in enumerate(frames):
        assert truth is not None
        assert 0.0 <= (got.timestamp - 100.0) - truth.timestamp <= 0.02
        assert len(got.points) == len(truth.points) > 10
        assert np.max(np.hypot(*(got.points - truth.points).T)) <= 0.008  # the nominal angle, the grid's range
        if k:
            assert got.point_times is not None
            assert np.max(np.abs(got.point_times - truth.point_times)) <= 0.015
    assert abs(lidar.period - 1 / 5.5) < 0.005
