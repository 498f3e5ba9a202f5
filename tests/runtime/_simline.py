"""A serial line to a device emulator in simulated time: deadlines measured without wall-clock luck.

The pty emulators serve their devices from a thread in real time, so on a loaded machine a
test of "the wheels stop within 300 ms of a LiDAR fault" measures the scheduler as much as the
software. :class:`SimLine` instead hands the driver a serial-like object whose far end is the
same emulator logic (not started: no pty, no thread), with time a :class:`ManualClock` that
moves only while the reader waits for bytes. Processing costs no simulated time, so what a
latency measured on it shows is the software's own windows and timeouts.
"""

from __future__ import annotations

import threading

from runtime.clock import ManualClock
from runtime.devices._pty import PtyEmulator

__all__ = ["SimLine"]

_STEP = 0.001  # simulated seconds a waiting reader lets pass at a time


class SimLine:
    """The driver's end of a line to ``device``; ``timeout`` as a serial port's read timeout.

    Only a read that finds nothing waiting moves the clock (up to its timeout, in 1 ms steps,
    letting the device emit meanwhile), so time runs only while the reader would block.
    ``running`` (an Event, set by default) pauses such waiting when cleared: a test holds
    time still while it arranges the next step. Lines to several devices on one clock share
    one ``lock`` (the clock moves under it).
    """

    def __init__(self, device: PtyEmulator, clock: ManualClock, *, timeout: float = 0.01, name: str = "sim",
                 lock: threading.RLock | None = None) -> None:
        self.device, self.clock, self.timeout, self.port = device, clock, timeout, name
        self.lock = lock or threading.RLock()
        self.running = threading.Event()
        self.running.set()
        self.dtr = False

    @property
    def in_waiting(self) -> int:
        with self.lock:
            self.device._tick(self.clock.now())
            return len(self.device._out)

    def write(self, data: bytes) -> int:
        with self.lock:
            self.device._on_bytes(bytes(data), self.clock.now())
        return len(data)

    def flush(self) -> None:
        pass

    def reset_input_buffer(self) -> None:
        with self.lock:
            self.device._out.clear()

    def read(self, size: int = 1) -> bytes:
        waited = 0.0
        while True:
            with self.lock:
                out = self.device._out
                if out:
                    data = bytes(out[:size])
                    del out[:size]
                    return data
                if waited >= self.timeout:
                    return b""
            self.running.wait()
            with self.lock:
                self.clock.advance(_STEP)
                waited += _STEP
                self.device._tick(self.clock.now())

    def close(self) -> None:
        pass
