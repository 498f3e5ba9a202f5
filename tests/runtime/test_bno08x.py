"""The BNO08x RVC driver against its emulator: the world's true heading through a real pty,
the sensor's errors, and the stream faults (unplugged, silent, garbage only) on device time.

Waits are for events (``wait_for`` re-checks after each pass of the reader) bounded in wall
time; deadlines are measured on a :class:`SimLine` (simulated time that moves only while the
driver waits for bytes), as in test_hardware_deadlines.py, so no figure depends on how busy
the machine is.
"""

from __future__ import annotations

import math
import threading
from collections.abc import Callable

import pytest

from clomp.planner.scenarios import load_scenario
from clomp.runtime.backends import make_world_robot
from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.bno08x import (
    Bno08xRvc,
    ImuError,
    ImuPortError,
    ImuProtocolError,
    ImuTimeout,
)
from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from tests.runtime._simline import SimLine

WAIT = 30.0  # wall seconds a test may wait for an event before it fails (a hang, not a figure)
# over a real pty the deadlines are not under test (a loaded machine can delay any thread by
# more than 0.2 s): they are measured on simulated time below
PTY_DEADLINE = 30.0
PERIOD = 0.01


def _wrap(a: float) -> float:
    return math.remainder(a, math.tau)


def _on_simline(emu: Bno08xEmulator, clock: ManualClock, *, start_timeout: float = 1.0) -> Bno08xRvc:
    return Bno08xRvc(SimLine(emu, clock, name="sim-imu"), clock=clock.now, start_timeout=start_timeout)


def _on_pty(emu: Bno08xEmulator) -> Bno08xRvc:
    return Bno08xRvc(emu.port, silence_timeout=PTY_DEADLINE, start_timeout=PTY_DEADLINE)


def _made_after(emu: Bno08xEmulator, turned: float) -> Callable[[Bno08xRvc], bool]:
    """The event: the driver has a report made when the true heading had ``turned``."""

    def event(imu: Bno08xRvc) -> bool:
        s = imu.latest()
        return s is not None and abs(emu.truth.get(s.report.index, math.inf) - turned) < 1e-9

    return event


def _wait(imu: Bno08xRvc, predicate: Callable[[Bno08xRvc], bool]) -> None:
    assert imu.wait_for(predicate, WAIT), "the event never came"


# ------------------------------------------------------------------- over a real pty


def test_the_worlds_true_heading_comes_through_a_pty_within_the_noise() -> None:
    """A world robot spins two turns and a half; the emulator reports its heading (noise
    0.3°) and the driver decodes every report within 5 σ of the world's heading when it
    was made, and follows it through the wrap: its continuous yaw counts the turns."""
    world = make_world_robot(load_scenario("open"), "ideal", seed=0)
    lock = threading.Lock()

    def heading() -> float:
        with lock:
            return float(world.ground_truth_pose().theta)

    noise = math.radians(0.3)
    theta0 = heading()
    world_turned = 0.0
    with Bno08xEmulator(heading, noise=noise, seed=3) as emu, _on_pty(emu) as imu:
        _wait(imu, lambda i: i.latest() is not None)  # the device has started: its yaw is 0 here
        for _ in range(60):
            with lock:  # the emulator reads the heading between steps only
                before = world.ground_truth_pose().theta
                world.set_wheel_speeds(-0.2, 0.2)
                world.sleep(0.1)
                world_turned += _wrap(world.ground_truth_pose().theta - before)
            _wait(imu, _made_after(emu, world_turned))
        with emu._lock:  # the emulator makes no report meanwhile
            samples = imu.recent()[-200:]  # the emulator's truth holds the last 256 indices
            truth = dict(emu.truth)
        assert len(samples) >= 60 and world_turned > 2 * math.tau
        for s in samples:
            assert abs(_wrap(s.report.yaw - truth[s.report.index])) <= 5 * noise + math.radians(0.005)
        last = samples[-1]
        assert truth[last.report.index] == pytest.approx(world_turned, abs=1e-9)
        assert _wrap(world_turned - (world.ground_truth_pose().theta - theta0)) == pytest.approx(0.0, abs=1e-9)
        assert last.yaw == pytest.approx(world_turned, abs=5 * noise)  # continuous: the turns are counted
        assert imu.rotation() == pytest.approx(world_turned, abs=10 * noise)  # the first report read ~0
        assert imu.fault is None and imu.decoder.lost_reports == 0


