"""Pololu Maestro driver over pyserial: two continuous-rotation wheel servos.

A wheel speed in [-1, 1] becomes a pulse of ``1500 µs ± 100 µs × speed × gain``
(1500 µs = stop) on the wheel's channel; the right wheel's sign is inverted by default
because its servo is mounted mirrored. A software watchdog stops the wheels when no
speed command arrived for ``watchdog_timeout`` seconds, so a crashed or stalled
controller cannot leave the robot driving.

>>> encode_set_target(0, speed_to_target(0.0, WheelConfig(0))).hex(" ")
'84 00 70 2e'
>>> encode_set_target(0, 6000, protocol="pololu").hex(" ")
'aa 0c 04 00 70 2e'
"""

from __future__ import annotations

import atexit
import math
import signal
import threading
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any, Literal

from runtime.devices._port import OPEN_ERRORS as _OPEN_ERRORS
from runtime.devices._port import PORT_ERRORS as _PORT_ERRORS
from runtime.devices._port import open_serial

__all__ = [
    "Maestro",
    "WheelConfig",
    "ErrorFlags",
    "MaestroError",
    "MaestroPortError",
    "MaestroTimeout",
    "MaestroDeviceError",
    "ERROR_BITS",
    "DEFAULT_DEVICE_NUMBER",
    "speed_to_target",
    "target_to_speed",
    "encode_set_target",
    "encode_set_multiple_targets",
    "encode_get_position",
    "encode_get_errors",
    "encode_go_home",
    "decode_errors",
]

WireProtocol = Literal["compact", "pololu"]

DEFAULT_DEVICE_NUMBER = 12
POLOLU_START = 0xAA
CMD_SET_TARGET = 0x84
CMD_SET_SPEED = 0x87
CMD_SET_ACCELERATION = 0x89
CMD_GET_POSITION = 0x90
CMD_SET_MULTIPLE_TARGETS = 0x9F
CMD_GET_ERRORS = 0xA1
CMD_GO_HOME = 0xA2

#: Get Errors bit → name (Pololu Maestro user's guide, "Errors").
ERROR_BITS: dict[int, str] = {
    0: "serial signal error",
    1: "serial overrun error",
    2: "serial RX buffer full",
    3: "serial CRC error",
    4: "serial protocol error",
    5: "serial timeout error",
    6: "script stack error",
    7: "script call stack error",
    8: "script program counter error",
}



class MaestroError(Exception):
    """Base class of every error raised by the Maestro layer."""


class MaestroPortError(MaestroError):
    """The serial port cannot be opened or failed (device unplugged, pty closed)."""


class MaestroTimeout(MaestroError):
    """The Maestro did not answer a query (Get Errors, Get Position) in time."""


class MaestroDeviceError(MaestroError):
    """The Maestro reports error flags (see :class:`ErrorFlags`)."""

    def __init__(self, flags: ErrorFlags) -> None:
        self.flags = flags
        super().__init__(f"Maestro reports errors 0x{flags.code:04X}: {', '.join(flags.names)}")


def decode_errors(code: int) -> list[str]:
    """Names of the error bits set in a Get Errors code (unknown bits as ``bit N``).

    >>> decode_errors(0x0011)
    ['serial signal error', 'serial protocol error']
    """
    return [ERROR_BITS.get(bit, f"bit {bit}") for bit in range(16) if code >> bit & 1]


@dataclass(frozen=True)
class ErrorFlags:
    """The Maestro's error register as read by Get Errors (reading clears it)."""

    code: int

    @property
    def names(self) -> list[str]:
        """Human-readable names of the set bits."""
        return decode_errors(self.code)

    def __bool__(self) -> bool:
        return self.code != 0


@dataclass(frozen=True)
class WheelConfig:
    """Where a wheel's servo is and how its pulse maps to speed.

    ``sign`` is +1 or -1 (a mirrored servo), ``gain`` scales the ±100 µs span so that
    both wheels reach the same speed at the same command.
    """

    channel: int
    sign: int = 1
    gain: float = 1.0

    def __post_init__(self) -> None:
        if not 0 <= self.channel <= 23:
            raise ValueError(f"Maestro channel must be in 0..23, got {self.channel}")
        if self.sign not in (1, -1):
            raise ValueError(f"wheel sign must be +1 or -1, got {self.sign}")
        if not (math.isfinite(self.gain) and self.gain > 0):
            raise ValueError(f"wheel gain must be a positive number, got {self.gain}")


