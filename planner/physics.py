"""Core knowledge: a small pymunk world in which one task is rolled forward.

For each rollout a world is rebuilt from the obstacle disturbances that lie in the way
of the task (a corridor ahead of a STRAIGHT, the disc a turn sweeps), as in the paper:
the raw scan is resampled so that only what the task could meet is represented.
The robot is a kinematic pymunk body with the robot's (inflated) footprint, driven each
tick by the velocity its wheel speeds give; the space steps with the control tick.
After each step the robot shape is queried against the obstacles: a new overlap (or
pushing deeper into something the robot already touched when the task began) is a
collision, which ends the task at the last collision-free pose, with D_N naming the
obstacle and the contact point.

How often the engine is asked decides the cost, so it is asked once per task when it
can: one shape query of the area the whole task sweeps (exact for a STRAIGHT, a tight
superset for a turn). When that area is clear — or nothing is in the way at all —
nothing can interrupt the task and its outcome is computed in closed form (the
controllers drive their error down linearly; tests check this against the tick loop).
Only a task whose sweep touches something is stepped tick by tick.

Rollouts are deterministic: the same inputs give bit-identical outcomes.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import pymunk

from formal.model import Disturbance, DisturbanceKind, Pose, TaskKind
from planner.perception import Obstacles
from planner.robot import RobotModel
from planner.tasks import Task, wrap_angle

__all__ = ["Outcome", "World", "in_the_way", "straight_limit", "simulate", "make_task"]


@dataclass(frozen=True, slots=True)
class Outcome:
    """What a rollout of one task produced."""

    task: TaskKind
    start: Pose
    end: Pose
    distance: float
    duration: float
    ticks: int
    d_n: Disturbance | None
    reached_goal: bool

    @property
    def collided(self) -> bool:
        """True when an obstacle interrupted the task."""
        return self.d_n is not None


def in_the_way(obstacles: Obstacles, robot: RobotModel, start: Pose, kind: TaskKind, length: float) -> np.ndarray:
    """Indices of the obstacles a task from ``start`` could touch.

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


def straight_limit(obstacles: Obstacles, robot: RobotModel, start: Pose, goal: Disturbance | None) -> float:
    """How far a STRAIGHT from ``start`` may drive.

    A clear run to a goal dead ahead (within the goal tolerance of the heading line and
    nothing in the corridor) is one task to the goal. Otherwise straights are cut into
    steps of ``robot.step_length`` (one body length) so that a plan can turn along the
    way; with ``step_length=None`` a straight runs to the sensor range.
    """
    if goal is not None:
        dx, dy = goal.x - start.x, goal.y - start.y
        c, s = math.cos(start.theta), math.sin(start.theta)
        along, lateral = dx * c + dy * s, -dx * s + dy * c
        if along > 0 and abs(lateral) <= robot.goal_tolerance:
            if len(in_the_way(obstacles, robot, start, TaskKind.STRAIGHT, along)) == 0:
                return along
    return robot.step_length if robot.step_length is not None else robot.sensor_range


def make_task(kind: TaskKind, obstacles: Obstacles, robot: RobotModel, start: Pose, goal: Disturbance | None) -> Task:
    """The controller the Configurator starts for ``kind`` at ``start``."""
    if kind is TaskKind.STRAIGHT:
        return Task.straight(robot, start, goal, straight_limit(obstacles, robot, start, goal))
    return Task.turn(robot, kind, start, goal)


_ROBOT_FILTER = pymunk.ShapeFilter(group=1)
# pymunk routes attribute writes through a typing mixin's __setattr__; the rollout's hot
# path calls the property setters directly (same effect, a third of the cost)
_set_velocity = pymunk.Body.velocity.fset  # type: ignore[attr-defined]
_set_angular_velocity = pymunk.Body.angular_velocity.fset  # type: ignore[attr-defined]
_set_position = pymunk.Body.position.fset  # type: ignore[attr-defined]
_set_angle = pymunk.Body.angle.fset  # type: ignore[attr-defined]
# how much deeper (m) a task may push into an obstacle it touched at its start
_DEEPER = 1e-4


