"""The reactive baseline: the authors' task structure (quarter turns, one-step straights), the look-ahead, faults."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clomp.planner import load_scenario
from clomp.planner.robot_model import RobotModel
from clomp.runtime.experiment.reactive import ReactiveController
from clomp.runtime.interface import ScanFrame
from clomp.runtime.backends.sim import SimRobot


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
        from clomp.formal.model import Pose

        return Pose(0.0, 0.0, 0.0)

    def close(self):
        pass

    def now(self):
        return self.t

    def sleep(self, s):
        self.t += max(0.0, s)


def _first_command(points, goal=(1.0, 0.0), **kw):
    robot = _Still(points)
    ReactiveController(robot, goal, **kw).run(max_time=0.25)
    return robot.commands[0]


def _kind(command):
    left, right = command
    return "ahead" if left > 0 and right > 0 else ("right" if left > right else "left")


FRONT = RobotModel().front_offset


STEP = RobotModel().step_length


@pytest.mark.parametrize("points, goal, expect", [
    ([[FRONT + 0.25, 0.05], [FRONT + 0.25, 0.06]], (1.0, 0.0), "right"),  # left of the heading: turn right
    ([[FRONT + 0.25, -0.05], [FRONT + 0.25, -0.06]], (1.0, 0.0), "left"),
    ([[FRONT + STEP - 0.01, 0.01], [FRONT + STEP - 0.005, 0.0]], (1.0, 0.0), "right"),  # within one step
    ([[FRONT + STEP + 0.01, 0.01], [FRONT + STEP + 0.02, 0.0]], (1.0, 0.0), "ahead"),  # beyond one step
    ([[FRONT + 0.16, 0.0], [FRONT + 0.17, 0.0]], (0.15, 0.0), "ahead"),  # beyond the goal
    ([[FRONT + 0.1, 0.12], [FRONT + 0.1, -0.12]], (1.0, 0.0), "ahead"),  # beside the body's corridor
    ([[FRONT + 0.1, 0.0]], (1.0, 0.0), "ahead"),  # a single point may be noise
    # away from the centre of the points' lateral extent (the crashed-into body's), not the nearest point
    ([[FRONT + 0.1, -0.02], [FRONT + 0.2, 0.09], [FRONT + 0.2, 0.08]], (1.0, 0.0), "right"),
])
def test_the_look_ahead_is_the_body_corridor_over_one_straight_step(points, goal, expect):
    # the authors' Task::willCollide ends the simulated straight after simulationStep (0.27 m);
    # signed sides, so that the side taken shows which points were seen
    assert _kind(_first_command(points, goal, sides="signed")) == expect


def test_a_longer_look_ahead_is_a_probe_up_to_the_goal():
    far = [[FRONT + 0.95, 0.01], [FRONT + 0.96, 0.0]]
    assert _kind(_first_command(far, (1.0, 0.0), look_ahead=1.0)) == "right"
    assert _kind(_first_command(far, (0.5, 0.0), look_ahead=1.0)) == "ahead"  # beyond the goal


def test_by_default_it_always_avoids_right_and_pursues_left_as_the_authors_code_ran():
    # their Disturbance::getAngle is acos(...), never negative (see the module docstring)
    right_of_heading = [[FRONT + 0.25, -0.05], [FRONT + 0.25, -0.06]]
    assert _kind(_first_command(right_of_heading)) == "right"
    assert _kind(_first_command([], (1.0, -0.5))) == "left"
    assert _kind(_first_command(right_of_heading, sides="signed")) == "left"
    assert _kind(_first_command([], (1.0, -0.5), sides="signed")) == "right"


def test_without_detection_it_is_a_blind_pursuer():
    # the authors' reactive branch before 2024-10-09 simulated the task in a world with no bodies
    assert _kind(_first_command([[FRONT + 0.25, 0.05], [FRONT + 0.25, 0.06]], detect=False)) == "ahead"


class _Driven(_Still):
    """A robot without odometry: the controller dead-reckons its commands; scans by tick."""

    def __init__(self, scans):
        super().__init__([])
        self.scans = scans

    def odometry(self):
        return None

    def read_scan(self, timeout=None):
        return ScanFrame(np.asarray(self.scans(len(self.commands)), float).reshape(-1, 2), self.t)


def _runs(commands):
    """[(kind, ticks)] of consecutive equal commands."""
    out: list[list] = []
    for c in commands:
        k = _kind(c)
        if out and out[-1][0] == k:
            out[-1][1] += 1
        else:
            out.append([k, 1])
    return [tuple(r) for r in out]


def test_an_avoiding_turn_is_a_blind_quarter_turn_then_one_straight_step():
    # a disturbance left of the heading for 3 ticks, then one right of it while turning, then clear
    def scans(k):
        return [[FRONT + 0.2, 0.05], [FRONT + 0.2, 0.06]] if k < 3 else [[FRONT + 0.2, -0.05], [FRONT + 0.2, -0.06]] \
            if k < 10 else [[FRONT + 0.2, 1.5]]

    robot = _Driven(scans)
    rep = ReactiveController(robot, (1.0, 0.0), feedback="none").run(max_time=9.0)
    m = RobotModel()
    quarter = round((m.turn_angle - m.turn_rate * m.tick / 2) / (m.turn_rate * m.tick) + 0.5)
    step = round((m.step_length - m.straight_speed * m.tick / 2) / (m.straight_speed * m.tick) + 0.5)
    runs = _runs(robot.commands)
    # right all along (the sight of a point on the other side mid-turn changes nothing), a
    # quarter turn; then one straight step; then the goal task: the goal now lies left, a quarter turn
    assert runs[:3] == [("right", quarter), ("ahead", step), ("left", quarter)]
    assert [t for _, t in rep.tasks[:4]] == ["straight", "right/avoid", "straight", "left/pursue"]
    assert rep.avoid_ticks == quarter


@pytest.mark.parametrize("goal, first", [((1.0, 0.09), "ahead"), ((1.0, 0.2), "left"), ((1.0, -0.2), "right")])
def test_the_goal_task_turns_a_quarter_when_the_goal_is_over_0_1_rad_off(goal, first):
    robot = _Driven(lambda k: [[FRONT + 0.2, 1.5]])
    ReactiveController(robot, goal, feedback="none", sides="signed").run(max_time=4.0)
    runs = _runs(robot.commands)
    assert runs[0][0] == first
    if first != "ahead":  # a quarter turn, not until it faces the goal (0.2 rad: 4 ticks)
        assert runs[0][1] > 20 and runs[1][0] == "ahead"


def test_bad_parameters_are_refused():
    with pytest.raises(ValueError, match="look_ahead"):
        ReactiveController(_Still([]), (1.0, 0.0), look_ahead=0.0)
    with pytest.raises(ValueError, match="hazard_points"):
        ReactiveController(_Still([]), (1.0, 0.0), hazard_points=0)
    with pytest.raises(ValueError, match="sides"):
        ReactiveController(_Still([]), (1.0, 0.0), sides="unsigned")


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

    from clomp.planner import load_scenario
    from clomp.runtime.experiment.reactive import ReactiveController
    from clomp.runtime.backends.sim import SimRobot

    with pytest.raises(ValueError, match="finite"):
        ReactiveController(SimRobot(load_scenario("open"), seed=0), (_math.nan, 0.0))


def _estimate_error(feedback: str) -> tuple[str, float]:
    from clomp.formal.geometry import compose
    from clomp.runtime.experiment.layouts import make_layout
    from clomp.runtime.backends.world import WorldNoise, make_world_robot

    scene = make_layout("corridor", 0, 0).scene  # walls either side: scan matching has surfaces to hold
    robot = make_world_robot(scene, WorldNoise(wheel_bias=0.05, wheel_sd=0.01), seed=0)
    ctl = ReactiveController(robot, scene.goal_in_robot_frame(), feedback=feedback)
    rep = ctl.run(max_time=13)  # straight steps and quarter turns along the corridor
    true, est = robot.ground_truth_pose(), compose(scene.start, ctl.pose)
    return rep.state, math.hypot(true.x - est.x, true.y - est.y)


def test_scan_feedback_corrects_the_estimate_as_the_planning_condition_does():
    # the same robot, the same sensing: with a 5 % wheel bias dead reckoning drifts
    # (0.19 m in 13 s of the corridor); the supervisor's scan odometry keeps the estimate on the truth
    state, err_scan = _estimate_error("scan")
    _, err_none = _estimate_error("none")
    assert state == "TIMEOUT"  # not a fault
    assert err_scan < 0.02 < 0.1 < err_none


def test_feedback_must_be_scan_or_none():
    with pytest.raises(ValueError, match="feedback"):
        ReactiveController(_Still([]), (1.0, 0.0), feedback="icp")
