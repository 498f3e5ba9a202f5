"""Pololu Maestro driver over pyserial (port I/O): two continuous-rotation wheel servos.

Built on :mod:`clomp.runtime.devices.maestro_codec` (whose names are re-exported here). A
software watchdog stops the wheels when no speed command arrived for
``watchdog_timeout`` seconds, so a crashed or stalled controller cannot leave the robot
driving.

>>> encode_set_target(0, speed_to_target(0.0, WheelConfig(0))).hex(" ")
'84 00 70 2e'
"""

from __future__ import annotations

import atexit
import math
import signal
import threading
import time
from collections.abc import Callable
from typing import Any

from clomp.runtime.devices.port import PORT_ERRORS as _PORT_ERRORS
from clomp.runtime.devices.port import SerialDevice
from clomp.runtime.devices.maestro_codec import (
    decode_errors,
    DEFAULT_DEVICE_NUMBER,
    encode_get_errors,
    encode_get_position,
    encode_go_home,
    encode_set_multiple_targets,
    encode_set_target,
    ERROR_BITS,
    ErrorFlags,
    MaestroDeviceError,
    MaestroError,
    MaestroPortError,
    MaestroTimeout,
    speed_to_target,
    target_to_speed,
    WheelConfig,
    WireProtocol,
)

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


class Maestro(SerialDevice):
    """Two wheel servos on a Pololu Maestro.

    ``port`` is a device path (``/dev/ttyACM0``), a pyserial URL, or an open
    serial-like object (not closed by :meth:`close`). Use it as a context manager, or
    call :meth:`close`, so the wheels are stopped on the way out; a watchdog thread
    stops them when :meth:`set_speeds` is not called for ``watchdog_timeout`` seconds
    (``None`` disables it).
    """

    _device, _port_error = "Maestro", MaestroPortError

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
        clock: Callable[[], float] | None = None,
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
        #: called (in the watchdog's thread, under the driver's lock, so no command can
        #: slip in between) after each stop the watchdog made: whoever dead-reckons from
        #: the commands learns that the wheels stopped without being told to
        self.on_watchdog_stop: Callable[[], None] | None = None
        #: the watchdog's and the reply deadline's time (seconds); ``time.monotonic`` unless
        #: the robot (or a test) passes its clock's ``now``
        self.clock: Callable[[], float] = clock or time.monotonic
        #: passes of the watchdog loop so far (a test can wait for it to have looked)
        self.watchdog_passes = 0
        self._watch_cond = threading.Condition()
        self._lock = threading.RLock()
        self._last_command = self.clock()
        self._stopped = True
        self._speeds = (0.0, 0.0)
        self._closed = threading.Event()
        self._uninstall: Callable[[], None] | None = None
        self._attach(port, baudrate=baudrate, timeout=reply_timeout)
        self._watchdog: threading.Thread | None = None
        if watchdog_timeout is not None:
            self._watchdog = threading.Thread(target=self._watch, name="maestro-watchdog", daemon=True)
            self._watchdog.start()

    # -- port plumbing (SerialDevice's: opening, port_name, _write, closing)

    def _query(self, request: bytes, n: int, what: str) -> bytes:
        with self._lock:
            try:
                reset = getattr(self._port, "reset_input_buffer", None)
                if reset is not None:
                    reset()
            except _PORT_ERRORS as exc:
                raise MaestroPortError(f"Maestro port {self.port_name} failed: {exc}") from exc
            self._write(request)
            deadline = self.clock() + self.reply_timeout
            buf = bytearray()
            while len(buf) < n:
                if self.clock() >= deadline:
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
            self._last_command = self.clock()
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
        # an injected clock may jump: then look again often rather than sleep its whole wait
        poll = None if self.clock is time.monotonic else 0.01
        while True:
            with self._lock:
                wait = timeout if self._stopped else self._last_command + timeout - self.clock()
                if wait <= 0:
                    try:
                        self.stop()
                    except MaestroError as exc:
                        self.watchdog_error = exc
                        self._last_command = self.clock()  # retry after another period
                    else:
                        self._tell_watchdog_stop()  # before it is counted: a count means it was told
                        self.watchdog_stops += 1
                    wait = 0.0
            with self._watch_cond:
                self.watchdog_passes += 1
                self._watch_cond.notify_all()
            if wait > 0 and self._closed.wait(wait if poll is None else min(wait, poll)):
                return
            if wait <= 0 and self._closed.is_set():
                return

    def _tell_watchdog_stop(self) -> None:
        callback = self.on_watchdog_stop
        if callback is None:
            return
        try:
            callback()
        except Exception:  # a listener's bug must not end the watchdog that keeps the robot safe
            pass

    def wait_watchdog(self, passes: int = 1, timeout: float = 10.0) -> bool:
        """Wait until the watchdog has looked at the clock ``passes`` more times (for tests
        that move an injected clock and must know the watchdog saw the new time)."""
        with self._watch_cond:
            target = self.watchdog_passes + passes
            return self._watch_cond.wait_for(lambda: self.watchdog_passes >= target, timeout)

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
        self._close_port()

    def __repr__(self) -> str:
        return f"Maestro({self.port_name!r}, protocol={self.protocol!r})"
