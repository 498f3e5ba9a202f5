"""A serial-like port that counts the bytes read through it (the hardware robot's stream watch needs it)."""

from __future__ import annotations

from typing import Any

__all__ = ["CountingPort"]


class CountingPort:
    """A serial-like port that counts the bytes read through it (the stream watch needs it)."""

    def __init__(self, port: Any) -> None:
        self._port = port
        self.bytes_read = 0

    def read(self, size: int = 1) -> bytes:
        data: bytes = self._port.read(size)
        self.bytes_read += len(data)
        return data

    @property
    def dtr(self) -> Any:
        return self._port.dtr

    @dtr.setter
    def dtr(self, value: bool) -> None:
        self._port.dtr = value

    def __getattr__(self, name: str) -> Any:
        return getattr(self._port, name)
