"""The simulated robot: a :class:`~clomp.runtime.interface.Robot` backend over a ground-truth world.

The world is a scenario (:class:`clomp.planner.scenarios.Scene`) rebuilt as static pymunk
shapes. The robot is the :class:`~clomp.planner.robot_model.RobotModel`'s body (not inflated) on a
differential drive: each physics substep integrates the *actual* wheel speeds — the
commanded ones with a per-run bias and per-tick noise, plus a heading drift — and
resolves contact with the obstacles by pushing the body out along the contact normal
(the robot slides along what it hits instead of passing through it). Every new contact
counts as a collision: a brush counts, a contact that lasts is counted once.

The LiDAR turns at ``scan_rate`` revolutions per second with ``rays`` rays per turn; each
ray is cast at its own time from the robot's pose then (a moving robot's scan is
distorted like a real one), with Gaussian range noise, dropouts, the crop at
``max_range`` and coordinates rounded to ``resolution``. A revolution becomes one
:class:`~clomp.runtime.interface.ScanFrame`.

Time is simulated: the backend owns a clock that only :meth:`SimRobot.sleep` (and a
blocking :meth:`SimRobot.read_scan`) advance, so a supervisor using the robot as its
clock runs far faster than real time and bit-for-bit reproducibly for one seed.

>>> from clomp.planner import load_scenario
>>> sim = SimRobot(load_scenario("open"), noise=NoiseConfig.ideal())
>>> sim.set_wheel_speeds(0.1, 0.1); sim.sleep(1.0); round(sim.pose.x, 3)
0.1
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
import pymunk

from clomp.formal.geometry import arc_step, polar_to_xy, wrap_angle
from clomp.formal.model import Pose
from clomp.planner.noise import check_noise, noise_from_scene
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene, ScenarioError, load_scenario
from clomp.runtime.interface import RobotFault, ScanFrame
from clomp.runtime.backends._simulated import SimulatedBackend

__all__ = ["NoiseConfig", "SimRobot", "Contact", "scenario_noise", "scenario_seed", "scenario_scan_source"]

# a contact that begins this long after the previous one ended counts as a new collision
_CONTACT_GAP = 0.5


@dataclass(frozen=True)
class NoiseConfig:
    """Sensor and execution noise of the simulated robot (SI units).

    ``range_sd``: standard deviation of the LiDAR range error (m). ``dropout``:
    probability that a ray returns nothing. ``wheel_sd``: relative standard deviation of
    each wheel's speed error, drawn anew every control tick. ``wheel_bias``: relative
    standard deviation of a per-wheel speed bias drawn once per run (a wheel slightly
    faster than the other makes a straight curve). ``drift``: standard deviation (rad/s)
    of a heading drift drawn once per run, applied while the wheels turn.

    >>> quiet = NoiseConfig(range_sd=0.0, dropout=0.0)
    >>> quiet.range_sd, quiet.dropout
    (0.0, 0.0)
    """

    range_sd: float = 0.005
    dropout: float = 0.02
    wheel_sd: float = 0.02
    wheel_bias: float = 0.005
    drift: float = 0.002

    def __post_init__(self) -> None:
        check_noise(asdict(self))

    @classmethod
    def ideal(cls) -> "NoiseConfig":
        """No noise at all: the simulated robot does exactly what it is told."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0)

    @classmethod
    def from_dict(cls, data: Any, where: str = "noise") -> "NoiseConfig":
        """Validate a ``noise`` object of a scenario file; errors name the field."""
        return noise_from_scene(cls, data, where)

    def to_dict(self) -> dict[str, float]:
        """JSON-ready form."""
        return asdict(self)


def scenario_noise(scene: Scene) -> NoiseConfig:
    """The scene's ``noise`` settings (defaults for the fields it leaves out)."""
    raw = scene.raw.get("noise")
    if raw is None:
        return NoiseConfig()
    return NoiseConfig.from_dict(raw, f"{scene.name}.noise")


def scenario_seed(scene: Scene) -> int | None:
    """The scene's ``seed`` for the simulator, or None when it names none."""
    v = scene.raw.get("seed")
    if v is None:
        return None
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        raise ScenarioError(f"{scene.name}.seed: expected a non-negative integer, got {v!r}")
    return v


@dataclass(frozen=True, slots=True)
class Contact:
    """One counted collision: when (simulated s) and where (world frame) it began."""

    time: float
    x: float
    y: float


