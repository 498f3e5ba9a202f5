"""Pololu Maestro: command bytes, speed mapping, and the driver against the emulator."""

from __future__ import annotations

import math
import os
import signal
import time

import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.emulators import MaestroEmulator
from clomp.runtime.devices.maestro import (
    ErrorFlags,
    Maestro,
    MaestroDeviceError,
    MaestroError,
    MaestroPortError,
    MaestroTimeout,
    WheelConfig,
    decode_errors,
    encode_get_errors,
    encode_get_position,
    encode_go_home,
    encode_set_multiple_targets,
    encode_set_target,
    speed_to_target,
    target_to_speed,
)

LEFT, RIGHT = WheelConfig(0, 1), WheelConfig(1, -1)

# ------------------------------------------------------------------------------- bytes


def test_set_target_neutral_on_channel_0_compact() -> None:
    assert encode_set_target(0, 6000) == bytes.fromhex("84 00 70 2E")


def test_set_target_pololu_protocol_uses_device_number_and_clears_msb() -> None:
    assert encode_set_target(0, 6000, protocol="pololu") == bytes.fromhex("AA 0C 04 00 70 2E")
    assert encode_set_target(3, 6400, protocol="pololu", device=5) == bytes.fromhex("AA 05 04 03 00 32")


def test_other_commands() -> None:
    # 6000 = 0x1770 -> 70 2E; 6400 = 0x1900 -> 00 32
    assert encode_set_multiple_targets(0, [6000, 6400]) == bytes.fromhex("9F 02 00 70 2E 00 32")
    assert encode_get_position(2) == bytes.fromhex("90 02")
    assert encode_get_errors() == bytes.fromhex("A1")
    assert encode_get_errors(protocol="pololu") == bytes.fromhex("AA 0C 21")
    assert encode_go_home() == bytes.fromhex("A2")


def test_out_of_range_targets_and_protocols_are_refused() -> None:
    with pytest.raises(ValueError):
        encode_set_target(0, 16384)
    with pytest.raises(ValueError):
        encode_set_target(0, 6000, protocol="mini")  # type: ignore[arg-type]


def test_error_bits_have_names() -> None:
    assert decode_errors(0) == []
    assert decode_errors(0x0001) == ["serial signal error"]
    assert decode_errors(0x0014) == ["serial RX buffer full", "serial protocol error"]
    assert decode_errors(0x0020) == ["serial timeout error"]
    assert decode_errors(0x01C0) == ["script stack error", "script call stack error", "script program counter error"]
    assert decode_errors(0x0200) == ["bit 9"]


# ------------------------------------------------------------------------------ mapping


def test_speed_mapping_is_1500us_plus_minus_100us() -> None:
    assert speed_to_target(0.0, LEFT) == 6000
    assert speed_to_target(1.0, LEFT) == 6400  # 1600 µs
    assert speed_to_target(-1.0, LEFT) == 5600  # 1400 µs
    assert speed_to_target(1.0, RIGHT) == 5600  # mirrored servo
    assert speed_to_target(0.5, WheelConfig(0, gain=0.5)) == 6100  # 1525 µs
    assert speed_to_target(7.0, LEFT) == speed_to_target(1.0, LEFT)
    assert speed_to_target(-math.inf, LEFT) == speed_to_target(-1.0, LEFT)
    with pytest.raises(ValueError, match="NaN"):
        speed_to_target(math.nan, LEFT)


@given(st.floats(-1, 1), st.sampled_from([1, -1]), st.floats(0.2, 2.0))
def test_speed_mapping_round_trip(speed: float, sign: int, gain: float) -> None:
    wheel = WheelConfig(2, sign, gain)
    target = speed_to_target(speed, wheel)
    assert abs(target / 4 - 1500) <= 100 * gain + 0.125
    # one quarter-µs of quantisation is 0.0025 of full speed at gain 1
    assert abs(target_to_speed(target, wheel) - speed) <= 0.125 / (100 * gain) + 1e-12


@pytest.mark.parametrize("bad", [dict(channel=24), dict(channel=0, sign=0), dict(channel=0, gain=0.0)])
def test_wheel_config_is_validated(bad: dict) -> None:
    with pytest.raises(ValueError):
        WheelConfig(**bad)


