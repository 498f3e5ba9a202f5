"""The compiled loops of :mod:`clomp.planner.visibility` (numba): the known-free table and its tests.

:class:`clomp.planner.visibility.KnownFree` states its rules with numpy and Python: the
returns within the horizon by bearing, per gap between adjacent returns whether a
surface, a jump in depth or open, each chord's line, how far each return's own ray is
known and a range within which the sectors beside it are wholly known; then whether a
point, a straight's swept rectangle or a turn's swept outline lies in known-free space.
On a scan of a few hundred points the table was some sixty small array calls (40–60 µs,
most of a plan where nothing is ahead) and a turn's test some forty (90 µs, a third of a
50-state plan). :func:`table` computes the same figures in a few loops with the same
floating-point operations in the same order: the ranges are ``hypot`` (numpy's is the C
library's, as numba's), the bearings numpy's own ``arctan2`` (its SIMD loop), computed
before the compiled call.

:func:`contains`, :func:`straight_clear` and :func:`turn_clear` answer as the methods do,
in their scalar arithmetic (``math`` is the C library, as numba's; numpy's cos and sin
are too where :data:`TRIG_AS_NUMPY`). Where the methods use a function the C library
computes otherwise — CPython's own ``math.hypot``, numpy's ``arctan2`` — and the figure
lies within 1e-14 (relative) or 1e-12 rad of what it is compared with, the loops answer
-1 and the method's statements decide. ``tests/planner/test_free_kernels.py`` holds the
table to the numpy statements bit for bit and the tests to the methods answer for answer.

>>> x, y = np.array([0.5, 0.5, 0.5, 3.0]), np.array([-0.01, 0.0, 0.01, 0.0])
>>> f, flags, shadow = table(x, y, np.arctan2(y, x), 1.1, BEAM_GAP, SURFACE, _TOL)
>>> flags[0].tolist(), [round(v, 3) for v in f[ROW_LIM].tolist()]   # two chords of one surface, then the open rest
([True, True, False], [0.501, 0.501, 0.501])
"""

from __future__ import annotations

import math

import numpy as np

from clomp.planner._kernels import _compiled

__all__ = ["BEAM_GAP", "SURFACE", "ROWS", "TRIG_AS_NUMPY", "contains", "table", "straight_clear", "turn_clear"]

#: as :data:`clomp.planner.visibility.BEAM_GAP` and ``SURFACE`` (repeated: visibility imports this module)
BEAM_GAP = math.radians(2.0)
SURFACE = 0.1
_TOL = 0.001
#: the rows of :func:`table`'s float array, by name (``KnownFree``'s attributes are views of them)
ROWS = ("b", "r", "reach", "nx", "ny", "c", "lim", "near")
ROW_B, ROW_R, ROW_REACH, ROW_NX, ROW_NY, ROW_C, ROW_LIM, ROW_NEAR = range(8)
_TWO_PI = 2 * math.pi


@_compiled
def _order(b: np.ndarray) -> np.ndarray:  # pragma: no cover
    # the returns by bearing: perception's order turned back where it starts at a break
    # (one descent, the last bearing not above the first), else a stable sort
    m = b.shape[0]
    idx = np.arange(m)
    if m <= 1:
        return idx
    down, first = 0, -1
    for i in range(m - 1):
        if b[i + 1] < b[i]:
            down += 1
            if first < 0:
                first = i
    if down == 1 and b[m - 1] <= b[0]:
        k = first + 1
        for i in range(m):
            idx[i] = (i + k) % m
        return idx
    if down:
        return np.argsort(b, kind="mergesort")
    return idx


