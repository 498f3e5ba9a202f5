"""What the first plan's model misses: the calibration bench's runs read back.

Run: ``python bench/calibration_model.py FILE.jsonl … [--noise harsh] [--resample current pushes]
[--cache FILE.json] [--fit]`` on the records of ``bench/calibration.py --out``.

- **Causes**: every failed greedy run by how it failed — a contact episode that began
  within :data:`PUSH_WINDOW` s of a push (the world's ``push_rate``), another contact, a
  goal believed reached that is not (false success), ``GOAL_UNCONFIRMED`` off the goal,
  ``UNREACHABLE``, ``HALTED`` — split by the bin of the first plan's P (top bin: P >= 0.8).
- **Resampled predictions**: the first plan's P computed again on a map sampled anew
  from the record's first scan (its budget and recovery as recorded), with a variant of
  the closed-loop model: ``current`` (the rollout terms :func:`clomp.planner.robust.rollout_noise`
  gives now), ``pushes`` (the same with the world's pushes in the rollouts,
  :mod:`clomp.planner.pushes`). Each is a map and Storm per record (about 2 s of CPU);
  ``--cache`` keeps them between calls. Prints the calibration table of each.
- **Fit** (``--fit``): the tasks' end errors of the runs (truth against the supervisor's
  estimate, :func:`rollout_calibration.task_errors`) beside the rollouts' with the
  current closed-loop terms, and the terms that would match their mean and spread (one
  correction step; outliers beyond 4 median deviations, mostly a push during the task,
  left out: the pushes are their own term).

Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
from typing import Any

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from calibration import BINS, _print_table, predictions, read_records  # noqa: E402

PUSH_WINDOW = 1.5
"""A contact episode that begins this soon (s) after a push is the push's."""
MAIN = "closed loop, 1 replan (the robust planner's objective)"
OUTSIDE = ("unconfirmed, off the goal", "false success", "contact after a push")
"""Failures whose cause no first plan's map holds: the estimate's error where the run
ends, and a push into an obstacle (during the first plan's tasks only the ``pushes``
variant holds it)."""


def cause(r: dict[str, Any]) -> str:
    """How a failed run failed (see the module docstring).

    >>> cause({"episodes": [[6.6, 7.6, 0.005, False]], "pushes": [6.5], "end": "GOAL_REACHED", "false_success": 0})
    'contact after a push'
    >>> cause({"episodes": [], "pushes": [], "end": "GOAL_REACHED", "false_success": 1})
    'false success'
    """
    eps = [e for e in r.get("episodes", []) if not e[3]]
    if eps:
        if any(0 <= e[0] - t <= PUSH_WINDOW for e in eps for t in r.get("pushes", [])):
            return "contact after a push"
        return "contact"
    if r["false_success"]:
        return "false success"
    if r["end"] == "GOAL_UNCONFIRMED":
        return "unconfirmed, off the goal"
    return str(r["end"])


def causes(pairs: list[dict[str, Any]]) -> None:
    """Print the failed greedy runs' causes, all runs and the top bin."""
    g = [(p, p["greedy"]) for p in pairs if "greedy" in p and "map" in p["greedy"]]
    for label, keep in (("all", lambda r: True), (f"P >= {BINS[-2]}", lambda r: r["pred"][MAIN] >= BINS[-2])):
        runs = [(p, r) for p, r in g if keep(r)]
        failed = [(p, r) for p, r in runs if not r["ok"]]
        tally: dict[str, int] = {}
        for _, r in failed:
            tally[cause(r)] = tally.get(cause(r), 0) + 1
        pushed = sum(1 for _, r in runs if r.get("pushes"))
        print(f"  {label}: {len(runs)} runs, {len(failed)} failed; runs with a push {pushed}; causes "
              + ", ".join(f"{k} {v}" for k, v in sorted(tally.items(), key=lambda kv: -kv[1])))
        for p, r in failed if label != "all" else []:
            print(f"    {p['family']} {p['run']}: P {r['pred'][MAIN]:.2f}, {cause(r)}, {r['end']} after {r['plans']} plans, "
                  f"{r['distance']:.2f} m off (estimate {r.get('estimate_error', math.nan):.2f} m off the truth), "
                  f"pushes at {[round(t, 1) for t in r.get('pushes', [])]} s of {r.get('time', math.nan):.0f} s")


def resampled(rec: dict[str, Any], noise: str, variant: str, family: str, k: int) -> float:
    """The first plan's P on a map sampled anew from ``rec``'s first scan (see the module)."""
    import numpy as np

    from clomp.planner.pushes import Pushes
    from clomp.planner.robust import CLOSED_LOOP_HAZARD, RobustConfigurator

    pushes = Pushes.preset(noise) if variant == "pushes" else None
    conf = RobustConfigurator(samples=rec.get("samples", 30), noise=noise, seed=1000 * k, hazard=CLOSED_LOOP_HAZARD,
                              pushes=pushes, max_states=rec.get("first_states", 50), recovery=rec.get("first_recovery", False))
    return float(conf.sample(np.asarray(rec["scan"], dtype=float), tuple(rec["goal"])).p_greedy)