# ------------------------------------------------------------------ driver vs emulator


@pytest.fixture
def emu():
    with MaestroEmulator() as e:
        yield e


def _wheel_targets(e: MaestroEmulator) -> tuple[int, int]:
    return e.targets[0], e.targets[1]


def test_set_speeds_reaches_the_servos(emu: MaestroEmulator) -> None:
    with Maestro(emu.port, watchdog_timeout=None) as m:
        m.set_speeds(0.5, 0.5)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6200, 5800), 10.0)
        assert emu.speeds == (0.5, 0.5)
        m.set_speeds(3.0, -3.0)  # clamped
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6400, 6400), 10.0)
        assert m.speeds == (1.0, -1.0)
        m.stop()
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6000, 6000), 10.0)
        assert m.get_position(0) == 6000


@pytest.mark.parametrize("options", [dict(protocol="pololu"), dict(multiple_targets=True), dict(protocol="pololu", multiple_targets=True)])
def test_pololu_protocol_and_multiple_targets(emu: MaestroEmulator, options: dict) -> None:
    with Maestro(emu.port, watchdog_timeout=None, **options) as m:
        m.set_speeds(-0.25, 1.0)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (5900, 5600), 10.0)
        assert not m.get_errors()


def test_other_device_number_is_ignored_by_the_maestro(emu: MaestroEmulator) -> None:
    with Maestro(emu.port, protocol="pololu", device_number=7, watchdog_timeout=None, reply_timeout=0.2) as m:
        sent = emu.clock()
        m.set_speeds(1.0, 1.0)
        # the event, not a pause: the device has taken in the command's bytes (and ignored them)
        assert emu.wait_for(lambda e: e.last_byte_at >= sent, 10.0)
        assert _wheel_targets(emu) == (0, 0)
        with pytest.raises(MaestroTimeout):
            m.get_errors()


def test_get_errors_decodes_and_clears(emu: MaestroEmulator) -> None:
    with Maestro(emu.port, watchdog_timeout=None) as m:
        assert m.get_errors() == ErrorFlags(0) and not m.get_errors()
        emu.inject_errors(0x0011)
        flags = m.get_errors()
        assert flags.code == 0x0011 and flags.names == ["serial signal error", "serial protocol error"]
        assert not m.get_errors()  # reading cleared them
        emu.inject_errors(0x0004)
        with pytest.raises(MaestroDeviceError, match="RX buffer full"):
            m.check_errors()


def test_nan_is_rejected_and_stops_the_wheels(emu: MaestroEmulator) -> None:
    with Maestro(emu.port, watchdog_timeout=None) as m:
        m.set_speeds(0.8, 0.8)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6320, 5680), 10.0)
        with pytest.raises(ValueError, match="NaN"):
            m.set_speeds(math.nan, 0.2)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6000, 6000), 10.0)


def _watchdog_latency(timeout: float | None, margin: float = 0.004) -> float:
    """Device time from a speed command to the watchdog's stop, the driver and the
    emulator sharing one manual clock: the test moves time, so load cannot skew it."""
    clock = ManualClock(0.0)
    options = {} if timeout is None else {"watchdog_timeout": timeout}
    with MaestroEmulator(clock=clock.now) as emu, Maestro(emu.port, clock=clock.now, **options) as m:
        wd = m.watchdog_timeout
        assert wd is not None
        m.set_speeds(0.5, 0.5)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6200, 5800), 10.0)
        commanded = emu.events[-1][0]
        clock.advance(wd - margin)
        assert m.wait_watchdog(2)  # it has seen the new time
        assert m.watchdog_stops == 0 and m.speeds == (0.5, 0.5)  # not before its timeout
        clock.advance(2 * margin)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6000, 6000), 10.0)
        # the device may see the stop before the watchdog has counted it: let it finish its pass
        assert m.wait_watchdog(1) and m.watchdog_stops == 1
        return emu.events[-1][0] - commanded


def test_watchdog_stops_the_wheels_at_its_timeout() -> None:
    latency = _watchdog_latency(0.2)
    assert 0.2 <= latency <= 0.2 + 0.004 + 1e-9  # measured on the emulator's (shared) clock


