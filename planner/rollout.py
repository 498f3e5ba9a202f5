"""Core knowledge: one task rolled forward in the world of what the scan saw.

A planning run shares one scene (:class:`clomp.planner.contact.Scene`): the sensed points perception kept (in surface order)
as flat arrays, and the body's extents, built once; no rollout allocates anything per
point or builds a shape. A task's outcome is computed in closed form from the points:

- a STRAIGHT translates the inflated footprint: the first point that enters its lane
  ahead gives the exact distance to contact; the task ends at the last control tick
  before it (D_N names the point's box and the point). Nothing in the lane: the task
  runs its length (the controllers drive their error down linearly, tested against the
  engine's tick loop);
  A step that would end with a point ahead nearer than the body needs to spin in place
  ends that much earlier (the straight as short as the geometry needs: from there the
  plan can still turn);
- a turn spins the footprint in place: only points within its swept disc matter, and
  they are tested at every tick heading (the corner moves at most 1.2 cm between ticks,
  within the 1 cm clearance plus the real body's own sides).

The boxes of :mod:`clomp.planner.perception` are the obstacles' outlines (D_N, the map, the
goal test); the rollouts test the points themselves, so **the margin between the body
and a sensed point is exactly the body's** ``clearance`` **(1 cm)**, however thick a
box is. The recorded scans round coordinates to 1 cm, so a surface may lie up to 7 mm
nearer than its point: that is the sensor-noise allowance the clearance has to absorb
(no further padding is added).

**The start-touching rule.** A point already inside the inflated footprint when a task
starts (within the margin, e.g. a wall the previous task ended against) waives the
margin for that point only: it interrupts the task when the *real* body would touch it.
Points inside the real body at the planning origin are the robot's own returns and were
dropped by perception (``Obstacles.exempt``); no other point is ever exempt.

**Unseen space.** What the scan saw is the sensor disc (radius ``sensor_range`` around
the planning origin): beyond it nothing is known. A STRAIGHT that would carry the body
out of the disc ends where the body touches its rim (``Outcome.frontier``); a turn whose
sweep would leave it is not available (it comes back with ``frontier`` set and is not
added to the map). When the goal lies inside the disc, a step that would reach the rim
ends instead where the body can still spin in place inside it (a way to the goal may
turn round the end of a wall there), unless that leaves less than 3 cm to drive. LiDAR
shadows (the space behind a sensed surface) lie inside the disc and are unknown too: the
rollouts do not test them, the Configurator does (:mod:`clomp.planner.visibility`: a task
whose body leaves what the rays crossed is a frontier end, like one at the rim).

:class:`clomp.planner.engine.World` is the pymunk engine the closed forms are tested against;
rollouts are deterministic: the same inputs give bit-identical outcomes.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.planner.contact import SPIN_SLACK, Scene, cut_straight, unobstructed
from clomp.planner.engine import Outcome, World
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task

__all__ = ["MIN_TURN", "Outcome", "World", "in_the_way", "straight_limit", "simulate", "make_task", "frontier_distance", "turn_angle"]

MIN_TURN = math.radians(1.0)
"""The smallest turn the search expands (rad): a turn whose chosen angle is less (facing a
goal that lies within 1° of the heading) is not available, as one that would leave the
sensed disc is not. It changes nothing a plan can use (the straight from its parent passes
such a goal within its 5 cm tolerance up to 2.8 m away; farther, the next plan turns), and
its straight nearly repeats the parent's: the demo's first plan began with a RIGHT of
0.0014° (issue #39)."""


def in_the_way(obstacles: Obstacles, robot: RobotModel, start: Pose, kind: TaskKind, length: float) -> np.ndarray:
    """Indices of the obstacles a task from ``start`` could touch (a numpy filter).

    STRAIGHT: boxes overlapping the corridor swept by the inflated footprint over
    ``length`` metres (tested on the boxes' extents in the task frame). Turns: boxes
    within the disc the footprint sweeps. Conservative: the engine decides exactly.
    """
    if len(obstacles) == 0:
        return np.zeros(0, dtype=np.intp)
    if kind is TaskKind.STRAIGHT:
        c, s = math.cos(start.theta), math.sin(start.theta)
        rel = obstacles.boxes - np.array([start.x, start.y])
        u = rel[..., 0] * c + rel[..., 1] * s
        v = rel[..., 1] * c - rel[..., 0] * s
        fp = robot.footprint
        u_lo, u_hi = fp[0][0], length + fp[1][0]
        half = fp[2][1]
        hit = (u.max(axis=1) >= u_lo) & (u.min(axis=1) <= u_hi) & (v.max(axis=1) >= -half) & (v.min(axis=1) <= half)
        return np.flatnonzero(hit)
    d = np.hypot(obstacles.centres[:, 0] - start.x, obstacles.centres[:, 1] - start.y)
    return np.flatnonzero(d - obstacles.radii <= robot.swept_radius)


def frontier_distance(robot: RobotModel, start: Pose) -> float:
    """How far a STRAIGHT from ``start`` can drive before the real body leaves the
    sensed disc (radius ``robot.sensor_range`` around the planning origin); 0 when it
    is already at (or past) the rim.

    >>> round(frontier_distance(RobotModel(), Pose(0.0, 0.0, 0.0)), 4)
    1.0063
    """
    return _frontier_at(robot, start.x, start.y, start.theta)


def _frontier_at(robot: RobotModel, sx: float, sy: float, theta: float) -> float:
    # :func:`frontier_distance` for a pose given as three floats (no Pose built)
    c, s = math.cos(theta), math.sin(theta)
    r2 = robot.sensor_range * robot.sensor_range
    best = math.inf
    for a, b in robot.corners:
        x = sx + a * c - b * s
        y = sy + a * s + b * c
        bb = x * c + y * s
        q = x * x + y * y - r2
        disc = bb * bb - q
        if q > 0 or disc < 0:
            return 0.0
        d = -bb + math.sqrt(disc)
        if d < best:
            best = d
    return 0.0 if 0.0 > best else best  # max(best, 0.0), to the bit


def _inside_for(robot: RobotModel, x: float, y: float, theta: float, length: float) -> bool:
    """True when the real body surely stays inside the sensed disc over a STRAIGHT of
    ``length`` from (x, y) heading ``theta``: its centre's path stays within the rim less
    the body's radius (then no corner can reach the rim), with 1e-9 m to spare. Then
    :func:`frontier_distance` is at least ``length`` and need not be computed."""
    r = robot.sensor_range - robot.body_radius
    q = x * x + y * y - r * r
    if q > 0:
        return False
    bb = x * math.cos(theta) + y * math.sin(theta)
    return -bb + math.sqrt(bb * bb - q) >= length + 1e-9


def _turn_leaves_disc(robot: RobotModel, start: Pose, signed_angle: float) -> bool:
    """True when the real body, spinning in place by ``signed_angle``, leaves the sensed disc."""
    cx, cy = start.x, start.y
    dist = math.hypot(cx, cy)
    reach = robot.sensor_range
    rmax = robot.body_radius
    if dist + rmax <= reach:
        return False
    n = max(2, int(math.ceil(abs(signed_angle) / 0.2)))
    grow = rmax * (1 - math.cos(abs(signed_angle) / n / 2))
    for k in range(n + 1):
        th = start.theta + signed_angle * k / n
        c, s = math.cos(th), math.sin(th)
        for a, b in robot.corners:
            if math.hypot(cx + a * c - b * s, cy + a * s + b * c) + grow > reach:
                return True
    return False


def straight_limit(obstacles: Obstacles, robot: RobotModel, start: Pose, goal: Disturbance | None) -> float:
    """How far a STRAIGHT from ``start`` may drive: what :func:`simulate` starts.

    A clear run to a goal dead ahead (within the goal tolerance of the heading line and
    no sensed point in the lane before it) is one task to the goal. Otherwise straights
    are cut into steps of ``robot.step_length`` (one body length) so that a plan can
    turn along the way; with ``step_length=None`` a straight runs to the sensor range.
    Either is cut where the body would leave the sensed disc, and a step where the body
    could no longer spin in place (:func:`_spin_room_step`).
    """
    room = frontier_distance(robot, start)
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    along = _goal_dead_ahead(robot, start, goal)
    d = _scene(obstacles, robot, None).straight_gap(start)[0] if len(obstacles) else math.inf
    if along is not None and d >= min(along, room):
        return min(along, room)
    return _free_step(robot, start, goal, d, min(step, room), room)


def _free_step(robot: RobotModel, start: Pose, goal: Disturbance | None, gap: float, limit: float, room: float) -> float:
    """A step of at most ``limit`` metres (``gap`` free ahead, ``room`` to the rim), cut
    where the body can still spin in place: short of a point ahead
    (:func:`_spin_room_step`), and, for a goal inside the sensed disc, short of the rim
    (:func:`_rim_spin_room`). A step cut at the rim ends a way that needs unseen space
    (a frontier state, never expanded); cut where the body can still spin, the search
    can turn there towards a goal round the end of a wall near the rim (recorded scan 138)."""
    limit = _spin_room_step(robot, gap, limit)
    if limit >= room - _EPS and goal is not None and robot.free_turns and math.hypot(goal.x, goal.y) <= robot.sensor_range:
        spin = _rim_spin_room(robot, start)
        if _MIN_STEP <= spin < limit:
            return spin
    return limit


def _spin_room_step(robot: RobotModel, gap: float, limit: float) -> float:
    """A step of ``limit`` metres with ``gap`` metres free ahead, cut where the body can
    still spin in place: a step that would end closer to a point ahead than the swept
    disc reaches past the front ends that much earlier (the straight as short as the
    geometry needs), unless that leaves less than 3 cm to drive. With the authors' fixed
    turns (``free_turns=False``) every step is one body length, as theirs.

    >>> round(_spin_room_step(RobotModel(), 0.30, 0.27), 3), _spin_room_step(RobotModel(), 1.0, 0.27)
    (0.182, 0.27)
    """
    if not robot.free_turns:
        return limit  # the authors' planner: every step one body length
    spin = robot.swept_radius - robot.front_offset - robot.clearance + SPIN_SLACK
    if math.isfinite(gap) and limit <= gap < limit + spin and gap - spin >= _MIN_STEP:
        return gap - spin
    return limit


# the shortest step worth cutting to keep room to spin (m)
_MIN_STEP = 0.03


def _rim_spin_room(robot: RobotModel, start: Pose) -> float:
    """How far a STRAIGHT from ``start`` can drive with the body still able to spin in
    place inside the sensed disc (the real body's swept disc within the rim); 0 when it
    cannot.

    >>> round(_rim_spin_room(RobotModel(), Pose(0.0, 0.0, 0.0)), 3)
    0.896
    """
    c, s = math.cos(start.theta), math.sin(start.theta)
    r = robot.sensor_range - robot.body_radius - SPIN_SLACK
    if r <= 0:
        return 0.0
    bb = start.x * c + start.y * s
    q = start.x * start.x + start.y * start.y - r * r
    disc = bb * bb - q
    if q > 0 or disc < 0:
        return 0.0
    return max(-bb + math.sqrt(disc), 0.0)


def _goal_dead_ahead(robot: RobotModel, start: Pose, goal: Disturbance | None) -> float | None:
    if goal is None:
        return None
    dx, dy = goal.x - start.x, goal.y - start.y
    c, s = math.cos(start.theta), math.sin(start.theta)
    along, lateral = dx * c + dy * s, -dx * s + dy * c
    if along > 0 and abs(lateral) <= robot.goal_tolerance:
        return along
    return None


def make_task(kind: TaskKind, obstacles: Obstacles, robot: RobotModel, start: Pose, goal: Disturbance | None) -> Task:
    """The controller the Configurator starts for ``kind`` at ``start``."""
    if kind is TaskKind.STRAIGHT:
        return Task.straight(robot, start, goal, straight_limit(obstacles, robot, start, goal))
    angle = turn_angle(kind, start, goal, obstacles, robot) if robot.free_turns else None
    return Task.turn(robot, kind, start, goal, angle)


_EPS = 1e-9
_TWO_PI = 2 * math.pi


def _scene(obstacles: Obstacles, robot: RobotModel, worlds: dict[Any, Any] | None) -> Scene:
    scene = worlds.get(()) if worlds is not None else None
    if not isinstance(scene, Scene) or scene.robot is not robot or scene.obstacles is not obstacles:
        scene = Scene(obstacles, robot)
        if worlds is not None:
            worlds[()] = scene
    return scene


def turn_angle(
    kind: TaskKind,
    start: Pose,
    goal: Disturbance | None,
    obstacles: Obstacles,
    robot: RobotModel,
    worlds: dict[Any, Any] | None = None,
) -> float:
    """Where a turn from ``start`` ends: the paper ends a task when its error is zero.

    A turn towards the side the goal is on is contingent on the goal: it ends facing it,
    provided the way to the goal is clear for the next straight. Otherwise (the goal is
    on the other side, or the way to it is blocked) the turn is contingent on what is in
    the way: it ends at the first mark, every ``turn_angle / 4`` from ``turn_angle / 2``
    (π/4, 3π/8, π/2 for the default quarter turn; short of the goal's bearing or beyond
    it), from which the way ahead is clear for a step; when none is, it ends facing the
    goal if it turned towards it, else at ``turn_angle``; from the planning origin (the
    robot's own pose) a turn may also end at ``turn_angle / 4`` (π/8) when no other
    mark is clear: the smallest turn that frees a robot beside an obstacle. A turn away from the goal (the
    goal on the other side, or ahead) has marks on up to a half turn, every
    ``turn_angle / 8`` past ``turn_angle`` (9π/16 … π): the way out of a nook may lie
    behind a wall beside the body that a quarter turn would face (recorded scans
    126–135), and may need a mark between the π/8 ones (scan 121: 9π/16). A turn
    towards the goal stops at ``turn_angle``: further would turn its back on the goal,
    and such detours fail under execution noise.

    >>> from clomp.planner.perception import perceive
    >>> g = Disturbance.goal(0.0, 0.5)
    >>> round(turn_angle(TaskKind.LEFT, Pose(0.0, 0.0, 0.0), g, perceive(np.zeros((0, 2))), RobotModel()), 4)
    1.5708
    >>> round(turn_angle(TaskKind.LEFT, Pose(0.0, 0.0, 0.0), Disturbance.goal(0.5, 0.5), perceive(np.zeros((0, 2))), RobotModel()), 4)
    0.7854
    """
    scene = _scene(obstacles, robot, worlds) if len(obstacles) else None
    if scene is None:
        angles, _, fallback = _turn_options(kind, start, goal, robot)
        return angles[0] if angles else fallback
    key = (start.x, start.y, start.theta, kind, None if goal is None else (goal.x, goal.y))
    known = scene.turns.get(key)
    if known is not None:
        return known
    return _turn_pair(kind, start, goal, robot, scene, key)


def _turn_pair(
    kind: TaskKind, start: Pose, goal: Disturbance | None, robot: RobotModel, scene: Scene, key: tuple[Any, ...],
    straight: float | None = None,
) -> float:
    """The angles of both turns from ``start`` (the left and the right turn from one pose
    are asked one after the other: one array operation answers both, and with
    ``straight`` the straight from ``start`` too); returns the one of ``kind`` and
    remembers the other."""
    kinds = (kind, TaskKind.RIGHT if kind is TaskKind.LEFT else TaskKind.LEFT)
    groups = []
    options = []
    sx, sy, th = start.x, start.y, start.theta
    # the rim is no nearer than this whatever the heading: most turns need no rim test
    sure = robot.sensor_range - math.hypot(sx, sy) - robot.body_radius
    wrapped = None if goal is None else _goal_bearing(start, goal)
    # :func:`_inside_for` at this position: the centre's path within the rim less the body radius
    inner = robot.sensor_range - robot.body_radius
    q = sx * sx + sy * sy - inner * inner
    fmod, pi, cos, sin, sqrt = math.fmod, math.pi, math.cos, math.sin, math.sqrt
    for k in kinds:
        sign = 1.0 if k is TaskKind.LEFT else -1.0
        angles, needs, fallback = _turn_options(k, start, goal, robot, wrapped)
        # clomp.formal.geometry.wrap_angle(th + sign * a), inline (the same arithmetic)
        heads = [(h if (h := fmod(th + sign * a + pi, _TWO_PI)) > 0 else h + _TWO_PI) - pi for a in angles]
        lengths = needs  # a fresh list from _turn_options: cut in place where the rim is nearer
        if max(needs) > sure:
            for i, (a, n) in enumerate(zip(angles, needs)):
                if n > sure:
                    t = th + sign * a
                    if q > 0 or -(bb := sx * cos(t) + sy * sin(t)) + sqrt(bb * bb - q) < n + 1e-9:
                        lengths[i] = min(n, _frontier_at(robot, sx, sy, t))
        groups.append((heads, lengths, angles.index(fallback)))
        options.append((angles, fallback))
    found = scene.first_clear_each(start, groups, straight)
    result = [angles[i] if i >= 0 else fallback for i, (angles, fallback) in zip(found, options)]
    scene.turns[key] = result[0]
    scene.turns[key[:3] + (kinds[1], key[4])] = result[1]
    return result[0]


def _goal_bearing(start: Pose, goal: Disturbance) -> float:
    """The goal's bearing from ``start``, relative to its heading, in (−π, π]."""
    return wrap_angle(math.atan2(goal.y - start.y, goal.x - start.x) - start.theta)


def _turn_options(
    kind: TaskKind, start: Pose, goal: Disturbance | None, robot: RobotModel, wrapped: float | None = None
) -> tuple[list[float], list[float], float]:
    """The angles a turn from ``start`` may end at, in order of preference, the length of
    the way each needs clear ahead, and where the turn ends when none is clear.
    ``wrapped`` is :func:`_goal_bearing` when the caller has it (both turns from one pose)."""
    sign = 1.0 if kind is TaskKind.LEFT else -1.0
    full = robot.turn_angle
    towards: float | None = None
    if goal is not None:
        if wrapped is None:
            wrapped = _goal_bearing(start, goal)
        bearing = sign * wrapped
        if bearing < -math.pi + 1e-9:
            bearing += 2 * math.pi  # the goal straight behind: either turn faces it
        if bearing > 1e-6:
            towards = bearing
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    # short of the goal's bearing too: the free way may lie between the heading and the goal
    # a turn towards the goal's side ends by turn_angle at the latest (further would turn
    # away from the goal); one away from it may go on to a half turn
    marks = _marks(full, towards is None)
    if towards is None or goal is None:
        angles, needs, fallback = list(marks), [step] * len(marks), full
    else:
        angles = [towards] + [a for a in marks if abs(a - towards) > 1e-3]
        needs = [min(step, math.hypot(goal.x - start.x, goal.y - start.y) - robot.goal_tolerance)] + [step] * (len(angles) - 1)
        fallback = towards
    if start.x == 0.0 and start.y == 0.0 and start.theta == 0.0:
        # the planning origin (the robot's sensed pose) may also end a turn at the small
        # mark, as a last resort: beside an obstacle after a turn overshot, the smallest
        # turn that clears the way is the one left (overtaking layout 0/1: π/4 faced the
        # box or the wall and the robot halted UNREACHABLE). Deeper in the search the
        # mark is not offered: there it spent the budget on shallow detours (honest reach
        # on the recorded scans 196 -> 195 of 230, scan 117)
        angles.append(full / 4)
        needs.append(step)
    return angles, needs, fallback


@functools.lru_cache(maxsize=32)
def _marks(full: float, away: bool) -> tuple[float, ...]:
    """Where a turn contingent on an obstacle may end: every ``full / 4`` from ``full / 2``
    up to ``full``; for a turn ``away`` from the goal on past ``full``, every ``full / 8``,
    up to π.

    >>> [round(a / math.pi, 3) for a in _marks(math.pi / 2, False)]
    [0.25, 0.375, 0.5]
    >>> [round(a / math.pi, 4) for a in _marks(math.pi / 2, True)]
    [0.25, 0.375, 0.5, 0.5625, 0.625, 0.6875, 0.75, 0.8125, 0.875, 0.9375, 1.0]
    """
    out = [full * k / 4 for k in range(2, 5)]
    if away:
        k = 9
        while full * k / 8 < math.pi + 1e-9:
            out.append(min(full * k / 8, math.pi))
            k += 1
    return tuple(out)


def simulate(
    kind: TaskKind,
    start: Pose,
    goal: Disturbance | None,
    obstacles: Obstacles,
    robot: RobotModel,
    worlds: dict[Any, Any] | None = None,
    *,
    angle: float | None = None,
) -> Outcome:
    """Roll one task of ``kind`` forward from ``start`` in the world of what the scan saw.

    ``reached_goal`` says whether the task ended within the goal tolerance. ``worlds``
    is an optional cache (one per planning run, for the same obstacles and robot) that
    keeps what the run's rollouts share. ``angle`` is a turn's angle (default the
    robot's ``turn_angle``). A STRAIGHT that meets the rim of the sensed disc ends
    there (``frontier``); a turn that would leave it, or whose chosen angle is a turn of
    nothing (below :data:`MIN_TURN`), comes back with ``frontier`` set and its end at its
    start (not available).

    >>> from clomp.planner.perception import perceive
    >>> out = simulate(TaskKind.STRAIGHT, Pose(0.0, 0.0, 0.0), Disturbance.goal(1.0, 0.0), perceive(np.zeros((0, 2))), RobotModel())
    >>> out.reached_goal, out.frontier, round(out.end.x, 3)
    (True, False, 1.0)
    """
    scene = worlds.get(()) if worlds is not None else None
    if type(scene) is not Scene or scene.obstacles is not obstacles or scene.robot is not robot:
        scene = _scene(obstacles, robot, worlds) if len(obstacles) else None  # the run's first rollout
    if kind is TaskKind.STRAIGHT:
        out = _straight(start, goal, obstacles, robot, scene)
    else:
        turned = _turn(kind, start, goal, obstacles, robot, worlds, scene, angle)
        if turned is None:  # it would leave the sensed disc: not available
            return Outcome(kind, start, start, 0.0, 0.0, 0, None, False, True)
        out = turned
    if goal is not None and out.d_n is None and out.end.distance_to(goal.x, goal.y) <= robot.goal_tolerance:
        out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, True, out.frontier)
    return out


