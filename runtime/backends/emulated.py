"""An emulated world for the hardware stack: the device emulators wired to a simulated robot.

Three devices: the LiDAR and the Maestro, and a BNO08x IMU in UART-RVC mode reporting the
world's true heading at 100 Hz with a drift, noise, scale error, dropped reports and
garbage bursts drawn from the noise preset (:mod:`clomp.runtime.backends._imu`), for
``clomp run --imu``; a run without it never opens its port.

:class:`EmulatedWorld` runs a :class:`~clomp.runtime.backends.sim.SimRobot` (the ground truth of a
scenario) in real time — a thread advances it every ``tick`` seconds of wall time — and
puts the two device emulators on pseudo-terminals in front of it: the Maestro
emulator's decoded wheel speeds drive the simulated robot's wheels, and each LiDAR
revolution is a scan of the simulated robot's current pose in the world. With the
execution world (a ``noise`` preset), the world's LiDAR turns clockwise as an A1 does and
the emulated A1 sends each sample in the emulator tick after the world measured it
(:meth:`~clomp.runtime.backends.world.WorldRobot.stream`), so a revolution reaches the driver
when it ends, skewed by the motion during it, as from the device. ``clomp run``
pointed at the two ptys then runs the whole hardware stack (drivers, the hardware
robot, the supervisor) without hardware, and the world tells whether it reached the goal
and whether it touched anything.

The world's time runs only while a program drives the robot (the LiDAR scans, or the robot
is not yet at rest): served before ``clomp run`` starts or after it ended it is held
(:meth:`EmulatedWorld._driven`), so nothing pushes it while nobody runs it.

``time_scale`` > 1 runs the world (and the LiDAR's pace) faster than real time; the
controller must then use a :class:`clomp.runtime.clock.ScaledClock` of the same scale.
``clock`` (a :class:`clomp.runtime.clock.Clock`) replaces wall time for the world and both
emulators when it is not a wall clock itself (a test's simulated time, read through
:func:`clomp.runtime.clock.device_time`: the world is then advanced whenever the LiDAR starts
a revolution or a wheel command arrives, and is not started as a thread).
"""

from __future__ import annotations

import math
import os
import threading
import time
from collections import deque
from collections.abc import Callable
from typing import Any, Self

import numpy as np

from clomp.formal.geometry import polar_to_xy, relative
from clomp.formal.model import Pose
from clomp.planner.noise import NoiseTerms
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene, load_scenario
from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from clomp.runtime.devices.maestro_emulator import MaestroEmulator
from clomp.runtime.devices.rplidar_emulator import LidarEmulator
from clomp.runtime.devices.maestro import WheelConfig
from clomp.runtime.backends._imu import imu_terms
from clomp.runtime.backends.imu_fault import ImuFault
from clomp.runtime.backends.sim import NoiseConfig, SimRobot
from clomp.runtime.realtime import favour_this_thread
from clomp.runtime.backends.world import WorldNoise, WorldRobot, make_world_robot
from clomp.runtime.clock import Clock, device_time

__all__ = ["IMPACT", "EmulatedWorld", "EmulatedWorldProcess"]

IMPACT = 0.03
"""How long (world s) the emulated accelerometer feels a kick: a push's contact, three 10 ms reports."""
_AT_REST = 1e-9  # m or rad a physics step may still move a body at rest (the solver's residue)


