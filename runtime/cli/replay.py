"""``clomp replay``: re-plan on a recorded sequence — a ``clomp run`` log or a folder of scans."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from planner import PlanningError, ScanError, scan_files
from runtime.cli._progress import progress
from runtime.cli.plan import add_planner_options, configurator_from_args, parse_goal
from runtime.cli import CliError
from runtime.records.runlog import LogError, scans_from_log

__all__ = ["register"]

def register(sub: Any) -> None:
    """Add ``replay`` to the command line."""
    p = sub.add_parser("replay", help="re-plan on a recorded run log or folder of scans", description=__doc__)
    p.add_argument("source", help="a folder of scans (mapNNNN.dat …) or a clomp run log (.jsonl)")
    p.add_argument("--goal", help="goal X,Y in the robot frame for every scan (default: the log's, else 1.0,0.0)")
    p.add_argument("--json", action="store_true", help="one JSON line per scan, then a summary line")
    add_planner_options(p)
    p.set_defaults(func=run)


def _sources(
    path: Path, goal: tuple[float, float] | None
) -> tuple[int, Iterator[tuple[str, Path | np.ndarray, tuple[float, float]]]]:
    if path.is_dir():
        try:
            files = scan_files(path)
        except ScanError as exc:
            raise CliError(str(exc)) from None
        return len(files), ((f.name, f, goal or (1.0, 0.0)) for f in files)
    try:
        records = list(scans_from_log(path))
    except LogError as exc:
        raise CliError(str(exc)) from None
    if not records:
        raise CliError(f"{path}: the log holds no scan records")
    return len(records), ((label, pts, goal or g or (1.0, 0.0)) for label, pts, g in records)


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp replay``."""
    conf = configurator_from_args(args)
    path = Path(args.source)
    if not path.exists():
        raise CliError(f"{path}: no such file or folder")
    goal = parse_goal(args.goal) if args.goal else None
    total, items = _sources(path, goal)
    times: list[float] = []
    plans = reached = failed = 0
    bar = progress(items, total=total, desc="replay", unit="scan")
    for label, scan, g in bar:
        try:
            r = conf.plan(scan, g)
        except (ScanError, PlanningError) as exc:
            failed += 1
            if args.json:
                bar.write(json.dumps({"scan": label, "error": str(exc)}))
            else:
                bar.write(f"{label}: error: {exc}")
            continue
        times.append(r.planning_time_s)
        plans += bool(r.steps) or r.reached_goal
        reached += r.reached_goal
        if args.json:
            rec = {
                "scan": label,
                "reached_goal": r.reached_goal,
                "collision_free": r.collision_free,
                "states": r.states,
                "planning_time_s": r.planning_time_s,
                "plan": [s.task.value for s in r.steps],
            }
            bar.write(json.dumps(rec))
        else:
            bar.write(
                f"{label}: {'goal' if r.reached_goal else 'partial' if r.steps else 'no move'}  "
                f"{r.states:3d} states  {r.planning_time_s * 1e3:7.2f} ms  [{' '.join(s.task.value[0] for s in r.steps)}]"
            )
    t = np.array(times) if times else np.array([np.nan])
    median_s = float(np.median(t)) if times else None
    p90_s = float(np.percentile(t, 90)) if times else None
    summary = {
        "scans": total,
        "plans": plans,
        "reached_goal": reached,
        "errors": failed,
        "median_planning_time_s": median_s,
        "p90_planning_time_s": p90_s,
    }
    if args.json:
        print(json.dumps({"summary": summary}))
    else:
        med = f"{median_s * 1e3:.2f} ms" if median_s is not None else "n/a"
        p90 = f"{p90_s * 1e3:.2f} ms" if p90_s is not None else "n/a"
        print(
            f"summary: {total} scans, {plans} plans found ({reached} reach the goal), {failed} errors; "
            f"planning time median {med}, p90 {p90}"
        )
    return 0 if failed == 0 else 1
