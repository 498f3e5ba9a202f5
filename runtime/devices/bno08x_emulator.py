"""An emulated BNO08x IMU in UART-RVC mode on a pseudo-terminal, beside the A1 and Maestro emulators.

It streams :mod:`clomp.runtime.devices.bno08x_codec` reports at 100 Hz from a heading
source (a callable giving the true yaw, e.g. a simulated world's) and, when given, an
acceleration source (the body's true horizontal acceleration: a kick is felt), with the sensor's
errors (drift, noise, scale error) and the line's (dropped reports, garbage bursts, bad
checksums, silence, the device vanishing), seeded, so the driver can be tested without
hardware.

>>> with Bno08xEmulator(lambda: 0.25) as imu:
...     imu.port.startswith("/dev/")
True
"""

from __future__ import annotations

import math
import random
from collections.abc import Callable

from clomp.runtime.devices import bno08x_codec as _c
from clomp.runtime.devices._pty import PtyEmulator

__all__ = ["AccelerationSource", "Bno08xEmulator", "HeadingSource"]

HeadingSource = Callable[[], float]
"""The true heading now (rad, counter-clockwise seen from above; wrapped or not)."""

AccelerationSource = Callable[[], tuple[float, float]]
"""The body's largest horizontal acceleration since the last call (m/s², the sensor's frame:
x forward, y left), e.g. an execution world's
(:meth:`~clomp.runtime.backends.world.WorldRobot.peak_acceleration_vector`, turned into the body frame)."""


