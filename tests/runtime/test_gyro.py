"""The rate gyro: the world measures its turn as a gyro does, and the estimator's heading
follows it (gyrodometry), its offset measured while the robot stands."""

from __future__ import annotations

import math

import numpy as np
import pytest

from clomp.formal.geometry import relative, wrap_angle
from clomp.formal.model import Pose
from clomp.planner.scenarios import load_scenario
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.odometry import ScanOdometry
from clomp.runtime.interface import TurnSensing
from clomp.runtime.backends import make_world_robot
from clomp.runtime.backends.world import WorldNoise

# a spin on the spot and back, then a long curve: what a gyro and a wheel model see differently
COMMANDS = [(0.0, 0.0)] * 15 + [(-0.04, 0.04)] * 20 + [(0.1, 0.1)] * 40 + [(0.04, -0.04)] * 10 + [(0.1, 0.08)] * 40


def _drive(world, commands, odo: ScanOdometry | None = None) -> list[tuple[float, float]]:
    """(true heading turned, gyro reading) after each 0.1 s tick; ``odo`` dead-reckons along."""
    out = []
    cmd = (0.0, 0.0)
    if odo is not None:
        odo.reset(Pose(0.0, 0.0, 0.0), world.now())
        odo.advance(world.now(), cmd, None, world.rotation())
    for nxt in commands:
        cmd = nxt
        world.set_wheel_speeds(*cmd)
        world.sleep(0.1)
        if odo is not None:
            odo.advance(world.now(), cmd, None, world.rotation())
        turned = wrap_angle(world.ground_truth_pose().theta - world.start_pose.theta)
        out.append((turned, world.rotation()))
    return out


def test_the_world_robot_offers_a_gyro_and_can_go_without() -> None:
    scene = load_scenario("open")
    assert isinstance(make_world_robot(scene, "paper", seed=0), TurnSensing)
    assert make_world_robot(scene, "paper", seed=0, gyro=False).rotation() is None


def test_a_noiseless_gyro_reads_the_bodys_true_turn() -> None:
    world = make_world_robot(load_scenario("open"), "ideal", seed=0)
    for turned, read in _drive(world, COMMANDS):
        assert read == pytest.approx(turned, abs=1e-9)


def test_a_noisy_gyro_errs_by_its_offset_scale_and_walk_and_not_more() -> None:
    noise = WorldNoise(rate_sd=0.0025, rate_bias=0.05, rate_scale=0.05)
    errors = []
    for seed in range(20):
        world = make_world_robot(load_scenario("open"), noise, seed=seed)
        trace = _drive(world, COMMANDS)
        errors.append(trace[-1][1] - trace[-1][0])
    # 12.5 s: an offset of 0.05 rad/s is 0.6 rad at 1 sd; the scale and the walk add little
    assert 0.2 < float(np.std(errors)) < 1.2, errors
    assert len(set(errors)) == 20  # every run draws its own


def test_an_asymmetric_gyro_loses_heading_on_a_spin_and_back() -> None:
    """``rate_asymmetry`` (an IMU whose scale is wrong in a way one gain cannot fit): a spin
    counter-clockwise and back ends where it began, the gyro not, by the gains' difference."""
    spin = [(-0.05, 0.05)] * 30 + [(0.05, -0.05)] * 30 + [(0.0, 0.0)] * 10

    def spin_and_back(noise: WorldNoise) -> tuple[float, float, dict[str, float]]:
        """The gyro's error at the end less the constant gain's share, the peak turned, the truth."""
        world = make_world_robot(load_scenario("open"), noise, seed=6)
        trace = _drive(world, spin)
        truth = world.gyro_truth()
        end = trace[-1][0]
        return trace[-1][1] - end - (truth["gain"] - 1.0) * end, max(t for t, _ in trace), truth
    error, peak, truth = spin_and_back(WorldNoise(rate_asymmetry=0.05))
    assert abs(truth["asymmetry"]) > 0.01 and error == pytest.approx(truth["asymmetry"] * peak, rel=0.05)
    error, _peak, truth = spin_and_back(WorldNoise(rate_scale=0.05))
    assert truth["asymmetry"] == 0.0 and truth["gain"] != 1.0
    assert error == pytest.approx(0.0, abs=1e-9)  # a constant gain: out and back cancel


