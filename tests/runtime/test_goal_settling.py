"""The goal is declared on the settled estimate, not on the one taken while driving."""

from __future__ import annotations

from clomp.planner import load_scenario
from clomp.runtime.backends import make_world_robot
from clomp.runtime.supervision import Supervisor, SupervisorConfig, SupervisorState

S = SupervisorState


def test_a_plan_ending_at_the_goal_stands_and_decides_on_the_settled_estimate() -> None:
    scene = load_scenario("overtaking")
    world = make_world_robot(scene, "paper", seed=0)
    sup = Supervisor(world, scene.goal_in_robot_frame())
    rep = sup.run(max_time=120)
    assert rep.state is S.GOAL_REACHED, rep.reason
    last, before = rep.transitions[-1], rep.transitions[-2]
    assert last.source is S.REPLANNING and last.target is S.GOAL_REACHED
    assert before.source is S.EXECUTING and "settling" in before.reason
    # it stood through the settling revolutions: the wheels were not driven in between
    standing = [p for p in rep.trajectory if before.time <= p[0] <= last.time]
    assert last.time - before.time >= 0.5 and len(standing) >= 5
    world.close()


def test_without_scan_feedback_the_plan_ends_at_the_goal_at_once() -> None:
    """Dead reckoning learns nothing from standing: there is nothing to settle."""
    scene = load_scenario("overtaking")
    world = make_world_robot(scene, "paper", seed=0)
    rep = Supervisor(world, scene.goal_in_robot_frame(), config=SupervisorConfig(feedback="none")).run(max_time=120)
    assert rep.state is S.GOAL_REACHED, rep.reason
    assert rep.transitions[-1].source is S.EXECUTING
    world.close()
