"""A device that streams unasked, with no one reading: the line keeps the newest second, not the oldest.

A USB serial adapter loses what its device sends while no program has the port open; a pty
kept every byte the emulated IMU sent from ``clomp emulate world``'s start until ``clomp run``
opened the port (its kernel buffers full of minute-old reports). The driver then read the
heading's drift over that minute as a turn while the wheels stood, and halted (issue #36: exit
3 on "disagrees wildly", a run that opened its ports 130 s after the world started). Here the
emulator's time is a manual clock, stepped only after each pass of its serving loop was seen.
"""

from __future__ import annotations

import os
import select
from functools import partial

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.bno08x_codec import RvcDecoder
from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from tests.runtime._ptycli import HANG

DRIFT = 0.05  # rad/s: the emulated gyro's yaw walks while no one listens
STALE = 1.0  # s: Bno08xEmulator.stale_after


def _served_for(emu: Bno08xEmulator, clock: ManualClock, seconds: float, step: float = 0.1) -> None:
    """``seconds`` of the device's time, ``step`` at a time, each step seen served by its loop."""
    for _ in range(round(seconds / step)):
        target = emu.passes + 2  # a whole pass after the step
        clock.advance(step)
        assert emu.wait_for(partial(_passed, target=target), HANG)


def _passed(emu: Bno08xEmulator, target: int) -> bool:
    return emu.passes >= target


def test_a_driver_opening_the_port_late_reads_the_heading_of_now_not_of_a_minute_ago() -> None:
    clock = ManualClock()
    with Bno08xEmulator(lambda: 0.0, drift=DRIFT, clock=clock.now) as emu:
        _served_for(emu, clock, 20.0)  # nobody has the port open
        assert emu.stale_after == STALE and emu.stale_dropped > 0
        fd = os.open(emu.port, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
        try:
            assert select.select([fd], [], [], HANG)[0]
            reports = RvcDecoder().feed(os.read(fd, 4096))
        finally:
            os.close(fd)
    assert reports
    # the first report on the line was made within the last second (the line's staleness), plus a pass
    assert reports[0].yaw >= DRIFT * (20.0 - STALE - 0.2), [r.yaw for r in reports[:3]]


def test_a_driver_that_reads_loses_nothing() -> None:
    clock = ManualClock()
    with Bno08xEmulator(lambda: 0.0, clock=clock.now) as emu:
        fd = os.open(emu.port, os.O_RDONLY | os.O_NOCTTY | os.O_NONBLOCK)
        decoder, got = RvcDecoder(), 0
        try:
            for _ in range(30):  # 3 s of the device's time, read after every step
                _served_for(emu, clock, 0.1)
                while select.select([fd], [], [], 0)[0]:
                    got += len(decoder.feed(os.read(fd, 4096)))
        finally:
            os.close(fd)
    assert emu.stale_dropped == 0 and decoder.lost_reports == 0 and got > 0