class SimRobot(SimulatedBackend):
    """A simulated differential-drive robot with a LiDAR in a scenario's world.

    Implements :class:`clomp.runtime.interface.Robot` plus a simulated clock (:meth:`now`,
    :meth:`sleep`). Odometry frames: the robot's start pose is the origin; ground truth
    (:attr:`pose`, :attr:`trajectory`, :attr:`contacts`) is in the scene's world frame.
    ``odometry=True`` gives wheel-encoder odometry (integrated actual wheel speeds,
    blind to drift and to being pushed); the default, like the paper's robot, has none.

    >>> robot = SimRobot(load_scenario("open"), seed=0)
    >>> robot.set_wheel_speeds(0.1, 0.1); robot.sleep(1.0); robot.stop()
    >>> round(robot.now(), 6), round(robot.pose.x, 2)
    (1.0, 0.1)
    """

    def __init__(
        self,
        scene: Scene,
        robot: RobotModel | None = None,
        *,
        noise: NoiseConfig | None = None,
        seed: int | None = None,
        rays: int = 360,
        scan_rate: float = 5.5,
        max_range: float | None = None,
        resolution: float = 0.01,
        substep: float = 0.02,
        odometry: bool = False,
        start: Pose | None = None,
    ) -> None:
        self.scene = scene
        self.model = robot or RobotModel()
        self.noise = scenario_noise(scene) if noise is None else noise
        if seed is None:
            seed = scenario_seed(scene)
        self.seed = seed
        if rays < 1 or not (scan_rate > 0) or not (substep > 0):
            raise ValueError("rays, scan_rate and substep must be positive")
        self.rays = int(rays)
        self.scan_rate = float(scan_rate)
        self.max_range = self.model.sensor_range if max_range is None else float(max_range)
        self.resolution = float(resolution)
        self.substep = float(substep)
        self._rng = np.random.default_rng(seed)
        self._bias = 1.0 + self.noise.wheel_bias * self._rng.standard_normal(2)
        self._drift = self.noise.drift * float(self._rng.standard_normal())
        self._start = scene.start if start is None else start
        self._has_odometry = bool(odometry)
        self._t = 0.0
        self._x, self._y, self._th = self._start.x, self._start.y, self._start.theta
        self._odo = (0.0, 0.0, 0.0)
        self._cmd = (0.0, 0.0)
        self._actual = (0.0, 0.0)
        self._noise_until = -1.0
        self._tick_err = np.ones(2)
        self._closed = False
        self.collisions = 0
        self.contacts: list[Contact] = []
        self.in_contact = False
        self._contact_ended = -math.inf
        self.trajectory: list[tuple[float, float, float, float]] = [(0.0, self._x, self._y, self._th)]
        self._build_space()
        # LiDAR revolution in progress
        self._ray_angles = np.arange(self.rays) * (2 * math.pi / self.rays)
        self._next_ray = 0
        self._rev_start = 0.0
        self._pts: list[np.ndarray] = []
        self._latest: ScanFrame | None = None
        self._delivered = True

    # -- world ------------------------------------------------------------------------
    def _build_space(self) -> None:
        space = pymunk.Space()
        space.collision_slop = 0.0005
        for s in self.scene.shapes:
            if s.kind == "circle":
                shape: pymunk.Shape = pymunk.Circle(space.static_body, s.radius, s.center)
            else:
                shape = pymunk.Poly(space.static_body, list(s.vertices))
            space.add(shape)
        self._body = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        m = self.model
        outline = [(-m.rear_offset, -m.width / 2), (m.front_offset, -m.width / 2), (m.front_offset, m.width / 2), (-m.rear_offset, m.width / 2)]
        self._shape = pymunk.Poly(self._body, outline)
        space.add(self._body, self._shape)
        self._space = space
        if self._overlap(self._x, self._y, self._th):
            raise ScenarioError(f"{self.scene.name}.start: the robot's body overlaps an obstacle at the start pose")

    def _overlap(self, x: float, y: float, th: float) -> list[Any]:
        self._body.position = (x, y)
        self._body.angle = th
        self._space.reindex_shapes_for_body(self._body)
        return self._space.shape_query(self._shape)

    # -- Robot protocol ------------------------------------------------------------------
    @property
    def quantum(self) -> float:
        """The physics substep (s)."""
        return self.substep

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels (m/s), saturated at the model's top speed."""
        self._check_open()
        if not (math.isfinite(left) and math.isfinite(right)):
            raise ValueError(f"wheel speeds must be finite, got ({left}, {right})")
        vmax = self.model.max_speed
        self._cmd = (min(max(float(left), -vmax), vmax), min(max(float(right), -vmax), vmax))
        self._noise_until = -1.0  # draw the tick's speed error afresh

    def stop(self) -> None:
        """Stop the wheels (always allowed, also after :meth:`close`)."""
        self._cmd = (0.0, 0.0)
        self._actual = (0.0, 0.0)

    def odometry(self) -> Pose | None:
        """Wheel-encoder odometry (start = origin) when enabled, else None."""
        if not self._has_odometry:
            return None
        x, y, th = self._odo
        return Pose(x, y, wrap_angle(th))

    # -- ground truth ---------------------------------------------------------------------
    @property
    def pose(self) -> Pose:
        """The true pose in the world frame."""
        return Pose(self._x, self._y, wrap_angle(self._th))

    @property
    def start_pose(self) -> Pose:
        """The world pose of the odometry frame's origin."""
        return self._start

    @property
    def commanded(self) -> tuple[float, float]:
        """The wheel speeds last commanded (m/s); (0, 0) after :meth:`stop`."""
        return self._cmd

    # -- physics ---------------------------------------------------------------------------
    def _advance(self, dt: float) -> None:
        n = self.noise
        cl, cr = self._cmd
        if cl == 0.0 and cr == 0.0:
            vl = vr = 0.0
        else:
            if self._t >= self._noise_until:
                err = 1.0 + n.wheel_sd * self._rng.standard_normal(2) if n.wheel_sd else np.ones(2)
                self._tick_err = err
                self._noise_until = self._t + self.model.tick
            vl = float(cl * self._bias[0] * self._tick_err[0])
            vr = float(cr * self._bias[1] * self._tick_err[1])
        self._actual = (vl, vr)
        b = self.model.wheel_base
        v = (vl + vr) / 2
        w = (vr - vl) / b
        # encoders see the actual wheel speeds
        ox, oy, oth = self._odo
        self._odo = arc_step(ox, oy, oth, v, w, dt)
        if vl != 0.0 or vr != 0.0:
            w += self._drift
        if v != 0.0 or w != 0.0:
            nx, ny, nth = arc_step(self._x, self._y, self._th, v, w, dt)
            self._move_to(nx, ny, nth)
        self._t += dt
        self.trajectory.append((self._t, self._x, self._y, self._th))
        self._lidar(dt)

    def _move_to(self, x: float, y: float, th: float) -> None:
        """Go to (x, y, th), pushed out of any obstacle along the contact normals."""
        hits = self._overlap(x, y, th)
        touched = bool(hits)
        first = None
        for _ in range(4):
            if not hits:
                break
            for h in hits:
                cps = h.contact_point_set
                if not cps.points:
                    continue
                depth = max(-p.distance for p in cps.points)
                if first is None:
                    p = cps.points[0].point_b
                    first = (float(p.x), float(p.y))
                if depth > 0:
                    x -= cps.normal.x * (depth + 1e-4)
                    y -= cps.normal.y * (depth + 1e-4)
            hits = self._overlap(x, y, th)
        if hits:  # could not be resolved (wedged): stay where it was
            x, y, th = self._x, self._y, self._th
            self._overlap(x, y, th)
        if touched and not self.in_contact and self._t - self._contact_ended >= _CONTACT_GAP:
            cx, cy = first if first is not None else (x, y)
            self.collisions += 1
            self.contacts.append(Contact(self._t, cx, cy))
        if touched:
            self.in_contact = True
        elif self.in_contact:
            self.in_contact = False
            self._contact_ended = self._t
        self._x, self._y, self._th = x, y, th

    def _lidar(self, dt: float) -> None:
        period = 1.0 / self.scan_rate
        due = int(min(self.rays, math.floor((self._t - self._rev_start) / period * self.rays + 1e-9)))
        if due > self._next_ray:
            self._cast(self._next_ray, due)
            self._next_ray = due
        if self._next_ray >= self.rays:
            pts = np.concatenate(self._pts) if self._pts else np.zeros((0, 2))
            self._latest = ScanFrame(pts, self._t)
            self._delivered = False
            self._pts = []
            self._next_ray = 0
            self._rev_start += period

    def _cast(self, i0: int, i1: int) -> None:
        local = self._ray_angles[i0:i1]
        n = self.noise
        ranges = self.scene.raycast(np.array([self._x, self._y]), local + self._th, np.inf)
        if n.range_sd:
            ranges = ranges + n.range_sd * self._rng.standard_normal(len(ranges))
        keep = np.isfinite(ranges) & (ranges > 0) & (ranges <= self.max_range)
        if n.dropout:
            keep &= self._rng.random(len(ranges)) >= n.dropout
        r, a = ranges[keep], local[keep]
        pts = polar_to_xy(r, a)
        if self.resolution > 0:
            pts = np.round(pts / self.resolution) * self.resolution
        self._pts.append(pts)

    def scan_now(self) -> np.ndarray:
        """A complete noise-free revolution from the current pose, taken instantly (robot frame)."""
        return self.scene.scan(self.pose, self.rays, self.max_range)



