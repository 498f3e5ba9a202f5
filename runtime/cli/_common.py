"""Helpers shared by the subcommands: the scene ``--scenario`` names (:func:`load_scene`), a
log's records (:func:`log_records`), the per-scan outcome of ``clomp plan`` (folders, bags)
and ``clomp replay``, and the summary of such a run.

:func:`scan_outcomes` plans on one scan and never raises for the scan's own faults, so a
many-scan run never stops at one scan; :func:`many_summary` counts the outcomes. The
commands differ only in the lines they print.

>>> import numpy as np
>>> from clomp.planner import Configurator
>>> conf = Configurator()
>>> [scan_outcomes(conf, s, g)[1]["outcome"] for s, g in
...  [(np.zeros((0, 2)), (1.0, 0.0)), (np.zeros((0, 2)), (0.0, 0.0)), (np.full((1, 2), np.nan), (1.0, 0.0))]]
['goal', 'at_goal', 'error']
>>> many_summary(["goal", "error"], [0.01])["error"]
1
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Iterable
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from clomp.planner import Configurator, PlanningError, PlanResult, ScanError
from clomp.planner.scenarios import Scene, ScenarioError, load_scenario
from clomp.runtime.cli import CliError, plural
from clomp.runtime.records.runlog import LogError

__all__ = ["load_scene", "log_records", "many_summary", "scan_outcomes", "summary_line"]

T = TypeVar("T")


def load_scene(scenario: str) -> Scene:
    """The scene ``--scenario NAME|FILE`` names (a built-in scenario or a scenario JSON file),
    for every command that takes one; a scenario that cannot be loaded is one CliError line.

    >>> load_scene("open").name
    'open'
    >>> load_scene("atlantis")
    Traceback (most recent call last):
    clomp.runtime.cli.CliError: unknown scenario 'atlantis'; built in: ...
    """
    try:
        return load_scenario(scenario)
    except ScenarioError as exc:
        raise CliError(str(exc)) from None


def log_records(read: Callable[[Path], Iterable[T]], path: Path, what: str) -> list[T]:
    """Every record ``read`` finds in the run log at ``path``; a log that cannot be read,
    or holds none (``what`` names them), is one CliError line."""
    try:
        records = list(read(path))
    except LogError as exc:
        raise CliError(str(exc)) from None
    if not records:
        raise CliError(f"{path}: the log holds no {what}")
    return records


def scan_outcomes(conf: Configurator, scan: Any, goal: tuple[float, float]) -> tuple[PlanResult | None, dict[str, Any]]:
    """Plan on one scan of a many-scan run; never raises for the scan's own faults.

    Returns (result or None, record): the record has ``outcome`` — ``goal``, ``partial``,
    ``no_move``, ``at_goal`` (the goal lies within the goal tolerance of the robot: being
    there is an outcome, not an error) or ``error`` (with ``error``: why the scan cannot
    be planned) — and ``warnings`` (e.g. points beyond the sensor range) when any.
    """
    rec: dict[str, Any] = {}
    if math.hypot(goal[0], goal[1]) <= conf.robot.goal_tolerance:
        rec.update(outcome="at_goal", reached_goal=True, plan=[])
        return None, rec
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            scan = scan() if callable(scan) else scan
            r = conf.plan(scan, goal)
        except (ScanError, PlanningError) as exc:
            r = None
            rec.update(outcome="error", error=str(exc))
    if caught:
        rec["warnings"] = [str(w.message) for w in caught]
    if r is not None:
        rec["outcome"] = "goal" if r.reached_goal else "partial" if r.steps else "no_move"
    return r, rec


def many_summary(outcomes: list[str], times: list[float]) -> dict[str, Any]:
    """The summary of a many-scan run: counts per outcome and planning-time figures."""
    t = sorted(times)
    return {
        "scans": len(outcomes),
        **{k: outcomes.count(k) for k in ("goal", "partial", "no_move", "at_goal", "error")},
        "median_planning_time_s": float(np.median(t)) if t else None,
        "p90_planning_time_s": float(np.percentile(t, 90)) if t else None,
    }


def summary_line(s: dict[str, Any]) -> str:
    """The readable summary line of a many-scan run."""
    med = f"{s['median_planning_time_s'] * 1e3:.2f} ms" if s["median_planning_time_s"] is not None else "n/a"
    p90 = f"{s['p90_planning_time_s'] * 1e3:.2f} ms" if s["p90_planning_time_s"] is not None else "n/a"
    return (
        f"summary: {plural(s['scans'], 'scan')}: {s['goal']} reach the goal, {s['partial']} partial, "
        f"{s['no_move']} no move, {s['at_goal']} already at the goal, {plural(s['error'], 'error')}; "
        f"planning time median {med}, p90 {p90}"
    )
