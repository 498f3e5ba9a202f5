"""The execution world: a ground-truth robot independent of the planner's model.

A scenario (:class:`clomp.planner.scenarios.Scene`, only its obstacle list, start and goal) is
rebuilt as static pymunk shapes, and the robot is a *dynamic* pymunk body with mass and
inertia driven the way wheels drive a body: a kinematic control body moves at the speed
the wheels give, and a pivot and a gear joint with limited force (traction, ``mu·m·g``)
pull the robot's body along. Against an obstacle the joints slip: contacts stop the body
or deflect it along the surface, as on a real floor. Nothing here comes from the
planner's physics, tasks or kinematics (a test checks the imports): the planner's
unicycle rollouts are the robot's *belief*, this is the world.

The drive, per wheel: the command waits ``latency`` s (actuation latency), is multiplied
by a per-run bias and a per-tick error, and the wheel's speed follows it at most
``wheel_accel`` m/s² (a per-wheel acceleration limit); each wheel then loses a random
fraction ``slip`` of its speed on the ground, and a heading drift is added while the
wheels turn.

The LiDAR is an RPLIDAR A1: ``scan_rate`` revolutions a second (5.5–10 Hz), ``rays``
samples a revolution (360–720), each ray cast at its own time from the body's pose then
(a revolution taken while moving is skewed as on the real sensor), along a beam jittered
by ``angle_sd`` around the angle reported, with Gaussian range noise, dropouts, the crop
at ``max_range`` and each range rounded along its beam to ``resolution``: by default
0.25 mm, the unit an A1 reports distances in (``distance_q2 / 4`` mm; its datasheet gives
a resolution under 0.5 mm at these ranges). ``resolution=0.01`` rounds to 1 cm, and
``rounding="grid"`` rounds each point's x and y instead, as the paper's recorded scans
are (the authors' software rounded them, not the sensor). A coarse rounding fixed to
the robot's frame biases scan matching either way; README, *The world's LiDAR*. Each
revolution is a :class:`~clomp.runtime.interface.ScanFrame`.

Ground truth for experiments: :meth:`WorldRobot.ground_truth_pose` (world frame) and
:meth:`WorldRobot.contact_trace` — one ``(time_s, penetration_m)`` sample per physics
step (``dt``, default 0.01 s) during which the body touches an obstacle, with the deepest
penetration of that step. Time is simulated (:meth:`now`, :meth:`sleep`), so a supervisor
that uses the robot as its clock runs much faster than real time, bit for bit the same
for one seed.

>>> from clomp.planner.scenarios import load_scenario
>>> w = make_world_robot(load_scenario("open"), noise="ideal", seed=0)
>>> w.set_wheel_speeds(0.1, 0.1); w.sleep(2.0)
>>> round(w.ground_truth_pose().x, 2)   # 0.2 m less what the 1 m/s² ramp-up costs
0.19
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import asdict, dataclass, fields, replace
from typing import Any

import numpy as np
import pymunk

from clomp.formal.geometry import polar_to_xy, wrap_angle
from clomp.formal.model import Pose
from clomp.planner.scenarios import Scene, ScenarioError
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.backends._gyro import RateGyro
from clomp.runtime.backends._raycast import first_hits as _first_hits
from clomp.runtime.backends._simulated import SimulatedBackend

__all__ = ["BodySpec", "WorldNoise", "WorldRobot", "WorldContact", "make_world_robot", "NOISE_PRESETS"]

NOISE_PRESETS = ("ideal", "paper", "harsh")
# pymunk routes attribute writes through a typing mixin's __setattr__; the physics step calls
# the property setters directly (the same effect, cheaper)
_set_velocity = pymunk.Body.velocity.fset  # type: ignore[attr-defined]
_set_angular_velocity = pymunk.Body.angular_velocity.fset  # type: ignore[attr-defined]
_set_position = pymunk.Body.position.fset  # type: ignore[attr-defined]
_CONTACT_GAP = 0.5  # a contact beginning this long after the previous ended is a new collision
_OBSTACLE, _ROBOT = 1, 2


@dataclass(frozen=True)
class WorldNoise:
    """The world's noise terms (SI units); see ``specs/noise_presets.json`` for each field.

    >>> WorldNoise.preset("harsh").latency
    0.1
    >>> WorldNoise.preset("paper", scale=0.0) == WorldNoise.preset("ideal")
    True
    """

    range_sd: float = 0.0
    angle_sd: float = 0.0
    dropout: float = 0.0
    wheel_sd: float = 0.0
    wheel_bias: float = 0.0
    drift: float = 0.0
    slip: float = 0.0
    latency: float = 0.0
    rate_sd: float = 0.0
    rate_bias: float = 0.0
    rate_scale: float = 0.0

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v < 0:
                raise ValueError(f"noise.{f.name}: expected a finite number >= 0, got {v!r}")
        if self.dropout >= 1:
            raise ValueError(f"noise.dropout: must be below 1, got {self.dropout!r}")

    @classmethod
    def preset(cls, name: str, scale: float = 1.0) -> "WorldNoise":
        """A named preset (``ideal``, ``paper``, ``harsh``) with every term × ``scale``."""
        from clomp.specs import noise_preset

        return cls(**noise_preset(name, scale))

    def to_dict(self) -> dict[str, float]:
        """JSON-ready form."""
        return asdict(self)

    @classmethod
    def for_scene(cls, scene: Scene, preset: str = "paper", scale: float = 1.0) -> "WorldNoise":
        """A preset with the scene file's ``noise`` object laid over it (each key replaces
        that term); ScenarioError naming the field when a value is bad or unknown."""
        base = cls.preset(preset, scale).to_dict()
        raw = scene.raw.get("noise")
        if raw is None:
            return cls(**base)
        where = f"{scene.name}.noise"
        if not isinstance(raw, dict):
            raise ScenarioError(f"{where}: expected an object, got {raw!r}")
        for key, value in raw.items():
            if key not in base:
                raise ScenarioError(f"{where}.{key}: unknown noise setting (known: {', '.join(sorted(base))})")
            base[key] = value
        try:
            return cls(**base)
        except (TypeError, ValueError) as exc:
            name, _, why = str(exc).partition(":")
            raise ScenarioError(f"{where}.{name.removeprefix('noise.')}:{why}") from None


@dataclass(frozen=True)
class BodySpec:
    """The physical robot: body, wheels and their limits (SI units; the paper's robot).

    The body is ``length`` × ``width``; the wheel axle and the LiDAR sit ``front_offset``
    behind the front edge (the robot frame's origin).
    """

    length: float = 0.27
    width: float = 0.18
    front_offset: float = 0.09
    wheel_base: float = 0.15
    max_wheel_speed: float = 0.2
    wheel_accel: float = 1.0
    mass: float = 1.5
    traction: float = 0.8
    wall_friction: float = 0.4

    def __post_init__(self) -> None:
        for f in fields(self):
            v = getattr(self, f.name)
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or v <= 0:
                raise ValueError(f"body.{f.name}: expected a positive finite number, got {v!r}")
        if self.front_offset >= self.length:
            raise ValueError("body.front_offset must be smaller than the body length")

    @classmethod
    def like(cls, model: Any, **changes: Any) -> "BodySpec":
        """A body with the dimensions of a robot description (any object with ``length``,
        ``width``, ``front_offset``, ``wheel_base``, ``max_speed``, e.g. a RobotModel)."""
        dims = {k: float(getattr(model, k)) for k in ("length", "width", "front_offset", "wheel_base")}
        return replace(cls(**dims, max_wheel_speed=float(model.max_speed)), **changes)


@dataclass(frozen=True, slots=True)
class WorldContact:
    """One counted collision: when (simulated s) and where (world frame) it began."""

    time: float
    x: float
    y: float


class WorldRobot(SimulatedBackend):
    """A differential-drive robot with an RPLIDAR A1 in a scenario's world (see the module).

    Implements :class:`clomp.runtime.interface.Robot` and a simulated clock. It has no wheel
    encoders (:meth:`odometry` is None), like the paper's robot; it has a rate gyro
    (:meth:`rotation`; ``gyro=False`` takes it off).
    """

    _what = "the simulated world robot"

    def __init__(
        self,
        scene: Scene,
        *,
        noise: WorldNoise | None = None,
        body: BodySpec | None = None,
        seed: int | None = None,
        rays: int = 360,
        scan_rate: float = 5.5,
        max_range: float = 1.1,
        resolution: float = 0.00025,
        dt: float = 0.01,
        control_tick: float = 0.1,
        start: Pose | None = None,
        sweep: int = 1,
        gyro: bool = True,
        rounding: str = "range",
    ) -> None:
        if rounding not in ("grid", "range"):
            raise ValueError(f"rounding: 'grid' (x and y) or 'range' (along the beam, as an A1), got {rounding!r}")
        if not (isinstance(rays, int) and 360 <= rays <= 720):
            raise ValueError(f"rays: an RPLIDAR A1 takes 360 to 720 samples a revolution, got {rays!r}")
        if not (5.5 <= scan_rate <= 10.0):
            raise ValueError(f"scan_rate: an RPLIDAR A1 turns at 5.5 to 10 Hz, got {scan_rate!r}")
        for name, v in (("max_range", max_range), ("dt", dt), ("control_tick", control_tick)):
            if not (math.isfinite(v) and v > 0):
                raise ValueError(f"{name}: expected a positive number, got {v!r}")
        if not (math.isfinite(resolution) and resolution >= 0):
            raise ValueError(f"resolution: expected a number >= 0, got {resolution!r}")
        if sweep not in (1, -1):
            raise ValueError(f"sweep: 1 (counter-clockwise) or -1 (clockwise, as an A1 turns), got {sweep!r}")
        self.scene = scene
        self.noise = noise or WorldNoise()
        self.body = body or BodySpec()
        self.seed = seed
        self.rays = rays
        self.scan_rate = float(scan_rate)
        self.max_range = float(max_range)
        self.resolution, self.dt, self.control_tick = float(resolution), float(dt), float(control_tick)
        self.rounding = rounding  # "range": the range along its beam, as an A1; "grid": each point's x and y
        self._rng = np.random.default_rng(seed)
        n = self.noise
        self._bias = 1.0 + n.wheel_bias * self._rng.standard_normal(2)
        self._drift = n.drift * float(self._rng.standard_normal())
        self._gyro = RateGyro(sd=n.rate_sd, bias=n.rate_bias, scale=n.rate_scale, seed=seed) if gyro else None
        self._start = scene.start if start is None else start
        self._t, self._closed, self._cmd = 0.0, False, (0.0, 0.0)
        self._pending: deque[tuple[float, tuple[float, float]]] = deque()
        self._applied = (0.0, 0.0)
        self._bias_lr = (float(self._bias[0]), float(self._bias[1]))
        self._wheel = (0.0, 0.0)
        self._tick_err = (1.0, 1.0)
        self._tick_slip = (0.0, 0.0)
        self._next_draw = 0.0
        self.collisions = 0
        self.contacts: list[WorldContact] = []
        self._trace: list[tuple[float, float]] = []
        self.in_contact = False
        self._contact_ended = -math.inf
        self._build()
        self.trajectory: list[tuple[float, float, float, float]] = [(0.0, *self._xyth())]
        self._ray_angles = sweep * np.arange(rays) * (2 * math.pi / rays)
        self._stream: list[tuple[np.ndarray, np.ndarray, float, bool]] | None = None  # see :meth:`stream`
        self._next_ray = 0
        self._rev_start = 0.0
        self._pending_rays: list[tuple[Any, ...]] = []
        self._latest: ScanFrame | None = None
        self._delivered = True

    # -- building the world -------------------------------------------------------------------
    def _build(self) -> None:
        b = self.body
        space = pymunk.Space()
        space.collision_slop = 0.0005
        space.iterations = 20
        edges: list[tuple[float, float, float, float]] = []
        circles: list[tuple[float, float, float]] = []
        for s in self.scene.shapes:
            if s.kind == "circle":
                circles.append((float(s.center[0]), float(s.center[1]), float(s.radius)))
            else:
                v = s.vertices
                edges += [(float(v[k][0]), float(v[k][1]), float(v[(k + 1) % len(v)][0] - v[k][0]),
                           float(v[(k + 1) % len(v)][1] - v[k][1])) for k in range(len(v))]
            if s.kind == "circle":
                shape: pymunk.Shape = pymunk.Circle(space.static_body, s.radius, s.center)
            else:
                shape = pymunk.Poly(space.static_body, list(s.vertices))
            shape.friction = b.wall_friction
            shape.collision_type = _OBSTACLE
            shape.filter = pymunk.ShapeFilter(categories=_OBSTACLE)
            space.add(shape)
        rear = b.length - b.front_offset
        outline = [(-rear, -b.width / 2), (b.front_offset, -b.width / 2), (b.front_offset, b.width / 2), (-rear, b.width / 2)]
        body = pymunk.Body(b.mass, pymunk.moment_for_poly(b.mass, outline))
        body.position = (self._start.x, self._start.y)
        body.angle = self._start.theta
        shape = pymunk.Poly(body, outline)
        shape.friction = 1.0
        shape.collision_type = _ROBOT
        shape.filter = pymunk.ShapeFilter(categories=_ROBOT)
        control = pymunk.Body(body_type=pymunk.Body.KINEMATIC)
        control.position = body.position
        grip = b.traction * b.mass * 9.81
        pivot = pymunk.PivotJoint(control, body, (0.0, 0.0), (0.0, 0.0))
        pivot.max_bias = 0.0
        pivot.max_force = grip
        gear = pymunk.GearJoint(control, body, 0.0, 1.0)
        gear.error_bias = 0.0
        gear.max_bias = 0.0
        gear.max_force = grip * b.wheel_base / 2
        space.add(body, shape, control, pivot, gear)
        self._space, self._body, self._shape, self._control = space, body, shape, control
        self._edges = np.array(edges, dtype=float).reshape(-1, 4)
        self._circles = np.array(circles, dtype=float).reshape(-1, 3)
        if space.shape_query(shape):
            raise ScenarioError(f"{self.scene.name}.start: the robot's body overlaps an obstacle at the start pose")

    def _xyth(self) -> tuple[float, float, float]:
        p = self._body.position
        return float(p.x), float(p.y), float(self._body.angle)

    # -- Robot protocol -------------------------------------------------------------------------
    @property
    def quantum(self) -> float:
        """The physics step (s)."""
        return self.dt

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels (m/s), saturated at the top wheel speed; applied after the latency."""
        self._check_open()
        if not (math.isfinite(left) and math.isfinite(right)):
            raise ValueError(f"wheel speeds must be finite, got ({left}, {right})")
        vmax = self.body.max_wheel_speed
        cmd = (min(max(float(left), -vmax), vmax), min(max(float(right), -vmax), vmax))
        self._cmd = cmd
        self._pending.append((self._t + self.noise.latency, cmd))

    def stop(self) -> None:
        """Command the wheels to stop (always allowed, also after :meth:`close`).

        Like a real motor controller, the stop is subject to the actuation latency and the
        wheels decelerate at their acceleration limit.
        """
        self._cmd = (0.0, 0.0)
        self._pending.append((self._t + self.noise.latency, (0.0, 0.0)))

    def odometry(self) -> Pose | None:
        """None: the robot has no wheel encoders."""
        return None

    def rotation(self) -> float | None:
        """The heading turned since start-up as the rate gyro integrates it (rad; see
        :class:`~clomp.runtime.backends._gyro.RateGyro`), or None when built with ``gyro=False``."""
        return None if self._gyro is None else self._gyro.angle

    # -- ground truth ----------------------------------------------------------------------------
    def ground_truth_pose(self) -> Pose:
        """The true pose of the robot frame's origin in the world frame."""
        x, y, th = self._xyth()
        return Pose(x, y, wrap_angle(th))

    def drive_truth(self) -> dict[str, float]:
        """This run's systematic drive terms, ground truth for ablations: each wheel's speed
        bias (a factor), the heading drift while the wheels turn (rad/s), the mean share of
        speed slip takes (``E|N(0, slip)|``); ``{'bias_left': 1.0, ...}`` with no noise."""
        bl, br = self._bias_lr
        return {"bias_left": bl, "bias_right": br, "drift": float(self._drift),
                "slip_mean": float(self.noise.slip) * math.sqrt(2.0 / math.pi)}

    def gyro_truth(self) -> dict[str, float]:
        """This run's gyro terms, ground truth for ablations: it reads ``gain`` times the
        body's turn rate plus ``offset`` (rad/s); ``{'gain': 1.0, 'offset': 0.0}`` without one."""
        g = self._gyro
        return {"gain": 1.0, "offset": 0.0} if g is None else {"gain": g.gain, "offset": g.offset}

    @property
    def pose(self) -> Pose:
        """Same as :meth:`ground_truth_pose`."""
        return self.ground_truth_pose()

    @property
    def start_pose(self) -> Pose:
        """The world pose the robot started from (the origin of the supervisor's frame)."""
        return self._start

    def contact_trace(self) -> list[tuple[float, float]]:
        """``(time_s, penetration_m)``: one sample per physics step in contact (see the module)."""
        return list(self._trace)

    @property
    def commanded(self) -> tuple[float, float]:
        """The wheel speeds last commanded (m/s)."""
        return self._cmd

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """The wheels' actual speeds now (m/s), before slip: not zero while they still decelerate."""
        return float(self._wheel[0]), float(self._wheel[1])

    def newest_revolution(self) -> ScanFrame | None:
        """The newest complete revolution, whether :meth:`read_scan` returned it or not
        (for a device emulator that streams the world's LiDAR at its own pace)."""
        return self._latest

    def stream(self) -> list[tuple[np.ndarray, np.ndarray, float, bool]]:
        """The LiDAR's rays measured since the last call, as they were measured: per physics
        step, ``(angle, range, time, first)`` — the nominal angles (rad, robot frame), the
        ranges (m, with the range noise; ``inf``: no return, a dropout or beyond
        ``max_range``), the step's time and whether the step began a revolution. For a
        device emulator that streams each sample when it is measured, as an A1 does; the
        first call starts the recording (its rays are cast step by step from then on,
        with the same draws and the same result as a whole revolution cast at once).

        >>> from clomp.planner.scenarios import load_scenario
        >>> w = make_world_robot(load_scenario("open"), "ideal", seed=0, sweep=-1)
        >>> w.stream(); w.sleep(0.1)
        []
        >>> steps = w.stream(); len(steps), steps[0][3], round(float(steps[1][0][0]), 4)   # clockwise from the front
        (10, True, -0.3316)
        """
        if self._stream is None:
            self._stream = []
            return []
        out, self._stream = self._stream, []
        return out

    def scan_now(self) -> np.ndarray:
        """A complete revolution from the current pose, taken instantly, noise-free (robot frame)."""
        x, y, th = self._xyth()
        r = self._cast(x, y, th + self._ray_angles)
        ok = np.isfinite(r)
        a = self._ray_angles[ok]
        return polar_to_xy(r[ok], a)

    # -- the physics step ---------------------------------------------------------------------------
    def _advance(self, dt: float) -> None:
        n, b = self.noise, self.body
        while self._pending and self._pending[0][0] <= self._t + 1e-12:
            self._applied = self._pending.popleft()[1]
        if self._t >= self._next_draw - 1e-12:  # a control tick's draws
            err = 1.0 + n.wheel_sd * self._rng.standard_normal(2) if n.wheel_sd else np.ones(2)
            slip = np.minimum(np.abs(n.slip * self._rng.standard_normal(2)), 0.9) if n.slip else np.zeros(2)
            self._tick_err = (float(err[0]), float(err[1]))
            self._tick_slip = (float(slip[0]), float(slip[1]))
            self._next_draw = self._t + self.control_tick
        # per wheel, in Python floats (the same IEEE operations as the arrays they replace, faster)
        (cl, cr), (bl, br) = self._applied, self._bias_lr
        el, er = self._tick_err
        sl, sr = self._tick_slip
        wl, wr = self._wheel
        step = b.wheel_accel * dt
        tl = cl * bl * el if cl != 0.0 else 0.0
        tr = cr * br * er if cr != 0.0 else 0.0
        wl = wl + min(max(tl - wl, -step), step)
        wr = wr + min(max(tr - wr, -step), step)
        self._wheel = (wl, wr)
        gl, gr = wl * (1.0 - sl), wr * (1.0 - sr)
        v = (gl + gr) / 2
        w = (gr - gl) / b.wheel_base
        if wl != 0.0 or wr != 0.0:
            w += self._drift
        body, control = self._body, self._control
        th = body.angle
        # the property setters directly: pymunk's typing mixin __setattr__ costs as much again
        _set_velocity(control, (v * math.cos(th), v * math.sin(th)))
        _set_angular_velocity(control, w)
        _set_position(control, body.position)
        self._space.step(dt)
        if self._gyro is not None:
            self._gyro.step((body.angle - th) / dt, dt)
        self._t += dt
        self._contacts()
        pose = self._xyth()
        self.trajectory.append((self._t, *pose))
        self._lidar(pose)

    def _contacts(self) -> None:
        deepest = -1.0
        where: tuple[float, float] | None = None

        def visit(arb: pymunk.Arbiter) -> None:
            nonlocal deepest, where
            for p in arb.contact_point_set.points:
                if -p.distance > deepest:
                    deepest = -p.distance
                    where = (float(p.point_a.x), float(p.point_a.y))

        self._body.each_arbiter(visit)
        touched = where is not None
        if touched:
            self._trace.append((self._t, max(0.0, deepest)))
            if not self.in_contact and self._t - self._contact_ended >= _CONTACT_GAP:
                assert where is not None
                self.collisions += 1
                self.contacts.append(WorldContact(self._t, *where))
            self.in_contact = True
        elif self.in_contact:
            self.in_contact = False
            self._contact_ended = self._t

    # -- the LiDAR ----------------------------------------------------------------------------------
    def _cast(self, x: float, y: float, angles: np.ndarray) -> np.ndarray:
        """Distance along each world angle to the first obstacle within range, inf when none.

        The obstacles are static, so every ray is intersected with every edge and circle
        at once (numpy) instead of one pymunk segment query per ray: the same first hits,
        at a fraction of the cost (the LiDAR was half of a run's time).
        """
        return _first_hits(x, y, angles, self._edges, self._circles, self.max_range * 1.2)

    def _lidar(self, pose: tuple[float, float, float]) -> None:
        period = 1.0 / self.scan_rate
        due = int(min(self.rays, math.floor((self._t - self._rev_start) / period * self.rays + 1e-9)))
        if due > self._next_ray:
            self._rays(self._next_ray, due, pose)
            self._next_ray = due
        if self._next_ray >= self.rays:
            pts, times = self._revolution()
            self._latest = ScanFrame(pts, self._t, point_times=times - self._t)
            self._delivered = False
            self._pending_rays = []
            self._next_ray = 0
            self._rev_start += period

    def _rays(self, i0: int, i1: int, pose: tuple[float, float, float]) -> None:
        """The rays due in this step: their origin (the body's pose now) and noise draws.

        Casting waits for the revolution's end (:meth:`_revolution`), where every ray of
        the revolution is cast from its own origin at once; the draws are made here, in
        the order they always were, so a seed gives the same scans.
        """
        n, k = self.noise, i1 - i0
        nominal = self._ray_angles[i0:i1]
        beam = nominal + n.angle_sd * self._rng.standard_normal(k) if n.angle_sd else nominal
        x, y, th = pose
        noise = n.range_sd * self._rng.standard_normal(k) if n.range_sd else None
        kept = self._rng.random(k) >= n.dropout if n.dropout else None
        batch: tuple[Any, ...] = (x, y, th + beam, nominal, noise, kept, self._t)
        if self._stream is not None:  # cast now: the emulator sends these samples now
            dist = _first_hits(x, y, th + beam, self._edges, self._circles, self.max_range * 1.2)
            if noise is not None:
                dist = dist + noise
            self._stream.append((nominal, np.where(self._returned(dist, kept), dist, np.inf), self._t, i0 == 0))
            batch += (dist,)
        self._pending_rays.append(batch)

    def _returned(self, dist: np.ndarray, kept: np.ndarray | None) -> np.ndarray:
        """Which rays gave a return: a range above 0 within ``max_range``, not dropped."""
        keep: np.ndarray = np.isfinite(dist) & (dist > 0) & (dist <= self.max_range)
        return keep if kept is None else keep & kept

    def _revolution(self) -> tuple[np.ndarray, np.ndarray]:
        """Cast the revolution's rays; its points (robot frame at each ray's time) and times."""
        rays = self._pending_rays
        if not rays:
            return np.zeros((0, 2)), np.zeros(0)
        counts = [len(r[3]) for r in rays]
        x = np.repeat([r[0] for r in rays], counts)[:, None]
        y = np.repeat([r[1] for r in rays], counts)[:, None]
        world = np.concatenate([r[2] for r in rays])
        nominal = np.concatenate([r[3] for r in rays])
        t = np.repeat([r[6] for r in rays], counts)
        if all(len(r) > 7 for r in rays):  # cast step by step for the stream (noise added)
            dist = np.concatenate([r[7] for r in rays])
        else:
            dist = _first_hits(x, y, world, self._edges, self._circles, self.max_range * 1.2)
            if self.noise.range_sd:
                dist = dist + np.concatenate([r[4] for r in rays])
        keep = self._returned(dist, np.concatenate([r[5] for r in rays]) if self.noise.dropout else None)
        dist, a = dist[keep], nominal[keep]
        grid = self.resolution > 0 and self.rounding == "grid"
        if self.resolution > 0 and not grid:  # the range as an A1 reports it, along the beam it names
            dist = np.round(dist / self.resolution) * self.resolution
        pts = polar_to_xy(dist, a)
        return (np.round(pts / self.resolution) * self.resolution if grid else pts), t[keep]


def make_world_robot(
    scene: Scene,
    noise: str | WorldNoise = "paper",
    noise_scale: float = 1.0,
    seed: int | None = None,
    *,
    robot: Any = None,
    **options: Any,
) -> WorldRobot:
    """The execution world for ``scene``: a :class:`WorldRobot` with a named noise preset.

    ``noise`` is a preset name (``ideal``, ``paper``, ``harsh``; ``specs/noise_presets.json``)
    or a :class:`WorldNoise`; ``noise_scale`` multiplies every term of a named preset.
    ``robot`` (e.g. a planner ``RobotModel``) gives the body its dimensions and top speed;
    ``options`` go to :class:`WorldRobot` (``rays``, ``scan_rate``, ``dt``, ``start`` …).

    >>> from clomp.planner.scenarios import load_scenario
    >>> w = make_world_robot(load_scenario("overtaking"), "harsh", seed=3)
    >>> w.noise.latency, w.read_scan().points.shape[1]
    (0.1, 2)
    """
    if isinstance(noise, str):
        if noise not in NOISE_PRESETS:
            raise ValueError(f"unknown noise preset {noise!r} (known: {', '.join(NOISE_PRESETS)})")
        wn = WorldNoise.preset(noise, noise_scale)
    else:
        wn = noise
    body = options.pop("body", None)
    if body is None and robot is not None:
        body = BodySpec.like(robot)
    return WorldRobot(scene, noise=wn, body=body, seed=seed, **options)
