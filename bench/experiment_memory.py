"""How an experiment's memory grows with its runs, in one process (issue #43: flat at scale).

Runs ``--runs`` runs of a cheap family (default: ``open``, ``reactive``, ideal noise: each run a
few ms to a few tenths of a second) through :func:`run_experiment` with ``out`` set, as ``clomp
experiment`` does, and prints the resident set size (``/proc/self/statm``, else the peak from
``resource.getrusage``) after a warm-up and at the end: the growth in MB and per run in KiB.

    PYTHONPATH=$PWD python bench/experiment_memory.py --runs 2000

Measured (2 shared cores, 2,000 runs, about 3.5 min): before records were kept summary-only,
+41.7 MB (20.9 KiB per run; an overtaking planning run at paper noise holds about 150 KiB);
after, +3.9 MB (1.9 KiB per run: the summary fields each returned record still holds).
"""

from __future__ import annotations

import argparse
import gc
import os
import resource
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.runtime.experiment.runner import run_experiment  # noqa: E402


def rss_mb() -> float:
    """The resident set size now (MB); the peak where /proc is missing."""
    try:
        pages = int(Path("/proc/self/statm").read_text().split()[1])
        return pages * os.sysconf("SC_PAGE_SIZE") / 1e6
    except OSError:
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1e3


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=2000)
    ap.add_argument("--warmup", type=int, default=50, help="runs before the first reading (imports, caches, JIT)")
    ap.add_argument("--family", default="open")
    ap.add_argument("--condition", default="reactive")
    ap.add_argument("--noise", default="ideal")
    ap.add_argument("--every", type=int, default=250, help="print a reading every N runs")
    args = ap.parse_args(argv)
    readings: list[tuple[int, float]] = []

    def on_record(rec: dict[str, object]) -> None:
        n = int(rec["run"]) + 1  # type: ignore[call-overload]
        if n == args.warmup or n % args.every == 0 or n == args.runs:
            gc.collect()
            readings.append((n, rss_mb()))
            print(f"{n:6d} runs  RSS {readings[-1][1]:8.1f} MB", flush=True)

    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as out:
        recs = run_experiment(args.family, args.runs, 0, noise=args.noise, conditions=(args.condition,),
                              out=out, on_record=on_record)
        gc.collect()
        readings.append((args.runs, rss_mb()))  # the records returned still held
        n_recs = len(recs)
    (n0, m0), (n1, m1) = next(r for r in readings if r[0] >= args.warmup), readings[-1]
    per_run = (m1 - m0) * 1e6 / 1024 / max(1, n1 - n0)
    print(f"{n_recs} runs in {time.perf_counter() - t0:.0f} s; RSS {m0:.1f} MB after {n0} -> {m1:.1f} MB "
          f"after {n1} (records returned, held): growth {m1 - m0:+.1f} MB, {per_run:.1f} KiB per run")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
