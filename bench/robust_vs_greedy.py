"""Robust vs greedy plans in the execution world: how often each reaches the goal
without a collision, beside Storm's predicted probabilities.

Run: ``python bench/robust_vs_greedy.py [--runs 50] [--families doorway clutter]
[--noise harsh] [--samples 30] [--margin 0.1] [--retries 1] [--supervisor-hazard] [--workers K]``. Each run is one layout (family, seed 0,
run k) of the experiment (:func:`clomp.runtime.experiment.layouts.make_layout`) driven by the
supervisor in the execution world at the given noise, once with the Configurator's
best-first plans (greedy) and once with :class:`clomp.planner.robust.RobustConfigurator`
(Storm's scheduler on a map of ``--samples`` noisy rollouts per choice, the same noise
preset, executed as a policy, replanning robustly). The two conditions of a run meet
the same layout, world and noise seed (paired), and each plan of either condition is
predicted on a probabilistic map sampled with the same seeds.

Success: the robot truly ends within the experiment's success radius of the goal
(ground truth) with no collision episode. Storm's predictions are per plan:
``P[!collision U target]`` with the target of :func:`clomp.planner.robust.plan_target`
(the goal within 0.1 m, or, beyond the sensed disc, a frontier as close as the
best-first plan gets); they are set beside the observed rate at which a fresh plan was
carried to its end (the supervisor's ``plan done`` before the next fresh plan; a recall
that continues it counts). Prints figures; asserts nothing.
"""

from __future__ import annotations

import argparse
import math
import multiprocessing
import statistics
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from clomp.planner.configurator import Configurator, PlanResult
from clomp.planner.probabilistic import HazardRule, RolloutNoise
from clomp.planner.robust import SUPERVISOR_HAZARD, RobustConfigurator
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.experiment.runner import run_once
from clomp.runtime.experiment.stats import mcnemar, wilson
from clomp.runtime.supervision.states import Event, SupervisorState

NAMES = ("greedy", "robust")


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


def _ending(reason: str) -> str:
    """The kind of a DISAGREE that interrupted a plan."""
    if reason.startswith("plan check:"):
        return "check: meets an obstacle" if "meets an obstacle" in reason else "check: would end off the map"
    if "collision imminent" in reason or "did not predict" in reason:
        return "hazard"
    if "far from the map's prediction" in reason:
        return "task ended off the map"
    if "overran" in reason:
        return "task overran"
    return reason.split(":")[0][:40]


def plan_episodes(report: Any) -> list[tuple[int | None, bool, str]]:
    """(index among fresh plans, carried to its end?, how it ended) for every fresh plan
    the supervisor started executing: an episode runs from its PLANNED to the next fresh
    PLANNED or the end of the run, and is complete when the supervisor reports ``plan
    done`` (AT_GOAL or PLAN_SHORT from EXECUTING) within it. How it ended: "done", else
    the kind of the last interruption in it (a plan check of a queued task, the hazard
    test, ...; :func:`_ending`), else "run ended"."""
    fresh_index = {}
    k = 0
    for n, rec in enumerate(report.plans, 1):
        if not rec.recalled:
            fresh_index[n] = k
            k += 1
    out: list[tuple[int | None, bool, str]] = []
    current: int | None = None
    started = done = False
    why = "run ended"
    for tr in report.transitions:
        if tr.event is Event.PLANNED and "recalled" not in tr.reason:
            if started:
                out.append((current, done, "done" if done else why))
            n = int(tr.reason.split(":")[0].split()[1])
            current, started, done, why = fresh_index.get(n), True, False, "run ended"
        elif tr.event in (Event.AT_GOAL, Event.PLAN_SHORT) and tr.source is SupervisorState.EXECUTING:
            done = True
        elif tr.event is Event.DISAGREE:
            why = _ending(tr.reason)
    if started:
        out.append((current, done, "done" if done else why))
    return out


def _ci(s: int, n: int) -> str:
    lo, hi = wilson(s, n)
    return f"{s:3d}/{n:<3d} = {s / n:6.1%} [{lo:5.1%}, {hi:5.1%}]" if n else "  -"


def _configurator(name: str, k: int, args: argparse.Namespace) -> RobustConfigurator:
    kind = PredictedGreedy if name == "greedy" else RobustConfigurator
    rollout_noise = RolloutNoise.preset(args.noise) if args.preset_noise else args.noise  # a name: closed-loop terms
    conf = kind(samples=args.samples, noise=rollout_noise, seed=1000 * k, margin=args.margin, routes=args.routes,
                frontier_slack=args.frontier_slack, confirm=not args.no_confirm, retries=args.retries, carry=not args.no_carry,
                hazard=HazardRule.supervisor(RolloutNoise.preset(args.noise)) if args.supervisor_hazard else SUPERVISOR_HAZARD)
    if isinstance(conf, PredictedGreedy):
        conf.every_plan = args.predict_every_greedy_plan
    return conf


