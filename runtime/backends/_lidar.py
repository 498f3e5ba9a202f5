"""The world robot's LiDAR, an RPLIDAR A1 turning in the scene, as :mod:`clomp.runtime.backends.world`
describes it: each ray cast at its own time from the body's pose then, a jittered beam, range
noise, dropouts, the crop at ``max_range`` and the rounding to ``resolution``. Each revolution
is a :class:`~clomp.runtime.devices.frame.ScanFrame`.

>>> import numpy as np
>>> from clomp.planner.noise import NoiseTerms
>>> from clomp.planner.scenarios import load_scenario
>>> lidar = Lidar(load_scenario("corridor"), NoiseTerms(), np.random.default_rng(0), rays=360, scan_rate=5.5,
...               max_range=1.1, resolution=0.0, rounding="range", sweep=1)
>>> bool(np.isfinite(lidar.cast(0.0, 0.0, np.array([np.pi / 2]))[0]))   # a corridor wall beside the start
True
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from clomp.formal.geometry import polar_to_xy
from clomp.planner.noise import NoiseTerms
from clomp.planner.scenarios import Scene
from clomp.runtime.backends._raycast import first_hits
from clomp.runtime.devices.frame import ScanFrame

__all__ = ["Lidar", "obstacle_arrays"]

Pose3 = tuple[float, float, float]


def obstacle_arrays(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The scene's polygon edges (start x, y, vector x, y per row) and circles (centre x,
    y, radius per row), for casting every ray against every obstacle at once."""
    edges: list[tuple[float, float, float, float]] = []
    circles: list[tuple[float, float, float]] = []
    for s in scene.shapes:
        if s.kind == "circle":
            circles.append((float(s.center[0]), float(s.center[1]), float(s.radius)))
        else:
            v = s.vertices
            edges += [(float(v[k][0]), float(v[k][1]), float(v[(k + 1) % len(v)][0] - v[k][0]),
                       float(v[(k + 1) % len(v)][1] - v[k][1])) for k in range(len(v))]
    return np.array(edges, dtype=float).reshape(-1, 4), np.array(circles, dtype=float).reshape(-1, 3)


class Lidar:
    """The A1 in a scene (see the module): rays due each physics step, revolutions, a stream.

    Its noise draws come from ``rng`` (the world's), made in the physics step that measures
    the rays, in the order they always were, so a seed gives the same scans.
    """

    def __init__(self, scene: Scene, noise: NoiseTerms, rng: np.random.Generator, *, rays: int, scan_rate: float,
                 max_range: float, resolution: float, rounding: str, sweep: int) -> None:
        self.noise, self._rng = noise, rng
        self.rays, self.scan_rate, self.max_range = rays, scan_rate, max_range
        self.resolution, self.rounding = resolution, rounding
        self.edges, self.circles = obstacle_arrays(scene)
        self.angles = sweep * np.arange(rays) * (2 * math.pi / rays)
        self.streaming: list[tuple[np.ndarray, np.ndarray, float, bool]] | None = None
        self._next_ray = 0
        self._rev_start = 0.0
        self._pending: list[tuple[Any, ...]] = []

    def cast(self, x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Distance along each world angle to the first obstacle within reach, inf when none.

        The obstacles are static, so every ray is intersected with every edge and circle
        at once (numpy) instead of one pymunk segment query per ray: the same first hits,
        at a fraction of the cost (the LiDAR was half of a run's time).
        """
        return first_hits(x, y, angles, self.edges, self.circles, self.max_range * 1.2)

    def scan_now(self, x: float, y: float, th: float) -> np.ndarray:
        """A complete revolution from (x, y, th), taken instantly, noise-free (robot frame)."""
        r = self.cast(x, y, th + self.angles)
        ok = np.isfinite(r)
        a = self.angles[ok]
        return polar_to_xy(r[ok], a)

    def step(self, t: float, pose: Pose3) -> ScanFrame | None:
        """Measure the rays due by ``t`` from ``pose``; the revolution when this step ends one."""
        period = 1.0 / self.scan_rate
        due = int(min(self.rays, math.floor((t - self._rev_start) / period * self.rays + 1e-9)))
        if due > self._next_ray:
            self._measure(self._next_ray, due, t, pose)
            self._next_ray = due
        if self._next_ray < self.rays:
            return None
        pts, times = self._revolution()
        self._pending = []
        self._next_ray = 0
        self._rev_start += period
        return ScanFrame(pts, t, point_times=times - t)

    def _measure(self, i0: int, i1: int, t: float, pose: Pose3) -> None:
        """The rays due in this step: their origin (the body's pose now) and noise draws.

        Casting waits for the revolution's end (:meth:`_revolution`), where every ray of
        the revolution is cast from its own origin at once, unless the rays are streamed.
        """
        n, k = self.noise, i1 - i0
        nominal = self.angles[i0:i1]
        beam = nominal + n.angle_sd * self._rng.standard_normal(k) if n.angle_sd else nominal
        x, y, th = pose
        noise = n.range_sd * self._rng.standard_normal(k) if n.range_sd else None
        kept = self._rng.random(k) >= n.dropout if n.dropout else None
        batch: tuple[Any, ...] = (x, y, th + beam, nominal, noise, kept, t)
        if self.streaming is not None:  # cast now: the emulator sends these samples now
            dist = self.cast(x, y, th + beam)
            if noise is not None:
                dist = dist + noise
            self.streaming.append((nominal, np.where(self._returned(dist, kept), dist, np.inf), t, i0 == 0))
            batch += (dist,)
        self._pending.append(batch)

    def _returned(self, dist: np.ndarray, kept: np.ndarray | None) -> np.ndarray:
        """Which rays gave a return: a range above 0 within ``max_range``, not dropped."""
        keep: np.ndarray = np.isfinite(dist) & (dist > 0) & (dist <= self.max_range)
        return keep if kept is None else keep & kept

    def _distances(self) -> np.ndarray:
        """The pending rays' ranges (with the range noise), cast now unless streamed."""
        rays = self._pending
        if all(len(r) > 7 for r in rays):  # cast step by step for the stream (noise added)
            return np.concatenate([r[7] for r in rays])
        counts = [len(r[3]) for r in rays]
        x = np.repeat([r[0] for r in rays], counts)[:, None]
        y = np.repeat([r[1] for r in rays], counts)[:, None]
        dist = self.cast(x, y, np.concatenate([r[2] for r in rays]))
        if self.noise.range_sd:
            dist = dist + np.concatenate([r[4] for r in rays])
        return dist

    def _revolution(self) -> tuple[np.ndarray, np.ndarray]:
        """Cast the revolution's rays; its points (robot frame at each ray's time) and times."""
        rays = self._pending
        if not rays:
            return np.zeros((0, 2)), np.zeros(0)
        counts = [len(r[3]) for r in rays]
        nominal = np.concatenate([r[3] for r in rays])
        t = np.repeat([r[6] for r in rays], counts)
        dist = self._distances()
        keep = self._returned(dist, np.concatenate([r[5] for r in rays]) if self.noise.dropout else None)
        dist, a = dist[keep], nominal[keep]
        grid = self.resolution > 0 and self.rounding == "grid"
        if self.resolution > 0 and not grid:  # the range as an A1 reports it, along the beam it names
            dist = np.round(dist / self.resolution) * self.resolution
        pts = polar_to_xy(dist, a)
        return (np.round(pts / self.resolution) * self.resolution if grid else pts), t[keep]
