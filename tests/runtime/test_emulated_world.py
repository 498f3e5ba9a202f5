"""The emulated world: wheel commands take effect when they arrive, and the world can run in a
process of its own (the face the ``clomp run`` end-to-end tests use)."""

from __future__ import annotations

import os
import time

import pytest

from runtime.realtime import NICENESS
from runtime.robots.emulated import EmulatedWorld, EmulatedWorldProcess
from runtime.robots.sim import NoiseConfig


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
