"""What every simulated backend shares: its own clock and the closed state.

A simulated robot owns simulated time: :meth:`~SimulatedBackend.sleep` advances its
physics in steps of at most :attr:`~SimulatedBackend.quantum` seconds, and
:meth:`~SimulatedBackend.read_scan` waits for a revolution the same way. Subclasses
provide the step (``_advance``), the stop and the newest revolution.
"""

from __future__ import annotations

from abc import ABC, abstractmethod

from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.interface import RobotFault

__all__: list[str] = []  # private plumbing of clomp.runtime.backends


class SimulatedBackend(ABC):
    """Base of :class:`~clomp.runtime.backends.sim.SimRobot` and :class:`~clomp.runtime.backends.world.WorldRobot`."""

    _t: float
    _closed: bool
    _delivered: bool
    _latest: ScanFrame | None
    scan_rate: float
    _what = "the simulated robot"

    @property
    @abstractmethod
    def quantum(self) -> float:
        """The longest step of simulated time (s) taken at once."""

    @abstractmethod
    def _advance(self, dt: float) -> None:
        """Move the simulation on by ``dt`` seconds."""

    @abstractmethod
    def stop(self) -> None:
        """Stop the wheels."""

    def _run_until(self, end: float, *, until_scan: bool = False) -> None:
        while self._t < end - 1e-12 and not (until_scan and not self._delivered):
            self._advance(min(self.quantum, end - self._t))

    def read_scan(self, timeout: float | None = None) -> ScanFrame | None:
        """The newest full revolution not returned before; waits (in simulated time) up to
        ``timeout`` seconds for one, one revolution at most when None."""
        self._check_open()
        if self._delivered:
            wait = (1.0 / self.scan_rate) * 1.01 if timeout is None else max(0.0, float(timeout))
            self._run_until(self._t + wait, until_scan=True)
        if self._delivered or self._latest is None:
            return None
        self._delivered = True
        return self._latest

    def close(self) -> None:
        """Stop; further commands raise :class:`~clomp.runtime.interface.RobotFault`."""
        self.stop()
        self._closed = True

    def _check_open(self) -> None:
        if self._closed:
            raise RobotFault(f"{self._what} is closed")

    def now(self) -> float:
        """Simulated time (s) since the start."""
        return self._t

    def sleep(self, seconds: float) -> None:
        """Let ``seconds`` of simulated time pass (the wheels follow the last command)."""
        self._run_until(self._t + max(0.0, float(seconds)))
