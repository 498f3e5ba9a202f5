"""Process CPU per experiment run, and the runs/s two cores would give (prints figures; not a test).

    python bench/run_cpu.py [--family overtaking] [--noise paper] [--runs 12] [--seed 0]
                            [--condition planning --condition reactive] [--profile FILE]

Runs ``--runs`` runs of each condition one after the other in this process (as a Dask
worker does, after one warm-up run: imports and the compiled kernels' cache) and prints each
condition's mean process CPU per run, and ``2 / mean`` — the runs per second two cores
would sustain at that cost, with both conditions mixed as a sweep mixes them. Process CPU,
not wall time: the machine may be shared, and wall time under load is not the figure
(issue #41's target: >= 3 runs/s on 2 cores for the paper's family). CPU time still grows
somewhat under heavy load (caches shared with other processes), so compare two trees
side by side, interleaved. ``--profile FILE`` writes a cProfile of the measured runs (timed in process CPU).
"""

from __future__ import annotations

import argparse
import cProfile
import statistics
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.runtime.experiment.runner import RunSpec, run_spec  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--family", default="overtaking")
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--runs", type=int, default=12)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--condition", action="append", choices=("planning", "reactive", "dwa", "rl"))
    ap.add_argument("--profile", default=None, metavar="FILE")
    args = ap.parse_args()
    if args.runs < 1:
        ap.error("--runs must be at least 1")
    conditions = args.condition or ["planning", "reactive"]
    prof = cProfile.Profile(time.process_time) if args.profile else None  # CPU, not wall time: the machine is shared
    means = []
    for cond in conditions:
        run_spec(RunSpec(args.family, args.seed + 99, 0, cond, args.noise))  # warm-up, not counted
        cpus = []
        for k in range(args.runs):
            c0 = time.process_time()
            if prof is not None:
                prof.enable()
            run_spec(RunSpec(args.family, args.seed, k, cond, args.noise))
            if prof is not None:
                prof.disable()
            cpus.append(time.process_time() - c0)
        mean = statistics.mean(cpus)
        means.append(mean)
        print(f"{args.family} {args.noise} {cond}: {args.runs} runs, process CPU {mean:.3f} s/run "
              f"(median {statistics.median(cpus):.3f}, min {min(cpus):.3f}, max {max(cpus):.3f})", flush=True)
    mixed = statistics.mean(means)
    print(f"mixed ({', '.join(conditions)} alike): {mixed:.3f} s CPU/run -> {2 / mixed:.2f} runs/s on 2 cores "
          "(from CPU; not wall time)")
    if prof is not None:
        prof.dump_stats(args.profile)
        print(f"profile: {args.profile}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
