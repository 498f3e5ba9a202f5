"""A serial line to a device emulator in simulated time: deadlines measured without wall-clock luck.

The pty emulators serve their devices from a thread in real time, so on a loaded machine a
test of "the wheels stop within 300 ms of a LiDAR fault" measures the scheduler as much as the
software. :class:`SimLine` instead hands the driver a serial-like object whose far end is the
same emulator logic (not started: no pty, no thread), with time a :class:`ManualClock` that
moves only while the reader waits for bytes. Processing costs no simulated time, so what a
latency measured on it shows is the software's own windows and timeouts.

:class:`LockstepClock` takes this one step further, for a whole control loop in simulated
time: the controller's ``sleep`` is the only thing that lets time flow (a LiDAR line built
with ``lockstep=True`` advances it only up to the sleeper's wake-up time), so the controller's
own computing (planning, checking) takes no simulated time and nothing depends on how busy the
machine is. That is an idealisation (the real-time cost is what the pty tests measure).
"""

from __future__ import annotations

import errno
import threading
import time
from collections.abc import Callable, Sequence

from clomp.runtime.clock import ManualClock
from clomp.runtime.devices._pty import PtyEmulator

__all__ = ["LockstepClock", "SimLine"]

_STEP = 0.001  # simulated seconds a waiting reader lets pass at a time
_STALL_WALL = 20.0  # wall seconds a write on a stalled line blocks at most


class LockstepClock(ManualClock):
    """Simulated time that flows only while the controller sleeps in it.

    ``sleep(s)`` blocks until a lockstep line (see :class:`SimLine`) has moved the clock to
    its wake-up time and then found nothing more to read, so whatever the device sent up to
    then has been taken in before the controller looks; ``step(dt)`` is what such a line
    calls when it finds nothing waiting: it moves time by at most ``dt`` toward the
    sleeper's wake-up time and returns how far it moved (0: time stands still).
    With several lockstep lines (the LiDAR's and the IMU's readers), the wake-up time is
    reached once every one of them has found nothing more to read there (each line
    registers itself with :meth:`register` and passes its token to ``step``).
    ``release()`` lets time run freely from then on (for shutting down: the reader thread
    must see its timeouts pass once the controller has stopped sleeping).
    ``free_when`` (a callable, e.g. "the robot has tripped", after which its reader thread
    reads no more) releases the clock the same way once it holds. ``max_wall`` bounds a
    hang: a sleep that waits longer than that in wall time raises.
    """

    def __init__(self, start: float = 0.0, *, max_wall: float = 60.0) -> None:
        super().__init__(start)
        self._cond = threading.Condition()
        self._until: float | None = None
        self._reached = False
        self._free = False
        self.max_wall = max_wall
        self.free_when: Callable[[], bool] | None = None
        self._lines = 0  # lockstep lines registered
        self._idle: set[int] = set()  # those idle at the wake-up time

    def register(self) -> int:
        """A token for one more lockstep line (see the class)."""
        with self._cond:
            self._lines += 1
            return self._lines

    @property
    def free(self) -> bool:
        """True once released: time runs freely."""
        return self._free

    def sleep(self, seconds: float) -> None:
        if self._free:
            super().sleep(seconds)
            return
        if not seconds > 0:
            return
        give_up = time.monotonic() + self.max_wall
        with self._cond:
            until = self._t + seconds
            self._until, self._reached = until, False
            self._idle.clear()
            self._cond.notify_all()
            while not self._reached and not self._free:
                if self.free_when is not None and self.free_when():
                    self._free = True
                    break
                left = give_up - time.monotonic()
                if left <= 0:
                    raise RuntimeError(f"simulated time stood still for {self.max_wall} s of wall time "
                                       f"at t = {self._t:.3f} (no lockstep line is reading?)")
                self._cond.wait(min(left, 0.05))
            self._until = None
            if self._free:  # released while sleeping: the rest of the sleep passes at once
                self._t = max(self._t, until)

    def advance(self, seconds: float) -> None:
        """Move time now, whoever sleeps (a line the controller itself waits on)."""
        with self._cond:
            if seconds > 0:
                self._t += seconds
                self._cond.notify_all()

    def step(self, dt: float, line: int = 0) -> float:
        with self._cond:
            if self._free:
                self._t += dt
                return dt
            if self._until is None or self._reached:
                return 0.0
            if self._t >= self._until:
                # the line is idle at the wake-up time: all it had to read up to now is read
                self._idle.add(line)
                if len(self._idle) >= max(1, self._lines):
                    self._reached = True
                    self._cond.notify_all()
                return 0.0
            moved = min(dt, self._until - self._t)
            self._t = self._until if moved < dt else self._t + dt
            return moved

    def wait_for_sleeper(self, wall: float = 0.05) -> None:
        """Block (at most ``wall`` s) until a sleeper lets time flow."""
        with self._cond:
            if not self._free and (self._until is None or self._reached):
                self._cond.wait(wall)

    def release(self) -> None:
        with self._cond:
            self._free = True
            self._cond.notify_all()


