"""Probabilistic-map benchmark: time to build a map of N noisy rollouts per choice, and
Storm's time to solve Pmax=? [!"collision" U "goal"] (with its scheduler) on it.

Run: ``python bench/probabilistic.py [--scenario overtaking] [--samples 30] [--repeat 5]
[--noise paper] [--no-carry] [--closed-loop]``. The map is the one the robust planner chooses on
(:meth:`clomp.planner.robust.RobustConfigurator.probabilistic_map`: the supervisor's tolerance,
hazard stops, poses carried from task to task); ``--no-carry`` starts every rollout at the
state's recorded end instead; ``--closed-loop`` samples the closed loop's model
(:data:`clomp.planner.robust.CLOSED_LOOP_HAZARD`: a contact the plan check sees coming is a
stop, outcomes off the map's prediction are replanned from). Prints wall and thread CPU time (median of the repeats);
asserts nothing.
"""

from __future__ import annotations

import argparse
import statistics
import time

from clomp.formal.scheduler import robust_plan
from clomp.planner import load_scenario
from clomp.planner.robust import CLOSED_LOOP_HAZARD, SUPERVISOR_HAZARD, RobustConfigurator


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--scenario", default="overtaking")
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--repeat", type=int, default=5)
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--no-carry", action="store_true", help="every rollout starts at the state's recorded end")
    ap.add_argument("--closed-loop", action="store_true", help="the closed loop's model (contacts the check sees coming are stops)")
    args = ap.parse_args(argv)
    scene = load_scenario(args.scenario)
    conf = RobustConfigurator(samples=args.samples, noise=args.noise, carry=not args.no_carry,
                              hazard=CLOSED_LOOP_HAZARD if args.closed_loop else SUPERVISOR_HAZARD)
    scan = scene.scan(max_range=conf.robot.sensor_range)
    goal = tuple(scene.goal_in_robot_frame())
    build_wall, build_cpu, solve_wall, solve_cpu = [], [], [], []
    pm = None
    for k in range(args.repeat):
        w0, c0 = time.perf_counter(), time.thread_time()
        pm = conf.probabilistic_map(scan, goal, seed=k)
        build_wall.append(time.perf_counter() - w0)
        build_cpu.append(time.thread_time() - c0)
        w0, c0 = time.perf_counter(), time.thread_time()
        r = robust_plan(pm.map)
        solve_wall.append(time.perf_counter() - w0)
        solve_cpu.append(time.thread_time() - c0)
    assert pm is not None
    c = conf.sample(scan, goal)  # what plan --robust reports: its target, a stop retried once (seed 0)
    med = statistics.median
    carried = ("every rollout from the state's end" if args.no_carry else "poses carried") + (", closed loop" if args.closed_loop else "")
    print(f"{args.scenario}, {args.samples} samples per choice, noise {args.noise}, {carried}, "
          f"{args.repeat} repeats (median):")
    print(f"  build probabilistic map  wall {med(build_wall) * 1e3:8.1f} ms   thread CPU {med(build_cpu) * 1e3:8.1f} ms"
          f"   ({len(pm.map)} states, {pm.map.n_transitions} transitions, {pm.probabilistic_choices} uncertain choices)")
    print(f"  Storm Pmax + scheduler   wall {med(solve_wall) * 1e3:8.1f} ms   thread CPU {med(solve_cpu) * 1e3:8.1f} ms"
          "   (export to DRN, build, check)")
    print(f"  Pmax [!collision U goal], no retry, last map: {r.probability:.4f}")
    print(f"  as plan --robust reports it (seed 0; its target, a stop retried once): robust P = "
          f"{c.robust.probability:.4f}, greedy P = {c.p_greedy:.4f}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
