"""Device emulators on pseudo-terminals: an RPLIDAR A1 and a Pololu Maestro.

Each emulator owns the master side of a pty and runs in a background thread; its
``.port`` is the slave's path, which the real drivers open like a USB serial device.
They speak the device protocols byte for byte (see ``runtime.devices.rplidar`` and
``runtime.devices.maestro``), pace output like the hardware, and inject faults
(garbage, bad check bits, silence, the device vanishing) so the drivers can be tested
without hardware.

>>> import numpy as np
>>> with LidarEmulator(lambda: np.array([[0.5, 0.0]]), speed=4.0) as lidar:
...     lidar.port.startswith("/dev/")
True
"""

from __future__ import annotations

import abc
import os
import random
import re
import select
import threading
import time
import tty
from collections.abc import Callable
from pathlib import Path
from typing import Self

import numpy as np

from runtime.devices import maestro as _m
from runtime.devices import rplidar as _r

__all__ = [
    "ScanSource",
    "LidarEmulator",
    "MaestroEmulator",
    "load_scan_file",
    "recorded_scan_source",
    "scan_to_samples",
]

ScanSource = Callable[[], np.ndarray]

_MAP_FILE = re.compile(r"^map\d+\.dat$")


def load_scan_file(path: str | os.PathLike[str]) -> np.ndarray:
    """Read one recorded scan (``x<TAB>y`` per line, metres) as N×2; empty file → 0×2."""
    rows: list[tuple[float, float]] = []
    with open(path, encoding="utf-8") as fh:
        for lineno, line in enumerate(fh, 1):
            fields = line.split()
            if not fields:
                continue
            try:
                if len(fields) != 2:
                    raise ValueError(f"expected 2 columns, got {len(fields)}")
                rows.append((float(fields[0]), float(fields[1])))
            except ValueError as exc:
                raise ValueError(f"{path}:{lineno}: not an 'x<TAB>y' line ({exc}): {line.rstrip()!r}") from None
    return np.array(rows, dtype=float).reshape(-1, 2)


def recorded_scan_source(folder: str | os.PathLike[str]) -> ScanSource:
    """A scan source cycling over the ``mapNNNN.dat`` files of ``folder`` in order.

    All files are read up front so a malformed file fails here, not mid-stream.
    An empty file is an empty scan (free space).
    """
    root = Path(folder)
    if not root.is_dir():
        raise FileNotFoundError(f"scan folder not found: {root}")
    files = sorted(p for p in root.iterdir() if _MAP_FILE.match(p.name))
    if not files:
        subdirs = sorted(p.name for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
        hint = f" (it has subfolders: {', '.join(subdirs)})" if subdirs else ""
        raise FileNotFoundError(f"no mapNNNN.dat files in {root}{hint}")
    scans = [load_scan_file(p) for p in files]
    state = {"i": 0}
    lock = threading.Lock()

    def source() -> np.ndarray:
        with lock:
            scan = scans[state["i"]]
            state["i"] = (state["i"] + 1) % len(scans)
        return scan.copy()

    return source


def scan_to_samples(points: np.ndarray, bins: int = 360) -> tuple[np.ndarray, np.ndarray]:
    """What an A1 would measure of a robot-frame scan: (angle_deg, distance_mm) per bin.

    Angles are clockwise from the front; bin k covers [k, k+1) × 360/bins degrees and
    keeps its nearest return (at that point's exact angle), so angles rise through a
    revolution as on the device; a bin without a return has distance 0 at its start.
    """
    step = 360.0 / bins
    angle = np.arange(bins) * step
    dist = np.zeros(bins)
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    pts = pts[np.all(np.isfinite(pts), axis=1)]
    if len(pts):
        r = np.hypot(pts[:, 0], pts[:, 1]) * 1000.0
        cw = np.degrees(-np.arctan2(pts[:, 1], pts[:, 0])) % 360.0
        idx = np.floor(cw / step).astype(int) % bins
        order = np.argsort(-r, kind="stable")  # farthest first: the nearest is written last
        order = order[r[order] > 0]
        dist[idx[order]] = r[order]
        angle[idx[order]] = cw[order]
    return angle, dist


class _PtyEmulator(abc.ABC):
    """A pty whose master side is served by a background thread."""

    _name = "emulator"

    def __init__(self) -> None:
        self.port: str = ""
        self.error: BaseException | None = None
        self._master = -1
        self._slave = -1
        self._out = bytearray()
        self._stop = threading.Event()
        self._vanish = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.RLock()

    # -- lifetime

    def start(self) -> Self:
        """Open the pty and start serving; returns self."""
        if self._thread is not None:
            raise RuntimeError(f"{self._name} already started")
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo or line editing before the driver opens it
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the pty (idempotent)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._close_fds()

    def vanish(self) -> None:
        """Fault: close the pty now, as if the USB device was unplugged."""
        self._vanish.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._close_fds()

    @property
    def running(self) -> bool:
        """True while the background thread serves the pty."""
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self) -> Self:
        if self._thread is None:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _close_fds(self) -> None:
        with self._lock:
            for fd in (self._master, self._slave):
                if fd >= 0:
                    try:
                        os.close(fd)
                    except OSError:
                        pass
            self._master = self._slave = -1

    # -- the serving loop

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                if self._vanish.is_set():
                    self._close_fds()
                    return
                now = time.monotonic()
                timeout = max(0.0, min(0.05, self._next_wakeup(now) - now))
                wfds = [self._master] if self._out else []
                readable, writable, _ = select.select([self._master], wfds, [], timeout)
                if readable:
                    try:
                        data = os.read(self._master, 4096)
                    except BlockingIOError:
                        data = b""
                    if data:
                        self._on_bytes(data, time.monotonic())
                self._tick(time.monotonic())
                self._flush()
        except Exception as exc:  # keep the failure for the test instead of a thread traceback
            self.error = exc
            self._close_fds()

    def _send(self, data: bytes) -> None:
        self._out += data

    def _flush(self) -> None:
        if not self._out or self._master < 0:
            return
        try:
            n = os.write(self._master, self._out)
        except BlockingIOError:
            return
        del self._out[:n]

    def _next_wakeup(self, now: float) -> float:
        return now + 0.05

    @abc.abstractmethod
    def _on_bytes(self, data: bytes, now: float) -> None:
        """Handle bytes the driver wrote (each device decodes its own protocol)."""

    def _tick(self, now: float) -> None:
        pass


