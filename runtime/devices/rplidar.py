"""SLAMTEC RPLIDAR A1 driver over pyserial (port I/O), built on :mod:`clomp.runtime.devices.rplidar_codec`.

:class:`RPLidar` talks to a device (a port path, a pyserial URL or an open serial-like
object) and returns scans as :class:`clomp.runtime.devices.frame.ScanFrame` in the robot
frame. The codec's names are re-exported here for convenience.

>>> lidar = RPLidar("loop://", motor_control="none", timeout=0.2)
>>> lidar.close()
"""

from __future__ import annotations

import collections
import errno
import time
from collections.abc import Callable, Iterator
from typing import Any, Literal


from clomp.runtime.devices.port import PORT_ERRORS as _PORT_ERRORS
from clomp.runtime.devices.port import SerialDevice
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.devices.rplidar_codec import (
    Command,
    decode_health,
    decode_info,
    decode_sample,
    DEFAULT_BAUDRATE,
    Descriptor,
    DeviceInfo,
    encode_descriptor,
    encode_health,
    encode_info,
    encode_request,
    encode_sample,
    HEALTH_DESCRIPTOR,
    HealthStatus,
    INFO_DESCRIPTOR,
    LidarError,
    LidarHealthError,
    LidarPortError,
    LidarProtocolError,
    LidarSampleError,
    LidarTimeout,
    parse_descriptor,
    polar_to_robot,
    Revolution,
    SAMPLE_SIZE,
    SAMPLERATE_DESCRIPTOR,
    SCAN_DESCRIPTOR,
    ScanDecoder,
    SYNC_BYTE,
    SYNC_BYTE2,
)

__all__ = [
    "RPLidar",
    "Command",
    "Descriptor",
    "DeviceInfo",
    "HealthStatus",
    "Revolution",
    "ScanDecoder",
    "LidarError",
    "LidarPortError",
    "LidarProtocolError",
    "LidarSampleError",
    "LidarTimeout",
    "LidarHealthError",
    "encode_request",
    "encode_descriptor",
    "parse_descriptor",
    "encode_sample",
    "decode_sample",
    "encode_info",
    "decode_info",
    "encode_health",
    "decode_health",
    "polar_to_robot",
    "SCAN_DESCRIPTOR",
    "INFO_DESCRIPTOR",
    "HEALTH_DESCRIPTOR",
    "SAMPLERATE_DESCRIPTOR",
    "DEFAULT_BAUDRATE",
    "SAMPLE_SIZE",
    "SYNC_BYTE",
    "SYNC_BYTE2",
]

# seconds one blocking read may take; bounds how far a deadline can be overshot
_READ_SLICE = 0.05
# after STOP: the line counts as stopped once no byte came for this long (an A1 streams a
# byte every ~0.1 ms; an A1 stops within 1 ms; USB adapters hold bytes a few ms) ...
_STOP_QUIET = 0.02
# ... and a device that keeps talking is given up on after this long (its bytes are then
# skipped by the next reply's resynchronisation)
_STOP_DRAIN = 0.5


# ---------------------------------------------------------------------------- driver

MotorControl = Literal["dtr", "none"] | Callable[[bool], None] | None


