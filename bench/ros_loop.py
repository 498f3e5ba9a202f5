"""``clomp ros sim`` + ``clomp ros node`` over DDS on scenarios, noise presets and seeds: does
the robot truly end within 0.1 m of the goal, without a collision?

Each run is the whole loop in real time (:func:`clomp.runtime.cli.ros.run_loop`: the
execution world as a ROS node and the node command, each with its own rclpy context,
talking over DDS on this host only: localhost discovery, shared memory, a private domain
id). Prints one line a run and a Markdown table (the one in docs/ros2.md)::

    python bench/ros_loop.py --scenarios overtaking,corridor,doorway --noise harsh --seeds 0,1,2
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenarios", default="overtaking,corridor,doorway")
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--seeds", default="0,1,2")
    ap.add_argument("--domain", type=int, default=40 + os.getpid() % 50, help="ROS_DOMAIN_ID (0-101)")
    ap.add_argument("--json", metavar="FILE", help="also write the runs as JSON lines")
    args = ap.parse_args()

    from clomp.runtime.ros.session import localhost_only

    localhost_only(args.domain)  # before any rclpy context
    from clomp.runtime.cli.ros import run_loop

    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scenario in args.scenarios.split(","):
            for seed in (int(s) for s in args.seeds.split(",")):
                r = run_loop(scenario, args.noise, seed, log=Path(tmp) / f"{scenario}-{seed}.jsonl")
                rows.append(r)
                print(json.dumps({k: r[k] for k in ("scenario", "noise", "seed", "exit", "goal_distance", "collisions",
                                                    "odometry_error", "time_s")}), flush=True)
    if args.json:
        Path(args.json).write_text("".join(json.dumps(r) + "\n" for r in rows))
    print("\n| scenario | noise | seed | exit | truly from the goal (m) | collisions | odometry error (m) | time (s) |")
    print("|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scenario']} | {r['noise']} | {r['seed']} | {r['exit']} | {r['goal_distance']:.3f} | {r['collisions']} "
              f"| {r['odometry_error']:.3f} | {r['time_s']:.1f} |")
    truly = sum(r["goal_distance"] <= 0.1 and r["collisions"] == 0 for r in rows)
    claimed = sum(r["exit"] == 0 for r in rows)
    false = sum(r["exit"] == 0 and r["goal_distance"] > 0.1 for r in rows)
    unconfirmed_there = sum(r["exit"] == 1 and r["goal_distance"] <= 0.1 for r in rows)
    print(f"\n{truly} of {len(rows)} runs truly within 0.1 m of the goal without a collision; "
          f"{claimed} claimed the goal (exit 0), {false} of them falsely; "
          f"{unconfirmed_there} truly there but unconfirmed (exit 1)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
