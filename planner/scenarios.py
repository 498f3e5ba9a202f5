"""Scenes: worlds of walls, boxes, circles and polygons, with a start pose and a goal.

A scene is what the planner's built-in scenarios and the simulated robot share. It is
read from a JSON scenario file (format documented in ``specs/scenarios/README.md``) and
can produce the LiDAR scan the robot would see from a pose (exact ray casting).
Built-in scenarios are the files shipped in ``specs/scenarios/``.
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from clomp.formal.geometry import points_to_frame, polar_to_xy
from clomp.formal.model import Pose
from clomp.planner.inputs import MAX_JSON_BYTES, load_json, read_text

__all__ = ["ScenarioError", "Shape", "Scene", "load_scenario", "builtin_scenarios", "scenario_path"]


class ScenarioError(ValueError):
    """A scenario file is missing, unreadable, or has an invalid field (named in the message).

    >>> try:
    ...     load_scenario("nope")
    ... except ScenarioError as exc:
    ...     print(exc)
    unknown scenario 'nope'; built in: blocked, corridor, ...
    """


@dataclass(frozen=True)
class Shape:
    """An obstacle of the scene: a convex polygon (CCW vertices) or a circle."""

    kind: str  # "polygon" | "circle"
    vertices: tuple[tuple[float, float], ...] = ()
    center: tuple[float, float] = (0.0, 0.0)
    radius: float = 0.0

    def contains(self, x: float, y: float) -> bool:
        """True when (x, y) is inside (or on) the shape."""
        if self.kind == "circle":
            return math.hypot(x - self.center[0], y - self.center[1]) <= self.radius
        v = self.vertices
        for k in range(len(v)):
            ax, ay = v[k]
            bx, by = v[(k + 1) % len(v)]
            if (bx - ax) * (y - ay) - (by - ay) * (x - ax) < 0:
                return False
        return True


@dataclass(frozen=True)
class Scene:
    """A world: obstacles, the robot's start pose and the goal (world frame).

    >>> scene = load_scenario("overtaking")
    >>> scene.name, len(scene.shapes) > 0, scene.scan().shape[1]
    ('overtaking', True, 2)
    >>> scene.goal_in_robot_frame() == scene.goal   # the robot starts at the origin, facing +x
    True
    """

    name: str
    shapes: tuple[Shape, ...]
    goal: tuple[float, float]
    start: Pose = Pose(0.0, 0.0, 0.0)
    description: str = ""
    raw: dict[str, Any] = field(default_factory=dict, compare=False)

    def goal_in_robot_frame(self, pose: Pose | None = None) -> tuple[float, float]:
        """The goal seen from ``pose`` (default the start): x forward, y left."""
        p = self.start if pose is None else pose
        x, y = to_robot_frame(p, np.array([self.goal]))[0].tolist()
        return x, y

    def scan(self, pose: Pose | None = None, rays: int = 360, max_range: float = 1.1) -> np.ndarray:
        """The points a 2-D LiDAR at ``pose`` would return (robot frame), ``rays`` per turn.

        Exact ray casting against every shape; rays that hit nothing within
        ``max_range`` return no point.
        """
        p = self.start if pose is None else pose
        angles = p.theta + np.arange(rays) * (2 * math.pi / rays)
        ranges = self.raycast(np.array([p.x, p.y]), angles, max_range)
        ok = np.isfinite(ranges)
        local = angles[ok] - p.theta
        pts = polar_to_xy(ranges[ok], local)
        return pts

    def raycast(self, origin: np.ndarray, angles: np.ndarray, max_range: float) -> np.ndarray:
        """Distance to the first hit along each angle (world frame), inf when none."""
        d = np.c_[np.cos(angles), np.sin(angles)]
        best = np.full(len(angles), np.inf)
        segs = []
        for s in self.shapes:
            if s.kind == "polygon":
                v = np.array(s.vertices)
                segs.append(np.c_[v, np.roll(v, -1, axis=0)])
            else:
                oc = origin - np.array(s.center)
                bq = d @ oc
                cq = oc @ oc - s.radius**2
                disc = bq * bq - cq
                with np.errstate(invalid="ignore"):
                    t = -bq - np.sqrt(disc)
                t = np.where((disc >= 0) & (t >= 0), t, np.inf)
                best = np.minimum(best, t)
        if segs:
            seg = np.concatenate(segs)  # S×4: ax ay bx by
            a = seg[:, :2]
            e = seg[:, 2:] - a
            # solve origin + t d = a + u e for every ray × segment
            denom = d[:, None, 0] * e[None, :, 1] - d[:, None, 1] * e[None, :, 0]
            w = a[None, :, :] - origin[None, None, :]
            with np.errstate(divide="ignore", invalid="ignore"):
                t = (w[..., 0] * e[None, :, 1] - w[..., 1] * e[None, :, 0]) / denom
                u = (w[..., 0] * d[:, None, 1] - w[..., 1] * d[:, None, 0]) / denom
            ok = (np.abs(denom) > 1e-12) & (t >= 0) & (u >= 0) & (u <= 1)
            t = np.where(ok, t, np.inf)
            best = np.minimum(best, t.min(axis=1))
        best[best > max_range] = np.inf
        return best

    def collides(self, x: float, y: float) -> bool:
        """True when the point (x, y) is inside an obstacle."""
        return any(s.contains(x, y) for s in self.shapes)


def to_robot_frame(pose: Pose, pts: np.ndarray) -> np.ndarray:
    """World points → the frame of a robot at ``pose``."""
    return points_to_frame(pts, pose)


# -- the file format ---------------------------------------------------------------------
#: the smallest size of an obstacle (box side, wall thickness, circle radius), m: below a
#: millimetre a shape is a typing slip (and a divisor near zero in the simulation)
MIN_SIZE_M = 1e-3
#: the largest coordinate or size in a scenario, m
MAX_COORD_M = 1000.0
#: the largest ``seed`` (numpy's seeds)
MAX_SEED = 2**32 - 1


def _num(data: dict[str, Any], key: str, where: str, default: float | None = None, positive: bool = False) -> float:
    if key not in data:
        if default is None:
            raise ScenarioError(f"{where}.{key}: missing")
        return default
    v = data[key]
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise ScenarioError(f"{where}.{key}: expected a finite number, got {v!r}")
    if positive and not MIN_SIZE_M <= v <= MAX_COORD_M:
        raise ScenarioError(f"{where}.{key}: must be from {MIN_SIZE_M:g} to {MAX_COORD_M:g} m, got {v!r}")
    return float(v)


def _vec(data: dict[str, Any], key: str, where: str, n: int = 2, default: list[float] | None = None) -> list[float]:
    if key not in data:
        if default is None:
            raise ScenarioError(f"{where}.{key}: missing")
        return list(default)
    v = data[key]
    if (
        not isinstance(v, (list, tuple))
        or len(v) != n
        or not all(isinstance(a, (int, float)) and not isinstance(a, bool) and math.isfinite(a) for a in v)
    ):
        raise ScenarioError(f"{where}.{key}: expected {n} finite numbers, got {_short(v)}")
    if any(abs(a) > MAX_COORD_M for a in v):
        raise ScenarioError(f"{where}.{key}: coordinates beyond {MAX_COORD_M:g} m, got {_short(v)}")
    return [float(a) for a in v]


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:60] + "…"


def _rect(cx: float, cy: float, sx: float, sy: float, angle: float) -> tuple[tuple[float, float], ...]:
    c, s = math.cos(angle), math.sin(angle)
    out = []
    for dx, dy in ((-sx / 2, -sy / 2), (sx / 2, -sy / 2), (sx / 2, sy / 2), (-sx / 2, sy / 2)):
        out.append((cx + dx * c - dy * s, cy + dx * s + dy * c))
    return tuple(out)


def _shape(obj: Any, where: str) -> Shape:
    if not isinstance(obj, dict):
        raise ScenarioError(f"{where}: expected an object, got {obj!r}")
    kind = obj.get("type")
    if kind == "box":
        cx, cy = _vec(obj, "center", where)
        sx, sy = _vec(obj, "size", where)
        if min(sx, sy) < MIN_SIZE_M:
            raise ScenarioError(f"{where}.size: each side must be at least {MIN_SIZE_M:g} m, got {[sx, sy]}")
        return Shape("polygon", _rect(cx, cy, sx, sy, _num(obj, "angle", where, 0.0)))
    if kind == "wall":
        ax, ay = _vec(obj, "from", where)
        bx, by = _vec(obj, "to", where)
        th = _num(obj, "thickness", where, 0.02, positive=True)
        length = math.hypot(bx - ax, by - ay)
        if length < MIN_SIZE_M:
            raise ScenarioError(f"{where}: 'from' and 'to' are the same point (closer than {MIN_SIZE_M:g} m)")
        return Shape("polygon", _rect((ax + bx) / 2, (ay + by) / 2, length, th, math.atan2(by - ay, bx - ax)))
    if kind == "circle":
        return Shape("circle", center=tuple(_vec(obj, "center", where)), radius=_num(obj, "radius", where, positive=True))  # type: ignore[arg-type]
    if kind == "polygon":
        pts = obj.get("points")
        if not isinstance(pts, list) or len(pts) < 3:
            raise ScenarioError(f"{where}.points: expected at least 3 [x, y] points")
        v = [tuple(_vec({"p": p}, "p", f"{where}.points[{i}]")) for i, p in enumerate(pts)]
        area = sum(v[i][0] * v[(i + 1) % len(v)][1] - v[(i + 1) % len(v)][0] * v[i][1] for i in range(len(v)))
        if abs(area) < MIN_SIZE_M**2:
            raise ScenarioError(f"{where}.points: polygon has no area")
        if area < 0:
            v = v[::-1]
        n = len(v)
        for i in range(n):
            (ax, ay), (bx, by), (cx, cy) = v[i], v[(i + 1) % n], v[(i + 2) % n]
            if (bx - ax) * (cy - by) - (by - ay) * (cx - bx) < -1e-12:
                raise ScenarioError(f"{where}.points: polygon must be convex (split it into convex parts)")
        return Shape("polygon", tuple(v))  # type: ignore[arg-type]
    raise ScenarioError(f"{where}.type: expected 'box', 'wall', 'circle' or 'polygon', got {kind!r}")


def parse_scenario(data: Any, name: str = "scenario") -> Scene:
    """Validate a decoded scenario document and build the :class:`Scene`."""
    if not isinstance(data, dict):
        raise ScenarioError(f"{name}: expected a JSON object at the top level")
    goal = _vec(data, "goal", name)
    start = _vec(data, "start", name, 3, default=[0.0, 0.0, 0.0])
    obstacles = data.get("obstacles", [])
    if not isinstance(obstacles, list):
        raise ScenarioError(f"{name}.obstacles: expected a list")
    shapes = tuple(_shape(o, f"{name}.obstacles[{i}]") for i, o in enumerate(obstacles))
    _check_fields(data, name)
    scene = Scene(
        name=str(data.get("name", name)),
        shapes=shapes,
        goal=(goal[0], goal[1]),
        start=Pose(*start),
        description=str(data.get("description", "")),
        raw=data,
    )
    for i, s in enumerate(shapes):
        if s.contains(goal[0], goal[1]):
            raise ScenarioError(f"{name}.goal: ({goal[0]:g}, {goal[1]:g}) is inside obstacles[{i}]")
        if s.contains(start[0], start[1]):
            raise ScenarioError(f"{name}.start: ({start[0]:g}, {start[1]:g}) is inside obstacles[{i}]")
    return scene


def _check_fields(data: dict[str, Any], name: str) -> None:
    """``seed`` a whole number from 0 to :data:`MAX_SEED` (the rule of every command's
    ``--seed``), ``name`` and ``description`` strings, when given."""
    seed = data.get("seed")
    if seed is not None and (type(seed) is not int or not 0 <= seed <= MAX_SEED):
        raise ScenarioError(f"{name}.seed: expected a whole number from 0 to {MAX_SEED}, got {_short(seed)}")
    for key in ("name", "description"):
        if key in data and not isinstance(data[key], str):
            raise ScenarioError(f"{name}.{key}: expected a string, got {_short(data[key])}")


def _scenario_dir() -> Path:
    from clomp.specs import SPECS_DIR

    return SPECS_DIR / "scenarios"


def builtin_scenarios() -> list[str]:
    """Names of the scenarios shipped in ``specs/scenarios/``.

    >>> "overtaking" in builtin_scenarios()
    True
    """
    return sorted(p.stem for p in _scenario_dir().glob("*.json"))


def scenario_path(name: str) -> Path:
    """The file of a built-in scenario."""
    p = _scenario_dir() / f"{name}.json"
    if not p.is_file():
        raise ScenarioError(f"unknown scenario {name!r}; built in: {', '.join(builtin_scenarios())}")
    return p


def load_scenario(source: str | os.PathLike[str]) -> Scene:
    """Load a scenario by built-in name or from a JSON file path.

    >>> load_scenario("open").name
    'open'
    """
    path = Path(source)
    if "\x00" in str(source):
        raise ScenarioError(f"{str(source)!r}: a path cannot hold a NUL byte")
    if not path.suffix and not _exists(path):
        path = scenario_path(str(source))
    try:
        text = read_text(path, "scenario file", MAX_JSON_BYTES, ScenarioError)
    except ScenarioError as exc:
        if str(exc) == f"{path}: no such file":
            raise ScenarioError(f"{path}: no such scenario file") from None
        raise
    return parse_scenario(load_json(text, str(path), ScenarioError), path.stem)


def _exists(path: Path) -> bool:
    """True when something is at ``path`` (an unreachable path counts: its reader says why)."""
    try:
        os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return False
    except OSError:
        return True
    return True