def _straight(start: Pose, goal: Disturbance | None, obstacles: Obstacles, robot: RobotModel, scene: Scene | None) -> Outcome:
    """:func:`simulate` for a STRAIGHT: a step (or the run to a goal dead ahead) cut where
    the body meets a point, or ended at the rim of the sensed disc (``frontier``)."""
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    along = _goal_dead_ahead(robot, start, goal)
    # the rim is no nearer than ``sure`` whatever the heading: when the task cannot
    # reach that far, the rim does not limit it (and the exact distance is not needed)
    sure = robot.sensor_range - math.hypot(start.x, start.y) - robot.body_radius
    far = max(step, along or 0.0)
    # (nor when the body surely stays inside the disc on this heading: every use of
    # ``room`` below compares it with at most ``far``, so inf gives the same answers)
    room = (
        frontier_distance(robot, start)
        if far > sure - 1e-6 and not _inside_for(robot, start.x, start.y, start.theta, far + 1e-6)
        else math.inf
    )
    if scene is not None:
        # what the step's length depends on: a point within a step and room to spin,
        # or within the run to a goal dead ahead
        need = max(min(step, room) + scene.spin, min(along, room) if along is not None else 0.0) + 1e-6
        if robot.free_turns and need <= scene.local_gap and not scene.knows(start, need):
            # a straight not known from a turn's choice of angle starts where the
            # search expands a state, and the turns from there are asked next: their
            # choice of angle and this straight are one array operation
            tkey = (start.x, start.y, start.theta, TaskKind.LEFT,
                    None if goal is None else (goal.x, goal.y))
            if tkey not in scene.turns:
                _turn_pair(TaskKind.LEFT, start, goal, robot, scene, tkey, need - scene.spin)
        d, k = scene.straight_gap(start, need)
    else:
        d, k = math.inf, -1
    if along is not None and d >= min(along, room):
        limit = min(along, room)  # a clear run to the goal dead ahead: one task
    else:
        limit = _free_step(robot, start, goal, d, min(step, room), room)
    task = Task.straight(robot, start, goal, limit)
    if k >= 0 and scene is not None:
        out = cut_straight(task, d, obstacles, int(scene.owner[k]), float(scene.x[k]), float(scene.y[k]))
    else:
        out = unobstructed(task)
    if limit >= room - _EPS and not out.collided and out.distance >= room - 1e-6:
        out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, False, True)
    return out


