"""Calibration of Storm's predictions against the execution world, with the closed-loop model.

Run: ``python bench/calibration.py [--layouts 100] [--families doorway clutter]
[--noise paper harsh] [--samples 30] [--conditions greedy robust] [--workers K]
[--out FILE.jsonl [--resume]]`` (``--resume``: in stages, leaving out the layouts
``--out`` holds; each record is written as its run ends), and ``python bench/calibration.py --summary FILE.jsonl …`` for the
tables of runs already made. For every layout (family, seed 0, index k;
:func:`clomp.runtime.experiment.layouts.make_layout`, the layouts of ``clomp experiment``)
and noise preset, the supervisor drives the layout in the execution world with the
Configurator's best-first plans (greedy) and, paired (the same layout, world and noise
seeds), with :class:`clomp.planner.robust.RobustConfigurator` (robust).

Storm's prediction of a greedy run is ``P[!collision U target]`` of its **first plan** on
the probabilistic map of the first scan sampled as the closed loop
(:data:`clomp.planner.robust.CLOSED_LOOP_HAZARD`: a rollout the supervisor's check would
interrupt before a contact is a stop, not a collision), in several models of what the
loop does after an interruption (:data:`PREDICTIONS`: the replans the robust planner
assumes, the supervisor's patience, Storm's optimum on the same map, …). The map, the
plan and the target are stored with each run, so the predictions are computed again
from the records (``--summary``) when a model changes, without driving the world again.
The target is :func:`clomp.planner.robust.plan_target`: the goal within 0.1 m, or, when
the goal lies beyond the sensed disc, a frontier as close as the best-first plan gets;
``goal_in_map`` marks the runs whose first best-first plan reaches the goal (only there
is the prediction one of the run's own success).

Cost: a robust run samples a map at every plan (about ten times a greedy run's cost),
so the calibration (greedy runs) and the paired comparison (robust runs) can be run
apart (``--conditions``) and merged by ``--summary``; a robust run paired with a greedy
one in the same process reuses the greedy run's first map (the same scan and seed).
Each run's record is appended to ``--out`` as one JSON line as soon as it is done, and
the layouts are taken in the order k = 0, 1, … across families and noise presets, so a
run stopped early leaves balanced samples.

Observed: success = the robot truly ends within the experiment's 0.1 m of the goal with
no collision episode (ground truth); false successes (the supervisor believed the goal
reached, the truth is farther) are counted beside. Prints a calibration table per noise
and prediction (bins of the predicted P: n, mean predicted, observed success with a 95 %
Wilson interval, whether the mean lies in it), and robust vs greedy with the exact
McNemar test. The pooled tables are of the reaching families only (a cul-de-sac's success is a
safe ``UNREACHABLE``, another event: per family only); at a preset whose world pushes the
robot, the runs it pushed and those it did not are tabled apart too. Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import multiprocessing
import statistics
import os
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from concurrent.futures import ProcessPoolExecutor, as_completed
from typing import Any

from clomp.planner.configurator import PlanResult
from clomp.planner.robust import CLOSED_LOOP_HAZARD, SUPERVISOR_HAZARD, RobustChoice, RobustConfigurator
from clomp.planner.noise import preset_names
from clomp.runtime.experiment.layouts import FAMILIES, make_layout
from clomp.runtime.experiment.runner import run_once
from clomp.runtime.experiment.stats import mcnemar, wilson
from rollout_calibration import task_errors

NAMES = ("greedy", "robust")
BINS = (0.0, 0.2, 0.4, 0.6, 0.8, 1.0 + 1e-9)
PUSH_JUMP = 0.04
"""A step of the true path (0.1 s) longer than this is a push (:func:`pushes`)."""
PATIENCE = 6
"""The supervisor's patience (:class:`clomp.runtime.supervision.config.SupervisorConfig`):
plans in a row that come no closer before it gives up."""


def _plan_p(replans: int) -> Callable[[Any, Any, set[int]], float]:
    def p(cmap: Any, plan: Any, target: set[int]) -> float:
        from clomp.formal.scheduler import plan_probability

        return plan_probability(cmap, plan, target, replans)
    return p


def _optimum(cmap: Any, plan: Any, target: set[int]) -> float:
    from clomp.formal.scheduler import robust_plan

    return robust_plan(cmap, target, retries=1).probability


def _before(cmap: Any, plan: Any, target: set[int]) -> float:
    """1 replan, on the target rule before the fix (:func:`leaf_target`)."""
    from clomp.formal.scheduler import plan_probability

    return plan_probability(cmap, plan, leaf_target(cmap, target), 1)


def leaf_target(cmap: Any, target: set[int]) -> set[int]:
    """The target rule :func:`clomp.planner.robust.plan_target` had before it was fixed, for
    comparison: the goal (within 0.1 m) whenever one outcome ends there, else the free
    *leaves* as close as the best-first plan's end (0.03 m slack): the leaves of the
    present rule's ``target`` when it is a frontier's."""
    goal = cmap.goal
    reach, q0 = cmap.reachable(), cmap.initial.ident
    free = [s for s in cmap.states() if s.ident in reach and s.ident != q0 and not s.interrupted]
    near = {s.ident for s in free if s.end.distance_to(goal.x, goal.y) <= 0.1}
    return near or {q for q in target if not cmap.out_transitions(q)}


PREDICTIONS: dict[str, Callable[[Any, Any, set[int]], float]] = {
    "closed loop, 1 replan, the target rule before the fix (leaves only; the goal once one outcome gets there)": _before,
    "closed loop, 1 replan (the robust planner's objective)": _plan_p(1),
    "closed loop, 3 replans": _plan_p(3),
    f"closed loop, {PATIENCE} replans (the supervisor's patience)": _plan_p(PATIENCE),
    "Storm's optimum on the same map (1 replan)": _optimum,
}
"""The predictions of a greedy run's first plan, from its stored map, plan and target."""