def test_the_gyro_draws_change_nothing_else_in_the_world() -> None:
    """Its own random generator: the drive and the LiDAR are the same with and without it."""
    scene = load_scenario("overtaking")
    a = make_world_robot(scene, "harsh", seed=3)
    b = make_world_robot(scene, "harsh", seed=3, gyro=False)
    _drive(a, COMMANDS[:60])
    _drive(b, COMMANDS[:60])
    assert a.trajectory == b.trajectory
    assert np.array_equal(a.read_scan(0.0).points, b.read_scan(0.0).points)


def test_standing_still_measures_the_offset_and_keeps_the_heading() -> None:
    f = OdometryFilter(0.15)
    for _ in range(30):
        f.zero_rate(0.004 + 0.0005 * math.sin(_), 0.1)
    assert f.rate_offset == pytest.approx(0.04, abs=0.002)
    assert f.pose.theta == 0.0
    # driving on, the offset is taken off what the gyro reads
    for _ in range(10):
        f.predict(0.1, 0.0, 0.1, turned=0.004)
    assert f.pose.theta == pytest.approx(0.0, abs=0.002)


def test_the_heading_is_the_gyros_not_the_wheels() -> None:
    f = OdometryFilter(0.15)
    for _ in range(10):
        f.predict(0.1, 0.0, 0.1, turned=0.02)  # commanded straight; the body turned 0.2 rad
    assert f.pose.theta == pytest.approx(0.2, abs=1e-9)
    assert f.pose.y > 0.005  # and the path curved with it


@pytest.mark.parametrize("seed", range(3))
def test_dead_reckoning_with_the_gyro_holds_the_heading_the_wheels_lose(seed: int) -> None:
    """Harsh world, no scans: the wheels' heading drifts by degrees; the gyro's, its offset
    measured in the 1.5 s standing at the start, stays within 3 degrees."""
    scene = load_scenario("open")
    errs = {}
    for gyro in (True, False):
        world = make_world_robot(scene, "harsh", seed=seed, gyro=gyro)
        odo = ScanOdometry(0.15, compass=False)
        _drive(world, COMMANDS, odo)
        truth = relative(world.start_pose, world.ground_truth_pose())
        errs[gyro] = abs(wrap_angle(odo.pose.theta - truth.theta))
    assert errs[True] < math.radians(3), errs
    assert errs[True] < errs[False], errs


def test_the_supervisor_feeds_the_gyro_to_its_estimate() -> None:
    """A whole harsh overtaking run: the supervisor's filter learnt the gyro's offset the world
    drew (measured in the still revolutions at the start and at every stop), and without the
    gyro it learns none."""
    from clomp.runtime.supervision import Supervisor

    scene = load_scenario("overtaking")
    learnt = {}
    for gyro in (True, False):
        world = make_world_robot(scene, "harsh", seed=1, gyro=gyro)
        sup = Supervisor(world, scene.goal_in_robot_frame())
        sup.run(max_time=60)
        assert sup.estimator is not None
        learnt[gyro] = sup.estimator.filter.rate_offset
        if gyro:
            drawn = world._gyro.offset
            assert abs(drawn) > 0.01  # a draw worth measuring
            assert learnt[gyro] == pytest.approx(drawn, abs=0.005), (learnt, drawn)
    assert learnt[False] == 0.0


ROOM = {"goal": [0.5, 0.0], "obstacles": [
    {"type": "wall", "from": [-0.8, 0.6], "to": [0.8, 0.6]},
    {"type": "wall", "from": [0.8, 0.6], "to": [0.8, -0.6]},
    {"type": "wall", "from": [0.8, -0.6], "to": [-0.8, -0.6]},
    {"type": "box", "center": [0.3, 0.3], "size": [0.1, 0.1]},
]}


