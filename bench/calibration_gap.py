"""Why Storm's P of the first plan misses the closed loop: the calibration bench's runs decomposed.

Run (on the records of ``bench/calibration.py --out``; the predictions come from caches
that this script fills when asked, with the code on ``PYTHONPATH``)::

    python bench/calibration_gap.py greedy.jsonl --whole resample.json --stored stored.json \\
        [--mass mass.json --mass-layouts 0 16] [--robust robust.jsonl …] [--train-below 6]

- **Outcomes per bin** of a prediction (held-out harsh runs, layouts from
  ``--train-below`` on, cul-de-sac left out): the bench's success (truly within 0.1 m, no
  collision of the robot's own) beside "physically reached" (within 0.1 m, whatever the
  run claimed or touched), "claimed" (``GOAL_REACHED``; the false ones among them),
  "unconfirmed" (``GOAL_UNCONFIRMED``, at or off the goal), and the failures by
  :func:`failure` — which fill the gap between a bin's mean P and what it observed.
- **Pushes**: success by the number of pushes a run survived (no contact within 1.5 s),
  on the training and the held-out layouts; the model's push factor (the whole-run P
  over the same map's P without pushes) per bin.
- **Resolution**: the Brier score of each prediction beside the climatology's (the
  training layouts' success rate, one number for every run), and the correlation of a
  run's success with its P and with "the world pushed it".
- **Where the model's mass goes** (``--mass``): the whole-run model re-sampled from the
  stored first scan (as ``calibration_model.py --resample whole``), its plan DTMC split
  into target, collision, estimate lost and gave up, with 1 replan (the planner's
  objective) and 6 (the supervisor's patience).
- **The patience variant** (the one model change tried): the whole-run P with the
  supervisor's 6 replans instead of 1, ``whole × P6 / P1`` (P6, P1 of the stored map,
  no pushes); no term is fitted.
- **Robust vs greedy** (``--robust``): exact McNemar per noise and family over the
  layouts both conditions ran.

Asserts nothing.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import statistics
import sys
from collections.abc import Callable, Sequence
from typing import Any

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from calibration import BINS, read_records  # noqa: E402

from clomp.runtime.experiment.stats import mcnemar, wilson  # noqa: E402

PUSH_WINDOW = 1.5
"""A contact episode that begins this soon (s) after a push is the push's (as ``calibration_model``)."""
RADIUS = 0.1
"""The experiment's success radius (m)."""
PATIENCE = 6
"""The supervisor's patience: plans in a row that come no closer before it gives up."""
WHOLE_KEY = "whole 0.430 20.0"
"""The resample cache's key of the whole-run model (lost 0.43, stand 20 s, fitted on layouts 0-5)."""
FAILURES = ("false success", "unconfirmed, off the goal", "contact after a push", "contact", "UNREACHABLE", "HALTED")
"""Every way a run fails, in the order :func:`failure` tests them."""

Run = dict[str, Any]


def failure(r: Run) -> str | None:
    """How a greedy run's record ``r`` failed, or None when it succeeded (truly within the
    radius, no collision of its own). A contact counts before the end (pushed when it began
    within :data:`PUSH_WINDOW` s of a push); ``HALTED`` is the time limit.

    >>> failure({"ok": 1})
    >>> failure({"ok": 0, "episodes": [[6.6, 7.6, 0.005, False]], "pushes": [6.5], "end": "GOAL_REACHED", "false_success": 0})
    'contact after a push'
    >>> failure({"ok": 0, "episodes": [], "pushes": [], "end": "GOAL_UNCONFIRMED", "false_success": 0})
    'unconfirmed, off the goal'
    """
    if r["ok"]:
        return None
    eps = [e for e in r.get("episodes", []) if not e[3]]
    if eps:
        pushed = any(0 <= e[0] - t <= PUSH_WINDOW for e in eps for t in r.get("pushes", []))
        return "contact after a push" if pushed else "contact"
    if r["false_success"]:
        return "false success"
    if r["end"] == "GOAL_UNCONFIRMED":
        return "unconfirmed, off the goal"
    return str(r["end"])


def survived(r: Run) -> int:
    """The pushes of ``r`` no contact followed within :data:`PUSH_WINDOW` s.

    >>> survived({"pushes": [2.0, 9.0], "episodes": [[9.5, 10.0, 0.01, False]]})
    1
    """
    eps = [e[0] for e in r.get("episodes", []) if not e[3]]
    return sum(1 for t in r.get("pushes", []) if not any(0 <= e - t <= PUSH_WINDOW for e in eps))


