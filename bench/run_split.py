"""Where a run's thread CPU goes, without a profiler's distortion (prints figures; not a test).

    python bench/run_split.py [--family overtaking] [--noise paper] [--condition planning]
                              [--runs 20] [--seed 0]

cProfile charges every Python call (it doubled a planning run's CPU, and inflated most the
many small calls), so its shares are not the run's. Here a handful of entry points
(the world's physics step, the estimator's revolution and its parts, the supervisor's
hazard test, plan check, planning …) are wrapped to add up their inclusive thread CPU; a
few thousand calls a run cost little. Prints ms per run and the share of the run, after one
warm-up run (imports and the compiled kernels' cache).
"""

from __future__ import annotations

import argparse
import functools
import importlib
import statistics
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.runtime.experiment.runner import RunSpec, run_spec  # noqa: E402

#: (label, module, attribute path): inclusive thread CPU of each; indented labels lie inside the one above
PARTS = [
    ("world physics step (_advance)", "clomp.runtime.backends.world", "WorldRobot._advance"),
    ("  LiDAR rays and revolution", "clomp.runtime.backends._lidar", "Lidar.step"),
    ("estimator revolution (odometry.update)", "clomp.runtime.estimation.odometry", "ScanOdometry.update"),
    ("  heading from faces (_steer)", "clomp.runtime.estimation.odometry", "ScanOdometry._steer"),
    ("  observability (_observed)", "clomp.runtime.estimation._localmap", "LocalMap._observed"),
    ("  local map growth (_add)", "clomp.runtime.estimation._localmap", "LocalMap._add"),
    ("  scan match (match_scans)", "clomp.runtime.estimation.odometry", "match_scans"),
    ("  EKF correct", "clomp.runtime.estimation.ekf", "OdometryFilter.correct"),
    ("  de-skew", "clomp.runtime.estimation.odometry", "ScanOdometry._deskew_along"),
    ("  doubt see-through", "clomp.runtime.estimation.odometry", "see_through"),
    ("  map sd", "clomp.runtime.estimation._localmap", "LocalMap._map_sd"),
    ("dead reckoning (sensing.update_pose)", "clomp.runtime.supervision.sensing", "Sensing.update_pose"),
    ("hazard test (supervisor._hazard)", "clomp.runtime.supervision.supervisor", "Supervisor._hazard"),
    ("plan check (supervisor._check_remaining)", "clomp.runtime.supervision.supervisor", "Supervisor._check_remaining"),
    ("planning (supervisor._plan_tick)", "clomp.runtime.supervision.supervisor", "Supervisor._plan_tick"),
    ("goal confirmation (goal.confirm_tick)", "clomp.runtime.supervision.supervisor", "confirm_tick"),
]


def _wrap(owner: Any, name: str, spent: dict[str, float], label: str) -> bool:
    fn = getattr(owner, name, None)
    if fn is None or not callable(fn):
        return False

    @functools.wraps(fn)
    def timed(*a: Any, **k: Any) -> Any:
        c0 = time.thread_time()
        try:
            return fn(*a, **k)
        finally:
            spent[label] += time.thread_time() - c0

    setattr(owner, name, timed)
    return True


def _install(spent: dict[str, float]) -> list[str]:
    missing = []
    for label, module, path in PARTS:
        owner: Any = importlib.import_module(module)
        *outer, attr = path.split(".")
        for p in outer:
            owner = getattr(owner, p, None)
        spent[label] = 0.0
        if owner is None or not _wrap(owner, attr, spent, label):
            missing.append(f"{module}.{path}")
    return missing


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--family", default="overtaking")
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--condition", default="planning")
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args()
    run_spec(RunSpec(args.family, args.seed + 99, 0, args.condition, args.noise))  # warm-up, not counted
    spent: dict[str, float] = {}
    missing = _install(spent)
    for m in missing:
        print(f"(not found, not timed: {m})")
    cpus, inside = [], []
    for k in range(args.runs):
        c0 = time.thread_time()
        rec = run_spec(RunSpec(args.family, args.seed, k, args.condition, args.noise))
        cpus.append(time.thread_time() - c0)
        inside.append(float(rec["cpu_s"]))
    total = sum(cpus)
    n = args.runs
    print(f"{args.family} {args.noise} {args.condition}: {n} runs (seed {args.seed}, runs 0-{n - 1}), "
          f"thread CPU {total / n * 1000:.0f} ms/run (median {statistics.median(cpus) * 1000:.0f}); "
          f"the run's own cpu_s {sum(inside) / n * 1000:.0f} ms/run, set-up and record {(total - sum(inside)) / n * 1000:.0f}")
    row: Callable[[str, float], str] = lambda label, s: f"{label:<44} {s / n * 1000:7.1f} ms/run {100 * s / total:5.1f} %"
    for label, _, _ in PARTS:
        print(row(label, spent[label]))
    top = sum(spent[label] for label, _, _ in PARTS if not label.startswith(" "))
    print(row("the rest (supervisor ticks, records, set-up …)", total - top))
    return 0


if __name__ == "__main__":
    sys.exit(main())
