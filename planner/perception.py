"""Perception: a LiDAR scan becomes obstacle disturbances.

A scan is an N×2 array of points (metres, robot frame: x forward, y left). It is
validated, cropped to the planning horizon (``RobotModel.sensor_range``, 1.1 m: an A1
returns to 12 m, and cropping is normal, not a warning), de-duplicated and clustered (points closer than
``cluster_distance`` belong to one object). Each cluster is covered tightly by thin
oriented boxes: a cluster is split along its principal axis until every piece is thin,
so a slanted wall becomes a slanted slab and an L-shaped corner two slabs, never one fat
axis-aligned box that would close a corridor.
"""

from __future__ import annotations

import functools
import math
import warnings
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clomp.planner.footprint import inside
from clomp.planner.units import MOSTLY_BEYOND_M, millimetres_suspected
from clomp.planner.scanfile import MAX_SCAN_BYTES, MAX_SCAN_POINTS, SCAN_SUFFIXES, ScanError, load_scan, scan_files, validate_scan

__all__ = [
    "MAX_SCAN_BYTES",
    "MAX_SCAN_POINTS",
    "SCAN_SUFFIXES",
    "Obstacles",
    "ScanError",
    "ScanWarning",
    "load_scan",
    "perceive",
    "range_warning",
    "scan_files",
    "validate_scan",
]

# a piece is "thin" when its points spread at most this much across its axis
_THIN = 0.0075
# surfaces are first cut into pieces of this much path length, then thick pieces halved
_PIECE = 0.08
# how far a box stands off its outermost points: the allowance for sensor noise
_PAD = 0.002
# each box's four corners, counter-clockwise, as (along, across) pairs taken from its
# extents (u0, t0, u1, t1): (u0,t0) (u1,t0) (u1,t1) (u0,t1)
_CORNERS = np.array([0, 1, 2, 1, 2, 3, 0, 3])
_CORNERS.flags.writeable = False
# the sign of each extent's pad (rows u0 t0 u1 t1)
_SIGNS = np.array([[-1.0], [-1.0], [1.0], [1.0]])
_SIGNS_PAD = _SIGNS * _PAD
_SIGNS_PAD.flags.writeable = False
# from how many points repeats are dropped before the sort (below it the test costs what it saves)
_DEDUPE_FROM = 512
# a return beyond this squared range (20 m) asks whether the scan is in millimetres
_UNITS_R2 = MOSTLY_BEYOND_M * MOSTLY_BEYOND_M


class ScanWarning(UserWarning):
    """A scan was read but something about it is suspicious: it looks like millimetres
    (:func:`range_warning`). Returns beyond the planning horizon are not: they are cropped
    without a word.

    >>> import warnings
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     _ = perceive(np.array([[5.0, 0.0], [5.0, 0.02]]))       # beyond the horizon: cropped
    ...     _ = perceive(np.array([[5000.0, 0.0], [5000.0, 20.0]]))  # millimetres?
    >>> [issubclass(w.category, ScanWarning) for w in caught]
    [True]
    """


def range_warning(points: np.ndarray, sensor_range: float) -> str | None:
    """A warning when the scan looks like millimetres (:func:`clomp.planner.units.millimetres_suspected`:
    its returns mostly beyond 20 m, or its median range above 50 m), else None. Returns beyond
    the planning horizon ``sensor_range`` alone are no warning: perception crops them.

    >>> range_warning(np.array([[300.0, 0.0], [0.5, 0.0], [0.7, 0.0]]), 1.1) is None   # one far return: cropped
    True
    >>> range_warning(np.array([[300.0, 0.0], [500.0, 0.0]]), 1.1)
    'the scan looks like millimetres (2 of 2 returns lie beyond 20 m, median range 400 m); every return lies beyond the 1.1 m planning horizon and is ignored'
    """
    why = millimetres_suspected(points)
    if why is None:
        return None
    n = len(points)
    far = int(np.count_nonzero(np.hypot(points[:, 0], points[:, 1]) > sensor_range))
    lost = "every return lies" if far == n else f"{far} of {n} returns lie"
    return f"the scan looks like millimetres ({why}); {lost} beyond the {sensor_range:g} m planning horizon and {'is' if far == n else 'are'} ignored"