def bins_of(pred: Sequence[float]) -> list[list[int]]:
    """The indices of ``pred`` per bin of :data:`BINS`.

    >>> bins_of([0.1, 0.9, 0.95])
    [[0], [], [], [], [1, 2]]
    """
    out: list[list[int]] = [[] for _ in BINS[:-1]]
    for i, p in enumerate(pred):
        out[min(max(sum(1 for b in BINS[1:-1] if p >= b), 0), len(out) - 1)].append(i)
    return out


def brier(pred: Sequence[float], ok: Sequence[int]) -> float:
    """Mean squared error of ``pred`` against ``ok``.

    >>> brier([1.0, 0.5], [1, 0])
    0.125
    """
    return statistics.fmean((p - o) ** 2 for p, o in zip(pred, ok))


def correlation(a: Sequence[float], b: Sequence[float]) -> float:
    """Pearson's r of ``a`` and ``b`` (nan when either is constant).

    >>> round(correlation([0, 1, 2], [0, 2, 4]), 3)
    1.0
    """
    ma, mb = statistics.fmean(a), statistics.fmean(b)
    sa = math.sqrt(sum((x - ma) ** 2 for x in a))
    sb = math.sqrt(sum((y - mb) ** 2 for y in b))
    if sa == 0 or sb == 0:
        return math.nan
    return sum((x - ma) * (y - mb) for x, y in zip(a, b)) / (sa * sb)


def outcome_row(runs: list[Run], pred: list[float]) -> dict[str, Any]:
    """One bin's figures: n, mean P, successes with the Wilson interval and whether the
    mean P lies in it, and the counts of every outcome (see the module docstring).

    >>> row = outcome_row([{"ok": 1, "distance": 0.05, "end": "GOAL_UNCONFIRMED", "false_success": 0}], [0.4])
    >>> row["ok"], row["inside"], row["reached"], row["unconfirmed at the goal"]
    (1, True, 1, 1)
    """
    n = len(runs)
    ok = sum(r["ok"] for r in runs)
    lo, hi = wilson(ok, n)
    mean = statistics.fmean(pred) if pred else math.nan
    row: dict[str, Any] = {
        "n": n,
        "mean": mean,
        "ok": ok,
        "lo": lo,
        "hi": hi,
        "inside": lo <= mean <= hi,
        "reached": sum(r["distance"] <= RADIUS for r in runs),
        "claimed": sum(r["end"] == "GOAL_REACHED" for r in runs),
        "false": sum(r["false_success"] for r in runs),
        "unconfirmed at the goal": sum(r["end"] == "GOAL_UNCONFIRMED" and r["distance"] <= RADIUS for r in runs),
        "unconfirmed off": sum(r["end"] == "GOAL_UNCONFIRMED" and r["distance"] > RADIUS for r in runs),
        "pushed": sum(bool(r.get("pushes")) for r in runs),
        "estimate off": sum(r.get("estimate_error", 0.0) > RADIUS for r in runs),
    }
    for f in FAILURES:
        row[f] = sum(failure(r) == f for r in runs)
    return row


def outcome_table(title: str, runs: list[Run], key: Callable[[Run], float]) -> None:
    """Print :func:`outcome_row` per bin of ``key`` over ``runs``, and the pooled Brier score."""
    pred = [key(r) for r in runs]
    print(
        f"\n{title}: {len(runs)} runs, mean P {statistics.fmean(pred):.3f}, observed "
        f"{statistics.fmean(r['ok'] for r in runs):.3f}, Brier {brier(pred, [r['ok'] for r in runs]):.4f}"
    )
    print(
        "  bin      n  mean P  success [95% Wilson]      in?  reached claimed(false) unconf@goal unconf-off | "
        + " / ".join(FAILURES)
        + " | pushed, estimate > 0.1 m off"
    )
    for b, idx in enumerate(bins_of(pred)):
        if not idx:
            continue
        row = outcome_row([runs[i] for i in idx], [pred[i] for i in idx])
        n = row["n"]
        print(
            f"  {BINS[b]:.1f}-{min(BINS[b + 1], 1.0):.1f} {n:4d}  {row['mean']:.3f}  {row['ok']:3d}/{n:<3d} = {row['ok'] / n:5.1%} "
            f"[{row['lo']:.0%}, {row['hi']:.0%}] {'in ' if row['inside'] else 'OUT'}  {row['reached']:4d} {row['claimed']:4d}({row['false']}) "
            f"{row['unconfirmed at the goal']:6d} {row['unconfirmed off']:8d}    | "
            + " / ".join(str(row[f]) for f in FAILURES)
            + f" | {row['pushed']}, {row['estimate off']}"
        )


