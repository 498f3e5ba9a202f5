"""Ctrl-C and SIGTERM for long-running commands, whatever the parent shell did with them.

A shell that starts a command in the background (``cmd &`` without job control) sets
SIGINT to *ignored*, and Python then never installs its own handler: a command relying
on ``KeyboardInterrupt`` would not stop on Ctrl-C. :func:`interrupts_raise` installs a
handler for both signals for the duration of a block, so they always raise
``KeyboardInterrupt("interrupted by SIGINT")`` (once: later ones are ignored while
the command stops), and restores the previous handlers after it.

>>> with interrupts_raise() as signalled:
...     signalled() is None
True
"""

from __future__ import annotations

import signal
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from typing import Any

__all__ = ["interrupts_raise"]


@contextmanager
def interrupts_raise() -> Iterator[Callable[[], str | None]]:
    """SIGINT/SIGTERM raise KeyboardInterrupt once inside the block; yields a function
    returning the name of the signal received (None before one arrived)."""
    got: list[str] = []

    def handler(signum: int, frame: Any) -> None:
        if got:
            return
        got.append(signal.Signals(signum).name)
        # the reason travels with the exception: whoever catches it first can log it
        raise KeyboardInterrupt(f"interrupted by {got[0]}")

    signals = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.getsignal(s) for s in signals}
    installed = threading.current_thread() is threading.main_thread()
    if installed:
        for s in signals:
            signal.signal(s, handler)
    try:
        yield lambda: got[0] if got else None
    finally:
        if installed:
            for s, h in previous.items():
                signal.signal(s, h)