@dataclass(frozen=True, eq=False)
class Obstacles:
    """The obstacle disturbances of one scan, with arrays for fast geometry.

    ``boxes`` is M×4×2 (the corners of each oriented box, counter-clockwise),
    ``centres`` M×2 and ``radii`` M (circumradius of each box). ``points`` are the
    sensed points the boxes cover (N×2) and box ``i`` covers
    ``points[starts[i]:starts[i + 1]]``. ``exempt`` counts the returns perception
    dropped because they lay inside the robot's body at the planning origin.

    >>> obs = Obstacles.from_boxes([[(0.5, -0.1), (0.6, -0.1), (0.6, 0.1), (0.5, 0.1)]])
    >>> len(obs), obs.contains_point(0.55, 0.0), obs.contains_point(0.0, 0.0)
    (1, 0, None)
    """

    boxes: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    points: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    starts: np.ndarray = field(default_factory=lambda: np.zeros(1, dtype=np.intp))
    exempt: int = 0

    def __post_init__(self) -> None:
        # a hand-built value with arrays that disagree would fail deep in the planner with a
        # bare numpy broadcast error; say what is wrong here instead (a few len() calls)
        m = len(self.boxes)
        if len(self.centres) != m or len(self.radii) != m or len(self.starts) != m + 1 or (
            int(self.starts[-1]) != len(self.points) if len(self.starts) else True
        ):
            raise ValueError(
                f"Obstacles: {m} boxes need {m} centres, {m} radii and {m + 1} starts ending at the "
                f"{len(self.points)} points, got {len(self.centres)}, {len(self.radii)} and {len(self.starts)} "
                "(build them with Obstacles.from_boxes or perceive)"
            )

    @functools.cached_property
    def owner(self) -> np.ndarray:
        """For every point, the index of the box that covers it."""
        return np.repeat(np.arange(len(self.boxes)), self.starts[1:] - self.starts[:-1])

    def __len__(self) -> int:
        return len(self.boxes)

    @functools.cached_property
    def _outlines(self) -> dict[int, tuple[tuple[float, float], ...]]:
        return {}

    def outline(self, i: int) -> tuple[tuple[float, float], ...]:
        """Box ``i``'s corners as (x, y) floats, counter-clockwise (remembered: the rollouts
        of one plan name a few boxes many times, as the D_N of the tasks they interrupt).

        >>> Obstacles.from_boxes([[(0.5, -0.1), (0.6, -0.1), (0.6, 0.1), (0.5, 0.1)]]).outline(0)
        ((0.5, -0.1), (0.6, -0.1), (0.6, 0.1), (0.5, 0.1))
        """
        known = self._outlines.get(i)
        if known is None:
            known = self._outlines[i] = tuple(map(tuple, self.boxes[i].tolist()))
        return known

    def box_points(self, i: int) -> np.ndarray:
        """The sensed points box ``i`` covers (its outline sampled every 5 mm for a box not made from a scan)."""
        return self.points[self.starts[i] : self.starts[i + 1]]

    @classmethod
    def from_boxes(cls, boxes: list[np.ndarray] | np.ndarray | list[Any]) -> "Obstacles":
        """Build from a list of 4×2 convex quadrilaterals (counter-clockwise)."""
        arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4, 2)
        centres = arr.mean(axis=1)
        radii = np.linalg.norm(arr - centres[:, None, :], axis=2).max(axis=1) if len(arr) else np.zeros(0)
        pieces = [_outline(b) for b in arr]
        starts = np.cumsum([0] + [len(p) for p in pieces]).astype(np.intp)
        pts = np.concatenate(pieces) if pieces else np.zeros((0, 2))
        return cls(arr, centres, radii, pts, starts)

    def contains_point(self, x: float, y: float, margin: float = 0.0) -> int | None:
        """The index of a box containing (x, y) (grown by ``margin``), or None."""
        if not len(self.boxes):
            return None
        # the boxes whose circumcircle (grown by margin) holds the point: a compiled loop over
        # the centres (the arithmetic of hypot(cx - x, cy - y) <= radii + margin + 1e-12)
        for i in _near_boxes()(self.centres, self.radii, float(x), float(y), float(margin)):
            if _point_in_convex(self.boxes[i].tolist(), x, y, margin):  # as floats: the same arithmetic
                return int(i)
        return None


_NONE = Obstacles(np.zeros((0, 4, 2)), np.zeros((0, 2)), np.zeros(0))


def _built(boxes: np.ndarray, centres: np.ndarray, radii: np.ndarray, points: np.ndarray, starts: np.ndarray, exempt: int) -> Obstacles:
    """An :class:`Obstacles` from arrays that agree by construction (perception's own): the
    checks of ``__post_init__`` and the frozen dataclass's ``__init__`` are a few µs of a
    perception that takes a few dozen."""
    obs: Obstacles = object.__new__(Obstacles)
    obs.__dict__.update(boxes=boxes, centres=centres, radii=radii, points=points, starts=starts, exempt=exempt)
    return obs