def push_table(label: str, runs: list[Run]) -> None:
    """Print success by the pushes a run survived (runs with a contact after a push left out)."""
    clean = [r for r in runs if survived(r) == len(r.get("pushes", []))]
    parts = []
    for k in range(4):
        sel = [r for r in clean if min(survived(r), 3) == k]
        if sel:
            s = sum(r["ok"] for r in sel)
            lo, hi = wilson(s, len(sel))
            parts.append(f"{k}{'+' if k == 3 else ''}: {s}/{len(sel)} = {s / len(sel):.0%} [{lo:.0%}, {hi:.0%}]")
    print(f"  {label} ({len(clean)} runs without a contact after a push), success by pushes survived: " + "; ".join(parts))


def resolution(runs: list[Run], train: list[Run], preds: dict[str, Callable[[Run], float]]) -> None:
    """Print each prediction's Brier score beside the climatology's and its correlation with success."""
    ok = [r["ok"] for r in runs]
    base = statistics.fmean(r["ok"] for r in train) if train else math.nan
    print(
        f"\nresolution ({len(runs)} held-out runs): climatology (the training layouts' rate {base:.3f} for every run) "
        f"Brier {brier([base] * len(runs), ok):.4f}; success against 'the world pushed the run' r = "
        f"{correlation([float(bool(r.get('pushes'))) for r in runs], [float(o) for o in ok]):+.3f}"
    )
    pushed = {b: [r["ok"] for r in train if bool(r.get("pushes")) == b] for b in (False, True)}
    if all(pushed.values()):
        rate = {b: statistics.fmean(v) for b, v in pushed.items()}
        print(
            f"  knowing whether the world pushes the run (the training rates {rate[False]:.3f} unpushed, {rate[True]:.3f} pushed): "
            f"Brier {brier([rate[bool(r.get('pushes'))] for r in runs], ok):.4f}"
        )
    by_k: dict[int, list[int]] = {}
    for r in runs:
        by_k.setdefault(int(r.get("run", -1)), []).append(r["ok"])
    if len(by_k) > 1:
        rates = [statistics.fmean(v) for v in by_k.values()]
        size = statistics.fmean(len(v) for v in by_k.values())
        base_h = statistics.fmean(ok)
        print(
            f"  between layout indices (one push schedule each, shared by the families): variance of the success rate "
            f"{statistics.pvariance(rates):.4f} against {base_h * (1 - base_h) / size:.4f} for independent runs"
        )
    for name, key in preds.items():
        pred = [key(r) for r in runs]
        print(
            f"  {name}: Brier {brier(pred, ok):.4f}, r(P, success) = {correlation(pred, [float(o) for o in ok]):+.3f}, "
            f"spread of P (sd) {statistics.pstdev(pred):.3f}"
        )


def mass_table(runs: list[Run]) -> None:
    """Print where the whole-run model's mass goes (the ``mass`` of each run), per bin of its P."""
    have = [r for r in runs if "mass" in r]
    if not have:
        return
    print(
        f"\nwhere the whole-run model's mass goes ({len(have)} held-out runs re-sampled), per bin of the whole-run P (1 replan):"
    )
    print(
        "  bin      n  | 1 replan: target collision lost gave-up other | 6 replans: target collision lost gave-up | whole×P6/P1 | observed"
    )
    pred = [r["mass"]["target1"] for r in have]
    for b, idx in enumerate(bins_of(pred)):
        if not idx:
            continue
        sel = [have[i]["mass"] for i in idx]

        def m(k: str, sel: list[dict[str, float]] = sel) -> float:
            return statistics.fmean(s[k] for s in sel)

        other = 1 - m("target1") - m("collision1") - m("lost1") - m("gave_up1")
        fact = statistics.fmean(patience(have[i]) for i in idx)
        s = sum(have[i]["ok"] for i in idx)
        print(
            f"  {BINS[b]:.1f}-{min(BINS[b + 1], 1.0):.1f} {len(idx):4d}  |  {m('target1'):.3f} {m('collision1'):.3f} {m('lost1'):.3f} "
            f"{m('gave_up1'):.3f} {other:.3f} | {m('target6'):.3f} {m('collision6'):.3f} {m('lost6'):.3f} {m('gave_up6'):.3f} "
            f"| {fact:.3f} | {s}/{len(idx)}"
        )


