"""An IMU whose yaw turns while the wheels stand is a device fault (issue #36: "an IMU that
disagrees wildly", bno08x_still.StillWatch): the driver latches it, a drift within the bound
and a turn while the wheels move do not. Deadlines on simulated time (SimLine), as in
test_bno08x.py; the whole stack meeting it is test_imu_stack_simtime.py's."""

from __future__ import annotations

import threading

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.bno08x import Bno08xRvc, ImuProtocolError
from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from clomp.runtime.devices.bno08x_still import StillWatch
from tests.runtime._simline import SimLine

WAIT = 30.0  # wall seconds: a hang, not a figure
SPIN = 0.52  # rad/s: 30°/s, a turn the robot could make, at the wrong time


@settings(max_examples=60, deadline=None)
@given(rate=st.floats(-0.25, 0.25), noise=st.lists(st.floats(-0.02, 0.02), min_size=50, max_size=300),
       lost=st.lists(st.integers(1, 3), min_size=50, max_size=300))
def test_a_drift_within_the_bound_never_trips(rate: float, noise: list[float], lost: list[int]) -> None:
    """Any drift up to ``max_rate``, noise within ±``slack``/2 on every report, reports lost
    (an index gap of up to 3): never judged wrong."""
    w = StillWatch(max_rate=0.25, slack=0.05, settle=0.3)
    w.command(still=True, at=0.0)
    index = 0
    for gap, n in zip(lost, noise):
        index += gap
        assert w.feed(index % 256, rate * index / 100.0 + n, index / 100.0) is None


@given(rate=st.floats(0.4, 4.0), sign=st.sampled_from([-1.0, 1.0]))
def test_a_turn_while_standing_trips_within_its_bound(rate: float, sign: float) -> None:
    """A yaw turning at ``rate`` > max_rate from the window's start trips once ``rate × t``
    exceeds ``max_rate × t + slack``, to the report."""
    w = StillWatch(max_rate=0.25, slack=0.05, settle=0.3)
    w.command(still=True, at=0.0)
    for i in range(31):
        assert w.feed(i, 0.0, i / 100.0) is None  # settling (0.3 s), then the window's base: not judged
    tripped = next(k for k in range(1, 1000) if w.feed(30 + k, sign * rate * k / 100.0, (30 + k) / 100.0) is not None)
    assert tripped == next(k for k in range(1, 1000) if rate * k / 100.0 > 0.25 * k / 100.0 + 0.05)


def test_moving_wheels_are_not_judged_and_a_new_stand_starts_a_new_window() -> None:
    w = StillWatch()
    w.command(still=False, at=0.0)
    assert all(w.feed(i % 256, SPIN * i / 100.0, i / 100.0) is None for i in range(300))
    w.command(still=True, at=3.0)  # the body stands from here: the yaw it stopped at is not held against it
    assert all(w.feed((300 + i) % 256, SPIN * 3.0, 3.0 + i / 100.0) is None for i in range(300))


def test_reports_made_before_the_stand_are_not_judged_when_read_late() -> None:
    """A reader running late (a busy host) feeds reports made while the body still turned
    after the wheels were commanded still: they neither count in the settle nor become the
    window's base."""
    w = StillWatch(max_rate=0.25, slack=0.05, settle=0.3)
    w.command(still=True, at=1.0)
    late = [w.feed(i, SPIN * i / 100.0, i / 100.0) for i in range(100)]  # made 0-1.0 s: turning
    assert late == [None] * 100
    assert all(w.feed(i, SPIN * 1.0, i / 100.0) is None for i in range(100, 300))  # standing from 1.0 s


def _driver(still: bool) -> tuple[Bno08xRvc, float]:
    """The driver reading an IMU that turns at SPIN, told the wheels stand (or move) at the
    returned simulated time (its reader already runs: simulated time moves while it waits)."""
    clock, lock = ManualClock(0.0), threading.RLock()
    emu = Bno08xEmulator(lambda: SPIN * clock.now(), seed=1, clock=clock.now)
    imu = Bno08xRvc(SimLine(emu, clock, lock=lock, name="sim-imu"), clock=clock.now, max_rate=4.0, still_rate=0.25)
    with lock:  # the line does not move time meanwhile
        told = clock.now()
        imu.wheels_still(still)
    return imu, told


def test_an_imu_turning_while_the_wheels_stand_is_a_fault() -> None:
    imu, told = _driver(still=True)
    with imu:
        assert imu.wait_for(lambda i: i.fault is not None or i.decoder.reports >= 400, WAIT)
        assert isinstance(imu.fault, ImuProtocolError) and "disagrees wildly" in str(imu.fault), imu.fault
        # settle 0.3 s, then 0.52 t > 0.25 t + 0.05 from t = 0.19 s (to the report, one more held by the decoder)
        assert imu.fault_time is not None and 0.48 <= imu.fault_time - told <= 0.52 + 1e-9, imu.fault_time - told
        with pytest.raises(ImuProtocolError):
            imu.rotation()


def test_the_same_turn_while_the_wheels_move_is_a_heading() -> None:
    imu, _ = _driver(still=False)
    with imu:
        assert imu.wait_for(lambda i: i.fault is not None or i.decoder.reports >= 300, WAIT)
        assert imu.fault is None
        turned = imu.rotation()
        assert turned is not None and turned > SPIN * 2.9  # followed: 300 reports (3 s) and more
