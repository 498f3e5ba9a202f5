"""The planner's compiled loops (numba): perception's surfaces, pieces and boxes, and a straight's gap.

:func:`surfaces_and_boxes` is the second half of :func:`clomp.planner.perception.perceive`:
:func:`clomp.planner.perception._along_surfaces`, ``_cut`` and ``_boxes`` state the rules
with numpy (the kept points in bearing order, repeats dropped; a surface breaks at a step
longer than the cluster distance, is cut every ``_PIECE`` metres of path, a piece is halved
while thick, each piece is covered by a padded box along its chord). On a scan of a few
hundred points they cost dozens of small array calls per halving round, 80–100 µs, most
of a plan where nothing is ahead. These loops do the same with the same floating-point
operations, in the same order, and rounded the same way as numpy's own loops round them
on this machine: numpy multiplies complex numbers with a fused multiply-add
(``re = fma(ar, br, -ai·bi)``, ``im = fma(ar, bi, ai·br)``), takes a complex modulus as
``larger · sqrt(fma(q, q, 1))`` with ``q = smaller / larger``, and divides a complex number
by a real one as Smith's algorithm does (by the reciprocal); the bearings are numpy's own
``arctan2`` (its SIMD loop), computed between two compiled calls.

:func:`lane_gap` is :meth:`clomp.planner.contact.Scene.straight_gap`'s pass over the points
(a dozen array calls per straight). The tests hold each to its numpy statement bit for bit
(``tests/planner/test_kernels.py``).

>>> wall = np.c_[np.full(5, 0.5), np.linspace(-0.02, 0.02, 5)]   # 1 cm apart: one piece
>>> pts, bounds, boxes, centres, radii = surfaces_and_boxes(wall, np.ones(5, dtype=bool), False, 0.1, 0.002, 0.08, 0.0075)
>>> bounds.tolist(), [round(float(v), 3) for v in boxes[0, 0]], round(float(radii[0]), 4)
([0, 5], [0.502, -0.022], 0.0221)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit, types
from numba.extending import intrinsic

__all__ = ["ROUNDS_AS_NUMPY", "boxes_of", "kept_points", "lane_gap", "lane_gaps", "near_boxes", "surfaces_and_boxes", "turn_hits"]


def _rounds_as_these_loops() -> bool:
    """True when numpy's complex loops round here as :func:`surfaces_and_boxes` and
    :func:`lane_gap` do: a product fused (``(1 + 2⁻³⁰ + i)·(1 − 2⁻³⁰ + i)`` has the real part
    −2⁻⁶⁰, not the 0 of two roundings) and the modulus by its SIMD formula, on arrays long
    and short and with a scalar factor. A numpy or a CPU that rounds otherwise keeps the
    numpy statements (perception and the straight gap then cost what they did, and plan
    exactly as before)."""
    ok = True
    for n in (1, 3, 17, 64):
        a = np.full(n, complex(1 + 2.0**-30, 1.0))
        b = complex(1 - 2.0**-30, 1.0)
        modulus = np.abs(np.full(n, complex(-0.8019314252534474, -0.5401312070783946)))
        ok &= bool((np.real(a * np.full(n, b)) == -(2.0**-60)).all() and (np.real(a * b) == -(2.0**-60)).all())
        ok &= bool((modulus == 0.9668690354277508).all())  # hypot's 0.9668690354277507 unfused
    return ok


#: whether the compiled loops give numpy's own figures on this host (see :func:`_rounds_as_these_loops`)
ROUNDS_AS_NUMPY = _rounds_as_these_loops()


def _compiled(fn: Any) -> Any:
    # as clomp.runtime.jit.compiled (which the planner may not import): machine code cached
    # beside the module, compiled afresh per process where no cache can be written
    try:
        return njit(cache=True)(fn)
    except RuntimeError:  # pragma: no cover - numba: "cannot cache function …: no locator available"
        return njit()(fn)


def _fma_typed(typingctx: Any, a: Any, b: Any, c: Any) -> Any:
    """a·b + c rounded once (LLVM's fma), as numpy's complex loops compute it."""
    sig = types.float64(types.float64, types.float64, types.float64)

    def codegen(context: Any, builder: Any, signature: Any, args: Any) -> Any:
        return builder.fma(*args)

    return sig, codegen


_fma: Any = intrinsic(_fma_typed)


@_compiled
def _cabs(re: float, im: float) -> float:  # pragma: no cover - compiled
    # numpy's complex absolute value (its SIMD loop): larger · sqrt(q² + 1), q = smaller / larger
    r, i = abs(re), abs(im)
    larger, smaller = max(r, i), min(r, i)
    q = smaller / larger if larger != 0.0 and smaller != math.inf else 0.0
    return math.sqrt(_fma(q, q, 1.0)) * larger


@_compiled
def _chord(zr: np.ndarray, zi: np.ndarray, s: int, e: int) -> tuple[float, float, float, float]:  # pragma: no cover
    # the piece s:e's first point a and unit chord to its last point (1 when they coincide)
    ar, ai = zr[s], zi[s]
    er, ei = zr[e - 1] - ar, zi[e - 1] - ai
    norm = _cabs(er, ei)
    if norm < 1e-9:
        norm, er, ei = 1.0, 1.0, 0.0
    # complex / real as numpy divides (Smith's algorithm with a zero imaginary part)
    rat = 0.0 / norm
    scl = 1.0 / (norm + 0.0 * rat)
    return ar, ai, (er + ei * rat) * scl, (ei - er * rat) * scl


@_compiled
def _extents(zr: np.ndarray, zi: np.ndarray, s: int, e: int, ar: float, ai: float, er: float, ei: float) -> tuple[float, float, float, float]:  # pragma: no cover
    # (u0, t0, u1, t1): the piece's extents along and across its chord, w = (z - a)·conj(e)
    br, bi = er, -ei
    u0 = t0 = math.inf
    u1 = t1 = -math.inf
    for k in range(s, e):
        xr, xi = zr[k] - ar, zi[k] - ai
        u = _fma(xr, br, -(xi * bi))
        t = _fma(xr, bi, xi * br)
        u0, u1, t0, t1 = min(u0, u), max(u1, u), min(t0, t), max(t1, t)
    return u0, t0, u1, t1


@_compiled
def _cuts(zr: np.ndarray, zi: np.ndarray, step: np.ndarray, cluster_distance: float, per_piece: float) -> np.ndarray:  # pragma: no cover
    # perception._cut: rotate to start at a break (in place), then flag where pieces start
    n = zr.shape[0]
    first = -1
    for k in range(n):
        if step[k] > cluster_distance:
            first = k
            break
    if first > 0:
        zr[:] = np.concatenate((zr[first:], zr[:first]))
        zi[:] = np.concatenate((zi[first:], zi[:first]))
        step[:] = np.concatenate((step[first:], step[:first]))
    cut = np.zeros(n + 1, dtype=np.bool_)
    path = 0.0
    last = 0
    for k in range(n):
        brk = step[k] > cluster_distance or (first < 0 and k == 0)
        path = path + (0.0 if brk else step[k])
        cell = int(path * per_piece)
        cut[k] = brk or (k > 0 and cell != last)
        last = cell
    cut[n] = True
    return cut


@_compiled
def _halve(zr: np.ndarray, zi: np.ndarray, cut: np.ndarray, thin: float, rec: np.ndarray) -> None:  # pragma: no cover
    # perception._boxes's rounds: every piece thicker than ``thin`` across its chord halved,
    # until none is; each final piece's chord and extents into ``rec`` at its first point
    # (a final piece is one found thin: the same figures the boxes would compute again)
    n = zr.shape[0]
    stack = np.empty(2 * n + 2, dtype=np.int64)
    top = 0
    s = 0
    for k in range(1, n + 1):
        if cut[k]:
            stack[top], stack[top + 1] = s, k
            top += 2
            s = k
    while top:
        top -= 2
        s, e = stack[top], stack[top + 1]
        ar, ai, er, ei = _chord(zr, zi, s, e)
        u0, t0, u1, t1 = _extents(zr, zi, s, e, ar, ai, er, ei)
        if t1 - t0 > thin:
            mid = (s + e) >> 1
            cut[mid] = True
            stack[top], stack[top + 1], stack[top + 2], stack[top + 3] = s, mid, mid, e
            top += 4
        else:
            rec[s, 0], rec[s, 1], rec[s, 2], rec[s, 3] = ar, ai, er, ei
            rec[s, 4], rec[s, 5], rec[s, 6], rec[s, 7] = u0, t0, u1, t1


@_compiled
def _kernel(
    zr: np.ndarray, zi: np.ndarray, step: np.ndarray, cluster_distance: float, pad: float, per_piece: float, thin: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:  # pragma: no cover
    n = zr.shape[0]
    cut = _cuts(zr, zi, step, cluster_distance, per_piece)
    rec = np.empty((n, 8))
    _halve(zr, zi, cut, thin, rec)
    bounds = np.flatnonzero(cut)
    m = bounds.shape[0] - 1
    boxes = np.empty((m, 4, 2))
    centres = np.empty((m, 2))
    radii = np.empty(m)
    local = np.empty((4, 2))
    for j in range(m):
        ar, ai, er, ei, u0, t0, u1, t1 = rec[bounds[j]]
        u0, t0, u1, t1 = u0 + -pad, t0 + -pad, u1 + pad, t1 + pad
        local[0, 0], local[0, 1], local[1, 0], local[1, 1] = u0, t0, u1, t0
        local[2, 0], local[2, 1], local[3, 0], local[3, 1] = u1, t1, u0, t1
        for c in range(4):  # a + local·e, numpy's complex product
            lr, li = local[c, 0], local[c, 1]
            boxes[j, c, 0] = _fma(lr, er, -(li * ei)) + ar
            boxes[j, c, 1] = _fma(lr, ei, li * er) + ai
        sr, si = boxes[j, 0, 0] + boxes[j, 2, 0], boxes[j, 0, 1] + boxes[j, 2, 1]
        centres[j, 0] = _fma(sr, 0.5, -(si * 0.0))  # (c0 + c2) · (0.5 + 0i)
        centres[j, 1] = _fma(sr, 0.0, si * 0.5)
        radii[j] = _cabs(u1 - u0, t1 - t0) * 0.5
    pts = np.empty((n, 2))
    pts[:, 0], pts[:, 1] = zr, zi
    return pts, bounds, boxes, centres, radii


@_compiled
def _select(zf: np.ndarray, bits: np.ndarray, keep: np.ndarray, dedupe: bool) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover
    # perception._along_surfaces's first half: the kept points (with ``dedupe``, less each
    # one bit-equal to the point before it in the scan), as contiguous x and y
    n = zf.shape[0]
    if dedupe:
        for k in range(n - 1, 0, -1):
            if bits[k, 0] == bits[k - 1, 0] and bits[k, 1] == bits[k - 1, 1]:
                keep[k] = False
    m = 0
    for k in range(n):
        m += keep[k]
    zr, zi = np.empty(m), np.empty(m)
    j = 0
    for k in range(n):
        if keep[k]:
            zr[j], zi[j] = zf[k, 0], zf[k, 1]
            j += 1
    return zr, zi


@_compiled
def _stable_order(bearing: np.ndarray) -> np.ndarray:  # pragma: no cover
    # np.argsort(bearing, kind="stable"), the one order by (bearing, index): a scan's
    # bearings rise (or fall: the A1 sweeps clockwise) from where the sensor's revolution
    # began, up to the jitter of rounded points, so from that order turned at its deepest
    # drop of more than π (the wrap from +π to −π; a scan that spans less than a turn
    # has none and is not turned: turned at a jitter's drop, 0.02 rad, it needed some 17
    # moves a point and fell back to the merge sort) an insertion sort on (bearing,
    # index) moves few points; past a budget of moves, numba's merge sort
    n = bearing.shape[0]
    falls = 0
    for k in range(n - 1):
        falls += bearing[k + 1] < bearing[k]
    order = np.empty(n, dtype=np.int64)
    for k in range(n):
        order[k] = n - 1 - k if 2 * falls > n else k
    first, deepest = 0, -math.pi
    for k in range(n - 1):
        drop = bearing[order[k + 1]] - bearing[order[k]]
        if drop < deepest:
            first, deepest = k + 1, drop
    if first:
        order = np.concatenate((order[first:], order[:first]))
    budget = 8 * n
    for i in range(1, n):
        o = order[i]
        v = bearing[o]
        j = i - 1
        while j >= 0 and (bearing[order[j]] > v or (bearing[order[j]] == v and order[j] > o)):
            order[j + 1] = order[j]
            j -= 1
            budget -= 1
        order[j + 1] = o
        if budget < 0:
            return np.argsort(bearing, kind="mergesort")
    return order


@_compiled
def _swept(
    zr: np.ndarray, zi: np.ndarray, bearing: np.ndarray, cluster_distance: float, pad: float, per_piece: float, thin: float
) -> Any:  # pragma: no cover - compiled: the five arrays of surfaces_and_boxes
    # perception._along_surfaces's second half (in bearing order, each point's step from
    # the one before, repeats dropped), then the pieces and boxes
    order = _stable_order(bearing)
    n = order.shape[0]
    sr, si = np.empty(n), np.empty(n)
    for k in range(n):
        sr[k], si[k] = zr[order[k]], zi[order[k]]
    step = np.empty(n)
    step[0] = np.hypot(sr[0] - sr[n - 1], si[0] - si[n - 1])
    for k in range(1, n):
        step[k] = np.hypot(sr[k] - sr[k - 1], si[k] - si[k - 1])
    if n > 1:
        uniq = step > 1e-4
        distinct = 0
        for k in range(n):
            distinct += uniq[k]
        if distinct < n:
            if not distinct:
                uniq[0] = True
                distinct = 1
            tr, ti, ts = np.empty(distinct), np.empty(distinct), np.empty(distinct)
            j = 0
            for k in range(n):
                if uniq[k]:
                    tr[j], ti[j], ts[j] = sr[k], si[k], step[k]
                    j += 1
            sr, si, step = tr, ti, ts
    return _kernel(sr, si, step, cluster_distance, pad, per_piece, thin)


@_compiled
def kept_points(
    pts: np.ndarray, range2: float, own2: float, body: tuple[float, float, float], exempting: bool, dedupe: bool
) -> tuple[np.ndarray, int, int, float]:  # pragma: no cover - compiled
    """:func:`clomp.planner.perception._kept` and the first half of :func:`surfaces_and_boxes`
    in one pass over a float N×2 scan: the kept points (2×K: x, y; within ``range2``, the
    squared horizon, not at the sensor, and with ``exempting`` not strictly inside the
    ``body`` (rear, front, half width) when nearer than ``own2``; with ``dedupe`` less each
    one bit-equal to the point before it in the scan), how many were kept before that,
    how many the body exempted, and the largest squared range (nan with a nan; inf
    with an inf, or a coordinate whose square overflows: a scan with neither is finite).

    >>> z, kept, exempt, far2 = kept_points(np.array([[0.5, 0.0], [0.05, 0.0], [3.0, 0.0]]), 1.21, 0.0405, (0.18, 0.09, 0.09), True, False)
    >>> z.tolist(), kept, exempt, far2
    ([[0.5], [0.0]], 1, 1, 9.0)
    """
    n = pts.shape[0]
    rear, front, half = body
    keep = np.empty(n, dtype=np.bool_)
    kept = exempt = 0
    far2 = -math.inf
    for i in range(n):
        x, y = pts[i, 0], pts[i, 1]
        r2 = x * x + y * y  # as numpy: one product over the array, then the sum
        far2 = r2 if r2 > far2 or r2 != r2 else far2
        k = r2 <= range2 and r2 > 1e-6
        # clomp.planner.footprint.inside(x, |y|, body, strict=True) for the returns within own2
        if k and exempting and r2 < own2 and x > -rear and x < front and abs(y) < half:
            k = False
            exempt += 1
        keep[i] = k
        kept += k
    if dedupe:
        bits = pts.view(np.int64)
        for i in range(n - 1, 0, -1):
            if bits[i, 0] == bits[i - 1, 0] and bits[i, 1] == bits[i - 1, 1]:
                keep[i] = False
    m = 0
    for i in range(n):
        m += keep[i]
    z = np.empty((2, m))
    j = 0
    for i in range(n):
        if keep[i]:
            z[0, j], z[1, j] = pts[i, 0], pts[i, 1]
            j += 1
    return z, kept, exempt, far2


def boxes_of(
    zr: np.ndarray, zi: np.ndarray, cluster_distance: float, pad: float, piece: float, thin: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """:func:`surfaces_and_boxes` of points already kept (:func:`kept_points`' rows)."""
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    out = _swept(zr, zi, np.arctan2(zi, zr), float(cluster_distance), float(pad), 1.0 / piece, float(thin))
    return out


def surfaces_and_boxes(
    points: np.ndarray, keep: np.ndarray, dedupe: bool, cluster_distance: float, pad: float, piece: float, thin: float
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Perception's pieces and boxes of the ``keep`` of ``points`` (N×2; ``keep`` is changed
    in place): the kept points in surface order, turned to start at a break (K×2); where
    each piece starts (M + 1, the last K); the boxes (M×4×2), centres (M×2) and circumradii
    (M). With ``dedupe`` a point bit-equal to the one before it in the scan is dropped
    first. Pieces are cut every ``piece`` metres of path and halved while more than
    ``thin`` across; boxes stand ``pad`` off their points (positive: perception's numpy
    path keeps the sign of a zero extent for the rest).

    >>> wall = np.array([[0.5, 0.02], [0.5, 0.01], [0.5, 0.0], [0.5, -0.01], [0.5, -0.02]])
    >>> pts, bounds, *_ = surfaces_and_boxes(wall, np.ones(5, dtype=bool), False, 0.1, 0.002, 0.08, 0.0075)
    >>> pts[:, 1].tolist(), bounds.tolist()   # in bearing order, one piece
    ([-0.02, -0.01, 0.0, 0.01, 0.02], [0, 5])
    """
    if not pad > 0:
        raise ValueError(f"surfaces_and_boxes: pad must be positive, got {pad!r}")
    zf = np.ascontiguousarray(points, dtype=np.float64)
    zr, zi = _select(zf, zf.view(np.int64), keep, bool(dedupe))
    out: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]
    out = _swept(zr, zi, np.arctan2(zi, zr), float(cluster_distance), float(pad), 1.0 / piece, float(thin))
    return out


@_compiled
def lane_gap(
    zr: np.ndarray, zi: np.ndarray, x: float, y: float, cr: float, ci: float,
    infl: tuple[float, float, float], real: tuple[float, float, float], body: bool,
) -> tuple[float, int]:  # pragma: no cover - compiled
    """How far the body at (``x``, ``y``) heading θ (``cr + i·ci`` = cos θ − i sin θ)
    drives before it meets one of the points ``zr + i·zi``, and the first such point's
    position; (inf, -1) when none. ``infl`` and ``real`` are the inflated and
    the real body (rear, front, half width); with ``body`` a point inside the inflated
    footprint at the start is held to the real body (the start-touching rule).

    >>> lane_gap(np.array([0.5, 0.5]), np.array([0.3, 0.0]), 0.0, 0.0, 1.0, -0.0, (0.1, 0.2, 0.1), (0.1, 0.19, 0.09), True)
    (0.3, 1)
    """
    rear, front, half = infl
    _, rfront, rhalf = real
    best, k = math.inf, -1
    for j in range(zr.shape[0]):
        dr, di = zr[j] - x, zi[j] - y
        u = _fma(dr, cr, -(di * ci))  # (dz · rot), numpy's complex product
        v = abs(_fma(dr, ci, di * cr))
        if not v <= half:
            continue
        if u > front:
            gap = u - front
        elif body and u >= -rear and v < rhalf and u >= rfront:
            gap = u - rfront
        else:
            continue
        if gap < best:
            best, k = gap, j
    return (best, k) if k >= 0 else (math.inf, -1)


@_compiled
def lane_gaps(
    zr: np.ndarray, zi: np.ndarray, cr: np.ndarray, ci: np.ndarray,
    infl: tuple[float, float, float], real: tuple[float, float, float], body: bool,
) -> tuple[np.ndarray, np.ndarray]:  # pragma: no cover - compiled
    """:func:`lane_gap` from the origin for every heading ``cr[q] + i·ci[q]`` (cos θ − i sin θ)
    at once: :meth:`clomp.planner.contact.Scene._gaps`' least gap per heading and the first
    point that has it (-1 where none is in the lane).

    >>> gaps, idx = lane_gaps(np.array([0.5]), np.array([0.0]), np.array([1.0, 0.0]), np.array([-0.0, -1.0]), (0.1, 0.2, 0.1), (0.1, 0.19, 0.09), True)
    >>> gaps.tolist(), idx.tolist()
    ([0.3, inf], [0, -1])
    """
    k = cr.shape[0]
    gaps, idx = np.empty(k), np.empty(k, dtype=np.int64)
    for q in range(k):
        gaps[q], idx[q] = lane_gap(zr, zi, 0.0, 0.0, cr[q], ci[q], infl, real, body)
    return gaps, idx


@_compiled
def _inside_body(u: float, v: float, box: tuple[float, float, float], strict: bool) -> bool:  # pragma: no cover
    # clomp.planner.footprint.inside for one point at (u, |v|)
    if strict:
        return u > -box[0] and u < box[1] and v < box[2]
    return u >= -box[0] and u <= box[1] and v <= box[2]


@_compiled
def _waived_tick(
    dx: np.ndarray, dy: np.ndarray, waived: np.ndarray, theta: float, sign: float, per_tick: float, e0: float, ticks: int,
    real: tuple[float, float, float],
) -> int:  # pragma: no cover
    # Scene._waived_turn: the first tick at or after which the real body meets a waived point
    # strictly outside it at the start, eight headings per tick
    c0, s0 = math.cos(theta), math.sin(theta)
    step = per_tick / 8
    for i in range(8 * ticks):
        th = theta + sign * min((i + 1) * step, e0)
        c, sn = np.cos(th), np.sin(th)
        for p in range(dx.shape[0]):
            if not waived[p]:
                continue
            if _inside_body(dx[p] * c0 + dy[p] * s0, abs(dy[p] * c0 - dx[p] * s0), real, True):
                continue
            if _inside_body(dx[p] * c + dy[p] * sn, abs(dy[p] * c - dx[p] * sn), real, False):
                return i // 8 + 1
    return ticks + 1


@_compiled
def _met_at(
    dx: np.ndarray, dy: np.ndarray, th: float, waived: np.ndarray, exempt: np.ndarray, any_waived: bool,
    infl: tuple[float, float, float], real: tuple[float, float, float],
) -> int:  # pragma: no cover
    # the first point the body at heading th meets (-1: none): the inflated body, the real
    # one for a waived point, none for an exempt one
    c, sn = np.cos(th), np.sin(th)
    for p in range(dx.shape[0]):
        if any_waived and exempt[p]:
            continue
        u, v = dx[p] * c + dy[p] * sn, abs(dy[p] * c - dx[p] * sn)
        if _inside_body(u, v, real if any_waived and waived[p] else infl, False):
            return p
    return -1


@_compiled
def turn_hits(
    dx: np.ndarray, dy: np.ndarray, theta: float, signs: np.ndarray, e0s: np.ndarray, ticks: np.ndarray, per_tick: float,
    infl: tuple[float, float, float], real: tuple[float, float, float],
) -> np.ndarray:  # pragma: no cover - compiled
    """:meth:`clomp.planner.contact.Scene._turns` for turns from one heading ``theta`` among
    the points at offsets (``dx``, ``dy``): per turn (sign, error ``e0s``, ``ticks``) the
    first tick in contact (``ticks + 1``: none), the point met (its column, -1: none) and
    the heading at the tick before (3×T, as floats). The start-touching rule as there: a
    point inside the inflated body at the start is held to the real body, tested at eight
    headings per tick; one strictly inside the real body at the start is exempt.

    >>> turn_hits(np.array([0.3]), np.array([0.0]), 0.0, np.array([1.0]), np.array([1.5]), np.array([26]), 0.058, (0.19, 0.1, 0.1), (0.18, 0.09, 0.09))[0].tolist()
    [27.0]
    """
    n, t = dx.shape[0], signs.shape[0]
    out = np.empty((3, t))
    c, sn = np.cos(theta), np.sin(theta)
    waived = np.empty(n, dtype=np.bool_)
    exempt = np.empty(n, dtype=np.bool_)
    any_waived = False
    for p in range(n):
        u, v = dx[p] * c + dy[p] * sn, abs(dy[p] * c - dx[p] * sn)
        waived[p] = _inside_body(u, v, infl, False)
        exempt[p] = _inside_body(u, v, real, True)
        any_waived = any_waived or waived[p]
    for q in range(t):
        k, j = ticks[q] + 1, -1
        for tick in range(1, ticks[q] + 1):
            j = _met_at(dx, dy, theta + signs[q] * min(tick * per_tick, e0s[q]), waived, exempt, any_waived, infl, real)
            if j >= 0:
                k = tick
                break
        if any_waived:
            w = _waived_tick(dx, dy, waived, theta, signs[q], per_tick, e0s[q], ticks[q], real)
            if w < k:
                # between ticks: no point is met at tick w (k was the first), so the first waived one
                k, j = w, int(np.argmax(waived))
        out[0, q], out[1, q] = k, j
        out[2, q] = theta + signs[q] * min((k - 1) * per_tick, e0s[q])
    return out


@_compiled
def near_boxes(centres: np.ndarray, radii: np.ndarray, x: float, y: float, margin: float) -> list[int]:  # pragma: no cover
    """The boxes (ascending) whose circumcircle, grown by ``margin``, holds (``x``, ``y``):
    :meth:`clomp.planner.perception.Obstacles.contains_point`'s filter, in its arithmetic.

    >>> near_boxes(np.array([[0.5, 0.0], [2.0, 0.0]]), np.array([0.1, 0.1]), 0.55, 0.0, 0.0)
    [0]
    """
    out = []
    for i in range(centres.shape[0]):
        if np.hypot(centres[i, 0] - x, centres[i, 1] - y) <= radii[i] + margin + 1e-12:
            out.append(i)
    return out
