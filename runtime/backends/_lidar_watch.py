"""The LiDAR side of :class:`~clomp.runtime.backends.hardware.HardwareRobot`: its port (opened
with a short read timeout, the bytes read through it counted), the reader thread that reads
revolutions and watches the stream, and a revolution put on the robot's clock.

A mixin and its helpers, moved out of :mod:`clomp.runtime.backends.hardware` unchanged (the
module reached its 600-line limit); ``open_lidar_port`` and ``on_clock`` are imported from
there as before.

>>> from clomp.runtime.backends.hardware import HardwareRobot
>>> issubclass(HardwareRobot, LidarWatch)
True
"""

from __future__ import annotations

import dataclasses
import threading
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

from clomp.runtime.clock import Clock, device_seconds, device_to_clock
from clomp.runtime.devices.port import OPEN_ERRORS, open_serial
from clomp.runtime.devices.rplidar import DEFAULT_BAUDRATE, LidarTimeout, RPLidar
from clomp.runtime.interface import RobotFault, ScanFrame

if TYPE_CHECKING:
    from clomp.runtime.backends.hardware import HardwareConfig

__all__ = ["LidarWatch", "on_clock", "open_lidar_port"]

_READ_SLICE = 0.05  # seconds one blocking read of the LiDAR port may take


class _CountingPort:
    """A serial-like port that counts the bytes read through it (the stream watch needs it)."""

    def __init__(self, port: Any) -> None:
        self._port = port
        self.bytes_read = 0

    def read(self, size: int = 1) -> bytes:
        data: bytes = self._port.read(size)
        self.bytes_read += len(data)
        return data

    @property
    def dtr(self) -> Any:
        return self._port.dtr

    @dtr.setter
    def dtr(self, value: bool) -> None:
        self._port.dtr = value

    def __getattr__(self, name: str) -> Any:
        return getattr(self._port, name)



def open_lidar_port(spec: str, baudrate: int = DEFAULT_BAUDRATE) -> Any:
    """Open a LiDAR serial port (path or pyserial URL) with a short read timeout.

    Raises :class:`RobotFault` with the port's name when it cannot be opened.
    """
    try:
        return open_serial(spec, baudrate, _READ_SLICE)
    except OPEN_ERRORS as exc:
        raise RobotFault(f"cannot open the LiDAR port {spec}: {exc}") from exc


def _describe(exc: BaseException) -> str:
    return f"{type(exc).__name__}: {exc}"


def on_clock(frame: ScanFrame, clock: Clock) -> ScanFrame:
    """``frame`` (stamped by the LiDAR's driver on :func:`~clomp.runtime.clock.device_time`) with its
    timestamp and point times on ``clock``: unchanged but on a ScaledClock, whose supervisor
    would otherwise take a revolution for one of another clock and de-skew it by wall seconds.

    >>> import numpy as np
    >>> from clomp.runtime.clock import ScaledClock
    >>> c = ScaledClock(2.0); f = on_clock(ScanFrame(np.zeros((2, 2)), c._origin + 1.0, point_times=np.array([-0.09, 0.0])), c)
    >>> round(f.timestamp, 9), f.point_times.tolist()
    (2.0, [-0.18, 0.0])
    """
    scale = device_seconds(clock)
    stamp = device_to_clock(clock)(frame.timestamp)
    if scale == 1.0 and stamp == frame.timestamp:
        return frame
    times = None if frame.point_times is None else frame.point_times * scale
    return dataclasses.replace(frame, timestamp=stamp, point_times=times)


class LidarWatch:
    """The reader thread of :class:`~clomp.runtime.backends.hardware.HardwareRobot` (see there
    for the settings it reads and the fault it trips)."""

    config: HardwareConfig
    clock: Clock
    lidar: RPLidar
    scans: int
    _counter: _CountingPort
    _device_clock: Callable[[], float]
    _closing: threading.Event
    _lock: threading.Condition
    _latest: ScanFrame | None
    _delivered: bool

    if TYPE_CHECKING:
        def _trip(self, reason: str, *, source: str) -> None: ...

    def _watch(self) -> None:
        """Read revolutions and watch the stream until closed or tripped."""
        cfg = self.config
        lidar, counter = self.lidar, self._counter
        now_fn = self._device_clock  # the stream watch's windows run on the devices' time
        last_bytes, last_byte_t = counter.bytes_read, now_fn()
        window: deque[tuple[float, int, int]] = deque([(last_byte_t, counter.bytes_read, lidar.dropped_bytes)])
        while not self._closing.is_set():
            try:
                frame: ScanFrame | None = lidar.read_scan(timeout=_READ_SLICE)
            except LidarTimeout:
                frame = None
            except Exception as exc:  # port gone, protocol error, anything: the stream is dead
                if not self._closing.is_set():
                    self._trip(f"LiDAR on {lidar.port_name} failed: {_describe(exc)}", source="lidar")
                return
            now = now_fn()
            if frame is not None:
                frame = on_clock(frame, self.clock)
                with self._lock:
                    self._latest, self._delivered = frame, False
                    self.scans += 1
                    self._lock.notify_all()
            nbytes, dropped = counter.bytes_read, lidar.dropped_bytes
            if nbytes != last_bytes:
                last_bytes, last_byte_t = nbytes, now
            elif now - last_byte_t > (cfg.byte_timeout if self.scans else cfg.start_timeout):
                # before the first revolution the motor may still be spinning up
                self._trip(f"LiDAR on {lidar.port_name} fell silent: no byte for {now - last_byte_t:.2f} s", source="lidar")
                return
            window.append((now, nbytes, dropped))
            while len(window) > 2 and now - window[1][0] >= cfg.garbage_window:
                window.popleft()
            t0, b0, d0 = window[0]
            got, bad = nbytes - b0, dropped - d0
            if now - t0 >= cfg.garbage_window and got >= cfg.min_window_bytes and bad > cfg.garbage_fraction * got:
                self._trip(
                    f"LiDAR stream on {lidar.port_name} is corrupt: {bad} of {got} bytes in the last "
                    f"{now - t0:.2f} s could not be decoded (wrong baud rate, bad cable or noise?)",
                    source="lidar",
                )
                return
