"""The compiled inner loop of :func:`clomp.runtime.estimation.icp.match_scans` (numba).

A match is about ten Gauss–Newton iterations over a hundred or so points, every revolution
of every run: written with numpy, each iteration was some forty small array calls and a
k-d tree query, about 0.2 ms of call overhead for microseconds of arithmetic, and the
largest share of an experiment run's time. Here the whole loop — nearest reference point
through a uniform grid, Huber-weighted normal equations accumulated point by point, the
eigen-decomposition and the step in the observable subspace — is one compiled call.

The arithmetic is the module :mod:`clomp.runtime.estimation.icp` documents; this module holds
no policy (thresholds, gating, what a failure says), only the numbers.

>>> import numpy as np
>>> pts = np.array([[0.0, 0.0], [0.25, 0.05], [1.0, 1.0]])
>>> starts, grid = grid_index(pts, 0.1)
>>> order = np.argsort(cell_keys(pts, grid), kind="stable")
>>> int(nearest(0.24, 0.04, 0.1**2, pts[order], starts, *grid)[0]) == int(np.where(order == 1)[0][0])
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from clomp.runtime.jit import compiled, interruptible

__all__ = ["grid_index", "cell_keys", "nearest", "nearest_two", "icp_iterations", "warm_up"]

# a grid of at most this many cells per axis (a quarter of a million in all): a scan
# spread over more than 51 m (far outliers) gets coarser cells rather than a huge index
_MAX_CELLS = 512


def grid_index(points: np.ndarray, cell: float) -> tuple[np.ndarray, tuple[float, float, float, int, int]]:
    """A uniform grid over ``points`` (N×2): ``(starts, (x0, y0, cell, nx, ny))``.

    Sorted by cell (``cell_keys``), the points of cell ``k`` are ``starts[k]:starts[k+1]``.
    The cell grows when the points spread over more than ``_MAX_CELLS`` cells an axis.
    """
    lo = points.min(axis=0) if len(points) else np.zeros(2)
    hi = points.max(axis=0) if len(points) else np.zeros(2)
    cell = max(cell, float(np.max(hi - lo)) / (_MAX_CELLS - 1))
    nx, ny = int((hi[0] - lo[0]) // cell) + 1, int((hi[1] - lo[1]) // cell) + 1
    grid = (float(lo[0]), float(lo[1]), float(cell), nx, ny)
    keys = np.sort(cell_keys(points, grid))
    starts = np.searchsorted(keys, np.arange(nx * ny + 1)).astype(np.int64)
    return starts, grid


def cell_keys(points: np.ndarray, grid: tuple[float, float, float, int, int]) -> np.ndarray:
    """The grid cell of each point (row-major: ``ix * ny + iy``)."""
    x0, y0, cell, nx, ny = grid
    ix = np.clip(((points[:, 0] - x0) // cell).astype(np.int64), 0, nx - 1)
    iy = np.clip(((points[:, 1] - y0) // cell).astype(np.int64), 0, ny - 1)
    keys: np.ndarray = ix * ny + iy
    return keys


@compiled
def nearest(qx: float, qy: float, bound2: float, pts: np.ndarray, starts: np.ndarray, x0: float, y0: float,
            cell: float, nx: int, ny: int) -> tuple[int, float]:
    """The grid-sorted point nearest (qx, qy) closer than ``sqrt(bound2)``: (index, squared
    distance), (-1, bound2) when none is."""
    bound = math.sqrt(bound2)
    lx = max(math.floor((qx - bound - x0) / cell), 0.0)
    hx = min(math.floor((qx + bound - x0) / cell), nx - 1.0)
    ly = max(math.floor((qy - bound - y0) / cell), 0.0)
    hy = min(math.floor((qy + bound - y0) / cell), ny - 1.0)
    best, found = bound2, -1
    if not (lx <= hx and ly <= hy):  # outside the grid (or not a number)
        return found, best
    for ix in range(int(lx), int(hx) + 1):
        for iy in range(int(ly), int(hy) + 1):
            c = ix * ny + iy
            for k in range(starts[c], starts[c + 1]):
                dx, dy = qx - pts[k, 0], qy - pts[k, 1]
                d2 = dx * dx + dy * dy
                if d2 < best:
                    best, found = d2, k
    return found, best


@compiled
def nearest_two(qs: np.ndarray, bound2: float, pts: np.ndarray, starts: np.ndarray, x0: float, y0: float, cell: float,
                nx: int, ny: int, found: np.ndarray, best: np.ndarray, second: np.ndarray) -> None:
    """For each row of ``qs`` (N×2): the grid-sorted point nearest it with a squared distance
    below ``bound2`` (``found``: its index, -1 when none), that squared distance and the
    next nearest one's (``best``, ``second``; ``bound2`` when there is none) — a k-d tree's
    ``query(qs, k=2, distance_upper_bound=sqrt(bound2))`` with squared distances summed as
    it sums them (``dx * dx + dy * dy``). A cell beyond the bound on every side is searched
    too, so that no rounding at a cell's edge can leave a point within the bound out."""
    bound = math.sqrt(bound2)
    for i in range(qs.shape[0]):
        qx, qy = qs[i, 0], qs[i, 1]
        b1, b2, f = bound2, bound2, -1
        lx = max(math.floor((qx - bound - x0) / cell) - 1.0, 0.0)
        hx = min(math.floor((qx + bound - x0) / cell) + 1.0, nx - 1.0)
        ly = max(math.floor((qy - bound - y0) / cell) - 1.0, 0.0)
        hy = min(math.floor((qy + bound - y0) / cell) + 1.0, ny - 1.0)
        if lx <= hx and ly <= hy:  # else outside the grid (or not a number)
            for ix in range(int(lx), int(hx) + 1):
                for iy in range(int(ly), int(hy) + 1):
                    c = ix * ny + iy
                    for k in range(starts[c], starts[c + 1]):
                        dx, dy = qx - pts[k, 0], qy - pts[k, 1]
                        d2 = dx * dx + dy * dy
                        if d2 < b1:
                            b1, b2, f = d2, b1, k
                        elif d2 < b2:
                            b2 = d2
        found[i], best[i], second[i] = f, b1, b2