def test_an_unplugged_imu_is_a_port_fault() -> None:
    with Bno08xEmulator(lambda: 1.0) as emu, _on_pty(emu) as imu:
        _wait(imu, lambda i: i.latest() is not None)
        emu.vanish()
        _wait(imu, lambda i: i.fault is not None)
        assert isinstance(imu.fault, ImuPortError) and "unplugged" in str(imu.fault)
        with pytest.raises(ImuPortError):
            imu.rotation()


def test_a_port_that_cannot_be_opened_is_a_port_error() -> None:
    with pytest.raises(ImuPortError, match="/nonexistent/tty"):
        Bno08xRvc("/nonexistent/tty")


# --------------------------------------------------------------- on simulated time


def test_drift_and_scale_error_show_in_the_heading() -> None:
    clock = ManualClock(10.0)
    drift, rate, scale = math.radians(0.5) / 60.0, 0.5, 0.02  # the datasheet's 0.5°/min; 0.5 rad/s
    emu = Bno08xEmulator(lambda: rate * clock.now(), drift=drift, scale_error=scale, clock=clock.now)
    with _on_simline(emu, clock) as imu:
        _wait(imu, lambda i: (s := i.latest()) is not None and s.timestamp >= 20.0)
        s = imu.latest()
        assert s is not None
        t = s.timestamp - 10.0  # since the emulator's start (its first tick at t = 10)
        # 5 rad in 10 s (through the wrap), read 2 % more, plus 0.083° of drift
        assert s.yaw == pytest.approx((1 + scale) * rate * t + drift * t, abs=math.radians(0.01) + rate * 0.002)


def test_dropped_reports_garbage_and_bad_checksums_are_counted_and_survived() -> None:
    clock, lock = ManualClock(0.0), threading.RLock()
    emu = Bno08xEmulator(lambda: 0.7, drop_rate=0.05, garbage_rate=0.05, bad_checksum_rate=0.05,
                         seed=11, clock=clock.now)
    with Bno08xRvc(SimLine(emu, clock, lock=lock, name="sim-imu"), clock=clock.now) as imu:
        _wait(imu, lambda i: i.decoder.reports >= 500)
        with lock:  # the faults end here: every faulty report is followed by a good one
            emu.inject(drop_rate=0.0, garbage_rate=0.0, bad_checksum_rate=0.0)
            made, dropped, corrupted = emu.sent, emu.dropped, emu.corrupted
        _wait(imu, lambda i: i.decoder.reports + i.decoder.lost_reports > made)
        d = imu.decoder
        assert imu.fault is None and dropped > 10 and corrupted > 10 and emu.garbage_bytes_sent > 100
        assert d.lost_reports == dropped + corrupted
        assert d.bad_checksums >= corrupted
        assert all(s.yaw == 0.0 for s in imu.recent())  # reported relative to the start


@pytest.mark.parametrize(
    ("fault", "error", "said"),
    [({"silent": True}, ImuTimeout, "fell silent"), ({"garbage_only": True}, ImuProtocolError, "corrupt")],
)
def test_a_silent_or_garbled_stream_is_a_fault_after_the_deadline_of_device_time(
    fault: dict[str, bool], error: type[ImuError], said: str
) -> None:
    clock, lock = ManualClock(100.0), threading.RLock()
    emu = Bno08xEmulator(lambda: 0.0, seed=1, clock=clock.now)  # not started: no pty, no thread
    line = SimLine(emu, clock, lock=lock, name="sim-imu")
    with Bno08xRvc(line, clock=clock.now, silence_timeout=0.2) as imu:
        _wait(imu, lambda i: i.decoder.reports >= 20)
        with lock:  # no simulated time passes while the fault goes in
            t0 = emu.inject(**fault)
        _wait(imu, lambda i: i.fault is not None)
        assert isinstance(imu.fault, error) and said in str(imu.fault), imu.fault
        assert imu.fault_time is not None
        # never before 0.2 s without a report handed on (the last one sent may be held back by
        # the decoder, waiting for the next one's first bytes: see RvcDecoder) ...
        assert imu.fault_time - imu._recent[-1].timestamp > 0.2
        # ... and noticed at the next read after 0.2 s (at most 10 ms: the line's read timeout)
        assert imu.fault_time - t0 <= 0.2 + 0.01 + 0.001 + 1e-9
        with pytest.raises(error):
            imu.latest()


