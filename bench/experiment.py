"""Throughput of ``clomp experiment`` on Dask, and what a lost worker costs (prints figures; not a test).

    python bench/experiment.py [--runs 1000] [--workers 2] [--family overtaking] [--noise paper]
                               [--kill-worker-after 0.3] [--out DIR]

Starts a local Dask cluster of ``--workers`` processes (one thread each) and runs the
experiment on it through ``--scheduler``-style access, streaming records to OUT. With
``--kill-worker-after F`` it SIGKILLs one worker process once a fraction F of the runs
has finished; the nanny starts a new one, the scheduler reruns the lost runs, and the
script checks that every run is present exactly once (the slow test
``test_a_killed_worker_loses_no_run`` also checks that the records equal those of a run
without the kill: runs are pure functions of their spec).

Prints: runs, wall time, runs per second, simulated seconds per wall second, the
workers' summed thread CPU time (each run's ``time.thread_time()``) and per run, this
process's CPU time and the load average (the machine may be shared). Target (issue #9):
1,000 overtaking runs (``--runs 500``: 500 layouts × 2 conditions) with 2 workers in
<= 10 minutes.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import sys
import time
import warnings
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.runtime.experiment.results import summarise  # noqa: E402
from clomp.runtime.experiment.runner import load_records, run_experiment  # noqa: E402


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--runs", type=int, default=1000, help="runs (layouts); each runs in both conditions unless --condition")
    ap.add_argument("--condition", action="append", choices=("planning", "reactive"))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--family", default="overtaking")
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--kill-worker-after", type=float, default=None, metavar="F")
    ap.add_argument("--out", default="bench-experiment-out")
    args = ap.parse_args()

    from distributed import Client, LocalCluster

    conditions = tuple(args.condition) if args.condition else ("planning", "reactive")
    total = args.runs * len(conditions)
    with warnings.catch_warnings():  # the scheduler's HTTP server moving off a busy port 8787
        warnings.simplefilter("ignore", UserWarning)
        cluster = LocalCluster(n_workers=args.workers, threads_per_worker=1, processes=True, host="127.0.0.1",
                               dashboard_address=None, silence_logs=logging.CRITICAL)
    client = Client(cluster)
    killed: list[int] = []
    done = [0]

    def on_record(_rec: dict) -> None:
        done[0] += 1
        if args.kill_worker_after is not None and not killed and done[0] >= args.kill_worker_after * total:
            pids = client.run(os.getpid)
            pid = sorted(pids.values())[0]
            os.kill(pid, signal.SIGKILL)
            killed.append(pid)
            print(f"  killed worker process {pid} after {done[0]} of {total} runs", flush=True)

    c0, t0 = time.process_time(), time.perf_counter()
    try:
        recs = run_experiment(args.family, args.runs, args.seed, noise=args.noise, conditions=conditions,
                              scheduler=cluster.scheduler_address, out=args.out, on_record=on_record)
    finally:
        wall = time.perf_counter() - t0
        client.close()
        cluster.close()
    keys = [r["key"] for r in load_records(Path(args.out) / "runs.jsonl")]
    sim_s = sum(float(r["time_s"]) for r in recs)
    cpu_workers = sum(float(r["cpu_s"]) for r in recs)
    print(f"{args.family} · noise {args.noise} · {args.workers} workers: {len(recs)} runs "
          f"({args.runs} layouts × {len(conditions)} conditions) in {wall:.1f} s wall")
    print(f"  {len(recs) / wall:.2f} runs/s; {sim_s / wall:.0f} simulated s per wall s ({sim_s:.0f} s simulated)")
    print(f"  workers' thread CPU {cpu_workers:.1f} s ({cpu_workers / max(len(recs), 1):.3f} s per run, "
          f"≈ {cpu_workers / wall:.2f} cores busy); "
          f"this process CPU {time.process_time() - c0:.1f} s; load average {os.getloadavg()[0]:.1f}")
    ok = len(keys) == len(set(keys)) == total and len(recs) == total
    print(f"  records in runs.jsonl: {len(keys)} ({len(set(keys))} distinct) of {total}: {'all present' if ok else 'MISSING'}")
    if killed:
        print(f"  worker {killed[0]} was killed mid-experiment; every run still present: {ok}")
    c = summarise(recs)["conditions"]
    for name in conditions:
        d = c[name]
        print(f"  {name}: success {d['success']}/{d['runs']}, collisions {d['collisions']}, brushes {d['brushes']}, "
              f"median final error {d['final_error_median_m']:.3f} m")
    target = 600.0
    if len(recs) >= 1000:
        per_1000 = wall * 1000 / len(recs)
        print(f"  target: 1,000 runs in <= {target:.0f} s: {'reached' if per_1000 <= target else 'NOT reached'} "
              f"({per_1000:.0f} s per 1,000 runs)")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
