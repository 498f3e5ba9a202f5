"""The execution world: a ground-truth robot independent of the planner's model.

A scenario (:class:`clomp.planner.scenarios.Scene`, only its obstacle list, start and goal) is
rebuilt as static pymunk shapes, and the robot is a *dynamic* pymunk body with mass and
inertia driven the way wheels drive a body: a kinematic control body moves at the speed
the wheels give, and a pivot and a gear joint with limited force (traction, ``mu·m·g``)
pull the robot's body along. Against an obstacle the joints slip: contacts stop the body
or deflect it along the surface, as on a real floor. Nothing here comes from the
planner's physics, tasks or kinematics (a test checks the imports): the planner's
unicycle rollouts are the robot's *belief*, this is the world. Only the body's dimensions
(:class:`~clomp.planner.robot_model.Body`, declared once) and the noise terms
(:class:`~clomp.planner.noise.NoiseTerms`, here :data:`WorldNoise`) are the planner's types.

This module assembles the world from one module per noun: the body and its pymunk world
(``_world_body.py``: :class:`BodySpec`), the dynamics (``_dynamics.py``: the wheel drive
and the contacts), the LiDAR (``_lidar.py``) and the gyro (``_gyro.py``).

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
the robot's frame biases scan matching either way; docs/closed-loop.md, *The world's LiDAR*. Each
revolution is a :class:`~clomp.runtime.interface.ScanFrame`.

The error sources the estimator does not model (``harsh`` only; README, *What is and is not
modelled*): a wheel bias that walks and slip events (``_dynamics.py``), the LiDAR at
``mount`` on the body, returning beyond the horizon (``_lidar.py``; the backend converts its
points to the robot frame by ``told_mount``, the mount it was told), a gyro scale asymmetry
(``_gyro.py``) and pushes (:meth:`WorldRobot.push`, at ``push_rate``; :attr:`WorldRobot.pushes`).

A world may move (issue #42): ``movers`` are people walking seeded paths and boxes that
appear (``_movers.py``), kinematic bodies the LiDAR sees at each ray's time; their contacts
are counted apart from the static ones, with who hit whom (:meth:`WorldRobot.contact_traces`).

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
from collections.abc import Iterable, Mapping
from typing import Any

import numpy as np
import pymunk

from clomp.formal.geometry import wrap_angle
from clomp.formal.model import Pose
from clomp.planner.noise import NoiseTerms
from clomp.planner.robot_model import Body
from clomp.planner.scenarios import Scene
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.backends._dynamics import Contacts, Drive, WorldContact, WorldPush, push_speed, term_stream
from clomp.runtime.backends._gyro import RateGyro, ShockSensor
from clomp.runtime.backends._lidar import Lidar
from clomp.runtime.backends._movers import Mover, Movers, parse_movers
from clomp.runtime.backends._pymunk_fast import angle as _angle, position as _position, space_step as _space_step, \
    velocity as _velocity
from clomp.runtime.backends._simulated import SimulatedBackend
from clomp.runtime.backends._world_body import BodySpec, build_physics

__all__ = [
    "BodySpec",
    "Mover",
    "WorldNoise",
    "WorldRobot",
    "WorldContact",
    "WorldPush",
    "make_world_robot",
    "parse_movers",
    "push_speed",
]

WorldNoise = NoiseTerms
"""The world's noise: every term of a preset (:class:`clomp.planner.noise.NoiseTerms`)."""
# pymunk routes attribute writes through a typing mixin's __setattr__; the physics step calls
# the property setters directly (the same effect, cheaper)
_set_velocity = pymunk.Body.velocity.fset  # type: ignore[attr-defined]
_set_angular_velocity = pymunk.Body.angular_velocity.fset  # type: ignore[attr-defined]
_set_position = pymunk.Body.position.fset  # type: ignore[attr-defined]
SHOCK_SD = 0.05
"""The accelerometer's noise on a peak (m/s²): a hobby IMU's (a BNO08x's 0.3 % of 8 g) and a little vibration."""
Mount = tuple[float, float, float]
"""A LiDAR's pose on the body: x ahead of the rotation centre, y to the left (m), theta (rad)."""


