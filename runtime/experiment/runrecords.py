"""The record of a run: :func:`run_spec` runs a :class:`~clomp.runtime.experiment.runspec.RunSpec`
and returns it as one JSON-ready dict (the CSV columns of :mod:`clomp.runtime.experiment.results`
plus what the plots need); :func:`load_records` reads a ``runs.jsonl`` of them back.
"""

from __future__ import annotations

import json
import os
from dataclasses import asdict
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.groundtruth import world_name
from clomp.runtime.experiment.onerun import SUCCESS_RADIUS, run_once
from clomp.runtime.experiment.runspec import RunSpec, movers_for, noise_seed, scene_for

__all__ = ["PLOTTED_RUNS", "TRACE_FIELDS", "load_records", "run_spec", "summary_record"]

#: the fields of a record that only the plots read (not in the CSV): what a run grows with
TRACE_FIELDS = ("obstacles", "goal", "start", "path", "estimate", "planned", "contacts", "episodes", "final_pose")
#: the runs (index below this) whose traces the plots draw (report.write_plots' max_panels)
PLOTTED_RUNS = 20


def _r(v: float | None, nd: int) -> float | None:
    return None if v is None else round(float(v), nd)


def run_spec(spec: RunSpec) -> dict[str, Any]:
    """One run as a JSON-ready record (the CSV columns plus what the plots need).

    >>> rec = run_spec(RunSpec("open", 0, 0, "reactive", "ideal"))
    >>> rec["key"], rec["success"], rec["collisions"]
    ('open/0/0/reactive/ideal/1/120', 1, 0)
    """
    scene, expect = scene_for(spec)
    r = run_once(scene, spec.condition, noise_seed(spec.seed, spec.run), run=spec.run, noise=spec.noise,
                 noise_scale=spec.noise_scale, max_time=spec.max_time, expect=expect, feedback=spec.feedback,
                 gyro=spec.gyro, movers=movers_for(spec),
                 reactive={"policy": spec.policy} if spec.condition == "rl" else None)
    rec = _record(spec, scene, expect, r)
    if r.moving is not None:  # a moving family (issue #42): its contacts counted apart
        rec.update(r.moving)
    return rec


def _record(spec: RunSpec, scene: Any, expect: str, r: Any) -> dict[str, Any]:
    return {
        "key": spec.key,
        "family": spec.family,
        "seed": spec.seed,
        "run": spec.run,
        "condition": spec.condition,
        "noise": spec.noise,
        "noise_scale": spec.noise_scale,
        "feedback": spec.feedback,
        "gyro": int(spec.gyro),
        "world": world_name(),
        "layout": scene.name,
        "expect": expect,
        "success": int(r.reached_goal),
        "reached_goal": int(r.final_distance <= SUCCESS_RADIUS),
        "believed_goal": int(r.believed_goal),
        "goal_unconfirmed": int(r.end_state == "GOAL_UNCONFIRMED"),
        "false_success": int(r.end_state == "GOAL_REACHED" and r.final_distance > SUCCESS_RADIUS),
        "end_state": r.end_state,
        "final_error_m": _r(r.final_distance, 4),
        "collisions": r.collisions,
        "pushed_contacts": r.pushed_contacts,
        "brushes": r.brushes,
        "max_penetration_m": _r(max((e.max_penetration_m for e in r.episodes), default=0.0), 4),
        "contact_s": _r(sum(e.duration_s for e in r.episodes), 3),
        "time_s": _r(r.time_s, 2),
        "time_to_goal_s": _r(r.time_to_goal_s, 2),
        "planning_time_s": _r(r.planning_time_s, 6),
        "states": r.n_states,
        "plans": r.plans,
        "checks": r.counters.get("checks"),
        "recalls": r.counters.get("recalls"),
        "fresh_plans": r.counters.get("fresh_plans"),
        "wall_s": _r(r.wall_s, 3),
        "cpu_s": _r(r.cpu_s, 3),
        "reason": r.reason,
        # for the plots (not in the CSV)
        "obstacles": scene.raw.get("obstacles", []),
        "goal": list(scene.goal),
        "start": [scene.start.x, scene.start.y, scene.start.theta],
        "path": [[round(x, 4), round(y, 4)] for x, y in r.path],
        "estimate": [[round(x, 4), round(y, 4)] for x, y in r.estimate[::3]],
        "planned": [[[round(x, 4), round(y, 4)] for x, y in poly] for poly in r.planned],
        "contacts": [[round(x, 4), round(y, 4)] for x, y in r.contacts],
        "episodes": [asdict(e) for e in r.episodes],
        "final_pose": [round(v, 4) for v in r.final_pose],
    }


def summary_record(rec: dict[str, Any]) -> dict[str, Any]:
    """``rec`` without its :data:`TRACE_FIELDS`: what the summary, the CSV and Parquet read.

    >>> summary_record({"key": "k", "success": 1, "path": [[0.0, 0.0]]})
    {'key': 'k', 'success': 1}
    """
    return {k: v for k, v in rec.items() if k not in TRACE_FIELDS}


def load_records(path: str | os.PathLike[str]) -> list[dict[str, Any]]:
    """The records of a ``runs.jsonl`` (a line cut short by a crash is skipped; no file: none).

    >>> load_records("no-such-folder/runs.jsonl")
    []
    """
    p = Path(path)
    if not p.exists():
        return []
    out = []
    for line in p.read_text(encoding="utf-8").splitlines():
        try:
            rec = json.loads(line)
        except json.JSONDecodeError:
            continue
        if isinstance(rec, dict) and "key" in rec:
            out.append(rec)
    return out
