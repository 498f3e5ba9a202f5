"""Digest of what clomp does: every map on the scenarios and the recorded scans, and seeded closed-loop runs.

A refactor must not change behaviour. This prints one SHA-256 per input — the planner's map,
plan, stop reason and Ψ on every built-in scenario and every recorded scan under
``../shared/data/scans`` (goal 1 m ahead), and the outcome of seeded closed-loop runs (every
layout family, both conditions, ``paper`` and ``harsh``; every scenario on the simulated
robot): the experiment's record of each run (end state, final true pose, contacts, plans,
counters, the true path; all but its wall and CPU times) and, for the scenarios, end state,
reason, final true pose, contacts, plans and the true path, all written
with ``repr`` (bit-exact). ``--save FILE`` writes them; ``--compare FILE`` says which inputs
differ (exit status 1 when any does).

Run it in the old tree and the new tree::

    python bench/behaviour_digest.py --save /tmp/before.txt
    python bench/behaviour_digest.py --compare /tmp/before.txt   # "identical: N of N"
"""

from __future__ import annotations

import argparse
import hashlib
import importlib
import json
import sys
import time
import warnings
from pathlib import Path
from typing import Any



def _module(name: str) -> Any:
    """``clomp.<name>``, or ``<name>`` on a tree from before the clomp namespace (run with PYTHONPATH=that tree)."""
    try:
        return importlib.import_module(name)
    except ImportError:
        return importlib.import_module(f"clomp.{name}")


_planner = _module("planner")
Configurator, builtin_scenarios, load_scan, load_scenario = (
    _planner.Configurator, _planner.builtin_scenarios, _planner.load_scan, _planner.load_scenario)
FAMILIES = _module("runtime.experiment.layouts").FAMILIES
_runner = _module("runtime.experiment.runner")
RunSpec, run_once, run_spec = _runner.RunSpec, _runner.run_once, _runner.run_spec

SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans"


def _sha(doc: Any) -> str:
    return hashlib.sha256(json.dumps(doc, sort_keys=True, default=repr).encode()).hexdigest()


def map_digests(scans: Path) -> dict[str, str]:
    """``{input: sha256}`` of the map, plan, stop reason and Ψ for every scenario and recorded scan."""
    conf = Configurator()
    inputs = []
    for name in builtin_scenarios():
        scene = load_scenario(name)
        gx, gy = scene.goal_in_robot_frame()
        inputs.append((f"scenario:{name}", scene.scan(), (float(gx), float(gy))))
    files = sorted(scans.glob("*/*.dat"))
    if not files:
        raise SystemExit(f"behaviour_digest: no recorded scans (*/*.dat) under {scans}; pass --scans")
    for f in files:
        inputs.append((f"scan:{f.parent.name}/{f.name}", load_scan(f), (1.0, 0.0)))
    out = {}
    for name, pts, goal in inputs:
        r = conf.plan(pts, goal)
        out[name] = _sha({"map": r.map.to_dict(), "plan": list(r.plan.states), "stop": r.stop_reason,
                          "blocked": r.goal_blocked, "psi": sorted((repr(k), v) for k, v in r.psi.items())})
    return out


def _run_doc(r: Any) -> dict[str, Any]:
    return {"end": r.end_state, "reason": r.reason, "reached": r.reached_goal, "believed": r.believed_goal,
            "final": [repr(v) for v in r.final_pose], "distance": repr(r.final_distance),
            "episodes": [(repr(e.start_s), repr(e.max_penetration_m), e.brush) for e in r.episodes],
            "plans": r.plans, "states": getattr(r, "n_states", getattr(r, "states", None)), "path": [(repr(x), repr(y)) for x, y in r.path],
            "time": repr(r.time_s)}


def run_digests(runs: int) -> dict[str, str]:
    """``{run: sha256}`` of seeded closed-loop runs: every family x condition x noise, and the scenarios."""
    out = {}
    for family in FAMILIES:
        for noise in ("paper", "harsh"):
            for condition in ("planning", "reactive"):
                for k in range(runs):
                    rec = run_spec(RunSpec(family, 0, k, condition, noise, max_time=60.0))
                    out[f"run:{family}/{noise}/{condition}/{k}"] = _sha(
                        {key: v for key, v in rec.items() if key not in ("wall_s", "cpu_s", "planning_time_s")})
    for name in builtin_scenarios():
        r = run_once(load_scenario(name), "planning", 0, max_time=60.0)
        out[f"run:scenario/{name}"] = _sha(_run_doc(r))
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scans", type=Path, default=SCANS, help="a folder of recorded-scan folders")
    ap.add_argument("--runs", type=int, default=1, help="closed-loop runs per family, condition and noise")
    ap.add_argument("--maps-only", action="store_true")
    ap.add_argument("--save", type=Path, help="write the digests to this file")
    ap.add_argument("--compare", type=Path, help="compare with digests saved by --save")
    args = ap.parse_args(argv)
    warnings.simplefilter("ignore")  # scan warnings (points beyond the sensor range) are not behaviour here
    t0, c0 = time.perf_counter(), time.thread_time()
    d = map_digests(args.scans)
    if not args.maps_only:
        d.update(run_digests(args.runs))
    whole = hashlib.sha256("".join(f"{k}={v}\n" for k, v in sorted(d.items())).encode()).hexdigest()
    print(f"{len(d)} inputs, digest {whole} ({time.perf_counter() - t0:.0f} s wall, {time.thread_time() - c0:.0f} s thread CPU)")
    if args.save:
        args.save.write_text("".join(f"{k} {v}\n" for k, v in sorted(d.items())), encoding="utf-8")
    if args.compare:
        saved = dict(line.split(" ", 1) for line in args.compare.read_text(encoding="utf-8").split("\n") if line)
        saved = {k: v.strip() for k, v in saved.items()}
        differ = sorted(k for k in saved.keys() | d.keys() if saved.get(k) != d.get(k))
        print(f"identical: {len(d) - len(differ)} of {len(saved.keys() | d.keys())}")
        for k in differ:
            print(f"  differs: {k}")
        return 1 if differ else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