def test_silence_after_a_report_the_decoder_holds_is_silence_not_garbage() -> None:
    """Report 0xBF of a still device has checksum 0xAA: the decoder holds it for the next
    report's first bytes, which never come. Its bytes are no garbage: the device fell silent."""
    clock = ManualClock(0.0)
    emu = Bno08xEmulator(lambda: 0.0, start_index=0xBF - 5, silent_after=6, clock=clock.now)
    with _on_simline(emu, clock) as imu:
        _wait(imu, lambda i: i.fault is not None)
        assert isinstance(imu.fault, ImuTimeout) and "no full report" in str(imu.fault), imu.fault
        assert imu.decoder.reports == 5 and imu.decoder.pending_bytes == 19


def test_a_device_silent_from_the_start_fails_after_the_start_timeout() -> None:
    clock = ManualClock(5.0)
    emu = Bno08xEmulator(clock=clock.now)
    emu.inject(silent=True)
    t0 = clock.now()
    with _on_simline(emu, clock, start_timeout=0.5) as imu:
        _wait(imu, lambda i: i.fault is not None)
        assert isinstance(imu.fault, ImuTimeout) and "no byte for 0.5" in str(imu.fault)
        assert "since it was opened" in str(imu.fault)
        assert imu.fault_time is not None and 0.5 < imu.fault_time - t0 <= 0.5 + 0.011
        with pytest.raises(ImuTimeout):
            imu.rotation()


def test_a_vanished_device_on_simulated_time_is_a_port_fault_told_at_once() -> None:
    clock = ManualClock(0.0)
    emu = Bno08xEmulator(lambda: 0.1, clock=clock.now, vanish_after=30)
    told: list[tuple[ImuError, float]] = []
    line = SimLine(emu, clock, name="sim-imu")
    line.running.clear()  # time stands still until the callback is in place
    with Bno08xRvc(line, clock=clock.now) as imu:
        imu.on_fault = lambda fault: told.append((fault, clock.now()))
        line.running.set()
        _wait(imu, lambda i: bool(told))
        assert isinstance(imu.fault, ImuPortError)
        assert told == [(imu.fault, imu.fault_time)]  # once, from the reader, when found
        assert imu.decoder.reports >= 29  # what it sent before vanishing was read


def test_reports_read_late_are_timed_by_their_index() -> None:
    """A reader kept waiting finds a backlog: each report is dated 10 ms before the next."""
    clock = ManualClock(0.0)
    # 12 reports, then silence for longer than the driver's history could be overrun in
    emu = Bno08xEmulator(lambda: 0.0, silent_after=12, clock=clock.now)
    emu._tick(0.0)  # the device starts at 0 ...
    clock.advance(0.095)  # ... and has made 9 reports before the driver reads at all
    with Bno08xRvc(SimLine(emu, clock, name="sim-imu"), clock=clock.now, silence_timeout=1e9) as imu:
        _wait(imu, lambda i: i.decoder.reports >= 12)
        times = [s.timestamp for s in imu.recent()]
        assert len(times) == 12
        assert times[:9] == pytest.approx([0.095 - (8 - k) * PERIOD for k in range(9)])
        assert all(b >= a for a, b in zip(times, times[1:]))


def _jumping(after: int, *, once: bool) -> Callable[[], float]:
    """A heading source that stands still, then reads 1 rad off from its ``after``-th call on
    (once: at that call only, a single outlier). The emulator asks it once per report."""
    calls = [0]

    def heading() -> float:
        calls[0] += 1
        jumped = calls[0] == after if once else calls[0] >= after
        return 1.0 if jumped else 0.0

    return heading


@pytest.mark.parametrize("once", [False, True])
def test_a_yaw_turning_faster_than_the_robot_can_is_a_fault_and_one_outlier_is_not(once: bool) -> None:
    """1 rad in 10 ms, held: beyond 4 rad/s over 0.1 s for three reports in a row, an
    ImuProtocolError at the third; the same jump in one report only (a report forged by line
    noise) passes."""
    clock, lock = ManualClock(0.0), threading.RLock()
    emu = Bno08xEmulator(_jumping(30, once=once), seed=1, clock=clock.now)
    with Bno08xRvc(SimLine(emu, clock, lock=lock, name="sim-imu"), clock=clock.now, max_rate=4.0) as imu:
        _wait(imu, lambda i: i.fault is not None or i.decoder.reports >= 80)
        if once:
            assert imu.fault is None and imu.decoder.reports >= 80
            assert max(abs(s.yaw) for s in imu.recent()) == pytest.approx(1.0, abs=1e-3)  # the outlier was read
            return
        assert isinstance(imu.fault, ImuProtocolError) and "impossible turn" in str(imu.fault), imu.fault
        assert 30 <= imu.decoder.reports <= 33  # the jump's third report (and the one the decoder held)