class EmulatedWorld:
    """A scenario's world behind an emulated RPLIDAR A1 and an emulated Maestro.

    ``scenario`` is a built-in scenario name, a scenario file or a :class:`Scene`.
    ``noise`` and ``seed`` go to the simulated robot (default: the scenario's); a preset
    name (``ideal``, ``paper``, ``harsh``) or a :class:`~clomp.runtime.backends.world.WorldNoise`
    runs the execution world (:mod:`clomp.runtime.backends.world`: acceleration limits, latency,
    slip, a noisy LiDAR whose revolutions the emulated A1 then streams). The
    wheel mapping (``left``, ``right``, ``neutral_us``, ``span_us``) must match the
    driver's. ``lidar_options`` are passed to :class:`LidarEmulator` (fault injection);
    its attributes such as ``garbage_rate`` can also be changed while it runs.
    ``imu_options`` are laid over the IMU emulator's arguments the preset gives
    (:func:`~clomp.runtime.backends._imu.imu_terms`; e.g. ``{"drop_rate": 0.0}``);
    ``imu_fault`` (:class:`~clomp.runtime.backends.imu_fault.ImuFault`) fails the IMU at a
    moment of world time (``clomp emulate world --imu-fault``).
    ``serial_timeout`` is the Maestro's own fail-safe (off by default, as on a new
    board): no byte for that long sends the wheels home (stopped). ``movers``: bodies that
    move or appear (people, boxes, a door that closes; :mod:`clomp.runtime.backends._movers`),
    in the execution world only (a preset or WorldNoise ``noise``; issue #42).

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
        imu_options: dict[str, Any] | None = None,
        imu_fault: ImuFault | None = None,
        serial_timeout: float | None = None,
        clock: Clock | None = None,
        movers: tuple[Any, ...] = (),
    ) -> None:
        if not (math.isfinite(time_scale) and time_scale > 0):
            raise ValueError(f"time_scale must be a positive number, got {time_scale!r}")
        if not tick > 0:
            raise ValueError("tick must be positive")
        self.scene = scenario if isinstance(scenario, Scene) else load_scenario(scenario)
        self.model = model or RobotModel()
        self.sim: SimRobot | WorldRobot
        self.movers = tuple(movers)
        if isinstance(noise, (str, WorldNoise)):  # the A1 turns clockwise: so does the world's LiDAR
            self.sim = make_world_robot(self.scene, noise, seed=seed, robot=self.model, sweep=-1, movers=self.movers)
        elif self.movers:
            raise ValueError("bodies that move or appear need the execution world (a noise preset or a WorldNoise)")
        else:
            self.sim = SimRobot(self.scene, self.model, noise=noise, seed=seed)
        # the world's compiled ray caster loads (or compiles) on its first call: 1.5 s on a busy
        # host, with the world's lock held; here, not when clomp run starts the LiDAR (the
        # IMU's reports then stalled behind it: 'fell silent' 0.3 s into 8 of 9 runs)
        self.sim.scan_now()
        self.time_scale = float(time_scale)
        self.tick = float(tick)
        now = time.monotonic if clock is None else device_time(clock)
        self.clock: Callable[[], float] = now  # the devices' time: the world's and both emulators'
        self.imu_fault = imu_fault
        if imu_fault is not None and imu_fault.clock is None:
            imu_fault.clock = now
        self.error: BaseException | None = None
        self._lock = threading.Lock()
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._last: float | None = None  # wall time up to which the world has been advanced
        self._felt: deque[tuple[float, float, float]] = deque()  # (world s, ax, ay): the accelerometer's last IMPACT s
        options = {"speed": self.time_scale, **(lidar_options or {})}
        if isinstance(self.sim, WorldRobot):  # each sample sent when the world measured it
            options.setdefault("sample_stream", self._samples)
        self.lidar = LidarEmulator(self._scan, clock=now, **options)
        self.maestro = MaestroEmulator(
            device_number=device_number,
            left=left,
            right=right,
            neutral_us=neutral_us,
            span_us=span_us,
            on_speeds=self._on_speeds,
            serial_timeout=serial_timeout,
            clock=now,
        )
        world_noise = self.sim.noise if isinstance(self.sim, WorldRobot) else None
        felt = self._acceleration if isinstance(self.sim, WorldRobot) else None  # the older robot: gravity alone
        self.imu = Bno08xEmulator(self._heading, clock=now, **{"acceleration": felt,
                                  **imu_terms(world_noise, seed, self.time_scale), **(imu_options or {})})

    # -- wiring -----------------------------------------------------------------------------
    def _on_speeds(self, left: float, right: float) -> None:
        """Maestro emulator → simulated wheels (normalised speed × max_speed), from the moment
        the command arrived: the world is first brought up to now at the old speeds (else the
        new speeds would also drive the part of the tick before they arrived)."""
        vmax = self.model.max_speed
        with self._lock:
            self._catch_up(exact=True)
            self.sim.set_wheel_speeds(left * vmax, right * vmax)

    def _catch_up(self, exact: bool = False) -> None:
        """Advance the world to the clock's time now (call with the lock held): in whole
        physics steps (``quantum``), up to now ``exact``-ly only for a wheel command (which
        drives the world from the moment it arrived). Stepped in slivers of a few ms, as the
        devices' threads ask, the body's velocity jitters (an accelerometer read 135 m/s², a
        kick, while the robot merely drove), where the execution world's own runs step whole quanta."""
        now = self.clock()
        if self._last is None or not self._driven():
            self._last = now  # held: no time passes for the world (see :meth:`_driven`)
            return
        if exact:
            if now > self._last:
                self.sim.sleep((now - self._last) * self.time_scale)
                self._last = now
            return
        q = self.sim.quantum
        steps = math.floor((now - self._last) * self.time_scale / q + 1e-9)
        if steps > 0:
            self.sim.sleep(steps * q)
            self._last += steps * q / self.time_scale

    def _driven(self) -> bool:
        """Whether the world's time runs now: while the LiDAR scans (a program runs the robot)
        or the robot is not at rest (its wheels commanded or still turning, its body moving).

        Otherwise it is held: a world served before ``clomp run`` starts (seconds to minutes:
        a user types the command) or after it ended would be pushed, would let its wheel
        bias walk and its movers walk while nobody drives the robot, so the run would start
        elsewhere than the scenario's start (the goal given in the frame at start) and the
        ground truth would end elsewhere than where the run left it: harsh runs over ptys
        started from a pose pushed 0.13-0.22 m before the first wheel command (world time
        15-18 s at ``--time-scale 2``) and were judged 0.12-0.25 m from the goal."""
        if self.lidar.scanning:
            return True
        sim = self.sim
        if sim.commanded != (0.0, 0.0) or getattr(sim, "wheel_speeds", (0.0, 0.0)) != (0.0, 0.0):
            return True
        traj = sim.trajectory
        return len(traj) >= 2 and max(abs(a - b) for a, b in zip(traj[-1][1:], traj[-2][1:])) > _AT_REST

    def _scan(self) -> np.ndarray:
        """One LiDAR revolution: the world seen from the simulated robot's pose now (rounded as
        the world's LiDAR rounds); in the execution world, its newest revolution as its own
        LiDAR took it."""
        with self._lock:
            self._catch_up()  # the world as it is now, not at the last tick
            if isinstance(self.sim, WorldRobot):
                frame = self.sim.newest_revolution()
                pts = frame.points if frame is not None else self.sim.scan_now()
            else:
                pts = self.sim.scan_now()
        return np.round(pts, 2)

    def _heading(self) -> float:
        """The simulated robot's true heading now (rad, world frame): what the IMU measures
        (what it reports under ``imu_fault``, which comes here at its time)."""
        with self._lock:
            self._catch_up()
            pose, now = self.sim.pose, self.sim.now()
        fault = self.imu_fault
        return pose.theta if fault is None else fault.heading(pose.theta, now, self.imu, pose)

    def _acceleration(self) -> tuple[float, float]:
        """The execution world's largest horizontal body acceleration over the last
        :data:`IMPACT` s of world time, in the body's frame (m/s², x forward, y left): what the
        IMU's accelerometer feels (a kick, a collision), (0, 0) when the world has no IMU
        (``gyro=False``).

        The world's push is a change of velocity within one physics step, so its peak falls
        in one 10 ms report, and the line loses a report in ten at ``harsh``: one kick in ten
        reached ``clomp run --imu`` as the slide's 7.8 m/s² alone (a jolt, not a kick; seed 0
        at --time-scale 2 ended truly 0.119 m off believing a 5 cm doubt). A kick's contact
        lasts tens of ms, several reports; so is it felt here, as the world's own
        :meth:`~clomp.runtime.backends.world.WorldRobot.peak_acceleration` (no line) never misses it."""
        assert isinstance(self.sim, WorldRobot)
        with self._lock:
            self._catch_up()
            vec = self.sim.peak_acceleration_vector()
            theta = self.sim.pose.theta
            now = self.sim.now()
            felt = self._felt
            if vec is not None:
                felt.append((now, vec[0], vec[1]))
            while felt and felt[0][0] < now - IMPACT + 1e-9:
                felt.popleft()
        if vec is None or not felt:
            return (0.0, 0.0)
        _t, ax, ay = max(felt, key=lambda f: math.hypot(f[1], f[2]))
        body = relative(Pose(0.0, 0.0, theta), Pose(ax, ay))
        return (body.x, body.y)

    def _samples(self) -> list[tuple[float, float, bool]]:
        """The execution world's LiDAR samples measured since the last call, as an A1 sends
        them: (angle clockwise in degrees, distance in mm rounded as the world's LiDAR rounds
        it: the range, or the point on its grid; 0 for no return; whether it begins a
        revolution)."""
        assert isinstance(self.sim, WorldRobot)
        with self._lock:
            self._catch_up()
            steps = self.sim.stream()
        res = self.sim.resolution
        out: list[tuple[float, float, bool]] = []
        for angle, rng, _t, first in steps:
            ok = np.isfinite(rng)
            r = np.where(ok, rng, 0.0)
            if res > 0 and self.sim.rounding == "range":  # the range as the world's LiDAR reports it
                r = np.round(r / res) * res
            elif res > 0:  # the range of the point on the world's grid
                xy = np.round(polar_to_xy(r, angle) / res) * res
                r = np.hypot(xy[..., 0], xy[..., 1])
            dist = np.where(ok, r * 1000.0, 0.0)
            cw = np.degrees(-angle) % 360.0
            out += [(float(a), float(d), first and k == 0) for k, (a, d) in enumerate(zip(cw, dist))]
        return out

    def _run(self) -> None:
        with self._lock:
            self._last = self.clock()
        try:
            while not self._stop.wait(self.tick):
                with self._lock:
                    self._catch_up()
        except Exception as exc:  # keep it for the caller instead of a thread traceback
            self.error = exc

    # -- lifetime -----------------------------------------------------------------------------
    def start(self) -> Self:
        """Open the three ptys and start the world; returns self."""
        if self._thread is not None:
            raise RuntimeError("the emulated world is already running")
        self.maestro.start()
        self.lidar.start()
        self.imu.start()
        self._thread = threading.Thread(target=self._run, name="emulated-world", daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop the world and close the three ptys (idempotent)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout=2.0)
        self.imu.stop()
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
    def imu_port(self) -> str:
        """The IMU emulator's pty (what ``clomp run --imu`` opens)."""
        return self.imu.port

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
    def pushes(self) -> list[tuple[float, float]]:
        """The execution world's external pushes so far: (simulated s, distance m) each; []
        for the older simulated robot."""
        with self._lock:
            return [(p.time, p.distance) for p in getattr(self.sim, "pushes", [])]

    @property
    def slips(self) -> list[tuple[float, float]]:
        """The execution world's slip events so far: (start, end) simulated s each; [] for
        the older simulated robot."""
        with self._lock:
            return list(getattr(self.sim, "slips", []))

    @property
    def calibration(self) -> NoiseTerms | None:
        """What the world would tell a robot of its drive (the execution world's noise terms:
        what ``clomp emulate world --calibration-out`` writes for ``clomp run --calibration``),
        None for the older simulated robot (no terms a calibration file holds)."""
        return NoiseTerms(**self.sim.calibration()) if isinstance(self.sim, WorldRobot) else None

    @property
    def sim_time(self) -> float:
        """Simulated seconds since the start."""
        with self._lock:
            return self.sim.now()