def test_default_watchdog_fires_at_its_timeout() -> None:
    latency = _watchdog_latency(None)
    assert 0.3 <= latency <= 0.3 + 0.004 + 1e-9


def test_watchdog_stays_quiet_while_commands_keep_coming() -> None:
    clock = ManualClock(0.0)
    with MaestroEmulator(clock=clock.now) as emu, Maestro(emu.port, watchdog_timeout=0.2, clock=clock.now) as m:
        for _ in range(8):
            m.set_speeds(0.5, 0.5)
            clock.advance(0.15)  # 1.2 s of device time, never 0.2 s without a command
            assert m.wait_watchdog(2)
        assert m.watchdog_stops == 0
        assert emu.wait_for(lambda e: len(e.events) >= 2, 10.0)
        assert all(target != 6000 for _, ch, target in emu.events if ch in (0, 1))


def test_close_stops_first(emu: MaestroEmulator) -> None:
    m = Maestro(emu.port, watchdog_timeout=None)
    m.set_speeds(1.0, 1.0)
    m.close()
    assert emu.wait_for(lambda e: _wheel_targets(e) == (6000, 6000), 10.0)
    with pytest.raises(MaestroError, match="closed"):
        m.set_speeds(0.1, 0.1)


def test_port_disappearing_is_a_maestro_error(emu: MaestroEmulator) -> None:
    m = Maestro(emu.port, watchdog_timeout=None)
    m.set_speeds(0.2, 0.2)
    emu.vanish()
    with pytest.raises(MaestroPortError, match="unplugged"):
        for _ in range(20):  # the first write after the hangup may still be buffered
            m.set_speeds(0.2, 0.2)
            time.sleep(0.01)
    with pytest.raises(MaestroPortError):
        m.stop()
    m.close()  # closing a vanished device does not raise


def test_watchdog_survives_a_vanished_port() -> None:
    clock = ManualClock(0.0)
    emu = MaestroEmulator().start()
    with Maestro(emu.port, watchdog_timeout=0.05, clock=clock.now) as m:
        m.set_speeds(0.2, 0.2)
        emu.vanish()  # returns once the device is gone
        clock.advance(0.06)  # only now is the watchdog due
        assert m.wait_watchdog(2)
        assert isinstance(m.watchdog_error, MaestroPortError)
        clock.advance(0.06)  # it keeps trying (and failing) rather than dying
        assert m.wait_watchdog(2) and m.watchdog_stops == 0


def test_missing_port_and_silent_port() -> None:
    with pytest.raises(MaestroPortError, match="/dev/does-not-exist"):
        Maestro("/dev/does-not-exist")
    master, slave = os.openpty()
    try:
        with Maestro(os.ttyname(slave), watchdog_timeout=None, reply_timeout=0.2) as m:
            t0 = time.monotonic()
            with pytest.raises(MaestroTimeout, match=r"Get Errors reply within 0\.20 s"):
                m.get_errors()
            waited = time.monotonic() - t0
            # it waits out its own reply timeout (never gives up early), and it ends: the bound
            # is a hang detector, not a latency claim, so a loaded machine cannot fail it
            assert 0.2 <= waited < 10.0
    finally:
        os.close(master)
        os.close(slave)


@pytest.fixture
def python_sigint():
    """Python's own Ctrl-C handler, even when the suite was started with SIGINT ignored
    (a background job of a non-interactive shell)."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


def test_sigint_handler_stops_the_wheels_then_interrupts(emu: MaestroEmulator, python_sigint: None) -> None:
    before = signal.getsignal(signal.SIGINT)
    with Maestro(emu.port, watchdog_timeout=None) as m:
        uninstall = m.install_stop_handlers()
        m.set_speeds(1.0, 1.0)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6400, 5600), 10.0)
        with pytest.raises(KeyboardInterrupt):
            signal.raise_signal(signal.SIGINT)
        assert emu.wait_for(lambda e: _wheel_targets(e) == (6000, 6000), 10.0)
        uninstall()
        assert signal.getsignal(signal.SIGINT) is before