class FirstPlanPredicted(RobustConfigurator):
    """The best-first plans, unchanged; the first plan's map sampled as the closed loop
    (this configurator's hazard) and kept (``first``, ``choice``), with the open-loop
    map's prediction beside it when ``open_loop``.

    The first planning step is every call on the first scan: a search that spends its
    budget is searched again deeper, and an empty plan again with REVERSE, by copies of
    this configurator (:func:`clomp.planner.deepening.plan_deepening`), so the record is
    kept in dicts the copies share and the prediction is of the plan the supervisor
    runs (before, the first, shallow search's: a plan the robot never drove, and the
    copies planned without ``recovery``, so a bench run never backed off)."""

    def __init__(self, open_loop: bool = False, **kw: Any) -> None:
        super().__init__(**kw)
        self.open_loop = open_loop
        self.first: dict[str, Any] = {}
        self.shared: dict[str, Any] = {}

    @property
    def choice(self) -> RobustChoice | None:
        """The first sampled choice (the first scan at the first budget): what a paired
        robust run's first :meth:`RobustConfigurator.sample` reuses."""
        return self.shared.get("choice")

    @property
    def scan(self) -> Any:
        return self.shared.get("scan")

    def plan(self, scan: Any, goal: Any) -> PlanResult:
        import numpy as np

        sh = self.shared
        if "scan" in sh and not np.array_equal(np.asarray(scan), sh["scan"]):
            sh["closed"] = True  # a new scan: the first step is over
        if sh.get("closed"):
            return self._plain().plan(scan, goal)
        c = self.sample(scan, goal)
        sh.setdefault("choice", c)
        sh["scan"] = np.asarray(scan)
        self.first.clear()
        self.first.update({"closed": c.p_greedy, "goal_in_map": bool(c.greedy_result.reached_goal),
                           "target_is_goal": _goal_target(c), "map": c.pm.map.to_dict(), "plan": list(c.greedy.states),
                           "target": sorted(c.target), "goal": [c.greedy_result.goal.x, c.greedy_result.goal.y],
                           "nominal_end": c.greedy_result.map[c.greedy_result.plan.end].end.as_list(),
                           "first_stop": c.greedy_result.stop_reason, "first_states": self.max_states,
                           "first_recovery": self.recovery,
                           "scan": [[round(float(x), 5), round(float(y), 5)] for x, y in scan]})
        if self.open_loop:
            o = RobustConfigurator(self.robot, samples=self.samples, noise=self.noise, seed=self.seed,
                                   hazard=SUPERVISOR_HAZARD, retries=self.retries).sample(scan, goal)
            self.first["open"] = o.p_greedy
        return c.greedy_result


