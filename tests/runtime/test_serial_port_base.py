"""The drivers' shared port plumbing (runtime/devices/port.py): who closes the port."""

from __future__ import annotations

from typing import Any

import serial

from clomp.runtime.devices.port import SerialDevice


class _Plain(SerialDevice):
    """A driver with no device of its own to leave safe: the base's close is its close."""

    _device = "plain"

    def __init__(self, port: Any) -> None:
        self._attach(port, baudrate=115200, timeout=0.01)


def test_the_base_closes_a_port_it_opened_and_leaves_a_given_one_open() -> None:
    with _Plain("loop://") as owned:
        owned._write(b"x")
    assert not owned._port.is_open  # opened from a URL: owned, closed on leaving the block

    given = serial.serial_for_url("loop://", timeout=0.01)
    with _Plain(given) as dev:
        dev._write(b"y")
    assert given.is_open and given.read(1) == b"y"  # the caller's port: used, left open
    given.close()
