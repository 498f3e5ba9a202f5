"""The world robot's LiDAR, an RPLIDAR A1 turning in the scene, as :mod:`clomp.runtime.backends.world`
describes it: each ray cast at its own time from the body's pose then, a jittered beam, range
noise, dropouts, the crop at ``max_range`` and the rounding to ``resolution``. Each revolution
is a :class:`~clomp.runtime.devices.frame.ScanFrame` of points in the LiDAR's own frame.

Two terms the estimator does not model: the LiDAR sits at ``mount`` (x, y, theta on the
body; ``lidar_x`` ahead of the rotation centre in a preset), where its rays start, and it
returns up to ``far_range`` beyond ``max_range`` (the planning horizon), as an A1 sees
12 m. Neither draws anything.

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
from clomp.runtime.backends._movers import Movers
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
                 max_range: float, resolution: float, rounding: str, sweep: int,
                 mount: Pose3 = (0.0, 0.0, 0.0)) -> None:
        self.noise, self._rng = noise, rng
        self.rays, self.scan_rate, self.max_range = rays, scan_rate, max_range
        self.reach = max_range + noise.far_range  # the farthest return (m); the horizon without far_range
        self.mount = mount
        self.resolution, self.rounding = resolution, rounding
        self.edges, self.circles = obstacle_arrays(scene)
        self.angles = sweep * np.arange(rays) * (2 * math.pi / rays)
        self.streaming: list[tuple[np.ndarray, np.ndarray, float, bool]] | None = None
        self._next_ray = 0
        self._rev_start = 0.0
        self._pending: list[tuple[Any, ...]] = []
        self._raw: list[tuple[Any, ...]] = []  # rays not streamed: origin, draws, time (see _measure)
        self.movers: Movers | None = None  # bodies that move or appear (issue #42): cast at each ray's time

    def cast(self, x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray) -> np.ndarray:
        """Distance along each world angle to the first obstacle within reach, inf when none.

        The obstacles are static, so every ray is intersected with every edge and circle
        at once (numpy) instead of one pymunk segment query per ray: the same first hits,
        at a fraction of the cost (the LiDAR was half of a run's time).
        """
        return first_hits(x, y, angles, self.edges, self.circles, self.reach * 1.2)

    def cast_at(self, x: float | np.ndarray, y: float | np.ndarray, angles: np.ndarray, t: float) -> np.ndarray:
        """:meth:`cast`, the movers included where they are at ``t`` (s)."""
        dist = self.cast(x, y, angles)
        if self.movers is None:
            return dist
        edges, circles = self.movers.outlines(t)
        if not (len(edges) or len(circles)):
            return dist
        out: np.ndarray = np.minimum(dist, first_hits(x, y, angles, edges, circles, self.reach * 1.2))
        return out

    def origin(self, pose: Pose3) -> Pose3:
        """Where the rays start and the LiDAR's heading, the body at ``pose`` (world frame)."""
        mx, my, mth = self.mount
        if not (mx or my or mth):
            return pose
        x, y, th = pose
        c, s = math.cos(th), math.sin(th)
        return x + c * mx - s * my, y + s * mx + c * my, th + mth

    def scan_now(self, x: float, y: float, th: float, t: float = 0.0) -> np.ndarray:
        """A complete revolution from the body at (x, y, th), taken instantly, noise-free (LiDAR
        frame; movers where they are at ``t``)."""
        x, y, th = self.origin((x, y, th))
        r = self.cast_at(x, y, th + self.angles, t)
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
        """The rays due in this step: their origin (the LiDAR's pose now) and noise draws.

        Casting waits for the revolution's end (:meth:`_revolution`), where every ray of
        the revolution is cast from its own origin at once, unless the rays are streamed;
        so does the arithmetic on the draws (the same operations on each ray, once per
        revolution instead of once per physics step).
        """
        n, k = self.noise, i1 - i0
        angle: np.ndarray | None
        rng: np.ndarray | None
        if n.angle_sd and n.range_sd:  # one call, the same draws: the angles' k, then the ranges' k
            z = self._rng.standard_normal(2 * k)
            angle, rng = z[:k], z[k:]
        else:
            angle = self._rng.standard_normal(k) if n.angle_sd else None
            rng = self._rng.standard_normal(k) if n.range_sd else None
        x, y, th = self.origin(pose)
        drop = self._rng.random(k) if n.dropout else None
        if self.streaming is None:
            self._raw.append((x, y, th, k, angle, rng, drop, t))
            return
        nominal = self.angles[i0:i1]
        beam = nominal + n.angle_sd * angle if angle is not None else nominal
        noise = n.range_sd * rng if rng is not None else None
        kept = drop >= n.dropout if drop is not None else None
        batch: tuple[Any, ...] = (x, y, th + beam, nominal, noise, kept, t)
        # cast now: the emulator sends these samples now
        dist = self.cast_at(x, y, th + beam, t)
        if noise is not None:
            dist = dist + noise
        self.streaming.append((nominal, np.where(self._returned(dist, kept), dist, np.inf), t, i0 == 0))
        self._pending.append(batch + (dist,))

    def _raw_arrays(self) -> tuple[Any, ...]:
        """The revolution's rays not streamed, each ray's (x, y, angle, nominal angle, range
        noise, kept, time) as arrays, their draws turned into angles and noise all at once:
        element by element the operations :meth:`_measure` does on a streamed step's rays."""
        raw, n = self._raw, self.noise
        counts = [r[3] for r in raw]
        nominal = self.angles[:sum(counts)]  # a revolution's rays in order, from its first
        beam = nominal + n.angle_sd * np.concatenate([r[4] for r in raw]) if n.angle_sd else nominal
        angles = np.repeat([r[2] for r in raw], counts) + beam
        noise = n.range_sd * np.concatenate([r[5] for r in raw]) if n.range_sd else None
        kept = np.concatenate([r[6] for r in raw]) >= n.dropout if n.dropout else None
        each = [np.repeat([r[k] for r in raw], counts) for k in (0, 1, 7)]
        return each[0], each[1], angles, nominal, noise, kept, each[2], counts

    def _raw_rays(self) -> list[tuple[Any, ...]]:
        """:meth:`_raw_arrays` split back into steps, as :attr:`_pending` holds streamed ones."""
        x, y, angles, nominal, noise, kept, t, counts = self._raw_arrays()
        bounds = np.cumsum(counts)[:-1]
        parts = [np.split(v, bounds) if v is not None else [None] * len(counts) for v in (angles, nominal, noise, kept)]
        return [(r[0], r[1], a, nom, z, keep, r[7]) for r, a, nom, z, keep in zip(self._raw, *parts)]

    def _returned(self, dist: np.ndarray, kept: np.ndarray | None) -> np.ndarray:
        """Which rays gave a return: a range above 0 within ``reach``, not dropped."""
        keep: np.ndarray = np.isfinite(dist) & (dist > 0) & (dist <= self.reach)
        return keep if kept is None else keep & kept

    def _distances(self) -> np.ndarray:
        """The pending rays' ranges (with the range noise), cast now unless streamed."""
        rays = self._pending
        if all(len(r) > 7 for r in rays):  # cast step by step for the stream (noise added)
            return np.concatenate([r[7] for r in rays])
        if self.movers is not None:  # each step's rays against the movers where they were then
            dist = np.concatenate([self.cast_at(r[0], r[1], r[2], r[6]) for r in rays])
        else:
            counts = [len(r[3]) for r in rays]
            x = np.repeat([r[0] for r in rays], counts)[:, None]
            y = np.repeat([r[1] for r in rays], counts)[:, None]
            dist = self.cast(x, y, np.concatenate([r[2] for r in rays]))
        if self.noise.range_sd:
            dist = dist + np.concatenate([r[4] for r in rays])
        return dist

    def _revolution(self) -> tuple[np.ndarray, np.ndarray]:
        """Cast the revolution's rays; its points (LiDAR frame at each ray's time) and times."""
        if self._raw and not self._pending and self.movers is None:  # none streamed: all at once
            x, y, angles, nominal, noise, kept, t, _ = self._raw_arrays()
            self._raw = []
            dist = self.cast(x, y, angles)
            return self._points(dist + noise if noise is not None else dist, nominal, kept, t)
        if self._raw:  # movers (cast step by step), or streaming began mid-revolution: these came first
            self._pending[:0] = self._raw_rays()
            self._raw = []
        rays = self._pending
        if not rays:
            return np.zeros((0, 2)), np.zeros(0)
        counts = [len(r[3]) for r in rays]
        return self._points(self._distances(), np.concatenate([r[3] for r in rays]),
                            np.concatenate([r[5] for r in rays]) if self.noise.dropout else None,
                            np.repeat([r[6] for r in rays], counts))

    def _points(self, dist: np.ndarray, nominal: np.ndarray, kept: np.ndarray | None,
                t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The rays' returns as points (LiDAR frame) and their times: ranges rounded as an A1 does."""
        keep = self._returned(dist, kept)
        dist, a = dist[keep], nominal[keep]
        grid = self.resolution > 0 and self.rounding == "grid"
        if self.resolution > 0 and not grid:  # the range as an A1 reports it, along the beam it names
            dist = np.round(dist / self.resolution) * self.resolution
        pts = polar_to_xy(dist, a)
        return (np.round(pts / self.resolution) * self.resolution if grid else pts), t[keep]
