"""Core knowledge: one task rolled forward in the world of what the scan saw.

A planning run shares one scene: the sensed points perception kept (in surface order)
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

The boxes of :mod:`planner.perception` are the obstacles' outlines (D_N, the map, the
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
turn round the end of a wall there), unless that leaves less than 3 cm to drive. LiDAR shadows (the space behind a sensed surface) lie inside the disc
and are treated as free: to reach one the body has to go round the surface that casts
it, past its sensed end, and the next scan, taken from there, sees into it before the
robot drives in.

:class:`planner.engine.World` is the pymunk engine the closed forms are tested against;
rollouts are deterministic: the same inputs give bit-identical outcomes.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from formal.geometry import wrap_angle
from formal.model import Disturbance, Pose, TaskKind
from planner.engine import Outcome, World, _obstacle_disturbance
from planner.perception import Obstacles
from planner.robot import RobotModel
from planner.tasks import Task

__all__ = ["Outcome", "World", "in_the_way", "straight_limit", "simulate", "make_task", "frontier_distance", "turn_angle"]


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
    c, s = math.cos(start.theta), math.sin(start.theta)
    r2 = robot.sensor_range * robot.sensor_range
    best = math.inf
    for a, b in _corners(robot):
        x = start.x + a * c - b * s
        y = start.y + a * s + b * c
        bb = x * c + y * s
        q = x * x + y * y - r2
        disc = bb * bb - q
        if q > 0 or disc < 0:
            return 0.0
        best = min(best, -bb + math.sqrt(disc))
    return max(best, 0.0)


@functools.lru_cache(maxsize=16)
def _corners(robot: RobotModel) -> tuple[tuple[float, float], ...]:
    h = robot.width / 2
    return ((-robot.rear_offset, -h), (robot.front_offset, -h), (robot.front_offset, h), (-robot.rear_offset, h))


@functools.lru_cache(maxsize=16)
def _body_radius(robot: RobotModel) -> float:
    """The distance from the rotation centre to the real body's farthest corner."""
    return max(math.hypot(a, b) for a, b in _corners(robot))


def _turn_leaves_disc(robot: RobotModel, start: Pose, signed_angle: float) -> bool:
    """True when the real body, spinning in place by ``signed_angle``, leaves the sensed disc."""
    cx, cy = start.x, start.y
    dist = math.hypot(cx, cy)
    reach = robot.sensor_range
    rmax = _body_radius(robot)
    if dist + rmax <= reach:
        return False
    n = max(2, int(math.ceil(abs(signed_angle) / 0.2)))
    grow = rmax * (1 - math.cos(abs(signed_angle) / n / 2))
    for k in range(n + 1):
        th = start.theta + signed_angle * k / n
        c, s = math.cos(th), math.sin(th)
        for a, b in _corners(robot):
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
    spin = robot.swept_radius - robot.front_offset - robot.clearance + _SPIN_SLACK
    if math.isfinite(gap) and limit <= gap < limit + spin and gap - spin >= _MIN_STEP:
        return gap - spin
    return limit


# the shortest step worth cutting to keep room to spin (m)
_MIN_STEP = 0.03
# kept beyond the swept disc, so that a point ahead is not met on the sweep's very edge (m)
_SPIN_SLACK = 0.003


def _rim_spin_room(robot: RobotModel, start: Pose) -> float:
    """How far a STRAIGHT from ``start`` can drive with the body still able to spin in
    place inside the sensed disc (the real body's swept disc within the rim); 0 when it
    cannot.

    >>> round(_rim_spin_room(RobotModel(), Pose(0.0, 0.0, 0.0)), 3)
    0.896
    """
    c, s = math.cos(start.theta), math.sin(start.theta)
    r = robot.sensor_range - _body_radius(robot) - _SPIN_SLACK
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


