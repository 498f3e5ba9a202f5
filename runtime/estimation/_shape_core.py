"""A compiled, bounded estimate of :func:`~clomp.runtime.estimation.observability.shape_information` (numba).

:func:`~clomp.runtime.estimation.observability.observed_information` runs every revolution,
and its exact shape information (a k-d tree query of 32 neighbours and a dozen array
passes) was about 1.3 ms of numpy call overhead a revolution (issue #41). Most
revolutions confirm the match: every direction it claims is observed by a wide margin.
This kernel computes the same quantity in one compiled pass (the neighbours by brute force,
the sums in its own order), so its figure differs from the exact one only by rounding, and
it says when even that is unsafe: a neighbour at the radius, a tie at the 32nd neighbour, a
point at the line test's threshold or without spread. The caller then trusts it only where
the rounding provably cannot change the answer, and otherwise computes the exact one.

>>> import numpy as np
>>> wall = np.c_[np.linspace(-1.0, 1.0, 80), np.full(80, 0.5)]
>>> shape, n, unsure = shape_estimate(wall, 0.0, 0.0, 0.2, 32, 0.25, 0.5)
>>> n, unsure, round(float(shape[1, 1]), 6), round(float(shape[0, 0]), 6)
(80, False, 80.0, 0.0)
>>> spaced = np.c_[np.linspace(-1.0, 1.0, 81), np.full(81, 0.5)]  # every 2.5 cm: neighbours at 0.2 m exactly
>>> bool(shape_estimate(spaced, 0.0, 0.0, 0.2, 32, 0.25, 0.5)[2])
True
"""

from __future__ import annotations

import math

import numpy as np

from clomp.runtime.jit import compiled

__all__ = ["shape_estimate", "TIE"]

#: relative margin within which a comparison of the exact computation (a distance to the
#: radius, the 32nd against the 33rd neighbour, a spread against the line test) is called a
#: tie: rounding differences between two orders of summation are about 1e-13 of these
#: figures, so a tie this wide is never a rounding-induced disagreement
TIE = 1e-8


@compiled
def _first_at_least(keys: np.ndarray, key: int) -> int:  # pragma: no cover - compiled
    """The first index of the sorted ``keys`` holding ``key`` or more (a binary search)."""
    lo, hi = 0, keys.shape[0]
    while lo < hi:
        mid = (lo + hi) // 2
        if keys[mid] < key:
            lo = mid + 1
        else:
            hi = mid
    return lo


