"""CEVA/Hillcrest BNO08x IMU (BNO080/085/086) in UART-RVC mode over pyserial: a heading sensor.

:class:`Bno08xRvc` reads the device's 100 Hz report stream on a thread of its own (RVC
mode takes no commands) and keeps the newest heading with its time, followed through the
±180° wrap. It watches the stream as the hardware backend watches the LiDAR's: a port
that fails, no byte for ``silence_timeout`` seconds, or bytes without a valid report for
as long latch a fault (:class:`ImuPortError`, :class:`ImuTimeout`,
:class:`ImuProtocolError`, all :class:`ImuError`), which every later call raises. Given the
fastest turn its platform can make (``max_rate``), it also latches a yaw that turns faster
than that over ``rate_window`` s, report after report (:class:`ImuProtocolError`): a heading
that is wildly wrong, which no consumer should follow. A deadline found passed while bytes
wait in the port is the reader's own hold-up (its process busy), not silence: it takes
them in once before it judges. Built
on :mod:`clomp.runtime.devices.bno08x_codec` (whose names are re-exported here).

>>> with Bno08xRvc("loop://") as imu:
...     _ = imu.port.write(encode_report(RvcReport.of(0, yaw=0.5)) + bytes(2))
...     imu.wait_for(lambda i: i.latest() is not None, 5.0), round(imu.rotation(), 3)
(True, 0.0)
"""

from __future__ import annotations

import collections
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any, Self

from clomp.runtime.devices.bno08x_codec import (
    DEFAULT_BAUDRATE,
    REPORT_RATE,
    ImuError,
    ImuPortError,
    ImuProtocolError,
    ImuTimeout,
    RvcDecoder,
    RvcReport,
    encode_report,
    unwrap,
)
from clomp.runtime.devices.port import PORT_ERRORS as _PORT_ERRORS
from clomp.runtime.devices.port import SerialDevice
from clomp.runtime.devices.bno08x_slide import Slide, SlideWatch
from clomp.runtime.devices.bno08x_still import StillWatch

__all__ = [
    "Bno08xRvc",
    "Slide",
    "ImuSample",
    "ImuError",
    "ImuPortError",
    "ImuProtocolError",
    "ImuTimeout",
    "RvcDecoder",
    "RvcReport",
    "encode_report",
    "DEFAULT_BAUDRATE",
]

# seconds one blocking read may take: bounds how late a deadline can be noticed
_READ_SLICE = 0.02


@dataclass(frozen=True)
class ImuSample:
    """One report as the driver received it.

    ``timestamp``: when the device sent it, on the driver's clock (the reading time,
    less 10 ms per report that came after it in the same read: a reader kept waiting
    finds a backlog). ``yaw``: the report's yaw (rad, counter-clockwise, 0 at the device's
    reset) followed through the ±π wrap from the first report on, so it is continuous.

    >>> ImuSample(RvcReport(3, -9000), 1.0, -7.853981633974483).report.yaw_deg
    -90.0
    """

    report: RvcReport
    timestamp: float
    yaw: float


