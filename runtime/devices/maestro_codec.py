"""The Pololu Maestro serial protocol as pure functions: wheel speeds ↔ servo targets ↔ bytes.

A wheel speed in [-1, 1] becomes a pulse of ``1500 µs ± 100 µs × speed × gain``
(1500 µs = stop) on the wheel's channel; the right wheel's sign is inverted by default
because its servo is mounted mirrored. Commands encode in the compact or the Pololu
protocol. No port here: the driver (:mod:`clomp.runtime.devices.maestro`) and the emulator
(:mod:`clomp.runtime.devices.maestro_emulator`) are built on it.

>>> encode_set_target(0, speed_to_target(0.0, WheelConfig(0))).hex(" ")
'84 00 70 2e'
>>> encode_set_target(0, 6000, protocol="pololu").hex(" ")
'aa 0c 04 00 70 2e'
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Literal

__all__ = [
    "WireProtocol",
    "WheelConfig",
    "ErrorFlags",
    "MaestroError",
    "MaestroPortError",
    "MaestroTimeout",
    "MaestroDeviceError",
    "ERROR_BITS",
    "DEFAULT_DEVICE_NUMBER",
    "POLOLU_START",
    "CMD_SET_TARGET",
    "CMD_SET_SPEED",
    "CMD_SET_ACCELERATION",
    "CMD_GET_POSITION",
    "CMD_SET_MULTIPLE_TARGETS",
    "CMD_GET_ERRORS",
    "CMD_GO_HOME",
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
