"""An emulated Pololu Maestro servo controller on a pseudo-terminal.

It speaks the compact and Pololu protocols of :mod:`clomp.runtime.devices.maestro` byte for
byte, reports errors like the device (incl. its serial-timeout fail-safe) and decodes the
targets it receives into wheel speeds, so the driver and the hardware robot can be tested
without hardware.

>>> with MaestroEmulator() as maestro:
...     maestro.port.startswith("/dev/")
True
"""

from __future__ import annotations

import threading
from collections.abc import Callable


from clomp.runtime.devices import maestro_codec as _m
from clomp.runtime.devices._pty import PtyEmulator

__all__ = ["MaestroEmulator"]


class MaestroEmulator(PtyEmulator):
    """A Pololu Maestro: compact and Pololu protocol Set Target, Set Multiple Targets,
    Set Speed/Acceleration, Get Position, Get Moving State, Get Errors and Go Home.

    ``events`` records ``(time, channel, target)`` for every target change, in the
    emulator's ``clock`` (``time.monotonic`` unless a test passes its own),
    so a test can tell when the wheels were told to stop; ``on_speeds(left, right)`` is
    called with the decoded wheel speeds (the inverse of the driver's mapping, with
    the same defaults). ``serial_timeout`` emulates the Maestro's own fail-safe: no
    byte for that long sets the serial-timeout error and sends every channel home.
    """

    _name = "maestro-emulator"
    _DATA_LEN = {
        _m.CMD_SET_TARGET: 3,
        _m.CMD_SET_SPEED: 3,
        _m.CMD_SET_ACCELERATION: 3,
        _m.CMD_GET_POSITION: 1,
        0x93: 0,  # Get Moving State
        _m.CMD_GET_ERRORS: 0,
        _m.CMD_GO_HOME: 0,
    }

    def __init__(
        self,
        *,
        device_number: int = _m.DEFAULT_DEVICE_NUMBER,
        channels: int = 6,
        home: dict[int, int] | None = None,
        left: _m.WheelConfig = _m.WheelConfig(0, 1),
        right: _m.WheelConfig = _m.WheelConfig(1, -1),
        neutral_us: float = 1500.0,
        span_us: float = 100.0,
        on_speeds: Callable[[float, float], None] | None = None,
        serial_timeout: float | None = None,
        clock: Callable[[], float] | None = None,
    ) -> None:
        super().__init__(clock)
        self.device_number = device_number
        self.channels = channels
        self.home = dict(home or {})
        self.left, self.right = left, right
        self.neutral_us, self.span_us = neutral_us, span_us
        self.on_speeds = on_speeds
        self.serial_timeout = serial_timeout
        self.targets = [0] * channels
        self.speed_limits = [0] * channels
        self.accelerations = [0] * channels
        self.events: list[tuple[float, int, int]] = []
        self.callback_errors: list[BaseException] = []
        self.error_code = 0
        self._cond = threading.Condition(self._lock)
        self._cmd: int | None = None
        self._data: list[int] = []
        self._addressed = True
        self._pololu = 0  # 0: none, 1: got AA, 2: got the device number
        self._pololu_device = 0
        self._last_byte = self.clock()
        self._timed_out = False

    # -- what tests look at

    @property
    def speeds(self) -> tuple[float, float]:
        """The wheel speeds the current targets stand for."""
        with self._lock:
            return self._decode_speeds()

    def _decode_speeds(self) -> tuple[float, float]:
        kw = {"neutral_us": self.neutral_us, "span_us": self.span_us}
        return (
            _m.target_to_speed(self.targets[self.left.channel], self.left, **kw),
            _m.target_to_speed(self.targets[self.right.channel], self.right, **kw),
        )

    @property
    def last_byte_at(self) -> float:
        """When the last byte arrived, on the emulator's clock (what the serial timeout counts from)."""
        return self._last_byte

    @property
    def timed_out(self) -> bool:
        """True once the serial timeout sent the channels home (until the next byte)."""
        return self._timed_out

    def inject_errors(self, code: int) -> None:
        """Set error bits, as if the device had detected them."""
        with self._lock:
            self.error_code |= code

    # -- protocol

    def _on_bytes(self, data: bytes, now: float) -> None:
        self._last_byte = now
        self._timed_out = False
        with self._cond:
            for b in data:
                self._byte(b, now)
            self._cond.notify_all()

    def _protocol_error(self) -> None:
        self.error_code |= 1 << 4
        self._cmd, self._data = None, []

    def _byte(self, b: int, now: float) -> None:
        if b == _m.POLOLU_START:
            if self._cmd is not None or self._pololu:
                self._protocol_error()
            self._pololu = 1
            return
        if self._pololu == 1:
            if b & 0x80:
                self._pololu = 0
                self._protocol_error()
            else:
                self._pololu_device, self._pololu = b, 2
                return
        elif self._pololu == 2:
            self._pololu = 0
            if b & 0x80:
                self._protocol_error()
            else:
                self._begin(b | 0x80, self._pololu_device == self.device_number, now)
                return
        if b & 0x80:
            if self._cmd is not None:
                self._protocol_error()  # a command byte interrupted a command
            self._begin(b, True, now)
            return
        if self._cmd is None:
            self._protocol_error()  # a data byte where a command byte was expected
            return
        self._data.append(b)
        self._maybe_execute(now)

    def _begin(self, cmd: int, addressed: bool, now: float) -> None:
        if cmd not in self._DATA_LEN and cmd != _m.CMD_SET_MULTIPLE_TARGETS:
            self._protocol_error()
            return
        self._cmd, self._data, self._addressed = cmd, [], addressed
        self._maybe_execute(now)

    def _maybe_execute(self, now: float) -> None:
        cmd, data = self._cmd, self._data
        assert cmd is not None
        if cmd == _m.CMD_SET_MULTIPLE_TARGETS:
            if len(data) < 2 or len(data) < 2 + 2 * data[0]:
                return
        elif len(data) < self._DATA_LEN[cmd]:
            return
        self._cmd, self._data = None, []
        if self._addressed:
            self._execute(cmd, data, now)

    def _execute(self, cmd: int, data: list[int], now: float) -> None:
        if cmd == _m.CMD_SET_TARGET:
            self._set_targets({data[0]: data[1] | data[2] << 7}, now)
        elif cmd == _m.CMD_SET_MULTIPLE_TARGETS:
            count, first = data[0], data[1]
            pairs = data[2:]
            self._set_targets({first + i: pairs[2 * i] | pairs[2 * i + 1] << 7 for i in range(count)}, now)
        elif cmd in (_m.CMD_SET_SPEED, _m.CMD_SET_ACCELERATION):
            if data[0] >= self.channels:
                self._protocol_error()
                return
            table = self.speed_limits if cmd == _m.CMD_SET_SPEED else self.accelerations
            table[data[0]] = data[1] | data[2] << 7
        elif cmd == _m.CMD_GET_POSITION:
            if data[0] >= self.channels:
                self._protocol_error()
                return
            self._send(self.targets[data[0]].to_bytes(2, "little"))
        elif cmd == 0x93:
            self._send(b"\x00")  # no speed/acceleration limits emulated: never moving
        elif cmd == _m.CMD_GET_ERRORS:
            self._send(self.error_code.to_bytes(2, "little"))
            self.error_code = 0
        elif cmd == _m.CMD_GO_HOME:
            self._go_home(now)

    def _go_home(self, now: float) -> None:
        self._set_targets({ch: self.home.get(ch, 0) for ch in range(self.channels)}, now)

    def _set_targets(self, targets: dict[int, int], now: float) -> None:
        if any(ch >= self.channels for ch in targets):
            self._protocol_error()
            return
        for ch, target in targets.items():
            self.targets[ch] = target
            self.events.append((now, ch, target))
        if self.on_speeds is not None and {self.left.channel, self.right.channel} & targets.keys():
            try:
                self.on_speeds(*self._decode_speeds())
            except Exception as exc:
                self.callback_errors.append(exc)

    def _tick(self, now: float) -> None:
        if self.serial_timeout is not None and not self._timed_out and now - self._last_byte >= self.serial_timeout:
            with self._cond:
                self._timed_out = True
                self.error_code |= 1 << 5
                self._go_home(now)
                self._cond.notify_all()

    def _next_wakeup(self, now: float) -> float:
        if self.serial_timeout is not None and not self._timed_out:
            return min(now + 0.05, self._last_byte + self.serial_timeout)
        return now + 0.05