class LidarEmulator(_PtyEmulator):
    """An RPLIDAR A1: answers GET_INFO, GET_HEALTH, GET_SAMPLERATE, SCAN/FORCE_SCAN,
    STOP and RESET; streams ``samples_per_rev`` samples per revolution at
    ``sample_rate × speed`` samples/s, each revolution made from one ``scan_source()``.

    Faults: ``garbage_rate`` (probability per sample of 1–8 random bytes before it),
    ``bad_check_rate`` (probability per sample of C = 0), ``silent_after`` (revolutions,
    then no output and no answers), ``vanish_after`` (revolutions, fractional for
    mid-scan; then the pty is closed). ``seed`` makes the faults reproducible.
    """

    _name = "lidar-emulator"
    BANNER = b"RP LIDAR System.\r\nFirmware Ver 1.29 - rtm, HW Ver 7\r\nModel: 18\r\n"

    def __init__(
        self,
        scan_source: ScanSource | None = None,
        *,
        speed: float = 1.0,
        sample_rate: float = 2000.0,
        samples_per_rev: int = 360,
        quality: int = 15,
        health_status: int = 0,
        health_error_code: int = 0,
        info: _r.DeviceInfo | None = None,
        garbage_rate: float = 0.0,
        bad_check_rate: float = 0.0,
        silent_after: int | None = None,
        vanish_after: float | None = None,
        reset_time: float = 0.05,
        max_backlog: int = 65536,
        seed: int | None = None,
    ) -> None:
        super().__init__()
        if speed <= 0 or sample_rate <= 0:
            raise ValueError("speed and sample_rate must be positive")
        if samples_per_rev < 72:
            raise ValueError("samples_per_rev must be at least 72: an A1 sends samples a few degrees apart at most")
        if not (0 <= garbage_rate <= 1 and 0 <= bad_check_rate <= 1):
            raise ValueError("garbage_rate and bad_check_rate are probabilities in [0, 1]")
        self.scan_source: ScanSource = scan_source or (lambda: np.empty((0, 2)))
        self.speed = speed
        self.sample_rate = sample_rate
        self.samples_per_rev = samples_per_rev
        self.quality = quality
        self.health = _r.HealthStatus(health_status, health_error_code)
        self.info = info or _r.DeviceInfo(0x18, 29, 1, 7, bytes(range(16)))
        self.garbage_rate = garbage_rate
        self.bad_check_rate = bad_check_rate
        self.silent_after = silent_after
        self.vanish_after = vanish_after
        self.reset_time = reset_time
        self.max_backlog = max_backlog
        self._rng = random.Random(seed)
        self._in = bytearray()
        self.requests: list[int] = []  # command bytes received, in order
        self.source_errors: list[BaseException] = []
        self.scanning = False
        self.silent = False
        self.revolutions_sent = 0
        self.samples_sent = 0
        self.garbage_bytes_sent = 0
        self.backlog_dropped = 0
        self._scan_t0 = 0.0
        self._scan_due_base = 0
        self._rev: list[tuple[int, int, int]] = []
        self._rev_index = 0
        self._busy_until: float | None = None

    # -- requests

    def _on_bytes(self, data: bytes, now: float) -> None:
        if self.silent or (self._busy_until is not None and now < self._busy_until):
            return  # silent, or rebooting after RESET: input is lost
        buf = self._in
        buf += data
        while True:
            start = buf.find(_r.SYNC_BYTE)
            if start < 0:
                buf.clear()
                return
            del buf[:start]
            if len(buf) < 2:
                return
            cmd = buf[1]
            if cmd & 0x80:
                if len(buf) < 3 or len(buf) < 4 + buf[2]:
                    return
                size = 4 + buf[2]
                checksum = 0
                for b in buf[: size - 1]:
                    checksum ^= b
                if checksum != buf[size - 1]:
                    del buf[:1]  # not a valid request: look for the next A5
                    continue
                del buf[:size]
            else:
                del buf[:2]
            self.requests.append(cmd)
            self._handle(cmd, now)

    def _handle(self, cmd: int, now: float) -> None:
        C = _r.Command
        if cmd in (C.STOP, C.RESET, C.SCAN, C.FORCE_SCAN, C.GET_INFO, C.GET_HEALTH, C.GET_SAMPLERATE):
            self.scanning = False  # a new request ends the running scan
            self._out.clear()  # what was not on the wire yet is never sent
        if cmd == C.RESET:
            self._busy_until = now + self.reset_time
        elif cmd in (C.SCAN, C.FORCE_SCAN):
            self._send(_r.encode_descriptor(_r.SCAN_DESCRIPTOR))
            self.scanning = True
            self._scan_t0 = now
            self._scan_due_base = 0
            self._rev_index = 0
        elif cmd == C.GET_INFO:
            self._send(_r.encode_descriptor(_r.INFO_DESCRIPTOR) + _r.encode_info(self.info))
        elif cmd == C.GET_HEALTH:
            self._send(_r.encode_descriptor(_r.HEALTH_DESCRIPTOR) + _r.encode_health(self.health))
        elif cmd == C.GET_SAMPLERATE:
            t_us = round(1e6 / self.sample_rate)
            payload = t_us.to_bytes(2, "little") + (t_us // 2).to_bytes(2, "little")
            self._send(_r.encode_descriptor(_r.SAMPLERATE_DESCRIPTOR) + payload)
        # SET_MOTOR_PWM and unknown commands: an A1 ignores them

    # -- streaming

    def _next_wakeup(self, now: float) -> float:
        if self._busy_until is not None:
            return min(self._busy_until, now + 0.05)
        if self.scanning and not self.silent:
            return now + 0.005
        return now + 0.05

    def _new_revolution(self) -> None:
        try:
            points = np.asarray(self.scan_source(), dtype=float).reshape(-1, 2)
        except Exception as exc:  # a broken source must not kill the device: empty scan
            self.source_errors.append(exc)
            points = np.empty((0, 2))
        angle, dist = scan_to_samples(points, self.samples_per_rev)
        full = _r.FULL_CIRCLE_Q6
        self._rev = [
            (
                int(round(a * 64)) % full,
                min(0xFFFF, int(round(d * 4))),
                self.quality if d > 0 else 0,
            )
            for a, d in zip(angle, dist)
        ]
        self._rev_index = 0

    def _tick(self, now: float) -> None:
        if self._busy_until is not None and now >= self._busy_until:
            self._busy_until = None
            self._in.clear()
            self._send(self.BANNER)
        if not self.scanning or self.silent:
            return
        due = int((now - self._scan_t0) * self.sample_rate * self.speed) - self._scan_due_base
        if due <= 0:
            return
        self._scan_due_base += due
        rng = self._rng
        for _ in range(min(due, 4 * self.samples_per_rev)):
            if self._rev_index == 0:
                self._new_revolution()
            angle_q6, dist_q2, quality = self._rev[self._rev_index]
            sample = _r.encode_sample(
                self._rev_index == 0,
                quality,
                angle_q6,
                dist_q2,
                check_bit=not (self.bad_check_rate and rng.random() < self.bad_check_rate),
            )
            if self.garbage_rate and rng.random() < self.garbage_rate:
                junk = bytes(rng.randrange(256) for _ in range(rng.randint(1, 8)))
                self.garbage_bytes_sent += len(junk)
                sample = junk + sample
            if len(self._out) + len(sample) <= self.max_backlog:
                self._send(sample)
            else:
                self.backlog_dropped += len(sample)  # the host is not reading: bytes lost
            self.samples_sent += 1
            self._rev_index += 1
            if self._rev_index >= len(self._rev):
                self._rev_index = 0
                self.revolutions_sent += 1
                if self.silent_after is not None and self.revolutions_sent >= self.silent_after:
                    self.silent = True
                    return
            if self.vanish_after is not None and self.samples_sent >= self.vanish_after * self.samples_per_rev:
                self._flush()
                self._vanish.set()
                return


class MaestroEmulator(_PtyEmulator):
    """A Pololu Maestro: compact and Pololu protocol Set Target, Set Multiple Targets,
    Set Speed/Acceleration, Get Position, Get Moving State, Get Errors and Go Home.

    ``events`` records ``(time.monotonic(), channel, target)`` for every target change
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
    ) -> None:
        super().__init__()
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
        self._last_byte = time.monotonic()
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

    def wait_for(self, predicate: Callable[[MaestroEmulator], bool], timeout: float) -> bool:
        """Wait until ``predicate(self)`` holds (re-checked on every target change)."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not predicate(self):
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    return False
                self._cond.wait(remaining)
            return True

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
