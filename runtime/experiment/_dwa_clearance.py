"""The dwa condition's clearance check: how near the inflated body comes to a scan point along each arc.

:func:`arc_clearance_numpy` states the rule with numpy (every arc × pose × point at once, as
the condition first computed it); :func:`arc_clearance` computes each arc's smallest
clearance in one compiled loop (numba, :mod:`clomp.runtime.jit`) with the same
floating-point operations — each difference and product rounded on its own as numpy's
element-wise loops round it, the pose's cosine and sine numpy's own (computed before the
compiled call), ``hypot`` the C library's, as numpy's — so the two agree bit for bit
(``tests/runtime/test_dwa_clearance.py``). The loop skips work that cannot change the arc's
minimum: ``hypot`` wherever its larger leg already reaches the arc's least distance so far (a
faithfully rounded ``hypot`` is never below its larger leg; with a zero leg it is the other
leg exactly, C99 F.9.4.3), and the rest of the arc once a point touches. The controller asks
for less still, and gets it exactly: its score reads a clearance only up to 0.3 m (``cap``)
and only on arcs that keep the margin (``stop``: an arc within it is dropped whatever its
distance), so the loop starts each arc at the cap and leaves it at the margin. The numpy
statement took about 90 % of a dwa run's CPU (an arcs × poses × points broadcast, about
18 ms a control tick; the loop 0.1 ms).

>>> import numpy as np
>>> body = (0.1, 0.09, 0.01, 0.18)  # rear offset, front offset, clearance, width
>>> pts = np.array([[0.5, 0.0]])
>>> x, y, th = np.array([[0.1, 0.2]]), np.zeros((1, 2)), np.zeros((1, 2))
>>> arc_clearance(pts, x, y, th, body).round(3).tolist(), arc_clearance_numpy(pts, x, y, th, body).round(3).tolist()
([0.2], [[0.3, 0.2]])
"""

from __future__ import annotations

import math

import numpy as np

from clomp.runtime.jit import compiled, interruptible

__all__ = ["Body", "arc_clearance", "arc_clearance_numpy"]

Body = tuple[float, float, float, float]
"""The inflated body: ``(rear_offset, front_offset, clearance, width)`` (m)."""


def arc_clearance_numpy(pts: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray, body: Body) -> np.ndarray:
    """Per arc and pose (``x``, ``y``, ``th``: (N, T)), the smallest distance (m) from the inflated
    body to a point of ``pts`` (P, 2) (0: a hit; inf without points). The reference of :func:`arc_clearance`.

    >>> arc_clearance_numpy(np.zeros((0, 2)), np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), (0.1, 0.09, 0.01, 0.18)).tolist()
    [[inf]]
    """
    if len(pts) == 0:
        return np.full(x.shape, np.inf)
    rear, front, clearance, width = body
    c, s = np.cos(th)[..., None], np.sin(th)[..., None]
    dx, dy = pts[:, 0] - x[..., None], pts[:, 1] - y[..., None]  # (N, T, P)
    bx, by = c * dx + s * dy, -s * dx + c * dy
    ox = np.maximum(np.maximum(-rear - clearance - bx, bx - front - clearance), 0.0)
    oy = np.maximum(np.abs(by) - width / 2 - clearance, 0.0)
    inside = (ox == 0) & (oy == 0)
    d = np.where(inside, 0.0, np.hypot(ox, oy))
    out: np.ndarray = d.min(axis=2)
    return out


def arc_clearance(pts: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray, body: Body, cap: float = math.inf,
                  stop: float = 0.0) -> np.ndarray:
    """Per arc (``x``, ``y``, ``th``: (N, T) poses along it), the smallest distance (m) from the
    inflated body to a point of ``pts`` (P, 2) at any of its poses: ``arc_clearance_numpy(...).min(axis=1)``
    bit for bit, compiled (see the module) — where that is above ``stop`` (an arc that comes
    within ``stop`` gets some distance at most ``stop``: the loop stops there) and at most
    ``cap`` (a larger one is ``cap``). The defaults give the exact minimum.

    >>> arc_clearance(np.array([[0.0, 0.0]]), np.zeros((1, 1)), np.zeros((1, 1)), np.zeros((1, 1)), (0.1, 0.09, 0.01, 0.18)).tolist()
    [0.0]
    """
    rear, front, clearance, width = (float(b) for b in body)
    out = np.empty(x.shape[0])
    p = np.ascontiguousarray(pts, dtype=np.float64).reshape(-1, 2)
    xs, ys = (np.ascontiguousarray(a, dtype=np.float64) for a in (x, y))
    c, s = np.ascontiguousarray(np.cos(th), dtype=np.float64), np.ascontiguousarray(np.sin(th), dtype=np.float64)
    interruptible(_arc_clearance, p, xs, ys, c, s, -rear - clearance, front, clearance, width / 2, float(cap), float(stop), out)
    return out


@compiled
def _arc_clearance(pts: np.ndarray, x: np.ndarray, y: np.ndarray, c: np.ndarray, s: np.ndarray, back: float, front: float,
                   clearance: float, half: float, cap: float, stop: float, out: np.ndarray) -> None:  # pragma: no cover - compiled
    for i in range(x.shape[0]):
        best = cap  # the arc's least distance so far
        for j in range(x.shape[1]):
            xi, yi, ci, si = x[i, j], y[i, j], c[i, j], s[i, j]
            for k in range(pts.shape[0]):
                dx, dy = pts[k, 0] - xi, pts[k, 1] - yi
                bx, by = ci * dx + si * dy, -si * dx + ci * dy
                ox = max(max(back - bx, bx - front - clearance), 0.0)
                oy = max(abs(by) - half - clearance, 0.0)
                if ox == 0.0:
                    d = oy  # 0 inside (never -0.0: x - x is +0); hypot(0, oy) is oy
                elif oy == 0.0:
                    d = ox
                elif ox >= best or oy >= best:
                    continue  # hypot(ox, oy) >= max(ox, oy) >= best
                else:
                    d = math.hypot(ox, oy)
                if d < best:
                    best = d
                    if best <= stop:
                        break
            if best <= stop:
                break
        out[i] = best
