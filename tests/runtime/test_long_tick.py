"""A tick that lasts (a plan made under load, issue #36's pty runs): the wheel command set
at its end drove only from then on. Real time, at load 15-29, one plan took 4.7 s inside a
tick; the next tick dead-reckoned the new STRAIGHT over all of it, a phantom 0.415 m, and
the run ended truly 0.55 m from the goal. Here a plan lasts 3 s of simulated time (the
robot stands meanwhile: the wheels are stopped while planning)."""

from __future__ import annotations

import math
from typing import Any

import pytest

from clomp.formal.geometry import wrap_angle

from clomp.planner import load_scenario
from clomp.runtime.backends.sim import SimRobot
from clomp.runtime.supervision import replanning
from clomp.runtime.supervision import supervisor as sup_module
from clomp.runtime.supervision.supervisor import Supervisor


def test_a_plan_that_lasts_does_not_move_the_estimate(monkeypatch: pytest.MonkeyPatch) -> None:
    scene = load_scenario("open")  # the first task is a STRAIGHT
    robot = SimRobot(scene, seed=0)
    real = replanning.fresh_plan

    def slow(sup: Supervisor, *args: Any, **kwargs: Any) -> Any:
        robot.sleep(3.0)  # the plan takes 3 s, the wheels stopped meanwhile; then its first task starts
        return real(sup, *args, **kwargs)

    monkeypatch.setattr(sup_module, "fresh_plan", slow)
    sup = Supervisor(robot, scene.goal_in_robot_frame())
    worst = [0.0]
    update = sup.sensing.update_pose

    def watched(now: float, cmd: tuple[float, float]) -> None:
        update(now, cmd)
        p, t = sup.sensing.pose, robot.pose
        worst[0] = max(worst[0], math.hypot(p.x - t.x, p.y - t.y) + 0.5 * abs(wrap_angle(p.theta - t.theta)))

    monkeypatch.setattr(sup.sensing, "update_pose", watched)
    sup.run(max_time=120.0)
    assert len(sup.fresh_plans) >= 1
    assert worst[0] < 0.1, worst[0]  # position and heading (per 0.5 m of lever)
