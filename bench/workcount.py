"""Measures of executed work that a machine's speed cannot move, and a calibration of the machine.

Thread CPU time on a shared 2-vCPU virtual machine varies by 1.5x from run to run (a busy
sibling, the host's frequency, cache contention all inflate it). Counting what was executed
separates "the code did more" from "the host was slower":

- :func:`count_python` counts, for one call, the Python bytecode instructions executed
  (``sys.settrace`` with opcode events), the Python function calls and the C function calls
  (``sys.setprofile``). Deterministic for deterministic code; blind to work inside C (numpy).
- :func:`callgrind_counts` runs a script under valgrind's callgrind and returns the machine
  instructions (Ir) executed inside each call made through :func:`marked` (numpy included).
  Deterministic up to a few hundred instructions (allocation addresses).
- :func:`calibration` is the thread CPU time of a fixed pure-Python workload, run inside a
  function (locals, not module globals: the same code every time), so that a time measured on
  one host can be set beside one from another host (time / calibration).

>>> b, py, c = count_python(lambda: sum([1, 2, 3]))
>>> py >= 1 and c >= 1 and b > 0
True
"""

from __future__ import annotations

import itertools
import math
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Sequence
from pathlib import Path
from types import FrameType
from typing import Any

import numpy as np

__all__ = [
    "count_python", "marked", "callgrind_available", "callgrind_counts", "reference_workload", "reference_numpy", "calibration", "p90",
]

# collection is switched on exactly while this C function runs: the planner never calls it
MARKER = "starmap_next"


def count_python(fn: Callable[[], Any]) -> tuple[int, int, int]:
    """(bytecode instructions, Python calls, C calls) executed by ``fn()``.

    A generator's resumption counts as a call (as the interpreter enters its frame again).
    """
    counts = [0, 0, 0]

    def opcodes(frame: FrameType, event: str, arg: Any) -> Any:
        if event == "opcode":
            counts[0] += 1
        return opcodes

    def on_call(frame: FrameType, event: str, arg: Any) -> Any:
        frame.f_trace_lines = False
        frame.f_trace_opcodes = True
        return opcodes

    def profile(frame: FrameType, event: str, arg: Any) -> None:
        if event == "call":
            counts[1] += 1
        elif event == "c_call":
            counts[2] += 1

    old_trace, old_profile = sys.gettrace(), sys.getprofile()
    sys.setprofile(profile)
    sys.settrace(on_call)
    try:
        fn()
    finally:
        sys.settrace(old_trace)
        sys.setprofile(old_profile)
    # the two C calls that switch the hooks off are counted too
    return counts[0], counts[1], max(counts[2] - 1, 0)


def marked(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` called through :data:`MARKER`, so that callgrind counts exactly this call."""
    return next(itertools.starmap(fn, [args]))


def callgrind_available() -> bool:
    """True when ``valgrind`` is on PATH (Debian: ``apt-get install valgrind``)."""
    return shutil.which("valgrind") is not None


_TOTALS = re.compile(r"^(?:totals|summary):\s*(\d+)", re.M)


def callgrind_counts(argv: Sequence[str], timeout: float = 3600.0) -> list[int]:
    """Run ``python argv...`` under callgrind; the instructions executed in each
    :func:`marked` call, in call order (one dump per call).

    The child runs with ``PYTHONHASHSEED=0`` so that string hashing, and with it dict and set
    work, is the same in every run.
    """
    if not callgrind_available():
        raise RuntimeError("valgrind is not installed (apt-get install valgrind)")
    with tempfile.TemporaryDirectory(prefix="clomp-cg-") as tmp:
        out = Path(tmp) / "cg.out"
        cmd = [
            "valgrind",
            "--tool=callgrind",
            "--collect-atstart=no",
            f"--toggle-collect={MARKER}",
            f"--dump-after={MARKER}",
            f"--callgrind-out-file={out}",
            sys.executable,
            *argv,
        ]
        env = dict(os.environ, PYTHONHASHSEED="0")
        proc = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=timeout)
        if proc.returncode != 0:
            raise RuntimeError(f"callgrind run failed ({proc.returncode}): {proc.stderr[-2000:]}")
        dumps = sorted(Path(tmp).glob("cg.out.*"), key=lambda p: int(p.name.rsplit(".", 1)[1]))
        counts = []
        for p in dumps:
            m = _TOTALS.search(p.read_text(errors="replace"))
            counts.append(int(m.group(1)) if m else 0)
        return counts


def reference_workload(n: int = 20_000) -> float:
    """A fixed pure-Python workload (float arithmetic, math calls, tuples, a dict, calls):
    the kind of work the planner's Python does. The same code and data every time.

    >>> round(reference_workload(10), 6) == round(reference_workload(10), 6)
    True
    """
    seen: dict[tuple[int, int], float] = {}
    acc = 0.0
    x, y, th = 0.0, 0.0, 0.0
    for i in range(n):
        th = math.fmod(th + 0.37, 2 * math.pi)
        c, s = math.cos(th), math.sin(th)
        x, y = 0.5 * x + 0.1 * c, 0.5 * y + 0.1 * s
        key = (round(x * 1e3), round(y * 1e3))
        acc += seen.get(key, 0.0) + math.hypot(x, y)
        seen[key] = acc * 1e-9
        if i % 7 == 0:
            acc = _fold(acc, c, s)
    return acc


def _fold(a: float, c: float, s: float) -> float:
    return a * 0.5 + max(c, s) - min(c, s)


def reference_numpy(n: int = 1_500) -> float:
    """A fixed workload of numpy calls on small arrays (a few hundred elements: the
    planner's sizes), where call overhead, allocation and cache traffic weigh as in a plan.

    >>> round(reference_numpy(3), 6) == round(reference_numpy(3), 6)
    True
    """
    base = np.linspace(-1.0, 1.0, 300)
    z = base + 1j * base[::-1]
    acc = 0.0
    for i in range(n):
        w = z * complex(math.cos(i * 0.01), -math.sin(i * 0.01))
        u, v = w.real, np.abs(w.imag)
        gap = np.where((v <= 0.1) & (u > 0.2), u - 0.2, np.inf)
        k = int(gap.argmin())
        idx = (u * u + v * v <= 0.5).nonzero()[0]
        acc += float(gap[k]) if math.isfinite(gap[k]) else 0.0
        acc += float(np.minimum.reduceat(u, [0, 100, 200]).sum()) + len(idx) * 1e-6
    return acc


def calibration(runs: int = 15, workload: Callable[[], float] | None = None) -> tuple[float, float]:
    """(median, min) thread CPU seconds of :func:`reference_workload` (or ``workload``), over ``runs`` runs.

    On the machine where these figures were first taken (2-vCPU KVM, AMD EPYC, Python 3.11.7)
    the minimum was 9.8-10.9 ms at load 7 and the median 10.1-20.3 ms, up to 22 ms at load 12:
    the minimum is the steadier figure.
    """
    work = reference_workload if workload is None else workload
    work()
    times = []
    for _ in range(runs):
        c0 = time.thread_time()
        work()
        times.append(time.thread_time() - c0)
    return statistics.median(times), min(times)


def p90(values: Sequence[float]) -> float:
    """The 90th percentile (linear interpolation, as ``numpy.percentile``)."""
    v = sorted(values)
    if not v:
        return math.nan
    k = (len(v) - 1) * 0.9
    lo = math.floor(k)
    hi = min(lo + 1, len(v) - 1)
    return v[lo] + (v[hi] - v[lo]) * (k - lo)