class Reusing(RobustConfigurator):
    """The robust planner, whose first map is ``first``'s when its first scan is the one
    ``first`` sampled (the same seed and settings: the same map, sampled once)."""

    def __init__(self, first: FirstPlanPredicted | None, **kw: Any) -> None:
        super().__init__(**kw)
        self.reuse = first

    def sample(self, scan: Any, goal: Any) -> RobustChoice:
        import numpy as np

        f = self.reuse
        self.reuse = None
        if f is not None and f.choice is not None and self._calls == 0 and np.array_equal(np.asarray(scan), np.asarray(f.scan)):
            self._calls += 1
            self.last_probabilities = (f.choice.robust.probability, f.choice.p_greedy)
            self.predictions.append(self.last_probabilities)
            return f.choice
        return super().sample(scan, goal)


def _goal_target(c: Any) -> bool:
    """Whether the choice's target is the goal itself (not a frontier short of it)."""
    g = c.greedy_result.goal
    return any(c.pm.map[i].end.distance_to(g.x, g.y) <= 0.1 + 1e-9 for i in c.target)


def run_pair(family: str, k: int, noise: str, samples: int, max_time: float, conditions: tuple[str, ...] = NAMES,
             open_loop: bool = False) -> dict[str, Any]:
    """Layout ``k`` of ``family`` at ``noise`` in each of ``conditions`` (paired); plain data."""
    layout = make_layout(family, 0, k)
    out: dict[str, Any] = {"family": family, "run": k, "noise": noise, "samples": samples}
    first: FirstPlanPredicted | None = None
    for name in conditions:
        kw = dict(samples=samples, noise=noise, seed=1000 * k, hazard=CLOSED_LOOP_HAZARD)
        conf: RobustConfigurator
        if name == "greedy":
            conf = first = FirstPlanPredicted(open_loop=open_loop, **kw)
        else:
            conf = Reusing(first, **kw)
        c1 = time.thread_time()
        w1 = time.perf_counter()
        fd, log = tempfile.mkstemp(suffix=".jsonl")
        os.close(fd)
        try:
            r = run_once(layout.scene, "planning", seed=k, run=k, noise=noise, configurator=conf, max_time=max_time,
                         expect=layout.expect, log=log)
            with open(log, encoding="utf-8") as fh:
                errors = task_errors([json.loads(line) for line in fh])
        finally:
            os.unlink(log)
        rec: dict[str, Any] = {"ok": int(r.reached_goal and r.collisions == 0), "false_success": int(r.believed_goal and not r.reached_goal),
                               "collisions": r.collisions, "end": r.end_state, "distance": r.final_distance,
                               "plans": r.plans, "cpu": time.thread_time() - c1, "wall": time.perf_counter() - w1}
        rec.update(diagnosis(r, errors))
        if isinstance(conf, FirstPlanPredicted):
            rec.update(conf.first or {"closed": math.nan})  # no plan at all: no prediction
        else:
            rec["closed"] = conf.predictions[0][0] if conf.predictions else math.nan
            rec["decisions"] = list(conf.decisions)
        out[name] = rec
    return out


def pushes(path: list[tuple[float, float]], times: list[float], jump: float = PUSH_JUMP) -> list[float]:
    """The times at which the true path jumps by more than ``jump`` m between two of its
    points (0.1 s apart): a push (its kick is 1.1-2.2 m/s at ``harsh``; the wheels drive
    at most 0.1 m/s). The world keeps its pushes; the run's result does not.

    >>> pushes([(0.0, 0.0), (0.01, 0.0), (0.15, 0.0), (0.16, 0.0)], [0.0, 0.1, 0.2, 0.3])
    [0.1]
    """
    out: list[float] = []
    for i in range(1, min(len(path), len(times))):
        if math.dist(path[i - 1], path[i]) > jump and not (out and times[i - 1] - out[-1] <= 0.5):
            out.append(times[i - 1])
    return out


def diagnosis(r: Any, errors: dict[str, list[float]]) -> dict[str, Any]:
    """What a run's record keeps for reading its failure later: the pushes (times), the
    contact episodes (start, end, depth, brush), the estimate's error at the end (m), and
    the tasks' end errors (truth against estimate, :func:`rollout_calibration.task_errors`:
    what the closed loop's rollout terms are fitted to)."""
    est = r.estimate[-1] if r.estimate else None
    end = r.path[-1] if r.path else None
    return {"pushes": pushes(r.path, r.times),
            "episodes": [[e.start_s, e.end_s, e.max_penetration_m, e.brush] for e in r.episodes],
            "estimate_error": math.dist(est, end) if est is not None and end is not None else math.nan,
            "task_errors": errors, "time": r.time_s}


