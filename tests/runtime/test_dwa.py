"""The dwa condition: the dynamic window approach on the same robot, scans and estimate."""

from __future__ import annotations

import numpy as np
import pytest

from clomp.planner import load_scenario
from clomp.planner.robot_model import RobotModel
from clomp.runtime.experiment.dwa import DwaController
from clomp.runtime.experiment.driver import run_experiment
from clomp.runtime.experiment.onerun import run_once
from clomp.runtime.experiment.runspec import CONDITIONS, DEFAULT_CONDITIONS, RunSpec, experiment_specs, noise_seed, scene_for
from clomp.runtime.experiment.results import summarise, table


def test_dwa_is_a_condition_but_not_run_unless_asked():
    assert "dwa" in CONDITIONS and "dwa" not in DEFAULT_CONDITIONS
    assert [s.condition for s in experiment_specs("open", 1, conditions=("dwa",))] == ["dwa"]


def test_reaches_the_goal_in_open_space_without_contact():
    r = run_once(load_scenario("open"), "dwa", 0, noise="ideal")
    assert r.reached_goal and r.believed_goal and r.collisions == 0 and r.brushes == 0


@pytest.mark.parametrize("run", range(3))
def test_overtaking_at_ideal_noise_gets_past_the_box_without_contact(run):
    spec = RunSpec("overtaking", 0, run, "dwa", "ideal")
    scene, expect = scene_for(spec)
    r = run_once(scene, "dwa", noise_seed(0, run), noise="ideal", expect=expect, max_time=60)
    assert r.collisions == 0 and r.brushes == 0
    assert r.reached_goal


class _Still:
    """A robot that stands still and always sees the same points (robot frame)."""

    def __init__(self, points):
        self.points = np.asarray(points, float).reshape(-1, 2)


def test_every_command_keeps_the_wheels_within_the_top_speed_and_no_arc_touches_a_point():
    m = RobotModel()
    wall = np.c_[np.full(40, 0.3), np.linspace(-0.4, 0.4, 40)]  # a wall 0.21 m ahead of the front edge
    c = DwaController(_Still(wall), (1.0, 0.0), m)
    c._scan, c._scan_pose, c._t0 = wall, c.pose, 0.0
    for cmd in ((0.0, 0.0), (0.2, 0.2), (-0.0435, 0.0435)):
        c._cmd = cmd
        vl, vr = c._control(c.pose.__class__(1.0, 0.0, 0.0), 0.0)
        assert abs(vl) <= m.max_speed + 1e-9 and abs(vr) <= m.max_speed + 1e-9
        v, w = (vl + vr) / 2, (vr - vl) / m.wheel_base
        t = np.linspace(0.1, c.horizon, 15)
        th = w * t
        x = v * t if abs(w) < 1e-9 else v / w * np.sin(th)
        y = 0 * t if abs(w) < 1e-9 else v / w * (1 - np.cos(th))
        assert (c._clearance(wall, x[None], y[None], th[None]) > 0).all(), cmd


def test_the_summary_table_pairs_dwa_with_planning():
    recs = run_experiment("open", runs=1, noise="ideal", conditions=("planning", "dwa"), workers=0)
    s = summarise(recs)
    assert set(s["conditions"]) == {"planning", "dwa"} and "mcnemar_success_dwa" in s and "mcnemar_success" not in s
    assert "planning − dwa" in table(s)


def test_bad_options_are_refused():
    with pytest.raises(ValueError):
        DwaController(_Still([]), (1.0, 0.0), weights={"speed": 1.0})
    with pytest.raises(ValueError):
        DwaController(_Still([]), (1.0, 0.0), horizon=0.0)
