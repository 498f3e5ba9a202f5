"""The emulated world: wheel commands take effect when they arrive, and the world can run in a
process of its own (the face the ``clomp run`` end-to-end tests use)."""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
import sys
import time

import numpy as np
import pytest

from clomp.planner.noise import NoiseTerms
from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.rplidar import RPLidar
from clomp.runtime.realtime import NICENESS
from clomp.runtime.backends.emulated import IMPACT, EmulatedWorld, EmulatedWorldProcess
from clomp.runtime.backends.sim import NoiseConfig
from clomp.runtime.backends.world import WorldRobot
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
    sim = world.sim
    assert isinstance(sim, WorldRobot)
    lidar = RPLidar(SimLine(world.lidar, clock, name="sim-lidar"), motor_control="none", clock=clock.now)
    try:
        frames = []
        for _ in range(6):
            got = lidar.read_scan(timeout=2.0, newest=False)
            frames.append((got, sim.newest_revolution()))
    finally:
        lidar.close()
    assert frames[0][0].point_times is None  # no period measured yet: no times rather than wrong ones
    for k, (got, truth) in enumerate(frames):
        assert truth is not None
        assert 0.0 <= (got.timestamp - 100.0) - truth.timestamp <= 0.02
        assert len(got.points) == len(truth.points) > 10
        # the A1 sends its own frame: at harsh 5 cm ahead of the centre, where the world's revolution is
        mine = truth.points - np.array(sim.told_mount[:2])
        assert np.max(np.hypot(*(got.points - mine).T)) <= 0.008  # the nominal angle, the grid's range
        if k:
            assert got.point_times is not None
            assert np.max(np.abs(got.point_times - truth.point_times)) <= 0.015
    assert lidar.period is not None and abs(lidar.period - 1 / 5.5) < 0.005


def test_a_world_nobody_drives_is_held_before_and_after_the_run() -> None:
    """Served before ``clomp run`` starts scanning (a user typing the command) the world's time
    does not run: a harsh world that pushes every 2 s on average leaves the robot at the
    scenario's start however long it waits; once the LiDAR scans it runs (and pushes);
    when the scan stops it runs on only until the robot is at rest, then is held again."""
    noise = dataclasses.replace(NoiseTerms.preset("harsh"), push_rate=0.5)
    clock = ManualClock(100.0)
    world = EmulatedWorld("overtaking", noise=noise, seed=2, clock=clock)
    start = world.pose
    for _ in range(300):  # 60 s of devices asking, no scan and no wheel command
        clock.advance(0.2)
        world._heading()
    assert world.sim_time == 0.0 and world.pose == start and world.pushes == []
    world.lidar.scanning = True  # what the A1 emulator sets on a SCAN request
    for _ in range(150):
        clock.advance(0.2)
        world._heading()
    assert world.sim_time == pytest.approx(30.0, abs=0.02) and world.pushes  # pushed while it ran
    world.lidar.scanning = False  # the run ended (STOP)
    for _ in range(150):
        clock.advance(0.2)
        world._heading()
    held_at, pushes, pose = world.sim_time, len(world.pushes), world.pose
    assert held_at <= 31.0  # ran on at most while a slide ended, then held
    for _ in range(150):
        clock.advance(0.2)
        world._heading()
    assert (world.sim_time, len(world.pushes), world.pose) == (held_at, pushes, pose)


@pytest.mark.slow
def test_the_world_loads_its_compiled_ray_caster_before_it_serves() -> None:
    """In a fresh interpreter, a built world has already loaded its compiled ray caster: its
    first load (1.5 s on a busy host, the world's lock held) must not come when ``clomp run``
    starts the LiDAR, where it stalled the IMU's reports into a 'fell silent' fault."""
    code = ("from clomp.runtime.backends import _raycast\n"
            "from clomp.runtime.backends.emulated import EmulatedWorld\n"
            "assert not _raycast._first_hits.signatures\n"
            "EmulatedWorld('overtaking', noise='harsh', seed=0)\n"
            "print(len(_raycast._first_hits.signatures))\n")
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=300)
    assert done.returncode == 0 and done.stdout.strip() == "1", done.stderr


def test_a_kick_is_felt_for_a_contact_s_three_reports_not_one() -> None:
    """The world's push changes the body's velocity within one physics step; the emulated
    accelerometer feels it for IMPACT s (three 10 ms reports), so a report the line loses
    (one in ten at harsh) does not lose the kick: after a push of 0.2 m the three readings
    each carry its 169 m/s², the fourth only the slide's grip (7.8)."""
    clock = ManualClock(100.0)
    world = EmulatedWorld("overtaking", noise="ideal", seed=0, clock=clock)
    world.lidar.scanning = True  # the world runs
    for _ in range(5):
        clock.advance(0.01)
        assert max(map(abs, world._acceleration())) < 1.0  # standing
    world.sim.push(0.2, 0.0)  # type: ignore[union-attr]
    felt = []
    for _ in range(5):
        clock.advance(0.01)
        felt.append(math.hypot(*world._acceleration()))
    assert IMPACT == 0.03
    assert [round(a) for a in felt[:3]] == [round(felt[0])] * 3 and felt[0] > 100.0
    assert 5.0 < felt[3] < 10.0 and 5.0 < felt[4] < 10.0