@functools.lru_cache(maxsize=64)
def _turn_sweep(footprint: tuple[tuple[float, float], ...], angle: float, n: int = 16) -> tuple[tuple[float, float], ...]:
    """The footprint's corners at ``n + 1`` headings from 0 to ``angle`` (robot frame)."""
    verts: list[tuple[float, float]] = []
    for k in range(n + 1):
        a = angle * k / n
        c, s = math.cos(a), math.sin(a)
        verts.extend((x * c - y * s, x * s + y * c) for x, y in footprint)
    return tuple(verts)


class World:
    """A pymunk space with some obstacles (static boxes) and the robot (a kinematic body).

    Built from the obstacle disturbances in the way of a task. Rollouts only place the
    robot and step it, so a world built for one set of obstacles can serve every
    rollout that meets the same set: :func:`simulate` reuses it within one planning run
    (``worlds=``), with outcomes identical to a fresh build (tested).
    """

    def __init__(self, obstacles: Obstacles, robot: RobotModel, indices: np.ndarray | list[int] | None = None) -> None:
        self.robot = robot
        self.obstacles = obstacles
        space = pymunk.Space()
        space.collision_slop = 0.0005
        idx = range(len(obstacles)) if indices is None else indices
        shapes = []
        self._index: dict[pymunk.Shape, int] = {}
        for i in idx:
            shape = pymunk.Poly(space.static_body, [tuple(p) for p in obstacles.boxes[i]])
            self._index[shape] = int(i)
            shapes.append(shape)
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.shape = pymunk.Poly(self.body, list(robot.footprint))
        self.shape.filter = _ROBOT_FILTER
        space.add(self.body, self.shape, *shapes)
        self.space = space

    def place(self, pose: Pose) -> None:
        """Put the robot at ``pose``."""
        _set_position(self.body, (pose.x, pose.y))
        _set_angle(self.body, pose.theta)
        self.space.reindex_shapes_for_body(self.body)

    def contacts(self) -> dict[int, tuple[float, float, float]]:
        """Every obstacle the robot overlaps: index → (penetration depth, contact x, y).

        Depth is 0 for shapes that just touch (a brush) and grows as they overlap.
        """
        out: dict[int, tuple[float, float, float]] = {}
        for h in self.space.shape_query(self.shape):
            i = self._index[h.shape]
            pts = h.contact_point_set.points
            if pts:
                deepest = min(pts, key=lambda p: p.distance)
                out[i] = (max(0.0, -deepest.distance), float(deepest.point_b.x), float(deepest.point_b.y))
            else:
                cx, cy = self.obstacles.centres[i]
                out[i] = (0.0, float(cx), float(cy))
        return out

    def contact(self) -> tuple[int, float, float] | None:
        """(obstacle index, contact x, y) of the lowest-indexed obstacle the robot overlaps, or None."""
        hits = self.contacts()
        if not hits:
            return None
        i = min(hits)
        return i, hits[i][1], hits[i][2]

    def sweep_is_clear(self, task: Task) -> bool:
        """True when the whole motion of ``task`` touches nothing, decided by one query.

        A STRAIGHT translates the footprint: its swept area is exactly the hull of the
        start and end footprints. A turn rotates it: the hull of the footprint at
        sixteen headings across the turn, grown by the largest gap between an arc and
        its chord, contains the swept area. Both are upper bounds of the area limited
        by the task's limit, so "clear" is never wrong.
        """
        self.place(task.start)
        fp = self.robot.footprint
        if task.kind is TaskKind.STRAIGHT:
            (x0, y0), (x1, _), (_, y1), _ = fp
            verts = [(x0, y0), (x1 + task.limit, y0), (x1 + task.limit, y1), (x0, y1)]
            grow = 0.0
        else:
            sign = 1.0 if task.kind is TaskKind.LEFT else -1.0
            n = 16
            verts = list(_turn_sweep(fp, sign * task.limit, n))
            grow = self.robot.swept_radius * (1 - math.cos(task.limit / n / 2)) + 1e-6
        sweep = pymunk.Poly(self.body, verts, radius=grow)
        sweep.filter = _ROBOT_FILTER
        return not self.space.shape_query(sweep)

    def rollout(self, task: Task) -> Outcome:
        """Run ``task`` tick by tick from its start pose until it ends or collides."""
        return _rollout(task, self)