# ------------------------------------------------------------------ in a process of its own

_METHOD = ("<method>",)  # what the child answers for an attribute that is a method


def _serve_world(conn: Any, scenario: Any, options: dict[str, Any], favour: bool) -> None:
    """The child process: one EmulatedWorld, answering the parent's requests until told to stop."""
    # before the world's threads start: they inherit it
    scheduling = favour_this_thread(realtime=True) if favour else "normal"
    try:
        world = EmulatedWorld(scenario, **options).start()
    except BaseException as exc:  # noqa: BLE001 - reported to the parent, which raises it
        conn.send(("failed", exc))
        return
    conn.send(("ready", world.lidar_port, world.motor_port, world.imu_port, scheduling))
    targets = {"world": world, "lidar": world.lidar, "maestro": world.maestro, "imu": world.imu}
    try:
        while True:
            try:
                op, target, name, args = conn.recv()
            except (EOFError, OSError):
                return  # the parent is gone
            if op == "stop":
                return
            obj = targets[target]
            try:
                if op == "get":
                    value = getattr(obj, name)
                    reply: Any = _METHOD if callable(value) else value
                elif op == "set":
                    setattr(obj, name, args)
                    reply = None
                else:  # call
                    reply = getattr(obj, name)(*args[0], **args[1])
                conn.send(("ok", reply))
            except Exception as exc:  # noqa: BLE001 - raised again in the parent
                conn.send(("error", exc))
    finally:
        world.stop()


