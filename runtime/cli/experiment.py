"""``clomp experiment``: the paper's comparison, planning vs a reactive loop, on randomised layouts."""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from planner.scenarios import ScenarioError
from runtime.cli import CliError
from runtime.experiment.runner import CONDITIONS, run_experiment

__all__ = ["register", "run"]


def register(sub: Any) -> None:
    """Add ``experiment`` to the command line."""
    p = sub.add_parser(
        "experiment",
        help="planning vs reactive on randomised layouts of a scenario (the paper's table)",
        description=__doc__,
    )
    p.add_argument("scenario", nargs="?", default="overtaking", help="built-in scenario name or JSON file (default overtaking)")
    p.add_argument("--runs", type=int, default=10, help="randomised layouts, each run in both conditions (default 10)")
    p.add_argument("--seed", type=int, default=0, help="seed of the layouts and the noise (default 0)")
    p.add_argument("--jobs", type=int, default=None, help="worker processes (default: one per CPU)")
    p.add_argument("--max-time", type=float, default=120.0, help="simulated seconds a run may take (default 120)")
    p.add_argument("--condition", choices=CONDITIONS, action="append", help="run only this condition (repeatable)")
    p.add_argument("--out", default="clomp-experiment-out", help="folder for the CSV and PNGs (default ./clomp-experiment-out)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp experiment``."""
    if args.runs < 1:
        raise CliError("--runs: must be at least 1")
    if args.jobs is not None and args.jobs < 1:
        raise CliError("--jobs: must be at least 1")
    if not args.max_time > 0:
        raise CliError("--max-time: must be positive")
    out = Path(args.out)
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CliError(f"--out: cannot create {out}: {exc}") from None
    conditions = tuple(dict.fromkeys(args.condition)) if args.condition else CONDITIONS
    try:
        res = run_experiment(args.scenario, args.runs, args.seed, jobs=args.jobs, max_time=args.max_time,
                             conditions=conditions)
    except ScenarioError as exc:
        raise CliError(str(exc)) from None
    csv_path = out / f"{res.scenario}_runs.csv"
    res.write_csv(csv_path)
    pngs = res.write_plots(out)
    summary = res.summary()
    summary["files"] = {"csv": str(csv_path), "png": [str(p) for p in pngs]}
    if args.json:
        print(json.dumps(summary, allow_nan=False))
    else:
        print(res.table())
        print(f"wrote {csv_path} and {', '.join(str(p) for p in pngs)}  ({res.wall_s:.1f} s)", file=sys.stdout)
    return 0
