"""The simulated robot: kinematics, LiDAR, contacts, noise settings, determinism."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.planner import load_scenario
from clomp.planner.scenarios import ScenarioError, parse_scenario
from clomp.runtime.interface import Robot, RobotFault
from clomp.runtime.backends.sim import NoiseConfig, SimRobot, scenario_noise, scenario_scan_source, scenario_seed

IDEAL = NoiseConfig.ideal()


def test_is_a_robot_backend():
    assert isinstance(SimRobot(load_scenario("open"), seed=0), Robot)


@given(v=st.floats(-0.2, 0.2), w=st.floats(-1.0, 1.0), t=st.floats(0.1, 3.0))
@settings(max_examples=30, deadline=None)
def test_ideal_kinematics_match_the_unicycle_model(v, w, t):
    """Wheel speeds (v ∓ w b/2) for t seconds move the ideal robot along the exact arc."""
    sim = SimRobot(load_scenario("open"), noise=IDEAL)
    b = sim.model.wheel_base
    vl, vr = v - w * b / 2, v + w * b / 2
    if max(abs(vl), abs(vr)) > sim.model.max_speed:
        return
    sim.set_wheel_speeds(vl, vr)
    sim.sleep(t)
    th = w * t
    if abs(w) < 1e-9:
        x, y = v * t, 0.0
    else:
        x, y = v / w * math.sin(th), v / w * (1 - math.cos(th))
    p = sim.pose
    assert p.x == pytest.approx(x, abs=1e-9) and p.y == pytest.approx(y, abs=1e-9)
    assert math.remainder(p.theta - th, 2 * math.pi) == pytest.approx(0.0, abs=1e-9)
    assert sim.now() == pytest.approx(t)


def test_wheel_speeds_saturate_and_reject_nan():
    sim = SimRobot(load_scenario("open"), noise=IDEAL)
    sim.set_wheel_speeds(5.0, -5.0)
    assert sim.commanded == (0.2, -0.2)
    with pytest.raises(ValueError):
        sim.set_wheel_speeds(float("nan"), 0.0)


def test_lidar_revolutions_at_the_scan_rate_cropped_and_rounded():
    sim = SimRobot(load_scenario("blocked"), seed=1)
    frames = [sim.read_scan(timeout=None) for _ in range(5)]
    assert all(f is not None for f in frames)
    gaps = np.diff([f.timestamp for f in frames])  # type: ignore[union-attr]
    assert gaps == pytest.approx(1 / 5.5, abs=0.021)
    for f in frames:
        pts = f.points  # type: ignore[union-attr]
        r = np.hypot(pts[:, 0], pts[:, 1])
        assert (r <= 1.1 + 1e-9).all()
        # a closed pen: nearly every one of the 360 rays returns (2 % dropouts)
        assert 320 <= len(pts) <= 360
        assert np.allclose(pts * 100, np.round(pts * 100))
    # nothing new until the next revolution completes
    assert sim.read_scan(timeout=0.0) is None


def test_scan_sees_the_obstacle_where_it_is():
    sim = SimRobot(load_scenario("overtaking"), noise=IDEAL)
    pts = sim.read_scan(timeout=None).points  # type: ignore[union-attr]
    front = pts[np.abs(pts[:, 1]) < 0.05]
    assert front[:, 0].min() == pytest.approx(0.45, abs=0.011)


def test_driving_into_a_box_is_one_collision_and_no_tunnelling():
    sim = SimRobot(load_scenario("overtaking"), noise=IDEAL)
    sim.set_wheel_speeds(0.1, 0.1)
    sim.sleep(10.0)  # 1 m of commanded travel; the box face is at x = 0.45
    assert sim.collisions == 1
    assert sim.pose.x <= 0.45 - sim.model.front_offset + 1e-3
    assert len(sim.contacts) == 1 and sim.contacts[0].x == pytest.approx(0.45, abs=1e-6)


def test_a_brush_counts():
    """A box reaching 1 cm into the body's swept path is hit (once); 2 cm clear of it is not."""
    raw = {"goal": [1.2, 0.0], "obstacles": [{"type": "box", "center": [0.6, 0.13], "size": [0.2, 0.1]}]}
    sim = SimRobot(parse_scenario(raw, "brush"), noise=IDEAL)
    sim.set_wheel_speeds(0.1, 0.1)
    sim.sleep(12.0)
    assert sim.collisions == 1
    assert sim.pose.x <= 0.5 - sim.model.front_offset + 1e-3  # the corner is stopped by the face
    free = SimRobot(parse_scenario({**raw, "obstacles": [{"type": "box", "center": [0.6, 0.16], "size": [0.2, 0.1]}]}, "b"), noise=IDEAL)
    free.set_wheel_speeds(0.1, 0.1)
    free.sleep(12.0)
    assert free.collisions == 0 and free.pose.x == pytest.approx(1.2)


