"""The reference engine: a pymunk world of obstacle boxes in which a task is stepped tick by tick.

The planner's rollouts (:mod:`clomp.planner.rollout`) are closed forms over the sensed points;
this module is the physics engine they are tested against, and a world a user can
query: boxes as static polygons, the robot as a kinematic body. A task is stepped tick by
tick with the exact unicycle motion of its wheel speeds
(:func:`clomp.formal.geometry.arc_step`, the one pose integration) and tested against the
sensed points after each tick. :meth:`World.sweep_hits` asks, by one shape query of a reusable
polygon (nothing allocated per query), which boxes a whole task could touch.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymunk

from clomp.formal.geometry import arc_step, points_to_frame, wheel_twist, wrap_angle
from clomp.formal.model import Disturbance, DisturbanceKind, Pose, TaskKind
from clomp.planner.footprint import body_box, inside, inside_at
from clomp.planner.perception import Obstacles
from clomp.planner.robot_model import RobotModel
from clomp.planner.tasks import Task

__all__ = ["Outcome", "World"]


@dataclass(slots=True)
class Outcome:
    """What a rollout of one task produced (never changed once built: derive a new one
    with :func:`dataclasses.replace`).

    ``frontier`` is True when the task was cut where the body meets the rim of the
    sensed disc (a STRAIGHT), or would have left it (a turn: not available). Not a
    frozen dataclass: a plan builds dozens, and a frozen one of nine fields costs six
    times as much to build (each field set through ``object.__setattr__``).

    >>> o = Outcome(TaskKind.STRAIGHT, Pose(0.0, 0.0), Pose(0.1, 0.0), 0.1, 0.5, 5, None, False)
    >>> o.collided, o.frontier
    (False, False)
    """

    task: TaskKind
    start: Pose
    end: Pose
    distance: float
    duration: float
    ticks: int
    d_n: Disturbance | None
    reached_goal: bool
    frontier: bool = False

    @property
    def collided(self) -> bool:
        """True when an obstacle interrupted the task."""
        return self.d_n is not None


_ROBOT_FILTER = pymunk.ShapeFilter(group=1)
# pymunk routes attribute writes through a typing mixin's __setattr__; placing the body
# calls the property setters directly (same effect, a third of the cost)
_set_position = pymunk.Body.position.fset  # type: ignore[attr-defined]
_set_angle = pymunk.Body.angle.fset  # type: ignore[attr-defined]


@functools.lru_cache(maxsize=64)
def _turn_sweep(footprint: tuple[tuple[float, float], ...], angle: float, n: int = 16) -> tuple[tuple[float, float], ...]:
    """The convex hull (counter-clockwise) of the footprint's corners at ``n + 1``
    headings from 0 to ``angle`` (robot frame)."""
    verts: list[tuple[float, float]] = []
    for k in range(n + 1):
        a = angle * k / n
        c, s = math.cos(a), math.sin(a)
        verts.extend((x * c - y * s, x * s + y * c) for x, y in footprint)
    return _hull(verts)


def _hull(points: list[tuple[float, float]]) -> tuple[tuple[float, float], ...]:
    """Andrew's monotone chain: the convex hull, counter-clockwise."""
    pts = sorted(set(points))

    def cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
        return (a[0] - o[0]) * (b[1] - o[1]) - (a[1] - o[1]) * (b[0] - o[0])

    lower: list[tuple[float, float]] = []
    upper: list[tuple[float, float]] = []
    for p in pts:
        while len(lower) >= 2 and cross(lower[-2], lower[-1], p) <= 0:
            lower.pop()
        lower.append(p)
    for p in reversed(pts):
        while len(upper) >= 2 and cross(upper[-2], upper[-1], p) <= 0:
            upper.pop()
        upper.append(p)
    return tuple(lower[:-1] + upper[:-1])


