"""``bench/estimate_ceiling.py --modes calibration``: the calibration it hands the filter is
the world's drive in the filter's terms, so dead reckoning with it follows the world."""

from __future__ import annotations

import math
from collections.abc import Callable
from types import ModuleType

import pytest

from clomp.planner.scenarios import load_scenario
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.backends.world import WorldNoise, make_world_robot
from clomp.runtime.supervision import SupervisorConfig


@pytest.fixture
def ceiling(bench_script: Callable[[str], ModuleType]) -> ModuleType:
    return bench_script("estimate_ceiling")


def _dead_reckoning_error(seed: int, ceiling: ModuleType | None) -> tuple[float, float]:
    """A straight, a left quarter turn, a straight, a right quarter turn, a straight, in a
    world with strong bias, drift and slip: the filter's dead reckoning against the truth,
    told the world's calibration by ``ceiling`` (the bench module; None: not told)."""
    w = make_world_robot(load_scenario("open"), WorldNoise(wheel_bias=0.05, drift=0.02, slip=0.05), seed=seed)
    f = OdometryFilter(w.body.wheel_base)
    if ceiling is not None:
        f.x[3:7] = ceiling.true_calibration(w, w.body.wheel_base)
    start = w.ground_truth_pose()
    turn = 0.58 * w.body.wheel_base / 2
    for (left, right), ticks in (((0.1, 0.1), 30), ((-turn, turn), 27), ((0.1, 0.1), 30), ((turn, -turn), 27),
                                 ((0.1, 0.1), 20), ((0.0, 0.0), 5)):
        w.set_wheel_speeds(left, right)
        for _ in range(ticks):
            w.sleep(0.1)
            f.predict((left + right) / 2, (right - left) / w.body.wheel_base, 0.1)
    end = w.ground_truth_pose()
    dth = f.pose.theta - (end.theta - start.theta)
    return math.hypot(f.pose.x - (end.x - start.x), f.pose.y - (end.y - start.y)), abs(math.atan2(math.sin(dth), math.cos(dth)))


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_true_calibration_makes_dead_reckoning_follow_the_world(seed: int, ceiling: ModuleType) -> None:
    err, heading = _dead_reckoning_error(seed, ceiling)
    assert err < 0.015 and heading < math.radians(3.0)  # what is left is the per-tick slip


def test_without_it_the_same_drive_goes_astray() -> None:
    # the check above has something to tell: uncalibrated, the same seeds end far off
    assert max(_dead_reckoning_error(seed, None)[0] for seed in range(4)) > 0.1


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_the_gyros_true_calibration_makes_its_heading_follow_the_world(seed: int, ceiling: ModuleType) -> None:
    """With a gyro the filter's ``k`` and ``b`` are the gyro's: told them, the heading
    integrated from its readings follows the body through two quarter turns; untold, the
    same drive ends degrees off."""
    errors = []
    for known in (True, False):
        w = make_world_robot(load_scenario("open"), WorldNoise(rate_bias=0.05, rate_scale=0.05), seed=seed)
        f = OdometryFilter(w.body.wheel_base)
        if known:
            f.x[3:8] = ceiling.true_gyro_calibration(w, w.body.wheel_base)
        start, last = w.ground_truth_pose(), w.rotation()
        turn = 0.58 * w.body.wheel_base / 2
        for (left, right), ticks in (((-turn, turn), 27), ((0.1, 0.1), 20), ((turn, -turn), 27), ((0.0, 0.0), 5)):
            w.set_wheel_speeds(left, right)
            for _ in range(ticks):
                w.sleep(0.1)
                now = w.rotation()
                f.predict((left + right) / 2, (right - left) / w.body.wheel_base, 0.1, turned=now - last)
                last = now
        dth = f.pose.theta - (w.ground_truth_pose().theta - start.theta)
        errors.append(abs(math.atan2(math.sin(dth), math.cos(dth))))
    assert errors[0] < math.radians(0.1) < math.radians(2) < errors[1], errors


def test_the_true_pose_is_fed_in_the_supervisors_frame(ceiling: ModuleType) -> None:
    """A corridor layout starts turned in the world (here -0.145 rad): the truth ablation
    must hand the supervisor the world's pose seen from the start, as its estimate is, or
    the goal turns with the start heading and the "ceiling" misses corridors it should not."""
    from clomp.formal.geometry import relative
    from clomp.planner import Configurator
    from clomp.runtime.experiment.runner import RunSpec, scene_for
    from clomp.runtime.experiment.groundtruth import make_robot

    scene, _ = scene_for(RunSpec("corridor", 0, 0, "planning", "harsh"))
    assert abs(scene.start.theta) > 0.1  # the case this test is about
    conf = Configurator()
    robot = make_robot(scene, noise="harsh", seed=0, model=conf.robot)
    sup = ceiling._TruthFed(robot, tuple(scene.goal_in_robot_frame()), conf, config=SupervisorConfig(feedback="scan"))
    sup.start()
    poses = []
    for _ in range(400):  # 40 s: the still start, a plan, driving
        sup.step()
        poses.append((sup.pose, relative(scene.start, robot.ground_truth_pose())))
        if sup.terminal:
            break
        sup.clock.sleep(conf.robot.tick)  # simulated time, as Supervisor.run ticks it
    moved = [(p, w) for p, w in poses if math.hypot(w.x, w.y) > 0.05]
    assert moved, "the robot never drove"
    for p, w in poses:
        assert math.hypot(p.x - w.x, p.y - w.y) < 1e-9 and abs(p.theta - w.theta) < 1e-9