class _Remote:
    """One object of the world process (the world, its LiDAR, Maestro or IMU), seen from the parent:
    attribute reads and writes and method calls go to the child; ``wait_for`` polls here."""

    def __init__(self, owner: EmulatedWorldProcess, target: str) -> None:
        object.__setattr__(self, "_owner", owner)
        object.__setattr__(self, "_target", target)

    def __getattr__(self, name: str) -> Any:
        if name.startswith("__"):
            raise AttributeError(name)
        value = self._owner._request("get", self._target, name)
        if value == _METHOD:
            return lambda *args, **kwargs: self._owner._request("call", self._target, name, (args, kwargs))
        return value

    def __setattr__(self, name: str, value: Any) -> None:
        self._owner._request("set", self._target, name, value)

    def wait_for(self, predicate: Callable[[Any], bool], timeout: float) -> bool:
        """Wait until ``predicate(self)`` holds (re-checked every 5 ms); False after ``timeout`` s."""
        deadline = time.monotonic() + timeout
        while not predicate(self):
            if time.monotonic() >= deadline or not self._owner.alive:
                return bool(predicate(self)) if self._owner.alive else False
            time.sleep(0.005)
        return True


class EmulatedWorldProcess:
    """An :class:`EmulatedWorld` in a process of its own, with the same face for tests and tools.

    In one process with the program under test, the world, the LiDAR's byte stream and the
    Maestro share its interpreter lock and its scheduling: on a busy machine a thread of the
    program holding the lock while the OS has it waiting stalls the emulated LiDAR for tenths
    of a second, and the driver rightly reports a LiDAR that fell silent. Here the devices
    run apart, and the process asks to be favoured by the scheduler
    (:mod:`clomp.runtime.realtime`, where allowed; ``scheduling`` says what it got): real devices
    and physics do not slow down when the host is busy.

    Takes :class:`EmulatedWorld`'s arguments. ``lidar``, ``maestro`` and ``imu`` forward attribute
    reads, writes and method calls (``world.lidar.silent = True``, ``world.maestro.vanish()``)
    to the devices in the child; ``wait_for(predicate, timeout)`` re-checks ``predicate``
    on them every 5 ms. Starting takes a second or two (a fresh interpreter).

    >>> with EmulatedWorldProcess("open") as world:
    ...     world.lidar_port.startswith("/dev/"), world.collisions, world.maestro.speeds
    (True, 0, (0.0, 0.0))
    """

    def __init__(self, scenario: str | os.PathLike[str] | Scene, *, favour: bool = True,
                 start_timeout: float = 120.0, **options: Any) -> None:
        self._scenario = scenario
        self._options = options
        self._favour = favour
        self._start_timeout = start_timeout
        self._conn: Any = None
        self._proc: Any = None
        self._lock = threading.Lock()
        self.lidar_port = self.motor_port = self.imu_port = ""
        #: how the world's process is scheduled ("realtime", "nice -10", "normal")
        self.scheduling = ""
        self.lidar: Any = _Remote(self, "lidar")
        self.maestro: Any = _Remote(self, "maestro")
        self.imu: Any = _Remote(self, "imu")
        self._world = _Remote(self, "world")

    def start(self) -> Self:
        """Start the child process and wait until both ptys are open; returns self."""
        import multiprocessing

        if self._proc is not None:
            raise RuntimeError("the emulated world is already running")
        ctx = multiprocessing.get_context("spawn")  # no fork of a multi-threaded parent
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_serve_world, args=(child, self._scenario, self._options, self._favour),
                                 name="emulated-world", daemon=True)
        self._proc.start()
        child.close()
        if not self._conn.poll(self._start_timeout):
            self.stop()
            raise RuntimeError(f"the emulated world's process did not start within {self._start_timeout:g} s")
        try:
            msg = self._conn.recv()
        except EOFError:
            self.stop()
            raise RuntimeError(f"the emulated world's process died at start (exit {self._proc.exitcode})") from None
        if msg[0] == "failed":
            self.stop()
            raise msg[1]
        _, self.lidar_port, self.motor_port, self.imu_port, self.scheduling = msg
        return self

    def _request(self, op: str, target: str, name: str = "", args: Any = ()) -> Any:
        with self._lock:
            if self._conn is None:
                raise RuntimeError("the emulated world is not running")
            self._conn.send((op, target, name, args))
            status, value = self._conn.recv()
        if status == "error":
            raise value
        return value

    @property
    def alive(self) -> bool:
        """True while the child process runs."""
        return self._proc is not None and self._proc.is_alive()

    def stop(self) -> None:
        """Stop the world, close both ptys and end the child (idempotent)."""
        with self._lock:
            conn, self._conn = self._conn, None
        if conn is not None:
            try:
                conn.send(("stop", "", "", ()))
            except (OSError, ValueError):
                pass
        if self._proc is not None:
            self._proc.join(timeout=10.0)
            if self._proc.is_alive():
                self._proc.kill()
                self._proc.join(timeout=5.0)
        if conn is not None:
            conn.close()

    def __enter__(self) -> Self:
        if self._proc is None:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def __getattr__(self, name: str) -> Any:
        # pose, collisions, goal_distance, sim_time, error, scene, ...: read in the child
        if name.startswith("_"):
            raise AttributeError(name)
        return getattr(self._world, name)
