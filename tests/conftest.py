"""Shared fixtures: where the recorded scans are, and the bench scripts as modules."""

from __future__ import annotations

import importlib
import sys
from collections.abc import Callable
from pathlib import Path
from types import ModuleType

import pytest
from hypothesis import HealthCheck, settings

# Hypothesis's per-example deadline (200 ms) and its "too slow" health check measure wall time:
# on a shared, fully loaded machine they fail tests whose property holds. No test here states a
# property about speed (benchmarks live in bench/), so neither check belongs in the suite.
settings.register_profile("clomp", deadline=None, suppress_health_check=[HealthCheck.too_slow])
settings.load_profile("clomp")

REPO = Path(__file__).resolve().parents[1]
SCANS = REPO.parent / "shared" / "data" / "scans" / "corridor-2023-10-25"
#: the overtaking scenario's goal stands in the box's shadow (no plan claims it); this one,
#: right of the box and seen by the scan, is reached round the box (R S R S L S, 14 states)
SEEN_GOAL = "overtaking@0.8,-0.3"
BENCH = REPO / "bench"


@pytest.fixture(scope="session")
def bench_script() -> Callable[[str], ModuleType]:
    """``bench_script(name)``: the script ``bench/<name>.py`` as a module, imported by its own
    name with ``bench/`` on ``sys.path`` (as the worker processes a bench spawns import it,
    ``sys.path`` passed on), so the tests call the very functions the script runs."""

    def load(name: str) -> ModuleType:
        if str(BENCH) not in sys.path:
            sys.path.insert(0, str(BENCH))
        return importlib.import_module(name)

    return load


@pytest.fixture(scope="session")
def scans_dir() -> Path:
    """The folder of recorded scans from the paper's robot (skip when absent)."""
    if not SCANS.is_dir():
        pytest.skip(f"recorded scans not found at {SCANS}")
    return SCANS


@pytest.fixture(scope="session")
def scenario_map():
    """``scenario_map(name)``: the cognitive map of a built-in scenario (built once per session);
    ``name@x,y`` plans in that scenario to the goal (x, y) instead (``SEEN_GOAL``: the
    overtaking box with a goal the scan sees, beside the box's shadow, which a plan reaches)."""
    from functools import lru_cache

    from clomp.planner import Configurator, load_scenario

    @lru_cache(maxsize=None)
    def build(name: str):
        conf = Configurator()
        name, _, at = name.partition("@")
        scene = load_scenario(name)
        goal = tuple(float(v) for v in at.split(",")) if at else tuple(scene.goal_in_robot_frame())
        return conf.plan(scene.scan(max_range=conf.robot.sensor_range), goal).map

    return build


@pytest.fixture(scope="session")
def scan_maps():
    """``scan_maps()``: (file name, cognitive map) for the first 20 recorded scans, goal 1 m ahead."""
    from clomp.planner import Configurator

    cache: list = []

    def build():
        if not SCANS.is_dir():
            pytest.skip(f"recorded scans not found at {SCANS}")
        if not cache:
            conf = Configurator()
            cache.extend((f.name, conf.plan(f, (1.0, 0.0)).map) for f in sorted(SCANS.glob("*.dat"))[:20])
        return list(cache)

    return build
