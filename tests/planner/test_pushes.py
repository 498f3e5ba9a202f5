"""The world's external pushes in the probabilistic map's rollouts (clomp.planner.pushes)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose, TaskKind
from clomp.planner.engine import Outcome
from clomp.planner.noise import NoiseError
from clomp.planner.probabilistic import sample_map
from clomp.planner.pushes import Pushes, push_outcome
from clomp.planner.robot_model import RobotModel

WALL = np.array([[x, 0.25] for x in np.linspace(-0.5, 1.5, 201)])


def test_the_presets_pushes_are_the_worlds():
    assert Pushes.preset("harsh") == Pushes(0.02, 0.2)
    assert not Pushes.preset("paper").active and not Pushes.preset("harsh-modelled").active
    with pytest.raises(NoiseError):
        Pushes(-1.0, 0.2)


def test_inactive_pushes_leave_the_map_as_it_was():
    """No draw is taken without pushes: the map is the one sampled without the term (a
    tolerance of 1 mm keeps every rollout's own end, so one draw more would show)."""
    kw = dict(samples=6, noise="harsh", seed=3, carry=True, tolerance=(0.001, 0.001))
    a = sample_map(WALL, (0.8, -0.6), **kw)
    assert len(a.map) > 12
    b = sample_map(WALL, (0.8, -0.6), pushes=Pushes.preset("paper"), **kw)
    assert a.map.to_dict() == b.map.to_dict()


def test_a_push_beside_a_wall_ends_some_rollouts_in_it():
    """Pushed often enough, a straight along a wall 0.25 m off meets it in some noisy
    worlds (a collision outcome), never in the open."""
    pushes = Pushes(rate=0.5, size=0.2)
    near = sample_map(WALL, (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True, pushes=pushes)
    assert any(s.interrupted for s in near.map.states()), "no push met the wall"
    assert near.map.metadata["pushes"] == [0.5, 0.2]
    open_ = sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True, pushes=pushes)
    assert not any(s.interrupted for s in open_.map.states())
    assert len(open_.map) > len(sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=20, noise="harsh", seed=1, carry=True).map)


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), duration=st.floats(0.1, 30.0))
def test_a_push_either_meets_an_obstacle_or_moves_the_end_by_its_slide(seed, duration):
    out = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.5, 0.0), 0.5, duration, 50, None, False)
    got = push_outcome(out, WALL, RobotModel(), Pushes(0.2, 0.2), np.random.default_rng(seed))
    if got is out:
        return
    if got.d_n is not None:
        assert got.end.y > 0.0  # slid towards the wall, where it met it
    else:
        moved = math.hypot(got.end.x - out.end.x, got.end.y - out.end.y)
        assert 0.1 - 1e-9 <= moved <= 0.3 + 1e-9


def _plan_p(pm):
    from clomp.formal.scheduler import plan_probability
    from clomp.formal.supervisory import Plan
    from clomp.planner.robust import plan_target

    end = pm.nominal.map[pm.nominal.plan.end].end
    return plan_probability(pm.map, Plan(tuple(pm.nominal.plan.states)), plan_target(pm.map, end, pm.nominal.goal), 1)


def test_a_push_that_loses_the_estimate_is_a_dead_end_of_the_map():
    """The whole run's term: with ``lost`` = 1 every push the body survives ends in a
    lost state (named in the metadata, no successor, never the goal nor a target, not an
    outcome the loop replans from), so the plan's P falls by the pushes' chance; with
    ``lost`` = 0 the same pushes are outcomes the closed loop replans from."""
    from clomp.formal.retry import map_lost, map_offs
    from clomp.planner.robust import CLOSED_LOOP_HAZARD, plan_target

    kw = dict(samples=30, noise="harsh", seed=2, carry=True, hazard=CLOSED_LOOP_HAZARD)
    free = sample_map(np.zeros((0, 2)), (1.5, 0.0), pushes=Pushes(0.05, 0.2), **kw)
    dead = sample_map(np.zeros((0, 2)), (1.5, 0.0), pushes=Pushes(0.05, 0.2, lost=1.0), **kw)
    lost = map_lost(dead.map.metadata)
    assert lost and not map_lost(free.map.metadata)
    target = plan_target(dead.map, dead.nominal.map[dead.nominal.plan.end].end, dead.nominal.goal)
    for ident, source in lost.items():
        s = dead.map[ident]
        assert not dead.map.out_transitions(ident) and not s.reached_goal and not s.interrupted
        assert ident not in target and ident not in map_offs(dead.map.metadata)
        assert any(t.target == ident for t in dead.map.out_transitions(source))
    share = sum(float(t.probability) for src in set(lost.values()) for t in dead.map.out_transitions(src) if t.target in lost)
    assert share > 0
    assert _plan_p(dead) < _plan_p(free) - 0.05


def test_standing_time_is_exposed_on_the_first_task_only():
    """``stand`` adds exposure to the tasks from q0 (the run's planning and confirming);
    with a long stand and ``lost`` = 1 nearly every first task ends lost, later ones not more often."""
    from clomp.formal.retry import map_lost

    kw = dict(samples=20, noise="harsh", seed=4, carry=True)
    pm = sample_map(np.zeros((0, 2)), (1.5, 0.0), pushes=Pushes(0.05, 0.2, lost=1.0, stand=200.0), **kw)
    lost = map_lost(pm.map.metadata)
    q0 = pm.map.initial.ident
    first = sum(float(t.probability) for t in pm.map.out_transitions(q0) if t.target in lost and t.label is TaskKind.STRAIGHT)
    assert first >= 0.95
    assert all(src == q0 for src in lost.values()) or all(
        sum(float(t.probability) for t in pm.map.out_transitions(src) if t.target in lost) < 0.95
        for src in set(lost.values()) - {q0}
    )


def test_whole_run_pushes_refuse_a_lost_chance_above_one():
    with pytest.raises(NoiseError):
        Pushes(0.02, 0.2, lost=1.5)


def test_closed_loop_export_samples_the_worlds_pushes_with_the_whole_run_terms(tmp_path, capsys):
    """``clomp export --closed-loop`` writes the model the calibration bench checks
    (:func:`clomp.planner.robust.closed_loop_pushes`): at harsh the world's pushes and the
    whole run's terms; at paper none; without ``--closed-loop`` none (the robust planner's map)."""
    import json

    import clomp.runtime.cli as cli
    from clomp.planner.pushes import WHOLE_RUN

    def meta(*extra: str) -> dict:
        out = tmp_path / "m.json"
        assert cli.main(["export", "--scenario", "overtaking", "--samples", "3", *extra, "-f", "json", "-o", str(out)]) == 0
        return json.loads(out.read_text())["metadata"]

    assert meta("--noise", "harsh", "--closed-loop")["pushes"] == [0.02, 0.2, *WHOLE_RUN["harsh"]]
    assert "pushes" not in meta("--noise", "paper", "--closed-loop")
    assert "pushes" not in meta("--noise", "harsh")
