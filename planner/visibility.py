"""Known-free space: what the LiDAR's rays crossed, and whether a task's body stays in it.

A return at bearing β and range r says the ray from the sensor to it crossed free space;
behind it (its shadow) nothing is known. :class:`KnownFree` holds one scan's returns
sorted by bearing (a per-bearing free-range table, exact between returns) and answers
whether the region a task's body sweeps lies inside the union of those rays:

- between two returns adjacent in bearing less than ``surface`` (10 cm) apart, one
  surface lies: the free range is the chord between them, and behind it is the
  surface's shadow, unknown;
- between two returns farther apart but less than ``beam_gap`` (2°, a beam or two of
  the A1's) apart in bearing, the depth jumps (one beam grazed a near object's edge, the
  next went on): the wedge between them is known as far as the farther one;
- between returns farther apart in bearing, the beams in between returned nothing within
  the planning horizon. That is free space to the horizon when the sensor says so
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
known-free space. A goal in a shadow is treated as one beyond the disc: no way inside
known-free space reaches it, and the first frontier state popped ends the search.

The test is exact on straight edges. Known-free space is star-shaped about the sensor, so
a region lies in it when its outline does: the swept region's outline (a STRAIGHT's
rectangle; a turn's start and end bodies with its corners' arcs as circumscribed
polylines, 0.2 rad a segment, at most 1 mm off the arc) is tested, an outline edge is cut where it crosses the ray through a return, so that every piece lies
within one sector, whose free set is convex, and both ends of each piece are tested. Per
return, how far its own ray is known and a range within which the sectors beside it are
wholly known let most tasks pass at once (no array operation).

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

import functools
import math
from typing import Any

import numpy as np

from clomp.formal.geometry import polar_to_xy, wrap_angle
from clomp.formal.model import Pose, TaskKind
from clomp.planner.engine import Outcome
from clomp.planner.footprint import inside
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
# a turn's corner arcs as circumscribed polylines, at most this much a segment (rad): the
# polyline stands at most r (1 / cos(0.1) - 1), 1 mm at the rear corners, off the arc
_ARC_STEP = 0.2


def _next(a: np.ndarray) -> np.ndarray:
    """Each element's successor round the circle (the last one's: the first)."""
    return np.concatenate((a[1:], a[:1]))


def _prev(a: np.ndarray) -> np.ndarray:
    """Each element's predecessor round the circle (the first one's: the last)."""
    return np.concatenate((a[-1:], a[:-1]))


#: the attributes the compiled table holds as rows (set at their first use)
_ROWS = frozenset(("b", "r", "reach", "nx", "ny", "c", "lim", "near", "_near2", "surface", "jump", "m", "_sb2", "_sl", "_sc", "_ss"))


@functools.cache
def _free() -> Any:
    """:mod:`clomp.planner._free_kernels`, imported at the first table (numba's import is
    paid by a process that plans, as perception's loops)."""
    from clomp.planner import _free_kernels

    return _free_kernels


@functools.lru_cache(maxsize=8)
def _corners_polar(robot: RobotModel) -> tuple[np.ndarray, np.ndarray]:
    """The body's corners as distances and angles from the rotation centre."""
    corners = np.array(robot.corners)
    return np.hypot(corners[:, 0], corners[:, 1]), np.arctan2(corners[:, 1], corners[:, 0])


class KnownFree:
    """One scan's known-free space (see the module docstring): its returns by bearing,
    per gap between adjacent returns whether it is a surface (bounded by the chord) or
    open, each chord's line, and per return how far along its own ray space is known.

    >>> KnownFree.from_points(np.zeros((0, 2)), 1.1).contains(1.0, 0.0)
    True
    >>> KnownFree.from_points(np.zeros((0, 2)), 1.1, nothing_beyond=False).contains(1.0, 0.0)
    False
    """

    __slots__ = (
        "horizon", "nothing_beyond", "body", "m", "b", "r", "surface", "jump", "reach", "nx", "ny", "c", "lim", "near",
        "_home2", "_near2", "_sb2", "_sl", "_sc", "_ss", "_table",
    )

    def __init__(
        self, points: np.ndarray, horizon: float, *, nothing_beyond: bool = True,
        body: tuple[float, float, float] = (0.18, 0.09, 0.09), beam_gap: float = BEAM_GAP, surface: float = SURFACE,
    ) -> None:
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
        self.horizon = float(horizon)
        self.nothing_beyond = bool(nothing_beyond)
        self.body = body
        self._home2 = max(body[0], body[1]) ** 2 + body[2] ** 2  # the body at the origin lies within
        kernels = _free() if self.nothing_beyond else None
        self._table: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None
        if kernels is None or not (type(body[0]) is float and type(body[1]) is float and type(body[2]) is float):
            self._build(pts, beam_gap, surface)
            return
        # the compiled loops of _build (the same figures, to the bit); the compiled tests
        # read the table itself, and its rows become the attributes at their first use
        # (:meth:`__getattr__`: most plans never read them)
        x, y = pts[:, 0], pts[:, 1]
        self._table = kernels.table(x, y, np.arctan2(y, x), self.horizon, beam_gap, surface, _TOL)

    def __getattr__(self, name: str) -> Any:
        """A table attribute not yet set (the compiled table's rows: set here at first use)."""
        table = object.__getattribute__(self, "_table") if name in _ROWS else None
        if table is None:
            raise AttributeError(f"{type(self).__name__!r} object has no attribute {name!r}")
        f, flags, shadow = table
        self.b, self.r, self.reach, self.nx, self.ny, self.c, self.lim, self.near = f[:8]
        self._near2 = f[8:].reshape(-1)
        self.surface, self.jump = flags
        self.m = f.shape[1]
        self._sb2, self._sl, self._sc, self._ss = shadow
        return getattr(self, name)

    def _build(self, pts: np.ndarray, beam_gap: float, surface: float) -> None:
        """The table as numpy statements (the rules; :mod:`clomp.planner._free_kernels` computes
        the same figures in compiled loops for a scan cropped at the horizon)."""
        h = self.horizon
        x, y = pts[:, 0], pts[:, 1]
        r = np.hypot(x, y)
        keep = (r > 1e-6) & (r <= h)
        if not keep.all():
            x, y, r = x[keep], y[keep], r[keep]
        b = np.arctan2(y, x)
        m = self.m = len(b)
        if m > 1:
            # perception keeps its points by bearing, turned to start at a break: turned back
            # when so (one cut), else sorted
            down = (b[1:] < b[:-1]).nonzero()[0]
            if len(down) == 1 and b[-1] <= b[0]:
                k = int(down[0]) + 1
                b, x, y, r = (np.concatenate((a[k:], a[:k])) for a in (b, x, y, r))
            elif len(down):
                order = b.argsort(kind="stable")
                b, x, y, r = b.take(order), x.take(order), y.take(order), r.take(order)
        self.b, self.r = b, r
        # gap k: from return k to return k + 1 (the last to the first, round the circle)
        gap, dx, dy = _next(b) - b, _next(x) - x, _next(y) - y
        if m:
            gap[-1] += 2 * math.pi
        chord = np.hypot(dx, dy)
        # a surface: the chord bounds what is known; a jump in depth between adjacent beams
        # (one grazes a near object's edge, the next goes on): the wedge is known to the
        # farther return, as far as the beam beside it went; else open
        narrow = gap < math.pi / 2
        face = self.surface = narrow & (chord <= surface)
        jump = self.jump = narrow & ~face & (gap <= beam_gap)
        self.reach = np.maximum(r, _next(r)) + _TOL
        # each chord's line n·p = c with n a unit normal pointing away from the sensor
        # (a chord of no length: the radial line through its return)
        short = chord <= 1e-12
        if short.any():
            chord = np.where(short, 1.0, chord)
            dx, dy = np.where(short, -y / r, dx), np.where(short, x / r, dy)
        nx, ny = dy / chord, -dx / chord
        c = nx * x + ny * y
        flip = c < 0
        if flip.any():
            nx, ny, c = np.where(flip, -nx, nx), np.where(flip, -ny, ny), np.abs(c)
        self.nx, self.ny, self.c = nx, ny, c
        # how far along each return's own ray space is known: to the return where a
        # surface lies on either side, else to the horizon (or, for a bare point list,
        # only within the body at the origin)
        open_lim: float | np.ndarray = h if self.nothing_beyond else self._body_range(x / r, y / r)
        side = np.where(face, r + _TOL, np.where(jump, self.reach, open_lim))
        lim = np.minimum(side, _prev(side))
        if not self.nothing_beyond:
            lim = np.maximum(lim, open_lim)
        self.lim = lim
        # per return, a range within which everything in the sectors beside it is known free
        with np.errstate(invalid="ignore", divide="ignore"):
            tau = -(x * dx + y * dy) / (chord * chord)
        open_near = h if self.nothing_beyond else min(self.body)
        sector = np.where(face, np.where((tau > 0) & (tau < 1), c, np.minimum(r, _next(r))), np.where(jump, self.reach, open_near))
        near = self.near = np.minimum(np.minimum(lim, open_near), np.minimum(sector, _prev(sector)))
        self._near2 = np.concatenate((near, near))
        # the returns whose own ray is known short of the horizon, doubled round the circle
        shadow = (lim < h).nonzero()[0]
        sb, sr = b.take(shadow), r.take(shadow)
        self._sb2 = np.concatenate((sb, sb + 2 * math.pi))
        self._sl = np.concatenate((lim.take(shadow),) * 2)
        self._sc = np.concatenate((x.take(shadow) / sr,) * 2)
        self._ss = np.concatenate((y.take(shadow) / sr,) * 2)

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

    def _body_range(self, cb: np.ndarray, sb: np.ndarray) -> np.ndarray:
        """How far the body at the origin reaches along each bearing (its cosine, sine)."""
        rear, front, half = self.body
        with np.errstate(divide="ignore"):
            along = np.where(cb > 0, front / cb, np.where(cb < 0, -rear / cb, np.inf))
            across = np.where(sb != 0, half / np.abs(sb), np.inf)
        out: np.ndarray = np.minimum(along, across)
        return out

    # -- queries -----------------------------------------------------------------------
    def contains(self, x: float, y: float) -> bool:
        """True when the point (x, y) (sensor frame) is known free."""
        table = self._table
        if table is not None:
            # the compiled test (the same answer; -1 where its range lies within 1e-14 of
            # the bound, where C's hypot and CPython's might part: asked below)
            got = _free().contains(table[0], table[1], self.horizon, self._home2, self.body, float(x), float(y))
            if got >= 0:
                return bool(got == 1)
        return self._contains(x, y)

    def _contains(self, x: float, y: float) -> bool:
        """:meth:`contains` as Python statements."""
        if x * x + y * y <= self._home2 and inside(np.array(x), np.array(abs(y)), self.body):
            return True
        if x * x + y * y > self.horizon * self.horizon:
            return False
        if not self.m:
            return self.nothing_beyond
        k = int(np.searchsorted(self.b, math.atan2(y, x), side="right")) - 1
        if self.surface[k]:
            return float(self.nx[k]) * x + float(self.ny[k]) * y <= float(self.c[k]) + _TOL
        if self.jump[k]:
            return math.hypot(x, y) <= float(self.reach[k])
        return self.nothing_beyond

    def _in_body(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        return inside(x, np.abs(y), self.body)

    def _free(self, x: np.ndarray, y: np.ndarray) -> np.ndarray:
        """:meth:`contains` for arrays of points."""
        inside = x * x + y * y <= self.horizon * self.horizon
        if not self.m:
            ok = inside & self.nothing_beyond
        else:
            k = np.searchsorted(self.b, np.arctan2(y, x), side="right") - 1
            chord_ok = self.nx[k] * x + self.ny[k] * y <= self.c[k] + _TOL
            near = x * x + y * y <= self.reach[k] ** 2
            ok = inside & np.where(self.surface[k], chord_ok, np.where(self.jump[k], near, self.nothing_beyond))
        out: np.ndarray = ok | self._in_body(x, y)
        return out

    def _span(self, lo: float, hi: float) -> tuple[int, int]:
        """The shadow returns with bearings in [lo, hi] (lo in [-π, π]): a slice of the doubled arrays."""
        i0, i1 = np.searchsorted(self._sb2, (lo, hi), side="left")
        return int(i0), int(i1)

    def _quick(self, lo: float, hi: float, far: float) -> bool:
        """True when nothing within ``far`` of the sensor over bearings [lo, hi] is unknown."""
        m = self.m
        if not m:
            return far <= self.horizon and self.nothing_beyond
        if hi - lo >= 2 * math.pi - 1e-9:
            return far <= float(self._near2[:m].min())
        if lo < -math.pi:
            lo, hi = lo + 2 * math.pi, hi + 2 * math.pi
        # the sector holding lo begins at the return before it
        i0, i1 = (int(i) for i in np.searchsorted(self.b, (lo, hi if hi <= math.pi else hi - 2 * math.pi), side="left"))
        i0 -= 1
        if hi > math.pi:
            i1 += m
        if i0 < 0:
            i0 += m
            i1 += m
        return far <= float(self._near2[i0 : i1 + 1].min())

    def _rays(self, lo: float, hi: float, far: float) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
        """The shadow returns with bearings in [lo, hi] whose known range along their own
        ray is under ``far`` (the only ones a shape within ``far`` can pass): their rays'
        directions and known ranges; None when there is none."""
        n = len(self._sl) // 2
        if hi - lo >= 2 * math.pi - 1e-9:
            i0, i1 = 0, n
        else:
            if lo < -math.pi:
                lo, hi = lo + 2 * math.pi, hi + 2 * math.pi
            i0, i1 = self._span(lo, hi)
        if i1 <= i0:
            return None
        lim = self._sl[i0:i1]
        sel = (lim < far).nonzero()[0]
        if not len(sel):
            return None
        return self._sc[i0:i1].take(sel), self._ss[i0:i1].take(sel), lim.take(sel)

    def straight_clear(self, start: Pose, distance: float, robot: RobotModel, start_known: bool = False) -> bool:
        """True when the real body, driven ``distance`` metres straight from ``start``,
        stays in known-free space. ``start_known``: the body at ``start`` is known to be
        (the task before it ended there, checked): only the strip ahead of its front,
        which the body sweeps, is tested."""
        if start_known and distance <= 0.0:
            return True
        # the swept rectangle from u = -rear (or the front edge) to the front edge moved on
        rear = -robot.front_offset if start_known else robot.rear_offset
        front = robot.front_offset + max(distance, 0.0)
        half = robot.width / 2
        table = self._table
        if table is not None:
            # the compiled test (the same answer; -1 where a range compared lies within
            # 1e-14 of its bound, where C's hypot and CPython's might part: asked below)
            got = _free().straight_clear(
                *table, self.horizon, self._home2, self.body, start.x, start.y, start.theta, rear, front, half
            )
            if got >= 0:
                return bool(got == 1)
        return self._straight_clear(start, rear, front, half)

    def _straight_clear(self, start: Pose, rear: float, front: float, half: float) -> bool:
        """:meth:`straight_clear` of the rectangle ``(rear, front, half)`` as Python and numpy statements."""
        c, s = math.cos(start.theta), math.sin(start.theta)
        us = (-rear, front, front, -rear)
        vs = (-half, -half, half, half)
        xs = [start.x + u * c - v * s for u, v in zip(us, vs)]
        ys = [start.y + u * s + v * c for u, v in zip(us, vs)]
        far = max(math.hypot(a, b) for a, b in zip(xs, ys))
        # the sensor inside the swept rectangle: every bearing is spanned
        ox, oy = -start.x * c - start.y * s, start.x * s - start.y * c
        if ox * ox + oy * oy <= rear * rear + front * front + half * half and inside(
            np.array(ox), np.array(abs(oy)), (rear, front, half)
        ):
            lo, hi = -math.pi, math.pi
        else:
            b0 = math.atan2(ys[0], xs[0])
            rel = [wrap_angle(math.atan2(b, a) - b0) for a, b in zip(xs, ys)]
            lo, hi = b0 + min(rel), b0 + max(rel)
        if self._quick(lo, hi, far):
            return True
        if not all(self.contains(a, b) for a, b in zip(xs, ys)):
            return False
        rays = self._rays(lo, hi, far)
        if rays is None:
            return True
        ux, uy, lim = rays
        # where each ray leaves the rectangle (its frame: the ray from (ox, oy) along (du, dv))
        du, dv = ux * c + uy * s, uy * c - ux * s
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            t1, t2 = (-rear - ox) / du, (front - ox) / du
            t3, t4 = (-half - oy) / dv, (half - oy) / dv
        out = np.minimum(np.fmax(t1, t2), np.fmax(t3, t4))
        into = np.maximum(np.fmin(t1, t2), np.fmin(t3, t4))
        return not bool(((into <= out) & (out > lim)).any())

    def turn_clear(self, start: Pose, angle: float, robot: RobotModel) -> bool:
        """True when the real body, turned in place by ``angle`` (signed, rad) at
        ``start``, stays in known-free space: the body at both ends and its corners' arcs
        (as circumscribed polylines) are its outline."""
        rad = robot.body_radius
        x, y = start.x, start.y
        d = math.hypot(x, y)
        table = self._table
        if table is not None and _free().TRIG_AS_NUMPY:
            # the compiled test (the same answer; -1 where an outline point's bearing lies
            # within 1e-12 rad of a return's, where numpy's arctan2 and C's might part)
            rc, phi = _corners_polar(robot)
            got = _free().turn_clear(*table, self.horizon, self.body, x, y, start.theta, angle, d, rad, rc, phi, _ARC_STEP)
            if got >= 0:
                return bool(got == 1)
        return self._turn_clear(start, angle, robot, d)

    def _turn_clear(self, start: Pose, angle: float, robot: RobotModel, d: float) -> bool:
        """:meth:`turn_clear` as Python and numpy statements (``d``: the start's distance from the sensor)."""
        rad = robot.body_radius
        x, y = start.x, start.y
        if d > rad:
            half = math.asin(rad / d)
            bc = math.atan2(y, x)
            lo, hi = bc - half, bc + half
        else:
            lo, hi = -math.pi, math.pi
        if self._quick(lo, hi, d + rad):
            return True
        n = max(1, int(math.ceil(abs(angle) / _ARC_STEP)))
        step = angle / n
        offs = np.empty(n + 2)
        offs[0], offs[-1] = 0.0, angle
        offs[1:-1] = step * (np.arange(n) + 0.5)
        grow = np.full(n + 2, 1.0 / math.cos(step / 2))
        grow[0] = grow[-1] = 1.0
        rc, phi = _corners_polar(robot)
        ang = (start.theta + phi)[:, None] + offs
        rr = rc[:, None] * grow
        arcs = polar_to_xy(rr, ang)  # per corner: its arc's polyline, round (x, y)
        px, py = x + arcs[..., 0], y + arcs[..., 1]
        if not self._free(px.ravel(), py.ravel()).all():
            return False
        rays = self._rays(lo, hi, d + rad)
        if rays is None:
            return True
        # the segments: each arc's, and the body's outline at the start and at the end
        ends = np.roll(np.arange(4), -1)
        ax = np.concatenate((px[:, :-1].ravel(), px[:, 0], px[:, -1]))
        ay = np.concatenate((py[:, :-1].ravel(), py[:, 0], py[:, -1]))
        bx = np.concatenate((px[:, 1:].ravel(), px[ends, 0], px[ends, -1]))
        by = np.concatenate((py[:, 1:].ravel(), py[ends, 0], py[ends, -1]))
        ux, uy, lim = (v[:, None] for v in rays)
        ex, ey = bx - ax, by - ay
        den = ux * ey - uy * ex
        with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
            rho = (ax * ey - ay * ex) / den  # where the segment's line meets the ray
            t = (ax * uy - ay * ux) / den  # and where along the segment
        return not bool(((t >= 0) & (t <= 1) & (rho > lim)).any())

    def clear(self, out: Outcome, robot: RobotModel, start_known: bool = False) -> bool:
        """True when the body stays in known-free space over the task ``out`` rolled out
        (``start_known``: its body at the start is known, see :meth:`straight_clear`)."""
        if out.task is TaskKind.STRAIGHT:
            return self.straight_clear(out.start, out.distance, robot, start_known)
        turned = wrap_angle(out.end.theta - out.start.theta)
        if out.task is TaskKind.LEFT and turned < 0:
            turned += 2 * math.pi
        elif out.task is TaskKind.RIGHT and turned > 0:
            turned -= 2 * math.pi
        return turned == 0.0 or self.turn_clear(out.start, turned, robot)