def _to_robot(points: np.ndarray, mount: Mount) -> np.ndarray:
    """LiDAR-frame points in the robot frame, the LiDAR at ``mount`` (unchanged at the centre)."""
    mx, my, mth = mount
    if not (mx or my or mth) or not len(points):
        return points
    c, s = math.cos(mth), math.sin(mth)
    out: np.ndarray = np.c_[c * points[:, 0] - s * points[:, 1] + mx, s * points[:, 0] + c * points[:, 1] + my]
    return out


def _check_options(rays: Any, scan_rate: float, max_range: float, resolution: float, dt: float, control_tick: float,
                   sweep: int, rounding: str) -> None:
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


def _mount(name: str, mount: Any) -> Mount:
    try:
        x, y, th = (float(v) for v in mount)
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected (x, y, theta), got {mount!r}") from None
    if not all(math.isfinite(v) for v in (x, y, th)):
        raise ValueError(f"{name}: expected finite numbers, got {mount!r}")
    return x, y, th


class WorldRobot(SimulatedBackend):
    """A differential-drive robot with an RPLIDAR A1 in a scenario's world (see the module).

    Implements :class:`clomp.runtime.interface.Robot` and a simulated clock. It has no wheel
    encoders (:meth:`odometry` is None), like the paper's robot; it has a rate gyro
    (:meth:`rotation`; ``gyro=False`` takes it off). ``mount`` is the LiDAR's pose on the body
    (x, y, theta; default ``(noise.lidar_x, 0, 0)``), ``told_mount`` the pose the backend
    converts its points to the robot frame by (default: ``mount``; another models a
    mis-measured mount). ``movers``: people and boxes that move or appear
    (:class:`~clomp.runtime.backends._movers.Mover` or their JSON forms; issue #42), kinematic
    bodies the LiDAR sees beam by beam; :meth:`contact_traces` keeps their contacts apart.

    >>> from clomp.planner.scenarios import load_scenario
    >>> WorldRobot(load_scenario("open"), body=BodySpec(width=0.2)).body.width
    0.2
    """

    _what = "the simulated world robot"

    def __init__(
        self,
        scene: Scene,
        *,
        noise: NoiseTerms | None = None,
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
        mount: Mount | None = None,
        told_mount: Mount | None = None,
        movers: Iterable[Mover | Mapping[str, Any]] | None = None,
    ) -> None:
        _check_options(rays, scan_rate, max_range, resolution, dt, control_tick, sweep, rounding)
        self.scene = scene
        self.noise = noise or NoiseTerms()
        self.body = body or BodySpec()
        self.seed = seed
        self.rays = rays
        self.scan_rate = float(scan_rate)
        self.max_range = float(max_range)
        self.resolution, self.dt, self.control_tick = float(resolution), float(dt), float(control_tick)
        self.rounding = rounding  # "range": the range along its beam, as an A1; "grid": each point's x and y
        self._rng = np.random.default_rng(seed)
        n = self.noise
        self._drive = Drive(n, self.body, self._rng, control_tick=self.control_tick, seed=seed)
        self._gyro = RateGyro(sd=n.rate_sd, bias=n.rate_bias, scale=n.rate_scale, seed=seed,
                              asymmetry=n.rate_asymmetry) if gyro else None
        # the IMU's accelerometer, read as a shock sensor (with the gyro: one device)
        self._shock = ShockSensor(sd=SHOCK_SD, seed=seed) if gyro else None
        self._velocity = (0.0, 0.0)  # the body's at the end of the last physics step
        self.mount: Mount = _mount("mount", mount) if mount is not None else (n.lidar_x, 0.0, 0.0)
        self.told_mount: Mount = self.mount if told_mount is None else _mount("told_mount", told_mount)
        self._pushes: list[WorldPush] = []
        self._push_rng = term_stream(seed, "push_rate") if n.push_rate else None
        self._next_push = math.inf if self._push_rng is None else float(self._push_rng.exponential(1 / n.push_rate))
        self._start = scene.start if start is None else start
        self._t, self._closed = 0.0, False
        self._contacts = Contacts()
        self._space, self._body, self._shape, self._control = build_physics(scene, self.body, self._start)
        self.trajectory: list[tuple[float, float, float, float]] = [(0.0, *self._xyth())]
        self._lidar = Lidar(scene, n, self._rng, rays=rays, scan_rate=self.scan_rate, max_range=self.max_range,
                            resolution=self.resolution, rounding=rounding, sweep=sweep, mount=self.mount)
        self._latest: ScanFrame | None = None
        self._delivered = True
        moving = parse_movers(movers)
        self.movers: Movers | None = Movers(self._space, moving, self.body.wall_friction) if moving else None
        self._lidar.movers = self.movers

    def _xyth(self) -> tuple[float, float, float]:
        x, y = _position(self._body)
        return x, y, _angle(self._body)

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
        self._drive.command(self._t, (min(max(float(left), -vmax), vmax), min(max(float(right), -vmax), vmax)))

    def stop(self) -> None:
        """Command the wheels to stop (always allowed, also after :meth:`close`).

        Like a real motor controller, the stop is subject to the actuation latency and the
        wheels decelerate at their acceleration limit.
        """
        self._drive.command(self._t, (0.0, 0.0))

    def odometry(self) -> Pose | None:
        """None: the robot has no wheel encoders."""
        return None

    @property
    def heading_sensor(self) -> bool:
        """Whether the robot carries its gyro (:func:`~clomp.runtime.interface.has_heading_sensor`)."""
        return self._gyro is not None

    def rotation(self) -> float | None:
        """The heading turned since start-up as the rate gyro integrates it (rad; see
        :class:`~clomp.runtime.backends._gyro.RateGyro`), or None when built with ``gyro=False``."""
        return None if self._gyro is None else self._gyro.angle

    def peak_acceleration(self) -> float | None:
        """The largest horizontal acceleration of the body since the last call (m/s², the
        IMU's accelerometer; :class:`~clomp.runtime.backends._gyro.ShockSensor`), or None when
        built with ``gyro=False`` (no IMU)."""
        return None if self._shock is None else self._shock.read()

    def peak_acceleration_vector(self) -> tuple[float, float] | None:
        """The largest horizontal acceleration of the body since the last call, as a vector
        (m/s², world frame; the accelerometer's truth for an emulated IMU, read apart from
        :meth:`peak_acceleration`), or None when built with ``gyro=False`` (no IMU)."""
        return None if self._shock is None else self._shock.read_vector()

    def calibration(self) -> dict[str, float]:
        """What the robot is told of its own errors (:class:`~clomp.runtime.interface.Calibrated`):
        the noise terms it draws them from, as a maker's specification gives them, not this
        run's draws (those are :meth:`drive_truth` and :meth:`gyro_truth`)."""
        return self.noise.to_dict()

    # -- ground truth ----------------------------------------------------------------------------
    def ground_truth_pose(self) -> Pose:
        """The true pose of the robot frame's origin in the world frame."""
        x, y, th = self._xyth()
        return Pose(x, y, wrap_angle(th))

    def drive_truth(self) -> dict[str, float]:
        """This run's systematic drive terms, ground truth for ablations: each wheel's speed
        bias (a factor; now, as ``bias_walk`` has walked it), the heading drift while the wheels turn (rad/s), the mean share of
        speed slip takes (``E|N(0, slip)|``); ``{'bias_left': 1.0, ...}`` with no noise."""
        bl, br = self._drive.bias
        return {"bias_left": bl, "bias_right": br, "drift": float(self._drive.drift),
                "slip_mean": float(self.noise.slip) * math.sqrt(2.0 / math.pi)}

    def gyro_truth(self) -> dict[str, float]:
        """This run's gyro terms, ground truth for ablations: it reads ``gain`` times the
        body's turn rate plus ``offset`` (rad/s), the gain ``asymmetry`` (relative) higher
        turning counter-clockwise than clockwise; ``{'gain': 1.0, 'offset': 0.0, 'asymmetry': 0.0}``
        without one."""
        g = self._gyro
        if g is None:
            return {"gain": 1.0, "offset": 0.0, "asymmetry": 0.0}
        return {"gain": g.gain, "offset": g.offset, "asymmetry": g.asymmetry}

    @property
    def slips(self) -> list[tuple[float, float]]:
        """The slip events so far, ``(start, end)`` s: the wheels spun, the body stood (``slip_rate``)."""
        return list(self._drive.slips)

    @property
    def pushes(self) -> list[WorldPush]:
        """The external pushes so far (``push_rate``, or :meth:`push`)."""
        return list(self._pushes)

    def push(self, distance: float, direction: float) -> None:
        """Push the body now: a kick that slides it ``distance`` m towards ``direction`` (rad,
        world frame) on open floor before its wheels' grip stops it (an obstacle stops it
        sooner, a contact as any other). Recorded in :attr:`pushes`."""
        if not (math.isfinite(distance) and distance >= 0 and math.isfinite(direction)):
            raise ValueError(f"push: expected a distance >= 0 and a finite direction, got ({distance}, {direction})")
        v0 = push_speed(distance, self.body)
        vx, vy = self._body.velocity
        _set_velocity(self._body, (vx + v0 * math.cos(direction), vy + v0 * math.sin(direction)))
        self._pushes.append(WorldPush(self._t, float(distance), float(direction)))

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
        return list(self._contacts.trace)

    def contact_traces(self) -> tuple[list[tuple[float, float]], list[tuple[float, float, bool]]]:
        """With movers (issue #42): the contact samples with the static obstacles, ``(time_s,
        penetration_m)``, and with the moving bodies, ``(time_s, penetration_m, robot_caused)``
        (True: the robot drove into the body; False: the body walked into the robot); without
        movers, :meth:`contact_trace` and no moving samples."""
        if self.movers is None:
            return self.contact_trace(), []
        return list(self._contacts.static_trace), list(self._contacts.moving_trace)

    @property
    def collisions(self) -> int:
        """Collisions counted so far (a contact that lasts counts once)."""
        return self._contacts.collisions

    @property
    def contacts(self) -> list[WorldContact]:
        """The collisions counted so far: when and where each began."""
        return self._contacts.contacts

    @property
    def in_contact(self) -> bool:
        """Whether the body touches an obstacle now."""
        return self._contacts.touching

    @property
    def commanded(self) -> tuple[float, float]:
        """The wheel speeds last commanded (m/s)."""
        return self._drive.commanded

    @property
    def wheel_speeds(self) -> tuple[float, float]:
        """The wheels' actual speeds now (m/s), before slip: not zero while they still decelerate."""
        wl, wr = self._drive.wheels
        return float(wl), float(wr)

    def newest_revolution(self) -> ScanFrame | None:
        """The newest complete revolution, whether :meth:`read_scan` returned it or not
        (for a device emulator that streams the world's LiDAR at its own pace)."""
        return self._latest

    def stream(self) -> list[tuple[np.ndarray, np.ndarray, float, bool]]:
        """The LiDAR's rays measured since the last call, as they were measured: per physics
        step, ``(angle, range, time, first)`` — the nominal angles (rad, in the LiDAR's frame,
        as an A1 sends them: the robot's when it sits at the centre, ``mount``), the
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
        lidar = self._lidar
        if lidar.streaming is None:
            lidar.streaming = []
            return []
        out, lidar.streaming = lidar.streaming, []
        return out

    def scan_now(self) -> np.ndarray:
        """A complete revolution from the current pose, taken instantly, noise-free (robot
        frame, by the told mount)."""
        return _to_robot(self._lidar.scan_now(*self._xyth(), self._t), self.told_mount)

    # -- the physics step ---------------------------------------------------------------------------
    def _advance(self, dt: float) -> None:
        if self._t >= self._next_push:
            self._random_push()
        v, w = self._drive.step(self._t, dt)
        body, control = self._body, self._control
        th = _angle(body)  # chipmunk's own reads and step (_pymunk_fast): the same numbers, cheaper
        # the property setters directly: pymunk's typing mixin __setattr__ costs as much again
        _set_velocity(control, (v * math.cos(th), v * math.sin(th)))
        _set_angular_velocity(control, w)
        _set_position(control, _position(body))
        if self.movers is not None:
            self.movers.step(self._t, dt, self._xyth(), self.body.front_offset, (v * math.cos(th), v * math.sin(th), w))
        _space_step(self._space, dt)
        (px, py), angle = _position(body), _angle(body)  # read once: nothing below moves the body
        if self._gyro is not None:
            self._gyro.step((angle - th) / dt, dt)
        if self._shock is not None:
            after = _velocity(body)
            self._shock.step(self._velocity, after, dt)
            self._velocity = after
        self._t += dt
        self._contacts.update(self._t, body, self.movers)
        pose = (px, py, angle)  # _xyth(), from the reads above
        self.trajectory.append((self._t, *pose))
        frame = self._lidar.step(self._t, pose)
        if frame is not None:
            if self.told_mount != (0.0, 0.0, 0.0):  # the LiDAR's frame to the robot's, by the mount told
                frame = ScanFrame(_to_robot(frame.points, self.told_mount), frame.timestamp,
                                  point_times=frame.point_times)
            self._latest, self._delivered = frame, False

    def _random_push(self) -> None:
        """A push of ``push_rate`` (its size and direction from the push stream), and the next one's time."""
        rng, n = self._push_rng, self.noise
        assert rng is not None
        self.push(n.push_size * float(rng.uniform(0.5, 1.5)), float(rng.uniform(-math.pi, math.pi)))
        self._next_push = self._t + float(rng.exponential(1 / n.push_rate))


