"""An emulated world for the hardware stack: the device emulators wired to a simulated robot.

:class:`EmulatedWorld` runs a :class:`~runtime.robots.sim.SimRobot` (the ground truth of a
scenario) in real time — a thread advances it every ``tick`` seconds of wall time — and
puts the two device emulators on pseudo-terminals in front of it: the Maestro
emulator's decoded wheel speeds drive the simulated robot's wheels, and each LiDAR
revolution is a scan of the simulated robot's current pose in the world. ``clomp run``
pointed at the two ptys then runs the whole hardware stack (drivers, the hardware
robot, the supervisor) without hardware, and the world tells whether it reached the goal
and whether it touched anything.

``time_scale`` > 1 runs the world (and the LiDAR's pace) faster than real time; the
controller must then use a :class:`runtime.clock.ScaledClock` of the same scale.
"""

from __future__ import annotations

import math
import os
import threading
import time
from typing import Any, Self

import numpy as np

from formal.model import Pose
from planner.robot import RobotModel
from planner.scenarios import Scene, load_scenario
from runtime.devices.maestro_emulator import MaestroEmulator
from runtime.devices.rplidar_emulator import LidarEmulator
from runtime.devices.maestro import WheelConfig
from runtime.robots.sim import NoiseConfig, SimRobot
from runtime.robots.world import WorldNoise, WorldRobot, make_world_robot

__all__ = ["EmulatedWorld"]


class EmulatedWorld:
    """A scenario's world behind an emulated RPLIDAR A1 and an emulated Maestro.

    ``scenario`` is a built-in scenario name, a scenario file or a :class:`Scene`.
    ``noise`` and ``seed`` go to the simulated robot (default: the scenario's); a preset
    name (``ideal``, ``paper``, ``harsh``) or a :class:`~runtime.robots.world.WorldNoise`
    runs the execution world (:mod:`runtime.robots.world`: acceleration limits, latency,
    slip, a noisy LiDAR whose revolutions the emulated A1 then streams). The
    wheel mapping (``left``, ``right``, ``neutral_us``, ``span_us``) must match the
    driver's. ``lidar_options`` are passed to :class:`LidarEmulator` (fault injection);
    its attributes such as ``garbage_rate`` can also be changed while it runs.
    ``serial_timeout`` is the Maestro's own fail-safe (off by default, as on a new
    board): no byte for that long sends the wheels home (stopped).

    >>> with EmulatedWorld("open") as world:
    ...     world.lidar_port.startswith("/dev/"), world.motor_port.startswith("/dev/"), world.collisions
    (True, True, 0)
    """

    def __init__(
        self,
        scenario: str | os.PathLike[str] | Scene,
        *,
        model: RobotModel | None = None,
        noise: NoiseConfig | WorldNoise | str | None = None,
        seed: int | None = None,
        time_scale: float = 1.0,
        tick: float = 0.02,
        left: WheelConfig = WheelConfig(0, 1),
        right: WheelConfig = WheelConfig(1, -1),
        neutral_us: float = 1500.0,
        span_us: float = 100.0,
        device_number: int = 12,
        lidar_options: dict[str, Any] | None = None,
        serial_timeout: float | None = None,
    ) -> None:
        if not (math.isfinite(time_scale) and time_scale > 0):
            raise ValueError(f"time_scale must be a positive number, got {time_scale!r}")
        if not tick > 0:
            raise ValueError("tick must be positive")
        self.scene = scenario if isinstance(scenario, Scene) else load_scenario(scenario)
        self.model = model or RobotModel()
        self.sim: SimRobot | WorldRobot
        if isinstance(noise, (str, WorldNoise)):
            self.sim = make_world_robot(self.scene, noise, seed=seed, robot=self.model)
        else:
            self.sim = SimRobot(self.scene, self.model, noise=noise, seed=seed)
        self.time_scale = float(time_scale)
        self.tick = float(tick)
        self.error: BaseException | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        options = {"speed": self.time_scale, **(lidar_options or {})}
        self.lidar = LidarEmulator(self._scan, **options)
        self.maestro = MaestroEmulator(
            device_number=device_number,
            left=left,
            right=right,
            neutral_us=neutral_us,
            span_us=span_us,
            on_speeds=self._on_speeds,
            serial_timeout=serial_timeout,
        )

    # -- wiring -----------------------------------------------------------------------------
    def _on_speeds(self, left: float, right: float) -> None:
        """Maestro emulator → simulated wheels (normalised speed × max_speed)."""
        vmax = self.model.max_speed
        with self._lock:
            self.sim.set_wheel_speeds(left * vmax, right * vmax)

    def _scan(self) -> np.ndarray:
        """One LiDAR revolution: the world seen from the simulated robot's pose now (1 cm grid);
        in the execution world, its newest revolution as its own LiDAR took it."""
        with self._lock:
            if isinstance(self.sim, WorldRobot):
                frame = self.sim.newest_revolution()
                pts = frame.points if frame is not None else self.sim.scan_now()
            else:
                pts = self.sim.scan_now()
        return np.round(pts, 2)

    def _run(self) -> None:
        last = time.monotonic()
        try:
            while not self._stop.wait(self.tick):
                now = time.monotonic()
                with self._lock:
                    self.sim.sleep((now - last) * self.time_scale)
                last = now
        except Exception as exc:  # keep it for the caller instead of a thread traceback
            self.error = exc

    # -- lifetime -----------------------------------------------------------------------------
    def start(self) -> Self:
        """Open both ptys and start the world; returns self."""
        if self._thread is not None:
            raise RuntimeError("the emulated world is already running")
        self.maestro.start()
        self.lidar.start()
        self._thread = threading.Thread(target=self._run, name="emulated-world", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the world and close both ptys (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.lidar.stop()
        self.maestro.stop()

    def __enter__(self) -> Self:
        if self._thread is None:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # -- what a test or a user looks at ----------------------------------------------------------
    @property
    def lidar_port(self) -> str:
        """The LiDAR emulator's pty (what ``clomp run --lidar`` opens)."""
        return self.lidar.port

    @property
    def motor_port(self) -> str:
        """The Maestro emulator's pty (what ``clomp run --motors`` opens)."""
        return self.maestro.port

    @property
    def pose(self) -> Pose:
        """The simulated robot's true pose in the world frame."""
        with self._lock:
            return self.sim.pose

    @property
    def collisions(self) -> int:
        """Contacts of the robot's body with an obstacle so far."""
        with self._lock:
            return self.sim.collisions

    @property
    def goal_distance(self) -> float:
        """True distance (m) from the robot's rotation centre to the scenario's goal."""
        p = self.pose
        gx, gy = self.scene.goal
        return math.hypot(p.x - gx, p.y - gy)

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the start."""
        with self._lock:
            return self.sim.now()
