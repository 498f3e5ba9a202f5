"""``clomp`` as a user runs it, in processes of their own over pseudo-terminals, for tests.

The command line of ``clomp ARGS`` (:func:`clomp`), the first lines a process prints
(:func:`read_lines`) and the end of a ``clomp emulate world`` process (:func:`stop_world`: Ctrl-C,
then its summary). Every wait is for an event (a line, an exit), bounded only by :data:`HANG`
against a hang, never a window a busy machine could miss.
"""

from __future__ import annotations

import queue
import signal
import subprocess
import sys
import threading
from pathlib import Path

import pytest

import clomp.runtime.cli as cli

__all__ = ["HANG", "RUN_MODULE", "clomp", "read_lines", "stop_world"]

HANG = 300.0  # wall seconds after which a wait for an event is a hang, not a slow machine
RUN_MODULE = "clomp.runtime.cli.run"
_UNREGISTERED = f"import clomp.runtime.cli as c; c._COMMAND_MODULES.append({RUN_MODULE!r}); raise SystemExit(c.main())"


def clomp(*args: str) -> list[str]:
    """The command line of ``clomp ARGS``: the console script once ``run`` is registered."""
    if RUN_MODULE not in cli._COMMAND_MODULES:
        return [sys.executable, "-c", _UNREGISTERED, *args]
    script = Path(sys.executable).with_name("clomp")
    return [str(script), *args] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli", *args]


def read_lines(proc: subprocess.Popen[str], n: int) -> list[str]:
    """The first ``n`` lines ``proc`` prints (stripped), waited for as they come; fails when it
    ends first or prints fewer in :data:`HANG` s (a hang: a bare readline would wait forever)."""
    got: queue.Queue[str] = queue.Queue()
    out = proc.stdout
    assert out is not None

    def read() -> None:
        for _ in range(n):
            got.put(out.readline())

    threading.Thread(target=read, daemon=True).start()
    lines: list[str] = []
    for _ in range(n):
        try:
            line = got.get(timeout=HANG)
        except queue.Empty:
            pytest.fail(f"printed {lines} and no more in {HANG:g} s")
        if not line:
            pytest.fail(f"ended after printing {lines}")
        lines.append(line.strip())
    return lines


def stop_world(world: subprocess.Popen[str]) -> tuple[str, str]:
    """Stop a ``clomp emulate world`` process as a user does (Ctrl-C) and wait for its end: its
    stdout (the summary comes last) and stderr. Killed only if it hangs (:data:`HANG`).

    >>> w = subprocess.Popen([sys.executable, "-c", "print('robot at (0, 0)')"], stdout=subprocess.PIPE,
    ...                      stderr=subprocess.PIPE, text=True)
    >>> _ = w.wait()  # already ended here (a signal before its print would end it earlier)
    >>> stop_world(w)[0]
    'robot at (0, 0)\\n'
    """
    world.send_signal(signal.SIGINT)
    try:
        return world.communicate(timeout=HANG)
    except subprocess.TimeoutExpired:
        world.kill()
        return world.communicate()
