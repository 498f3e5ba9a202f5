"""Bodies that move or appear in the execution world: people (discs) walking seeded paths,
a person who walks in and stops, a box that appears in the lane, a door that closes (issue #42).

A :class:`Mover` is kinematic: it follows its path whatever touches it (a person does not
yield to a robot), so a contact with one is either the robot driving into it or it walking
into the robot. :class:`Movers` keeps them in the world's pymunk space (added when they
appear, removed when they leave), gives the LiDAR their outlines at each ray's time (the
sensor sees them beam by beam, as it sees walls) and tells, at every step the robot
touches one, who hit whom (:meth:`Movers.robot_caused`).

A path is a list of ``(t, x, y)`` waypoints (s, m, world frame): the body is absent before
the first time, moves linearly between waypoints, and after the last one stays there
(``stays``) or leaves the world. A box with ``ahead`` set appears at ``appear`` s that far
(m) ahead of the robot's front edge, across its heading, wherever the robot then is (the
issue's "a box appearing 5 cm ahead"); a person with ``ahead`` set appears at ``appear`` s
``lateral`` m to the side (positive: left) of that point and walks there at ``speed`` m/s,
and stops (the issue's "a person walks in and stops ahead"): the point is reckoned with
the robot driving on at ``drive_speed`` while the person walks. A ``door`` is a sliding
panel (a rectangle ``size`` = [length, thickness] m, its long side at ``angle`` rad from the
x axis, by default across the x axis): it enters the world at its path's first time, slides
along the path into the doorway and stays (a door that closes; hidden in the wall before, as
the wall is as thick as the panel).

>>> m = Mover.from_dict({"kind": "person", "path": [[0, 0.5, -1.0], [2, 0.5, 1.0]], "stays": False})
>>> m.position(1.0), m.present(3.0), m.radius
((0.5, 0.0), False, 0.12)
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
import pymunk

__all__ = ["MOVER", "PERSON_RADIUS", "BOX_SIZE", "DOOR_THICKNESS", "Mover", "Movers", "parse_movers"]

MOVER = 3
"""The pymunk collision type (and filter category) of a moving body."""
PERSON_RADIUS = 0.12
"""A person's radius (m), the issue's kinematic person."""
BOX_SIZE = 0.16
"""The side of a box that appears (m)."""
DOOR_THICKNESS = 0.02
"""A door panel's thickness by default (m): the layouts' wall thickness."""


@dataclass(frozen=True)
class Mover:
    """One moving or appearing body (see the module): ``kind`` ``"person"`` (a disc of
    ``radius``), ``"box"`` (a square of side ``2 * radius``) or ``"door"`` (a panel of
    ``size`` at ``angle``), its waypoints ``path``, whether it ``stays`` at the last one,
    and for a box or a person ``ahead`` / ``appear``.

    >>> Mover.from_dict({"kind": "box", "appear": 4.0, "ahead": 0.05}).radius
    0.08
    >>> Mover.from_dict({"kind": "door", "size": [0.5, 0.02], "path": [[3, 0.6, 0.5], [4, 0.6, 0.0]]}).corners((0.6, 0.0))[0]
    (0.61, -0.25)
    """

    kind: str
    radius: float
    path: tuple[tuple[float, float, float], ...] = ()
    stays: bool = True
    appear: float | None = None
    ahead: float | None = None
    lateral: float = 0.0
    speed: float = 0.5
    drive_speed: float = 0.1
    size: tuple[float, float] = (0.0, 0.0)
    angle: float = math.pi / 2

    @classmethod
    def from_dict(cls, raw: Mapping[str, Any]) -> "Mover":
        """A mover from its JSON form; ValueError naming what is wrong."""
        kind = raw.get("kind")
        if kind not in ("person", "box", "door"):
            raise ValueError(f"mover kind must be 'person', 'box' or 'door', got {kind!r}")
        if kind == "door":
            return cls._door(raw)
        radius = float(raw.get("radius", PERSON_RADIUS if kind == "person" else BOX_SIZE / 2))
        try:
            path = tuple((float(t), float(x), float(y)) for t, x, y in raw.get("path", ()))
        except (TypeError, ValueError):
            raise ValueError(f"mover path must be a list of [t, x, y], got {raw.get('path')!r}") from None
        ahead = raw.get("ahead")
        appear = raw.get("appear")
        vals = [radius, *(v for p in path for v in p)] + [float(v) for v in (ahead, appear) if v is not None]
        if not all(math.isfinite(v) for v in vals) or radius <= 0:
            raise ValueError(f"mover: expected finite numbers and a positive radius, got {dict(raw)!r}")
        if any(b[0] < a[0] for a, b in zip(path, path[1:])):
            raise ValueError("mover path: waypoint times must not decrease")
        if ahead is None and not path:
            raise ValueError("mover: needs a path, or 'ahead' and 'appear' (a box that appears ahead of the robot)")
        if ahead is not None and appear is None:
            raise ValueError("mover: 'ahead' needs 'appear' (when the box appears)")
        lateral, speed = float(raw.get("lateral", 0.0)), float(raw.get("speed", 0.5))
        if not (math.isfinite(lateral) and math.isfinite(speed) and speed > 0):
            raise ValueError(f"mover: lateral must be finite and speed positive, got {lateral!r}, {speed!r}")
        return cls(kind, radius, path, bool(raw.get("stays", True)), None if appear is None else float(appear),
                   None if ahead is None else float(ahead), lateral, speed)

    @classmethod
    def _door(cls, raw: Mapping[str, Any]) -> "Mover":
        """A door from its JSON form: ``size``, ``angle`` and a ``path`` (it stays)."""
        try:
            size = tuple(float(v) for v in raw.get("size", ()))
            path = tuple((float(t), float(x), float(y)) for t, x, y in raw.get("path", ()))
            angle = float(raw.get("angle", math.pi / 2))
        except (TypeError, ValueError):
            raise ValueError(f"door: expected size [length, thickness], a path of [t, x, y] and an angle, got {dict(raw)!r}") from None
        if len(size) == 1:
            size = (size[0], DOOR_THICKNESS)
        if len(size) != 2 or not all(math.isfinite(v) and v > 0 for v in size) or not path:
            raise ValueError(f"door: needs a size [length, thickness] of positive numbers and a path, got {dict(raw)!r}")
        if not all(math.isfinite(v) for p in path for v in p) or not math.isfinite(angle):
            raise ValueError(f"door: expected finite numbers, got {dict(raw)!r}")
        if any(b[0] < a[0] for a, b in zip(path, path[1:])):
            raise ValueError("mover path: waypoint times must not decrease")
        if "ahead" in raw:
            raise ValueError("door: 'ahead' is for a box or a person (a door slides along its path)")
        return cls("door", max(size) / 2, path, True, size=(size[0], size[1]), angle=angle)

    def corners(self, c: tuple[float, float]) -> list[tuple[float, float]]:
        """The outline of a box or a door centred at ``c`` (world frame, counter-clockwise)."""
        if self.kind == "door":
            hl, ht = self.size[0] / 2, self.size[1] / 2
            a, b = math.cos(self.angle), math.sin(self.angle)
            local = [(-hl, -ht), (hl, -ht), (hl, ht), (-hl, ht)]
            return [(round(c[0] + u * a - v * b, 12), round(c[1] + u * b + v * a, 12)) for u, v in local]
        r = self.radius
        return [(c[0] - r, c[1] - r), (c[0] + r, c[1] - r), (c[0] + r, c[1] + r), (c[0] - r, c[1] + r)]

    def placed(self, t: float, robot: tuple[float, float, float], front: float) -> tuple[tuple[float, float, float], ...]:
        """The path of a mover with ``ahead``, placed at ``t`` for the robot at ``robot`` (x, y,
        theta) with its front edge ``front`` m ahead of its centre."""
        x, y, th = robot
        c, s = math.cos(th), math.sin(th)
        walk = abs(self.lateral) / self.speed
        d = front + float(self.ahead or 0.0) + self.radius + self.drive_speed * walk
        tx, ty = x + d * c, y + d * s
        if not self.lateral:
            return ((t, tx, ty),)
        return ((t, tx - self.lateral * s, ty + self.lateral * c), (t + walk, tx, ty))

    def start_time(self) -> float:
        """When the body enters the world (s)."""
        return self.appear if self.appear is not None else self.path[0][0]

    def present(self, t: float) -> bool:
        """Whether the body is in the world at ``t`` (path-only movers; see :class:`Movers`)."""
        if t < self.start_time():
            return False
        return self.stays or not self.path or t <= self.path[-1][0]

    def position(self, t: float) -> tuple[float, float]:
        """Where the path puts the body's centre at ``t`` (held at its ends)."""
        p = self.path
        if t <= p[0][0]:
            return p[0][1], p[0][2]
        for (t0, x0, y0), (t1, x1, y1) in zip(p, p[1:]):
            if t <= t1:
                u = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
                return x0 + u * (x1 - x0), y0 + u * (y1 - y0)
        return p[-1][1], p[-1][2]