def speed_to_target(
    speed: float, wheel: WheelConfig, *, neutral_us: float = 1500.0, span_us: float = 100.0
) -> int:
    """Target in quarter-microseconds for a speed in [-1, 1] (clamped) on ``wheel``.

    >>> speed_to_target(1.0, WheelConfig(1, sign=-1))
    5600
    """
    if math.isnan(speed):
        raise ValueError("wheel speed is NaN")
    s = min(1.0, max(-1.0, speed))
    pulse_us = neutral_us + span_us * s * wheel.sign * wheel.gain
    return max(0, min(0x3FFF, round(pulse_us * 4)))


def target_to_speed(
    target: int, wheel: WheelConfig, *, neutral_us: float = 1500.0, span_us: float = 100.0
) -> float:
    """Inverse of :func:`speed_to_target`; target 0 (pulses off) is speed 0."""
    if target == 0:
        return 0.0
    return (target / 4.0 - neutral_us) / (span_us * wheel.sign * wheel.gain)


def _frame(cmd: int, data: Sequence[int], protocol: WireProtocol, device: int) -> bytes:
    if any(not 0 <= b <= 0x7F for b in data):
        raise ValueError(f"Maestro data bytes must be 7-bit: {list(data)}")
    if protocol == "compact":
        return bytes((cmd, *data))
    if protocol == "pololu":
        if not 0 <= device <= 0x7F:
            raise ValueError(f"device number must be in 0..127, got {device}")
        return bytes((POLOLU_START, device, cmd & 0x7F, *data))
    raise ValueError(f"protocol must be 'compact' or 'pololu', got {protocol!r}")


def _target_bytes(target: int) -> tuple[int, int]:
    if not 0 <= target <= 0x3FFF:
        raise ValueError(f"target must be in 0..16383 quarter-µs, got {target}")
    return target & 0x7F, (target >> 7) & 0x7F


def encode_set_target(
    channel: int, target: int, *, protocol: WireProtocol = "compact", device: int = DEFAULT_DEVICE_NUMBER
) -> bytes:
    """Set Target: ``84 ch lo7 hi7`` (compact) or ``AA dev 04 ch lo7 hi7`` (Pololu)."""
    return _frame(CMD_SET_TARGET, (channel, *_target_bytes(target)), protocol, device)


def encode_set_multiple_targets(
    first_channel: int,
    targets: Sequence[int],
    *,
    protocol: WireProtocol = "compact",
    device: int = DEFAULT_DEVICE_NUMBER,
) -> bytes:
    """Set Multiple Targets (Mini Maestro): ``9F count first lo hi lo hi …``."""
    if not targets:
        raise ValueError("at least one target")
    data = [len(targets), first_channel]
    for t in targets:
        data.extend(_target_bytes(t))
    return _frame(CMD_SET_MULTIPLE_TARGETS, data, protocol, device)


def encode_get_position(
    channel: int, *, protocol: WireProtocol = "compact", device: int = DEFAULT_DEVICE_NUMBER
) -> bytes:
    """Get Position: ``90 ch``; the reply is 2 bytes, low first, quarter-µs."""
    return _frame(CMD_GET_POSITION, (channel,), protocol, device)


def encode_get_errors(*, protocol: WireProtocol = "compact", device: int = DEFAULT_DEVICE_NUMBER) -> bytes:
    """Get Errors: ``A1``; the reply is 2 bytes, low first."""
    return _frame(CMD_GET_ERRORS, (), protocol, device)


def encode_go_home(*, protocol: WireProtocol = "compact", device: int = DEFAULT_DEVICE_NUMBER) -> bytes:
    """Go Home: ``A2`` (every channel to its home position, or off)."""
    return _frame(CMD_GO_HOME, (), protocol, device)


