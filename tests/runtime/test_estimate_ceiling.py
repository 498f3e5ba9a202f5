"""``bench/estimate_ceiling.py --modes calibration``: the calibration it hands the filter is
the world's drive in the filter's terms, so dead reckoning with it follows the world."""

from __future__ import annotations

import importlib
import math
import sys
from pathlib import Path
from types import ModuleType

import pytest

from planner.scenarios import load_scenario
from runtime.estimation.ekf import OdometryFilter
from runtime.robots.world import WorldNoise, make_world_robot

BENCH = Path(__file__).resolve().parents[2] / "bench" / "estimate_ceiling.py"


def _bench() -> ModuleType:
    if str(BENCH.parent) not in sys.path:
        sys.path.insert(0, str(BENCH.parent))
    return importlib.import_module(BENCH.stem)


def _dead_reckoning_error(seed: int, known: bool) -> tuple[float, float]:
    """A straight, a left quarter turn, a straight, a right quarter turn, a straight, in a
    world with strong bias, drift and slip: the filter's dead reckoning against the truth."""
    w = make_world_robot(load_scenario("open"), WorldNoise(wheel_bias=0.05, drift=0.02, slip=0.05), seed=seed)
    f = OdometryFilter(w.body.wheel_base)
    if known:
        f.x[3:7] = _bench().true_calibration(w, w.body.wheel_base)
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
def test_the_true_calibration_makes_dead_reckoning_follow_the_world(seed: int) -> None:
    err, heading = _dead_reckoning_error(seed, known=True)
    assert err < 0.015 and heading < math.radians(3.0)  # what is left is the per-tick slip


def test_without_it_the_same_drive_goes_astray() -> None:
    # the check above has something to tell: uncalibrated, the same seeds end far off
    assert max(_dead_reckoning_error(seed, known=False)[0] for seed in range(4)) > 0.1
