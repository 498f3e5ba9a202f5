"""Calibration of Storm's predictions against the execution world, with the closed-loop model.

Run: ``python bench/calibration.py [--layouts 100] [--families doorway clutter]
[--noise paper harsh] [--samples 30] [--workers K] [--out FILE.json]``. For every layout
(family, seed 0, index k; :func:`clomp.runtime.experiment.layouts.make_layout`, the layouts of
``clomp experiment``) and noise preset, the supervisor drives the layout in the execution
world twice, paired (the same layout, world and noise seeds): with the Configurator's
best-first plans (greedy) and with :class:`clomp.planner.robust.RobustConfigurator` (robust).

Storm's prediction of a run is ``P[!collision U target]`` of its **first plan** on the
probabilistic map of the first scan, in the **closed-loop model**
(:data:`clomp.planner.robust.CLOSED_LOOP_HAZARD`: a rollout the supervisor's check would
interrupt before a contact is a stop, replanned once, not a collision; the robust
planner's objective), beside the same plan's value in the **open-loop model** (the
default map: every contact a collision). The target is
:func:`clomp.planner.robust.plan_target`: the goal within 0.1 m, or, when the goal lies
beyond the sensed disc, a frontier as close as the best-first plan gets; ``goal in
map`` marks the runs whose first best-first plan reaches the goal (only there is the
prediction one of the run's own success; elsewhere it is the chance of the first
plan's progress). Also recorded for the greedy plan: its closed-loop value with 3
replans, and Storm's optimum on the same map (Pmax, 1 replan).

Observed: success = the robot truly ends within the experiment's 0.1 m of the goal with
no collision episode (ground truth); false successes (the supervisor believed the goal
reached, the truth is farther) are counted beside. Prints a calibration table per
noise (bins of the predicted P: n, mean predicted, observed success with a 95 % Wilson
interval, whether the mean lies in it), over every run and over the runs whose goal is
in the first map, and robust vs greedy with the exact McNemar test. Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import statistics
import time
from collections.abc import Iterator
from concurrent.futures import ProcessPoolExecutor
from typing import Any

from clomp.planner.configurator import Configurator, PlanResult
from clomp.planner.robust import CLOSED_LOOP_HAZARD, SUPERVISOR_HAZARD, RobustConfigurator
from clomp.planner.noise import preset_names
from clomp.runtime.experiment.layouts import FAMILIES, make_layout
from clomp.runtime.experiment.runner import run_once
from clomp.runtime.experiment.stats import mcnemar, wilson

NAMES = ("greedy", "robust")
BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0 + 1e-9)


class FirstPlanPredicted(RobustConfigurator):
    """The best-first plans, unchanged; the first one predicted on the closed-loop map
    (this configurator's hazard) and on the open-loop map (the default's), same seeds."""

    def __init__(self, **kw: Any) -> None:
        super().__init__(**kw)
        self.first: dict[str, Any] = {}

    def plan(self, scan: Any, goal: Any) -> PlanResult:
        if self.first:
            return Configurator(self.robot, self.cost, self.max_states, self.horizon).plan(scan, goal)
        from clomp.formal.scheduler import plan_probability, robust_plan

        c = self.sample(scan, goal)
        open_loop = RobustConfigurator(self.robot, samples=self.samples, noise=self.noise, seed=self.seed,
                                       hazard=SUPERVISOR_HAZARD, retries=self.retries)
        o = open_loop.sample(scan, goal)
        self.first = {"closed": c.p_greedy, "open": o.p_greedy, "goal_in_map": bool(c.greedy_result.reached_goal),
                      "closed_3": plan_probability(c.pm.map, c.greedy, c.target, 3),
                      "closed_max": robust_plan(c.pm.map, c.target, retries=self.retries).probability,
                      "target_is_goal": _goal_target(c)}
        return c.greedy_result


def _goal_target(c: Any) -> bool:
    """Whether the choice's target is the goal itself (not a frontier short of it)."""
    g = c.greedy_result.goal
    return any(c.pm.map[i].end.distance_to(g.x, g.y) <= 0.1 + 1e-9 for i in c.target)


