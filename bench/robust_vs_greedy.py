"""Robust vs greedy plans in the execution world: how often each reaches the goal
without a collision, beside Storm's predicted probabilities.

Run: ``python bench/robust_vs_greedy.py [--runs 50] [--families doorway clutter]
[--noise harsh] [--samples 30] [--margin 0.1] [--retries 1] [--supervisor-hazard]``. Each run is one layout (family, seed 0,
run k) of the experiment (:func:`runtime.experiment.layouts.make_layout`) driven by the
supervisor in the execution world at the given noise, once with the Configurator's
best-first plans (greedy) and once with :class:`planner.robust.RobustConfigurator`
(Storm's scheduler on a map of ``--samples`` noisy rollouts per choice, the same noise
preset, executed as a policy, replanning robustly). The two conditions of a run meet
the same layout, world and noise seed (paired), and each plan of either condition is
predicted on a probabilistic map sampled with the same seeds.

Success: the robot truly ends within the experiment's success radius of the goal
(ground truth) with no collision episode. Storm's predictions are per plan:
``P[!collision U target]`` with the target of :func:`planner.robust.plan_target`
(the goal within 0.1 m, or, beyond the sensed disc, a frontier as close as the
best-first plan gets); they are set beside the observed rate at which a fresh plan was
carried to its end (the supervisor's ``plan done`` before the next fresh plan; a recall
that continues it counts). Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import statistics
import time
from typing import Any

from planner.configurator import Configurator, PlanResult
from planner.probabilistic import HazardRule, RolloutNoise
from planner.robust import SUPERVISOR_HAZARD, RobustConfigurator, closed_loop_noise
from runtime.experiment.layouts import make_layout
from runtime.experiment.runner import run_once
from runtime.experiment.stats import mcnemar, wilson
from runtime.supervision.machine import Event, SupervisorState


class PredictedGreedy(RobustConfigurator):
    """The best-first plan, unchanged, with Storm's prediction of it on the probabilistic
    map the robust condition samples with the same seeds (the paired prediction)."""

    every_plan = False
    """Predict every plan (else only the first: sampling costs as much as the robust plan)."""

    def plan(self, scan: Any, goal: Any) -> PlanResult:
        if self.predictions and not self.every_plan:
            return Configurator(self.robot, self.cost, self.max_states, self.horizon).plan(scan, goal)
        c = self.sample(scan, goal)
        self.predictions[-1] = (math.nan, c.p_greedy)
        return c.greedy_result


def plan_episodes(report: Any) -> list[tuple[int, bool]]:
    """(index among fresh plans, carried to its end?) for every fresh plan the supervisor
    started executing: an episode runs from its PLANNED to the next fresh PLANNED or the
    end of the run, and is complete when the supervisor reports ``plan done`` (AT_GOAL or
    PLAN_SHORT from EXECUTING) within it."""
    fresh_index = {}
    k = 0
    for n, rec in enumerate(report.plans, 1):
        if not rec.recalled:
            fresh_index[n] = k
            k += 1
    out: list[tuple[int, bool]] = []
    current: int | None = None
    done = False
    for tr in report.transitions:
        if tr.event is Event.PLANNED and "recalled" not in tr.reason:
            if current is not None:
                out.append((current, done))
            n = int(tr.reason.split(":")[0].split()[1])
            current, done = fresh_index.get(n), False
        elif tr.event in (Event.AT_GOAL, Event.PLAN_SHORT) and tr.source is SupervisorState.EXECUTING:
            done = True
    if current is not None:
        out.append((current, done))
    return out


def _ci(s: int, n: int) -> str:
    lo, hi = wilson(s, n)
    return f"{s:3d}/{n:<3d} = {s / n:6.1%} [{lo:5.1%}, {hi:5.1%}]" if n else "  -"


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=50, help="runs per family (default 50)")
    ap.add_argument("--first-run", type=int, default=0, help="first run index (default 0)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--margin", type=float, default=0.1, help="RobustConfigurator's margin (default 0.1)")
    ap.add_argument("--routes", type=int, default=1, help="RobustConfigurator's routes (default 1)")
    ap.add_argument("--frontier-slack", type=float, default=0.03, help="RobustConfigurator's frontier_slack (default 0.03 m)")
    ap.add_argument("--closed-loop-noise", action="store_true",
                    help="sample with planner.robust.closed_loop_noise(NOISE): the terms measured in the world's closed loop")
    ap.add_argument("--no-confirm", action="store_true",
                    help="take the scheduler's deviations without the second look on fresh rollouts (RobustConfigurator(confirm=False))")
    ap.add_argument("--retries", type=int, default=1,
                    help="stops retried in Storm's objective, as the supervisor replans after one (formal.retry; default 1; 0: a stop is final)")
    ap.add_argument("--supervisor-hazard", action="store_true",
                    help="interrupt rollouts with the supervisor's noise allowance (HazardRule.supervisor: deep alarms at once, "
                         "shallow ones when the revolution before raised one; default: any 2 points inside the body)")
    ap.add_argument("--max-time", type=float, default=120.0)
    ap.add_argument("--predict-every-greedy-plan", action="store_true",
                    help="sample a map for every greedy plan too (default: its first plan only; twice the CPU)")
    ap.add_argument("--quiet", action="store_true", help="no line per run")
    args = ap.parse_args(argv)
    w0, c0 = time.perf_counter(), time.thread_time()
    rows = []
    names = ("greedy", "robust")
    for family in args.families:
        ok: dict[str, list[int]] = {name: [] for name in names}
        first: dict[str, list[float]] = {name: [] for name in names}
        per_plan: dict[str, list[tuple[float, bool]]] = {name: [] for name in names}
        cpu: dict[str, float] = {name: 0.0 for name in names}
        decisions: dict[str, int] = {}
        diverged: list[int] = []  # the runs in which the robust condition took a deviation
        for k in range(args.first_run, args.first_run + args.runs):
            layout = make_layout(family, 0, k)
            scene = layout.scene
            line = []
            for name in names:
                kind = PredictedGreedy if name == "greedy" else RobustConfigurator
                rollout_noise = closed_loop_noise(args.noise) if args.closed_loop_noise else args.noise
                conf = kind(samples=args.samples, noise=rollout_noise, seed=1000 * k, margin=args.margin, routes=args.routes,
                            frontier_slack=args.frontier_slack, confirm=not args.no_confirm, retries=args.retries,
                            hazard=HazardRule.supervisor(RolloutNoise.preset(args.noise)) if args.supervisor_hazard else SUPERVISOR_HAZARD)
                if isinstance(conf, PredictedGreedy):
                    conf.every_plan = args.predict_every_greedy_plan
                c1 = time.thread_time()
                r = run_once(scene, "planning", seed=k, run=k, noise=args.noise, configurator=conf, max_time=args.max_time,
                             expect=layout.expect, keep_report=True)
                cpu[name] += time.thread_time() - c1
                success = r.reached_goal and r.collisions == 0
                ok[name].append(int(success))
                preds = [p[0] if name == "robust" else p[1] for p in conf.predictions]
                if preds:
                    first[name].append(preds[0])
                for i, done in plan_episodes(r.report):
                    if i is not None:
                        per_plan[name].append((preds[i] if i < len(preds) else math.nan, done))
                line.append(f"{name} {'ok  ' if success else 'FAIL'} ({r.end_state}, {r.final_distance:.2f} m, {r.collisions} coll., "
                            f"{r.plans} plans, P1 {preds[0] if preds else math.nan:.2f})")
                if name == "robust":
                    for d in conf.decisions:
                        decisions[d] = decisions.get(d, 0) + 1
                    if any(d in ("confirmed", "deviated") for d in conf.decisions):
                        diverged.append(len(ok[name]) - 1)
                        line.append("deviations " + ", ".join(f"{v_r:.2f}>{v_g:.2f}" for v_r, v_g in conf.confirmations
                                                              if v_r > v_g + args.margin) if conf.confirmations else "deviated")
            if not args.quiet:
                print(f"{family} run {k}: {'; '.join(line)}", flush=True)
        rows.append((family, ok, first, per_plan, cpu, decisions, diverged))
    print(f"\nexecution world, noise {args.noise}, runs {args.first_run}..{args.first_run + args.runs - 1} per family "
          f"(paired: same layout, world and seeds), {args.samples} samples per choice, margin {args.margin}, "
          f"routes {args.routes}, frontier slack {args.frontier_slack} m, retries {args.retries}, "
          f"hazard rule {'supervisor (allowance)' if args.supervisor_hazard else 'strict'}, "
          f"rollout noise {'closed-loop ' if args.closed_loop_noise else ''}{args.noise}:")
    print(f"  {'family':<8} {'plans':<7} {'success (goal, no collision) [95% Wilson]':<44} {'Storm P, 1st plan':<18} "
          f"{'Storm P per plan*':<17} {'plans carried to their end [95%]':<36} CPU s/run")
    print("  (* the mean over the plans predicted: every robust plan; the greedy condition's first plans unless "
          "--predict-every-greedy-plan)")
    totals = {name: [0, 0] for name in names}
    for family, ok, first, per_plan, cpu, decisions, diverged in rows:
        for name in names:
            s, n = sum(ok[name]), len(ok[name])
            totals[name][0] += s
            totals[name][1] += n
            pp = per_plan[name]
            completed = sum(int(d) for _, d in pp)
            mean_first = statistics.fmean(first[name]) if first[name] else math.nan
            predicted = [p for p, _ in pp if not math.isnan(p)]
            mean_pp = statistics.fmean(predicted) if predicted else math.nan
            print(f"  {family:<8} {name:<7} {_ci(s, n):<44} {mean_first:<18.3f} {mean_pp:<17.3f} {_ci(completed, len(pp)):<36} "
                  f"{cpu[name] / max(n, 1):.1f}")
        test = mcnemar(ok["greedy"], ok["robust"])
        print(f"  {family:<8} paired: {test}")
        print(f"  {family:<8} robust plans' decisions: {', '.join(f'{k} {v}' for k, v in sorted(decisions.items()))}; "
              f"runs with a deviation taken: {len(diverged)}")
        rescued = [args.first_run + i for i in diverged if ok["robust"][i] > ok["greedy"][i]]
        lost = [args.first_run + i for i in diverged if ok["robust"][i] < ok["greedy"][i]]
        print(f"  {family:<8} of those, robust succeeded where greedy failed in runs {rescued or 'none'}, "
              f"failed where greedy succeeded in runs {lost or 'none'} (every other run is the greedy run itself)")
    for name in names:
        s, n = totals[name]
        print(f"  {'all':<8} {name:<7} {_ci(s, n)}")
    print(f"total wall {time.perf_counter() - w0:.0f} s, thread CPU {time.thread_time() - c0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
