"""The local map of :class:`~clomp.runtime.estimation.odometry.ScanOdometry`: how a matched
revolution joins it and how wrong the surfaces a revolution meets may be.

A mixin, split out of :mod:`clomp.runtime.estimation.odometry` unchanged (the module neared
its 600-line limit): :class:`ScanOdometry` holds the state these methods read and write
(the map's points, their k-d tree, each point's uncertainty, and the matcher's
:class:`~clomp.runtime.estimation.icp.ReferenceScan` of them).

>>> from clomp.runtime.estimation.odometry import ScanOdometry
>>> issubclass(ScanOdometry, LocalMap)
True
"""

from __future__ import annotations

import math

import numpy as np
from scipy.spatial import cKDTree

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose
from clomp.runtime.estimation._exact import median
from clomp.runtime.estimation.doubt import Doubt, see_through
from clomp.runtime.estimation.ekf import OdometryFilter
from clomp.runtime.estimation.icp import ReferenceScan

__all__ = ["LocalMap"]


class LocalMap:
    """The map-building half of :class:`~clomp.runtime.estimation.odometry.ScanOdometry`
    (see there for the settings it reads)."""

    min_points: int
    map_radius: float
    map_resolution: float
    new_surface: float
    filter: OdometryFilter
    doubt: Doubt
    _map: ReferenceScan | None
    _map_points: np.ndarray | None
    _map_tree: cKDTree | None
    _map_sds: np.ndarray | None
    pose: Pose

    def sees_past(self, points: np.ndarray) -> tuple[int, int]:
        """How many bearings of a revolution ``points`` (robot frame) seen at the estimate look
        past a surface the map holds (:func:`~clomp.runtime.estimation.doubt.see_through`), and
        at how many the map holds one; (0, 0) before there is a map."""
        if self._map_points is None:
            return 0, 0
        return see_through(self._map_points, points, self.pose)

    def _add(self, points: np.ndarray, pose: Pose, reseed: bool) -> bool:
        """Put a revolution seen from ``pose`` into the map (1 cm grid, within ``map_radius``)."""
        if len(points) < self.min_points:
            return False
        world = points_from_frame(points, pose)
        old = self._map_points if (self._map_points is not None and not reseed) else np.zeros((0, 2))
        old_sds = self._map_sds if (self._map_sds is not None and not reseed) else np.zeros((0, 3))
        if len(old) and self._map is not None and len(self._map):
            # only surfaces the map does not hold yet: re-adding known ones would smear them
            # along the robot's estimation error and let the estimate drift with them
            d, _ = self._tree().query(world, distance_upper_bound=self.new_surface)
            new = ~np.isfinite(d)
            if not new.any():
                return False
            points, world = points[new], world[new]  # each point's uncertainty below is its own arithmetic
        # how wrong each new point may be: the honest position sd and the heading's at its range
        hon = self.filter.honest
        pos_var = max(float(np.linalg.eigvalsh(hon[:2, :2])[-1]), self.doubt.sd ** 2)  # in doubt, the doubt
        th_var = max(float(hon[2, 2]), 0.0)
        rng2 = np.einsum("ij,ij->i", points, points)
        sds = np.column_stack((np.sqrt(pos_var + rng2 * th_var), np.full(len(points), math.sqrt(th_var)),
                               np.arctan2(world[:, 1] - pose.y, world[:, 0] - pose.x)))  # seen from this side
        cells, first = np.unique(np.round(np.r_[old, world] / self.map_resolution), axis=0, return_index=True)
        merged = cells * self.map_resolution
        merged_sds = np.r_[old_sds, sds][first]  # a cell the map held keeps its own
        near = np.hypot(merged[:, 0] - pose.x, merged[:, 1] - pose.y) <= self.map_radius
        merged, merged_sds = merged[near], merged_sds[near]
        if self._map_points is not None and not reseed and len(merged) == len(self._map_points):
            return False  # nothing new
        self._map_points, self._map_tree, self._map_sds = merged, None, merged_sds
        self._map = ReferenceScan(merged)
        return True

    def _tree(self) -> cKDTree:
        """The k-d tree of the map's points, built when first asked after the map changed (one
        per map, not one per revolution). Built unbalanced and without shrinking its nodes to
        the points (scipy's ``balanced_tree`` and ``compact_nodes`` off), which costs half as
        much: a nearest point found in it, and its distance, are those scipy's default tree
        finds, but where two map points are exactly as near (:meth:`_map_sd` asks that tree then)."""
        if self._map_tree is None:
            self._map_tree = cKDTree(self._map_points, balanced_tree=False, compact_nodes=False)
        return self._map_tree

    def _map_sd(self, points: np.ndarray, pose: Pose) -> tuple[float, float]:
        """How wrong the surfaces a revolution seen from ``pose`` meets may be (m, rad): the
        median over its points of the map points they meet (within 5 cm), each as uncertain
        as the estimate that drew it (0 for the start's seed)."""
        if self._map_points is None or self._map_sds is None or not len(self._map_points) or not len(points):
            return (0.0, 0.0)
        seen = points_from_frame(points, pose)
        d2, idx2 = self._tree().query(seen, k=2, distance_upper_bound=0.05)
        d, idx = d2[:, 0], idx2[:, 0]
        if bool((np.isfinite(d) & (d == d2[:, 1])).any()):
            # two map points equally near a point: which one counts is the tree's choice, and
            # the map's tree was built balanced and compacted (scipy's default) until issue
            # #41; that tree chooses here, so that the answer stays the one it gave
            d, idx = cKDTree(self._map_points).query(seen, distance_upper_bound=0.05)
        hit = np.isfinite(d)
        if not hit.any():
            return (0.0, 0.0)
        sds = self._map_sds[idx[hit]]
        return (median(sds[:, 0]), median(sds[:, 1]))  # float(np.median(...)), bit for bit
