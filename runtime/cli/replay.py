"""``clomp replay``: re-plan on a recorded sequence — a ``clomp run`` log, a folder of
scans, or the LaserScan topic of a ROS bag (``clomp replay BAG --topic /scan``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from planner import Configurator, PlanningError, PlanResult, ScanError, scan_files
from runtime.cli._bags import add_bag_options, is_bag, labelled_scans, lidar_offset, open_topic
from runtime.cli._common import plan_scans
from runtime.cli.plan import add_planner_options, configurator_from_args, parse_goal
from runtime.cli import CliError
from runtime.records.bags import BagError, LaserScan
from runtime.records.runlog import LogError, scans_from_log

__all__ = ["register"]

def register(sub: Any) -> None:
    """Add ``replay`` to the command line."""
    p = sub.add_parser("replay", help="re-plan on a recorded run log or folder of scans", description=__doc__)
    p.add_argument("source", help="a folder of scans (mapNNNN.dat …), a clomp run log (.jsonl), or a ROS bag (with --topic)")
    p.add_argument("--goal", help="goal X,Y in the robot frame for every scan (default: the log's, else 1.0,0.0)")
    p.add_argument("--json", action="store_true", help="one JSON line per scan, then a summary line")
    add_bag_options(p)
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
    bag = bool(args.topic) or is_bag(path)
    offset = lidar_offset(args, bag)
    if bag:
        with open_topic(path, args) as topic:
            g = goal or (1.0, 0.0)
            return _replay(conf, topic.count, ((lb, s, g) for lb, s in labelled_scans(topic)), offset, args)
    total, items = _sources(path, goal)
    return _replay(conf, total, items, offset, args)


def _replay(conf: Configurator, total: int, items: Iterable[tuple[str, Any, tuple[float, float]]],
            offset: tuple[float, float, float], args: argparse.Namespace) -> int:

    def line(label: str, r: PlanResult, g: tuple[float, float]) -> str:
        if args.json:
            rec = {
                "scan": label,
                "reached_goal": r.reached_goal,
                "collision_free": r.collision_free,
                "states": r.states,
                "planning_time_s": r.planning_time_s,
                "plan": [s.task.value for s in r.steps],
            }
            return json.dumps(rec)
        return (
            f"{label}: {'goal' if r.reached_goal else 'partial' if r.steps else 'no move'}  "
            f"{r.states:3d} states  {r.planning_time_s * 1e3:7.2f} ms  [{' '.join(s.task.value[0] for s in r.steps)}]"
        )

    def error(label: str, exc: BaseException) -> str:
        return json.dumps({"scan": label, "error": str(exc)}) if args.json else f"{label}: error: {exc}"

    def plan(scan: Any, g: tuple[float, float]) -> PlanResult:
        return conf.plan(scan.points(offset) if isinstance(scan, LaserScan) else scan, g)

    run = plan_scans(items, total, "replay", plan, line, catch=(ScanError, PlanningError, BagError), emit_error=error)
    times, plans, reached, failed, seen = run.times, run.plans, run.reached, run.failed, run.seen
    t = np.array(times) if times else np.array([np.nan])
    median_s = float(np.median(t)) if times else None
    p90_s = float(np.percentile(t, 90)) if times else None
    total = seen
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