def _outline(box: np.ndarray, step: float = 0.005) -> np.ndarray:
    out = []
    for k in range(4):
        a, b = box[k], box[(k + 1) % 4]
        n = max(1, int(math.ceil(float(np.hypot(*(b - a))) / step)))
        t = np.arange(n)[:, None] / n
        out.append(a + t * (b - a))
    return np.concatenate(out)


def _point_in_convex(box: list[list[float]], x: float, y: float, margin: float) -> bool:
    n = len(box)
    for k in range(n):
        ax, ay = box[k]
        bx, by = box[(k + 1) % n]
        ex, ey = bx - ax, by - ay
        norm = math.hypot(ex, ey) or 1.0
        # signed distance to the left of the edge (inside for a CCW polygon)
        if (ex * (y - ay) - ey * (x - ax)) / norm < -margin:
            return False
    return True


def perceive(
    points: np.ndarray,
    sensor_range: float = 1.1,
    cluster_distance: float = 0.1,
    *,
    pad: float = _PAD,
    body: tuple[float, float, float] | None = None,
) -> Obstacles:
    """Turn a scan into obstacle disturbances (see the module docstring).

    Points beyond ``sensor_range`` (the planning horizon) are dropped without a word (the
    paper's robot ignored them; a :class:`ScanWarning` only when the scan looks like
    millimetres, see :func:`range_warning`), as are returns at the sensor
    itself (closer than 1 mm). ``pad`` is how far a box stands off its outermost points
    (the allowance for sensor noise). ``body`` = ``(rear, front, half_width)`` is the
    robot's body at the planning origin: returns inside it are its own (or already under
    it) and are dropped, counted in ``Obstacles.exempt``; nothing outside the body is
    exempt.

    >>> wall = np.c_[np.full(41, 0.5), np.linspace(-0.2, 0.2, 41)]
    >>> obs = perceive(wall)
    >>> bool(obs.contains_point(0.5, 0.0) is not None), bool(obs.contains_point(0.52, 0.0) is None)
    (True, True)
    >>> round(float((obs.boxes[:, :, 0].max(axis=1) - obs.boxes[:, :, 0].min(axis=1)).max()), 3)  # 4 mm thin
    0.004
    """
    kernels = _compiled() if pad > 0 else None
    if kernels is not None:
        # the compiled loops of _kept, _along_surfaces, _cut and _boxes (the same arithmetic, to the bit)
        got = _kept_compiled(kernels, points, sensor_range, body)
        if isinstance(got, Obstacles):
            return got
        z, exempt = got
        pts, bounds, boxes, centres, radii = kernels.boxes_of(z[0], z[1], cluster_distance, pad, _PIECE, _THIN)
        return _built(boxes, centres, radii, pts, bounds, exempt)
    kept = _kept(points, sensor_range, body)
    if isinstance(kept, Obstacles):
        return kept
    pts, keep, exempt = kept
    z, step = _along_surfaces(pts, keep)
    z, cut = _cut(z, step, cluster_distance)
    return _boxes(z, cut, pad, exempt)


@functools.cache
def _near_boxes() -> Any:
    """:func:`clomp.planner._kernels.near_boxes`, imported at first use (as :func:`_compiled`)."""
    from clomp.planner._kernels import near_boxes

    return near_boxes


@functools.cache
def _compiled() -> Any:
    """:mod:`clomp.planner._kernels` (``kept_points`` and ``boxes_of``), imported at the first
    scan that needs it: numba's import (about half a second) is paid by a process that
    perceives, not by every import of the planner. Its first call in a process loads the
    cached machine code (about a second on a busy 2-core machine: numba's start-up, once
    per process). None where numpy rounds otherwise than the compiled loops
    (``_kernels.ROUNDS_AS_NUMPY``): the numpy statements then run."""
    from clomp.planner import _kernels

    return _kernels if _kernels.ROUNDS_AS_NUMPY else None


def _as_scan(points: np.ndarray) -> tuple[np.ndarray, bool]:
    """The scan as a float N×2 array, and whether it was validated: the common case, a float
    array (from a driver or a file), is not yet; its finiteness is checked only when some
    point is not kept (a NaN or inf never is)."""
    if type(points) is np.ndarray and points.ndim == 2 and points.shape[1] == 2 and points.dtype == np.float64:
        if len(points) > MAX_SCAN_POINTS:
            return validate_scan(points), True
        return points, False
    return validate_scan(points), True


