"""The supervisor's watch over its plan (runtime.supervision.planwatch): a robot that is
interrupted again and again before it moves comes to a defined end."""

from __future__ import annotations

from typing import Any

from planner import load_scenario
from runtime.robots import make_world_robot
from runtime.supervision import Supervisor, SupervisorState

S = SupervisorState


def test_a_robot_interrupted_each_time_before_it_moves_gives_up_with_the_reason() -> None:
    """A hazard that stands in every tick (as false 'collision imminent' alarms did beside a
    box under harsh noise) must not hold the robot recalling until its time runs out: after
    two plans that ended where they began recall is skipped, after ``max_stuck`` it ends
    UNREACHABLE, saying why, the wheels stopped and the robot where it started."""
    scene = load_scenario("open")
    world = make_world_robot(scene, "paper", seed=0)
    sup = Supervisor(world, scene.goal_in_robot_frame(), max_stuck=6)

    def always(*args: Any, **kwargs: Any) -> str:
        return "collision imminent: injected"

    sup.watch.hazard = always  # type: ignore[method-assign]
    rep = sup.run(max_time=120.0)
    assert rep.state is S.UNREACHABLE, rep.reason
    assert "no progress, 6 plans in a row" in rep.reason and "collision imminent: injected" in rep.reason
    assert rep.time_s < 30.0  # about a second a plan, not the time limit
    skipped = [r for r in rep.recalls if r.reason.startswith("skipped: 2 plans in a row")]
    assert skipped and not any(r.ok for r in rep.recalls if r.time >= skipped[0].time)
    assert world.commanded == (0.0, 0.0)
    p = world.ground_truth_pose()
    assert abs(p.x - scene.start.x) < 0.02 and abs(p.y - scene.start.y) < 0.02
    world.close()