def run_pair(family: str, k: int, noise: str, samples: int, max_time: float) -> dict[str, Any]:
    """Layout ``k`` of ``family`` at ``noise`` in both conditions (paired); plain data."""
    layout = make_layout(family, 0, k)
    out: dict[str, Any] = {"family": family, "run": k, "noise": noise}
    for name in NAMES:
        conf: RobustConfigurator
        if name == "greedy":
            conf = FirstPlanPredicted(samples=samples, noise=noise, seed=1000 * k, hazard=CLOSED_LOOP_HAZARD)
        else:
            conf = RobustConfigurator(samples=samples, noise=noise, seed=1000 * k, hazard=CLOSED_LOOP_HAZARD)
        c1 = time.thread_time()
        r = run_once(layout.scene, "planning", seed=k, run=k, noise=noise, configurator=conf, max_time=max_time,
                     expect=layout.expect)
        rec: dict[str, Any] = {"ok": int(r.reached_goal and r.collisions == 0), "false_success": int(r.believed_goal and not r.reached_goal),
                               "collisions": r.collisions, "end": r.end_state, "distance": r.final_distance,
                               "plans": r.plans, "cpu": time.thread_time() - c1}
        if isinstance(conf, FirstPlanPredicted):
            rec.update(conf.first)
        else:
            rec["closed"] = conf.predictions[0][0] if conf.predictions else math.nan
            rec["decisions"] = list(conf.decisions)
        out[name] = rec
    return out


def _pairs(args: argparse.Namespace) -> Iterator[dict[str, Any]]:
    todo = [(f, k, nz) for nz in args.noise for f in args.families for k in range(args.first, args.first + args.layouts)]
    fn = [args.samples] * len(todo), [args.max_time] * len(todo)
    if args.workers <= 1:
        for f, k, nz in todo:
            yield run_pair(f, k, nz, args.samples, args.max_time)
        return
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent that may hold Storm's threads
    with ProcessPoolExecutor(max_workers=args.workers, mp_context=ctx) as pool:
        yield from pool.map(run_pair, [t[0] for t in todo], [t[1] for t in todo], [t[2] for t in todo], *fn)


def calibration_rows(pred: list[float], ok: list[int]) -> list[dict[str, Any]]:
    """The calibration table of predictions ``pred`` against outcomes ``ok`` (1 = success):
    per bin of :data:`BINS`, n, the mean prediction, the observed rate and its 95 % Wilson
    interval, and whether the mean prediction lies in the interval.

    >>> rows = calibration_rows([0.1, 0.15, 0.9, 0.95], [0, 0, 1, 1])
    >>> [(r["bin"], r["n"], r["observed"], r["inside"]) for r in rows]
    [('0.0-0.2', 2, 0.0, True), ('0.8-1.0', 2, 1.0, True)]
    """
    rows = []
    for lo, hi in zip(BINS, BINS[1:]):
        idx = [i for i, p in enumerate(pred) if not math.isnan(p) and lo <= p < hi]
        if not idx:
            continue
        s, n = sum(ok[i] for i in idx), len(idx)
        mean = statistics.fmean(pred[i] for i in idx)
        w_lo, w_hi = wilson(s, n)
        rows.append({"bin": f"{lo:.1f}-{min(hi, 1.0):.1f}", "n": n, "mean_predicted": mean, "observed": s / n,
                     "successes": s, "wilson": (w_lo, w_hi), "inside": w_lo <= mean <= w_hi})
    return rows


def _print_table(title: str, pred: list[float], ok: list[int]) -> None:
    rows = calibration_rows(pred, ok)
    n_in = sum(r["n"] for r in rows if r["inside"])
    print(f"  {title}: {len(pred)} runs; bins whose mean prediction lies in the observed 95 % interval: "
          f"{sum(r['inside'] for r in rows)} of {len(rows)} ({n_in} of {len(pred)} runs)")
    print(f"    {'bin':<8} {'n':>4} {'mean P':>7}  observed success [95% Wilson]")
    for r in rows:
        lo, hi = r["wilson"]
        print(f"    {r['bin']:<8} {r['n']:>4} {r['mean_predicted']:>7.3f}  {r['successes']:>3}/{r['n']:<3} = {r['observed']:6.1%} "
              f"[{lo:5.1%}, {hi:5.1%}] {'in' if r['inside'] else 'OUT'}")
    if pred:
        brier = statistics.fmean((p - o) ** 2 for p, o in zip(pred, ok))
        print(f"    mean predicted {statistics.fmean(pred):.3f}, observed {sum(ok) / len(ok):.3f}, Brier score {brier:.3f}")


