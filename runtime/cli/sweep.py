"""``clomp sweep``: families × noise presets × seeds × conditions (× gyro) in one go, on Dask, one report page.

Every run is the experiment's (:class:`~clomp.runtime.experiment.runspec.RunSpec`: the same
layouts, noise and pairing as ``clomp experiment``), all submitted to one Dask cluster so the
workers never idle between cells. It writes OUT/runs.jsonl (streamed; ``--resume`` keeps the
finished runs), runs.csv, summary.json (one summary per cell) and report.html (every cell's
table, paired tests and runs), and prints one line per cell, the wall time, thread CPU and
runs per second. ``--workers N`` starts a local cluster and prints its dashboard's address
(with bokeh: ``clomp[dask]``).
"""

from __future__ import annotations

import argparse
import json
import math
import os
import time
from typing import Any

from clomp.runtime.cli import CliError
from clomp.runtime.cli._common import output_folder
from clomp.runtime.experiment.layouts import ALL_FAMILIES as FAMILIES
from clomp.runtime.experiment.runspec import CONDITIONS, DEFAULT_CONDITIONS

__all__ = ["parse_seeds", "register", "run"]


def register(sub: Any) -> None:
    """Add ``sweep`` to the command line."""
    p = sub.add_parser("sweep", help="families × noise presets × seeds × conditions on Dask, with one HTML report",
                       description=__doc__)
    p.add_argument("--families", default="all", help=f"comma-separated layout families or 'all' ({', '.join(FAMILIES)})")
    p.add_argument("--noise", default="paper,harsh", help="comma-separated noise presets (default paper,harsh)")
    p.add_argument("--seeds", default="0", help="seeds: 0,1,2 or a range 0-4 (default 0)")
    p.add_argument("--runs", type=int, default=10, help="layouts per family and seed (default 10)")
    p.add_argument("--condition", choices=CONDITIONS, action="append",
                   help="a condition to run (repeatable; default planning and reactive)")
    p.add_argument("--gyro", choices=("on", "off", "both"), default="on", help="with the rate gyro, without, or both")
    p.add_argument("--policy", metavar="FILE", default=None, help="the rl condition's policy file (default: the shipped one)")
    p.add_argument("--max-time", type=float, default=120.0, help="simulated seconds a run may take (default 120)")
    p.add_argument("--workers", type=int, default=None, help="Dask worker processes (default: one per CPU; 0: this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS", help="an existing Dask scheduler instead of a local cluster")
    p.add_argument("--out", default="clomp-sweep-out", help="output folder (default ./clomp-sweep-out)")
    p.add_argument("--resume", action="store_true", help="keep the finished runs in OUT/runs.jsonl, run the rest")
    p.set_defaults(func=run)


def parse_seeds(text: str) -> list[int]:
    """``"0,2"`` → [0, 2]; ``"0-3"`` → [0, 1, 2, 3]; CliError naming the bad item.

    >>> parse_seeds("0-2,7")
    [0, 1, 2, 7]
    """
    out: list[int] = []
    for item in text.split(","):
        lo, sep, hi = item.strip().partition("-")
        try:
            a = int(lo)
            b = int(hi) if sep else a
        except ValueError:
            raise CliError(f"--seeds: {item!r} is not a seed or a range a-b") from None
        if a < 0 or b < a or b - a > 10_000:
            raise CliError(f"--seeds: {item!r} must be seeds >= 0, a range a-b with a <= b")
        out.extend(range(a, b + 1))
    return sorted(set(out))


def _names(text: str, known: tuple[str, ...], what: str) -> list[str]:
    names = list(known) if text.strip() == "all" else [n.strip() for n in text.split(",") if n.strip()]
    bad = [n for n in names if n not in known]
    if bad or not names:
        raise CliError(f"--{what}: unknown {', '.join(bad) or 'empty list'} (known: {', '.join(known)})")
    return list(dict.fromkeys(names))


