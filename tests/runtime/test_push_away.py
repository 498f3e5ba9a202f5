"""After a push felt against an obstacle the supervisor moves clear first (MOVING_AWAY), in simulated time."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from clomp.formal.model import Pose
from clomp.planner.footprint import body_box, inside

from clomp.planner import load_scenario
from clomp.planner.robot_model import RobotModel
from clomp.runtime.backends.world import make_world_robot
from clomp.runtime.experiment.onerun import run_contacts
from clomp.runtime.experiment.runrecords import run_spec
from clomp.runtime.experiment.runspec import RunSpec
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


def _seen_through_beside_the_box(jump: float, kind: str = "seen through") -> Supervisor:
    """Overtaking at ``ideal``, no push: 3 s in, while a task runs, three points appear 2 cm
    ahead of the body in every revolution (within the push margin), and the estimator's
    doubt records a revolution seeing through the map; with ``jump`` > 0 that revolution
    also moves the estimate ``jump`` m (as the matches following a pushed body do). 2 s more."""
    scene = load_scenario("overtaking")
    world = make_world_robot(scene, "ideal", seed=0)
    sup = Supervisor(world, scene.goal_in_robot_frame())
    read, take = world.read_scan, sup.sensing.take
    near = np.array([[0.11, -0.02], [0.11, 0.0], [0.11, 0.02]])
    seen: list[float] = []

    def read_near(timeout: float | None = None):  # type: ignore[no-untyped-def]
        frame = read(timeout=timeout)
        if frame is None or not seen:
            return frame
        times = None if frame.point_times is None else np.concatenate([frame.point_times, np.zeros(3)])
        quality = None if frame.quality is None else np.concatenate([frame.quality, np.full(3, frame.quality.max())])
        return dataclasses.replace(frame, points=np.vstack([frame.points, near]), point_times=times, quality=quality)

    def take_and_see(frame, now, cmd, still):  # type: ignore[no-untyped-def]
        rec = take(frame, now, cmd, still)
        if not seen and now > 3.0 and sup.state is S.EXECUTING:
            assert sup.estimator is not None
            sup.estimator.doubt.events.append((now, kind, 0.1))
            if jump > 0:
                p = sup.sensing.pose
                sup.sensing.relocate(Pose(p.x + jump, p.y, p.theta))
            seen.append(now)
        return rec

    world.read_scan = read_near  # type: ignore[method-assign]
    sup.sensing.take = take_and_see  # type: ignore[method-assign]
    sup.start()
    while not sup.terminal and (not seen or sup.clock.now() < seen[0] + 2.0):
        t = sup.clock.now()
        sup.step()
        sup.clock.sleep(t + sup.model.tick - sup.clock.now())
    assert seen
    return sup


def test_seeing_through_the_map_without_a_push_does_not_start_a_move_away() -> None:
    sup = _seen_through_beside_the_box(0.0)
    assert not [t for t in sup.transitions if t.target is S.MOVING_AWAY], sup.transitions


def test_seeing_through_the_map_as_the_estimate_jumps_is_a_push() -> None:
    sup = _seen_through_beside_the_box(0.1)
    assert [t for t in sup.transitions if t.target is S.MOVING_AWAY], sup.transitions


def test_seeing_nearer_than_the_map_as_the_estimate_jumps_is_a_push_too() -> None:
    """A push *towards* surfaces is seen nearer, not through (``Doubt.seen``): the same move away."""
    sup = _seen_through_beside_the_box(0.1, "seen nearer")
    assert [t for t in sup.transitions if t.target is S.MOVING_AWAY], sup.transitions
    assert not [t for t in _seen_through_beside_the_box(0.0, "seen nearer").transitions if t.target is S.MOVING_AWAY]


def _arc(cx: float, cy: float, r: float, a0: float, a1: float) -> np.ndarray:
    return np.array([[cx + r * np.cos(a), cy + r * np.sin(a)] for a in np.linspace(a0, a1, 15)])


def test_beside_a_post_the_move_backs_off_until_the_post_is_clear_of_its_corner() -> None:
    """A post touching the body's left side just ahead of its centre (as a push left it in
    clutter 1/0 at harsh): backing off the usual 12 cm slides the body along it and leaves
    it at the front corner within the margin; the move backs off until it is clear, and no
    farther than a post behind allows."""
    m = RobotModel()
    post = _arc(0.03, 0.09 + 0.0465, 0.0465, -2.6, -0.5)
    grown = body_box(m, 0.04)
    d = away_move(post, m, 0.04, 0.12, longest=0.3)
    assert d is not None and -0.3 <= d < -0.12
    assert np.count_nonzero(inside(post[:, 0] - d, np.abs(post[:, 1]), grown)) < 2  # clear of the margin
    assert np.count_nonzero(inside(post[:, 0] + 0.12, np.abs(post[:, 1]), grown)) >= 2  # 12 cm was not
    wall = np.array([[0.10, y] for y in np.linspace(-0.2, 0.05, 11)])  # 1 cm ahead: no driving on
    far = _arc(-0.45, 0.0, 0.042, -0.6, 0.6)  # a post behind, 23 cm from the rear
    near = _arc(-0.35, 0.0, 0.042, -0.6, 0.6)  # 13 cm from it
    assert away_move(np.vstack([post, wall, far]), m, 0.04, 0.12, longest=0.3) == pytest.approx(-0.14)
    assert away_move(np.vstack([post, wall, near]), m, 0.04, 0.12, longest=0.3) == pytest.approx(-0.12)  # no farther


@pytest.mark.slow
def test_clutter_1_0_harsh_a_push_into_a_post_still_leaves_a_plan() -> None:
    """clutter 1/0, harsh with the gyro: pushed into a post at 27.4 s, the robot backed off 12 cm
    and stood with the post at its corner, 1.4 cm away; three plans found no safe task
    (UNREACHABLE 0.42 m off, session 7). Backing off until clear, it plans on."""
    rec = run_spec(RunSpec("clutter", 1, 0, "planning", "harsh", gyro=True))
    assert rec["end_state"] != "UNREACHABLE", rec["reason"]
    assert rec["final_error_m"] < 0.1


def test_the_move_goes_past_its_length_only_to_get_clear_and_never_dragged_along_a_surface() -> None:
    """Against a wall behind, touching an obstacle's side along its left (as the push left it in
    slalom 0/1 at harsh): driving on clears the wall behind within 12 cm, then the body stays
    against the side until 29 cm, which left it clear of the margin (driven there, it scraped
    the side for 1.3 s). It drives on the 12 cm. And a farther move that does not get clear is
    not made: beside a post, with another post's margin where the first is clear, 12 cm it is."""
    m = RobotModel()
    behind = np.array([[-0.19, y] for y in np.linspace(-0.05, 0.05, 6)])
    side = np.array([[x, 0.085] for x in np.linspace(-0.06, 0.06, 13)])  # 5 mm inside the body's side
    assert away_move(np.vstack([behind, side]), m, 0.04, 0.12, longest=0.3) == pytest.approx(0.12)
    post = _arc(0.03, 0.09 + 0.0465, 0.0465, -2.6, -0.5)
    wall = np.array([[0.10, y] for y in np.linspace(-0.2, 0.05, 11)])  # 1 cm ahead: no driving on
    blocker = _arc(-0.40, 0.0, 0.042, -0.6, 0.6)  # its margin takes the 14 cm where the post is clear
    assert away_move(np.vstack([post, wall, blocker]), m, 0.04, 0.12, longest=0.3) == pytest.approx(-0.12)


@pytest.mark.slow
def test_slalom_0_1_harsh_the_move_away_does_not_scrape_along_an_obstacle() -> None:
    """slalom 0/1, harsh (the behaviour digest's run): pushed against an obstacle's side at
    24.1 s, a move driven on 29 cm along it scraped it for 1.3 s (0.2 mm deep). Backing off
    12 cm, the robot touches nothing but where the push put it."""
    rec = run_spec(RunSpec("slalom", 0, 1, "planning", "harsh", max_time=60.0))
    assert (rec["collisions"], rec["pushed_contacts"]) == (0, 1), rec["reason"]
