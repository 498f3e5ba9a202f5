"""Ray casting for the world's LiDAR: the first edge or circle along each beam.

:func:`first_hits_numpy` states the rule with numpy (every ray against every obstacle at
once); :func:`first_hits` computes it in one compiled loop (numba, :mod:`clomp.runtime.jit`)
with the same floating-point operations in the same order — each a product, difference or
quotient rounded on its own as numpy's element-wise loops round it, the square root exact,
the beam's cosine and sine numpy's own (computed before the compiled call) — so the two
agree bit for bit (``tests/runtime/test_raycast.py``). A revolution was about 0.15 ms of
array calls on 360 × dozens of edges; the loop skips the array temporaries.

>>> import numpy as np
>>> first_hits(0.0, 0.0, np.array([0.0]), np.array([[1.0, -1.0, 0.0, 2.0]]), np.zeros((0, 3)), 5.0).tolist()
[1.0]
"""

from __future__ import annotations

import math

import numpy as np

from clomp.runtime.jit import compiled, interruptible

__all__ = ["first_hits", "first_hits_numpy"]


def first_hits_numpy(x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray, edges: np.ndarray,
                     circles: np.ndarray, reach: float) -> np.ndarray:
    """:func:`first_hits` as numpy array statements (the reference the compiled loop is held to).

    >>> first_hits_numpy(0.0, 0.0, np.array([0.0]), np.array([[1.0, -1.0, 0.0, 2.0]]), np.zeros((0, 3)), 5.0).tolist()
    [1.0]
    """
    c, s = np.cos(angles)[:, None], np.sin(angles)[:, None]
    best = np.full(len(angles), np.inf)
    if len(edges):
        wx, wy, ex, ey = edges[:, 0] - x, edges[:, 1] - y, edges[:, 2], edges[:, 3]
        # (x, y) + t (c, s) = edge start + u edge vector, by Cramer's rule
        det = ex * s - ey * c
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (ex * wy - ey * wx) / det
            u = (c * wy - s * wx) / det
        t = np.where((det != 0) & (u >= 0) & (u <= 1) & (t >= 0) & (t <= reach), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    if len(circles):
        dx, dy, r = circles[:, 0] - x, circles[:, 1] - y, circles[:, 2]
        b = dx * c + dy * s
        disc = b * b - (dx * dx + dy * dy - r * r)
        with np.errstate(invalid="ignore"):
            t = b - np.sqrt(disc)
        t = np.where((disc >= 0) & (t >= 0) & (t <= reach), t, np.inf)
        best = np.minimum(best, t.min(axis=1))
    return best


@compiled
def _first_hits(xs: np.ndarray, ys: np.ndarray, c: np.ndarray, s: np.ndarray, edges: np.ndarray,
                circles: np.ndarray, reach: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    for i in range(len(c)):
        x, y, ci, si = xs[i], ys[i], c[i], s[i]
        best = math.inf
        for j in range(edges.shape[0]):
            wx, wy, ex, ey = edges[j, 0] - x, edges[j, 1] - y, edges[j, 2], edges[j, 3]
            det = ex * si - ey * ci
            if det != 0.0:
                t = (ex * wy - ey * wx) / det
                u = (ci * wy - si * wx) / det
                if u >= 0.0 and u <= 1.0 and t >= 0.0 and t <= reach and t < best:
                    best = t
        for j in range(circles.shape[0]):
            dx, dy, r = circles[j, 0] - x, circles[j, 1] - y, circles[j, 2]
            b = dx * ci + dy * si
            disc = b * b - (dx * dx + dy * dy - r * r)
            if disc >= 0.0:
                t = b - math.sqrt(disc)
                if t >= 0.0 and t <= reach and t < best:
                    best = t
        out[i] = best


def first_hits(x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray, edges: np.ndarray, circles: np.ndarray,
               reach: float) -> np.ndarray:
    """Distance from (x, y) along each angle to the first edge (start x, y, vector x, y per
    row) or circle (centre x, y, radius per row) within ``reach``; inf where none is.
    ``x`` and ``y`` may be columns (one origin per angle).

    >>> square = np.array([[1, -1, 0, 2], [1, 1, -2, 0], [-1, 1, 0, -2], [-1, -1, 2, 0]], float) + [2, 0, 0, 0]
    >>> first_hits(0.0, 0.0, np.array([0.0, np.pi]), square, np.array([[-3.0, 0.0, 0.5]]), 5.0).tolist()
    [1.0, 2.5]
    """
    a = np.asarray(angles, dtype=float).reshape(-1)
    n = len(a)
    xs = np.broadcast_to(np.asarray(x, dtype=float).reshape(-1), (n,))
    ys = np.broadcast_to(np.asarray(y, dtype=float).reshape(-1), (n,))
    out = np.empty(n)
    interruptible(_first_hits, np.ascontiguousarray(xs), np.ascontiguousarray(ys), np.cos(a), np.sin(a),
                  np.ascontiguousarray(edges, dtype=float).reshape(-1, 4),
                  np.ascontiguousarray(circles, dtype=float).reshape(-1, 3), float(reach), out)
    return out