def scenario_scan_source(
    name_or_path: str | os.PathLike[str] | Scene,
    *,
    noise: NoiseConfig | None = None,
    seed: int | None = None,
    pose: Pose | None = None,
    robot: RobotModel | None = None,
    rays: int = 360,
    scan_rate: float = 5.5,
) -> Callable[[], np.ndarray]:
    """Successive simulated LiDAR scans of a scenario, for device emulators.

    Each call lets one revolution of simulated time pass and returns that revolution's
    points (N×2, metres, robot frame, cropped at the sensor range), seen from ``pose``
    (default the scenario's start) with the scenario's noise (or ``noise``).

    >>> source = scenario_scan_source("overtaking", seed=1)
    >>> pts = source(); pts.shape[1], bool((abs(pts) <= 1.1).all())
    (2, True)
    """
    scene = name_or_path if isinstance(name_or_path, Scene) else load_scenario(name_or_path)
    sim = SimRobot(scene, robot, noise=noise, seed=seed, rays=rays, scan_rate=scan_rate, start=pose)

    def next_scan() -> np.ndarray:
        frame = sim.read_scan(timeout=None)
        if frame is None:  # pragma: no cover - a revolution always completes within its period
            raise RobotFault("simulated LiDAR produced no revolution")
        return frame.points

    return next_scan