class RPLidar(SerialDevice):
    """An RPLIDAR A1 on a serial port.

    ``port`` is a device path (``/dev/ttyUSB0``), a pyserial URL (``loop://``,
    ``spy:///dev/ttyUSB0``) or an open serial-like object (read/write/
    reset_input_buffer; it is not closed by :meth:`close`, and its read timeout
    bounds how late a LidarTimeout can come). ``motor_control`` is
    ``"dtr"`` (the A1's USB adapter runs the motor while DTR is low; a port that
    cannot set DTR, such as a pseudo-terminal, is tolerated), ``"none"``, or a
    callable ``motor(on: bool)``. Scans come back in the robot frame (x forward,
    y left, metres) without zero distances and cropped to ``max_range`` metres.
    A frame's ``timestamp`` is when its revolution ended (when the next one's first
    sample was read); once a revolution has been timed, each point also carries when it
    was measured (``point_times``, from its angle and :attr:`period`, the smoothed time
    between revolution ends), so a scan taken while moving can be de-skewed.
    ``clock`` is the time of the driver's deadlines and of the scans' timestamps
    (``time.monotonic`` unless a test passes its own); waiting for the line to fall quiet
    after STOP is always on wall time.
    """

    _device, _port_error = "LiDAR", LidarPortError

    def __init__(
        self,
        port: str | Any,
        *,
        baudrate: int = DEFAULT_BAUDRATE,
        timeout: float = 1.0,
        motor_control: MotorControl = "dtr",
        max_range: float | None = 1.1,
        clock: Callable[[], float] | None = None,
    ) -> None:
        if timeout <= 0:
            raise ValueError("timeout must be positive")
        if not (motor_control in ("dtr", "none", None) or callable(motor_control)):
            raise ValueError(f"motor_control must be 'dtr', 'none' or a callable, got {motor_control!r}")
        self.baudrate = baudrate
        self.timeout = timeout
        self.clock: Callable[[], float] = clock or time.monotonic
        self.max_range = max_range
        self._motor_control = motor_control
        self._dtr_supported = True
        self._scanning = False
        self._decoder = ScanDecoder()
        self._pending: collections.deque[ScanFrame] = collections.deque()
        self.skipped_scans = 0
        self.period: float | None = None  # s a revolution takes, measured from their ends
        self._last_end: float | None = None
        self._attach(port, baudrate=baudrate, timeout=_READ_SLICE, read_slice=_READ_SLICE)

    # -- port plumbing (SerialDevice's, the scan stopped when the port fails)

    @property
    def scanning(self) -> bool:
        """True between start_scan() and stop()."""
        return self._scanning

    @property
    def dropped_bytes(self) -> int:
        """Bytes skipped while resynchronising the current scan stream."""
        return self._decoder.dropped_bytes

    def _port_failed(self, what: str, exc: BaseException) -> Exception:
        self._scanning = False
        return super()._port_failed(what, exc)

    def _reset_input(self) -> None:
        reset = getattr(self._port, "reset_input_buffer", None)
        if reset is None:
            return
        try:
            reset()
        except _PORT_ERRORS as exc:
            raise self._port_failed("flushing input", exc) from exc

    def _read_some(self, n: int) -> bytes:
        try:
            return bytes(self._port.read(n))
        except _PORT_ERRORS as exc:
            raise self._port_failed("reading", exc) from exc

    def _waiting(self) -> int:
        try:
            return int(getattr(self._port, "in_waiting", 0))
        except _PORT_ERRORS as exc:
            raise self._port_failed("reading", exc) from exc

    def _read_exact(self, n: int, deadline: float, what: str) -> bytes:
        buf = bytearray()
        while len(buf) < n:
            want = n - len(buf)
            if self.clock() >= deadline:  # late: only what is already here still counts
                want = min(want, self._waiting())
                if not want:
                    raise LidarTimeout(
                        f"LiDAR on {self.port_name} sent {len(buf)} of {n} bytes of {what} "
                        f"before the timeout (is it powered and connected?)"
                    )
            buf += self._read_some(want)
        return bytes(buf)

    def _set_motor(self, on: bool) -> None:
        mc = self._motor_control
        if mc in ("none", None):
            return
        if callable(mc):
            mc(on)
            return
        if not self._dtr_supported or not hasattr(self._port, "dtr"):
            return
        try:
            self._port.dtr = not on  # A1: DTR low runs the motor
        except _PORT_ERRORS as exc:
            if getattr(exc, "errno", None) in (errno.ENOTTY, errno.EINVAL) or (
                exc.args and exc.args[0] in (errno.ENOTTY, errno.EINVAL)
            ):
                self._dtr_supported = False  # a pseudo-terminal has no modem lines
                return
            raise self._port_failed("switching the motor", exc) from exc

    # -- requests

    def _request(self, cmd: int, payload: bytes = b"") -> None:
        self._write(encode_request(cmd, payload))

    def _read_descriptor(self, expected: Descriptor, deadline: float, what: str) -> None:
        prev = -1
        while True:  # skip stray bytes (a reset banner, a stopped scan's tail) up to A5 5A
            b = self._read_exact(1, deadline, f"the {what} reply")[0]
            if prev == SYNC_BYTE and b == SYNC_BYTE2:
                break
            prev = b
        rest = self._read_exact(5, deadline, f"the {what} descriptor")
        got = parse_descriptor(bytes((SYNC_BYTE, SYNC_BYTE2)) + rest)
        if got != expected:
            raise LidarProtocolError(f"unexpected {what} descriptor {got}, expected {expected}")

    def _query(self, cmd: Command, expected: Descriptor, timeout: float | None) -> bytes:
        if self._scanning:
            raise LidarError(f"cannot send {cmd.name} while scanning; call stop() first")
        deadline = self.clock() + (self.timeout if timeout is None else timeout)
        self._reset_input()
        self._request(cmd)
        self._read_descriptor(expected, deadline, cmd.name)
        return self._read_exact(expected.length, deadline, f"the {cmd.name} reply")

    def info(self, timeout: float | None = None) -> DeviceInfo:
        """Model, firmware, hardware revision and serial number (GET_INFO)."""
        return decode_info(self._query(Command.GET_INFO, INFO_DESCRIPTOR, timeout))

    def health(self, timeout: float | None = None) -> HealthStatus:
        """The device's self-check (GET_HEALTH); raises LidarHealthError on status 2."""
        health = decode_health(self._query(Command.GET_HEALTH, HEALTH_DESCRIPTOR, timeout))
        if health.status == 2:
            raise LidarHealthError(health.status, health.error_code)
        return health

    def reset(self, wait: float = 0.5) -> None:
        """Reboot the core (RESET), wait for it, and drop whatever it printed meanwhile."""
        self._request(Command.RESET)
        self._scanning = False
        time.sleep(wait)
        self._reset_input()

    def start_scan(self, *, force: bool = False, timeout: float | None = None) -> None:
        """Start the motor and the SCAN (or FORCE_SCAN) stream; no-op if already scanning."""
        if self._scanning:
            return
        deadline = self.clock() + (self.timeout if timeout is None else timeout)
        self._set_motor(True)
        self._reset_input()
        self._request(Command.FORCE_SCAN if force else Command.SCAN)
        self._read_descriptor(SCAN_DESCRIPTOR, deadline, "SCAN")
        self._decoder = ScanDecoder()
        self._pending.clear()
        self._last_end = None
        self._scanning = True

    def stop(self) -> None:
        """Stop the scan stream (STOP), drop what the device still sends, then stop the motor.

        The samples already on their way when STOP went out (the UART, the USB adapter's
        buffer, the kernel's) keep arriving for a few milliseconds; dropped only once, they
        would reach the next request, and a stray ``A5 5A`` in them (a sample near 330° with
        distance byte 0x5A) is read as that request's reply. So the input is drained until
        the line has been quiet for ``_STOP_QUIET`` s (at most ``_STOP_DRAIN`` s).
        """
        self._scanning = False
        self._pending.clear()
        self._request(Command.STOP)
        time.sleep(0.002)  # the device needs ≥1 ms before the next request
        self._drain(_STOP_QUIET, _STOP_DRAIN)
        self._set_motor(False)

    def _drain(self, quiet: float, limit: float) -> None:
        """Read and drop input until none arrived for ``quiet`` s, or ``limit`` s passed."""
        start = last = time.monotonic()
        while True:
            waiting = self._waiting()
            now = time.monotonic()
            if waiting:
                self._read_some(waiting)
                last = now
            elif now - last >= quiet or now - start >= limit:
                break
            else:
                time.sleep(0.001)
        self._reset_input()

    def _pump(self, deadline: float, timeout: float) -> None:
        # what is waiting is read even past the deadline: a reader that was kept from running
        # (a busy computer) must not call a device silent whose bytes are already here
        late = self.clock() >= deadline
        waiting = self._waiting()
        if waiting or not late:
            self._feed(self._read_some(max(1, waiting)))
        if late and not self._pending:
            d = self._decoder
            raise LidarTimeout(
                f"no full revolution from the LiDAR on {self.port_name} within "
                f"{timeout:.2f} s ({d.samples} samples decoded, {d.dropped_bytes} bytes "
                f"dropped, {d.rejected_revolutions} implausible revolutions rejected so far)"
            )

    def _feed(self, data: bytes) -> None:
        if not data:
            return
        now = self.clock()
        for rev in self._decoder.feed(data):
            points, quality = rev.to_points(self.max_range)
            times = self._times(now)
            self._pending.append(ScanFrame(points=points, timestamp=now, quality=quality,
                                           point_times=None if times is None else rev.point_times(times, self.max_range)))

    def _times(self, end: float) -> float | None:
        """A revolution ended at ``end``: the period its points are timed with (the time
        between the ends of consecutive revolutions, smoothed; an A1 turns at 1-10 Hz), or
        None while no period is known, so a frame carries per-point times only when they
        can be trusted."""
        last, self._last_end = self._last_end, end
        if last is not None and 0.09 <= end - last <= 1.1:
            self.period = end - last if self.period is None else 0.8 * self.period + 0.2 * (end - last)
        return self.period

    def read_scan(self, timeout: float | None = None, *, newest: bool = True) -> ScanFrame:
        """The next full revolution (starting the scan if needed).

        With ``newest`` the backlog is skipped: the latest complete revolution already
        received is returned (``skipped_scans`` counts the others). Raises LidarTimeout
        when no revolution completes within ``timeout`` seconds (default: the driver's).
        """
        if not self._scanning:
            self.start_scan(timeout=timeout)
        t = self.timeout if timeout is None else timeout
        deadline = self.clock() + t
        while not self._pending:
            self._pump(deadline, t)
        if newest:
            waiting = self._waiting()
            if waiting:
                self._feed(self._read_some(waiting))
            while len(self._pending) > 1:
                self._pending.popleft()
                self.skipped_scans += 1
        return self._pending.popleft()

    def iter_scans(self, timeout: float | None = None) -> Iterator[ScanFrame]:
        """Every revolution in order, forever (stop by breaking out; then call stop())."""
        while True:
            yield self.read_scan(timeout, newest=False)

    def reconnect(self, timeout: float = 5.0) -> None:
        """Reopen the port (retrying until ``timeout``) and resume scanning if it was on."""
        was_scanning = self._scanning
        self._scanning = False
        deadline = self.clock() + timeout
        last: BaseException | None = None
        while True:
            try:
                self._reopen()
                if was_scanning:
                    self.start_scan(timeout=max(0.1, deadline - self.clock()))
                return
            except LidarError as exc:
                last = exc
            if self.clock() >= deadline:
                raise LidarPortError(
                    f"could not reconnect to the LiDAR on {self.port_name} within "
                    f"{timeout:.1f} s: {last}"
                ) from last
            time.sleep(0.1)

    def _reopen(self) -> None:
        try:
            if self._port is not None:
                self._port.close()
        except _PORT_ERRORS:
            pass
        if self._owns_port:
            self._open_port(self.baudrate, _READ_SLICE)
            return
        opener = getattr(self._port, "open", None)
        if opener is None:
            raise LidarError("cannot reconnect: the given port object has no open()")
        try:
            opener()
        except _PORT_ERRORS as exc:
            raise LidarPortError(f"cannot reopen LiDAR port {self.port_name}: {exc}") from exc

    def close(self) -> None:
        """Stop scanning and the motor (best effort) and close a port this driver opened."""
        try:
            if self._port is not None:
                self.stop()
        except LidarError:
            pass
        self._close_port()

    def __repr__(self) -> str:
        return f"RPLidar({self.port_name!r}, scanning={self._scanning})"

