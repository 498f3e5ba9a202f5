"""Serial ports for the device drivers and their users: opening one, and what its failure raises.

A port is named by a device path (``/dev/ttyUSB0``), a pyserial URL (``loop://``,
``socket://…``, ``spy://…``) or a pseudo-terminal's path; :func:`open_serial` opens any
of them. :data:`PORT_ERRORS` are the exceptions a port can raise when the device is
unplugged or the pty's other side closes (``termios.error`` is not an ``OSError``).
The robot backends catch the same errors, so this module is public.

>>> port = open_serial("loop://", 115200, 0.01)
>>> port.write(b"A5"), port.read(2)
(2, b'A5')
>>> port.close()
"""

from __future__ import annotations

from typing import Any

try:
    import termios

    _TERMIOS_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # pragma: no cover - Windows
    _TERMIOS_ERRORS = ()

__all__ = ["OPEN_ERRORS", "PORT_ERRORS", "TERMIOS_ERRORS", "open_serial"]

#: errors a port raises when its device goes away (serial.SerialException is an OSError)
PORT_ERRORS: tuple[type[BaseException], ...] = (OSError, *_TERMIOS_ERRORS)
#: the same, plus the ValueError pyserial raises for a malformed port name or setting
OPEN_ERRORS: tuple[type[BaseException], ...] = (ValueError, *PORT_ERRORS)
TERMIOS_ERRORS = _TERMIOS_ERRORS


def open_serial(spec: str, baudrate: int, timeout: float) -> Any:
    """Open ``spec`` (path or pyserial URL) at ``baudrate`` with a read ``timeout``.

    Raises ``ValueError`` or one of :data:`PORT_ERRORS`; callers turn those into their
    own device error naming the port.
    """
    import serial

    return serial.serial_for_url(spec, baudrate=baudrate, timeout=timeout)
