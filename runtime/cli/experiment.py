"""``clomp experiment``: the paper's comparison, planning vs the reactive loop, on layout families.

Each run is a pure function of (family, seed, run index, condition, noise), so results
do not depend on the number of workers. Runs stream to OUT/runs.jsonl as they finish;
Ctrl-C keeps them and ``--resume`` runs only the rest. At the end OUT holds runs.csv
(schema in runs_schema.md), runs.parquet when pyarrow is installed (the same columns,
typed), summary.json and the plots.
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import math
import os
import sys
from pathlib import Path
from typing import Any

from clomp.planner.noise import preset_names
from clomp.planner.scenarios import ScenarioError
from clomp.runtime.cli._common import output_folder
from clomp.runtime.cli._args import seed_arg
from clomp.runtime.cli import CliError
from clomp.runtime.experiment.layouts import ALL_FAMILIES as FAMILIES
from clomp.runtime.experiment.policy import PolicyError
from clomp.runtime.experiment.runspec import CONDITIONS

__all__ = ["parse_scales", "register", "run"]


def register(sub: Any) -> None:
    """Add ``experiment`` to the command line."""
    p = sub.add_parser("experiment", help="planning vs reactive on a layout family (the paper's table), locally or on Dask",
                       description=__doc__)
    p.add_argument("family", nargs="?", default="overtaking",
                   help=f"layout family ({', '.join(FAMILIES)}) or a scenario name/JSON file for one fixed layout "
                        "(default overtaking)")
    p.add_argument("--runs", type=int, default=10, help="layouts, each run in both conditions (default 10)")
    p.add_argument("--seed", type=seed_arg, default=0, help="seed of the layouts and the noise (default 0)")
    p.add_argument("--noise", choices=preset_names(), default="paper",
                   help="noise preset of the execution world (default paper)")
    p.add_argument("--noise-scale", type=float, default=1.0, help="factor on every noise term (default 1)")
    p.add_argument("--feedback", choices=("scan", "none"), default="scan",
                   help="both conditions' pose estimate: scan matching (default) or dead reckoning only")
    p.add_argument("--no-gyro", action="store_true",
                   help="the robot without its rate gyro, as the paper's robot and clomp run without an IMU")
    p.add_argument("--noise-sweep", metavar="X,Y,...", default=None,
                   help="run every noise scale in the list (e.g. 0,0.5,1,2,4) and plot success against it")
    p.add_argument("--workers", type=int, default=None,
                   help="Dask worker processes of a local cluster (default: one per CPU; 0: run in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="use an existing Dask scheduler (e.g. tcp://host:8786) instead of a local cluster")
    p.add_argument("--max-time", type=float, default=120.0, help="simulated seconds a run may take (default 120)")
    p.add_argument("--condition", choices=CONDITIONS, action="append",
                   help="run only this condition (repeatable; default planning and reactive; dwa: the dynamic window "
                        "approach; rl: a learned policy, --policy)")
    p.add_argument("--policy", metavar="FILE", default=None,
                   help="the rl condition's policy: a clomp-policy JSON or a stable-baselines3 .zip (default: the shipped one)")
    p.add_argument("--out", default="clomp-experiment-out", help="output folder (default ./clomp-experiment-out)")
    p.add_argument("--resume", action="store_true", help="keep the finished runs in OUT/runs.jsonl, run the rest")
    p.add_argument("--no-plots", action="store_true", help="skip the PNGs")
    p.add_argument("--report", action="store_true",
                   help="also write OUT/report.html: the summary, the paired tests, every run's trajectory (offline, one file)")
    p.add_argument("--gallery", action="store_true", help="only draw OUT/gallery.png: sample layouts of every family")
    p.add_argument("--json", action="store_true", help="print the summary as one JSON object instead of the table")
    p.add_argument("--markdown", action="store_true", help="print the summary as a row of the experiment table (docs/experiment-room.md)")
    p.set_defaults(func=run)


def parse_scales(text: str) -> list[float]:
    """``"0,0.5,1"`` → [0.0, 0.5, 1.0]; CliError naming the bad item."""
    out = []
    for item in text.split(","):
        item = item.strip()
        try:
            v = float(item)
        except ValueError:
            raise CliError(f"--noise-sweep: {item!r} is not a number") from None
        if not (math.isfinite(v) and v >= 0):
            raise CliError(f"--noise-sweep: {item!r} must be a finite number >= 0")
        out.append(v)
    if not out:
        raise CliError("--noise-sweep: give at least one scale")
    return sorted(set(out))


def _write_outputs(records: list[dict[str, Any]], out: Path, plots: bool, report: str | None = None) -> dict[str, Any]:
    from clomp.runtime.experiment.results import summarise, write_csv, write_parquet, write_schema

    files: dict[str, Any] = {"jsonl": str(out / "runs.jsonl"), "csv": str(write_csv(records, out / "runs.csv")),
                             "schema": str(write_schema(out / "runs_schema.md"))}
    if importlib.util.find_spec("pyarrow") is not None:  # optional: clomp[parquet]
        files["parquet"] = str(write_parquet(records, out / "runs.parquet"))
    summary = summarise(records)
    if plots and records:
        from clomp.runtime.experiment.report import write_plots

        files["png"] = [str(p) for p in write_plots(records, out)]
    if report is not None:  # the page, titled so, from the whole records on disk (memory keeps only some traces)
        from clomp.runtime.experiment.htmlpage import write_report
        from clomp.runtime.experiment.runrecords import load_records

        files["html"] = str(write_report(load_records(out / "runs.jsonl"), out / "report.html", report, images=out))
    summary["files"] = files
    (out / "summary.json").write_text(json.dumps(summary, indent=1, allow_nan=False) + "\n", encoding="utf-8")
    return summary


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp experiment``."""
    from clomp.runtime.experiment.driver import ExperimentInterrupted, RunsFailed, run_experiment
    from clomp.runtime.experiment.results import PAPER
    from clomp.runtime.experiment.runspec import DEFAULT_CONDITIONS

    if args.runs < 1:
        raise CliError("--runs: must be at least 1")
    if args.workers is not None and args.workers < 0:
        raise CliError("--workers: must be 0 (this process) or more")
    if not (math.isfinite(args.max_time) and args.max_time > 0):
        raise CliError(f"--max-time: must be a finite positive number of seconds, got {args.max_time:g}")
    if not (math.isfinite(args.noise_scale) and args.noise_scale >= 0):
        raise CliError("--noise-scale: must be a finite number >= 0")
    out = output_folder(args.out)
    if args.gallery:
        from clomp.runtime.experiment.plots import plot_gallery

        path = out / "gallery.png"
        plot_gallery(path, seed=args.seed)
        print(f"wrote {path}")
        return 0
    scales = parse_scales(args.noise_sweep) if args.noise_sweep else [args.noise_scale]
    conditions = tuple(dict.fromkeys(args.condition)) if args.condition else DEFAULT_CONDITIONS
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    from clomp.runtime.cli._progress import progress

    def bar(total: int, initial: int) -> Any:
        b: Any = progress(total=total, desc=f"{args.family} · {args.noise}", unit="run")
        if initial:
            b.update(initial)
        return b

    from clomp.runtime.cli._signals import interrupts_raise

    try:
        # Ctrl-C and SIGTERM stop it even when started with SIGINT ignored (a background job of a script)
        with interrupts_raise():
            records = run_experiment(args.family, args.runs, args.seed, noise=args.noise, noise_scales=scales,
                                     conditions=conditions, max_time=args.max_time, workers=workers,
                                     scheduler=args.scheduler, out=out, resume=args.resume, progress=bar,
                                     feedback=args.feedback, gyro=not args.no_gyro, policy=args.policy)
    except PolicyError as exc:
        raise CliError(f"--policy: {exc}") from None
    except ScenarioError as exc:
        raise CliError(f"{exc} (or a layout family: {', '.join(FAMILIES)})") from None
    except ExperimentInterrupted as exc:
        _write_outputs(exc.records, out, plots=False)
        print(f"clomp: interrupted: {len(exc.records)} of {exc.total} runs finished and kept in {out / 'runs.jsonl'}; "
              f"run the same command with --resume to finish", file=sys.stderr)
        return 130
    except RunsFailed as exc:
        _write_outputs(exc.records, out, plots=False)
        print(f"clomp: {exc} (every failure in {out / 'errors.jsonl'}; the {len(exc.records)} finished runs are kept, "
              "--resume reruns only the rest)", file=sys.stderr)
        return 1
    except (RuntimeError, OSError) as exc:
        raise CliError(str(exc)) from None
    summary = _write_outputs(records, out, plots=not args.no_plots,
                             report=f"clomp experiment {args.family}" if args.report else None)
    if args.json:
        print(json.dumps(summary, allow_nan=False))
    elif args.markdown:
        from clomp.runtime.experiment.results import markdown_rows

        print(markdown_rows(summary))
    else:
        from clomp.runtime.experiment.results import table

        paper = PAPER if args.family == "overtaking" else None
        print(table(summary, paper))
        print(f"wrote {out}{os.sep}: runs.jsonl, runs.csv, " + ("runs.parquet, " if "parquet" in summary["files"] else "")
              + "runs_schema.md, summary.json" + (", report.html" if "html" in summary["files"] else "")
              + (", " + ", ".join(Path(p).name for p in summary["files"].get("png", [])) if summary["files"].get("png") else ""))
    return 0