def run_pair(family: str, k: int, args: argparse.Namespace) -> dict[str, Any]:
    """Run ``k`` of ``family`` in both conditions (paired: the same layout, world and
    seeds); everything the summary needs, in plain data (a worker process returns it).
    Deterministic: it depends on ``family``, ``k`` and ``args`` alone."""
    layout = make_layout(family, 0, k)
    out: dict[str, Any] = {"family": family, "run": k, "line": []}
    for name in NAMES:
        conf = _configurator(name, k, args)
        c1 = time.thread_time()
        r = run_once(layout.scene, "planning", seed=k, run=k, noise=args.noise, configurator=conf, max_time=args.max_time,
                     expect=layout.expect, keep_report=True)
        cpu = time.thread_time() - c1
        success = r.reached_goal and r.collisions == 0
        preds = [p[0] if name == "robust" else p[1] for p in conf.predictions]
        ep = [(i, done, why) for i, done, why in plan_episodes(r.report) if i is not None]
        episodes = [(preds[i] if i < len(preds) else math.nan, done) for i, done, _ in ep]
        rec: dict[str, Any] = {"ok": int(success), "first": preds[0] if preds else None, "per_plan": episodes, "cpu": cpu,
                               "endings": [why for _, _, why in ep],
                               "decisions": list(conf.decisions) if name == "robust" else [], "diverged": False}
        out["line"].append(f"{name} {'ok  ' if success else 'FAIL'} ({r.end_state}, {r.final_distance:.2f} m, {r.collisions} coll., "
                           f"{r.plans} plans, P1 {preds[0] if preds else math.nan:.2f})")
        if name == "robust" and any(d in ("confirmed", "deviated") for d in conf.decisions):
            rec["diverged"] = True
            out["line"].append("deviations " + ", ".join(f"{v_r:.2f}>{v_g:.2f}" for v_r, v_g in conf.confirmations
                                                         if v_r > v_g + args.margin) if conf.confirmations else "deviated")
        out[name] = rec
    return out


