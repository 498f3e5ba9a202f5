"""Compiled inner loops (numba), with the machine code cached between processes.

The scan matcher's Gauss–Newton loop (:mod:`clomp.runtime.estimation._icp_core`) and the plan
check's contact tests (:mod:`clomp.runtime.supervision._contacts_core`) run every revolution;
written with numpy they were dozens of small array calls each, mostly call overhead.
:func:`compiled` compiles such a function once per machine (numba's cache beside the
module, or in the user's cache directory) and, where numba finds no writable place for
its cache, once per process instead of failing to import.

>>> @compiled
... def twice(x: float) -> float:
...     return 2.0 * x
>>> twice(1.5)
3.0
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from numba import njit

__all__ = ["compiled", "interruptible"]


def compiled(fn: Callable[..., Any]) -> Any:
    """``fn`` compiled in nopython mode, its machine code cached for the next process;
    compiled afresh in each process where the cache cannot be written (a read-only install
    without a home directory: numba raises at decoration there).

    The GIL is held (no ``nogil``): these calls take microseconds, and a Ctrl-C arriving
    while a ``nogil`` function ran came back as ``SystemError: … returned a result with an
    exception set`` instead of ``KeyboardInterrupt`` (measured: 157 of 200 interrupts)."""
    try:
        return njit(cache=True)(fn)
    except RuntimeError:  # numba: "cannot cache function …: no locator available"
        return njit()(fn)


def interruptible(fn: Callable[..., Any], *args: Any) -> Any:
    """``fn(*args)`` for a :func:`compiled` ``fn``, where a Ctrl-C always comes back as
    ``KeyboardInterrupt``.

    A compiled call runs a few Python helpers of numba's (``_numba_unpickle``); a Python-level
    SIGINT handler, as long commands install (:mod:`clomp.runtime.cli._signals`), can run inside
    one, and its ``KeyboardInterrupt`` then surfaces as ``SystemError: … returned a result
    with an exception set`` (1 in about 2,000 interrupts of matching; in ``clomp experiment``
    a run recorded HALTED and the experiment ran on). The interrupt is found in the error's
    chain and raised as itself; any other SystemError is raised unchanged.

    >>> interruptible(lambda x: 2.0 * x, 1.5)
    3.0
    """
    try:
        return fn(*args)
    except SystemError as exc:
        seen: set[int] = set()
        cause: BaseException | None = exc
        while cause is not None and id(cause) not in seen:
            if isinstance(cause, KeyboardInterrupt):
                raise cause from None
            seen.add(id(cause))
            cause = cause.__cause__ or cause.__context__
        raise