def _kept_compiled(
    kernels: Any, points: np.ndarray, sensor_range: float, body: tuple[float, float, float] | None
) -> tuple[np.ndarray, int] | Obstacles:
    """:func:`_kept` and the selection of the kept points in one compiled pass
    (``_kernels.kept_points``): the kept points (2×K, repeats dropped from a long scan) and
    how many the body exempted; when none is kept, the (empty) obstacles instead. The same
    checks and warnings as :func:`_kept`."""
    pts, checked = _as_scan(points)
    if not len(pts):
        return _NONE
    rear, front, half = body if body is not None else (0.0, 0.0, 0.0)
    z, kept, exempt, far2 = kernels.kept_points(
        np.ascontiguousarray(pts), sensor_range * sensor_range, rear * rear + half * half,
        (float(rear), float(front), float(half)), body is not None, len(pts) > _DEDUPE_FROM,
    )
    if kept < len(pts):
        if not checked and not far2 < math.inf:  # (a finite far2: every coordinate is finite)
            validate_scan(pts)  # a ScanError naming the first point that is not finite
        if far2 > _UNITS_R2:  # returns beyond 20 m: perhaps not metres (the horizon's crop is silent)
            warning = range_warning(pts, sensor_range)
            if warning:
                warnings.warn(ScanWarning(warning), stacklevel=3)  # at perceive's caller
        if not kept:
            return _NONE if not exempt else Obstacles(_NONE.boxes, _NONE.centres, _NONE.radii, exempt=exempt)
    return z, exempt


def _kept(
    points: np.ndarray, sensor_range: float, body: tuple[float, float, float] | None
) -> tuple[np.ndarray, np.ndarray, int] | Obstacles:
    """The scan as a float array, which of its points perception keeps (within range, not
    at the sensor, not the body's own) and how many the body exempted; when none is
    kept, the (empty) obstacles instead. Warns (:class:`ScanWarning`) of a scan in millimetres."""
    pts, checked = _as_scan(points)
    exempt = 0
    if not len(pts):
        return _NONE
    x, y = pts[:, 0], pts[:, 1]
    sq = pts * pts  # one product over the array, then x² + y² (the same sum)
    r2 = sq[:, 0] + sq[:, 1]
    keep = (r2 <= sensor_range * sensor_range) & (r2 > 1e-6)
    if body is not None:
        rear, _, half = body
        near = (keep & (r2 < rear * rear + half * half)).nonzero()[0]
        if len(near):
            own = near[inside(x[near], np.abs(y[near]), body, strict=True)]
            exempt = len(own)
            keep[own] = False
    kept = int(np.count_nonzero(keep))
    if kept < len(pts):
        if not checked:
            validate_scan(pts)  # a ScanError naming the first point that is not finite
        if r2.max() > _UNITS_R2:  # returns beyond 20 m: perhaps not metres (the horizon's crop is silent)
            warning = range_warning(pts, sensor_range)
            if warning:
                warnings.warn(ScanWarning(warning), stacklevel=3)  # at perceive's caller
        if not kept:
            return _NONE if not exempt else Obstacles(_NONE.boxes, _NONE.centres, _NONE.radii, exempt=exempt)
    return pts, keep, exempt