@_compiled
def _by_bearing(xa: np.ndarray, ya: np.ndarray, ba: np.ndarray, horizon: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    # the returns within the horizon by bearing: the table (10×m) with its rows b and r
    # filled, and their x and y
    n = xa.shape[0]
    ra = np.empty(n)
    m = 0
    for i in range(n):
        ra[i] = np.hypot(xa[i], ya[i])
        m += ra[i] > 1e-6 and ra[i] <= horizon
    kept = np.empty(m, dtype=np.int64)
    j = 0
    for i in range(n):
        if ra[i] > 1e-6 and ra[i] <= horizon:
            kept[j] = i
            j += 1
    b0 = np.empty(m)
    for i in range(m):
        b0[i] = ba[kept[i]]
    order = _order(b0)
    f = np.empty((10, m))
    x, y = np.empty(m), np.empty(m)
    for i in range(m):
        k = kept[order[i]]
        f[ROW_B, i], f[ROW_R, i], x[i], y[i] = ba[k], ra[k], xa[k], ya[k]
    return f, x, y


@_compiled
def table(
    xa: np.ndarray, ya: np.ndarray, ba: np.ndarray, horizon: float, beam_gap: float, surface: float, tol: float,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    """``KnownFree``'s figures (``nothing_beyond``) of the returns ``xa, ya`` at bearings
    ``ba`` (numpy's ``arctan2``), those within ``horizon`` (and not at the sensor) kept:
    the rows :data:`ROWS` and the near ranges again twice (10×m: rows 8 and 9 are the near
    ranges doubled round the circle), the flags (2×m: surface, jump) and the shadow
    returns doubled (4×2s: bearing, known range, cosine, sine)."""
    f, x, y = _by_bearing(xa, ya, ba, horizon)
    m = x.shape[0]
    flags = np.zeros((2, m), dtype=np.bool_)
    b, r = f[ROW_B], f[ROW_R]
    dxs, dys, chords = np.empty(m), np.empty(m), np.empty(m)
    flipped = False
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        gap = b[j] - b[i]
        if i == m - 1:
            gap += _TWO_PI
        dx, dy = x[j] - x[i], y[j] - y[i]
        chord = np.hypot(dx, dy)
        narrow = gap < math.pi / 2
        face = narrow and chord <= surface
        flags[0, i] = face
        flags[1, i] = narrow and not face and gap <= beam_gap
        f[ROW_REACH, i] = (r[i] if r[i] >= r[j] else r[j]) + tol
        if chord <= 1e-12:
            chord, dx, dy = 1.0, -y[i] / r[i], x[i] / r[i]
        nx, ny = dy / chord, -dx / chord
        c = nx * x[i] + ny * y[i]
        if c < 0:
            nx, ny, flipped = -nx, -ny, True
        f[ROW_NX, i], f[ROW_NY, i], f[ROW_C, i] = nx, ny, c
        dxs[i], dys[i], chords[i] = dx, dy, chord
    if flipped:  # as np.abs over every chord once one flips (a -0.0 becomes 0.0 too)
        for i in range(m):
            f[ROW_C, i] = abs(f[ROW_C, i])
    side, sector = np.empty(m), np.empty(m)
    for i in range(m):
        j = i + 1 if i + 1 < m else 0
        side[i] = r[i] + tol if flags[0, i] else (f[ROW_REACH, i] if flags[1, i] else horizon)
        if flags[0, i]:
            tau = -(x[i] * dxs[i] + y[i] * dys[i]) / (chords[i] * chords[i])
            sector[i] = f[ROW_C, i] if tau > 0 and tau < 1 else min(r[i], r[j])
        else:
            sector[i] = f[ROW_REACH, i] if flags[1, i] else horizon
    shadows = 0
    for i in range(m):
        p = i - 1 if i else m - 1
        lim = min(side[i], side[p])
        f[ROW_LIM, i] = lim
        near = min(min(lim, horizon), min(sector[i], sector[p]))
        f[ROW_NEAR, i] = f[8, i] = f[9, i] = near
        shadows += lim < horizon
    s = np.empty((4, 2 * shadows))
    k = 0
    for i in range(m):
        if f[ROW_LIM, i] < horizon:
            s[0, k], s[0, k + shadows] = b[i], b[i] + _TWO_PI
            s[1, k] = s[1, k + shadows] = f[ROW_LIM, i]
            s[2, k] = s[2, k + shadows] = x[i] / r[i]
            s[3, k] = s[3, k + shadows] = y[i] / r[i]
            k += 1
    return f, flags, s


@_compiled
def _min_near(f: np.ndarray, i0: int, i1: int) -> float:  # pragma: no cover
    # the least near range of returns i0 … i1 round the circle (KnownFree._near2[i0 : i1 + 1].min())
    m = f.shape[1]
    out = math.inf
    for i in range(i0, i1 + 1):
        out = min(out, f[ROW_NEAR, i % m])
    return out


@_compiled
def _inside(u: float, across: float, rear: float, front: float, half: float) -> bool:  # pragma: no cover
    # clomp.planner.footprint.inside for one point (on the outline counts)
    return u >= -rear and u <= front and across <= half


@_compiled
def _le(a: float, b: float) -> int:  # pragma: no cover
    # a <= b for an ``a`` that is a hypot: 1 or 0, or -1 when the two lie so close that the
    # C library's hypot (here) and CPython's math.hypot (the Python method's), each within
    # an ulp of the true value, might answer otherwise
    if abs(a - b) <= 1e-14 * max(abs(a), abs(b)):
        return -1
    return 1 if a <= b else 0


@_compiled
def contains(
    f: np.ndarray, flags: np.ndarray, horizon: float, home2: float, body: tuple[float, float, float], x: float, y: float
) -> int:  # pragma: no cover
    """``KnownFree.contains`` (``nothing_beyond``) of the point (``x``, ``y``): 1, 0 or -1
    (undecided: its range lies within 1e-14 of the bound it is compared with)."""
    if x * x + y * y <= home2 and _inside(x, abs(y), body[0], body[1], body[2]):
        return 1
    if x * x + y * y > horizon * horizon:
        return 0
    m = f.shape[1]
    if not m:
        return 1
    k = np.searchsorted(f[ROW_B], math.atan2(y, x), side="right") - 1
    if k < 0:
        k += m
    if flags[0, k]:
        return 1 if f[ROW_NX, k] * x + f[ROW_NY, k] * y <= f[ROW_C, k] + _TOL else 0
    if flags[1, k]:
        return int(_le(math.hypot(x, y), f[ROW_REACH, k]))
    return 1


@_compiled
def _wrap(a: float) -> float:  # pragma: no cover
    # clomp.formal.geometry.wrap_angle, inline (the same arithmetic: numba has no math.fmod,
    # so it cannot compile that function; np.fmod is the C library's fmod, exact)
    a = np.fmod(a + math.pi, _TWO_PI)
    if a <= 0:
        a += _TWO_PI
    return a - math.pi


@_compiled
def _quick(f: np.ndarray, horizon: float, lo: float, hi: float, far: float) -> int:  # pragma: no cover
    # KnownFree._quick (nothing_beyond): 1, 0 or -1 (undecided, see _le)
    return int(_le(far, _near_min(f, horizon, lo, hi)))


@_compiled
def _shadow_span(s: np.ndarray, lo: float, hi: float) -> tuple[int, int]:  # pragma: no cover
    # KnownFree._rays' window: the shadow returns (columns of the doubled s) with bearings in [lo, hi]
    if hi - lo >= 2 * math.pi - 1e-9:
        return 0, s.shape[1] // 2
    if lo < -math.pi:
        lo, hi = lo + 2 * math.pi, hi + 2 * math.pi
    return int(np.searchsorted(s[0], lo, side="left")), int(np.searchsorted(s[0], hi, side="left"))


@_compiled
def straight_clear(
    f: np.ndarray, flags: np.ndarray, s: np.ndarray, horizon: float, home2: float,
    body: tuple[float, float, float], sx: float, sy: float, theta: float, rear: float, front: float, half: float,
) -> int:  # pragma: no cover
    """``KnownFree.straight_clear`` (``nothing_beyond``) of the rectangle from ``-rear`` to
    ``front`` along the heading ``theta`` and ``±half`` across, at (``sx``, ``sy``): 1 (it
    lies in known-free space) or 0; -1 where a range compared lies within 1e-14 of what it
    is compared with (the C library's hypot here, CPython's in the method: the caller
    asks the method)."""
    c, sn = math.cos(theta), math.sin(theta)
    xs, ys = np.empty(4), np.empty(4)
    far = 0.0
    for i in range(4):
        u = -rear if i == 0 or i == 3 else front
        v = -half if i < 2 else half
        xs[i] = sx + u * c - v * sn
        ys[i] = sy + u * sn + v * c
        far = max(far, math.hypot(xs[i], ys[i]))
    ox, oy = -sx * c - sy * sn, sx * sn - sy * c
    if ox * ox + oy * oy <= rear * rear + front * front + half * half and _inside(ox, abs(oy), rear, front, half):
        lo, hi = -math.pi, math.pi
    else:
        b0 = math.atan2(ys[0], xs[0])
        rlo, rhi = math.inf, -math.inf
        for i in range(4):
            rel = _wrap(math.atan2(ys[i], xs[i]) - b0)
            rlo, rhi = min(rlo, rel), max(rhi, rel)
        lo, hi = b0 + rlo, b0 + rhi
    quick = _quick(f, horizon, lo, hi, far)
    if quick:
        return int(quick)
    undecided = False
    for i in range(4):
        inner = contains(f, flags, horizon, home2, body, xs[i], ys[i])
        if inner == 0:
            return 0
        undecided = undecided or inner < 0
    if undecided:
        return -1
    i0, i1 = _shadow_span(s, lo, hi)
    for k in range(i0, i1):
        lim = s[1, k]
        if _le(far, lim) < 0:
            return -1
        if not lim < far:
            continue
        ux, uy = s[2, k], s[3, k]
        # where the ray leaves the rectangle (its frame: the ray from (ox, oy) along (du, dv))
        du, dv = ux * c + uy * sn, uy * c - ux * sn
        t1, t2 = _div(-rear - ox, du), _div(front - ox, du)
        t3, t4 = _div(-half - oy, dv), _div(half - oy, dv)
        out = _nanmin(_fmax(t1, t2), _fmax(t3, t4))
        into = _nanmax(_fmin(t1, t2), _fmin(t3, t4))
        if into <= out and out > lim:
            return 0
    return 1


@_compiled
def _div(a: float, b: float) -> float:  # pragma: no cover
    # numpy's division: a zero divisor gives ±inf (or nan), not an exception
    if b == 0.0:
        if a == 0.0 or a != a:
            return math.nan
        return math.copysign(math.inf, a) * math.copysign(1.0, b)
    return a / b


@_compiled
def _fmax(a: float, b: float) -> float:  # pragma: no cover
    # np.fmax: a nan is ignored
    if a != a:
        return b
    if b != b:
        return a
    return a if a >= b else b


@_compiled
def _fmin(a: float, b: float) -> float:  # pragma: no cover
    if a != a:
        return b
    if b != b:
        return a
    return a if a <= b else b


@_compiled
def _nanmin(a: float, b: float) -> float:  # pragma: no cover
    # np.minimum: a nan wins
    if a != a or b != b:
        return math.nan
    return a if a <= b else b


@_compiled
def _nanmax(a: float, b: float) -> float:  # pragma: no cover
    if a != a or b != b:
        return math.nan
    return a if a >= b else b


@_compiled
def _near_min(f: np.ndarray, horizon: float, lo: float, hi: float) -> float:  # pragma: no cover
    # the range within which the sectors over bearings [lo, hi] are wholly known (KnownFree._quick's bound)
    m = f.shape[1]
    if not m:
        return horizon
    if hi - lo >= 2 * math.pi - 1e-9:
        return float(f[ROW_NEAR].min())
    if lo < -math.pi:
        lo, hi = lo + 2 * math.pi, hi + 2 * math.pi
    b = f[ROW_B]
    i0 = np.searchsorted(b, lo, side="left") - 1
    i1 = np.searchsorted(b, hi if hi <= math.pi else hi - 2 * math.pi, side="left")
    if hi > math.pi:
        i1 += m
    if i0 < 0:
        i0 += m
        i1 += m
    return float(_min_near(f, i0, i1))


@_compiled
def _free_at(f: np.ndarray, flags: np.ndarray, horizon: float, body: tuple[float, float, float], x: float, y: float) -> int:  # pragma: no cover
    # KnownFree._free for one point (nothing_beyond): 1, 0, or -1 where its bearing lies
    # within 1e-12 rad of a return's (numpy's arctan2 there, the C library's here)
    if _inside(x, abs(y), body[0], body[1], body[2]):
        return 1
    if not x * x + y * y <= horizon * horizon:
        return 0
    m = f.shape[1]
    if not m:
        return 1
    b = f[ROW_B]
    a = math.atan2(y, x)
    k = np.searchsorted(b, a, side="right") - 1
    free = _sector_free(f, flags, k, x, y)
    # a bearing on (or within 1e-12 rad of) a return's: numpy's arctan2 may put the point
    # in the sector on the other side; decided when both sectors answer alike
    if k >= 0 and a - b[k] <= 1e-12 and _sector_free(f, flags, k - 1, x, y) != free:
        return -1
    if k + 1 < m and b[k + 1] - a <= 1e-12 and _sector_free(f, flags, k + 1, x, y) != free:
        return -1
    return int(free)


@_compiled
def _sector_free(f: np.ndarray, flags: np.ndarray, k: int, x: float, y: float) -> int:  # pragma: no cover
    # KnownFree._free's answer for a point within the horizon in the sector from return k
    # (k = -1: the last, round the circle)
    if k < 0:
        k += f.shape[1]
    if flags[0, k]:
        return 1 if f[ROW_NX, k] * x + f[ROW_NY, k] * y <= f[ROW_C, k] + _TOL else 0
    if flags[1, k]:
        return 1 if x * x + y * y <= f[ROW_REACH, k] * f[ROW_REACH, k] else 0
    return 1


@_compiled
def turn_clear(
    f: np.ndarray, flags: np.ndarray, s: np.ndarray, horizon: float,
    body: tuple[float, float, float], x: float, y: float, theta: float, angle: float, d: float, rad: float,
    rc: np.ndarray, phi: np.ndarray, arc_step: float,
) -> int:  # pragma: no cover
    """``KnownFree.turn_clear`` (``nothing_beyond``) of a turn by ``angle`` at (``x``, ``y``,
    ``theta``), ``d`` = ``math.hypot(x, y)`` (CPython's, as the method's), ``rad`` the body's
    radius, ``rc`` and ``phi`` its corners' distances and angles from the rotation centre:
    1 (it lies in known-free space) or 0; -1 where an outline point's bearing lies within
    1e-12 rad of a return's (the caller asks the method)."""
    if d > rad:
        half = math.asin(rad / d)
        bc = math.atan2(y, x)
        lo, hi = bc - half, bc + half
    else:
        lo, hi = -math.pi, math.pi
    far = d + rad
    if far <= _near_min(f, horizon, lo, hi):
        return 1
    n = max(1, int(math.ceil(abs(angle) / arc_step)))
    step = angle / n
    grow = 1.0 / math.cos(step / 2)
    # per corner its arc's circumscribed polyline (start, n midpoints grown, end), as polar_to_xy
    px, py = np.empty((4, n + 2)), np.empty((4, n + 2))
    undecided = False
    for c in range(4):
        base = theta + phi[c]
        for j in range(n + 2):
            off = 0.0 if j == 0 else (angle if j == n + 1 else step * ((j - 1) + 0.5))
            rr = rc[c] * (1.0 if j == 0 or j == n + 1 else grow)
            a = base + off
            px[c, j] = x + rr * math.cos(a)
            py[c, j] = y + rr * math.sin(a)
            inner = _free_at(f, flags, horizon, body, px[c, j], py[c, j])
            if inner == 0:
                return 0
            undecided = undecided or inner < 0
    if undecided:
        return -1
    i0, i1 = _shadow_span(s, lo, hi)
    for k in range(i0, i1):
        lim = s[1, k]
        if not lim < far:
            continue
        ux, uy = s[2, k], s[3, k]
        # the segments: each arc's, then the body's outline at the start and at the end
        for q in range(4 * (n + 1) + 8):
            if q < 4 * (n + 1):
                c, j = q // (n + 1), q % (n + 1)
                ax, ay, bx, by = px[c, j], py[c, j], px[c, j + 1], py[c, j + 1]
            else:
                c = (q - 4 * (n + 1)) % 4
                j = 0 if q < 4 * (n + 1) + 4 else n + 1
                e = (c + 1) % 4
                ax, ay, bx, by = px[c, j], py[c, j], px[e, j], py[e, j]
            ex, ey = bx - ax, by - ay
            den = ux * ey - uy * ex
            rho = _div(ax * ey - ay * ex, den)  # where the segment's line meets the ray
            t = _div(ax * uy - ay * ux, den)  # and where along the segment
            if t >= 0 and t <= 1 and rho > lim:
                return 0
    return 1


@_compiled
def _trig(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    c, s = np.empty_like(a), np.empty_like(a)
    for i in range(a.shape[0]):
        c[i], s[i] = math.cos(a[i]), math.sin(a[i])
    return c, s


def _trig_as_numpy() -> bool:
    """True when numpy's cos and sin (``polar_to_xy``'s) give the C library's figures here,
    as :func:`turn_clear`'s do, on a spread of angles (a SIMD loop that rounds otherwise
    differs on some percent of them): else the method's numpy statements run."""
    a = np.concatenate((np.linspace(-4 * math.pi, 4 * math.pi, 4099), np.random.default_rng(0).uniform(-7.0, 7.0, 4096)))
    c, s = _trig(a)
    return bool((c == np.cos(a)).all() and (s == np.sin(a)).all())


#: whether :func:`turn_clear`'s cos and sin are numpy's on this host (see :func:`_trig_as_numpy`)
TRIG_AS_NUMPY = _trig_as_numpy()