def _todo(args: argparse.Namespace) -> list[tuple[str, int, str]]:
    """(family, k, noise) in the order k = first, first + 1, …: a run stopped early is balanced.
    With ``--resume``, the layouts whose every asked condition ``--out`` already holds are left out."""
    todo = [(f, k, nz) for k in range(args.first, args.first + args.layouts) for nz in args.noise for f in args.families]
    if getattr(args, "resume", False) and args.out and os.path.exists(args.out):
        held = done(read_records([args.out]), tuple(args.conditions))
        todo = [t for t in todo if (t[2], t[0], t[1]) not in held]
    return todo


def done(pairs: list[dict[str, Any]], conditions: tuple[str, ...]) -> set[tuple[str, str, int]]:
    """(noise, family, layout) of the records ``pairs`` that hold a run of every one of ``conditions``.

    >>> sorted(done([{"noise": "harsh", "family": "u-trap", "run": 3, "greedy": {}},
    ...              {"noise": "paper", "family": "u-trap", "run": 3, "robust": {}}], ("greedy",)))
    [('harsh', 'u-trap', 3)]
    """
    return {(p["noise"], p["family"], p["run"]) for p in pairs if all(c in p for c in conditions)}


def _pairs(args: argparse.Namespace) -> Iterator[dict[str, Any]]:
    todo = _todo(args)
    conds = tuple(args.conditions)
    if args.workers <= 1:
        for f, k, nz in todo:
            yield run_pair(f, k, nz, args.samples, args.max_time, conds, args.open_loop)
        return
    ctx = multiprocessing.get_context("spawn")  # no fork of a parent that may hold Storm's threads
    with ProcessPoolExecutor(max_workers=args.workers, mp_context=ctx) as pool:
        futures = [pool.submit(run_pair, f, k, nz, args.samples, args.max_time, conds, args.open_loop) for f, k, nz in todo]
        for fut in as_completed(futures):  # as each is done: a run stopped early keeps every finished record
            yield fut.result()


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


def predictions(rec: dict[str, Any]) -> dict[str, float]:
    """Every prediction of :data:`PREDICTIONS` for a greedy run's record (its stored first
    map, plan and target), computed with Storm."""
    from clomp.formal.lts import CognitiveMap
    from clomp.formal.supervisory import Plan

    cmap = CognitiveMap.from_dict(rec["map"])
    plan = Plan(tuple(rec["plan"]))
    return {name: f(cmap, plan, target_of(rec, cmap)) for name, f in PREDICTIONS.items()}


def target_of(rec: dict[str, Any], cmap: Any) -> set[int]:
    """The first plan's target, :func:`clomp.planner.robust.plan_target` computed anew on
    the stored map and the best-first plan's end (:func:`nominal_end`)."""
    from clomp.formal.model import Disturbance
    from clomp.planner.robust import plan_target

    return plan_target(cmap, nominal_end(rec, cmap), Disturbance.goal(*rec["goal"]))


def nominal_end(rec: dict[str, Any], cmap: Any) -> Any:
    """Where the first best-first plan ends: as recorded, else its last state on the
    stored map, else (a carried plan whose nominal end no rollout reached) planned again
    on the stored scan (the Configurator is deterministic)."""
    from clomp.formal.model import Pose

    if "nominal_end" in rec:
        return Pose.from_list(rec["nominal_end"])
    last = cmap.metadata["nominal_plan"][-1]
    if last in cmap:
        return cmap[last].end
    import numpy as np

    g = RobustConfigurator()._plain().plan(np.asarray(rec["scan"], dtype=float), tuple(rec["goal"]))
    return g.map[g.plan.end].end