def _rollout(task: Task, world: World | None) -> Outcome:
    r = task.robot
    dt = r.tick
    b = r.wheel_base
    x, y, th = task.start.x, task.start.y, task.start.theta
    pose = task.start
    ticks = 0
    distance = 0.0
    d_n: Disturbance | None = None
    body = None
    # obstacles the robot already touches when the task starts (a brush, or returns of
    # its own body) interrupt it only if the task pushes further into them
    touching: dict[int, float] = {}
    if world is not None:
        world.place(task.start)
        body = world.body
        touching = {i: depth for i, (depth, _, _) in world.contacts().items()}
    limit = task.max_ticks()
    while d_n is None and ticks < limit:
        e = task.error_at(x, y, th)
        if task.done(e):
            break
        vl, vr = task.wheel_speeds(e)
        v = (vl + vr) / 2
        w = (vr - vl) / b
        vx, vy = v * math.cos(th), v * math.sin(th)
        if body is not None:
            _set_velocity(body, (vx, vy))
            _set_angular_velocity(body, w)
            world.space.step(dt)  # type: ignore[union-attr]
            for i, (depth, cx, cy) in sorted(world.contacts().items()):  # type: ignore[union-attr]
                if i not in touching or depth > touching[i] + _DEEPER:
                    d_n = _obstacle_disturbance(world.obstacles, (i, cx, cy))  # type: ignore[union-attr]
                    break
            if d_n is not None:
                break
            pos = body.position
            nx, ny, nth = pos.x, pos.y, body.angle
        else:
            nx, ny, nth = x + vx * dt, y + vy * dt, th + w * dt
        distance += abs(v) * dt
        x, y, th = nx, ny, nth
        ticks += 1
    if ticks:
        pose = Pose(x, y, wrap_angle(th))
    return Outcome(task.kind, task.start, pose, distance, ticks * dt, ticks, d_n, False)


def _unobstructed(task: Task) -> Outcome:
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
    return Outcome(task.kind, s, end if ticks else s, distance, ticks * r.tick, ticks, None, False)


def _obstacle_disturbance(obstacles: Obstacles, hit: tuple[int, float, float]) -> Disturbance:
    i, x, y = hit
    base = obstacles.disturbances[i]
    return Disturbance(DisturbanceKind.OBSTACLE, x, y, base.vertices, base.ident)


def simulate(
    kind: TaskKind,
    start: Pose,
    goal: Disturbance | None,
    obstacles: Obstacles,
    robot: RobotModel,
    worlds: dict[tuple[int, ...], World] | None = None,
) -> Outcome:
    """Roll one task of ``kind`` forward from ``start`` in a world of what is in its way.

    Only the obstacles in the way of the task enter the world; the outcome's
    ``reached_goal`` says whether the task ended within the goal tolerance. ``worlds``
    is an optional cache (one per planning run, for the same obstacles and robot) of
    worlds keyed by the set of obstacles they hold.
    """
    task = make_task(kind, obstacles, robot, start, goal)
    length = task.limit if kind is TaskKind.STRAIGHT else 0.0
    idx = in_the_way(obstacles, robot, start, kind, length)
    world: World | None = None
    if len(idx):
        key = tuple(idx.tolist())
        world = worlds.get(key) if worlds is not None else None
        if world is None:
            world = World(obstacles, robot, idx)
            if worlds is not None:
                worlds[key] = world
    if world is None or world.sweep_is_clear(task):
        out = _unobstructed(task)  # nothing can interrupt it: no contact to check per tick
    else:
        out = _rollout(task, world)
    if goal is not None and out.d_n is None and out.end.distance_to(goal.x, goal.y) <= robot.goal_tolerance:
        out = Outcome(out.task, out.start, out.end, out.distance, out.duration, out.ticks, None, True)
    return out