def test_same_seed_same_run_other_seed_other_run():
    def run(seed: int) -> tuple[float, float, int]:
        sim = SimRobot(load_scenario("overtaking"), seed=seed)
        sim.set_wheel_speeds(0.1, 0.12)
        sim.sleep(3.0)
        n = len(sim.read_scan(timeout=None).points)  # type: ignore[union-attr]
        return sim.pose.x, sim.pose.y, n

    assert run(3) == run(3)
    assert run(3) != run(4)


def test_odometry_is_optional_and_starts_at_the_origin():
    scene = load_scenario("open")
    assert SimRobot(scene, seed=0).odometry() is None
    sim = SimRobot(scene, seed=0, odometry=True, start=Pose(1.0, 2.0, 0.5))
    assert sim.odometry() == Pose(0.0, 0.0, 0.0)
    sim.set_wheel_speeds(0.1, 0.1)
    sim.sleep(1.0)
    odo = sim.odometry()
    assert odo is not None and odo.x == pytest.approx(0.1, rel=0.1)
    assert sim.pose.x > 1.0 and sim.pose.y > 2.0  # world frame


def test_closed_robot_faults_but_can_always_stop():
    sim = SimRobot(load_scenario("open"), seed=0)
    sim.close()
    sim.stop()
    with pytest.raises(RobotFault):
        sim.set_wheel_speeds(0.1, 0.1)
    with pytest.raises(RobotFault):
        sim.read_scan()


def test_start_inside_an_obstacle_is_refused():
    raw = {"goal": [1.0, 0.0], "obstacles": [{"type": "box", "center": [0.12, 0.0], "size": [0.1, 0.1]}]}
    with pytest.raises(ScenarioError, match="start"):
        SimRobot(parse_scenario(raw, "inside"))


# -- the scenario file's noise and seed ------------------------------------------------------
def test_scenario_noise_and_seed_are_read():
    raw = {"goal": [1.0, 0.0], "seed": 9, "noise": {"range_sd": 0.01, "dropout": 0.0}}
    scene = parse_scenario(raw, "n")
    assert scenario_noise(scene) == NoiseConfig(range_sd=0.01, dropout=0.0)
    assert scenario_seed(scene) == 9
    assert SimRobot(scene).seed == 9


@pytest.mark.parametrize(
    "noise, seed, field",
    [
        ({"range_sd": -0.1}, 0, "n.noise.range_sd"),
        ({"dropout": 1.0}, 0, "n.noise.dropout"),
        ({"wheel_sd": "x"}, 0, "n.noise.wheel_sd"),
        ({"wobble": 0.1}, 0, "n.noise.wobble"),
        ([0.1], 0, "n.noise"),
        ({}, -1, "n.seed"),
        ({}, 1.5, "n.seed"),
        ({}, True, "n.seed"),
    ],
)
def test_bad_noise_or_seed_names_the_field(noise, seed, field):
    with pytest.raises(ScenarioError) as err:  # the seed is checked as the scenario is read, the noise by the robot
        SimRobot(parse_scenario({"goal": [1.0, 0.0], "seed": seed, "noise": noise}, "n"))
    assert str(err.value).startswith(field + ":")


def test_every_shipped_scenario_builds_a_simulator():
    from clomp.planner import builtin_scenarios

    names = builtin_scenarios()
    assert {"overtaking", "corridor", "doorway", "slalom", "cul-de-sac"} <= set(names)
    for name in names:
        sim = SimRobot(load_scenario(name))
        assert sim.read_scan(timeout=None) is not None


def test_scenario_scan_source_yields_successive_noisy_scans():
    source = scenario_scan_source("overtaking", seed=2)
    a, b = source(), source()
    assert a.ndim == 2 and a.shape[1] == 2 and len(a) > 10
    assert not np.array_equal(a, b)  # noise differs from one revolution to the next
    ideal = scenario_scan_source("overtaking", noise=IDEAL)
    assert np.array_equal(ideal(), ideal())
    with pytest.raises(ScenarioError):
        scenario_scan_source("no-such-scenario")


def test_one_seed_gives_one_ground_truth_whatever_the_wall_clock(monkeypatch: pytest.MonkeyPatch) -> None:
    """A closed-loop run on the simulated robot is a function of the seed alone: the second run,
    with planning made slower in wall time, drives the same trajectory to the last bit."""
    import time as _time

    from clomp.planner.configurator import Configurator
    from clomp.runtime.experiment.runner import run_once

    scene = load_scenario("overtaking")
    noise = NoiseConfig(range_sd=0.01, dropout=0.05, wheel_sd=0.05, wheel_bias=0.01, drift=0.005)

    def run() -> tuple[object, ...]:
        r = run_once(scene, "planning", 5, noise=noise, max_time=15)
        return r.path, r.estimate, r.final_pose, r.end_state, r.time_s, r.plans

    first = run()
    real_plan = Configurator.plan

    def slow_plan(self: Configurator, scan: object, goal: object) -> object:
        _time.sleep(0.01)  # wall time passes while planning; simulated time must not notice
        return real_plan(self, scan, goal)  # type: ignore[arg-type]

    monkeypatch.setattr(Configurator, "plan", slow_plan)
    second = run()
    assert first == second
    assert len(first[0]) > 10 and first[5] >= 1  # a real run: it drove and planned
