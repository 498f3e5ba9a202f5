"""What a model checker prints: kept off the user's terminal, attributed when it matters.

Storm (through stormpy) logs from C++ straight to the process's file descriptors 1 and 2
(``ERROR (SparsePropositionalModelChecker.cpp:46): …``), under Python's ``sys.stdout``.
:func:`captured_fds` points both descriptors at a temporary file while a stormpy call
runs and hands back what was written, so a command's standard output holds only its
own lines; the caller decides whether (and under which tool's name) to show the log.

>>> import os
>>> with captured_fds() as log:
...     _ = os.write(1, b"ERROR (Model.cpp:1): from C++\\n")
>>> log.text
'ERROR (Model.cpp:1): from C++\\n'
"""

from __future__ import annotations

import ctypes
import os
import sys
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

__all__ = ["CapturedLog", "captured_fds"]


@dataclass
class CapturedLog:
    """The text a tool wrote to file descriptors 1 and 2 (filled when the block ends)."""

    text: str = ""

    def lines(self, tool: str) -> list[str]:
        """Each non-empty line prefixed with the tool's name: ``Storm: ERROR (…)``."""
        return [f"{tool}: {line.strip()}" for line in self.text.splitlines() if line.strip()]


def _flush_c_stdio() -> None:
    """Flush C's stdio buffers (C++ streams that share them), so nothing written inside
    the block comes out after it."""
    try:
        ctypes.CDLL(None).fflush(None)
    except (OSError, AttributeError):  # no libc to ask (not on the platforms clomp runs on)
        pass


@contextmanager
def captured_fds() -> Iterator[CapturedLog]:
    """Redirect the process's file descriptors 1 and 2 to a temporary file for the block;
    yields a :class:`CapturedLog` whose ``text`` is set when the block ends (also when it
    raises). Python's own ``sys.stdout``/``sys.stderr`` are flushed first."""
    log = CapturedLog()
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (AttributeError, ValueError):
            pass
    saved = [os.dup(1), os.dup(2)]
    with tempfile.TemporaryFile() as sink:
        try:
            os.dup2(sink.fileno(), 1)
            os.dup2(sink.fileno(), 2)
            yield log
        finally:
            _flush_c_stdio()
            os.dup2(saved[0], 1)
            os.dup2(saved[1], 2)
            for fd in saved:
                os.close(fd)
            sink.seek(0)
            log.text = sink.read().decode("utf-8", errors="replace")