class World:
    """A pymunk space with the obstacle boxes (static) and the robot (a kinematic body).

    Built once per planning run (:func:`simulate` caches it in ``worlds=``); a query
    only places the robot and reshapes one reusable sweep polygon. ``indices`` limits
    the world to some boxes.
    """

    def __init__(self, obstacles: Obstacles, robot: RobotModel, indices: np.ndarray | list[int] | None = None) -> None:
        self.robot = robot
        self.obstacles = obstacles
        space = pymunk.Space()
        space.collision_slop = 0.0005
        idx = range(len(obstacles)) if indices is None else indices
        shapes = []
        self._index: dict[pymunk.Shape, int] = {}
        body = space.static_body
        for i, box in zip(idx, obstacles.boxes[list(idx)].tolist()):
            shape = pymunk.Poly(body, box)
            self._index[shape] = int(i)
            shapes.append(shape)
        self.body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        self.shape = pymunk.Poly(self.body, list(robot.footprint))
        self.shape.filter = _ROBOT_FILTER
        self._sweep = pymunk.Poly(self.body, list(robot.footprint))
        self._sweep.filter = _ROBOT_FILTER
        space.add(self.body, self.shape, self._sweep, *shapes)
        self.space = space
        # the sensed points of the world's boxes, which decide contact
        owner = obstacles.owner
        mask = slice(None) if indices is None else np.isin(owner, np.asarray(list(idx), dtype=np.intp))
        self.points = np.ascontiguousarray(obstacles.points[mask]) if len(obstacles.points) else np.zeros((0, 2))
        self.owner = owner[mask] if len(owner) else np.zeros(0, dtype=np.intp)
        # the body in its own frame: real and inflated extents, swept radius
        self.real = body_box(robot)
        self.infl = body_box(robot, robot.clearance)
        self._radius = robot.swept_radius

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
            i = self._index.get(h.shape)
            if i is None:
                continue
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

    def sweep_hits(self, task: Task) -> list[int]:
        """Indices of the boxes the whole motion of ``task`` could touch, by one query.

        A STRAIGHT translates the footprint: its swept area is exactly the hull of the
        start and end footprints. A turn rotates it: the hull of the footprint at
        sixteen headings across the turn, grown by the largest gap between an arc and
        its chord, contains the swept area. Both are upper bounds of the area limited
        by the task's limit, so an empty answer is never wrong.
        """
        rear, front, half = self.infl
        if task.kind is TaskKind.STRAIGHT:
            verts: Any = ((-rear, -half), (front + task.limit, -half), (front + task.limit, half), (-rear, half))
            grow = 0.0
        else:
            sign = 1.0 if task.kind is TaskKind.LEFT else -1.0
            n = 16
            verts = _turn_sweep(self.robot.footprint, sign * task.limit, n)
            grow = self._radius * (1 - math.cos(task.limit / n / 2)) + 1e-6
        sweep = self._sweep
        sweep.unsafe_set_vertices(verts)
        sweep.unsafe_set_radius(grow)
        self.place(task.start)
        index = self._index
        return sorted(i for h in self.space.shape_query(sweep) if (i := index.get(h.shape)) is not None)

    def sweep_is_clear(self, task: Task) -> bool:
        """True when the whole motion of ``task`` touches no box (see :meth:`sweep_hits`)."""
        return not self.sweep_hits(task)

    def point_check(self, start: Pose) -> _PointCheck:
        """What a task from ``start`` is tested against: the points within its reach."""
        reach = self.robot.sensor_range * 2 + self._radius
        return _PointCheck(self, start, reach)

    def rollout(self, task: Task) -> Outcome:
        """Run ``task`` tick by tick in the engine from its start pose until it ends or
        touches a box (the reference the closed forms are tested against)."""
        return _rollout(task, self)


def _rollout(task: Task, world: World | None) -> Outcome:
    """The tick loop: each control tick moves the body by the exact unicycle step of its
    wheel speeds (:func:`clomp.formal.geometry.arc_step`, the one pose integration), and in
    a ``world`` the footprint is then tested against the sensed points (the rule of
    :mod:`clomp.planner.rollout`: the inflated footprint; the real body for points already
    within the margin at the start; points inside the real body at the start are exempt)
    and the engine's body placed where the task stopped."""
    r = task.robot
    dt = r.tick
    b = r.wheel_base
    x, y, th = task.start.x, task.start.y, task.start.theta
    pose = task.start
    ticks = 0
    distance = 0.0
    d_n: Disturbance | None = None
    check = None if world is None else world.point_check(task.start)
    limit = task.max_ticks()
    while d_n is None and ticks < limit:
        e = task.error_at(x, y, th)
        if task.done(e):
            break
        v, w = wheel_twist(*task.wheel_speeds(e), b)
        nx, ny, nth = arc_step(x, y, th, v, w, dt)
        if check is not None and (d_n := check.hit(nx, ny, nth)) is not None:
            break
        distance += abs(v) * dt
        x, y, th = nx, ny, nth
        ticks += 1
    if ticks:
        pose = Pose(x, y, wrap_angle(th))
    if world is not None:
        world.place(pose)
    return Outcome(task.kind, task.start, pose, distance, ticks * dt, ticks, d_n, False)


class _PointCheck:
    """The sensed points a task from one start pose can meet, with its start-touching sets."""

    def __init__(self, world: World, start: Pose, reach: float) -> None:
        pts = world.points
        dx, dy = pts[:, 0] - start.x, pts[:, 1] - start.y
        near = np.flatnonzero(dx * dx + dy * dy <= reach * reach)
        self.world = world
        self.idx = near
        self.points = pts[near]
        self.waived = inside_at(self.points, start, world.infl)
        self.exempt = inside_at(self.points, start, world.real, strict=True)

    def hit(self, x: float, y: float, th: float) -> Disturbance | None:
        """D_N for the first point the footprint at (x, y, th) touches, or None."""
        if not len(self.points):
            return None
        w = self.world
        local = points_to_frame(self.points, (x, y, th))
        u, v = local[:, 0], np.abs(local[:, 1])
        met = np.where(self.waived, inside(u, v, w.real), inside(u, v, w.infl)) & ~self.exempt
        if not met.any():
            return None
        j = int(np.argmax(met))
        k = int(self.idx[j])
        return _obstacle_disturbance(w.obstacles, (int(w.owner[k]), float(self.points[j, 0]), float(self.points[j, 1])))


def _obstacle_disturbance(obstacles: Obstacles, hit: tuple[int, float, float]) -> Disturbance:
    i, x, y = hit
    return Disturbance(DisturbanceKind.OBSTACLE, x, y, obstacles.outline(i), i)


