"""Known-free space: what the LiDAR's rays crossed, and whether a task's body stays in it.

A return at bearing β and range r says the ray from the sensor to it crossed free space;
behind it (its shadow) nothing is known. :class:`KnownFree` holds one scan's returns
sorted by bearing (a per-bearing free-range table, exact between returns) and answers
whether the region a task's body sweeps lies inside the union of those rays:

- between two returns adjacent in bearing that belong to one surface (less than
  ``beam_gap`` apart in bearing, or less than ``surface`` apart in space) the free range
  is the chord between them: behind it is the surface's shadow, unknown;
- between returns farther apart, the beams in between returned nothing within the
  planning horizon. That is free space to the horizon when the sensor says so
  (``nothing_beyond=True``: a scan cropped at the horizon, as the recorded scans, the
  simulated LiDAR and the drivers deliver it — an empty scan is free space); for a bare
  point list without that promise (``nothing_beyond=False``) it is unknown;
- the body at the planning origin (where the robot stands) is known; nothing beyond the
  horizon is.

**The rule** (:class:`clomp.planner.configurator.Configurator`): a task whose body leaves
known-free space is like a step that meets the rim of the sensed disc — a STRAIGHT is
kept as a frontier end (never expanded, never a goal: the closed loop drives there and
looks again), a turn is not available. So a plan's body never passes through unknown
space before its last task, and ``reached_goal`` is claimed only for a plan wholly inside
known-free space. A goal outside known-free space (in a shadow) is treated like one
beyond the disc: the first frontier end popped ends the search.

The test is exact on straight edges: the swept region (a STRAIGHT's rectangle; a turn's
start and end bodies with its corners' arcs as circumscribed polylines, 0.1 rad a
segment) is star-shaped checked by its outline, and an outline edge is cut where it
crosses the ray through a return, so that every piece lies within one sector, whose free
set is convex. A per-degree table of each sector's nearest free range accepts most tasks
at once (no array operation).

>>> import numpy as np
>>> from clomp.planner.robot_model import RobotModel
>>> post = np.array([[0.5, y] for y in (-0.02, -0.01, 0.0, 0.01, 0.02)])
>>> free = KnownFree.from_points(post, 1.1)
>>> free.contains(0.4, 0.0), free.contains(0.7, 0.0), free.contains(0.7, 0.3)
(True, False, True)
>>> free.straight_clear(Pose(0.0, 0.3, 0.0), 0.5, RobotModel()), free.straight_clear(Pose(0.0, 0.0, 0.0), 0.5, RobotModel())
(True, False)
"""

from __future__ import annotations

import math

import numpy as np

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose, TaskKind
from clomp.planner.engine import Outcome
from clomp.planner.robot_model import RobotModel

__all__ = ["KnownFree", "BEAM_GAP", "SURFACE"]

#: returns closer than this in bearing (rad) are adjacent beams of one surface: the A1's
#: beams are under 1 degree apart, so two degrees always leave a beam between open sectors
BEAM_GAP = math.radians(2.0)
#: returns closer than this in space (m) are one surface (perception's cluster distance)
SURFACE = 0.1
#: how far a body point may lie beyond a chord and still count as crossed (m): 1 mm of
#: arithmetic slack against the 1 cm the sensor rounds to (the body keeps 1 cm off a point)
_TOL = 0.001
# the per-degree table of nearest free ranges (quick acceptance)
_BINS = 360
_BIN = 2 * math.pi / _BINS
# a turn's corner arcs as circumscribed polylines, at most this much a segment (rad)
_ARC_STEP = 0.1