def _pairs(args: argparse.Namespace) -> Iterator[dict[str, Any]]:
    """Every run's pair, in the order of (family, run) whatever ``args.workers``."""
    todo = [(family, k) for family in args.families for k in range(args.first_run, args.first_run + args.runs)]
    if args.workers <= 1:
        for family, k in todo:
            yield run_pair(family, k, args)
        return
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent that may hold Storm's threads
    with ProcessPoolExecutor(max_workers=args.workers, mp_context=ctx) as pool:
        yield from pool.map(run_pair, [f for f, _ in todo], [k for _, k in todo], [args] * len(todo))


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    """The command line's options (see the module docstring)."""
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--runs", type=int, default=50, help="runs per family (default 50)")
    ap.add_argument("--first-run", type=int, default=0, help="first run index (default 0)")
    ap.add_argument("--workers", type=int, default=1,
                    help="processes running pairs at once (default 1; runs are independent, the figures do not depend on it)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--margin", type=float, default=0.1, help="RobustConfigurator's margin (default 0.1)")
    ap.add_argument("--routes", type=int, default=1, help="RobustConfigurator's routes (default 1)")
    ap.add_argument("--frontier-slack", type=float, default=0.03, help="RobustConfigurator's frontier_slack (default 0.03 m)")
    ap.add_argument("--preset-noise", action="store_true",
                    help="sample with the preset's own terms (default: clomp.planner.robust.rollout_noise(NOISE), the terms measured "
                         "in the world's closed loop)")
    ap.add_argument("--no-confirm", action="store_true",
                    help="take the scheduler's deviations without the second look on fresh rollouts (RobustConfigurator(confirm=False))")
    ap.add_argument("--retries", type=int, default=1,
                    help="stops retried in Storm's objective, as the supervisor replans after one (clomp.formal.retry; default 1; 0: a stop is final)")
    ap.add_argument("--supervisor-hazard", action="store_true",
                    help="interrupt rollouts with the supervisor's noise allowance (HazardRule.supervisor: deep alarms at once, "
                         "shallow ones when the revolution before raised one; default: any 2 points inside the body)")
    ap.add_argument("--no-carry", action="store_true",
                    help="start every rollout of a choice at the state's recorded end (sample_map(carry=False)); default: each "
                         "noisy world carries its true pose from task to task")
    ap.add_argument("--max-time", type=float, default=120.0)
    ap.add_argument("--predict-every-greedy-plan", action="store_true",
                    help="sample a map for every greedy plan too (default: its first plan only; twice the CPU)")
    ap.add_argument("--quiet", action="store_true", help="no line per run")
    args = ap.parse_args(argv)
    if args.runs < 1 or args.first_run < 0 or args.workers < 0:
        ap.error("--runs must be >= 1, --first-run and --workers >= 0")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    w0, c0 = time.perf_counter(), time.thread_time()
    by_family: dict[str, list[dict[str, Any]]] = {f: [] for f in args.families}
    for pair in _pairs(args):
        by_family[pair["family"]].append(pair)
        if not args.quiet:
            print(f"{pair['family']} run {pair['run']}: {'; '.join(pair['line'])}", flush=True)
    print(f"\nexecution world, noise {args.noise}, runs {args.first_run}..{args.first_run + args.runs - 1} per family "
          f"(paired: same layout, world and seeds), {args.samples} samples per choice, margin {args.margin}, "
          f"routes {args.routes}, frontier slack {args.frontier_slack} m, retries {args.retries}, "
          f"hazard rule {'supervisor (allowance)' if args.supervisor_hazard else 'strict'}, "
          f"rollout noise {'preset' if args.preset_noise else 'closed-loop'} {args.noise}, "
          f"poses {'reset at each state' if args.no_carry else 'carried'}, workers {args.workers}:")
    print(f"  {'family':<8} {'plans':<7} {'success (goal, no collision) [95% Wilson]':<44} {'Storm P, 1st plan':<18} "
          f"{'Storm P per plan*':<17} {'plans carried to their end [95%]':<36} CPU s/run")
    print("  (* the mean over the plans predicted: every robust plan; the greedy condition's first plans unless "
          "--predict-every-greedy-plan)")
    totals = {name: [0, 0] for name in NAMES}
    cpu_total = 0.0
    for family, pairs in by_family.items():
        ok = {name: [p[name]["ok"] for p in pairs] for name in NAMES}
        for name in NAMES:
            s, n = sum(ok[name]), len(ok[name])
            totals[name][0] += s
            totals[name][1] += n
            pp = [e for p in pairs for e in p[name]["per_plan"]]
            completed = sum(int(d) for _, d in pp)
            first = [p[name]["first"] for p in pairs if p[name]["first"] is not None]
            mean_first = statistics.fmean(first) if first else math.nan
            predicted = [q for q, _ in pp if not math.isnan(q)]
            mean_pp = statistics.fmean(predicted) if predicted else math.nan
            cpu = sum(p[name]["cpu"] for p in pairs)
            cpu_total += cpu
            print(f"  {family:<8} {name:<7} {_ci(s, n):<44} {mean_first:<18.3f} {mean_pp:<17.3f} {_ci(completed, len(pp)):<36} "
                  f"{cpu / max(n, 1):.1f}")
        for name in NAMES:
            endings: dict[str, int] = {}
            for p in pairs:
                for why in p[name]["endings"]:
                    endings[why] = endings.get(why, 0) + 1
            total = sum(endings.values())
            print(f"  {family:<8} {name:<7} how its {total} fresh plans ended: "
                  + ", ".join(f"{k} {v} ({v / total:.0%})" for k, v in sorted(endings.items(), key=lambda kv: -kv[1])))
        test = mcnemar(ok["greedy"], ok["robust"])
        print(f"  {family:<8} paired: {test}")
        decisions: dict[str, int] = {}
        for p in pairs:
            for d in p["robust"]["decisions"]:
                decisions[d] = decisions.get(d, 0) + 1
        diverged = [p for p in pairs if p["robust"]["diverged"]]
        print(f"  {family:<8} robust plans' decisions: {', '.join(f'{k} {v}' for k, v in sorted(decisions.items()))}; "
              f"runs with a deviation taken: {len(diverged)}")
        rescued = [p["run"] for p in diverged if p["robust"]["ok"] > p["greedy"]["ok"]]
        lost = [p["run"] for p in diverged if p["robust"]["ok"] < p["greedy"]["ok"]]
        print(f"  {family:<8} of those, robust succeeded where greedy failed in runs {rescued or 'none'}, "
              f"failed where greedy succeeded in runs {lost or 'none'} (every other run is the greedy run itself)")
    for name in NAMES:
        s, n = totals[name]
        print(f"  {'all':<8} {name:<7} {_ci(s, n)}")
    print(f"total wall {time.perf_counter() - w0:.0f} s; thread CPU of the runs {cpu_total:.0f} s "
          f"(summed over the workers), of this process {time.thread_time() - c0:.0f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
