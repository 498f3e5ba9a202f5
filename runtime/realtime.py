"""Scheduling for the real-time parts: the control loop, the device watch, emulated devices.

A closed loop over serial ports lives in wall time: a controller thread that the OS keeps
waiting for a few tenths of a second on a busy computer stops the wheels late after a fault
and drives on what it believed a while ago. So ``clomp run`` asks the OS to favour its
threads (niceness :data:`NICENESS`), and the emulated world (standing for devices and
physics, which a busy computer does not slow down) asks for the real-time class, where
allowed (root or ``CAP_SYS_NICE``; elsewhere nothing changes and the result says so).
Linux schedules threads, not processes: this is the calling thread's scheduling, and
threads it starts afterwards inherit it.

>>> with favoured() as how:
...     how in ("normal", f"nice {NICENESS}")
True
"""

from __future__ import annotations

import os
import sys
import threading
from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["NICENESS", "favour_this_thread", "favoured"]

#: the niceness asked for (lower is more favoured; 0 is the default of every process)
NICENESS = -10


def _tid() -> int:
    return threading.get_native_id() if sys.platform.startswith("linux") else 0  # 0: the process


def _niceness() -> int | None:
    try:
        return os.getpriority(os.PRIO_PROCESS, _tid())
    except (OSError, AttributeError):
        return None


def _realtime() -> bool:
    try:
        return os.sched_getscheduler(0) in (os.SCHED_RR, os.SCHED_FIFO)
    except (OSError, AttributeError):
        return False


def favour_this_thread(niceness: int = NICENESS, *, realtime: bool = False) -> str:
    """Ask for ``niceness`` for the calling thread (and the threads it starts from now on).

    ``realtime`` asks first for the real-time class at its lowest priority (``SCHED_RR`` 1),
    for threads that mostly sleep and must wake on time (an emulated device: under load a
    niced thread still wakes up to ~70 ms late, a real-time one ~20 ms); never for work
    that computes at length, which would keep everything else waiting. Returns how the
    thread is scheduled: ``"realtime"``, ``"nice -10"``, or ``"normal"`` without the right
    (nothing changed then). Never lowers a thread's priority that is already higher.

    >>> favour_this_thread(0).startswith(("nice", "normal", "realtime"))  # 0 or better already: unchanged
    True
    """
    if _realtime():
        return "realtime"
    if realtime:
        try:
            os.sched_setscheduler(0, os.SCHED_RR, os.sched_param(os.sched_get_priority_min(os.SCHED_RR)))
            return "realtime"
        except (OSError, AttributeError):
            pass
    now = _niceness()
    if now is None:
        return "normal"
    if now <= niceness:
        return f"nice {now}"
    try:
        os.setpriority(os.PRIO_PROCESS, _tid(), niceness)
    except OSError:
        return "normal" if now == 0 else f"nice {now}"
    return f"nice {niceness}"


@contextmanager
def favoured(niceness: int = NICENESS) -> Iterator[str]:
    """:func:`favour_this_thread` for the ``with`` block; the thread's niceness is restored after.

    Threads started inside keep the favour until they end (their own business).

    >>> with favoured() as how:
    ...     isinstance(how, str)
    True
    """
    before = _niceness()
    how = favour_this_thread(niceness)  # never the real-time class: the block may compute at length
    try:
        yield how
    finally:
        if before is not None and _niceness() != before:
            try:
                os.setpriority(os.PRIO_PROCESS, _tid(), before)
            except OSError:
                pass