class KnownFree:
    """One scan's known-free space (see the module docstring): its returns by bearing,
    per gap between adjacent returns whether it is a surface (bounded by the chord) or
    open, and each chord's line.

    >>> KnownFree.from_points(np.zeros((0, 2)), 1.1).contains(1.0, 0.0)
    True
    >>> KnownFree.from_points(np.zeros((0, 2)), 1.1, nothing_beyond=False).contains(1.0, 0.0)
    False
    """

    __slots__ = ("horizon", "nothing_beyond", "body", "b", "b2", "r", "bounded", "nx", "ny", "c", "lb", "m")

    def __init__(
        self, points: np.ndarray, horizon: float, *, nothing_beyond: bool = True,
        body: tuple[float, float, float] = (0.18, 0.09, 0.09), beam_gap: float = BEAM_GAP, surface: float = SURFACE,
    ) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        self.horizon = float(horizon)
        self.nothing_beyond = bool(nothing_beyond)
        self.body = body
        x, y = pts[:, 0], pts[:, 1]
        r = np.hypot(x, y)
        keep = (r > 1e-6) & (r <= horizon)
        b = np.arctan2(y[keep], x[keep])
        order = b.argsort(kind="stable")
        b, x, y, r = b[order], x[keep][order], y[keep][order], r[keep][order]
        m = self.m = len(b)
        self.b, self.r = b, r
        self.b2 = np.concatenate((b, b + 2 * math.pi))
        # gap k: from return k to return k + 1 (the last to the first, round the circle)
        nxt = np.roll(np.arange(m), -1)
        gap = np.empty(m)
        if m:
            gap[:-1] = b[1:] - b[:-1]
            gap[-1] = b[0] + 2 * math.pi - b[-1]
        dx, dy = x[nxt] - x, y[nxt] - y
        chord = np.hypot(dx, dy)
        self.bounded = (gap < math.pi / 2) & ((gap <= beam_gap) | (chord <= surface))
        # each chord's line n·p = c with n a unit normal pointing away from the sensor
        # (a chord of no length: the radial line through its return)
        with np.errstate(invalid="ignore", divide="ignore"):
            nx = np.where(chord > 1e-12, dy / chord, x / r)
            ny = np.where(chord > 1e-12, -dx / chord, y / r)
        c = nx * x + ny * y
        flip = c < 0
        self.nx, self.ny, self.c = np.where(flip, -nx, nx), np.where(flip, -ny, ny), np.abs(c)
        self.lb = self._table(x, y, dx, dy, chord, r)

    @classmethod
    def from_points(
        cls, points: np.ndarray, horizon: float, *, nothing_beyond: bool = True, robot: RobotModel | None = None,
        beam_gap: float = BEAM_GAP, surface: float = SURFACE,
    ) -> "KnownFree":
        """The known-free space of a scan given as its returns (N×2, sensor frame);
        ``nothing_beyond``: bearings with no return within ``horizon`` returned nothing
        within it (a cropped revolution); ``robot``: whose body at the origin is known."""
        rob = robot or RobotModel()
        box = (rob.rear_offset, rob.front_offset, rob.width / 2)
        return cls(points, horizon, nothing_beyond=nothing_beyond, body=box, beam_gap=beam_gap, surface=surface)

    def _table(self, x: np.ndarray, y: np.ndarray, dx: np.ndarray, dy: np.ndarray, chord: np.ndarray, r: np.ndarray) -> list[float]:
        """Per degree of bearing, a range within which everything is known free."""
        open_range = self.horizon if self.nothing_beyond else 0.0
        m = self.m
        if not m:
            val_ext = np.array([open_range])
            s_ext = np.zeros(_BINS + 1, dtype=np.intp)
        else:
            # the sector's nearest point: the chord's (a surface), else the horizon or nothing
            with np.errstate(invalid="ignore", divide="ignore"):
                tau = np.where(chord > 1e-12, -(x * dx + y * dy) / (chord * chord), 0.0)
            near = np.where((tau > 0) & (tau < 1), self.c, np.minimum(r, np.roll(r, -1)))
            val = np.where(self.bounded, near, open_range)
            val_ext = np.concatenate((val[-1:], val))  # index 0: the sector round the bearing ±π
            edges = -math.pi + _BIN * np.arange(_BINS + 1)
            s_ext = np.searchsorted(self.b, edges, side="right")
        red = np.minimum.reduceat(val_ext, s_ext)[:_BINS]
        lb = np.minimum(red, val_ext[s_ext[1:]])
        rear, front, half = self.body
        return np.maximum(lb, min(rear, front, half)).tolist()  # type: ignore[no-any-return]

    # -- queries -----------------------------------------------------------------------
    def contains(self, x: float, y: float) -> bool:
        """True when the point (x, y) (sensor frame) is known free."""
        return bool(self._free(np.array([x]), np.array([y]))[0])

    def _in_body(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        rear, front, half = self.body
        out: np.ndarray = (x >= -rear) & (x <= front) & (np.abs(y) <= half)
        return out

    def _sector_free(self, x: np.ndarray, y: np.ndarray, k: np.ndarray) -> np.ndarray:
        """Whether each point lies in the free set of sector ``k`` (its gap's)."""
        if not self.m:
            d2 = x * x + y * y
            out: np.ndarray = d2 <= self.horizon ** 2 if self.nothing_beyond else np.zeros(len(x), dtype=bool)
            return out | self._in_body(x, y)
        bounded = self.bounded[k]
        chord_ok = self.nx[k] * x + self.ny[k] * y <= self.c[k] + _TOL
        open_ok = (x * x + y * y <= self.horizon ** 2) if self.nothing_beyond else np.zeros(len(x), dtype=bool)
        return np.where(bounded, chord_ok, open_ok) | self._in_body(x, y)

    def _sector(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """The gap each point's bearing lies in (gap k: from return k to return k + 1)."""
        if not self.m:
            return np.zeros(len(x), dtype=np.intp)
        i = np.searchsorted(self.b, np.arctan2(y, x), side="right") - 1
        i[i < 0] = self.m - 1
        return i

    def _free(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return self._sector_free(x, y, self._sector(x, y))

    def _quick(self, xs: list[float], ys: list[float]) -> bool:
        """True when the convex polygon of these vertices (not round the sensor) lies within
        the table's nearest free ranges over its bearings (then it is surely free)."""
        far = max(math.hypot(a, b) for a, b in zip(xs, ys))
        b0 = math.atan2(ys[0], xs[0])
        rel = [wrap_angle(math.atan2(b, a) - b0) for a, b in zip(xs, ys)]
        return self._span_ok(b0 + min(rel), b0 + max(rel), far)

    def _span_ok(self, lo: float, hi: float, far: float) -> bool:
        i0 = int(math.floor((lo + math.pi) / _BIN))
        i1 = int(math.floor((hi + math.pi) / _BIN))
        lb = self.lb
        if i1 - i0 >= _BINS - 1:
            return far <= min(lb)
        i0 %= _BINS
        i1 %= _BINS
        near = min(lb[i0 : i1 + 1]) if i0 <= i1 else min(min(lb[i0:]), min(lb[: i1 + 1]))
        return far <= near

    def edges_clear(self, ax: np.ndarray, ay: np.ndarray, bx: np.ndarray, by: np.ndarray) -> bool:
        """True when every segment from (ax, ay) to (bx, by) lies in known-free space: each
        is cut where it crosses the ray through a return, and both ends of every piece
        are tested in the piece's own sector (whose free set is convex)."""
        ok = self._free(ax, ay) & self._free(bx, by)
        if not ok.all():
            return False
        if self.m < 2:
            return True  # one sector round the sensor: its ends decide
        m = self.m
        ba, bb = np.arctan2(ay, ax), np.arctan2(by, bx)
        rel = bb - ba
        rel = np.where(rel > math.pi, rel - 2 * math.pi, np.where(rel <= -math.pi, rel + 2 * math.pi, rel))
        lo = np.where(rel >= 0, ba, bb)
        hi = lo + np.abs(rel)
        i0 = np.searchsorted(self.b2, lo, side="right")
        i1 = np.searchsorted(self.b2, hi, side="left")
        counts = np.maximum(i1 - i0, 0)
        total = int(counts.sum())
        if not total:
            return True
        e = np.repeat(np.arange(len(ax)), counts)
        j = np.arange(total) - np.repeat(np.cumsum(counts) - counts, counts) + np.repeat(i0, counts)
        j = j % m
        # where each segment's line meets the ray through return j: rho along the ray
        ex, ey = (bx - ax)[e], (by - ay)[e]
        ux, uy = np.cos(self.b[j]), np.sin(self.b[j])
        den = ux * ey - uy * ex
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = (ax[e] * ey - ay[e] * ex) / den
        rho = np.where(np.isfinite(rho), rho, 0.0)
        px, py = rho * ux, rho * uy
        left = (j - 1) % m
        return bool((self._sector_free(px, py, left) & self._sector_free(px, py, j)).all())

    def straight_clear(self, start: Pose, distance: float, robot: RobotModel) -> bool:
        """True when the real body, driven ``distance`` metres straight from ``start``,
        stays in known-free space."""
        rear, front = robot.rear_offset, robot.front_offset + max(distance, 0.0)
        half = robot.width / 2
        c, s = math.cos(start.theta), math.sin(start.theta)
        us = (-rear, front, front, -rear)
        vs = (-half, -half, half, half)
        xs = [start.x + u * c - v * s for u, v in zip(us, vs)]
        ys = [start.y + u * s + v * c for u, v in zip(us, vs)]
        # the sensor inside the swept rectangle: every bearing is spanned
        ox, oy = -start.x * c - start.y * s, start.x * s - start.y * c
        if not (-rear <= ox <= front and abs(oy) <= half) and self._quick(xs, ys):
            return True
        ax, ay = np.array(xs), np.array(ys)
        return self.edges_clear(ax, ay, np.roll(ax, -1), np.roll(ay, -1))

    def turn_clear(self, start: Pose, angle: float, robot: RobotModel) -> bool:
        """True when the real body, turned in place by ``angle`` (signed, rad) at
        ``start``, stays in known-free space."""
        rad = robot.body_radius
        d = math.hypot(start.x, start.y)
        if d > rad:
            half = math.asin(rad / d)
            bc = math.atan2(start.y, start.x)
            if self._span_ok(bc - half, bc + half, d + rad):
                return True
        segs = [self._body_edges(start.x, start.y, start.theta, robot), self._body_edges(start.x, start.y, start.theta + angle, robot)]
        n = max(1, int(math.ceil(abs(angle) / _ARC_STEP)))
        step = angle / n
        grow = 1.0 / math.cos(step / 2)
        for a, b in robot.corners:
            rc, phi = math.hypot(a, b), start.theta + math.atan2(b, a)
            mid = phi + step * (np.arange(n) + 0.5)
            px = np.concatenate(([start.x + rc * math.cos(phi)], start.x + rc * grow * np.cos(mid), [start.x + rc * math.cos(phi + angle)]))
            py = np.concatenate(([start.y + rc * math.sin(phi)], start.y + rc * grow * np.sin(mid), [start.y + rc * math.sin(phi + angle)]))
            segs.append((px[:-1], py[:-1], px[1:], py[1:]))
        ax, ay, bx, by = (np.concatenate([s[i] for s in segs]) for i in range(4))
        return self.edges_clear(ax, ay, bx, by)

    @staticmethod
    def _body_edges(x: float, y: float, theta: float, robot: RobotModel) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        c, s = math.cos(theta), math.sin(theta)
        corners = robot.corners
        ax = np.array([x + u * c - v * s for u, v in corners])
        ay = np.array([y + u * s + v * c for u, v in corners])
        return ax, ay, np.roll(ax, -1), np.roll(ay, -1)

    def clear(self, out: Outcome, robot: RobotModel) -> bool:
        """True when the body stays in known-free space over the task ``out`` rolled out."""
        if out.task is TaskKind.STRAIGHT:
            return self.straight_clear(out.start, out.distance, robot)
        turned = wrap_angle(out.end.theta - out.start.theta)
        if out.task is TaskKind.LEFT and turned < 0:
            turned += 2 * math.pi
        elif out.task is TaskKind.RIGHT and turned > 0:
            turned -= 2 * math.pi
        return turned == 0.0 or self.turn_clear(out.start, turned, robot)
