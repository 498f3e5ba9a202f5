"""The plots of an experiment, drawn from its records (``runs.jsonl``).

:func:`write_plots` draws, into the output folder: ``trajectories_<condition>.png`` (a
grid of runs, the first 20, at the lowest noise scale), ``collisions.png`` (collisions
and brushes per run, both conditions) and, for a noise sweep, ``success_vs_noise.png``.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.runspec import CONDITIONS
from clomp.planner.scenarios import Scene, parse_scenario
from clomp.runtime.experiment.plots import (
    RunTrace,
    outcome_title,
    plot_collisions,
    plot_runs,
    plot_success_vs_noise,
    start_scan,
)

__all__ = ["record_scene", "record_trace", "write_plots"]


def record_scene(rec: dict[str, Any]) -> Scene:
    """The layout a record ran in."""
    raw = {"name": rec.get("layout", "layout"), "goal": rec["goal"], "start": rec["start"], "obstacles": rec["obstacles"]}
    return parse_scenario(raw, raw["name"])


def record_trace(rec: dict[str, Any]) -> RunTrace:
    """A record as a picture: its outcome in words, the noise-free scan from the start (a record
    keeps no scan) and time marks (the path's points are the run's even simulation steps, every
    tenth, so the k-th of n is at ``time_s * k / (n - 1)``)."""
    scene = record_scene(rec)
    title, tone = outcome_title(int(rec["run"]), str(rec.get("end_state", "")), bool(rec["reached_goal"]),
                                float(rec["final_error_m"]), int(rec["collisions"]), int(rec["brushes"]),
                                str(rec.get("expect", "reach")), str(rec.get("reason", "")))
    st = scene.start
    path = [tuple(p) for p in rec["path"]]
    n, dur = len(path), float(rec.get("time_s") or 0.0)
    times = [dur * k / (n - 1) for k in range(n)] if n > 1 and dur > 0 else []
    return RunTrace(scene, title, path, [tuple(c) for c in rec["contacts"]],
                    [[tuple(p) for p in poly] for poly in rec["planned"]],
                    [tuple(p) for p in rec["estimate"]], [(st.x, st.y, st.theta), tuple(rec["final_pose"])],
                    bool(rec["success"]), tone, start_scan(scene), "LiDAR scan at the start (noise-free)", times)


def write_plots(records: list[dict[str, Any]], folder: str | os.PathLike[str], max_panels: int = 20) -> list[Path]:
    """Draw the experiment's plots; returns the files written."""
    out = Path(folder)
    written: list[Path] = []
    scales = sorted({float(r.get("noise_scale", 1.0)) for r in records})
    base = scales[0]
    fam = records[0].get("family", "")
    noise = records[0].get("noise", "")
    at = [r for r in records if float(r.get("noise_scale", 1.0)) == base]
    per_run: dict[str, list[tuple[int, int]]] = {}
    for name in CONDITIONS:
        rs = sorted((r for r in at if r["condition"] == name), key=lambda r: r["run"])
        if not rs:
            continue
        per_run[name] = [(int(r["collisions"]), int(r["brushes"])) for r in rs]
        p = out / f"trajectories_{name}.png"
        succ = sum(int(r["success"]) for r in rs)
        hits = sum(int(r["collisions"]) for r in rs)
        brushes = sum(int(r["brushes"]) for r in rs)
        shown = rs[:max_panels]
        more = f" (first {len(shown)} shown)" if len(rs) > len(shown) else ""
        plot_runs([record_trace(r) for r in shown], p,
                  f"{fam} — {name}, noise {noise} ×{base:g}: success {succ}/{len(rs)}, {hits} collisions, "
                  f"{brushes} brushes{more}")
        written.append(p)
    if per_run:
        p = out / "collisions.png"
        plot_collisions(per_run, p, f"{fam}, noise {noise} ×{base:g}: contact episodes per run (ground truth)")
        written.append(p)
    if len(scales) > 1:
        points: dict[str, list[tuple[float, int, int]]] = {}
        for name in CONDITIONS:
            for s in scales:
                rs = [r for r in records if r["condition"] == name and float(r.get("noise_scale", 1.0)) == s]
                if rs:
                    points.setdefault(name, []).append((s, sum(int(r["success"]) for r in rs), len(rs)))
        p = out / "success_vs_noise.png"
        plot_success_vs_noise(points, p, f"{fam}, noise preset {noise}: success against noise scale")
        written.append(p)
    return written
