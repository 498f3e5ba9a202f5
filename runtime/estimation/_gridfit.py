"""A revolution's misfit to the map at every pose of a grid: shared by the re-localisation
after a kick (:func:`~clomp.runtime.estimation.relocalise.relocalise`) and the test of a
revolution seeing surfaces nearer than the map holds them
(:func:`~clomp.runtime.estimation.seethrough.see_nearer`).

Each pose's misfit is each point's squared distance to the nearest map point (a distance
field on a grid of half the search's step, so thousands of poses cost one lookup each),
in ``sd``, at most ``reach`` sd, over ``correlation`` (neighbouring points counted as one).

>>> wall = np.array([[0.5, y] for y in np.linspace(-0.3, 0.3, 31)])
>>> g = misfit_grid(wall, wall - [0.1, 0.0], Pose(0.0, 0.0, 0.0), radius=0.2, headings=(0.0,))
>>> h, a, b = np.unravel_index(int(np.argmin(g.cost)), g.cost.shape)
>>> round(float(g.offsets[a]), 2), round(float(g.offsets[b]), 2)   # it stands 0.1 m nearer the wall
(0.1, 0.0)
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from scipy.ndimage import distance_transform_edt

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose

__all__ = ["MisfitGrid", "distance_field", "misfit_grid"]


class MisfitGrid(NamedTuple):
    """:func:`misfit_grid`'s result: ``cost[h, a, b]`` the misfit at the ``h``-th heading and
    the offsets ``offsets[a]`` along x, ``offsets[b]`` along y (m, map frame) from the pose."""

    cost: np.ndarray
    offsets: np.ndarray


def distance_field(map_points: np.ndarray, lo: np.ndarray, hi: np.ndarray, res: float, cap: float) -> np.ndarray:
    """The distance (m, at most ``cap``) from each cell of a ``res`` grid spanning ``lo``..``hi``
    to the nearest map point: the misfit of a point that falls there, looked up at once."""
    shape = np.ceil((hi - lo) / res).astype(int) + 1
    occupied = np.ones(tuple(shape), dtype=bool)
    k = np.floor((map_points - lo) / res + 0.5).astype(int)
    inside = np.all((k >= 0) & (k < shape), axis=1)
    occupied[k[inside, 0], k[inside, 1]] = False
    out: np.ndarray = np.minimum(distance_transform_edt(occupied) * res, cap)
    return out


def misfit_grid(ref: np.ndarray, pts: np.ndarray, pose: Pose, *, radius: float = 0.4, step: float = 0.02,
                headings: tuple[float, ...] = (0.0,), sd: float = 0.02, correlation: float = 4.0, reach: float = 3.0,
                most_points: int = 100) -> MisfitGrid:
    """The misfit (see the module docstring) of the revolution ``pts`` (robot frame) over
    ``ref`` (map frame) at every pose ``step`` m apart within ``radius`` m of ``pose`` (a
    square), at each heading ``pose.theta + h`` of ``headings``; scored on every k-th point
    (at most ``most_points``), scaled as if all were."""
    res, cap = step / 2, reach * sd
    few = pts[:: -(-len(pts) // most_points)]  # the grid is scored on at most ``most_points`` of them
    seen = [points_from_frame(few, Pose(pose.x, pose.y, pose.theta + h)) for h in headings]
    every = np.vstack([ref, *seen])
    lo, hi = every.min(axis=0) - radius - cap - res, every.max(axis=0) + radius + cap + res
    dist = distance_field(ref, lo, hi, res, cap)
    offs = np.arange(-round(radius / step), round(radius / step) + 1) * round(step / res)
    cost = np.empty((len(headings), len(offs), len(offs)))
    for i, w in enumerate(seen):
        k = np.floor((w - lo) / res + 0.5).astype(int)
        d = dist[k[:, 0, None, None] + offs[None, :, None], k[:, 1, None, None] + offs[None, None, :]]
        cost[i] = np.sum(d * d, axis=0) / (sd * sd) / correlation * (len(pts) / len(few))  # as if all were scored
    return MisfitGrid(cost, offs * res)
