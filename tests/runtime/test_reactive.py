"""The reactive baseline: reaches a free goal, bounces off the overtaking box, halts on faults."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner import load_scenario
from runtime.experiment.reactive import ReactiveController
from runtime.robot import ScanFrame
from runtime.robots.sim import SimRobot


def test_reaches_a_goal_in_free_space_without_collision():
    scene = load_scenario("open")
    sim = SimRobot(scene, seed=0)
    rep = ReactiveController(sim, scene.goal_in_robot_frame()).run(max_time=60)
    assert rep.reached_goal and rep.avoid_ticks == 0
    assert math.hypot(sim.pose.x - 1.0, sim.pose.y) <= 0.1
    assert sim.collisions == 0 and sim.commanded == (0.0, 0.0)


def test_turns_away_from_a_disturbance_one_loop_ahead():
    scene = load_scenario("overtaking")
    sim = SimRobot(scene, seed=0)
    rep = ReactiveController(sim, scene.goal_in_robot_frame()).run(max_time=120)
    assert rep.avoid_ticks > 0
    # one loop ahead is too late with a 5.5 Hz LiDAR: it hits the box, as in the paper
    assert sim.collisions >= 1
    assert sim.commanded == (0.0, 0.0)


def test_a_scan_with_nan_halts_with_wheels_stopped():
    scene = load_scenario("open")
    sim = SimRobot(scene, seed=0)

    class Bad:
        def __getattr__(self, name):
            return getattr(sim, name)

        def read_scan(self, timeout=None):
            f = sim.read_scan(timeout)
            if f is None or sim.now() < 2.0:
                return f
            return ScanFrame(np.array([[np.nan, 0.0]]), f.timestamp)

    rep = ReactiveController(Bad(), (1.0, 0.0)).run(max_time=60)
    assert rep.state == "HALTED" and "not finite" in rep.reason
    assert sim.commanded == (0.0, 0.0)
    assert 0.1 < sim.pose.x < 0.5


def test_times_out_with_wheels_stopped():
    scene = load_scenario("blocked")
    sim = SimRobot(scene, seed=0)
    rep = ReactiveController(sim, (1.0, 0.0)).run(max_time=5.0)
    assert rep.state == "TIMEOUT" and rep.time_s == pytest.approx(5.0, abs=0.11)
    assert sim.commanded == (0.0, 0.0)


def test_reactive_rejects_a_non_finite_goal():
    import math as _math

    from planner import load_scenario
    from runtime.experiment.reactive import ReactiveController
    from runtime.robots.sim import SimRobot

    with pytest.raises(ValueError, match="finite"):
        ReactiveController(SimRobot(load_scenario("open"), seed=0), (_math.nan, 0.0))