def _summary(pairs: list[dict[str, Any]], noise: str) -> None:
    print(f"\nnoise {noise}:")
    for fam in sorted({p["family"] for p in pairs}):
        fp = [p for p in pairs if p["family"] == fam]
        for name in NAMES:
            s, n = sum(p[name]["ok"] for p in fp), len(fp)
            lo, hi = wilson(s, n)
            false = sum(p[name]["false_success"] for p in fp)
            coll = sum(1 for p in fp if p[name]["collisions"])
            print(f"  {fam:<9} {name:<7} success {s}/{n} = {s / n:.0%} [{lo:.0%}, {hi:.0%}], false successes {false}, "
                  f"runs with a collision {coll}, mean Storm P of the 1st plan (closed loop) "
                  f"{statistics.fmean(p[name]['closed'] for p in fp):.3f}")
        t = mcnemar([p["greedy"]["ok"] for p in fp], [p["robust"]["ok"] for p in fp])
        dev = sum(1 for p in fp if any(d == "confirmed" for d in p["robust"]["decisions"]))
        print(f"  {fam:<9} paired: only greedy {t['b10']}, only robust {t['b01']}, McNemar p = {t['p']:.3g}; "
              f"robust runs with a confirmed deviation: {dev}")
    g = [p["greedy"] for p in pairs]
    ok = [r["ok"] for r in g]
    _print_table("greedy runs, Storm P of the first plan, closed-loop model", [r["closed"] for r in g], ok)
    _print_table("greedy runs, the same plan, closed-loop model with 3 replans", [r["closed_3"] for r in g], ok)
    _print_table("greedy runs, Storm's optimum on the first map (Pmax, closed loop, 1 replan)", [r["closed_max"] for r in g], ok)
    _print_table("greedy runs, the same plan, open-loop model (every contact a collision)", [r["open"] for r in g], ok)
    inmap = [r for r in g if r["goal_in_map"]]
    _print_table("greedy runs whose first (best-first) plan reaches the goal, closed-loop model", [r["closed"] for r in inmap],
                 [r["ok"] for r in inmap])
    _print_table("the same runs, open-loop model", [r["open"] for r in inmap], [r["ok"] for r in inmap])
    rb = [p["robust"] for p in pairs]
    _print_table("robust runs, Storm P of the first plan, closed-loop model", [r["closed"] for r in rb], [r["ok"] for r in rb])


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--layouts", type=int, default=100, help="layouts per family and noise (default 100)")
    ap.add_argument("--first", type=int, default=0, help="first layout index (default 0)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", nargs="+", default=["paper", "harsh"])
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--max-time", type=float, default=120.0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", help="also write every run's record as JSON to this file")
    args = ap.parse_args(argv)
    if args.layouts < 1 or args.first < 0 or args.samples < 1:
        ap.error("--layouts and --samples must be >= 1, --first >= 0")
    unknown = [f for f in args.families if f not in FAMILIES] + [n for n in args.noise if n not in preset_names()]
    if unknown:
        ap.error(f"unknown family or noise preset: {', '.join(unknown)} (families: {', '.join(FAMILIES)}; "
                 f"noise: {', '.join(preset_names())})")
    w0 = time.perf_counter()
    pairs: list[dict[str, Any]] = []
    for p in _pairs(args):
        pairs.append(p)
        g, r = p["greedy"], p["robust"]
        print(f"{p['noise']} {p['family']} {p['run']}: greedy {'ok  ' if g['ok'] else 'FAIL'} P {g['closed']:.2f} "
              f"(open {g['open']:.2f}, 3 replans {g['closed_3']:.2f}, max {g['closed_max']:.2f}{', goal in map' if g['goal_in_map'] else ''}), robust {'ok  ' if r['ok'] else 'FAIL'} "
              f"P {r['closed']:.2f}", flush=True)
    if args.out:
        with open(args.out, "w", encoding="utf-8") as fh:
            json.dump(pairs, fh, indent=1)
    print(f"\nexecution world, layouts {args.first}..{args.first + args.layouts - 1} of {', '.join(args.families)}, seed 0, "
          f"{args.samples} samples per choice, a stop replanned once; wall {time.perf_counter() - w0:.0f} s, "
          f"CPU of the runs {sum(p[n]['cpu'] for p in pairs for n in NAMES):.0f} s")
    for nz in args.noise:
        _summary([p for p in pairs if p["noise"] == nz], nz)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