@compiled
def _nearest_cut(near: np.ndarray, inside: int, k: int, r2: float, ranked: np.ndarray) -> tuple[float, bool]:  # pragma: no cover - compiled
    """The squared distance below which the ``k`` nearest of ``near[:inside]`` lie (``r2``
    when there are no more than ``k``), and whether the k-th and the next are a tie
    (``ranked``: scratch room for ``inside`` figures)."""
    if inside <= k:
        return r2, False
    ranked[:inside] = near[:inside]
    lo, hi = 0, inside - 1
    while lo < hi:  # quickselect: ranked[k] the (k+1)-th smallest, those before it no larger
        pivot = ranked[(lo + hi) // 2]
        i, j = lo, hi
        while i <= j:
            while ranked[i] < pivot:
                i += 1
            while ranked[j] > pivot:
                j -= 1
            if i <= j:
                ranked[i], ranked[j] = ranked[j], ranked[i]
                i += 1
                j -= 1
        if k <= j:
            hi = j
        elif k >= i:
            lo = i
        else:
            break
    kth, nxt = ranked[:k].max(), ranked[k]
    return 0.5 * (kth + nxt), bool(nxt - kth <= TIE * r2)


@compiled
def shape_estimate(pts: np.ndarray, cx: float, cy: float, radius: float, neighbours: int, line_ratio: float,
                   lever: float) -> tuple[np.ndarray, int, bool]:  # pragma: no cover - compiled
    """The shape information of the N×2 ``pts`` about a robot at (``cx``, ``cy``), as
    :func:`~clomp.runtime.estimation.observability.shape_information` defines it, up to
    rounding; the usable points' count; and whether some comparison was a tie (see
    :data:`TIE`: the estimate may then differ from the exact one by more than rounding)."""
    n_pts = pts.shape[0]
    k = min(neighbours, n_pts)
    r2 = radius * radius
    reach = radius * (1.0 + TIE)  # a grid cell: beyond the next cell a point is surely outside, and no tie
    x0, y0 = pts[:, 0].min(), pts[:, 1].min()
    nx = int((pts[:, 0].max() - x0) / reach) + 1
    ny = int((pts[:, 1].max() - y0) / reach) + 1
    out = np.zeros((3, 3))
    if nx * ny > 2**60:  # a scene too wide for the grid's keys: say so, the exact figure decides
        return out, 0, True
    cx_of = ((pts[:, 0] - x0) / reach).astype(np.int64)
    cy_of = ((pts[:, 1] - y0) / reach).astype(np.int64)
    order = np.argsort(cx_of * ny + cy_of, kind="mergesort")
    xs, ys = pts[order, 0].copy(), pts[order, 1].copy()
    keys = (cx_of * ny + cy_of)[order]
    near = np.empty(n_pts)
    scratch = np.empty(n_pts)
    who = np.empty(n_pts, dtype=np.int64)
    usable = 0
    unsure = False
    for i in range(n_pts):
        xi, yi = xs[i], ys[i]
        gx, gy = int(keys[i] // ny), int(keys[i] % ny)
        inside = 0
        for ix in range(max(gx - 1, 0), min(gx + 2, nx)):
            first = _first_at_least(keys, ix * ny + max(gy - 1, 0))
            last = _first_at_least(keys, ix * ny + min(gy + 2, ny))
            for jj in range(first, last):
                dx, dy = xs[jj] - xi, ys[jj] - yi
                e = dx * dx + dy * dy
                if abs(e - r2) <= TIE * r2:
                    unsure = True
                if e < r2:
                    near[inside] = e
                    who[inside] = jj
                    inside += 1
        cut, tie = _nearest_cut(near, inside, k, r2, scratch)
        unsure = unsure or tie
        count = 0
        mx, my = 0.0, 0.0
        for m in range(inside):
            if near[m] <= cut:
                j = who[m]
                who[count] = j
                count += 1
                mx += xs[j]
                my += ys[j]
        if count < 4:
            continue
        usable += 1
        mx, my = mx / count, my / count
        sxx, syy, sxy = 0.0, 0.0, 0.0
        for m in range(count):
            qx, qy = xs[who[m]] - mx, ys[who[m]] - my
            sxx += qx * qx
            syy += qy * qy
            sxy += qx * qy
        half, det = (sxx + syy) / 2, sxx * syy - sxy * sxy
        root = math.sqrt(max(half * half - det, 0.0))
        big, small = half + root, half - root
        if big <= TIE * r2 or abs(small - line_ratio * big) <= TIE * big:
            unsure = True  # no spread to speak of, or at the line test's threshold
        ax, ay = -(yi - cy) / lever, (xi - cx) / lever
        if big > 0 and small <= line_ratio * big:
            angle = 0.5 * math.atan2(2 * sxy, sxx - syy)
            ux, uy = -math.sin(angle), math.cos(angle)
            row = (ux, uy, ux * ax + uy * ay)
            for a in range(3):
                for b in range(3):
                    out[a, b] += row[a] * row[b]
        else:
            out[0, 0] += 1.0
            out[1, 1] += 1.0
            out[0, 2] += ax
            out[2, 0] += ax
            out[1, 2] += ay
            out[2, 1] += ay
            out[2, 2] += ax * ax + ay * ay
    return out, usable, unsure