def _conditions_table(fp: list[dict[str, Any]], fam: str) -> None:
    for name in NAMES:
        runs = [p[name] for p in fp if name in p]
        if not runs:
            continue
        s, n = sum(r["ok"] for r in runs), len(runs)
        lo, hi = wilson(s, n)
        false = sum(r["false_success"] for r in runs)
        coll = sum(1 for r in runs if r["collisions"])
        ends = {e: sum(1 for r in runs if r["end"] == e) for e in sorted({r["end"] for r in runs})}
        print(f"  {fam:<9} {name:<7} success {s}/{n} = {s / n:.0%} [{lo:.0%}, {hi:.0%}], false successes {false}, "
              f"runs with a collision {coll}; ends {ends}")
    both = [p for p in fp if all(name in p for name in NAMES)]
    if both:
        t = mcnemar([p["greedy"]["ok"] for p in both], [p["robust"]["ok"] for p in both])
        dev = sum(1 for p in both if any(d == "confirmed" for d in p["robust"]["decisions"]))
        print(f"  {fam:<9} paired ({len(both)} layouts): only greedy {t['b10']}, only robust {t['b01']}, McNemar p = {t['p']:.3g}; "
              f"robust runs with a confirmed deviation: {dev}")


def _summary(pairs: list[dict[str, Any]], noise: str) -> None:
    print(f"\nnoise {noise}:")
    for fam in sorted({p["family"] for p in pairs}):
        _conditions_table([p for p in pairs if p["family"] == fam], fam)
    # the pooled tables are of reaching the goal: a family whose goal is unreachable (cul-de-sac,
    # success a safe UNREACHABLE) is another event and is listed per family only
    reaching = {fam for fam in {p["family"] for p in pairs} if make_layout(fam, 0, 0).expect == "reach"}
    g = [p["greedy"] for p in pairs if "greedy" in p and p["family"] in reaching]
    ok = [r["ok"] for r in g]
    main = "closed loop, 1 replan (the robust planner's objective)"
    for fam in sorted({p["family"] for p in pairs}):
        fg = [p["greedy"] for p in pairs if p["family"] == fam and "greedy" in p]
        _print_table(f"{fam}: greedy runs, first plan: {main}", [r["pred"][main] for r in fg], [r["ok"] for r in fg])
    missed = [(p["family"], p["run"], p["greedy"]) for p in pairs if "greedy" in p and p["greedy"]["pred"][main] >= BINS[-2]
              and not p["greedy"]["ok"]]
    print(f"  runs predicted >= {BINS[-2]} that failed ({len(missed)}; first plan reaches the goal / end / plans / final distance):")
    for fam, k, r in missed:
        print(f"    {fam} {k}: P {r['pred'][main]:.3f}, goal in the first map {r['goal_in_map']}, {r['end']}, "
              f"{r['plans']} plans, {r['distance']:.2f} m, collisions {r['collisions']}, false success {r['false_success']}")
    inmap = [r for r in g if r["goal_in_map"]]
    if any(r["pushes"] for r in g):  # the world pushed some runs: a disturbance no first map holds
        calm = [r for r in g if not r["pushes"]]
        pushed = [r for r in g if r["pushes"]]
        _print_table(f"greedy runs the world did not push, first plan: {main}", [r["pred"][main] for r in calm],
                     [r["ok"] for r in calm])
        _print_table(f"greedy runs the world pushed, first plan: {main}", [r["pred"][main] for r in pushed],
                     [r["ok"] for r in pushed])
    for name in PREDICTIONS:
        _print_table(f"greedy runs, first plan: {name}", [r["pred"][name] for r in g], ok)
        _print_table("  the same, runs whose first (best-first) plan reaches the goal", [r["pred"][name] for r in inmap],
                     [r["ok"] for r in inmap])
    if any("open" in r for r in g):
        op = [r for r in g if "open" in r]
        _print_table("greedy runs, first plan, open-loop model (every contact a collision)", [r["open"] for r in op], [r["ok"] for r in op])
    rb = [p["robust"] for p in pairs if "robust" in p and p["family"] in reaching]
    if rb:
        _print_table("robust runs, Storm P of the first plan, closed-loop model", [r["closed"] for r in rb], [r["ok"] for r in rb])


def read_records(paths: list[str]) -> list[dict[str, Any]]:
    """The runs of JSON-lines files written by ``--out``, merged per (noise, family, layout):
    a layout's greedy and robust runs may come from different files."""
    merged: dict[tuple[str, str, int], dict[str, Any]] = {}
    for path in paths:
        with open(path, encoding="utf-8") as fh:
            for line in fh:
                if line.strip():
                    rec = json.loads(line)
                    merged.setdefault((rec["noise"], rec["family"], rec["run"]), {}).update(rec)
    return [merged[key] for key in sorted(merged)]


