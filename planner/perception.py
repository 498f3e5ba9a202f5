"""Perception: a LiDAR scan becomes obstacle disturbances.

A scan is an N×2 array of points (metres, robot frame: x forward, y left). It is
validated, cropped to the sensor range, de-duplicated and clustered (points closer than
``cluster_distance`` belong to one object). Each cluster is covered tightly by thin
oriented boxes: a cluster is split along its principal axis until every piece is thin,
so a slanted wall becomes a slanted slab and an L-shaped corner two slabs, never one fat
axis-aligned box that would close a corridor.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from formal.model import Disturbance, DisturbanceKind

__all__ = ["ScanError", "Obstacles", "load_scan", "validate_scan", "perceive"]

# a piece whose points lie within this distance of its principal axis is "thin"
_THIN = 0.02
# half-thickness given to a piece made of collinear points (LiDAR returns are surfaces)
_MIN_HALF = 0.01


class ScanError(ValueError):
    """A scan cannot be read or is not a valid N×2 array of finite coordinates."""


def validate_scan(points: object, name: str = "scan") -> np.ndarray:
    """Return ``points`` as a float64 N×2 array, or raise :class:`ScanError` saying why."""
    try:
        arr = np.asarray(points, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ScanError(f"{name}: not numeric ({exc})") from None
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ScanError(f"{name}: expected an N×2 array of x, y, got shape {arr.shape}")
    bad = ~np.isfinite(arr).all(axis=1)
    if bad.any():
        i = int(np.argmax(bad))
        raise ScanError(f"{name}: point {i} is not finite ({arr[i, 0]}, {arr[i, 1]})")
    return arr


def load_scan(source: str | os.PathLike[str] | np.ndarray) -> np.ndarray:
    """Read a scan: a text file of ``x y`` lines (tab or spaces), a ``.npy`` N×2 array,
    or an array. An empty file is a scan with no returns (free space)."""
    if not isinstance(source, (str, os.PathLike)):
        return validate_scan(source)
    path = Path(source)
    if not path.exists():
        raise ScanError(f"{path}: no such file")
    if path.is_dir():
        raise ScanError(f"{path}: is a folder, not a scan file")
    if path.suffix == ".npy":
        try:
            data = np.load(path, allow_pickle=False)
        except (ValueError, OSError) as exc:
            raise ScanError(f"{path}: not a readable .npy array ({exc})") from None
        return validate_scan(data, str(path))
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError:
        raise ScanError(f"{path}: not a text scan file (binary content)") from None
    rows: list[tuple[float, float]] = []
    for lineno, line in enumerate(text.splitlines(), 1):
        stripped = line.split("#", 1)[0].strip()
        if not stripped:
            continue
        parts = stripped.replace(",", " ").split()
        if len(parts) != 2:
            raise ScanError(f"{path}:{lineno}: expected two numbers 'x y', got {line.strip()!r}")
        try:
            x, y = float(parts[0]), float(parts[1])
        except ValueError:
            raise ScanError(f"{path}:{lineno}: not a number in {line.strip()!r}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ScanError(f"{path}:{lineno}: coordinate is not finite in {line.strip()!r}")
        rows.append((x, y))
    return np.array(rows, dtype=np.float64).reshape(-1, 2)


@dataclass(frozen=True)
class Obstacles:
    """The obstacle disturbances of one scan, with arrays for fast corridor filtering.

    ``boxes`` is M×4×2 (the corners of each oriented box, counter-clockwise),
    ``centres`` M×2 and ``radii`` M (circumradius of each box). ``disturbances[i]`` is
    the :class:`Disturbance` of box ``i`` (its ident is ``i``).
    """

    boxes: np.ndarray
    centres: np.ndarray
    radii: np.ndarray
    disturbances: tuple[Disturbance, ...]

    def __len__(self) -> int:
        return len(self.disturbances)

    @classmethod
    def from_boxes(cls, boxes: list[np.ndarray] | np.ndarray) -> "Obstacles":
        """Build from a list of 4×2 convex quadrilaterals (counter-clockwise)."""
        arr = np.asarray(boxes, dtype=np.float64).reshape(-1, 4, 2)
        centres = arr.mean(axis=1)
        radii = np.linalg.norm(arr - centres[:, None, :], axis=2).max(axis=1) if len(arr) else np.zeros(0)
        dist = tuple(
            Disturbance(
                DisturbanceKind.OBSTACLE,
                float(c[0]),
                float(c[1]),
                tuple((float(x), float(y)) for x, y in b),
                i,
            )
            for i, (b, c) in enumerate(zip(arr, centres))
        )
        return cls(arr, centres, radii, dist)

    def contains_point(self, x: float, y: float, margin: float = 0.0) -> int | None:
        """The index of a box containing (x, y) (grown by ``margin``), or None."""
        for i, box in enumerate(self.boxes):
            if _point_in_convex(box, x, y, margin):
                return i
        return None


def _point_in_convex(box: np.ndarray, x: float, y: float, margin: float) -> bool:
    n = len(box)
    for k in range(n):
        ax, ay = box[k]
        bx, by = box[(k + 1) % n]
        ex, ey = bx - ax, by - ay
        norm = math.hypot(ex, ey) or 1.0
        # signed distance to the left of the edge (inside for a CCW polygon)
        if (ex * (y - ay) - ey * (x - ax)) / norm < -margin:
            return False
    return True


def _clusters(points: np.ndarray, eps: float) -> list[np.ndarray]:
    """Single-linkage clusters: points closer than ``eps`` to each other share one.

    Neighbour pairs come from a k-d tree; components are found by min-label
    propagation with pointer jumping (a few vectorised passes, no Python loop per point).
    """
    n = len(points)
    if n == 0:
        return []
    pairs = cKDTree(points).query_pairs(eps, output_type="ndarray")
    labels = np.arange(n)
    if len(pairs):
        a, b = pairs[:, 0], pairs[:, 1]
        while True:
            m = np.minimum(labels[a], labels[b])
            new = labels.copy()
            np.minimum.at(new, a, m)
            np.minimum.at(new, b, m)
            new = new[new]
            if np.array_equal(new, labels):
                break
            labels = new
    order = np.argsort(labels, kind="stable")
    bounds = np.flatnonzero(np.diff(labels[order])) + 1
    return [points[idx] for idx in np.split(order, bounds)]


def _cover(points: np.ndarray, out: list[np.ndarray], gap: float, depth: int = 0) -> None:
    """Cover ``points`` with thin oriented boxes.

    A piece is split where its points leave a gap wider than ``gap`` along its principal
    axis (two parallel walls of one cluster must not be bridged by a box across the
    space between them), else at the median while it is thicker than a thin slab.
    """
    centre = points.mean(axis=0)
    rel = points - centre
    if len(points) >= 2:
        # principal axis of the 2×2 covariance in closed form
        sxx = float(rel[:, 0] @ rel[:, 0])
        syy = float(rel[:, 1] @ rel[:, 1])
        sxy = float(rel[:, 0] @ rel[:, 1])
        phi = 0.5 * math.atan2(2 * sxy, sxx - syy)
        axis = np.array([math.cos(phi), math.sin(phi)])
    else:
        axis = np.array([1.0, 0.0])
    normal = np.array([-axis[1], axis[0]])
    u = rel @ axis
    t = rel @ normal
    if len(points) > 1 and depth < 24:
        us = np.sort(u)
        gaps = np.diff(us)
        k = int(np.argmax(gaps))
        if gaps[k] > gap:
            below = u <= us[k]
            _cover(points[below], out, gap, depth + 1)
            _cover(points[~below], out, gap, depth + 1)
            return
    if len(points) > 2 and depth < 24 and (t.max() - t.min()) > 2 * _THIN:
        cut = np.median(u)
        below = u <= cut
        if below.any() and not below.all():
            _cover(points[below], out, gap, depth + 1)
            _cover(points[~below], out, gap, depth + 1)
            return
    u0, u1 = u.min() - _MIN_HALF, u.max() + _MIN_HALF
    t0, t1 = t.min() - _MIN_HALF, t.max() + _MIN_HALF
    # counter-clockwise: (axis, normal) is a right-handed frame
    out.append(
        np.array([centre + a * axis + b * normal for a, b in ((u0, t0), (u1, t0), (u1, t1), (u0, t1))])
    )


def perceive(
    points: np.ndarray,
    sensor_range: float = 1.1,
    cluster_distance: float = 0.1,
) -> Obstacles:
    """Turn a scan into obstacle disturbances (see the module docstring).

    Points beyond ``sensor_range`` are dropped (the paper's robot ignored them), as are
    returns at the sensor itself (closer than 1 mm).
    """
    pts = validate_scan(points)
    if len(pts):
        r = np.hypot(pts[:, 0], pts[:, 1])
        pts = pts[(r <= sensor_range) & (r > 1e-3)]
        # de-duplicate on a 0.1 mm grid, keeping scan order (recorded scans repeat points)
        k = np.round(pts * 1e4).astype(np.int64)
        _, first = np.unique(k[:, 0] * (1 << 32) + k[:, 1], return_index=True)
        pts = pts[np.sort(first)]
    boxes: list[np.ndarray] = []
    for cluster in _clusters(pts, cluster_distance):
        _cover(cluster, boxes, cluster_distance)
    return Obstacles.from_boxes(boxes)