def run(args: argparse.Namespace) -> int:
    """Execute ``clomp sweep``."""
    from clomp.runtime.experiment.driver import ExperimentInterrupted, RunsFailed, run_specs
    from clomp.runtime.experiment.groundtruth import NOISE_PRESETS
    from clomp.runtime.experiment.htmlpage import block_key, write_report
    from clomp.runtime.experiment.policy import PolicyError
    from clomp.runtime.experiment.results import conditions_table, summarise, write_csv
    from clomp.runtime.experiment.runrecords import load_records
    from clomp.runtime.experiment.runspec import experiment_specs

    families = _names(args.families, FAMILIES, "families")
    presets = _names(args.noise, tuple(NOISE_PRESETS), "noise")
    seeds = parse_seeds(args.seeds)
    if args.runs < 1:
        raise CliError("--runs: must be at least 1")
    if not (math.isfinite(args.max_time) and args.max_time > 0):
        raise CliError("--max-time: must be a finite positive number of seconds")
    if args.workers is not None and args.workers < 0:
        raise CliError("--workers: must be 0 (this process) or more")
    conditions = tuple(dict.fromkeys(args.condition)) if args.condition else DEFAULT_CONDITIONS
    gyros = {"on": (True,), "off": (False,), "both": (True, False)}[args.gyro]
    try:
        specs = [s for fam in families for noise in presets for seed in seeds for g in gyros
                 for s in experiment_specs(fam, args.runs, seed, noise=noise, conditions=conditions,
                                           max_time=args.max_time, gyro=g, policy=args.policy)]
    except PolicyError as exc:
        raise CliError(f"--policy: {exc}") from None
    out = output_folder(args.out)
    workers = (os.cpu_count() or 1) if args.workers is None else args.workers
    from clomp.runtime.cli._progress import progress

    def bar(total: int, initial: int) -> Any:
        b: Any = progress(total=total, desc="sweep", unit="run")
        if initial:
            b.update(initial)
        return b

    from clomp.runtime.cli._signals import interrupts_raise

    print(f"clomp sweep: {len(specs)} runs ({len(families)} families × {len(presets)} presets × {len(seeds)} seeds × "
          f"{args.runs} runs × {len(conditions)} conditions{' × 2 gyro settings' if len(gyros) > 1 else ''})", flush=True)
    wanted = {s.key for s in specs}
    kept = len({r["key"] for r in load_records(out / "runs.jsonl") if r["key"] in wanted}) if args.resume else 0
    w0, c0 = time.perf_counter(), time.thread_time()
    try:
        with interrupts_raise():
            records = run_specs(specs, workers=workers, scheduler=args.scheduler, out=out, resume=args.resume,
                                progress=bar, on_dashboard=lambda link: print(f"Dask dashboard: {link}", flush=True))
    except ExperimentInterrupted as exc:
        print(f"clomp: interrupted: {len(exc.records)} of {exc.total} runs finished and kept in {out / 'runs.jsonl'}; "
              "run the same command with --resume to finish")
        return 130
    except RunsFailed as exc:
        print(f"clomp: {exc} (every failure in {out / 'errors.jsonl'}; --resume reruns only the rest)")
        return 1
    except (RuntimeError, OSError) as exc:
        raise CliError(str(exc)) from None
    wall, cpu = time.perf_counter() - w0, time.thread_time() - c0
    on_disk = load_records(out / "runs.jsonl")
    whole = [r for r in on_disk if r["key"] in wanted]  # this command's runs; a resume keeps others on disk
    cells: dict[tuple[str, str, float, int], list[dict[str, Any]]] = {}
    for r in whole:
        cells.setdefault(block_key(r), []).append(r)
    summaries = []
    for key, rs in sorted(cells.items()):
        s = summarise(rs)
        s["gyro"] = key[3]
        summaries.append(s)
        c = s["conditions"]
        print(f"{key[0]:<11} {key[1]:<6}{'' if key[3] else ' no gyro'}  " + "  ".join(
            f"{n}: {c[n]['success']}/{c[n]['runs']} success, {c[n]['collisions']} coll., "
            f"{c[n].get('false_successes', 0)} false" for n in c))
    write_csv(whole, out / "runs.csv")
    (out / "table.md").write_text(conditions_table(whole) + "\n", encoding="utf-8")
    (out / "summary.json").write_text(json.dumps({"cells": summaries, "runs": len(whole), "wall_s": round(wall, 1),
                                                  "runs_per_s": round((len(records) - kept) / wall, 3) if wall > 0 else None},
                                                 indent=1, allow_nan=False) + "\n", encoding="utf-8")
    page = write_report(whole, out / "report.html", f"clomp sweep: {len(whole)} runs")
    ran = len(records) - kept  # runs/s counts what this call ran, not the runs a --resume kept
    print(f"{ran} runs in {wall:.0f} s wall ({ran / max(wall, 1e-9):.2f} runs/s{f'; {kept} kept from before' if kept else ''}"
          f"{f'; {len(on_disk) - len(whole)} runs outside this selection left in runs.jsonl' if len(on_disk) > len(whole) else ''}), this process "
          f"{cpu:.1f} s thread CPU; wrote {out}{os.sep}: runs.jsonl, runs.csv, table.md, summary.json, {page.name}")
    return 0
