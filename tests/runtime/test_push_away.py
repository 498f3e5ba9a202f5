"""After a push felt against an obstacle the supervisor moves clear first (MOVING_AWAY), in simulated time."""

from __future__ import annotations

import numpy as np

from clomp.planner import load_scenario
from clomp.planner.robot_model import RobotModel
from clomp.runtime.backends.world import make_world_robot
from clomp.runtime.experiment.onerun import run_contacts
from clomp.runtime.supervision.pushaway import away_move
from clomp.runtime.supervision.states import SupervisorState as S
from clomp.runtime.supervision.supervisor import Supervisor, SupervisorConfig


def _pushed_into_the_box(move_away: float | None) -> tuple[Supervisor, list]:
    """Overtaking, ideal noise with the IMU: 3 s in, while a task runs, a push slides the
    robot 0.3 m along +x into the box ahead; 5 s more of the run."""
    scene = load_scenario("overtaking")
    world = make_world_robot(scene, "ideal", seed=0)
    cfg = SupervisorConfig() if move_away is None else SupervisorConfig(move_away=move_away)
    sup = Supervisor(world, scene.goal_in_robot_frame(), config=cfg)
    sup.start()
    pushed = None
    while not sup.terminal and (pushed is None or sup.clock.now() < pushed + 5.0):
        t = sup.clock.now()
        if pushed is None and t > 3.0 and sup.state is S.EXECUTING:
            world.push(0.3, 0.0)
            pushed = t
        sup.step()
        sup.clock.sleep(t + sup.model.tick - sup.clock.now())
    assert pushed is not None
    return sup, run_contacts(world, scene)[0]


def test_a_push_into_the_box_is_answered_by_backing_off_and_stays_a_brush():
    sup, episodes = _pushed_into_the_box(None)  # the default move
    moves = [t for t in sup.transitions if t.target is S.MOVING_AWAY]
    assert len(moves) == 1 and "backing off" in moves[0].reason, sup.transitions
    after = [t for t in sup.transitions if t.source is S.MOVING_AWAY]
    assert after and after[0].target is S.REPLANNING and after[0].time - moves[0].time < 2.0
    assert episodes and all(e.brush for e in episodes), episodes  # touched, then clear within 0.5 s


def test_without_the_move_the_robot_stays_against_the_box_a_pushed_contact():
    sup, episodes = _pushed_into_the_box(0.0)
    assert not [t for t in sup.transitions if t.target is S.MOVING_AWAY]
    assert [e.pushed for e in episodes if not e.brush] == [True], episodes


def test_away_move_takes_the_side_that_helps_and_never_drives_into_a_point():
    m = RobotModel()
    ahead = np.array([[0.10, y] for y in np.linspace(-0.2, 0.2, 21)])
    behind = np.array([[-0.28, y] for y in np.linspace(-0.2, 0.2, 21)])  # 10 cm behind the body
    assert away_move(ahead, m, 0.04, 0.12) == -0.12
    assert away_move(np.vstack([ahead, behind]), m, 0.04, 0.12) is None  # backing off 12 cm would hit the wall behind
    assert away_move(np.vstack([ahead, behind]), m, 0.04, 0.05) == -0.05
    assert away_move(np.vstack([ahead, behind]), m, 0.04, 0.08) is None  # as near the wall behind then: no help
    assert away_move(ahead[:1], m, 0.04, 0.12) is None  # one point is noise, not an obstacle (hazard_points 2)
