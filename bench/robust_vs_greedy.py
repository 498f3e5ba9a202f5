"""Robust vs greedy plans in the execution world: how often each reaches the goal
without a collision, beside Storm's predicted probabilities.

Run: ``python bench/robust_vs_greedy.py [--runs 25] [--families doorway clutter]
[--noise harsh] [--samples 20]``. Each run is one layout (family, seed 0, run k) of the
experiment (:func:`runtime.experiment.layouts.make_layout`) driven by the supervisor in
the execution world at the given noise, once with the Configurator's best-first plans
(greedy) and once with :class:`planner.probabilistic.RobustConfigurator` (Storm's
scheduler on a map of ``--samples`` noisy rollouts per choice, same noise preset); the
two conditions of a run meet the same world and noise seed. Success: the robot truly
ends at the goal (ground truth) with no collision episode. Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time

from formal.robust import follow_tasks, plan_probability, robust_plan
from planner import Configurator
from planner.probabilistic import RobustConfigurator, sample_map
from runtime.experiment.layouts import make_layout
from runtime.experiment.runner import run_once


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=25, help="runs per family (default 25)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--samples", type=int, default=20)
    ap.add_argument("--max-time", type=float, default=120.0)
    args = ap.parse_args(argv)
    w0, c0 = time.perf_counter(), time.thread_time()
    rows = []
    for family in args.families:
        tally = {"greedy": [0, 0], "robust": [0, 0]}
        predicted: dict[str, list[float]] = {"greedy": [], "robust": []}
        for k in range(args.runs):
            layout = make_layout(family, 0, k)
            scene = layout.scene
            goal = tuple(scene.goal_in_robot_frame())
            # Storm's prediction on the first plan (the map from the start pose)
            pm = sample_map(scene.scan(max_range=1.1), goal, samples=args.samples, noise=args.noise, seed=k)  # type: ignore[arg-type]
            predicted["robust"].append(robust_plan(pm.map).probability)
            predicted["greedy"].append(plan_probability(pm.map, follow_tasks(pm.map, [s.task for s in pm.nominal.steps])))
            line = []
            for name, conf in (("greedy", Configurator()), ("robust", RobustConfigurator(samples=args.samples, noise=args.noise, seed=1000 * k))):
                r = run_once(scene, "planning", seed=k, run=k, noise=args.noise, configurator=conf, max_time=args.max_time,
                             expect=layout.expect)
                ok = r.reached_goal and r.collisions == 0
                tally[name][0] += ok
                tally[name][1] += 1
                line.append(f"{name} {'ok  ' if ok else 'FAIL'} ({r.end_state}, {r.collisions} coll., {r.plans} plans)")
            print(f"{family} run {k}: {'; '.join(line)}; Storm P robust {predicted['robust'][-1]:.3f} greedy {predicted['greedy'][-1]:.3f}",
                  flush=True)
        rows.append((family, tally, predicted))
    print(f"\nexecution world, noise {args.noise}, {args.runs} runs per family, {args.samples} samples per choice:")
    print(f"  {'family':<9} {'plans':<7} {'success (goal, no collision)':<30} {'Storm P at the start (mean)':<28}")
    for family, tally, predicted in rows:
        for name in ("greedy", "robust"):
            s, n = tally[name]
            mean = statistics.fmean(predicted[name]) if predicted[name] else math.nan
            print(f"  {family:<9} {name:<7} {s:3d}/{n:<3d} = {s / n:6.1%}{'':14} {mean:.3f}")
    print(f"total wall {time.perf_counter() - w0:.0f} s, thread CPU {time.thread_time() - c0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