def make_world_robot(
    scene: Scene,
    noise: str | WorldNoise = "paper",
    noise_scale: float = 1.0,
    seed: int | None = None,
    *,
    robot: Body | None = None,
    **options: Any,
) -> WorldRobot:
    """The execution world for ``scene``: a :class:`WorldRobot` with a named noise preset.

    ``noise`` is a preset name (``ideal``, ``paper``, ``harsh``; ``specs/noise_presets.json``)
    or a :data:`WorldNoise`; ``noise_scale`` multiplies every term of a named preset.
    ``robot`` (a :class:`~clomp.planner.robot_model.Body`, e.g. the planner's ``RobotModel``)
    gives the body its dimensions (and a model its top speed), unless ``body`` is given;
    ``options`` go to :class:`WorldRobot` (``rays``, ``scan_rate``, ``dt``, ``start``,
    ``mount``, ``told_mount`` …).

    >>> from clomp.planner.scenarios import load_scenario
    >>> w = make_world_robot(load_scenario("overtaking"), "harsh", seed=3)
    >>> w.noise.latency, w.read_scan().points.shape[1]
    (0.1, 2)
    """
    wn = WorldNoise.preset(noise, noise_scale) if isinstance(noise, str) else noise
    body = options.pop("body", None)
    if body is None and robot is not None:
        body = BodySpec.like(robot)
    return WorldRobot(scene, noise=wn, body=body, seed=seed, **options)