def summarise(pairs: list[dict[str, Any]]) -> None:
    """Print the tables of the records ``pairs`` (the predictions computed anew)."""
    unplanned = [p for p in pairs if "greedy" in p and "map" not in p["greedy"]]
    if unplanned:
        print(f"{len(unplanned)} greedy runs made no plan (no prediction): "
              + ", ".join(f"{p['noise']} {p['family']} {p['run']} ({p['greedy']['end']})" for p in unplanned))
    pairs = [p for p in pairs if p not in unplanned]
    for p in pairs:
        if "greedy" in p:
            p["greedy"]["pred"] = predictions(p["greedy"])
    layouts = sorted({(p["family"], p["run"]) for p in pairs})
    print(f"{len(pairs)} layout records ({len(layouts)} layouts of {', '.join(sorted({f for f, _ in layouts}))}); "
          f"greedy runs {sum('greedy' in p for p in pairs)}, robust runs {sum('robust' in p for p in pairs)}")
    for nz in sorted({p["noise"] for p in pairs}, key=lambda n: (n != "paper", n)):
        _summary([p for p in pairs if p["noise"] == nz], nz)


def _parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--layouts", type=int, default=100, help="layouts per family and noise (default 100)")
    ap.add_argument("--first", type=int, default=0, help="first layout index (default 0)")
    ap.add_argument("--families", nargs="+", default=["doorway", "clutter"])
    ap.add_argument("--noise", nargs="+", default=["paper", "harsh"])
    ap.add_argument("--samples", type=int, default=30)
    ap.add_argument("--conditions", nargs="+", default=list(NAMES), choices=NAMES,
                    help="greedy (the calibration), robust (paired with greedy runs of the same layouts), or both (default)")
    ap.add_argument("--open-loop", action="store_true", help="also predict the greedy runs' first plan on the open-loop map")
    ap.add_argument("--max-time", type=float, default=120.0)
    ap.add_argument("--workers", type=int, default=1)
    ap.add_argument("--out", help="append every run's record as a JSON line to this file as it is done")
    ap.add_argument("--resume", action="store_true",
                    help="with --out: skip the layouts whose asked conditions --out already holds (a sweep run in stages)")
    ap.add_argument("--summary", nargs="+", metavar="FILE", help="print the tables of records already written (no runs)")
    args = ap.parse_args(argv)
    if args.layouts < 1 or args.first < 0 or args.samples < 1:
        ap.error("--layouts and --samples must be >= 1, --first >= 0")
    if args.resume and not args.out:
        ap.error("--resume continues the records of --out: give --out FILE")
    unknown = [f for f in args.families if f not in FAMILIES] + [n for n in args.noise if n not in preset_names()]
    if unknown:
        ap.error(f"unknown family or noise preset: {', '.join(unknown)} (families: {', '.join(FAMILIES)}; "
                 f"noise: {', '.join(preset_names())})")
    return args


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    if args.summary:
        try:
            summarise(read_records(args.summary))
        except (OSError, ValueError, KeyError) as exc:
            print(f"calibration.py: error: {exc}", file=sys.stderr)
            return 2
        return 0
    w0 = time.perf_counter()
    pairs: list[dict[str, Any]] = []
    out = open(args.out, "a", encoding="utf-8") if args.out else None
    try:
        for p in _pairs(args):
            pairs.append(p)
            if out is not None:
                out.write(json.dumps(p) + "\n")
                out.flush()
            print(f"{p['noise']} {p['family']} {p['run']}: " + ", ".join(
                f"{n} {'ok  ' if p[n]['ok'] else 'FAIL'} P {p[n]['closed']:.2f} ({p[n]['wall']:.0f} s)" for n in NAMES if n in p), flush=True)
    finally:
        if out is not None:
            out.close()
    print(f"\nexecution world, layouts {args.first}..{args.first + args.layouts - 1} of {', '.join(args.families)}, seed 0, "
          f"{args.samples} samples per choice; wall {time.perf_counter() - w0:.0f} s, "
          f"thread CPU of the runs {sum(p[n]['cpu'] for p in pairs for n in NAMES if n in p):.0f} s")
    summarise(pairs)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