def parse_movers(raw: Iterable[Mover | Mapping[str, Any]] | None) -> tuple[Mover, ...]:
    """Movers from their JSON forms (or Movers as they are).

    >>> len(parse_movers([{"kind": "box", "appear": 2.0, "ahead": 0.1}]))
    1
    """
    return tuple(m if isinstance(m, Mover) else Mover.from_dict(m) for m in (raw or ()))


class Movers:
    """The movers of one world (see the module): their bodies in ``space``, their outlines
    for the LiDAR, and who hit whom."""

    def __init__(self, space: pymunk.Space, movers: Iterable[Mover], friction: float) -> None:
        self.space, self.movers = space, tuple(movers)
        self.bodies: list[pymunk.Body] = []
        self.shapes: list[pymunk.Shape] = []
        # each mover's path; one with 'ahead' gets it when it appears
        self.paths: list[tuple[tuple[float, float, float], ...] | None] = [
            None if m.ahead is not None else m.path for m in self.movers]
        self.inside = [False] * len(self.movers)
        self.drive = (0.0, 0.0, 0.0)
        for m in self.movers:
            body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
            if m.kind == "person":
                shape: pymunk.Shape = pymunk.Circle(body, m.radius)
            else:
                shape = pymunk.Poly(body, m.corners((0.0, 0.0)))
            shape.friction = friction
            shape.collision_type = MOVER
            shape.filter = pymunk.ShapeFilter(categories=MOVER)
            self.bodies.append(body)
            self.shapes.append(shape)

    def _where(self, k: int, t: float) -> tuple[float, float] | None:
        m, path = self.movers[k], self.paths[k]
        if path is None or not m.present(t):
            return None
        return m.position(t) if path is m.path else Mover(m.kind, m.radius, path).position(t)

    def step(self, t: float, dt: float, robot: tuple[float, float, float], front: float,
             drive: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> None:
        """Before the physics step from ``t``: bodies enter or leave, each is placed where
        its path has it at ``t`` with the velocity that carries it to where it is at ``t + dt``.
        ``drive`` is the velocity and turn rate the wheels drive the robot at in this step
        (world frame, m/s, rad/s): who hit whom is judged on it (after the step a contact has
        stopped the body)."""
        self.drive = drive
        for k, m in enumerate(self.movers):
            if self.paths[k] is None and t >= m.start_time():
                self.paths[k] = m.placed(t, robot, front)
            now = self._where(k, t)
            body = self.bodies[k]
            if now is None:
                if self.inside[k]:
                    self.space.remove(body, self.shapes[k])
                    self.inside[k] = False
                continue
            if not self.inside[k]:
                self.space.add(body, self.shapes[k])
                self.inside[k] = True
            then = self._where(k, t + dt) or now
            body.position = now
            body.velocity = ((then[0] - now[0]) / dt, (then[1] - now[1]) / dt)

    def outlines(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        """The movers present at ``t`` as the LiDAR's edges and circles (see
        :func:`clomp.runtime.backends._lidar.obstacle_arrays`)."""
        edges: list[tuple[float, float, float, float]] = []
        circles: list[tuple[float, float, float]] = []
        for k, m in enumerate(self.movers):
            c = self._where(k, t)
            if c is None:
                continue
            if m.kind == "person":
                circles.append((c[0], c[1], m.radius))
            else:
                v = m.corners(c)
                edges += [(v[i][0], v[i][1], v[(i + 1) % 4][0] - v[i][0], v[(i + 1) % 4][1] - v[i][1]) for i in range(4)]
        return np.array(edges, dtype=float).reshape(-1, 4), np.array(circles, dtype=float).reshape(-1, 3)

    def robot_caused(self, arb: pymunk.Arbiter, body: pymunk.Body) -> bool | None:
        """Who hit whom in the contact ``arb`` of the robot's ``body``: True when the robot
        drives into the mover (the wheels move the touching point of the body towards the
        mover, along the contact normal, at 1 cm/s or more and at least as fast as the mover
        comes towards it: a turn that swings the body's corner into a box counts), False when
        the mover walks into the robot; None when the contact is with no mover."""
        a, b = arb.shapes
        other, sign = (b, 1.0) if a.body is body else (a, -1.0)
        try:
            k = self.shapes.index(other)
        except ValueError:
            return None
        points = arb.contact_point_set.points
        if not points:
            return None
        n = arb.contact_point_set.normal  # from shape a to shape b
        nx, ny = sign * n.x, sign * n.y  # from the robot into the mover
        px, py = points[0].point_a if sign > 0 else points[0].point_b
        vx, vy, w = self.drive
        rx, ry = px - body.position.x, py - body.position.y
        robot = (vx - w * ry) * nx + (vy + w * rx) * ny
        mv = self.bodies[k].velocity
        mover = -(mv.x * nx + mv.y * ny)
        return robot >= 0.01 and robot >= mover