class _HeldUpPort:
    """A serial-like port of an IMU that reports every 10 ms of ``clock`` without fail, read by
    a reader that is held up once: the read that blocked for one byte returns it ``held`` s
    late, the reports made meanwhile waiting in the buffer (as when the reader's process is
    busy: the start of ``clomp run`` on a loaded machine). ``silent_from`` (index): the device
    stops reporting there and nothing more is buffered."""

    timeout = 0.01

    def __init__(self, clock: ManualClock, held_at: int, held: float, silent_from: int | None = None) -> None:
        from clomp.runtime.devices.bno08x_codec import RvcReport, encode_report

        self.clock, self.held_at, self.held, self.silent_from = clock, held_at, held, silent_from
        self._encode = lambda i: encode_report(RvcReport.of(i % 256, yaw=0.0))
        self.buffer, self.made, self.port = bytearray(), 0, "held-up-imu"

    def _make_until(self, t: float) -> None:
        while self.made * PERIOD <= t + 1e-9 and (self.silent_from is None or self.made < self.silent_from):
            self.buffer += self._encode(self.made)
            self.made += 1

    @property
    def in_waiting(self) -> int:
        self._make_until(self.clock.now())
        return len(self.buffer)

    def read(self, n: int) -> bytes:
        if self.made == self.held_at and not self.buffer:
            self.clock.advance(PERIOD)
            self._make_until(self.clock.now())
            self.clock.advance(self.held)  # one byte arrived; the reader takes it this late
            out = bytes(self.buffer[:1])
            del self.buffer[:1]
            self._make_until(self.clock.now())
            return out
        if not self.buffer:
            self.clock.advance(PERIOD)
            self._make_until(self.clock.now())
        out = bytes(self.buffer[:n])
        del self.buffer[:n]
        return out

    def close(self) -> None:
        pass


def test_a_reader_held_up_with_reports_waiting_is_not_a_silent_imu() -> None:
    """The reader comes back 0.4 s late with one byte, the reports of those 0.4 s waiting in
    the port: it takes them in before it judges, and the IMU is healthy (it tripped on a
    false 'fell silent' at the start of clomp run on a loaded machine)."""
    clock = ManualClock(0.0)
    port = _HeldUpPort(clock, held_at=20, held=0.4)
    with Bno08xRvc(port, clock=clock.now) as imu:
        _wait(imu, lambda i: i.decoder.reports >= 80 or i.fault is not None)
        assert imu.fault is None
        assert imu.decoder.reports >= 80


def test_a_held_up_reader_still_finds_a_device_that_fell_silent() -> None:
    """The same hold-up with the device silent meanwhile (nothing waiting): a fault at once."""
    clock = ManualClock(0.0)
    port = _HeldUpPort(clock, held_at=20, held=0.4, silent_from=21)
    with Bno08xRvc(port, clock=clock.now) as imu:
        assert imu.wait_for(lambda i: i.fault is not None, WAIT)
        assert isinstance(imu.fault, ImuTimeout)


def test_the_peak_horizontal_acceleration_is_read_once_and_gravity_is_not_a_shock() -> None:
    from clomp.runtime.devices.bno08x_codec import STANDARD_GRAVITY, RvcReport

    clock = ManualClock(0.0)
    emu = Bno08xEmulator(lambda: 0.0, clock=clock.now)  # level and still: gravity alone
    with _on_simline(emu, clock) as imu:
        _wait(imu, lambda i: i.latest() is not None)
        still = imu.peak_acceleration()
        assert still is not None and still < 0.05
        imu._take([RvcReport.of(7, yaw=0.0, accel=(3.0, -4.0, STANDARD_GRAVITY))], clock.now())  # a kick's report
        assert abs((imu.peak_acceleration() or 0.0) - 5.0) < 0.02
        assert (imu.peak_acceleration() or 0.0) < 0.05  # read once: the next peak is a new one
