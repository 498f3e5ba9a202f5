"""Scheduling for the real-time parts: the control loop, the device watch, emulated devices.

A closed loop over serial ports lives in wall time: a controller thread that the OS keeps
waiting for a few tenths of a second on a busy computer stops the wheels late after a fault
and drives on what it believed a while ago. So ``clomp run`` asks the OS to favour its
threads, and the emulated world (standing for devices and physics, which a busy computer
does not slow down) asks the same for its process: niceness :data:`NICENESS` where allowed
(root or ``CAP_SYS_NICE``; elsewhere nothing changes and the result says so). Linux
schedules threads, not processes: the niceness is the calling thread's, and threads it
starts afterwards inherit it.

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


def favour_this_thread(niceness: int = NICENESS) -> str:
    """Ask for ``niceness`` for the calling thread (and the threads it starts from now on).

    Returns how the thread is scheduled: ``"nice -10"``, or ``"normal"`` without the right
    (nothing changed then). Never lowers a thread's priority that is already higher.

    >>> favour_this_thread(0).startswith(("nice", "normal"))  # 0 or better already: unchanged
    True
    """
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
    how = favour_this_thread(niceness)
    try:
        yield how
    finally:
        if before is not None and _niceness() != before:
            try:
                os.setpriority(os.PRIO_PROCESS, _tid(), before)
            except OSError:
                pass