def _turn(
    kind: TaskKind, start: Pose, goal: Disturbance | None, obstacles: Obstacles, robot: RobotModel,
    worlds: dict[Any, Any] | None, scene: Scene | None, angle: float | None,
) -> Outcome | None:
    """:func:`simulate` for a turn (by ``angle``, else the angle :func:`turn_angle` chooses),
    cut at the first tick heading where the body meets a point; None when the turn would
    leave the sensed disc, or when the angle it chose is below :data:`MIN_TURN`."""
    sign = 1.0 if kind is TaskKind.LEFT else -1.0
    if angle is None and robot.free_turns:
        if scene is None:
            angle = turn_angle(kind, start, goal, obstacles, robot, worlds)
        else:
            # turn_angle with the run's scene at hand
            tkey = (start.x, start.y, start.theta, kind, None if goal is None else (goal.x, goal.y))
            angle = scene.turns.get(tkey)
            if angle is None:
                angle = _turn_pair(kind, start, goal, robot, scene, tkey)
        if angle < MIN_TURN:  # a turn of nothing: not available (see MIN_TURN)
            return None
    task = Task.turn(robot, kind, start, goal, angle)
    if _turn_leaves_disc(robot, start, sign * task.limit):
        return None
    if scene is None:
        return unobstructed(task)
    key = (start.x, start.y, start.theta)
    known = scene.turned.pop(key + (kind, task.limit), None)
    if known is not None:
        return known
    # the other turn from this pose is asked next (its angle is known when turn_angle
    # chose this one's): one array operation answers both
    tasks = [task]
    other_kind = TaskKind.RIGHT if kind is TaskKind.LEFT else TaskKind.LEFT
    other = scene.turns.get(key + (other_kind, None if goal is None else (goal.x, goal.y)))
    if other is not None and not _turn_leaves_disc(robot, start, -sign * other):
        tasks.append(Task.turn(robot, other_kind, start, goal, other))
    return scene.turn_each(tasks)[0]

