"""A jump in the estimate while a task runs ends the task and the supervisor plans afresh (issue #36), in simulated time."""

from __future__ import annotations

import math

import pytest

from clomp.formal.model import Pose
from clomp.planner import load_scenario
from clomp.runtime.backends.world import make_world_robot
from clomp.runtime.supervision.execution import jumped
from clomp.runtime.supervision.states import Event as E
from clomp.runtime.supervision.states import SupervisorState as S
from clomp.runtime.supervision.supervisor import Supervisor, SupervisorConfig


def _jump_mid_task(shift: float, config: SupervisorConfig | None = None) -> tuple[Supervisor, float, Pose]:
    """Overtaking at ``ideal``: the first revolution after 3 s, while a task runs, re-localises
    the estimate ``shift`` m back along the heading (as a search after a push would); 3 s more."""
    scene = load_scenario("overtaking")
    sup = Supervisor(make_world_robot(scene, "ideal", seed=0), scene.goal_in_robot_frame(), config=config)
    take = sup.sensing.take
    done: list[tuple[float, Pose]] = []

    def take_and_jump(frame, now, cmd, still):  # type: ignore[no-untyped-def]
        rec = take(frame, now, cmd, still)
        if not done and now > 3.0 and sup.state is S.EXECUTING and sup._task is not None:
            p = sup.sensing.pose
            sup.sensing.relocate(Pose(p.x - shift * math.cos(p.theta), p.y - shift * math.sin(p.theta), p.theta))
            done.append((now - (sup._t0 or 0.0), sup.sensing.pose))
        return rec

    sup.sensing.take = take_and_jump  # type: ignore[method-assign]
    sup.start()
    while not sup.terminal and (not done or sup.clock.now() < done[0][0] + 3.0):
        t = sup.clock.now()
        sup.step()
        sup.clock.sleep(t + sup.model.tick - sup.clock.now())
    assert done
    return sup, done[0][0], done[0][1]


def test_a_jump_mid_task_ends_the_task_in_that_tick_and_the_supervisor_plans_anew() -> None:
    sup, at, pose = _jump_mid_task(0.15)
    ended = [t for t in sup.transitions if t.event is E.DISAGREE and "estimate jumped" in t.reason]
    assert len(ended) == 1 and ended[0].source is S.EXECUTING and ended[0].target is S.REPLANNING, sup.transitions
    assert abs(ended[0].time - at) < 1e-9  # in the tick of the revolution that moved it, not at the task's end
    assert "0.150 m" in ended[0].reason
    interrupted = [r for r in sup.tasks if r.outcome is not None and "estimate jumped" in r.outcome]
    assert len(interrupted) == 1 and interrupted[0].end_time == pytest.approx(at)
    assert interrupted[0].end_pose == pose  # ended where the jump put the belief, not driven on from it
    assert [p for p in sup.plans if p.time > at], "REPLANNING made or recalled a plan from the new belief"


def test_a_small_correction_lets_the_task_run_on() -> None:
    sup, _, _ = _jump_mid_task(0.03)
    assert not [t for t in sup.transitions if "estimate jumped" in t.reason], sup.transitions


def test_without_the_rule_the_task_drives_on_from_the_old_belief() -> None:
    sup, at, _ = _jump_mid_task(0.15, SupervisorConfig(replan_jump=(math.inf, math.inf)))
    assert not [t for t in sup.transitions if "estimate jumped" in t.reason]
    assert not [t for t in sup.transitions if t.source is S.EXECUTING and abs(t.time - at) < 1e-9]


def test_jumped_names_the_jump_beyond_either_limit() -> None:
    assert jumped(Pose(0.0, 0.0, 0.0), Pose(0.0, 0.0, 0.2), (0.05, 0.1)) == "0.000 m, 11°"
    assert jumped(Pose(1.0, 1.0, 3.1), Pose(1.0, 1.0, -3.1), (0.05, 0.1)) is None  # wrapped: 0.08 rad


@pytest.mark.parametrize("bad", [(0.05,), (0.0, 0.1), (0.05, -1.0), "0.05"])
def test_replan_jump_is_checked_when_the_config_is_made(bad: object) -> None:
    with pytest.raises(ValueError, match="replan_jump"):
        SupervisorConfig(replan_jump=bad)  # type: ignore[arg-type]