def _mass_of(key: str) -> Callable[[Run], float]:
    """The prediction ``key`` of a run's re-sampled model (``r["mass"]``)."""
    return lambda r: float(r["mass"][key])


def patience(r: Run) -> float:
    """The patience variant of run ``r``: its whole-run P times P6 / P1 of its stored map, at most 1.

    >>> patience({"whole": 0.3, "p1": 0.5, "p6": 1.0})
    0.6
    """
    whole, p1, p6 = float(r["whole"]), float(r["p1"]), float(r["p6"])
    return min(1.0, whole * p6 / p1) if p1 > 0 else whole


def robust_table(pairs: list[dict[str, Any]]) -> None:
    """Print robust vs greedy, paired, per noise and family (exact McNemar)."""
    both = [p for p in pairs if "greedy" in p and "robust" in p]
    print(f"\nrobust vs greedy: {len(both)} paired layouts")
    for nz, fam in sorted({(p["noise"], p["family"]) for p in both}):
        sel = [p for p in both if (p["noise"], p["family"]) == (nz, fam)]
        g, rb = [p["greedy"]["ok"] for p in sel], [p["robust"]["ok"] for p in sel]
        t = mcnemar(g, rb)
        dev = sum(1 for p in sel if "confirmed" in p["robust"].get("decisions", []))
        print(
            f"  {nz} {fam}: layouts {min(p['run'] for p in sel)}-{max(p['run'] for p in sel)} ({len(sel)}), greedy {sum(g)}/{len(g)}, "
            f"robust {sum(rb)}/{len(rb)}, only greedy {t['b10']}, only robust {t['b01']}, McNemar p = {t['p']:.3g}; "
            f"confirmed deviations {dev}; false successes {sum(p['greedy']['false_success'] for p in sel)} / "
            f"{sum(p['robust']['false_success'] for p in sel)}"
        )


def _load(path: str | None) -> dict[str, Any]:
    if path and os.path.exists(path):
        with open(path, encoding="utf-8") as fh:
            data: dict[str, Any] = json.load(fh)
            return data
    return {}


def _save(data: dict[str, Any], path: str) -> None:
    with open(path + ".part", "w", encoding="utf-8") as fh:
        json.dump(data, fh)
    os.replace(path + ".part", path)


def stored_predictions(rec: Run) -> dict[str, float]:
    """P of the first plan on the record's stored map (no pushes) with 1 and :data:`PATIENCE` replans."""
    from calibration import target_of

    from clomp.formal.lts import CognitiveMap
    from clomp.formal.scheduler import plan_probability
    from clomp.formal.supervisory import Plan

    cmap = CognitiveMap.from_dict(rec["map"])
    plan, target = Plan(tuple(rec["plan"])), target_of(rec, cmap)
    return {str(k): plan_probability(cmap, plan, target, k) for k in (1, PATIENCE)}


def model_mass(rec: Run, noise: str, k: int) -> dict[str, float]:
    """The whole-run model re-sampled from the record's first scan (as
    ``calibration_model.resampled(variant="whole")``), its plan's DTMC with 1 and
    :data:`PATIENCE` replans split into target (safely), collision, estimate lost, gave up."""
    import tempfile
    from dataclasses import replace
    from pathlib import Path

    import numpy as np

    from clomp.formal.checking import require_stormpy
    from clomp.formal.export import export_model, write_drn
    from clomp.formal.retry import loop_model, map_lost, map_offs, map_stops
    from clomp.planner.robust import CLOSED_LOOP_HAZARD, RobustConfigurator, closed_loop_pushes

    stormpy = require_stormpy()
    conf = RobustConfigurator(
        samples=rec.get("samples", 30),
        noise=noise,
        seed=1000 * k,
        hazard=CLOSED_LOOP_HAZARD,
        pushes=closed_loop_pushes(noise),
        max_states=rec.get("first_states", 50),
        recovery=rec.get("first_recovery", False),
    )
    c = conf.sample(np.asarray(rec["scan"], dtype=float), tuple(rec["goal"]))
    cm, wanted = c.pm.map, set(c.target)
    out = {"p_greedy": float(c.p_greedy)}
    formulas = {
        "target": '!"collision" U "target"',
        "collision": 'F "collision"',
        "lost": 'F "estimate_lost"',
        "gave_up": 'F "gave_up"',
    }
    for rep in (1, PATIENCE):
        m = export_model(cm, "dtmc", c.greedy)
        m = replace(m, labels={**m.labels, "target": frozenset(i for i, s in enumerate(m.states) if s.ident in wanted)})
        m = loop_model(m, map_stops(cm.metadata), rep, map_offs(cm.metadata), map_lost(cm.metadata))
        with tempfile.TemporaryDirectory() as tmp:
            write_drn(m, Path(tmp) / "m.drn")
            model = stormpy.build_model_from_drn(str(Path(tmp) / "m.drn"))
        init = int(model.initial_states[0])
        for name, f in formulas.items():
            v = stormpy.model_checking(model, stormpy.parse_properties(f"P=? [{f}]")[0])
            out[f"{name}{rep}"] = float(v.at(init)) if hasattr(v, "at") else float(v[init])
    return out