def _along_surfaces(pts: np.ndarray, keep: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The kept points as complex numbers x + iy (a piece's frame is then one product per
    point) in the order the sensor swept them (by bearing), repeats dropped; and each
    one's step from the point before it (the first's from the last)."""
    zall = np.ascontiguousarray(pts).view(np.complex128).ravel()
    if len(pts) > _DEDUPE_FROM:
        # a recorded scan repeats most returns (3 of 4 on the shared scans): a point
        # bit-equal to the one before it in the scan is dropped before the sort. Sorted
        # stably by bearing it would follow that same point at once (an equal bearing
        # keeps the scan's order), and be dropped below as a zero step, leaving every
        # other step as it was: the same surfaces, with less to sort
        bits = zall.view(np.int64).reshape(-1, 2)
        # a point differs from the one before when either coordinate's bits do: the two
        # flags of a row, read as one 16-bit number, are nonzero
        keep[1:] &= (bits[1:] != bits[:-1]).view(np.uint16).ravel().astype(bool)
    idx = keep.nonzero()[0]
    # order along the surfaces the sensor saw: by bearing from the sensor
    z = zall.take(idx)
    z = z.take(np.arctan2(z.imag.copy(), z.real.copy()).argsort(kind="stable"))
    n = len(z)
    d = np.empty(n, dtype=np.complex128)
    np.subtract(z[1:], z[:-1], out=d[1:])
    d[0] = z[0] - z[-1]
    step = np.hypot(d.real, d.imag)
    if n > 1:
        uniq = step > 1e-4  # recorded scans repeat points: a repeat is a zero step
        distinct = np.count_nonzero(uniq)
        if distinct < n:
            if not distinct:
                uniq[0] = True
            sel = uniq.nonzero()[0]
            z, step = z.take(sel), step.take(sel)
    return z, step


def _cut(z: np.ndarray, step: np.ndarray, cluster_distance: float) -> tuple[np.ndarray, np.ndarray]:
    """The surfaces (a step longer than ``cluster_distance`` breaks one) cut every
    ``_PIECE`` metres of path: the points, turned to start at a break, and where each
    piece starts (n + 1 flags, the last one the end)."""
    n = len(z)
    brk = step > cluster_distance
    first = int(brk.argmax())
    if brk[first]:
        # start at a break, so that a surface crossing the bearing ±π is not cut
        if first:
            turn = np.arange(first, first + n)
            z, brk, step = z.take(turn, mode="wrap"), brk.take(turn, mode="wrap"), step.take(turn, mode="wrap")
    else:
        brk[0] = True
    step[brk] = 0.0  # a surface's path starts at its first point
    path = np.add.accumulate(step)
    path *= 1.0 / _PIECE
    cell = path.astype(np.int64)
    cut = np.empty(n + 1, dtype=bool)  # where a piece starts, and the end (n)
    cut[:n] = brk
    cut[1:n] |= cell[1:] != cell[:-1]
    cut[n] = True
    return z, cut


def _boxes(z: np.ndarray, cut: np.ndarray, pad: float, exempt: int) -> Obstacles:
    """The pieces (starting where ``cut`` says) halved while thick, each covered by a box
    along its chord standing ``pad`` off its outermost points."""
    n = len(z)
    # each point's predecessor (zl[i + 1] = z[i]): a piece's last point is one take
    zl = np.empty(n + 1, dtype=np.complex128)
    zl[1:] = z
    while True:
        # per piece (points starts[i]:ends[i]): its first point a and the unit chord e
        # to its last point; per point w = (z - a) / e, whose real part is the offset
        # along the chord and imaginary part the offset across it (so each extent is one
        # reduceat). On a few hundred points the cost is the number of numpy calls
        bounds = cut.nonzero()[0]
        starts, ends = bounds[:-1], bounds[1:]
        counts = ends - starts
        a = z.take(starts)
        e = zl.take(ends) - a
        norm = np.abs(e)
        if norm[norm.argmin()] < 1e-9:
            single = norm < 1e-9
            norm[single] = 1.0
            e[single] = 1.0
        e /= norm
        w = (z - a.repeat(counts)) * e.conj().repeat(counts)
        t = w.imag
        t0, t1 = np.minimum.reduceat(t, starts), np.maximum.reduceat(t, starts)
        # only the spread across a piece decides whether it is halved (a piece of one or
        # two points has none: its points lie on its chord, to a few 1e-17 m)
        fat = t1 - t0 > _THIN
        if not np.count_nonzero(fat):
            break
        cut[((starts + ends) >> 1)[fat]] = True  # halved: starts + counts // 2
    # the extents, padded (rows u0 t0 u1 t1), then each box's corners (along, across),
    # counter-clockwise: (u0,t0) (u1,t0) (u1,t1) (u0,t1); as complex, a + (u + i·t)·e
    m = len(starts)
    ext = np.empty((4, m))
    u = w.real
    np.minimum.reduceat(u, starts, out=ext[0])
    ext[1] = t0
    np.maximum.reduceat(u, starts, out=ext[2])
    ext[3] = t1
    ext += _SIGNS_PAD if pad == _PAD else _SIGNS * pad
    local = np.ascontiguousarray(ext.take(_CORNERS, axis=0).T).view(np.complex128)
    if not pad > 0:
        # an extent may then be -0.0: written as u + 1j·t, as before, to keep its sign the same
        local = local.real + 1j * local.imag
    corners = local.ravel() * e.repeat(4) + a.repeat(4)
    boxes = corners.view(np.float64).reshape(m, 4, 2)
    centres = ((corners[0::4] + corners[2::4]) * 0.5).view(np.float64).reshape(m, 2)
    radii = np.abs(local[:, 2] - local[:, 0]) * 0.5
    return _built(boxes, centres, radii, z.view(np.float64).reshape(n, 2), bounds, exempt)
