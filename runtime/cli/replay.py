"""``clomp replay``: re-plan on a recorded sequence — a ``clomp run`` log, a folder of
scans, or the LaserScan topic of a ROS bag (``clomp replay BAG --topic /scan``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Iterable, Iterator
from pathlib import Path
from typing import Any

import numpy as np

from clomp.planner import Configurator
from clomp.runtime.cli._bags import add_bag_options, bag_points, is_bag, labelled_scans, lidar_offset, open_topic
from clomp.runtime.cli._progress import progress
from clomp.runtime.cli import EXIT_OK, CliError, plural
from clomp.runtime.cli._common import Notes, add_units_option, folder_scans, log_records, path_kind, scan_outcomes
from clomp.runtime.cli.plan import add_planner_options, configurator_from_args, parse_goal
from clomp.runtime.records.bags import LaserScan
from clomp.runtime.records.runlog import scans_from_log

__all__ = ["register"]

def register(sub: Any) -> None:
    """Add ``replay`` to the command line."""
    p = sub.add_parser("replay", help="re-plan on a recorded run log or folder of scans", description=__doc__)
    p.add_argument("source", help="a folder of scans (mapNNNN.dat …), a clomp run log (.jsonl), or a ROS bag (with --topic)")
    p.add_argument("--goal", help="goal X,Y in the robot frame for every scan (default: the log's, else 1.0,0.0)")
    p.add_argument("--json", action="store_true", help="one JSON line per scan, then a summary line")
    add_units_option(p)
    add_bag_options(p)
    add_planner_options(p)
    p.set_defaults(func=run)


def _sources(
    path: Path, goal: tuple[float, float] | None
) -> tuple[int | None, Iterator[tuple[str, Any, tuple[float, float]]], list[str]]:
    """(count if known, the scans, what the listing found to say once) of a folder or run log."""
    if path_kind(path, "replay") == "folder":
        files, notes = folder_scans(path)
        return len(files), ((f.name, f, goal or (1.0, 0.0)) for f in files), notes
    records = log_records(scans_from_log, path, "scan records")  # streamed: bounded memory
    return None, ((label, pts, goal or g or (1.0, 0.0)) for label, pts, g in records), []


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp replay``."""
    conf = configurator_from_args(args)
    path = Path(args.source)
    if path_kind(path, "replay") == "missing":
        raise CliError(f"{path}: no such file or folder")
    goal = parse_goal(args.goal) if args.goal else None
    bag = bool(args.topic) or is_bag(path)
    offset = lidar_offset(args, bag)
    if bag:
        with open_topic(path, args) as topic:
            g = goal or (1.0, 0.0)
            return _replay(conf, topic.count, ((lb, s, g) for lb, s in labelled_scans(topic)), offset, args)
    total, items, notes = _sources(path, goal)
    return _replay(conf, total, items, offset, args, notes)


def _replay(conf: Configurator, total: int | None, items: Iterable[tuple[str, Any, tuple[float, float]]],
            offset: tuple[float, float, float], args: argparse.Namespace, listing: list[str] | None = None) -> int:
    """One line per scan (an ``error`` for a scan that cannot be planned, ``at_goal`` for
    one taken at the goal), then a summary; exit 0 once every scan was processed."""
    times: list[float] = []
    plans = reached = failed = at_goal = seen = 0
    notes = Notes(listing, conf.robot.sensor_range)  # said once, before the summary, not once per scan
    bar = progress(items, total=total, desc="replay", unit="scan")
    for label, scan, g in bar:
        seen += 1
        source = (lambda s=scan: bag_points(s, offset)) if isinstance(scan, LaserScan) else scan
        r, rec = scan_outcomes(conf, source, g, args.units, f"replay: {label}")
        if r is None:
            if rec["outcome"] == "error":
                failed += 1
                line = {"scan": label, "error": rec["error"]}
                text = f"{label}: error: {rec['error']}"
            else:
                at_goal += 1
                line = {"scan": label, "outcome": "at_goal", "reached_goal": True, "plan": []}
                text = f"{label}: already at the goal"
            bar.write(json.dumps(line) if args.json else text)
            notes.add(label, rec)
            continue
        times.append(r.planning_time_s)
        plans += bool(r.steps) or r.reached_goal
        reached += r.reached_goal
        if args.json:
            out = {
                "scan": label,
                "outcome": rec["outcome"],
                "reached_goal": r.reached_goal,
                "collision_free": r.collision_free,
                "states": r.n_states,
                "planning_time_s": r.planning_time_s,
                "plan": [s.task.value for s in r.steps],
            }
            if "warnings" in rec:
                out["warnings"] = rec["warnings"]
            bar.write(json.dumps(out))
        else:
            bar.write(
                f"{label}: {rec['outcome'].replace('_', ' ')}  "
                f"{r.n_states:3d} states  {r.planning_time_s * 1e3:7.2f} ms  [{' '.join(s.task.value[0] for s in r.steps)}]"
            )
        notes.add(label, rec)
    t = np.array(times) if times else np.array([np.nan])
    median_s = float(np.median(t)) if times else None
    p90_s = float(np.percentile(t, 90)) if times else None
    summary = {
        "scans": seen,
        "plans": plans,
        "reached_goal": reached,
        "at_goal": at_goal,
        "errors": failed,
        "median_planning_time_s": median_s,
        "p90_planning_time_s": p90_s,
        **notes.summary(),
    }
    if args.json:
        print(json.dumps({"summary": summary}))
    else:
        for note in notes.lines():
            print(note)
        med = f"{median_s * 1e3:.2f} ms" if median_s is not None else "n/a"
        p90 = f"{p90_s * 1e3:.2f} ms" if p90_s is not None else "n/a"
        print(
            f"summary: {plural(seen, 'scan')}, {plural(plans, 'plan')} found ({reached} reach the goal), "
            f"{at_goal} already at the goal, {plural(failed, 'error')}; planning time median {med}, p90 {p90}"
        )
    return EXIT_OK