class Bno08xEmulator(PtyEmulator):
    """A BNO08x strapped for RVC mode: no commands (bytes written to it are ignored), one
    report every ``1 / rate`` s of its clock, paced like the device.

    The yaw it reports is, as the device's, relative to the heading at its start (its
    reset): ``(1 + scale_error) × turned + drift × t + W + N(0, noise)``, wrapped to ±180°,
    where ``turned`` is the source's heading since the start followed through the wrap,
    ``t`` the time since the start, ``drift`` in rad/s, ``noise`` in rad, and ``W`` a random
    walk of ``walk`` rad/√s (a step of ``walk / √rate`` per report). Pitch and
    roll are 0, as on a level floor. The acceleration is gravity on z plus, on x and y,
    what ``acceleration`` (an :data:`AccelerationSource`) says the body felt since the last
    report (the peak, so that a kick shorter than a report is not lost; a report made in
    the same pass after it carries it too); without one, gravity alone.

    Faults: ``drop_rate`` (probability per report of not sending it: its index is used,
    so the driver counts it lost), ``garbage_rate`` (probability per report of 1-32
    random bytes before it), ``bad_checksum_rate`` (probability per report of a wrong
    checksum), ``silent_after`` (reports, then nothing), ``vanish_after`` (reports, then
    the pty is closed); :meth:`inject` switches ``silent``, the rates and ``garbage_only``
    (random bytes at the line rate instead of reports) at any time. ``seed`` makes the
    noise and the faults reproducible. ``sent`` counts the reports made (the ``dropped`` and
    ``corrupted`` ones too); ``truth`` maps an index to the true heading since the start
    (rad, followed through the wrap) when the last report with that index was made.
    """

    _name = "imu-emulator"
    stale_after = 1.0  # it streams unasked: what no one read for a second is lost (PtyEmulator)
    _FAULTS = ("silent", "garbage_only", "drop_rate", "garbage_rate", "bad_checksum_rate")

    def __init__(
        self,
        heading: HeadingSource | None = None,
        *,
        acceleration: AccelerationSource | None = None,
        rate: float = _c.REPORT_RATE,
        drift: float = 0.0,
        noise: float = 0.0,
        walk: float = 0.0,
        scale_error: float = 0.0,
        drop_rate: float = 0.0,
        garbage_rate: float = 0.0,
        bad_checksum_rate: float = 0.0,
        silent_after: int | None = None,
        vanish_after: int | None = None,
        start_index: int = 0,
        max_backlog: int = 8192,
        seed: int | None = None,
        clock: Callable[[], float] | None = None,
    ) -> None:
        super().__init__(clock)
        if not rate > 0 or noise < 0 or walk < 0:
            raise ValueError("rate must be positive, noise and walk not negative")
        for name, p in (("drop_rate", drop_rate), ("garbage_rate", garbage_rate), ("bad_checksum_rate", bad_checksum_rate)):
            if not 0 <= p <= 1:
                raise ValueError(f"{name} is a probability in [0, 1], got {p!r}")
        self.heading: HeadingSource = heading or (lambda: 0.0)
        self.acceleration = acceleration
        self._accel = (0.0, 0.0)  # what the source said at the last pass (m/s², x and y)
        self.rate, self.drift, self.noise, self.scale_error = rate, drift, noise, scale_error
        self.walk, self._walked = walk, 0.0
        self.drop_rate, self.garbage_rate, self.bad_checksum_rate = drop_rate, garbage_rate, bad_checksum_rate
        self.silent_after, self.vanish_after = silent_after, vanish_after
        self.silent = False
        self.garbage_only = False
        self.max_backlog = max_backlog
        self._rng = random.Random(seed)
        self.index = start_index & 0xFF  # of the next report
        self.sent = 0
        self.dropped = 0
        self.corrupted = 0
        self.garbage_bytes_sent = 0
        self.backlog_dropped = 0
        self.source_errors: list[BaseException] = []
        self.truth: dict[int, float] = {}
        self._t0: float | None = None
        self._due_base = 0
        self._start_heading = 0.0
        self._turned = 0.0

    def inject(self, **faults: float | bool) -> float:
        """Switch faults on or off now (``silent``, ``garbage_only``, ``drop_rate``,
        ``garbage_rate``, ``bad_checksum_rate``); returns the device's time of it.

        >>> with Bno08xEmulator() as imu:
        ...     imu.inject(silent=True) <= imu.clock() and imu.silent
        True
        """
        return self._set_faults(faults, self._FAULTS, ("drop_rate", "garbage_rate", "bad_checksum_rate"))

    # -- a device that takes no commands

    def _on_bytes(self, data: bytes, now: float) -> None:
        pass  # RVC mode has no commands: the device ignores its RX line

    def _next_wakeup(self, now: float) -> float:
        return now + 0.25 / self.rate

    def _true_turned(self) -> float:
        try:
            h = float(self.heading())
        except Exception as exc:  # a broken source must not kill the device: the last heading
            self.source_errors.append(exc)
            return self._turned
        if not math.isfinite(h):
            return self._turned
        if self._t0 is None:
            self._start_heading = h
        self._turned = _c.unwrap(self._turned, h - self._start_heading)
        return self._turned

    def _felt(self) -> tuple[float, float]:
        """The horizontal acceleration the source gives now ((0, 0) without one, or when it
        fails or is not finite: a broken source must not kill the device)."""
        if self.acceleration is None:
            return (0.0, 0.0)
        try:
            ax, ay = (float(v) for v in self.acceleration())
        except Exception as exc:
            self.source_errors.append(exc)
            return (0.0, 0.0)
        return (ax, ay) if math.isfinite(ax) and math.isfinite(ay) else (0.0, 0.0)

    def _tick(self, now: float) -> None:
        with self._lock:
            if self._t0 is None:
                self._true_turned()
                self._t0 = now
            due = int((now - self._t0) * self.rate) - self._due_base
            if due <= 0 or self.silent:
                self._due_base += max(due, 0)  # silence: the reports are not made, not held
                return
            self._due_base += due
            # the source is read first: it may switch a fault on now (a world's scheduled one,
            # backends/imu_fault.py), which then holds for this pass's reports too
            turned = None if self.garbage_only else self._true_turned()
            if self.silent or self._vanish.is_set():
                return
            if turned is None or self.garbage_only:
                self._emit_garbage(due * _c.REPORT_SIZE)
                return
            self._accel = self._felt()
            for _ in range(min(due, 10)):  # a long stall: the device does not catch up
                if not self._emit(turned, now):
                    return

    def _emit_garbage(self, n: int) -> None:
        junk = bytes(self._rng.randrange(256) for _ in range(n))
        self.garbage_bytes_sent += n
        self._queue(junk)

    def _queue(self, data: bytes) -> None:
        if len(self._out) + len(data) <= self.max_backlog:
            self._send(data)
        else:
            self.backlog_dropped += len(data)  # the host is not reading: bytes lost

    def _emit(self, turned: float, now: float) -> bool:
        """Send one report (with the faults in force); False once silent or vanished."""
        rng = self._rng
        assert self._t0 is not None
        yaw = (1.0 + self.scale_error) * turned + self.drift * (now - self._t0)
        if self.walk:
            self._walked += rng.gauss(0.0, self.walk / math.sqrt(self.rate))
            yaw += self._walked
        if self.noise:
            yaw += rng.gauss(0.0, self.noise)
        report = _c.RvcReport.of(self.index, yaw, accel=(*self._accel, _c.STANDARD_GRAVITY))
        self.truth[self.index] = turned
        self.index = (self.index + 1) & 0xFF
        self.sent += 1
        if self.drop_rate and rng.random() < self.drop_rate:
            self.dropped += 1
        else:
            frame = bytearray(_c.encode_report(report))
            if self.bad_checksum_rate and rng.random() < self.bad_checksum_rate:
                frame[-1] ^= 1 + rng.randrange(255)
                self.corrupted += 1
            if self.garbage_rate and rng.random() < self.garbage_rate:
                self._emit_garbage(rng.randint(1, 32))
            self._queue(bytes(frame))
        if self.silent_after is not None and self.sent >= self.silent_after:
            self.silent = True
            return False
        if self.vanish_after is not None and self.sent >= self.vanish_after:
            self._flush()
            self._vanish.set()
            return False
        return True
