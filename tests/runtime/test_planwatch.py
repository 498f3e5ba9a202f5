"""The supervisor's watch over its plan (clomp.runtime.supervision.planwatch): a robot that is
interrupted again and again before it moves comes to a defined end."""

from __future__ import annotations

from typing import Any

from clomp.planner import load_scenario
from clomp.runtime.backends import make_world_robot
from clomp.runtime.supervision import Supervisor, SupervisorConfig, SupervisorState

S = SupervisorState


def test_a_robot_interrupted_each_time_before_it_moves_gives_up_with_the_reason() -> None:
    """A hazard that stands in every tick (as false 'collision imminent' alarms did beside a
    box under harsh noise) must not hold the robot recalling until its time runs out: after
    two plans that ended where they began recall is skipped, after ``max_stuck`` it ends
    UNREACHABLE, saying why, the wheels stopped and the robot where it started."""
    scene = load_scenario("open")
    world = make_world_robot(scene, "paper", seed=0)
    sup = Supervisor(world, scene.goal_in_robot_frame(), config=SupervisorConfig(max_stuck=6))

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


# -- a spent budget is searched again, deeper -------------------------------------------------------
def _u_trap() -> tuple[Any, Any, dict[str, Any]]:
    """A U open toward the robot with the goal behind it (layout family ``u-trap``, seed 1, run 0;
    seed 0 run 1 escapes within 50 states since its turns of 0.4° towards the goal are not available):
    from the start, the paper's budget of 50 states runs out with the plan's end inside the U."""
    from clomp.runtime.experiment.layouts import make_layout

    layout = make_layout("u-trap", 1, 0)
    scene = layout.scene
    return scene, scene.scan(), layout.params


def _inside(end: Any, p: dict[str, Any]) -> bool:
    return bool(p["back_x"] - p["arm"] < end.x < p["back_x"] and abs(end.y - p["y"]) < p["inner_width"] / 2)


def test_a_spent_budget_is_searched_again_deeper_and_gets_round_the_u() -> None:
    """The plan of a spent budget ends at argmin φ, inside the U; ``plan_deepening`` searches
    the same scan with four times the budget and its search ends at a frontier (the goal
    stands in the floor's shadow, so no plan may claim it: issue #39), not with the budget spent. A search that
    did not spend its budget comes back as it was; ``deepen=1`` never searches again."""
    from clomp.planner.configurator import Configurator
    from clomp.runtime.supervision.planwatch import plan_deepening

    scene, scan, p = _u_trap()
    goal = scene.goal_in_robot_frame()
    first = Configurator().plan(scan, goal)
    assert first.stop_reason == "budget" and _inside(first.map[first.plan.states[-1]].end, p)
    assert plan_deepening(Configurator(), scan, goal, deepen=1).n_states == first.n_states
    deeper = plan_deepening(Configurator(), scan, goal)
    end = deeper.map[deeper.plan.states[-1]].end
    assert deeper.n_states > 50 and deeper.stop_reason == "frontier" and not deeper.reached_goal, (deeper.stop_reason, end)
    open_field = plan_deepening(Configurator(), scene.scan()[:0], goal)
    assert open_field.stop_reason == "goal" and open_field.n_states < 50


def test_the_supervisor_deepens_a_spent_search_unless_told_not_to() -> None:
    """The supervisor plans through ``plan_deepening``: with the default ``deepen`` a search
    that spent its 50 states is followed by one of 200 from the same scan; with ``deepen=1``
    none is; 0 is refused."""
    import pytest

    from clomp.planner.configurator import Configurator

    class Recording(Configurator):
        budgets: list[tuple[int, str]] = []  # (budget, stop reason) of each search, shared by the copies

        def plan(self, scan: Any, goal: Any) -> Any:
            r = super().plan(scan, goal)
            self.budgets.append((self.max_states, r.stop_reason))
            return r

    scene, _, _ = _u_trap()
    for deepen, expect in ((4, True), (1, False)):
        budgets = Recording.budgets = []
        world = make_world_robot(scene, "ideal", seed=0)
        Supervisor(world, scene.goal_in_robot_frame(), Recording(), config=SupervisorConfig(deepen=deepen)).run(max_time=4.0)
        world.close()
        assert budgets and budgets[0] == (50, "budget")
        assert (len(budgets) > 1 and budgets[1][0] == 200) is expect, budgets
        assert all(m == 50 for m, _ in budgets) is not expect
    with pytest.raises(ValueError, match="deepen must be a positive integer"):
        SupervisorConfig(deepen=0)
