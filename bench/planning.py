"""Planning benchmark: median and p90 planning time and map size per scenario and scan set.

Run: ``python bench/planning.py [--repeat N] [--scans DIR]``. Prints figures; asserts nothing.
Planning time covers perception (scan → obstacle boxes) and map construction.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from planner import Configurator, builtin_scenarios, load_scan, load_scenario

DEFAULT_SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans" / "corridor-2023-10-25"


def _row(name: str, times: list[float], states: list[int]) -> str:
    t = np.array(times) * 1e3
    return (
        f"{name:<28} n={len(times):4d}  median {np.median(t):7.3f} ms  p90 {np.percentile(t, 90):7.3f} ms"
        f"  states median {statistics.median(states):6.1f}  p90 {np.percentile(states, 90):6.1f}"
    )


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--repeat", type=int, default=50, help="runs per scenario (default 50)")
    ap.add_argument("--scans", type=Path, default=DEFAULT_SCANS, help="folder of recorded scans")
    ap.add_argument(
        "--single",
        nargs="*",
        default=["map0001.dat", "map0141.dat"],
        help="recorded scans (with something ahead) each planned --repeat times, for a per-scan median/p90",
    )
    args = ap.parse_args(argv)
    conf = Configurator()
    conf.plan(np.zeros((0, 2)), (1.0, 0.0))  # warm up imports
    print(f"clomp planning benchmark (python {sys.version.split()[0]}, repeat {args.repeat})")
    for name in builtin_scenarios():
        scene = load_scenario(name)
        scan, goal = scene.scan(), tuple(scene.goal_in_robot_frame())
        times, states = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            r = conf.plan(scan, goal)
            times.append(time.perf_counter() - t0)
            states.append(r.states)
        print(_row(f"scenario {name}", times, states) + f"  reached={r.reached_goal}")
    if args.scans.is_dir():
        files = sorted(args.scans.glob("*.dat"))
        scans = [load_scan(f) for f in files]
        groups = {"scans (all)": scans, "scans (non-empty)": [s for s in scans if len(s)]}
        for label, group in groups.items():
            times, states = [], []
            for s in group:
                best = []
                for _ in range(3):
                    t0 = time.perf_counter()
                    r = conf.plan(s, (1.0, 0.0))
                    best.append(time.perf_counter() - t0)
                times.append(min(best))
                states.append(r.states)
            print(_row(label, times, states))
        for name in args.single:
            f = args.scans / name
            if not f.is_file():
                continue
            s = load_scan(f)
            times, states = [], []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                r = conf.plan(s, (1.0, 0.0))
                times.append(time.perf_counter() - t0)
                states.append(r.states)
            print(_row(f"scan {name} (repeated)", times, states) + f"  reached={r.reached_goal}")
    else:
        print(f"(recorded scans not found at {args.scans})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
