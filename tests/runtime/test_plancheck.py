"""Plan checking and recall, and the supervisor's contract with them under any noise."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from clomp.formal.geometry import compose, relative
from clomp.formal.model import Pose, TaskKind
from clomp.planner import Configurator, load_scenario
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.backends import make_world_robot
from clomp.runtime.supervision import Supervisor, SupervisorState
from clomp.runtime.supervision.plancheck import check_plan, perceive_scan, recall
from clomp.runtime.supervision.states import MOTOR_STATES

S = SupervisorState
ORIGIN = Pose(0.0, 0.0, 0.0)


def _plan(name: str = "overtaking") -> tuple[Any, np.ndarray, Pose]:
    scene = load_scenario(name)
    scan = scene.scan()
    result = Configurator().plan(scan, tuple(scene.goal_in_robot_frame()))
    goal = Pose(*scene.goal_in_robot_frame())
    return result, scan, goal


def _wall_across(p: Pose, half: float = 0.25) -> np.ndarray:
    """Points of a wall across the heading of ``p``, through ``p`` (frame of ``p``'s parent)."""
    s = np.linspace(-half, half, 51)
    c, si = math.cos(p.theta), math.sin(p.theta)
    return np.c_[p.x - si * s, p.y + c * s]


def test_a_plan_checks_free_on_the_scan_it_was_made_from():
    result, scan, goal = _plan()
    v = check_plan(result.steps, ORIGIN, ORIGIN, goal, perceive_scan(scan, result.robot), result.robot)
    assert v.ok, v.reason
    assert v.tasks == len(result.steps) and v.duration_s >= 0


def test_an_obstacle_across_a_remaining_task_fails_the_check_and_names_it():
    result, scan, goal = _plan()
    steps = result.steps
    k = next(i for i, q in enumerate(steps) if q.task is TaskKind.STRAIGHT and i > 0 and q.distance > 0.1)
    q = steps[k]
    mid = Pose((q.start.x + q.end.x) / 2, (q.start.y + q.end.y) / 2, q.start.theta)
    blocked = np.r_[scan, _wall_across(mid)]
    v = check_plan(steps, ORIGIN, ORIGIN, goal, perceive_scan(blocked, result.robot), result.robot)
    assert not v.ok and "meets an obstacle" in v.reason
    assert v.tasks <= k + 1


def test_a_robot_off_the_planned_path_fails_the_check():
    result, scan, goal = _plan()
    off = Pose(0.0, 0.15, 0.0)  # 15 cm to the left of where the plan starts
    pts = relative(off, ORIGIN)
    c, s = math.cos(pts.theta), math.sin(pts.theta)
    seen = np.c_[pts.x + c * scan[:, 0] - s * scan[:, 1], pts.y + s * scan[:, 0] + c * scan[:, 1]]
    v = check_plan(result.steps, ORIGIN, off, goal, perceive_scan(seen, result.robot), result.robot)
    assert not v.ok and ("prediction" in v.reason or "obstacle" in v.reason)


def test_recall_continues_the_map_from_where_the_robot_is():
    result, scan, goal = _plan()
    states = result.plan.states
    here_id = states[2]
    here = result.map[here_id].end  # the robot stands where the map's third state ended
    rel = relative(here, ORIGIN)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    seen = np.c_[rel.x + c * scan[:, 0] - s * scan[:, 1], rel.y + s * scan[:, 0] + c * scan[:, 1]]
    found, why, took = recall(result, ORIGIN, here, goal, perceive_scan(seen, result.robot), result.robot)
    assert found is not None, why
    assert took >= 0 and "recalled from q" in why
    cmap = found.result.map
    assert found.state in found.result.plan.states
    # the recalled plan is a plan of the same map, enabled by its guard Ψ
    for a, b in found.result.plan.steps():
        assert cmap.has_transition(a, b)
    assert all(v in (0, 1) for v in found.result.psi.values())
    assert sum(found.result.psi.values()) == len(found.result.plan.steps())


def test_recall_fails_far_from_every_state_or_when_the_new_scan_blocks_the_way():
    result, scan, goal = _plan()
    obstacles = perceive_scan(scan, result.robot)
    found, why, _ = recall(result, ORIGIN, Pose(-2.0, 2.0, 1.0), goal, obstacles, result.robot)
    assert found is None and "no state of the map" in why
    here_id = result.plan.states[1]
    here = result.map[here_id].end
    rest = [result.map[i] for i in result.plan.states[2:]]
    wall = np.r_[scan, *[_wall_across(Pose((q.start.x + q.end.x) / 2, (q.start.y + q.end.y) / 2, q.start.theta), 0.4)
                         for q in rest if q.task is TaskKind.STRAIGHT and q.distance > 0.1]]
    rel = relative(here, ORIGIN)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    seen = np.c_[rel.x + c * wall[:, 0] - s * wall[:, 1], rel.y + s * wall[:, 0] + c * wall[:, 1]]
    found, why, _ = recall(result, ORIGIN, here, goal, perceive_scan(seen, result.robot), result.robot)
    assert found is None, why


# -- the supervisor ----------------------------------------------------------------------------------
class Phantom:
    """A world robot whose scans show a wall (world frame) once ``wall`` is set."""

    def __init__(self, world: Any) -> None:
        self.world = world
        self.wall: np.ndarray | None = None
        self.frames_with_wall = 0

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        frame = self.world.read_scan(timeout)
        if frame is None or self.wall is None:
            return frame
        p = self.world.ground_truth_pose()
        rel = relative(p, Pose(0.0, 0.0, 0.0))
        c, s = math.cos(rel.theta), math.sin(rel.theta)
        pts = np.c_[rel.x + c * self.wall[:, 0] - s * self.wall[:, 1], rel.y + s * self.wall[:, 0] + c * self.wall[:, 1]]
        pts = pts[np.hypot(pts[:, 0], pts[:, 1]) <= 1.0]
        if len(pts) == 0:
            return frame
        self.frames_with_wall += 1
        times = None if frame.point_times is None else np.r_[frame.point_times, np.zeros(len(pts))]
        return ScanFrame(np.r_[frame.points, pts], frame.timestamp, point_times=times)

    def __getattr__(self, name: str) -> Any:
        return getattr(self.world, name)


def _tick(sup: Supervisor, world: Any) -> None:
    t = world.now()
    sup.step()
    world.sleep(t + 0.1 - world.now())


def test_replanning_recalls_before_it_explores_and_planning_never_does():
    scene = load_scenario("slalom")  # the second box hides behind the first: replanning
    world = make_world_robot(scene, "paper", seed=1)
    rep = Supervisor(world, scene.goal_in_robot_frame()).run(max_time=120)
    assert rep.fresh_plans and rep.fresh_plans[0].time == pytest.approx(rep.plans[0].time)
    assert not rep.plans[0].recalled and not [r for r in rep.recalls if r.time <= rep.plans[0].time]
    replans = [t.time for t in rep.transitions if t.source is S.REPLANNING and t.event.value == "planned"]
    assert replans
    for t in replans:
        tried = [r for r in rep.recalls if r.time == pytest.approx(t)]
        fresh = [f for f in rep.fresh_plans if f.time == pytest.approx(t)]
        assert tried, f"REPLANNING at {t:.1f} s explored without trying recall"
        assert tried[0].ok != bool(fresh)  # a recall that worked made no fresh plan, one that failed did
    assert len(rep.checks) > 10 and all(c.duration_s >= 0 for c in rep.checks)


@given(noise=st.sampled_from(["ideal", "paper", "harsh"]), scale=st.sampled_from([0.5, 1.0, 2.0]),
       seed=st.integers(0, 1000), at=st.integers(8, 40))
@settings(max_examples=8, deadline=None)
@example(noise="harsh", scale=0.5, seed=1, at=8)  # pushed against the box: it moves away (MOVING_AWAY drives)
def test_wheels_drive_only_while_executing_and_a_blocked_plan_is_never_continued(noise, scale, seed, at):
    """Whatever the noise: (1) the wheels are commanded only in a state whose table lets them
    turn (EXECUTING, and MOVING_AWAY after a push against an obstacle) and come to rest
    within the latency and the deceleration after it; (2) once a revolution shows an obstacle
    across a remaining task of the plan, that plan is not continued."""
    scene = load_scenario("overtaking")
    world = make_world_robot(scene, noise, noise_scale=scale, seed=seed)
    robot = Phantom(world)
    sup = Supervisor(robot, scene.goal_in_robot_frame())
    settle = world.noise.latency + world.body.max_wheel_speed / world.body.wheel_accel + 0.15
    left_executing: float | None = None
    blocked_plan = None
    seen_before = 0
    for k in range(400):
        if sup.terminal:
            break
        if k == at and sup.state is S.EXECUTING and sup._plan is not None and robot.wall is None:
            queued = [q for q, _ in sup._queue if q.task is TaskKind.STRAIGHT and q.distance > 0.1]
            if queued:
                q = queued[0]
                mid = sup._plan.to_frame(Pose((q.start.x + q.end.x) / 2, (q.start.y + q.end.y) / 2, q.start.theta))
                robot.wall = _wall_across(compose(world.start_pose, mid), 0.3)
                blocked_plan = sup._plan
                seen_before = robot.frames_with_wall
        _tick(sup, world)
        # (1) the wheels
        if sup.state not in MOTOR_STATES:
            assert world.commanded == (0.0, 0.0) and sup.commanded == (0.0, 0.0)
            left_executing = world.now() if left_executing is None else left_executing
            if world.now() - left_executing > settle:
                assert world.wheel_speeds == (0.0, 0.0)
        else:
            left_executing = None
        # (2) the blocked plan
        if blocked_plan is not None and robot.frames_with_wall > seen_before:
            assert not (sup.state is S.EXECUTING and sup._plan is blocked_plan), "continued a blocked plan"
    world.close()


# -- the closed-form check against brute force and against the planner's rollouts ----------------
def _body_sweeps_a_point(pts: np.ndarray, legs: list[Any], m: Any, tol: tuple[float, float]) -> bool:
    """Brute force: does the real (uninflated) body, moved in 2 mm / 0.5° steps along each
    leg up to ``tol`` before its end, cover a point that was not already under it at the
    leg's start?"""
    for g in legs:
        if g.amount <= 1e-3:
            continue
        x0, y0, th0 = g.start
        if g.kind is TaskKind.STRAIGHT:
            n = max(2, int((g.amount - tol[0]) / 0.002) + 1)
            poses = [(x0 + math.cos(th0) * d, y0 + math.sin(th0) * d, th0)
                     for d in np.linspace(0.0, max(g.amount - tol[0], 0.0), n)]
        else:
            sign = 1.0 if g.kind is TaskKind.LEFT else -1.0
            n = max(2, int((g.amount - tol[1]) / math.radians(0.5)) + 1)
            poses = [(x0, y0, th0 + sign * a) for a in np.linspace(0.0, max(g.amount - tol[1], 0.0), n)]

        def under(x: float, y: float, th: float) -> np.ndarray:
            dx, dy = pts[:, 0] - x, pts[:, 1] - y
            u = dx * math.cos(th) + dy * math.sin(th)
            v = -dx * math.sin(th) + dy * math.cos(th)
            return (u > -m.rear_offset) & (u < m.front_offset) & (np.abs(v) < m.width / 2)

        at_start = under(*poses[0])
        for p in poses[1:]:
            if (under(*p) & ~at_start).any():
                return True
    return False


@given(name=st.sampled_from(["overtaking", "corridor", "doorway", "slalom"]), layout=st.integers(0, 20),
       dx=st.floats(-0.03, 0.03), dy=st.floats(-0.03, 0.03), dth=st.floats(-0.08, 0.08),
       wall=st.one_of(st.just(None), st.tuples(st.floats(0.0, 1.0), st.floats(0.0, 1.0), st.floats(-0.15, 0.15),
                                           st.floats(0.0, math.pi))),
       noise=st.sampled_from(["ideal", "paper", "harsh"]))
@settings(max_examples=50, deadline=None)
def test_a_check_that_passes_leaves_no_point_in_the_bodys_path(name, layout, dx, dy, dth, wall, noise):
    """Whatever the layout, the pose error, an extra wall anywhere and the sensor noise: when
    :func:`check_plan` passes a plan's remaining tasks, the real body, moved along them from
    the estimated pose, covers no point of the scan (up to the tolerance before each end)."""
    from clomp.runtime.experiment.layouts import make_layout
    from clomp.runtime.supervision.checkgeometry import _legs

    scene = make_layout(name, 0, layout).scene
    world = make_world_robot(scene, noise, seed=layout)
    scan = world.read_scan().points
    goal = Pose(*scene.goal_in_robot_frame())
    result = Configurator().plan(scan, (goal.x, goal.y))
    if not result.steps:
        return
    pose = Pose(dx, dy, dth)
    seen = np.asarray(scan)
    if wall is not None:  # a short wall where the body will pass, at any angle
        which, t, side, wth = wall
        q = result.steps[min(int(which * len(result.steps)), len(result.steps) - 1)]
        if q.task is TaskKind.STRAIGHT:  # ahead of the front along the straight
            a, r = q.start.theta, result.robot.front_offset + 0.03 + t * max(q.distance - 0.05, 0.0)
            at = Pose(q.start.x + r * math.cos(a) - side * math.sin(a), q.start.y + r * math.sin(a) + side * math.cos(a), wth)
        else:  # on the circle the rear corners sweep, somewhere along the turn
            a = q.start.theta + (1 if q.task is TaskKind.LEFT else -1) * t * abs(q.end.theta - q.start.theta) + math.pi
            at = Pose(q.start.x + 0.19 * math.cos(a), q.start.y + 0.19 * math.sin(a), wth)
        seen = np.r_[seen, _wall_across(at, 0.05)]
    rel = relative(pose, ORIGIN)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    seen = np.c_[rel.x + c * seen[:, 0] - s * seen[:, 1], rel.y + s * seen[:, 0] + c * seen[:, 1]]
    seen = seen[np.hypot(seen[:, 0], seen[:, 1]) <= result.robot.sensor_range]
    tol = (0.08, 0.3)
    v = check_plan(result.steps, ORIGIN, pose, goal, seen, result.robot, tolerance=tol)
    if v.ok:
        legs = _legs(result.steps, relative(pose, ORIGIN), False)
        assert not _body_sweeps_a_point(seen, legs, result.robot, tol), v.reason


def test_the_check_agrees_with_re_simulating_the_plan_on_a_blocked_and_a_free_scan():
    from clomp.runtime.supervision.plancheck import resimulate_plan

    result, scan, goal = _plan()
    robot = result.robot
    assert check_plan(result.steps, ORIGIN, ORIGIN, goal, scan, robot).ok
    assert resimulate_plan(result.steps, ORIGIN, ORIGIN, goal, perceive_scan(scan, robot), robot).ok
    q = next(q for i, q in enumerate(result.steps) if q.task is TaskKind.STRAIGHT and i > 0 and q.distance > 0.1)
    blocked = np.r_[scan, _wall_across(Pose((q.start.x + q.end.x) / 2, (q.start.y + q.end.y) / 2, q.start.theta))]
    fast = check_plan(result.steps, ORIGIN, ORIGIN, goal, blocked, robot)
    slow = resimulate_plan(result.steps, ORIGIN, ORIGIN, goal, perceive_scan(blocked, robot), robot)
    assert not fast.ok and not slow.ok
    assert fast.tasks == slow.tasks and fast.reason == slow.reason


def test_a_recalled_plans_guard_is_the_maps_guard_of_that_plan():
    from clomp.formal.supervisory import Guard

    result, scan, goal = _plan()
    here = result.map[result.plan.states[2]].end
    rel = relative(here, ORIGIN)
    c, s = math.cos(rel.theta), math.sin(rel.theta)
    seen = np.c_[rel.x + c * scan[:, 0] - s * scan[:, 1], rel.y + s * scan[:, 0] + c * scan[:, 1]]
    found, why, _ = recall(result, ORIGIN, here, goal, seen, result.robot)
    assert found is not None, why
    assert found.result.psi == Guard(result.map, found.result.plan).table()