def test_a_revolution_is_deskewed_along_the_gyros_heading_not_the_commands() -> None:
    """With 0.1 s of actuation latency the body turns a tick after the command: a revolution
    taken as a turn starts or stops, deskewed along the estimate's history (its heading the
    gyro's), lands where an instant scan at its stamp sees the room; the commanded twist
    misplaces it."""
    from scipy.spatial import cKDTree

    from clomp.planner.scenarios import parse_scenario
    from clomp.runtime.estimation.odometry import deskew

    world = make_world_robot(parse_scenario(ROOM, "room"), WorldNoise(latency=0.1), seed=0)
    odo = ScanOdometry(0.15, compass=False)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    odo.advance(0.0, (0.0, 0.0), None, world.rotation())
    cmd, along, commanded = (0.0, 0.0), [], []
    for k in range(60):
        cmd = (-0.05, 0.05) if 10 <= k % 20 < 17 else (0.0, 0.0)  # turn 0.7 s, stand 1.3 s
        world.set_wheel_speeds(*cmd)
        for _ in range(10):  # 0.1 s in physics steps: a revolution is caught as it ends
            world.sleep(0.01)
            odo.advance(world.now(), cmd, None, world.rotation())
            frame = world.read_scan(0.0)
            if frame is None or frame.point_times is None:
                continue
            truth = cKDTree(world.scan_now())
            fixed = odo._deskew_along(np.asarray(frame.points), np.asarray(frame.point_times), frame.timestamp)
            v, w = odo._twist
            naive = deskew(np.asarray(frame.points), frame.point_times, v, w)
            along.append(float(np.median(truth.query(fixed)[0])))
            commanded.append(float(np.median(truth.query(naive)[0])))
    worst_along, worst_commanded = max(along), max(commanded)
    assert worst_along < 0.01, along
    assert worst_commanded > 2 * worst_along, (worst_along, worst_commanded)


def _straight_on_the_estimate(hold: bool, seed: int) -> float:
    """A 1 m STRAIGHT on wheels that curve, run on the gyro-fed estimate; the true heading
    turned by its end (rad)."""
    from clomp.formal.geometry import wrap_angle as wrap
    from clomp.planner.robot_model import RobotModel
    from clomp.planner.tasks import Task

    world = make_world_robot(load_scenario("open"), WorldNoise(wheel_bias=0.05, rate_sd=0.0025, rate_bias=0.05),
                             seed=seed)
    odo = ScanOdometry(0.15, compass=False)
    _drive(world, [(0.0, 0.0)] * 15, odo)  # stand: the gyro's offset is measured
    task = Task.straight(RobotModel(), odo.pose, None, 1.0)
    cmd = (0.0, 0.0)
    for _ in range(200):
        e = task.error(odo.pose)
        if task.done(e):
            break
        cmd = task.wheel_speeds(e, wrap(odo.pose.theta - task.start.theta) if hold else 0.0)
        world.set_wheel_speeds(*cmd)
        world.sleep(0.1)
        odo.advance(world.now(), cmd, None, world.rotation())
    truth = relative(world.start_pose, world.ground_truth_pose())
    return abs(truth.theta)


@pytest.mark.parametrize("seed", range(3))
def test_a_straight_holds_its_heading_on_the_gyro(seed: int) -> None:
    """Wheels 5 % apart curve a 1 m straight by several degrees; held on the gyro-fed
    estimate, it ends within 2 degrees of where it began."""
    held, free = _straight_on_the_estimate(True, seed), _straight_on_the_estimate(False, seed)
    assert held < math.radians(2), (held, free)
    assert free > 2 * held, (held, free)


def test_the_reactive_baseline_measures_the_gyro_standing_then_drives() -> None:
    """The same sensing for both conditions: the reactive loop takes its heading from the
    gyro too, after standing its first second to measure the offset (without a gyro it
    drives at once, as before)."""
    from clomp.runtime.experiment.reactive import ReactiveController

    scene = load_scenario("open")
    for gyro in (True, False):
        world = make_world_robot(scene, "harsh", seed=2, gyro=gyro)
        c = ReactiveController(world, scene.goal_in_robot_frame())
        c.run(max_time=3.0)
        moved_at = next(t for t, *pose in world.trajectory if math.hypot(pose[0], pose[1]) > 1e-3)
        assert c.estimator is not None
        if gyro:
            assert moved_at > 1.0
            assert c.estimator.filter.rate_offset == pytest.approx(world.gyro_truth()["offset"], abs=0.005)
        else:
            assert moved_at < 0.5 and c.estimator.filter.rate_offset == 0.0
