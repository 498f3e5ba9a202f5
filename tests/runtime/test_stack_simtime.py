"""The whole hardware stack closing the loop in simulated time: drivers, hardware robot and
supervisor against the device emulators and a scenario's world, with no pty and no wall clock.

The same runs over ptys in real time (test_run_cli.py) measure the scheduler as much as the
software on a loaded machine, so they are kept out of the default suite. Here the devices are
the emulator logic on :class:`SimLine` and time is a :class:`LockstepClock`: it flows only
while the supervisor sleeps between ticks, so planning costs no simulated time (an
idealisation: the real-time cost is what the pty tests measure) and a run's outcome does not
depend on how busy the machine is.
"""

from __future__ import annotations

import pytest

from tests.runtime._stack import NEUTRAL, run_stack


def test_overtaking_reaches_the_goal_through_the_hardware_stack_in_simulated_time() -> None:
    run = run_stack("overtaking")
    assert run.report.state.value in ("GOAL_REACHED", "GOAL_UNCONFIRMED"), run.report
    assert run.world.goal_distance <= 0.12, run.world.pose  # truly there, not only by dead reckoning
    assert run.world.collisions == 0
    assert run.world.maestro.speeds == (0.0, 0.0)
    assert run.robot.fault is None and run.world.lidar.error is None and run.world.maestro.error is None
    assert run.robot.scans >= 5 * run.elapsed * 0.9  # the A1's ~5.5 revolutions/s of simulated time
    moved = [t for _, ch, t in run.world.maestro.events if ch in (0, 1) and t not in (0, NEUTRAL)]
    assert moved, "the wheels were never commanded"


def test_a_little_line_garbage_is_tolerated_and_the_run_still_works_in_simulated_time() -> None:
    faults = {"garbage_rate": 0.02, "bad_check_rate": 0.01, "seed": 7}
    run = run_stack("open", lidar_options=faults)
    assert run.report.state.value in ("GOAL_REACHED", "GOAL_UNCONFIRMED"), run.report
    assert run.world.goal_distance <= 0.12, run.world.pose
    assert run.world.lidar.garbage_bytes_sent > 0
    assert run.robot.fault is None


@pytest.mark.parametrize(("noise", "at_least"), [("harsh-modelled", 2), ("harsh", 1)])
def test_the_hardware_stack_closes_the_loop_in_the_harsh_world_in_simulated_time(noise: str, at_least: int) -> None:
    """Four harsh worlds (noise seeds 0-3) through the real drivers, with no IMU: every run
    ends at the goal or honestly unconfirmed, never claims a goal it is truly more than 0.1 m
    from, never collides, and stops the wheels; at least ``at_least`` end truly within 0.15 m.
    Measured on 16 seeds (2026-12-06, with CONFIRMING): ``harsh-modelled`` (the world the
    filter models) 7 within 0.15 m, median 0.157 m; ``harsh`` (with the error sources the
    filter does not model: a wandering wheel bias, slip events, the LiDAR 5 cm ahead, pushes)
    3 within 0.15 m, median 0.221 m, and one collision (seed 13). All 32 ended
    GOAL_UNCONFIRMED: without a heading sensor this stack cannot vouch for the goal in these
    worlds, and says so. The bounds are what the 16 seeds support, not what these four give."""
    near = 0
    for seed in range(4):
        run = run_stack("overtaking", noise=noise, max_time=90.0, seed=seed)
        assert run.report is not None and run.report.state.value in ("GOAL_REACHED", "GOAL_UNCONFIRMED"), (seed, run.report)
        assert run.report.state.value != "GOAL_REACHED" or run.world.goal_distance <= 0.1, (seed, run.world.goal_distance)
        assert run.world.collisions == 0, seed
        last = {ch: t for _, ch, t in run.world.maestro.events if ch in (0, 1)}
        assert last and all(t in (0, NEUTRAL) for t in last.values()), (seed, last)
        near += run.world.goal_distance <= 0.15
    assert near >= at_least, near


def test_a_run_in_simulated_time_is_the_same_run_every_time() -> None:
    """What makes the runs above independent of the machine's load: the same seed gives the
    same wheel commands, at the same simulated times, and the same end pose."""
    a, b = run_stack("open"), run_stack("open")
    assert a.world.maestro.events == b.world.maestro.events
    assert a.world.pose == b.world.pose and a.elapsed == b.elapsed
