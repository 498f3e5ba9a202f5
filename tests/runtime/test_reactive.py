"""The reactive baseline: reaches a free goal, bounces off the overtaking box, halts on faults."""

from __future__ import annotations

import math

import numpy as np
import pytest

from planner import load_scenario
from planner.robot import RobotModel
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
    assert sim.commanded == (0.0, 0.0)


class _Still:
    """A robot that stands still and always sees the same points (robot frame)."""

    def __init__(self, points):
        self.points = np.asarray(points, float).reshape(-1, 2)
        self.t = 0.0
        self.commands = []

    def read_scan(self, timeout=None):
        return ScanFrame(self.points, self.t)

    def set_wheel_speeds(self, left, right):
        self.commands.append((left, right))

    def stop(self):
        pass

    def odometry(self):
        from formal.model import Pose

        return Pose(0.0, 0.0, 0.0)

    def close(self):
        pass

    def now(self):
        return self.t

    def sleep(self, s):
        self.t += max(0.0, s)


def _first_command(points):
    robot = _Still(points)
    ReactiveController(robot, (1.0, 0.0)).run(max_time=0.25)
    return robot.commands[0]


FRONT = RobotModel().front_offset


@pytest.mark.parametrize("points, expect", [
    ([[FRONT + 0.25, 0.05], [FRONT + 0.25, 0.06]], "right"),  # within one straight step, left of the heading
    ([[FRONT + 0.25, -0.05], [FRONT + 0.25, -0.06]], "left"),
    ([[FRONT + 0.30, 0.0], [FRONT + 0.31, 0.0]], "ahead"),  # beyond one step (0.27 m): not yet a disturbance
    ([[FRONT + 0.1, 0.12], [FRONT + 0.1, -0.12]], "ahead"),  # beside the body's corridor
    ([[FRONT + 0.1, 0.0]], "ahead"),  # a single point may be noise
])
def test_the_look_ahead_is_the_body_corridor_over_one_straight_step(points, expect):
    left, right = _first_command(points)
    got = "ahead" if left > 0 and right > 0 else ("right" if left > right else "left")
    assert got == expect


def test_keeps_turning_the_same_way_until_clear():
    left_first = [[FRONT + 0.2, 0.02], [FRONT + 0.22, -0.03]]
    right_first = [[FRONT + 0.2, -0.02], [FRONT + 0.22, 0.04]]

    class Changing(_Still):
        def read_scan(self, timeout=None):
            k = len(self.commands)
            pts = left_first if k < 3 else right_first if k < 6 else [[FRONT + 0.2, 0.5]]
            return ScanFrame(np.asarray(pts, float), self.t)

    robot = Changing([])
    ReactiveController(robot, (1.0, 0.0)).run(max_time=0.75)
    turns = robot.commands[:6]
    assert all(c == turns[0] for c in turns) and turns[0][0] > turns[0][1]  # right, all along
    assert robot.commands[6][0] > 0 and robot.commands[6][1] > 0  # clear: towards the goal again


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="look_ahead"):
        ReactiveController(_Still([]), (1.0, 0.0), look_ahead=0.0)
    with pytest.raises(ValueError, match="hazard_points"):
        ReactiveController(_Still([]), (1.0, 0.0), hazard_points=0)


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


def _estimate_error(feedback: str) -> tuple[str, float]:
    from formal.geometry import compose
    from runtime.experiment.layouts import make_layout
    from runtime.robots.world import WorldNoise, make_world_robot

    scene = make_layout("corridor", 0, 0).scene  # walls either side: scan matching has surfaces to hold
    robot = make_world_robot(scene, WorldNoise(wheel_bias=0.05, wheel_sd=0.01), seed=0)
    ctl = ReactiveController(robot, scene.goal_in_robot_frame(), feedback=feedback)
    rep = ctl.run(max_time=60)
    true, est = robot.ground_truth_pose(), compose(scene.start, ctl.pose)
    return rep.state, math.hypot(true.x - est.x, true.y - est.y)


def test_scan_feedback_corrects_the_estimate_as_the_planning_condition_does():
    # the same robot, the same sensing: with a 5 % wheel bias dead reckoning drifts
    # (5 cm over the corridor); the supervisor's scan odometry keeps the estimate on the truth
    state, err_scan = _estimate_error("scan")
    _, err_none = _estimate_error("none")
    assert state == "GOAL_REACHED"
    assert err_scan < 0.02 < err_none


def test_feedback_must_be_scan_or_none():
    with pytest.raises(ValueError, match="feedback"):
        ReactiveController(_Still([]), (1.0, 0.0), feedback="icp")