@compiled
def _paired(cur: np.ndarray, i: int, x: np.ndarray, c: float, s: float, bound2: float, pts: np.ndarray,
            starts: np.ndarray, x0: float, y0: float, cell: float, nx: int, ny: int) -> tuple[int, float, float, float, float]:
    """Current point ``i`` moved by the pose ``x`` (its heading's cos ``c``, sin ``s``): its
    nearest reference point within ``sqrt(bound2)`` (-1: none), where it moved, and the
    offset from that reference point."""
    mx = x[0] + c * cur[i, 0] - s * cur[i, 1]
    my = x[1] + s * cur[i, 0] + c * cur[i, 1]
    k, _ = nearest(mx, my, bound2, pts, starts, x0, y0, cell, nx, ny)
    if k < 0:
        return k, mx, my, 0.0, 0.0
    return k, mx, my, mx - pts[k, 0], my - pts[k, 1]


@compiled
def icp_iterations(pts: np.ndarray, rows: np.ndarray, real: np.ndarray, starts: np.ndarray, x0: float, y0: float,
                   cell: float, nx: int, ny: int, cur: np.ndarray, prior: np.ndarray, max_iterations: int,
                   max_distance: float, final_distance: float, huber: float, lever: float, min_information: float,
                   min_points: int) -> Any:
    """Gauss–Newton from ``prior`` (x, y, theta) matching ``cur`` (N×2) to the grid-sorted
    reference (``pts``, its residual ``rows`` (M×2×2) and which of them are ``real``).

    Returns ``(stopped, x, lam, vecs, n_used, iterations, dist, n_final, rmse)``:
    ``stopped`` is True when an iteration found fewer than ``min_points`` correspondences
    within ``dist`` (then ``n_final`` and ``rmse`` are not computed); ``lam``, ``vecs`` the
    eigen-decomposition of the last information matrix (rotation scaled by ``lever``);
    ``n_final``, ``rmse`` the correspondences within ``final_distance`` of the result and
    their point-to-line RMS.
    """
    n = cur.shape[0]
    x = prior.copy()
    dist = max_distance
    lam = np.zeros(3)
    vecs = np.eye(3)
    n_used = 0
    it = 0
    for it in range(1, max_iterations + 1):
        c, s = math.cos(x[2]), math.sin(x[2])
        h = np.zeros((3, 3))
        g = np.zeros(3)
        n_used = 0
        for i in range(n):
            k, mx, my, dx, dy = _paired(cur, i, x, c, s, dist * dist, pts, starts, x0, y0, cell, nx, ny)
            if k < 0:
                continue
            n_used += 1
            dpx, dpy = x[1] - my, mx - x[0]  # d(moved)/d(theta): the point about the pose, turned a right angle
            for j in range(2):
                if not real[k, j]:
                    continue
                a0, a1 = rows[k, j, 0], rows[k, j, 1]
                r = a0 * dx + a1 * dy
                jt = (a0 * dpx + a1 * dpy) / lever
                w = 1.0 if abs(r) <= huber else huber / abs(r)
                h[0, 0] += w * a0 * a0
                h[0, 1] += w * a0 * a1
                h[0, 2] += w * a0 * jt
                h[1, 1] += w * a1 * a1
                h[1, 2] += w * a1 * jt
                h[2, 2] += w * jt * jt
                g[0] += w * a0 * r
                g[1] += w * a1 * r
                g[2] += w * jt * r
        if n_used < min_points:
            return True, x, lam, vecs, n_used, it, dist, 0, math.nan
        h[1, 0], h[2, 0], h[2, 1] = h[0, 1], h[0, 2], h[1, 2]
        lam, vecs = np.linalg.eigh(h)
        step = np.zeros(3)
        for e in range(3):
            if lam[e] / n_used >= min_information:
                coef = vecs[0, e] * g[0] + vecs[1, e] * g[1] + vecs[2, e] * g[2]
                step -= vecs[:, e] * (coef / lam[e])
        step[2] /= lever
        x += step
        x[2] = math.atan2(math.sin(x[2]), math.cos(x[2]))
        dist = max(final_distance, dist * 0.7)
        if math.hypot(step[0], step[1]) < 1e-5 and abs(step[2]) < 1e-5 and dist <= final_distance:
            break
    # the result's quality: correspondences within the final distance, their residual
    c, s = math.cos(x[2]), math.sin(x[2])
    n_final = 0
    sq = 0.0
    rows_used = 0
    for i in range(n):
        k, _, _, dx, dy = _paired(cur, i, x, c, s, final_distance * final_distance, pts, starts, x0, y0, cell, nx, ny)
        if k < 0:
            continue
        n_final += 1
        for j in range(2):
            if real[k, j]:
                r = rows[k, j, 0] * dx + rows[k, j, 1] * dy
                sq += r * r
                rows_used += 1
    rmse = math.sqrt(sq / rows_used) if rows_used else math.nan
    return False, x, lam, vecs, n_used, it, dist, n_final, rmse


def warm_up() -> None:
    """Compile (or load from the cache) the matcher (and the map's nearest-point search) now, with the argument types a match
    uses: a robot calls this before it moves, so that the first match — seconds of
    compiling on a fresh install — never stalls a control loop that is driving."""
    pts = np.zeros((1, 2))
    starts, grid = grid_index(pts, 0.1)
    interruptible(icp_iterations, pts, np.zeros((1, 2, 2)), np.ones((1, 2), dtype=bool), starts, *grid, np.zeros((1, 2)),
                  np.zeros(3), 1, 0.1, 0.1, 0.01, 0.5, 0.02, 1)
    interruptible(nearest_two, pts, 0.01, pts, starts, *grid, np.zeros(1, dtype=np.int64), np.zeros(1), np.zeros(1))
