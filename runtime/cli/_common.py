"""Helpers shared by the subcommands: the per-scan loop of ``clomp plan`` (folders, bags) and ``clomp replay``.

:func:`plan_scans` plans on every scan of a stream under one progress bar, writes one
line per scan above the bar (each command formats its own lines) and counts what
happened, so that the commands differ only in what they print.

>>> import numpy as np
>>> from planner import Configurator
>>> conf = Configurator()
>>> items = [("a", np.zeros((0, 2)), (1.0, 0.0)), ("b", np.zeros((0, 2)), (0.0, 0.0))]
>>> run = plan_scans(items, 2, "demo", conf.plan, lambda name, r, g: f"{name}: {r.reached_goal}",
...                  catch=(ValueError,), emit_error=lambda name, exc: f"{name}: error")
a: True
b: error
>>> run.seen, run.reached, run.failed, len(run.times)
(2, 1, 1, 1)
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from dataclasses import dataclass, field
from typing import Any, TypeVar

from planner import PlanResult
from runtime.cli._progress import progress

__all__ = ["ScanRun", "plan_scans"]

T = TypeVar("T")


@dataclass
class ScanRun:
    """What a per-scan loop counted: scans seen, plans found, goals reached, errors, planning times.

    >>> ScanRun().seen
    0
    """

    seen: int = 0
    plans: int = 0
    reached: int = 0
    failed: int = 0
    times: list[float] = field(default_factory=list)


def plan_scans(
    items: Iterable[tuple[str, Any, T]],
    total: int | None,
    desc: str,
    plan: Callable[[Any, T], PlanResult],
    emit: Callable[[str, PlanResult, T], str],
    *,
    catch: tuple[type[BaseException], ...] = (),
    emit_error: Callable[[str, BaseException], str] | None = None,
) -> ScanRun:
    """Plan ``plan(scan, extra)`` for every ``(name, scan, extra)`` of ``items`` under a progress bar.

    Each result's line ``emit(name, result, extra)`` is written above the bar. An
    exception of a type in ``catch`` counts as an error, writes ``emit_error(name, exc)``
    and the loop goes on; any other exception ends the loop.
    """
    run = ScanRun()
    bar = progress(items, total=total, desc=desc, unit="scan")
    for name, scan, extra in bar:
        run.seen += 1
        try:
            r = plan(scan, extra)
        except catch as exc:
            run.failed += 1
            if emit_error is not None:
                bar.write(emit_error(name, exc))
            continue
        run.times.append(r.planning_time_s)
        run.plans += bool(r.steps) or r.reached_goal
        run.reached += r.reached_goal
        bar.write(emit(name, r, extra))
    return run