def _fill(pairs: list[dict[str, Any]], path: str, compute: Callable[[dict[str, Any]], dict[str, float]]) -> dict[str, Any]:
    """The cache at ``path`` with every record of ``pairs`` computed (saved as it goes)."""
    cache = _load(path)
    for p in pairs:
        key = f"{p['noise']}|{p['family']}|{p['run']}"
        if key not in cache:
            cache[key] = compute(p)
            _save(cache, path)
    return cache


def _parse(argv: list[str] | None) -> argparse.Namespace:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("files", nargs="+", help="greedy runs (JSON lines of calibration.py --out)")
    ap.add_argument("--whole", required=True, help="calibration_model.py's --cache with the whole-run predictions")
    ap.add_argument("--stored", required=True, help="cache of the stored maps' P (1 and 6 replans); filled when missing")
    ap.add_argument("--mass", help="cache of the whole-run model's mass split; filled for --mass-layouts")
    ap.add_argument("--mass-layouts", type=int, nargs=2, default=(0, 0), metavar=("FIRST", "END"))
    ap.add_argument(
        "--robust",
        nargs="+",
        action="append",
        default=[],
        metavar="FILE",
        help="files with paired greedy and robust runs, merged per layout; repeat for data of another code version",
    )
    ap.add_argument("--train-below", type=int, default=6, metavar="K")
    return ap.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = _parse(argv)
    pairs = [p for p in read_records(args.files) if "map" in p.get("greedy", {}) and p["family"] != "cul-de-sac"]
    stored = _fill(pairs, args.stored, lambda p: stored_predictions(p["greedy"]))
    whole = _load(args.whole)
    a, b = args.mass_layouts
    todo = sorted((p for p in pairs if p["noise"] == "harsh" and a <= p["run"] < b), key=lambda p: (p["run"], p["family"]))
    mass = _fill(todo, args.mass, lambda p: model_mass(p["greedy"], p["noise"], p["run"])) if args.mass else {}
    for p in pairs:
        key = f"{p['noise']}|{p['family']}|{p['run']}"
        r = p["greedy"]
        r["run"] = p["run"]
        r["p1"], r["p6"] = stored[key]["1"], stored[key][str(PATIENCE)]
        r["whole"] = whole.get(f"{key}|{WHOLE_KEY}", r["p1"] if p["noise"] == "paper" else math.nan)
        if key in mass:
            r["mass"] = mass[key]
    for nz in ("paper", "harsh"):
        train = [p["greedy"] for p in pairs if p["noise"] == nz and p["run"] < args.train_below]
        held = [
            p["greedy"]
            for p in pairs
            if p["noise"] == nz and p["run"] >= args.train_below and not math.isnan(p["greedy"]["whole"])
        ]
        print(f"\n===== {nz}: {len(held)} held-out runs (layouts >= {args.train_below}), {len(train)} training runs")
        preds: dict[str, Callable[[Run], float]] = {
            "1 replan, no pushes (the planner's objective)": lambda r: r["p1"],
            "6 replans, no pushes": lambda r: r["p6"],
        }
        if nz == "harsh":
            preds |= {
                "whole run (pushes, lost 0.43, stand 20 s; 1 replan)": lambda r: r["whole"],
                "patience: whole run × P6/P1 (6 replans)": patience,
            }
        for name, pick in preds.items():
            outcome_table(f"{nz}, {name}", held, pick)
        push_table(f"{nz} training layouts", train)
        push_table(f"{nz} held-out layouts", held)
        resolution(held, train, preds)
        if nz == "harsh":
            mass_table(held)
            sample = [r for r in held if "mass" in r]
            if sample:
                for rep, what in ((1, "1 replan"), (PATIENCE, f"{PATIENCE} replans (the supervisor's patience)")):
                    outcome_table(f"harsh sample re-sampled, the whole-run model with {what}", sample, _mass_of(f"target{rep}"))
    for group in args.robust:
        print(f"\n{' + '.join(group)}:", end="")
        robust_table(read_records(group))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