def resample_all(pairs: list[dict[str, Any]], variants: list[str], cache_path: str | None) -> None:
    """Add ``rec["pred"]["resampled: V"]`` to every greedy record, from ``cache_path`` where kept."""
    cache: dict[str, float] = {}
    if cache_path and os.path.exists(cache_path):
        with open(cache_path, encoding="utf-8") as fh:
            cache = json.load(fh)
    try:
        for p in pairs:
            r = p.get("greedy")
            if r is None or "scan" not in r:
                continue
            for v in variants:
                key = f"{p['noise']}|{p['family']}|{p['run']}|{v}"
                if key not in cache:
                    cache[key] = resampled(r, p["noise"], v, p["family"], p["run"])
                    _save(cache, cache_path)
                r["pred"][f"resampled: {v}"] = cache[key]
    finally:
        _save(cache, cache_path)


def _save(cache: dict[str, float], path: str | None) -> None:
    if path:
        with open(path + ".part", "w", encoding="utf-8") as fh:
            json.dump(cache, fh)
        os.replace(path + ".part", path)


def _trimmed(values: list[float]) -> list[float]:
    if len(values) < 3:
        return values
    med = statistics.median(values)
    mad = statistics.median(abs(v - med) for v in values) or 1e-9
    return [v for v in values if abs(v - med) <= 4 * 1.4826 * mad]


def fit(pairs: list[dict[str, Any]], noise: str) -> None:
    """Print the world's task errors beside the current closed-loop rollouts' and the
    corrected terms (see the module docstring)."""
    from dataclasses import replace

    from rollout_calibration import rollout_errors

    from clomp.planner.robust import rollout_noise

    world: dict[str, list[float]] = {"turn": [], "length": [], "sideways": []}
    for p in pairs:
        for key, vals in p.get("greedy", {}).get("task_errors", {}).items():
            world[key].extend(vals)
    nz = rollout_noise(noise)
    roll = rollout_errors(nz, 300, 0)
    print(f"  task end errors at {noise}: world (trimmed) vs rollouts with the current terms {nz}")
    new: dict[str, float] = {}
    for key, (mean_t, sd_t) in {"turn": ("turn_mean", "turn_sd"), "length": ("straight_mean", "straight_sd")}.items():
        w = _trimmed(world[key])
        if len(w) < 2:
            continue
        wm, ws = statistics.fmean(w), statistics.pstdev(w)
        rm, rs = statistics.fmean(roll[key]), statistics.pstdev(roll[key])
        old_sd = nz.turn_error_sd if key == "turn" else nz.straight_sd
        new[mean_t] = round(getattr(nz, mean_t) + wm - rm, 3)
        new[sd_t] = round(math.sqrt(max(ws**2 - (rs**2 - old_sd**2), 0.0)), 3)
        print(f"    {key}: world n {len(w)} (of {len(world[key])}) mean {wm:+.4f} sd {ws:.4f}; rollouts mean {rm:+.4f} sd {rs:.4f}")
    w = _trimmed(world["sideways"])
    if len(w) >= 2:
        print(f"    sideways per metre: world n {len(w)} sd {statistics.pstdev(w):.4f}; rollouts sd {statistics.pstdev(roll['sideways']):.4f}")
    if new:
        check = rollout_errors(replace(nz, **new), 300, 0)
        print(f"    corrected terms {new}: rollouts turn {statistics.fmean(check['turn']):+.4f} sd {statistics.pstdev(check['turn']):.4f}, "
              f"length {statistics.fmean(check['length']):+.4f} sd {statistics.pstdev(check['length']):.4f}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+")
    ap.add_argument("--noise", nargs="+", default=["harsh"])
    ap.add_argument("--resample", nargs="*", default=[], choices=["current", "pushes"])
    ap.add_argument("--cache", help="JSON file keeping resampled predictions between calls")
    ap.add_argument("--resample-from", type=float, default=0.0, metavar="P",
                    help="resample only the runs whose first plan's P is at least P (the rest keep no resampled value)")
    ap.add_argument("--fit", action="store_true", help="refit the closed-loop rollout terms to the runs' task errors")
    args = ap.parse_args(argv)
    pairs = [p for p in read_records(args.files) if p["noise"] in args.noise and "map" in p.get("greedy", {})]
    for p in pairs:
        p["greedy"]["pred"] = predictions(p["greedy"])
    if args.resample:
        todo = sorted((p for p in pairs if p["greedy"]["pred"][MAIN] >= args.resample_from), key=lambda p: (p["run"], p["family"]))
        resample_all(todo, args.resample, args.cache)
        pairs = [p for p in pairs if all(f"resampled: {v}" in p["greedy"]["pred"] for v in args.resample)]
    for nz in args.noise:
        sub = [p for p in pairs if p["noise"] == nz]
        per = ", ".join(f"{f} {sum(p['family'] == f for p in sub)}" for f in sorted({p["family"] for p in sub}))
        print(f"noise {nz}: {len(sub)} greedy runs ({per})")
        causes([p for p in sub if p["family"] != "cul-de-sac"])
        g = [p["greedy"] for p in sub if p["family"] != "cul-de-sac"]
        for name in [MAIN] + [f"resampled: {v}" for v in args.resample]:
            _print_table(name, [r["pred"][name] for r in g], [r["ok"] for r in g])
            _print_table(f"{name}; against the runs with the failures outside the map forgiven ({', '.join(OUTSIDE)})",
                         [r["pred"][name] for r in g], [int(r["ok"] or cause(r) in OUTSIDE) for r in g])
        if args.fit:
            fit(sub, nz)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
