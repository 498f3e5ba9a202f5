"""The hardware robot: a :class:`~clomp.runtime.interface.Robot` backend over an RPLIDAR A1 and a
Pololu Maestro driving two continuous-rotation wheel servos, optionally with a BNO08x IMU.

Wheel speeds in m/s become the Maestro's normalised speeds in [-1, 1] by dividing by the robot model's
``max_speed`` (0.2 m/s on the paper's robot). The paper's robot has no wheel encoders, so
:meth:`HardwareRobot.odometry` is dead reckoning from the commanded speeds and the times they were sent (or
None when disabled).

A background thread reads the LiDAR all the time, so the control loop never blocks on the serial line and
the device layer watches the stream on its own: a port failure, no byte for ``byte_timeout`` s, or a stream
that is mostly undecodable (more than ``garbage_fraction`` of the bytes of the last ``garbage_window`` s)
*trips* the robot — the wheels are stopped from that thread at once, and every later :meth:`read_scan` /
:meth:`set_wheel_speeds` raises :class:`~clomp.runtime.interface.RobotFault` with the reason. A little
garbage is resynchronised by the decoder and tolerated. Every device error (LidarError, MaestroError, serial
and OS errors) surfaces as a RobotFault naming the device and port; :meth:`stop` always tries to stop the
wheels.

With an IMU (``imu_port``: a BNO08x in UART-RVC mode, :mod:`clomp.runtime.devices.bno08x`) the robot is
:class:`~clomp.runtime.interface.TurnSensing`: :meth:`HardwareRobot.rotation` is the heading the IMU turned
since its first report, which the supervisor's estimator follows for the heading (the wheels give the
distance, the scans the corrections) and whose offset it measures while the wheels stand, as it does the
execution world's gyro. :meth:`odometry` is then None, so the estimator reckons the wheels itself and knows
when they stand. The IMU's driver watches its stream as the LiDAR's is watched: unplugged, no report for
``imu_silence`` s, garbage instead of reports, or a yaw turning faster than the wheels can turn the robot
(``imu_rate_margin`` times their fastest spin) trips the robot at once from the IMU's reader thread — the
wheels stopped, every later call a RobotFault. Its reports' accelerations measure a kick's slide
(:meth:`slides`). Without an IMU :meth:`rotation` is None and nothing else changes.
In ``dry_run`` mode the LiDAR is read as usual but the wheels are held stopped (neutral is sent instead of
every command); the dead-reckoned pose still follows the commands, i.e. it is where the robot *would* be.
``clomp run --dry-run`` does not execute plans at all: it plans on every scan with the robot standing still
(see ``clomp.runtime.cli.run``).
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field
from typing import Any, Literal, TypeVar

from clomp.formal.geometry import dead_reckon
from clomp.formal.model import Pose
from clomp.planner.noise import NoiseTerms
from clomp.planner.robot_model import RobotModel
from clomp.runtime.devices.port import PORT_ERRORS
from clomp.runtime.devices.bno08x import Bno08xRvc, ImuError, Slide
from clomp.runtime.devices.maestro import Maestro, MaestroError, WheelConfig
from clomp.runtime.devices.rplidar import DEFAULT_BAUDRATE, LidarError, LidarTimeout, RPLidar
from clomp.runtime.clock import Clock, WallClock, device_time
from clomp.runtime.interface import RobotFault, ScanFrame
from clomp.runtime.records.runlog import RunLogLike
from clomp.runtime.backends.calibration import ToldCalibration
from clomp.runtime.backends._lidar_watch import LidarWatch, _CountingPort, _describe, on_clock, open_lidar_port

__all__ = ["CalibratedHardwareRobot", "HardwareConfig", "HardwareRobot", "on_clock", "open_lidar_port"]
_T = TypeVar("_T")

_DEVICE_ERRORS: tuple[type[BaseException], ...] = (LidarError, MaestroError, ImuError, ValueError, *PORT_ERRORS)
#: seconds (device time) close() waits, once the wheels are stopped, for the reader to end and
#: the devices to be released: a stalled device (a write that blocks) is then left behind, and
#: never holds the process
CLOSE_BUDGET = 0.5


@dataclass(frozen=True)
class HardwareConfig:
    """Settings of the two devices and of the stream watch (SI units).

    Maestro: ``protocol`` (compact / pololu), ``device_number``, the two wheels'
    channels, signs and gains, ``neutral_us`` ± ``span_us`` pulse mapping,
    ``multiple_targets`` (Mini Maestro command), ``watchdog_timeout`` (the driver stops
    the wheels when no command came for that long). LiDAR: ``lidar_baudrate``,
    ``motor_control`` (``dtr`` on the A1's USB adapter), ``start_timeout`` for the
    first reply and the first revolution (a motor spinning up). Watch: ``byte_timeout``
    (once revolutions flow), ``garbage_window``, ``garbage_fraction``. IMU (when one is
    given): ``imu_baudrate``, ``imu_start_timeout`` for the first report, ``imu_silence``
    for every later gap, ``imu_rate_margin`` (a yaw turning faster than this times the
    wheels' fastest spin, ``2 max_speed / wheel_base``, is a fault), ``imu_still_rate``
    (rad/s: a yaw turning faster while the wheels stand is a fault; bno08x_still).

    >>> cfg = HardwareConfig(motor_control="none", dry_run=True)
    >>> cfg.to_dict()["dry_run"], cfg.motor_control
    (True, 'none')
    """

    lidar_baudrate: int = DEFAULT_BAUDRATE
    motor_control: Literal["dtr", "none"] = "dtr"
    start_timeout: float = 2.0
    maestro_baudrate: int = 115200
    protocol: Literal["compact", "pololu"] = "compact"
    device_number: int = 12
    left: WheelConfig = field(default_factory=lambda: WheelConfig(0, 1))
    right: WheelConfig = field(default_factory=lambda: WheelConfig(1, -1))
    neutral_us: float = 1500.0
    span_us: float = 100.0
    multiple_targets: bool = False
    watchdog_timeout: float | None = 0.3
    dry_run: bool = False
    odometry: bool = True
    byte_timeout: float = 0.15
    garbage_window: float = 0.1
    garbage_fraction: float = 0.5
    min_window_bytes: int = 200
    imu_baudrate: int = 115200
    imu_start_timeout: float = 1.0
    imu_silence: float = 0.2
    imu_rate_margin: float = 1.5
    imu_still_rate: float = 0.25

    def __post_init__(self) -> None:
        for name in ("start_timeout", "byte_timeout", "garbage_window", "imu_start_timeout", "imu_silence",
                     "imu_rate_margin", "imu_still_rate"):
            v = getattr(self, name)
            if not (isinstance(v, (int, float)) and math.isfinite(v) and v > 0):
                raise ValueError(f"{name} must be a positive number of seconds, got {v!r}")
        if not 0 < self.garbage_fraction <= 1:
            raise ValueError(f"garbage_fraction must be in (0, 1], got {self.garbage_fraction!r}")
        if self.left.channel == self.right.channel:
            raise ValueError("the left and right wheels need different Maestro channels")

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form (for the run log)."""
        return asdict(self)


class HardwareRobot(LidarWatch):
    """The paper's robot on serial ports: RPLIDAR A1 scans in, Maestro wheel commands out.

    ``lidar_port`` and ``motor_port`` are device paths, pyserial URLs or open serial-like
    objects (objects are not closed by :meth:`close`). ``motor_port`` may be None only
    in dry-run mode; ``imu_port`` (the same kinds, optional) a BNO08x in UART-RVC mode (see
    the module). ``log`` receives ``device``, ``motor`` and ``fault`` records (see
    :mod:`clomp.runtime.records.runlog`); ``clock`` (a :class:`~clomp.runtime.clock.Clock`, wall time by default)
    is the robot's one time: the dead reckoning's, and — through :func:`~clomp.runtime.clock.device_time` —
    the stream watch's windows and the LiDAR and Maestro drivers' deadlines, so a test that
    drives simulated devices on its own time passes that clock alone. Waiting for a scan in
    :meth:`read_scan` blocks in wall time.
    Opening checks the LiDAR's health, stops the wheels and starts the scan; a device
    that cannot be opened or does not answer raises :class:`RobotFault`.

    >>> from clomp.runtime.backends.emulated import EmulatedWorld
    >>> with EmulatedWorld("open", time_scale=2.0) as world:
    ...     with HardwareRobot(world.lidar_port, world.motor_port, HardwareConfig(motor_control="none")) as robot:
    ...         frame = robot.read_scan(timeout=5.0)
    ...         robot.stop()
    >>> frame is not None and frame.points.shape[1] == 2
    True
    """

    def __init__(
        self,
        lidar_port: str | Any,
        motor_port: str | Any | None,
        config: HardwareConfig | None = None,
        *,
        model: RobotModel | None = None,
        log: RunLogLike | None = None,
        clock: Clock | None = None,
        imu_port: str | Any | None = None,
    ) -> None:
        self.config = cfg = config or HardwareConfig()
        self.model = model or RobotModel()
        self.dry_run = cfg.dry_run
        self.clock: Clock = clock or WallClock()
        self._device_clock = device_time(self.clock)
        self._log_sink = log
        self._log_lock = threading.Lock()
        self._lock = threading.Condition()
        self._fault: str | None = None
        self._closing = threading.Event()
        self._latest: ScanFrame | None = None
        self._delivered = True
        self.scans = 0
        self._cmd = (0.0, 0.0)
        self._pose = Pose(0.0, 0.0, 0.0)
        self._pose_t = self.clock.now()
        self._sent: tuple[tuple[float, float], tuple[float, float]] | None = None
        self._stop_failed = False
        self._thread: threading.Thread | None = None
        self._owned_lidar_port: Any = None
        self.maestro: Maestro | None = None
        self.imu: Bno08xRvc | None = None
        if motor_port is None and not cfg.dry_run:
            raise ValueError("a motor port is needed unless dry_run is set")
        try:
            if motor_port is not None:
                self.maestro = self._open_maestro(motor_port)
                self._maestro_stop()  # wheels stopped before anything else happens
            if imu_port is not None:
                self.imu = self._open_imu(imu_port)
            self.lidar, self._counter = self._open_lidar(lidar_port)
        except BaseException:
            self._release()
            raise
        self._thread = threading.Thread(target=self._watch, name="lidar-reader", daemon=True)
        self._thread.start()

    # -- opening ------------------------------------------------------------------------------
    def _open_maestro(self, port: str | Any) -> Maestro:
        cfg = self.config
        try:
            maestro = Maestro(
                port,
                baudrate=cfg.maestro_baudrate,
                protocol=cfg.protocol,
                device_number=cfg.device_number,
                left=cfg.left,
                right=cfg.right,
                neutral_us=cfg.neutral_us,
                span_us=cfg.span_us,
                watchdog_timeout=cfg.watchdog_timeout,
                multiple_targets=cfg.multiple_targets,
                clock=self._device_clock,
            )
        except (MaestroError, ValueError, TypeError) as exc:
            raise RobotFault(f"motor controller: {exc}") from exc
        maestro.on_watchdog_stop = self._on_watchdog_stop
        return maestro

    def _open_imu(self, port: str | Any) -> Bno08xRvc:
        """Open the IMU; its faults (also no first report within ``imu_start_timeout``) trip the robot."""
        cfg, model = self.config, self.model
        max_rate = cfg.imu_rate_margin * 2.0 * model.max_speed / model.wheel_base
        try:
            imu = Bno08xRvc(port, baudrate=cfg.imu_baudrate, silence_timeout=cfg.imu_silence,
                            start_timeout=cfg.imu_start_timeout, clock=self._device_clock, max_rate=max_rate,
                            still_rate=cfg.imu_still_rate)
        except (ImuError, ValueError, TypeError) as exc:
            raise RobotFault(f"IMU: {exc}") from exc
        # no wait for the first report here: the driver's start_timeout trips the robot when none comes
        imu.wheels_still(self.maestro is not None and not self.dry_run)  # stopped before the IMU was opened
        imu.on_fault = lambda exc: self._trip(f"IMU on {imu.port_name} failed: {_describe(exc)}", source="imu")
        self._write_log("device", device="imu", port=imu.port_name, mode="rvc", max_rate=max_rate)
        return imu

    def _open_lidar(self, port: str | Any) -> tuple[RPLidar, _CountingPort]:
        cfg = self.config
        if isinstance(port, str):
            raw = open_lidar_port(port, cfg.lidar_baudrate)
            self._owned_lidar_port = raw
        else:
            raw = port
        counter = _CountingPort(raw)
        try:
            lidar = RPLidar(counter, timeout=cfg.start_timeout, motor_control=cfg.motor_control,
                            max_range=self.model.sensor_range, clock=self._device_clock)
            health = lidar.health()
            info = lidar.info()
            self._write_log("device", device="lidar", port=lidar.port_name, model=info.model,
                            firmware=info.firmware, hardware=info.hardware, serial=info.serial_hex,
                            health=health.name, error_code=health.error_code)
            lidar.start_scan()
        except LidarTimeout as exc:
            raise RobotFault(f"LiDAR does not answer: {exc}") from exc
        except _DEVICE_ERRORS as exc:
            raise RobotFault(f"LiDAR on {getattr(raw, 'port', None) or raw}: {exc}") from exc
        return lidar, counter

    def _trip(self, reason: str, *, source: str) -> None:
        """Latch a fault and stop the wheels now (from whichever thread found it)."""
        with self._lock:
            if self._fault is not None:
                return
            self._fault = reason
            self._lock.notify_all()
        self._write_log("fault", reason=reason, source=source)
        try:
            self._halt_wheels("fault")
        except RobotFault:
            pass  # logged by _halt_wheels

    @property
    def wheels_stopped(self) -> bool:
        """False while driving, and when the last attempt to stop the wheels could not reach
        the motor controller (then only its own serial timeout, or power, stops them)."""
        return self._cmd == (0.0, 0.0) and not self._stop_failed

    @property
    def fault(self) -> str | None:
        """Why the robot tripped, or None while it is healthy."""
        return self._fault

    def _check(self) -> None:
        if self._fault is not None:
            raise RobotFault(self._fault)

    # -- Robot protocol ---------------------------------------------------------------------------
    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The newest revolution not returned before, or None if none arrived in ``timeout`` s.

        ``None`` waits until one arrives (the stream watch guarantees an end: a silent
        LiDAR trips the robot). Raises RobotFault once the robot has tripped.
        """
        deadline = None if timeout is None else time.monotonic() + max(0.0, timeout)
        with self._lock:
            while True:
                self._check()
                if not self._delivered and self._latest is not None:
                    self._delivered = True
                    return self._latest
                if self._closing.is_set():
                    raise RobotFault("the hardware robot is closed")
                remaining = None if deadline is None else deadline - time.monotonic()
                if remaining is not None and remaining <= 0:
                    return None
                self._lock.wait(remaining if remaining is not None else 0.5)

    def set_wheel_speeds(self, left: float, right: float) -> None:
        """Command the wheels (m/s, saturated at the model's ``max_speed``).

        In dry-run mode the wheels are held stopped instead. Raises RobotFault (after
        stopping the wheels) on a non-finite speed, a device error, or once tripped.
        """
        self._check()
        if self._closing.is_set():
            raise RobotFault("the hardware robot is closed")
        if not (math.isfinite(left) and math.isfinite(right)):
            self._trip(f"non-finite wheel speeds commanded ({left}, {right})", source="control")
            self._check()
        vmax = self.model.max_speed
        vl, vr = (min(max(float(v), -vmax), vmax) for v in (left, right))
        if self.maestro is None:
            self._set_command((vl, vr))
            return
        try:
            if self.dry_run:
                self._set_command((vl, vr))  # a dry run reckons as if the wheels obeyed
                self._maestro_stop()
                sent = (0.0, 0.0)
            else:
                # reckoned from when the command is sent: a watchdog stop just before it
                # (see _on_watchdog_stop) is then followed, not overwritten, by this command
                self.maestro.set_speeds(vl / vmax, vr / vmax)
                self._set_command((vl, vr))
                sent = (vl / vmax, vr / vmax)
            self._stop_failed = False
        except _DEVICE_ERRORS as exc:
            reason = f"motor controller on {self.maestro.port_name} failed: {_describe(exc)}"
            self._trip(reason, source="motors")
            raise RobotFault(self._fault or reason) from exc
        self._log_motor((vl, vr), sent)

    def stop(self) -> None:
        """Stop the wheels now; raises RobotFault if the motor controller cannot be reached."""
        self._halt_wheels("stop")

    def odometry(self) -> Pose | None:
        """Dead reckoning from the commanded speeds (start = origin), or None when disabled or
        with an IMU (the estimator then reckons the commanded wheels itself, the heading the IMU's).

        A stop by the motor controller's watchdog counts: the pose then stays where it was."""
        if not self.config.odometry or self.imu is not None:
            return None
        with self._lock:
            self._dead_reckon(self.clock.now())
            return self._pose

    @property
    def heading_sensor(self) -> bool:
        """Whether the robot carries an IMU, reported yet or not (:func:`~clomp.runtime.interface.has_heading_sensor`)."""
        return self.imu is not None

    def rotation(self) -> float | None:
        """The heading the IMU turned since its first report (rad, ccw; None: no IMU; TurnSensing; RobotFault once tripped)."""
        return self._from_imu(Bno08xRvc.rotation)

    def peak_acceleration(self) -> float | None:
        """The IMU's largest horizontal acceleration since the last call (m/s², None: none; ShockSensing)."""
        return self._from_imu(Bno08xRvc.peak_acceleration)

    def slides(self) -> list[Slide] | None:
        """The kicks' slides the IMU measured since the last call (bno08x_slide; None: no IMU; SlideSensing)."""
        return self._from_imu(Bno08xRvc.slides)

    def _from_imu(self, read: Callable[[Bno08xRvc], _T]) -> _T | None:
        """``read`` of the IMU (None without one); its faults trip the robot (RobotFault)."""
        if self.imu is None:
            return None
        self._check()
        try:
            return read(self.imu)
        except ImuError as exc:
            self._trip(f"IMU on {self.imu.port_name} failed: {_describe(exc)}", source="imu")
            raise RobotFault(self._fault or str(exc)) from exc

    def close(self) -> None:
        """Stop the wheels (best effort), end the readers, stop the LiDAR, release the ports.

        Once the wheels are stopped, the rest is bounded by :data:`CLOSE_BUDGET` (device and wall time):
        what a stalled device still holds then is left to a daemon thread and logged
        (``close`` record), so it never keeps the process from exiting."""
        if self._closing.is_set():
            return
        try:
            self._halt_wheels("close")
        except RobotFault:
            pass
        self._closing.set()
        with self._lock:
            self._lock.notify_all()
        deadline, wall_end = self._device_clock() + CLOSE_BUDGET, time.monotonic() + CLOSE_BUDGET
        if self._thread is not None and self._thread is not threading.current_thread():
            self._join(self._thread, deadline, wall_end)
        # released apart: a port whose write or close blocks (a stalled device) is left behind
        release = threading.Thread(target=self._release, name="device-release", daemon=True)
        release.start()
        if not self._join(release, deadline, wall_end):
            self._write_log("close", stalled=[t.name for t in (self._thread, release) if t is not None and t.is_alive()],
                            budget=CLOSE_BUDGET)

    def __enter__(self) -> HardwareRobot:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- internals ---------------------------------------------------------------------------------
    def _join(self, thread: threading.Thread, deadline: float, wall_end: float) -> bool:
        """Wait for ``thread`` until ``deadline`` (device time) or ``wall_end`` (wall time:
        simulated time may stand still meanwhile), whichever comes first; whether it ended."""
        while thread.is_alive():
            left = min(deadline - self._device_clock(), wall_end - time.monotonic())
            if left <= 0:
                return False
            thread.join(min(left, 0.01))
        return True

    def _release(self) -> None:
        if self.imu is not None:
            self.imu.close()
        if self.maestro is not None:
            try:
                self.maestro.close()  # stops the wheels (best effort) and ends its watchdog
            except _DEVICE_ERRORS:
                pass
        lidar = getattr(self, "lidar", None)
        if lidar is not None:
            try:
                lidar.close()
            except _DEVICE_ERRORS:
                pass
        if self._owned_lidar_port is not None:
            try:
                self._owned_lidar_port.close()
            except _DEVICE_ERRORS:
                pass
            self._owned_lidar_port = None

    def _maestro_stop(self) -> None:
        assert self.maestro is not None
        self.maestro.stop()

    def _halt_wheels(self, reason: str) -> None:
        self._set_command((0.0, 0.0))
        if self.maestro is None:
            return
        try:
            self._maestro_stop()
            self._stop_failed = False
        except _DEVICE_ERRORS as exc:
            self._stop_failed = True
            msg = f"could not stop the wheels: motor controller on {self.maestro.port_name} failed: {_describe(exc)}"
            self._write_log("motor", left=0.0, right=0.0, sent=None, reason=reason, error=msg)
            raise RobotFault(msg) from exc
        self._log_motor((0.0, 0.0), (0.0, 0.0), reason=reason)

    def _on_watchdog_stop(self) -> None:
        """The Maestro's watchdog stopped the wheels (no command for its timeout, e.g. a
        stalled control loop): dead reckoning stops with them, and the log says why."""
        if self._cmd == (0.0, 0.0) or self.dry_run:
            return
        self._set_command((0.0, 0.0))
        self._sent = None
        self._write_log("motor", left=0.0, right=0.0, sent=[0.0, 0.0], dry_run=False, reason="watchdog")

    def _set_command(self, cmd: tuple[float, float]) -> None:
        with self._lock:
            self._dead_reckon(self.clock.now())
            self._cmd = cmd
        if self.imu is not None:  # it judges its yaw while the wheels stand
            self.imu.wheels_still(cmd == (0.0, 0.0) and not self.dry_run)

    def _dead_reckon(self, now: float) -> None:
        dt = now - self._pose_t
        self._pose_t = now
        self._pose = dead_reckon(self._pose, *self._cmd, self.model.wheel_base, dt)

    def _log_motor(self, cmd: tuple[float, float], sent: tuple[float, float], reason: str | None = None) -> None:
        if self._log_sink is None or ((cmd, sent) == self._sent and reason != "fault"):
            return
        self._sent = (cmd, sent)
        extra = {"reason": reason} if reason else {}
        self._write_log("motor", left=cmd[0], right=cmd[1], sent=list(sent), dry_run=self.dry_run, **extra)

    def _write_log(self, event: str, **fields: Any) -> None:
        if self._log_sink is None:
            return
        with self._log_lock:
            try:
                self._log_sink.write(event, **fields)
            except Exception:  # a full disk must not stop the safety logic
                self._log_sink = None

    def __repr__(self) -> str:
        motors = self.maestro.port_name if self.maestro is not None else None
        imu = "" if self.imu is None else f", imu={self.imu.port_name!r}"
        return f"HardwareRobot(lidar={self.lidar.port_name!r}, motors={motors!r}{imu}, dry_run={self.dry_run})"


class CalibratedHardwareRobot(ToldCalibration, HardwareRobot):
    """A :class:`HardwareRobot` told its drive's calibration (``clomp run --calibration FILE``;
    :mod:`clomp.runtime.backends.calibration`): :meth:`calibration` reports ``calibration``'s
    terms, and the supervisor's estimator sizes its wheel prior to them
    (:class:`~clomp.runtime.interface.Calibrated`) instead of the worst case's. The other
    arguments are :class:`HardwareRobot`'s.
    """

    def __init__(self, lidar_port: str | Any, motor_port: str | Any | None, config: HardwareConfig | None = None,
                 *, calibration: NoiseTerms, **options: Any) -> None:
        self.tell(calibration)
        super().__init__(lidar_port, motor_port, config, **options)
