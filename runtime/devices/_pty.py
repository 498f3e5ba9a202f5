"""The common part of the device emulators: a pty whose master side a background thread serves.

Each emulator owns the master side of a pseudo-terminal and runs in a background thread;
its ``.port`` is the slave's path, which the real drivers open like a USB serial device.
Subclasses implement the device (:mod:`clomp.runtime.devices.rplidar_emulator`,
:mod:`clomp.runtime.devices.maestro_emulator`).
"""

from __future__ import annotations

import abc
import fcntl
import os
import select
import struct
import termios
import threading
import time
import tty
from collections.abc import Callable
from typing import Self


__all__ = ["PtyEmulator"]


class PtyEmulator(abc.ABC):
    """A pty whose master side is served by a background thread.

    ``stale_after`` (seconds of the device's time, None: never): bytes on the line that no
    one has read for that long are lost, the line emptied before the next write, as a USB
    serial adapter loses what its device sends while no program has the port open. Without
    it a pty keeps what a device streaming unasked (the IMU) sent from the emulator's start
    until the driver opens the port, kilobytes a minute old: the driver then read a
    heading that had drifted while it was not listening as a turn (issue #36, a run
    started 130 s after ``clomp emulate world`` halted on "disagrees wildly").
    """

    _name = "emulator"
    stale_after: float | None = None

    def _set_faults(self, faults: dict[str, float | bool], known: tuple[str, ...] | dict[str, object],
                    probabilities: tuple[str, ...]) -> float:
        """Set ``faults`` (attribute: value) under the lock, after refusing unknown names and
        probabilities outside [0, 1]; the device's time of it (what a fault is timed from).
        The one body of the emulators' ``inject``."""
        unknown = set(faults) - set(known)
        if unknown:
            raise ValueError(f"unknown fault(s) {', '.join(sorted(unknown))}; known: {', '.join(known)}")
        for name in probabilities:
            if name in faults and not 0 <= float(faults[name]) <= 1:
                raise ValueError(f"{name} is a probability in [0, 1], got {faults[name]!r}")
        with self._lock:
            for name, value in faults.items():
                setattr(self, name, value)
            return self.clock()

    def __init__(self, clock: Callable[[], float] | None = None) -> None:
        #: the device's own time (seconds); a test may pass a manual clock's ``now``
        self.clock: Callable[[], float] = clock or time.monotonic
        #: passes of the serving loop so far (a test can wait for the device to have looked)
        self.passes = 0
        self.port: str = ""
        self.error: BaseException | None = None
        self._master = -1
        self._slave = -1
        self._out = bytearray()
        self._stop = threading.Event()
        self._vanish = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.RLock()
        self._served = threading.Condition()  # notified after every pass of the serving loop
        #: bytes lost because no one read them for ``stale_after`` s (on the line or still to be sent)
        self.stale_dropped = 0
        self._unread = 0  # bytes the slave side held unread after the last write
        self._read_at: float | None = None  # the device's time the reader was last seen taking bytes

    # -- lifetime

    def start(self) -> Self:
        """Open the pty and start serving; returns self."""
        if self._thread is not None:
            raise RuntimeError(f"{self._name} already started")
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo or line editing before the driver opens it
        os.set_blocking(self._master, False)
        self.port = os.ttyname(self._slave)
        self._thread = threading.Thread(target=self._run, name=self._name, daemon=True)
        self._thread.start()
        return self

    def stop(self) -> None:
        """Stop serving and close the pty (idempotent)."""
        self._stop.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._close_fds()

    def vanish(self) -> None:
        """Fault: close the pty now, as if the USB device was unplugged."""
        self._vanish.set()
        if self._thread is not None and self._thread is not threading.current_thread():
            self._thread.join(timeout=2.0)
        self._close_fds()

    def wait_for(self, predicate: Callable[[Self], bool], timeout: float) -> bool:
        """Wait until ``predicate(self)`` holds, re-checked after each pass of the serving loop.

        For tests and tools that must see what the device received or did
        (``emu.wait_for(lambda e: Command.STOP in e.requests, 5.0)``) rather than assume
        the serving thread has already run. False after ``timeout`` seconds or once the
        emulator stopped with the predicate still false.
        """
        deadline = time.monotonic() + timeout
        with self._served:
            while not predicate(self):
                left = deadline - time.monotonic()
                if left <= 0 or not self.running:
                    return predicate(self)
                self._served.wait(min(left, 0.1))
        return True

    @property
    def running(self) -> bool:
        """True while the background thread serves the pty."""
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self) -> Self:
        if self._thread is None:
            self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def _close_fds(self) -> None:
        with self._lock:
            for fd in (self._master, self._slave):
                if fd >= 0:
                    try:
                        os.close(fd)
                    except OSError:
                        pass
            self._master = self._slave = -1

    # -- the serving loop

    def _run(self) -> None:
        try:
            while not self._stop.is_set():
                if self._vanish.is_set():
                    self._close_fds()
                    return
                now = self.clock()
                timeout = max(0.0, min(0.05, self._next_wakeup(now) - now))
                wfds = [self._master] if self._out else []
                readable, writable, _ = select.select([self._master], wfds, [], timeout)
                if readable:
                    try:
                        data = os.read(self._master, 4096)
                    except BlockingIOError:
                        data = b""
                    if data:
                        self._on_bytes(data, self.clock())
                self._tick(self.clock())
                self._flush()
                with self._served:
                    self.passes += 1
                    self._served.notify_all()
        except Exception as exc:  # keep the failure for the test instead of a thread traceback
            self.error = exc
            self._close_fds()
        finally:
            with self._served:
                self._served.notify_all()

    def _send(self, data: bytes) -> None:
        self._out += data

    def _flush(self) -> None:
        if self.stale_after is not None:
            self._drop_stale(self.clock())
        if not self._out or self._master < 0:
            return
        try:
            n = os.write(self._master, self._out)
        except BlockingIOError:
            return
        finally:
            if self.stale_after is not None:
                self._unread = self._line_unread()
        del self._out[:n]

    def _line_unread(self) -> int:
        """Bytes on the line the reader has not taken (the slave side's input queue)."""
        if self._slave < 0:
            return 0
        try:
            return int(struct.unpack("i", fcntl.ioctl(self._slave, termios.FIONREAD, b"\0\0\0\0"))[0])
        except OSError:
            return 0

    def _drop_stale(self, now: float) -> None:
        """Empty the line (and what waits to be sent) once its bytes went unread ``stale_after`` s:
        the reader took nothing since (the queue did not shrink) while it held some."""
        unread = self._line_unread()
        if self._read_at is None or unread == 0 or unread < self._unread:
            self._read_at = now  # a reader took bytes (or there were none to take)
        elif self.stale_after is not None and now - self._read_at >= self.stale_after:
            termios.tcflush(self._slave, termios.TCIFLUSH)  # the kernel's buffers of the line
            self.stale_dropped += unread + len(self._out)
            self._out.clear()
            self._read_at, unread = now, 0
        self._unread = unread

    def _next_wakeup(self, now: float) -> float:
        return now + 0.05

    @abc.abstractmethod
    def _on_bytes(self, data: bytes, now: float) -> None:
        """Handle bytes the driver wrote (each device decodes its own protocol)."""

    def _tick(self, now: float) -> None:  # noqa: B027 - optional hook, a no-op by default
        """Called by the serving thread whenever it wakes; devices that emit on their own override it."""
