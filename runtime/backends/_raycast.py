"""Ray casting for the world's LiDAR: the first edge or circle along each beam.

>>> import numpy as np
>>> first_hits(0.0, 0.0, np.array([0.0]), np.array([[1.0, -1.0, 0.0, 2.0]]), np.zeros((0, 3)), 5.0).tolist()
[1.0]
"""

from __future__ import annotations

import numpy as np

__all__ = ["first_hits"]


def first_hits(x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray, edges: np.ndarray, circles: np.ndarray,
               reach: float) -> np.ndarray:
    """Distance from (x, y) along each angle to the first edge (start x, y, vector x, y per
    row) or circle (centre x, y, radius per row) within ``reach``; inf where none is.
    ``x`` and ``y`` may be columns (one origin per angle).

    >>> square = np.array([[1, -1, 0, 2], [1, 1, -2, 0], [-1, 1, 0, -2], [-1, -1, 2, 0]], float) + [2, 0, 0, 0]
    >>> first_hits(0.0, 0.0, np.array([0.0, np.pi]), square, np.array([[-3.0, 0.0, 0.5]]), 5.0).tolist()
    [1.0, 2.5]
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