class _Scene:
    """The run's sensed points as flat arrays, and the body's extents: what every
    rollout of one planning run shares (built once per run, nothing per query)."""

    __slots__ = ("obstacles", "robot", "x", "y", "z", "owner", "real", "infl", "radius2", "gaps", "reach")

    def __init__(self, obstacles: Obstacles, robot: RobotModel) -> None:
        self.obstacles = obstacles
        self.robot = robot
        pts = obstacles.points
        self.x = np.ascontiguousarray(pts[:, 0])
        self.y = np.ascontiguousarray(pts[:, 1])
        self.z = self.x + 1j * self.y  # the points as x + iy: a frame change is one product
        self.owner = obstacles.owner
        c = robot.clearance
        self.real = (robot.rear_offset, robot.front_offset, robot.width / 2)
        self.infl = (robot.rear_offset + c, robot.front_offset + c, robot.width / 2 + c)
        self.radius2 = robot.swept_radius ** 2
        rear, front, half = self.infl
        self.reach = (math.hypot(rear, half), front, half)
        self.gaps: dict[tuple[int, int, int], tuple[float, int]] = {}

    def outcome(self, task: Task) -> Outcome:
        """The outcome of ``task`` among the sensed points (closed form; see the module docstring)."""
        if not len(self.x):
            return _unobstructed(task)
        if task.kind is TaskKind.STRAIGHT:
            d, k = self.straight_gap(task.start)
            if k < 0:
                return _unobstructed(task)
            return _cut_straight(task, d, self.obstacles, int(self.owner[k]), float(self.x[k]), float(self.y[k]))
        return self.turn(task)

    def straight_gap(self, s: Pose) -> tuple[float, int]:
        """(distance the body can drive from ``s`` before it meets a point, that point's
        index); (inf, -1) when none. Remembered per pose (a turn's choice of angle and
        the straight after it ask the same question)."""
        key = (round(s.x * 1e9), round(s.y * 1e9), round(wrap_angle(s.theta) * 1e9))
        hit = self.gaps.get(key)
        if hit is None:
            hit = self.gaps[key] = self._straight_gap(s)
        return hit

    def _straight_gap(self, s: Pose) -> tuple[float, int]:
        # :meth:`_gaps` for one heading, on the points in the body's lane only
        w = (self.z - complex(s.x, s.y)) * complex(math.cos(s.theta), -math.sin(s.theta))
        rear, front, half = self.infl
        lane = (np.abs(w.imag) <= half).nonzero()[0]
        if not len(lane):
            return math.inf, -1
        w = w.take(lane)
        u = w.real
        ahead = u > front
        gap = np.where(ahead, u - front, np.inf)
        # inside the inflated footprint at the start: the margin is waived for these points,
        # the real body still must not touch them (the start-touching rule)
        waived = ~ahead & (u >= -rear)
        if waived.any():
            _, rfront, rhalf = self.real
            gap = np.where(waived & (np.abs(w.imag) < rhalf) & (u >= rfront), u - rfront, gap)
        k = int(gap.argmin())
        d = float(gap[k])
        return (d, int(lane[k])) if math.isfinite(d) else (math.inf, -1)

    def _gaps(self, z: np.ndarray, at: complex, headings: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per heading (K): how far the body can drive from ``at`` before it meets one of
        the points ``z`` (complex x + iy), and which (index into ``z``); inf when none."""
        w = (z - at) * np.exp(-1j * headings)[:, None]  # K×N: u + iv in each task frame
        u = w.real
        v = np.abs(w.imag)
        rear, front, half = self.infl
        lane = v <= half
        gap = np.where(lane & (u > front), u - front, np.inf)
        # inside the inflated footprint at the start: the margin is waived for these points,
        # the real body still must not touch them (the start-touching rule)
        waived = lane & (u <= front) & (u >= -rear)
        if waived.any():
            _, rfront, rhalf = self.real
            gap = np.where(waived & (v < rhalf) & (u >= rfront), u - rfront, gap)
        k = gap.argmin(axis=1)
        return gap[np.arange(len(headings)), k], k

    def first_clear(self, s: Pose, headings: list[float], lengths: list[float]) -> int:
        """The index of the first heading from which the body, turned in place at ``s``,
        can drive ``lengths[i]`` without meeting a point; -1 when none can.

        One array operation for all headings, over the points within reach of the
        longest drive only (a nearer contact is among them; none nearer means clear).
        """
        if not headings:
            return -1
        at = complex(s.x, s.y)
        body, front, half = self.reach
        far = max(lengths)
        reach = max(body, math.hypot(front + far, half))
        dz = self.z - at
        near = (dz.real * dz.real + dz.imag * dz.imag <= reach * reach).nonzero()[0]
        if not len(near):
            return 0
        d, _ = self._gaps(self.z.take(near), at, np.asarray(headings))
        ok = (d >= np.asarray(lengths) - _EPS).nonzero()[0]
        return int(ok[0]) if len(ok) else -1

    def _waived_turn(self, dx: np.ndarray, dy: np.ndarray, theta: float, sign: float, per_tick: float, e0: float, ticks: int) -> int:
        """The first tick at or after which the real body meets one of these points
        (strictly outside it at the start), sampled at eight headings per tick."""
        rrear, rfront, rhalf = self.real
        fine = np.minimum(np.arange(1, 8 * ticks + 1) * (per_tick / 8), e0)
        th = theta + sign * fine
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        u = dx * c + dy * sn
        v = np.abs(dy * c - dx * sn)
        u0 = dx * math.cos(theta) + dy * math.sin(theta)
        v0 = np.abs(dy * math.cos(theta) - dx * math.sin(theta))
        live = ~((u0 > -rrear) & (u0 < rfront) & (v0 < rhalf))
        hit = np.flatnonzero(((u >= -rrear) & (u <= rfront) & (v <= rhalf) & live).any(axis=1))
        return int(hit[0]) // 8 + 1 if len(hit) else ticks + 1

    def turn(self, task: Task) -> Outcome:
        """A turn among the points within its swept disc, checked at every tick heading."""
        r = task.robot
        s = task.start
        dx, dy = self.x - s.x, self.y - s.y
        near = np.flatnonzero(dx * dx + dy * dy <= self.radius2)
        if not len(near):
            return _unobstructed(task)
        dx, dy = dx[near], dy[near]
        e0 = task.error_at(s.x, s.y, s.theta)
        per_tick = r.turn_rate * r.tick
        ticks = math.ceil(e0 / per_tick - 1e-9) if e0 > 1e-9 else 0
        if ticks == 0:
            return _unobstructed(task)
        sign = 1.0 if task.kind is TaskKind.LEFT else -1.0
        th = s.theta + sign * np.minimum(np.arange(ticks + 1) * per_tick, e0)
        c, sn = np.cos(th)[:, None], np.sin(th)[:, None]
        u = dx * c + dy * sn
        v = np.abs(dy * c - dx * sn)
        rear, front, half = self.infl
        inside = (u >= -rear) & (u <= front) & (v <= half)
        waived = inside[0]
        if waived.any():
            rrear, rfront, rhalf = self.real
            real = (u >= -rrear) & (u <= rfront) & (v <= rhalf)
            inside = np.where(waived, real, inside)
            # exempt: strictly inside the real body at the start (a point on its edge is not)
            inside[:, (u[0] > -rrear) & (u[0] < rfront) & (v[0] < rhalf)] = False
        rows = np.flatnonzero(inside[1:].any(axis=1))
        k = int(rows[0]) + 1 if len(rows) else ticks + 1  # the first tick in contact
        if waived.any():
            # a point within the margin is held to the real body, with no margin for the
            # corner's path between ticks: test it at eight headings per tick
            k = min(k, self._waived_turn(dx[waived], dy[waived], s.theta, sign, per_tick, e0, ticks))
        if k > ticks:
            return _unobstructed(task)
        j = int(near[int(np.argmax(inside[k]))]) if inside[k].any() else int(near[np.flatnonzero(waived)[0]])
        done = k - 1
        end = Pose(s.x, s.y, wrap_angle(float(th[done]))) if done else s
        d_n = _obstacle_disturbance(self.obstacles, (int(self.owner[j]), float(self.x[j]), float(self.y[j])))
        return Outcome(task.kind, s, end, 0.0, done * r.tick, done, d_n, False)


def _cut_straight(task: Task, d: float, obstacles: Obstacles, i: int, x: float, y: float) -> Outcome:
    """A STRAIGHT whose front meets a point after ``d`` metres (inf: never)."""
    r = task.robot
    s = task.start
    e0 = task.error_at(s.x, s.y, s.theta)
    if d >= e0 or not math.isfinite(d):
        return _unobstructed(task)
    per_tick = r.straight_speed * r.tick
    k = max(1, math.ceil(d / per_tick - 1e-12))  # the first tick whose travel reaches the point
    done = k - 1
    travel = done * per_tick
    c, sn = math.cos(s.theta), math.sin(s.theta)
    end = Pose(s.x + travel * c, s.y + travel * sn, s.theta) if done else s
    d_n = _obstacle_disturbance(obstacles, (i, x, y))
    return Outcome(task.kind, s, end, travel, done * r.tick, done, d_n, False)


def _unobstructed(task: Task, frontier: bool = False) -> Outcome:
    """The outcome of a task that nothing interrupts, in closed form.

    Both controllers drive their error down linearly at full rate and cover the rest in
    the last tick (see :mod:`planner.tasks`), so the end pose is the start moved by the
    initial error and the duration is the number of ticks that takes.
    """
    r = task.robot
    s = task.start
    e0 = task.error_at(s.x, s.y, s.theta)
    if task.kind is TaskKind.STRAIGHT:
        per_tick = r.straight_speed * r.tick
        end = Pose(s.x + e0 * math.cos(s.theta), s.y + e0 * math.sin(s.theta), s.theta)
        distance = e0
    else:
        per_tick = r.turn_rate * r.tick
        sign = 1.0 if task.kind is TaskKind.LEFT else -1.0
        end = Pose(s.x, s.y, wrap_angle(s.theta + sign * e0))
        distance = 0.0
    ticks = math.ceil(e0 / per_tick - 1e-9) if e0 > 1e-9 else 0
    return Outcome(task.kind, s, end if ticks else s, distance if ticks else 0.0, ticks * r.tick, ticks, None, False, frontier)


def _scene(obstacles: Obstacles, robot: RobotModel, worlds: dict[Any, Any] | None) -> _Scene:
    scene = worlds.get(()) if worlds is not None else None
    if not isinstance(scene, _Scene) or scene.robot is not robot or scene.obstacles is not obstacles:
        scene = _Scene(obstacles, robot)
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
    goal if it turned towards it, else at ``turn_angle``. A turn away from the goal (the
    goal on the other side, or ahead) has marks on up to a half turn (5π/8 … π): the way
    out of a nook may lie behind a wall beside the body that a quarter turn would face
    (recorded scans 126–135). A turn towards the goal stops at ``turn_angle``: further
    would turn its back on the goal, and such detours fail under execution noise.

    >>> from planner.perception import perceive
    >>> g = Disturbance.goal(0.0, 0.5)
    >>> round(turn_angle(TaskKind.LEFT, Pose(0.0, 0.0, 0.0), g, perceive(np.zeros((0, 2))), RobotModel()), 4)
    1.5708
    >>> round(turn_angle(TaskKind.LEFT, Pose(0.0, 0.0, 0.0), Disturbance.goal(0.5, 0.5), perceive(np.zeros((0, 2))), RobotModel()), 4)
    0.7854
    """
    sign = 1.0 if kind is TaskKind.LEFT else -1.0
    full = robot.turn_angle
    towards: float | None = None
    if goal is not None:
        bearing = sign * wrap_angle(math.atan2(goal.y - start.y, goal.x - start.x) - start.theta)
        if bearing < -math.pi + 1e-9:
            bearing += 2 * math.pi  # the goal straight behind: either turn faces it
        if bearing > 1e-6:
            towards = bearing
    scene = _scene(obstacles, robot, worlds) if len(obstacles) else None
    step = robot.step_length if robot.step_length is not None else robot.sensor_range
    angles: list[float] = []
    needs: list[float] = []
    if towards is not None and goal is not None:
        angles.append(towards)
        needs.append(min(step, math.hypot(goal.x - start.x, goal.y - start.y) - robot.goal_tolerance))
    # short of the goal's bearing too: the free way may lie between the heading and the goal
    # a turn towards the goal's side ends by turn_angle at the latest (further would turn
    # away from the goal); one away from it may go on to a half turn
    for a in _marks(full, towards is None):
        if towards is None or abs(a - towards) > 1e-3:
            angles.append(a)
            needs.append(step)
    if scene is None:
        return angles[0] if angles else full
    # the rim is no nearer than this whatever the heading: most turns need no rim test
    sure = robot.sensor_range - math.hypot(start.x, start.y) - _body_radius(robot)
    lengths = [
        n if n <= sure else min(n, frontier_distance(robot, Pose(start.x, start.y, start.theta + sign * a)))
        for a, n in zip(angles, needs)
    ]
    i = scene.first_clear(start, [start.theta + sign * a for a in angles], lengths)
    if i >= 0:
        return angles[i]
    return towards if towards is not None else full


@functools.lru_cache(maxsize=32)
def _marks(full: float, away: bool) -> tuple[float, ...]:
    """Where a turn contingent on an obstacle may end: every ``full / 4`` from ``full / 2``
    up to ``full``, or up to π for a turn ``away`` from the goal.

    >>> [round(a / math.pi, 3) for a in _marks(math.pi / 2, False)]
    [0.25, 0.375, 0.5]
    >>> [round(a / math.pi, 3) for a in _marks(math.pi / 2, True)]
    [0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0]
    """
    last = math.pi if away else full
    out = []
    k = 2
    while full * k / 4 <= last + 1e-9:
        out.append(min(full * k / 4, math.pi))
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
    there (``frontier``); a turn that would leave it comes back with ``frontier`` set
    and its end at its start (not available).

    >>> from planner.perception import perceive
    >>> out = simulate(TaskKind.STRAIGHT, Pose(0.0, 0.0, 0.0), Disturbance.goal(1.0, 0.0), perceive(np.zeros((0, 2))), RobotModel())
    >>> out.reached_goal, out.frontier, round(out.end.x, 3)
    (True, False, 1.0)
    """
    scene = _scene(obstacles, robot, worlds) if len(obstacles) else None
    if kind is TaskKind.STRAIGHT:
        step = robot.step_length if robot.step_length is not None else robot.sensor_range
        d, k = scene.straight_gap(start) if scene is not None else (math.inf, -1)
        along = _goal_dead_ahead(robot, start, goal)
        # the rim is no nearer than ``sure`` whatever the heading: when the task cannot
        # reach that far, the rim does not limit it (and the exact distance is not needed)
        sure = robot.sensor_range - math.hypot(start.x, start.y) - _body_radius(robot)
        room = frontier_distance(robot, start) if max(step, along or 0.0) > sure - 1e-6 else math.inf
        if along is not None and d >= min(along, room):
            limit = min(along, room)  # a clear run to the goal dead ahead: one task
        else:
            limit = _free_step(robot, start, goal, d, min(step, room), room)
        task = Task.straight(robot, start, goal, limit)
        if k >= 0 and scene is not None:
            out = _cut_straight(task, d, obstacles, int(scene.owner[k]), float(scene.x[k]), float(scene.y[k]))
        else:
            out = _unobstructed(task)
        if limit >= room - _EPS and not out.collided and out.distance >= room - 1e-6:
            out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, False, True)
    else:
        sign = 1.0 if kind is TaskKind.LEFT else -1.0
        if angle is None and robot.free_turns:
            angle = turn_angle(kind, start, goal, obstacles, robot, worlds)
        task = Task.turn(robot, kind, start, goal, angle)
        if _turn_leaves_disc(robot, start, sign * task.limit):
            return Outcome(kind, start, start, 0.0, 0.0, 0, None, False, True)
        out = scene.turn(task) if scene is not None else _unobstructed(task)
    if goal is not None and out.d_n is None and out.end.distance_to(goal.x, goal.y) <= robot.goal_tolerance:
        out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, True, out.frontier)
    return out

