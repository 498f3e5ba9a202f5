"""Serial ports for the device drivers and their users: opening one, what its failure raises,
and :class:`SerialDevice`, the port plumbing the three drivers share.

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

from collections.abc import Sequence
from typing import Any, Self

try:
    import termios

    _TERMIOS_ERRORS: tuple[type[BaseException], ...] = (termios.error,)
except ImportError:  # pragma: no cover - Windows
    _TERMIOS_ERRORS = ()

__all__ = ["OPEN_ERRORS", "PORT_ERRORS", "TERMIOS_ERRORS", "SerialDevice", "open_serial"]

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


class SerialDevice:
    """A driver's port: named by a path or URL (opened here, owned, closed by
    :meth:`_close_port`) or given as an open serial-like object (used as it is, left open).

    A driver sets ``_device`` (its name in messages, ``"LiDAR"``) and ``_port_error`` (the
    exception a failing port raises), calls :meth:`_attach` from its constructor and overrides
    ``close()`` (which leaving a ``with`` block calls) when its device must be left safe
    before the port closes; the base's closes an owned port and leaves a given one open.

    >>> class Echo(SerialDevice):
    ...     _device, _port_error = "echo", OSError
    ...     def __init__(self, port: Any) -> None:
    ...         self._attach(port, baudrate=115200, timeout=0.01)
    >>> with Echo("loop://") as dev:
    ...     dev._write(b"hi"), dev._port.read(2), dev.port_name
    (None, b'hi', 'loop://')
    >>> dev._port.is_open  # it opened the port, so leaving the block closed it
    False
    """

    _device = "device"
    _port_error: type[Exception] = OSError
    _port: Any = None
    _spec: str | None = None
    _owns_port = False

    def _attach(self, port: str | Any, *, baudrate: int, timeout: float, needs: Sequence[str] = ("read", "write"),
                read_slice: float | None = None) -> None:
        """Open ``port`` (a path or URL) with read ``timeout``, or take an open serial-like
        object that has ``needs`` (a blocking one given ``read_slice`` as its read timeout, so a
        silent device cannot hang its reader)."""
        if isinstance(port, str):
            self._spec, self._owns_port = port, True
            self._open_port(baudrate, timeout)
            return
        if not all(hasattr(port, m) for m in needs):
            raise TypeError(f"port must be a path, a URL or a serial-like object, got {port!r}")
        self._spec, self._owns_port, self._port = None, False, port
        if read_slice is not None and getattr(port, "timeout", 0) is None:
            port.timeout = read_slice

    def _open_port(self, baudrate: int, timeout: float) -> None:
        """(Re)open the owned port named ``_spec``; its failure raises ``_port_error``."""
        assert self._spec is not None
        try:
            self._port = open_serial(self._spec, baudrate, timeout)
        except OPEN_ERRORS as exc:
            raise self._port_error(f"cannot open {self._device} port {self._spec}: {exc}") from exc

    @property
    def port_name(self) -> str:
        """The path/URL of the port, or the name of the port object."""
        return self._spec or str(getattr(self._port, "port", None) or self._port)

    def _port_failed(self, what: str, exc: BaseException) -> Exception:
        """The error to raise for the port failing while doing ``what``."""
        return self._port_error(f"{self._device} port {self.port_name} failed while {what} (device unplugged?): {exc}")

    def _write(self, data: bytes) -> None:
        """Write ``data`` and flush it; a failing port raises :meth:`_port_failed`."""
        try:
            self._port.write(data)
            flush = getattr(self._port, "flush", None)
            if flush is not None:
                flush()
        except PORT_ERRORS as exc:
            raise self._port_failed("writing", exc) from exc

    def _close_port(self) -> None:
        """Close the port if this driver opened it (a port already gone is no error)."""
        if self._owns_port and self._port is not None:
            try:
                self._port.close()
            except PORT_ERRORS:
                pass

    def close(self) -> None:
        """Release the device: here, close the port if this driver opened it. A driver
        with a device to leave safe first (stop the motor, neutral wheels, the reader
        thread) does that and then calls :meth:`_close_port`."""
        self._close_port()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