class Bno08xRvc(SerialDevice):
    """A BNO08x in UART-RVC mode on a serial port, read on a background thread.

    ``port`` is a device path (``/dev/ttyUSB0``), a pyserial URL or an open serial-like
    object (``read``, optionally ``in_waiting``; not closed by :meth:`close`). ``clock`` is
    the time of the samples and of the deadlines (``time.monotonic`` unless a test passes
    its own). ``start_timeout`` bounds the wait for the first report, ``silence_timeout``
    every later gap between reports; ``history`` recent samples are kept. ``max_rate``
    (rad/s, None: no check): the yaw may change over the last ``rate_window`` s of the
    device's time (report indices, so a host that read late does not matter) by at most
    ``max_rate × rate_window + rate_slack``; ``rate_reports`` reports in a row beyond that
    latch :class:`ImuProtocolError` (one outlier, a report forged by line noise, passes).
    ``still_rate`` (rad/s, None: no check): told by :meth:`wheels_still` that the wheels
    stand, a yaw turning faster than that latches it too (bno08x_still).

    What a heading consumer calls: :meth:`rotation` (rad turned since the first report,
    as :class:`clomp.runtime.interface.TurnSensing` asks), :meth:`latest` (the newest
    :class:`ImuSample`), :meth:`recent` (the last samples, to find the heading at a
    scan's time); each raises the latched :class:`ImuError` once the stream has failed,
    and :attr:`on_fault` hears of the fault the moment it is found.
    """

    _device, _port_error = "IMU", ImuPortError

    def __init__(
        self,
        port: str | Any,
        *,
        baudrate: int = DEFAULT_BAUDRATE,
        silence_timeout: float = 0.2,
        start_timeout: float = 1.0,
        history: int = 256,
        clock: Callable[[], float] | None = None,
        max_rate: float | None = None,
        rate_window: float = 0.1,
        rate_slack: float = 0.05,
        rate_reports: int = 3,
        still_rate: float | None = None,
    ) -> None:
        if not (silence_timeout > 0 and start_timeout > 0):
            raise ValueError("silence_timeout and start_timeout must be positive")
        if max_rate is not None and not (max_rate > 0 and 0 < rate_window * REPORT_RATE < history
                                         and rate_slack >= 0 and rate_reports >= 1):
            raise ValueError("max_rate and rate_window must be positive (the window shorter than the history), "
                             "rate_slack not negative, rate_reports at least 1")
        self.max_rate, self.rate_window, self.rate_slack, self.rate_reports = max_rate, rate_window, rate_slack, rate_reports
        self._too_fast = 0  # reports in a row whose yaw turned faster than max_rate
        self._still = None if still_rate is None else StillWatch(max_rate=still_rate)  # a turn while the wheels stand
        if history < 1:
            raise ValueError("history must be at least 1")
        self.baudrate = baudrate
        self.silence_timeout = silence_timeout
        self.start_timeout = start_timeout
        self.clock: Callable[[], float] = clock or time.monotonic
        self.decoder = RvcDecoder()
        #: passes of the reader loop so far (a test can wait for the driver to have looked)
        self.passes = 0
        #: when the fault was found, on :attr:`clock`
        self.fault_time: float | None = None
        #: called once with the fault, in the reader's thread, as soon as it is latched and
        #: outside the driver's lock (a backend stops the wheels there, as the LiDAR's
        #: stream watch does)
        self.on_fault: Callable[[ImuError], None] | None = None
        self.callback_error: BaseException | None = None
        self._fault: ImuError | None = None
        self._first: ImuSample | None = None
        self._peak: float | None = None  # the largest horizontal acceleration since peak_acceleration (m/s²)
        self._watch = SlideWatch()  # a kick's slide, from the reports' accelerations (bno08x_slide)
        self._slides: list[Slide] = []  # the slides ended since :meth:`slides`
        self._recent: collections.deque[ImuSample] = collections.deque(maxlen=history)
        self._cond = threading.Condition()
        self._closing = threading.Event()
        self._attach(port, baudrate=baudrate, timeout=_READ_SLICE, needs=("read",), read_slice=_READ_SLICE)
        self._thread = threading.Thread(target=self._read_loop, name="imu-reader", daemon=True)
        self._thread.start()

    # -- what a consumer reads

    @property
    def port(self) -> Any:
        """The serial port (or the serial-like object given)."""
        return self._port

    @property
    def fault(self) -> ImuError | None:
        """Why the stream failed, or None while it is healthy."""
        return self._fault

    def check(self) -> None:
        """Raise the latched fault, if any."""
        if self._fault is not None:
            raise self._fault

    def latest(self) -> ImuSample | None:
        """The newest sample, or None before the first; raises the latched :class:`ImuError`."""
        with self._cond:
            self.check()
            return self._recent[-1] if self._recent else None

    def recent(self) -> list[ImuSample]:
        """The last samples kept (oldest first); raises the latched :class:`ImuError`."""
        with self._cond:
            self.check()
            return list(self._recent)

    def rotation(self) -> float | None:
        """Heading turned since the first report (rad, counter-clockwise), None before it;
        raises the latched :class:`ImuError`."""
        with self._cond:
            self.check()
            if not self._recent or self._first is None:
                return None
            return self._recent[-1].yaw - self._first.yaw

    def peak_acceleration(self) -> float | None:
        """The largest horizontal acceleration (m/s², the report's x and y: the device mounted
        level) among the reports since the last call, None when none came (as
        :class:`clomp.runtime.interface.ShockSensing` asks); raises the latched :class:`ImuError`."""
        with self._cond:
            self.check()
            peak, self._peak = self._peak, None
            return peak

    def slides(self) -> list[Slide]:
        """The kicks' slides measured since the last call (:class:`~clomp.runtime.devices.bno08x_slide.SlideWatch`),
        oldest first; raises the latched :class:`ImuError`."""
        with self._cond:
            self.check()
            out, self._slides = self._slides, []
            return out

    def wait_for(self, predicate: Callable[[Self], bool], timeout: float) -> bool:
        """Wait (wall time, at most ``timeout`` s) until ``predicate(self)`` holds, re-checked
        after each pass of the reader; False if it still does not then, or the reader ended."""
        deadline = time.monotonic() + timeout
        with self._cond:
            while not predicate(self):
                left = deadline - time.monotonic()
                if left <= 0 or not self._thread.is_alive():
                    return predicate(self)
                self._cond.wait(min(left, 0.1))
        return True

    # -- the reader

    def _read_loop(self) -> None:
        last_report = last_byte = self.clock()
        dropped_at_report = 0  # the decoder's dropped bytes when the last report came
        held = False  # a deadline passed with bytes waiting: read them before judging
        while not self._closing.is_set():
            try:
                waiting = int(getattr(self._port, "in_waiting", 0))
                data = bytes(self._port.read(max(1, waiting)))
            except _PORT_ERRORS as exc:
                if not self._closing.is_set():
                    self._trip(ImuPortError(f"IMU port {self.port_name} failed while reading (device unplugged?): {exc}"))
                return
            now = self.clock()
            fault: ImuError | None = None
            if data:
                last_byte = now
                took, fault = self._take(self.decoder.feed(data), now)
                if took:
                    last_report, dropped_at_report, held = now, self.decoder.dropped_bytes, False
            fault = fault or self._deadline_fault(now, last_report, last_byte, self.decoder.dropped_bytes - dropped_at_report)
            if isinstance(fault, ImuTimeout) and not held and self._waiting() > 0:
                # not silence: this thread was held up (its process busy, the machine loaded) and
                # the device's reports wait in the port's buffer; judge after taking them in
                held = True
                continue
            if fault is not None:
                self._trip(fault)
                return
            with self._cond:
                self.passes += 1
                self._cond.notify_all()

    def _waiting(self) -> int:
        """Bytes waiting in the port's buffer (0 when it cannot say)."""
        try:
            return int(getattr(self._port, "in_waiting", 0))
        except _PORT_ERRORS:
            return 0

    def _take(self, reports: list[RvcReport], now: float) -> tuple[bool, ImuError | None]:
        """Keep the reports (True when there were any) and the fault of a yaw turning too fast."""
        if not reports:
            return False, None
        newest = reports[-1].index
        fault = None
        with self._cond:
            for r in reports:
                t = now - ((newest - r.index) % 256) / REPORT_RATE
                prev = self._recent[-1] if self._recent else None
                if prev is None:
                    sample = ImuSample(r, t, r.yaw)
                    self._first = sample
                else:
                    sample = ImuSample(r, max(t, prev.timestamp), unwrap(prev.yaw, r.yaw))
                self._recent.append(sample)
                ax, ay, _az = r.accel
                self._peak = max(self._peak or 0.0, math.hypot(ax, ay))
                slid = self._watch.feed(r.index, ax, ay, sample.yaw)
                if slid is not None:
                    self._slides.append(slid)
                fault = fault or self._rate_fault() or self._still_fault(sample)
        return True, fault

    def wheels_still(self, still: bool) -> None:
        """Tell the driver the wheels were commanded still (True) or to move, now: with
        ``still_rate``, a yaw that turns while they stand latches :class:`ImuProtocolError`
        (:class:`~clomp.runtime.devices.bno08x_still.StillWatch`)."""
        if self._still is not None:
            with self._cond:
                self._still.command(still, self.clock())

    def _still_fault(self, sample: ImuSample) -> ImuError | None:
        why = None if self._still is None else self._still.feed(sample.report.index, sample.yaw, sample.timestamp)
        return None if why is None else ImuProtocolError(
            f"IMU on {self.port_name} disagrees wildly with the wheels: its yaw {why} "
            f"(a gyro gone bad, or a forged stream?)")

    def _rate_fault(self) -> ImuError | None:
        """The fault when the newest sample ends ``rate_reports`` in a row whose yaw changed
        faster than ``max_rate`` over the window (call with the lock held)."""
        if self.max_rate is None:
            return None
        hist, span = self._recent, 0
        new = hist[-1]
        for k in range(len(hist) - 2, -1, -1):  # back to the sample rate_window of device time before
            span += (hist[k + 1].report.index - hist[k].report.index) % 256
            if span >= self.rate_window * REPORT_RATE:
                dt = span / REPORT_RATE
                turned = abs(new.yaw - hist[k].yaw)
                self._too_fast = self._too_fast + 1 if turned > self.max_rate * dt + self.rate_slack else 0
                if self._too_fast >= self.rate_reports:
                    return ImuProtocolError(
                        f"IMU on {self.port_name} reports an impossible turn: {turned:.2f} rad in {dt:.2f} s "
                        f"({self._too_fast} reports in a row), the robot turns at most {self.max_rate:.2f} rad/s "
                        f"(a heading wildly wrong: the device reset, a bad mount, or a forged stream?)")
                return None
        return None

    def _deadline_fault(self, now: float, last_report: float, last_byte: float, dropped: int) -> ImuError | None:
        """The fault when no report came for too long: silence, or bytes that are no report
        (``dropped`` of them since the last report; the bytes of a report the decoder still
        holds, waiting for the next one, are not garbage)."""
        limit = self.silence_timeout if self._first is not None else self.start_timeout
        if now - last_report <= limit:
            return None
        if not dropped:
            since = "since it was opened" if self._first is None else "after the last report"
            what = f"no byte for {now - last_byte:.2f} s" if now - last_byte > limit else (
                f"no full report for {now - last_report:.2f} s")
            return ImuTimeout(f"IMU on {self.port_name} fell silent: {what} {since} "
                              f"(is it powered, connected, and its P0 pin strapped for RVC mode?)")
        d = self.decoder
        return ImuProtocolError(
            f"IMU stream on {self.port_name} is corrupt: no valid report for {now - last_report:.2f} s "
            f"({dropped} bytes dropped since the last one, {d.bad_checksums} bad checksums so far; wrong baud "
            f"rate, not in RVC mode, or a bad cable?)")

    def _trip(self, fault: ImuError) -> None:
        with self._cond:
            first = self._fault is None
            if first:
                self._fault, self.fault_time = fault, self.clock()
            self._cond.notify_all()
        if first and self.on_fault is not None:
            try:
                self.on_fault(fault)
            except Exception as exc:  # kept for the caller instead of a thread traceback
                self.callback_error = exc

    # -- lifetime

    def close(self) -> None:
        """End the reader and close a port this driver opened (idempotent)."""
        self._closing.set()
        if self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._close_port()

    def __repr__(self) -> str:
        state = "healthy" if self._fault is None else f"fault: {self._fault}"
        return f"Bno08xRvc({self.port_name!r}, {state})"

