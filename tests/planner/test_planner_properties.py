"""Invariants of every map the Configurator builds, over generated scenes."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st

from clomp.formal.supervisory import is_frontier
from clomp.planner import Configurator, PlanningError, RobotModel
from clomp.planner.scenarios import Scene
from clomp.planner.strategies import robot_models, scenes

sys.path.insert(0, str(Path(__file__).parent))
from sweepcheck import check_states  # noqa: E402


# the public strategies (clomp.planner.strategies) are what users property-test with, too
robots = robot_models()


def _build(scene: Scene, robot: RobotModel):
    return _build_scan(scene, robot, scene.scan(rays=180))


def _build_scan(scene: Scene, robot: RobotModel, scan: np.ndarray):
    conf = Configurator(robot=robot, max_states=120)
    try:
        return conf.plan(scan, scene.goal)
    except PlanningError:
        assume(False)


SETTINGS = settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@SETTINGS
@given(scenes(), robots)
def test_map_invariants(scene, robot):
    r = _build(scene, robot)
    m = r.map
    # every state is reachable from q0, which is the only initial state
    assert m.initial.ident == 0
    assert m.reachable() == {s.ident for s in m.states()}
    for s in m.states():
        # no transition leaves an interrupted state
        if s.interrupted:
            assert m.out_transitions(s.ident) == []
        # R: after an uninterrupted state, the next task is contingent on D_G
        for t in m.out_transitions(s.ident):
            assert not s.interrupted
            assert m[t.target].d_i == m.goal
            # the simulated motion is continuous: a task starts where its predecessor ended
            tgt = m[t.target].start
            assert math.isclose(tgt.x, s.end.x, abs_tol=1e-6) and math.isclose(tgt.y, s.end.y, abs_tol=1e-6)
        # a turn that was not interrupted is followed by a straight
        if s.task.is_turn and not s.interrupted:
            assert [x.task.value for x in m.successors(s.ident)] == ["STRAIGHT"]
    # the plan is a path from q0 ending at argmin phi over the states a plan may end in, or
    # at a frontier end (clomp.formal.supervisory.plan_end): at a frontier state, when argmin
    # phi is a frontier, q0 or a state the search looked past; and it never stands still
    # while a frontier state is in the map
    p = r.plan.states
    assert p[0] == 0
    assert all(m.has_transition(a, b) for a, b in zip(p, p[1:]))
    least = min((s for s in m.states() if not s.interrupted), key=lambda s: (s.cost, s.ident))
    end = m[p[-1]]
    assert end.ident == least.ident or (is_frontier(end) and (is_frontier(least) or m.successors(least.ident)))
    frontiers = [s for s in m.states() if is_frontier(s) and not s.interrupted]
    assert len(p) > 1 or not frontiers
    assert r.collision_free


@SETTINGS
@given(scenes(), robots)
def test_no_task_passes_over_a_sensed_point_or_leaves_the_sensed_disc(scene, robot):
    """The independent sweep (tests/planner/sweepcheck.py) of every simulated task: the
    real body never covers a sensed point it did not cover at the planning origin, and
    never leaves the disc the sensor saw."""
    scan = scene.scan(rays=180)
    r = _build_scan(scene, robot, scan)
    check = check_states(scan, [s for s in r.map.states() if s.ident != 0], robot)
    assert check.over_points == 0
    assert check.outside_disc <= 1e-6


@settings(max_examples=15, deadline=None)
@given(scenes(), robots)
def test_same_input_same_map(scene, robot):
    a = _build(scene, robot)
    b = _build(scene, robot)
    assert json.dumps(a.map.to_dict()) == json.dumps(b.map.to_dict())


@settings(max_examples=30, deadline=None)
@given(st.floats(0.3, 1.1), st.floats(-math.pi, math.pi))
def test_free_space_reaches_any_goal_in_range(d, a):
    goal = (d * math.cos(a), d * math.sin(a))
    r = Configurator().plan(np.zeros((0, 2)), goal)
    assert r.collision_free
    # a straight stops when the goal comes abeam, then a turn faces it and a clear run
    # reaches it: every goal in free space whose body fits in the sensed disc is reached
    if d <= r.robot.sensor_range - 0.21:
        assert r.reached_goal
        assert r.map[r.plan.end].end.distance_to(*goal) <= r.robot.goal_tolerance
    elif not r.reached_goal:
        # beyond: planning ends at the rim of what the sensor saw, and says so
        assert r.stop_reason == "frontier"
        assert any(dict(s.extra).get("frontier") == 1.0 for s in r.map.states())