class Maestro:
    """Two wheel servos on a Pololu Maestro.

    ``port`` is a device path (``/dev/ttyACM0``), a pyserial URL, or an open
    serial-like object (not closed by :meth:`close`). Use it as a context manager, or
    call :meth:`close`, so the wheels are stopped on the way out; a watchdog thread
    stops them when :meth:`set_speeds` is not called for ``watchdog_timeout`` seconds
    (``None`` disables it).
    """

    def __init__(
        self,
        port: str | Any,
        *,
        baudrate: int = 115200,
        protocol: WireProtocol = "compact",
        device_number: int = DEFAULT_DEVICE_NUMBER,
        left: WheelConfig = WheelConfig(0, 1),
        right: WheelConfig = WheelConfig(1, -1),
        neutral_us: float = 1500.0,
        span_us: float = 100.0,
        watchdog_timeout: float | None = 0.3,
        multiple_targets: bool = False,
        reply_timeout: float = 0.5,
    ) -> None:
        if protocol not in ("compact", "pololu"):
            raise ValueError(f"protocol must be 'compact' or 'pololu', got {protocol!r}")
        if left.channel == right.channel:
            raise ValueError("left and right wheels need different channels")
        if multiple_targets and abs(left.channel - right.channel) != 1:
            raise ValueError("Set Multiple Targets needs the wheels on adjacent channels")
        if watchdog_timeout is not None and not watchdog_timeout > 0:
            raise ValueError("watchdog_timeout must be positive or None")
        self.protocol: WireProtocol = protocol
        self.device_number = device_number
        self.left, self.right = left, right
        self.neutral_us, self.span_us = neutral_us, span_us
        self.watchdog_timeout = watchdog_timeout
        self.multiple_targets = multiple_targets
        self.reply_timeout = reply_timeout
        self.watchdog_stops = 0
        self.watchdog_error: MaestroError | None = None
        self._lock = threading.RLock()
        self._last_command = time.monotonic()
        self._stopped = True
        self._speeds = (0.0, 0.0)
        self._closed = threading.Event()
        self._uninstall: Callable[[], None] | None = None
        if isinstance(port, str):
            self._spec: str | None = port
            self._owns_port = True
            self._port: Any = self._open(port, baudrate)
        else:
            if not all(hasattr(port, m) for m in ("read", "write")):
                raise TypeError(f"port must be a path, a URL or a serial-like object, got {port!r}")
            self._spec, self._owns_port, self._port = None, False, port
        self._watchdog: threading.Thread | None = None
        if watchdog_timeout is not None:
            self._watchdog = threading.Thread(target=self._watch, name="maestro-watchdog", daemon=True)
            self._watchdog.start()

    # -- port plumbing

    def _open(self, spec: str, baudrate: int) -> Any:
        try:
            return open_serial(spec, baudrate, self.reply_timeout)
        except _OPEN_ERRORS as exc:
            raise MaestroPortError(f"cannot open Maestro port {spec}: {exc}") from exc

    @property
    def port_name(self) -> str:
        """The path/URL of the port, or the name of the port object."""
        return self._spec or str(getattr(self._port, "port", None) or self._port)

    def _write(self, data: bytes) -> None:
        try:
            self._port.write(data)
            flush = getattr(self._port, "flush", None)
            if flush is not None:
                flush()
        except _PORT_ERRORS as exc:
            raise MaestroPortError(
                f"Maestro port {self.port_name} failed while writing (device unplugged?): {exc}"
            ) from exc

    def _query(self, request: bytes, n: int, what: str) -> bytes:
        with self._lock:
            try:
                reset = getattr(self._port, "reset_input_buffer", None)
                if reset is not None:
                    reset()
            except _PORT_ERRORS as exc:
                raise MaestroPortError(f"Maestro port {self.port_name} failed: {exc}") from exc
            self._write(request)
            deadline = time.monotonic() + self.reply_timeout
            buf = bytearray()
            while len(buf) < n:
                if time.monotonic() >= deadline:
                    raise MaestroTimeout(
                        f"Maestro on {self.port_name} sent {len(buf)} of {n} bytes of "
                        f"the {what} reply within {self.reply_timeout:.2f} s"
                    )
                try:
                    buf += self._port.read(n - len(buf))
                except _PORT_ERRORS as exc:
                    raise MaestroPortError(
                        f"Maestro port {self.port_name} failed while reading: {exc}"
                    ) from exc
            return bytes(buf)

    # -- commands

    def set_target(self, channel: int, target: int) -> None:
        """Raw Set Target in quarter-µs (0 turns the pulses off); no watchdog bookkeeping."""
        with self._lock:
            self._write(encode_set_target(channel, target, protocol=self.protocol, device=self.device_number))

    def _send_wheels(self, left_target: int, right_target: int) -> None:
        p, d = self.protocol, self.device_number
        if self.multiple_targets:
            if self.left.channel < self.right.channel:
                msg = encode_set_multiple_targets(self.left.channel, [left_target, right_target], protocol=p, device=d)
            else:
                msg = encode_set_multiple_targets(self.right.channel, [right_target, left_target], protocol=p, device=d)
        else:
            msg = encode_set_target(self.left.channel, left_target, protocol=p, device=d)
            msg += encode_set_target(self.right.channel, right_target, protocol=p, device=d)
        self._write(msg)

    def _target(self, speed: float, wheel: WheelConfig) -> int:
        return speed_to_target(speed, wheel, neutral_us=self.neutral_us, span_us=self.span_us)

    def set_speeds(self, left: float, right: float) -> None:
        """Command both wheels, speeds in [-1, 1] (out-of-range values are clamped).

        A NaN speed stops the wheels and raises ValueError. Must be repeated faster
        than ``watchdog_timeout``, or the watchdog stops the wheels.
        """
        if math.isnan(left) or math.isnan(right):
            message = f"wheel speed is NaN (left={left}, right={right})"
            try:
                self.stop()
            except MaestroError as exc:
                raise ValueError(f"{message}; stopping the wheels failed too: {exc}") from exc
            raise ValueError(f"{message}; wheels stopped")
        left = min(1.0, max(-1.0, float(left)))
        right = min(1.0, max(-1.0, float(right)))
        with self._lock:
            if self._closed.is_set():
                raise MaestroError("the Maestro driver is closed")
            self._send_wheels(self._target(left, self.left), self._target(right, self.right))
            self._last_command = time.monotonic()
            self._speeds = (left, right)
            self._stopped = left == 0.0 and right == 0.0

    @property
    def speeds(self) -> tuple[float, float]:
        """The last commanded (clamped) speeds; (0, 0) after a stop."""
        return self._speeds

    def stop(self) -> None:
        """Send neutral (1500 µs) to both wheels now. Raises MaestroPortError if it cannot."""
        with self._lock:
            neutral = round(self.neutral_us * 4)
            self._speeds = (0.0, 0.0)
            self._stopped = True
            self._send_wheels(neutral, neutral)

    def go_home(self) -> None:
        """Go Home: every channel to its configured home position (or off)."""
        with self._lock:
            self._write(encode_go_home(protocol=self.protocol, device=self.device_number))
            self._speeds = (0.0, 0.0)
            self._stopped = True

    def get_errors(self) -> ErrorFlags:
        """Read (and thereby clear) the error register; falsy when there are none."""
        reply = self._query(encode_get_errors(protocol=self.protocol, device=self.device_number), 2, "Get Errors")
        return ErrorFlags(reply[0] | (reply[1] << 8))

    def check_errors(self) -> None:
        """Raise MaestroDeviceError if the Maestro reports any error flag."""
        flags = self.get_errors()
        if flags:
            raise MaestroDeviceError(flags)

    def get_position(self, channel: int) -> int:
        """The channel's current pulse width (quarter-µs), as reported by Get Position."""
        reply = self._query(
            encode_get_position(channel, protocol=self.protocol, device=self.device_number), 2, "Get Position"
        )
        return reply[0] | (reply[1] << 8)

    # -- watchdog

    def _watch(self) -> None:
        timeout = self.watchdog_timeout
        assert timeout is not None
        while True:
            with self._lock:
                wait = timeout if self._stopped else self._last_command + timeout - time.monotonic()
                if wait <= 0:
                    try:
                        self.stop()
                        self.watchdog_stops += 1
                    except MaestroError as exc:
                        self.watchdog_error = exc
                        self._last_command = time.monotonic()  # retry after another period
                    continue
            if self._closed.wait(wait):
                return

    # -- lifetime

    def install_stop_handlers(self) -> Callable[[], None]:
        """Stop the wheels at interpreter exit and on SIGINT (then the previous handler runs).

        Call from the main thread. Returns a function that removes both handlers
        (:meth:`close` calls it too).
        """
        previous = signal.getsignal(signal.SIGINT)

        def on_sigint(signum: int, frame: Any) -> None:
            try:
                self.stop()
            except MaestroError:
                pass
            if callable(previous):
                previous(signum, frame)
            elif previous != signal.SIG_IGN:
                raise KeyboardInterrupt

        signal.signal(signal.SIGINT, on_sigint)
        atexit.register(self.close)

        def uninstall() -> None:
            atexit.unregister(self.close)
            try:
                if signal.getsignal(signal.SIGINT) is on_sigint:
                    signal.signal(signal.SIGINT, previous)
            except ValueError:  # not in the main thread
                pass
            self._uninstall = None

        self._uninstall = uninstall
        return uninstall

    def close(self) -> None:
        """Stop the wheels (best effort if the port is gone), end the watchdog, close the port."""
        if self._uninstall is not None:
            self._uninstall()
        if self._closed.is_set():
            return
        try:
            self.stop()
        except MaestroError:
            pass
        self._closed.set()
        if self._watchdog is not None and self._watchdog is not threading.current_thread():
            self._watchdog.join(timeout=1.0)
        if self._owns_port:
            try:
                self._port.close()
            except _PORT_ERRORS:
                pass

    def __enter__(self) -> Maestro:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def __repr__(self) -> str:
        return f"Maestro({self.port_name!r}, protocol={self.protocol!r})"
