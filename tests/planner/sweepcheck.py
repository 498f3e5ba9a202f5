"""An independent check of planned motion against the raw scan (shared by tests and bench).

It knows nothing of the planner's geometry: it samples every task's motion finely
(5 mm of travel, 0.01 rad of turn) and tests the robot's real rectangle at each sample
against the sensed points, and against the sensed disc around the planning origin.

- ``over_points``: sensed points inside the real body at some sample (deeper than
  ``tol``), except the points inside the body at the planning origin (its own returns,
  the only points the start-touching rule may exempt);
- ``outside_disc``: the largest distance (m) by which a body corner leaves the disc.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

__all__ = ["Check", "check_motion", "check_states"]


@dataclass(frozen=True)
class Check:
    """What the independent sweep found for some tasks."""

    over_points: int
    outside_disc: float

    @property
    def ok(self) -> bool:
        return self.over_points == 0 and self.outside_disc <= 1e-6


def _samples(kind: str, start: tuple[float, float, float], end: tuple[float, float, float]) -> np.ndarray:
    x0, y0, t0 = start
    x1, y1, t1 = end
    if kind == "STRAIGHT":
        n = max(2, int(math.ceil(math.hypot(x1 - x0, y1 - y0) / 0.005)) + 1)
        f = np.linspace(0, 1, n)
        return np.c_[x0 + f * (x1 - x0), y0 + f * (y1 - y0), np.full(n, t0)]
    d = (t1 - t0 + math.pi) % (2 * math.pi) - math.pi
    if kind == "LEFT" and d < -1e-9:
        d += 2 * math.pi
    if kind == "RIGHT" and d > 1e-9:
        d -= 2 * math.pi
    n = max(2, int(math.ceil(abs(d) / 0.01)) + 1)
    return np.c_[np.full(n, x0), np.full(n, y0), t0 + np.linspace(0, d, n)]


def _inside(points: np.ndarray, pose: np.ndarray, rear: float, front: float, half: float, tol: float) -> np.ndarray:
    c, s = math.cos(pose[2]), math.sin(pose[2])
    dx, dy = points[:, 0] - pose[0], points[:, 1] - pose[1]
    u, v = dx * c + dy * s, dy * c - dx * s
    return (u > -rear + tol) & (u < front - tol) & (np.abs(v) < half - tol)


def check_motion(
    points: np.ndarray,
    motions: list[tuple[str, tuple[float, float, float], tuple[float, float, float]]],
    length: float = 0.27,
    width: float = 0.18,
    front: float = 0.09,
    sensor_range: float = 1.1,
    tol: float = 1e-3,
) -> Check:
    """Check ``motions`` ((task, start pose, end pose) in the planning frame) against ``points``."""
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    rear, half = length - front, width / 2
    if len(pts):
        own = _inside(pts, np.zeros(3), rear, front, half, 0.0)
        pts = pts[~own]
    corners = np.array([(-rear, -half), (front, -half), (front, half), (-rear, half)])
    over = np.zeros(len(pts), dtype=bool)
    out = 0.0
    for kind, start, end in motions:
        for pose in _samples(kind, start, end):
            if len(pts):
                over |= _inside(pts, pose, rear, front, half, tol)
            c, s = math.cos(pose[2]), math.sin(pose[2])
            r = np.hypot(pose[0] + corners[:, 0] * c - corners[:, 1] * s, pose[1] + corners[:, 0] * s + corners[:, 1] * c)
            out = max(out, float(r.max()) - sensor_range)
    return Check(int(over.sum()), max(out, 0.0))


def check_states(points: np.ndarray, states: list, robot: object | None = None) -> Check:  # type: ignore[type-arg]
    """:func:`check_motion` for cognitive-map states (``task``, ``start``, ``end``)."""
    kw = {}
    if robot is not None:
        kw = dict(length=robot.length, width=robot.width, front=robot.front_offset, sensor_range=robot.sensor_range)  # type: ignore[attr-defined]
    motions = [(s.task.value, tuple(s.start.as_list()), tuple(s.end.as_list())) for s in states]
    return check_motion(points, motions, **kw)  # type: ignore[arg-type]