class SimLine:
    """The driver's end of a line to ``device``; ``timeout`` as a serial port's read timeout.

    Only a read that finds nothing waiting moves the clock (up to its timeout, in 1 ms steps,
    letting the device emit meanwhile), so time runs only while the reader would block.
    ``running`` (an Event, set by default) pauses such waiting when cleared: a test holds
    time still while it arranges the next step. Lines to several devices on one clock share
    one ``lock`` (the clock moves under it). ``lockstep=True`` (with a :class:`LockstepClock`)
    moves time only while the controller sleeps: the line to the device a background thread
    reads (the LiDAR). A line the controller itself reads (the Maestro's replies) keeps the
    default: its waiting is the controller's own. ``also``: devices ticked with this line's
    (at the same times, in its thread: the world they read is advanced at the same instants
    however the threads interleave, so a run stays the same run); ``follow=True`` (lockstep)
    is the line to such a device: it never moves time nor ticks its device, and counts as
    idle at the wake-up time once it has read all the device sent. Once the device has vanished
    (``device.vanish()``, an unplugged USB device) every call raises ``OSError(EIO)``, as a
    serial port whose device is gone does.
    """

    def __init__(self, device: PtyEmulator, clock: ManualClock, *, timeout: float = 0.01, name: str = "sim",
                 lock: threading.RLock | None = None, lockstep: bool = False,
                 also: Sequence[PtyEmulator] = (), follow: bool = False) -> None:
        if lockstep and not isinstance(clock, LockstepClock):
            raise TypeError("lockstep=True needs a LockstepClock")
        self.device, self.clock, self.timeout, self.port = device, clock, timeout, name
        self.lockstep = lockstep or follow
        self.also, self.follow = tuple(also), follow
        self._token = clock.register() if isinstance(clock, LockstepClock) and self.lockstep else 0
        self.lock = lock or threading.RLock()
        self.running = threading.Event()
        self.running.set()
        self.dtr = False
        self._flowing = threading.Event()  # cleared: the line is stalled (see stall())
        self._flowing.set()
        self.blocked = 0  # writes blocked on the stalled line right now

    def stall(self) -> None:
        """The device stops (its process stopped): it sends nothing more, reads time out, and
        a write blocks (its buffer full) until :meth:`resume` (or ``_STALL_WALL`` s of wall
        time, then ``OSError``: a test without the bound fails instead of hanging)."""
        self._flowing.clear()

    def resume(self) -> None:
        self._flowing.set()

    @property
    def stalled(self) -> bool:
        return not self._flowing.is_set()

    def _tick_device(self, now: float) -> None:
        if self._flowing.is_set():
            self.device._tick(now)

    def _check_present(self) -> None:
        if self.device._vanish.is_set():
            raise OSError(errno.EIO, f"{self.port}: Input/output error (the device has vanished)")

    @property
    def in_waiting(self) -> int:
        self._check_present()
        with self.lock:
            if not self.follow:  # a followed device is ticked by its leading line alone
                self._tick_device(self.clock.now())
            return len(self.device._out)

    def write(self, data: bytes) -> int:
        self._check_present()
        if not self._flowing.is_set():
            with self.lock:
                self.blocked += 1
            try:
                if not self._flowing.wait(_STALL_WALL):
                    raise OSError(errno.EIO, f"{self.port}: the write blocked for {_STALL_WALL} s (stalled device)")
            finally:
                with self.lock:
                    self.blocked -= 1
        with self.lock:
            self.device._on_bytes(bytes(data), self.clock.now())
        return len(data)

    def flush(self) -> None:
        pass

    def reset_input_buffer(self) -> None:
        with self.lock:
            self.device._out.clear()

    def read(self, size: int = 1) -> bytes:
        waited, started = 0.0, self.clock.now()
        while True:
            self._check_present()
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
                if self.follow and self.device._out:  # sent since the look above: read it first
                    moved = -1.0
                elif self.follow:  # another line moves time and ticks the device
                    assert isinstance(self.clock, LockstepClock)
                    if self.clock.now() - started >= self.timeout and not self.clock.free:
                        # its read timed out while the leading line moved time: the reader judges
                        # that time (its silence deadline) before this line may count as idle at the
                        # wake-up time (idle first, a starved reader thread let the controller wake
                        # and act before it tripped: the wheels stopped a tick late, under load only)
                        return b""
                    moved = self.clock.step(_STEP if self.clock.free else 0.0, self._token)
                    if moved:
                        self.device._tick(self.clock.now())
                    waited = self.clock.now() - started
                    if waited < self.timeout and not moved:
                        moved = -1.0  # time may move: look again soon
                elif self.lockstep:
                    assert isinstance(self.clock, LockstepClock)
                    moved = self.clock.step(_STEP, self._token)
                else:
                    self.clock.advance(_STEP)
                    moved = _STEP
                if moved > 0 and not self.follow:
                    waited += moved
                    now = self.clock.now()
                    self._tick_device(now)
                    for other in self.also:
                        other._tick(now)
            if moved < 0:
                time.sleep(0.0002)
                continue
            if not moved:
                assert isinstance(self.clock, LockstepClock)
                self.clock.wait_for_sleeper()

    def close(self) -> None:
        pass
