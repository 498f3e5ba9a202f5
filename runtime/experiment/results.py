"""What an experiment leaves: one CSV row per run (documented schema), a summary, a table.

The records come from :func:`clomp.runtime.experiment.runrecords.run_spec` (one per run and
condition). :func:`summarise` turns them into the JSON summary — per condition: runs,
ground-truth goal reached, success with its Wilson 95 % interval, collisions and
brushes (totals and per run with t intervals), median final error; the paired t-test
on collisions and McNemar's test on success across conditions. :func:`write_csv`
writes :data:`CSV_COLUMNS` (units and meanings below, also written beside the CSV as
``runs_schema.md``); :func:`write_parquet` the same columns, typed, with each column's unit
and meaning in the file's own schema (needs pyarrow: ``pip install 'clomp[parquet]'``). :func:`table` is the summary as text, :func:`markdown_rows` as
Markdown rows for the experiment table (docs/experiment-room.md).

>>> recs = [{"condition": "planning", "run": 0, "noise_scale": 1.0, "success": 1, "reached_goal": 1,
...          "believed_goal": 1, "collisions": 0, "brushes": 1, "final_error_m": 0.02, "time_s": 12.0,
...          "wall_s": 0.5, "cpu_s": 0.5, "expect": "reach"}]
>>> s = summarise(recs)
>>> s["conditions"]["planning"]["reached_goal"], s["conditions"]["planning"]["brushes"]
(1, 1)
"""

from __future__ import annotations

import csv
import os
import statistics
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.runspec import CONDITIONS
from clomp.runtime.experiment.stats import mcnemar, mean_ci, paired_ttest, wilson

__all__ = ["BASELINES", "COLUMN_TYPES", "CONDITIONS_HEADER", "CSV_COLUMNS", "MARKDOWN_HEADER", "PAPER", "condition_rows", "conditions_table",
           "markdown_rows", "summarise", "table", "write_csv", "write_parquet", "write_schema"]

PAPER: dict[str, dict[str, Any]] = {
    "planning": {"reached_goal": 10, "runs": 10, "collisions": 0, "brushes": 2, "planning_time_s": (0.064, 0.009),
                 "states": (32.9, 1.758)},
    "reactive": {"reached_goal": 0, "runs": 10, "collisions": 8},
    "ttest": {"t": -1.747, "p": 0.111},
}
"""The paper's figures (overtaking, real robot, 10 runs per condition): what :func:`table` puts beside a summary."""

CSV_COLUMNS: dict[str, tuple[str, str]] = {
    "family": ("", "layout family (or scenario name/file for a fixed layout)"),
    "seed": ("", "experiment seed; with run, fixes the layout and the world's noise"),
    "run": ("", "run index 0..N-1; the two conditions of one run share layout and noise (paired)"),
    "condition": ("", "planning (supervisor + Configurator) or reactive (the single-loop baseline)"),
    "noise": ("", "noise preset of the execution world: ideal, paper or harsh"),
    "noise_scale": ("×", "factor on every noise term of the preset"),
    "gyro": ("0/1", "the robot had the world's rate gyro (0: --no-gyro, as the paper's robot)"),
    "world": ("", "execution world: world (independent world) or sim (simulated robot)"),
    "layout": ("", "name of the layout drawn: family-seed-run"),
    "expect": ("", "reach (goal reachable) or unreachable (success = stopping and saying so)"),
    "success": ("0/1", "reach: truly within success_radius of the goal at the end; unreachable: "
                       "ended UNREACHABLE with no collision"),
    "reached_goal": ("0/1", "ground truth: final distance to the goal <= success_radius (0.1 m)"),
    "believed_goal": ("0/1", "the controller stopped claiming the goal (GOAL_REACHED)"),
    "goal_unconfirmed": ("0/1", "the estimate put the robot at the goal but could not vouch for it: its 95 % "
                                "position bound did not fit in the tolerance (GOAL_UNCONFIRMED, issue #36)"),
    "false_success": ("0/1", "claimed the goal (GOAL_REACHED) while truly farther than success_radius from it"),
    "end_state": ("", "final state: GOAL_REACHED, GOAL_UNCONFIRMED, UNREACHABLE, TIMEOUT, HALTED"),
    "final_error_m": ("m", "ground-truth distance from the robot's rotation centre to the goal at the end"),
    "collisions": ("count", "contact episodes (gaps < 1 s merged) that are not brushes (ground truth)"),
    "brushes": ("count", "contact episodes shallower than 1 cm and shorter than 0.5 s"),
    "max_penetration_m": ("m", "deepest penetration of the body into an obstacle over the run"),
    "contact_s": ("s", "summed duration of the contact episodes"),
    "time_s": ("s", "simulated time the run took"),
    "time_to_goal_s": ("s", "simulated time to the goal, empty when not reached"),
    "planning_time_s": ("s", "wall time of the first plan (planning only)"),
    "states": ("count", "states of the first cognitive map (planning only)"),
    "plans": ("count", "plans made (planning only; 1 = never replanned)"),
    "checks": ("count", "plan checks against new scans (when the supervisor reports them)"),
    "recalls": ("count", "plans recalled from the map (when reported)"),
    "fresh_plans": ("count", "plans explored afresh (when reported)"),
    "static_collisions": ("count", "moving families only (issue #42): collisions with the static obstacles"),
    "moving_collisions": ("count", "moving families only: collisions with moving or appearing bodies (people, boxes)"),
    "moving_brushes": ("count", "moving families only: brushes with moving or appearing bodies"),
    "robot_caused_collisions": ("count", "moving families only: collisions with moving bodies the robot drove into "
                                         "(the rest: a body walked into the robot)"),
    "wall_s": ("s", "wall-clock time of the run on its worker"),
    "cpu_s": ("s", "thread CPU time of the run on its worker"),
    "reason": ("", "why the run ended, in words"),
}
"""CSV column → (unit, meaning)."""

MOVING_COUNTS = ("static_collisions", "moving_collisions", "moving_brushes", "robot_caused_collisions")
"""The record fields of a moving family's run (issue #42); absent from older and static runs'
records, summed per condition when present."""

COLUMN_TYPES: dict[str, str] = {
    k: ("int" if u in ("0/1", "count") or k in ("seed", "run") else "float" if u in ("m", "s", "×") else "str")
    for k, (u, _) in CSV_COLUMNS.items()
}
"""Column → its type in Parquet: ``int`` (int64), ``float`` (float64) or ``str``; every
column may be empty (null), as in the CSV (e.g. ``time_to_goal_s`` of a run that failed)."""

SUCCESS_RADIUS_M = 0.1


def _fmt(v: Any) -> Any:
    return "" if v is None else v


def write_csv(records: Iterable[dict[str, Any]], path: str | os.PathLike[str]) -> Path:
    """One row per run, in (noise scale, run, condition) order, columns :data:`CSV_COLUMNS`."""
    rows = sorted(records, key=lambda r: (r.get("noise_scale", 1.0), r["run"], r["condition"]))
    p = Path(path)
    with open(p, "w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(list(CSV_COLUMNS))
        for r in rows:
            w.writerow([_fmt(r.get(k)) for k in CSV_COLUMNS])
    return p


def write_parquet(records: Iterable[dict[str, Any]], path: str | os.PathLike[str]) -> Path:
    """The CSV's rows and columns as a Parquet file (same order), typed by :data:`COLUMN_TYPES`;
    each field's metadata holds its ``unit`` and ``meaning``. RuntimeError without pyarrow.

    >>> import pyarrow.parquet as pq, tempfile
    >>> rec = {"family": "overtaking", "seed": 0, "run": 0, "condition": "planning", "success": 1, "final_error_m": 0.02}
    >>> with tempfile.TemporaryDirectory() as d:
    ...     t = pq.read_table(write_parquet([rec], d + "/runs.parquet"))
    >>> t.column("final_error_m").to_pylist(), t.schema.field("final_error_m").metadata[b"unit"]
    ([0.02], b'm')
    """
    try:
        import pyarrow as pa
        import pyarrow.parquet as pq
    except ImportError:
        raise RuntimeError("Parquet output needs pyarrow: pip install 'clomp[parquet]'") from None
    rows = sorted(records, key=lambda r: (r.get("noise_scale", 1.0), r["run"], r["condition"]))
    kinds = {"int": pa.int64(), "float": pa.float64(), "str": pa.string()}
    fields = [pa.field(k, kinds[COLUMN_TYPES[k]], nullable=True, metadata={"unit": u, "meaning": m})
              for k, (u, m) in CSV_COLUMNS.items()]
    schema = pa.schema(fields, metadata={"clomp": "runs of clomp experiment: one row per run and condition; "
                                                  "ground truth is the execution world's"})
    table = pa.table({f.name: pa.array([_typed(r.get(f.name), COLUMN_TYPES[f.name]) for r in rows], type=f.type)
                      for f in fields}, schema=schema)
    p = Path(path)
    pq.write_table(table, p)
    return p


def _typed(v: Any, kind: str) -> Any:
    if v is None or v == "":
        return None
    return int(v) if kind == "int" else float(v) if kind == "float" else str(v)


def write_schema(path: str | os.PathLike[str]) -> Path:
    """The CSV's schema as a Markdown table."""
    lines = ["# runs.csv", "", "One row per run and condition. Ground truth is the execution world's, not the robot's belief.",
             "", "| column | unit | meaning |", "|---|---|---|"]
    lines += [f"| `{k}` | {u} | {m} |" for k, (u, m) in CSV_COLUMNS.items()]
    lines += ["", "runs.parquet (written when pyarrow is installed: `pip install 'clomp[parquet]'`) has the same rows "
              "and columns, typed (" + ", ".join(f"{t}: " + ", ".join(f"`{k}`" for k, v in COLUMN_TYPES.items() if v == t)
                                         for t in ("int", "float")) + "; the rest text; any may be null), "
              "with each column's unit and meaning in the field's metadata."]
    p = Path(path)
    p.write_text("\n".join(lines) + "\n", encoding="utf-8")
    return p


def _median(vals: Sequence[float]) -> float | None:
    return float(statistics.median(vals)) if vals else None


def _ms(vals: Sequence[float]) -> dict[str, float | None]:
    if not vals:
        return {"mean": None, "sd": None}
    return {"mean": statistics.fmean(vals), "sd": statistics.stdev(vals) if len(vals) > 1 else 0.0}


def _false_success(r: dict[str, Any]) -> int:
    """1 when the run claimed the goal (GOAL_REACHED) while truly farther than the success
    radius from it (a record written before the column: believed and not reached)."""
    if r.get("false_success") is not None:
        return int(r["false_success"])
    return int(bool(int(r["believed_goal"])) and not int(r["reached_goal"]))


def _condition(rs: list[dict[str, Any]]) -> dict[str, Any]:
    n = len(rs)
    succ = sum(int(r["success"]) for r in rs)
    lo, hi = wilson(succ, n)
    out: dict[str, Any] = {
        "runs": n,
        "reached_goal": sum(int(r["reached_goal"]) for r in rs),
        "believed_goal": sum(int(r["believed_goal"]) for r in rs),
        "goal_unconfirmed": sum(int(r.get("goal_unconfirmed") or 0) for r in rs),
        "false_successes": sum(_false_success(r) for r in rs),
        "success": succ,
        "success_rate": succ / n if n else None,
        "success_ci95": [lo, hi],
        "collisions": sum(int(r["collisions"]) for r in rs),
        "brushes": sum(int(r["brushes"]) for r in rs),
        "runs_with_collision": sum(int(r["collisions"]) > 0 for r in rs),
        "collisions_per_run": mean_ci([float(r["collisions"]) for r in rs]),
        "brushes_per_run": mean_ci([float(r["brushes"]) for r in rs]),
        "final_error_median_m": _median([float(r["final_error_m"]) for r in rs if r.get("final_error_m") is not None]),
        "planning_time_s": _ms([float(r["planning_time_s"]) for r in rs if r.get("planning_time_s") is not None]),
        "states": _ms([float(r["states"]) for r in rs if r.get("states") is not None]),
        "time_to_goal_s": _ms([float(r["time_to_goal_s"]) for r in rs if r.get("time_to_goal_s") is not None]),
        "time_to_goal_median_s": _median([float(r["time_to_goal_s"]) for r in rs
                                          if r.get("time_to_goal_s") is not None and int(r["reached_goal"])]),
        "sim_s": sum(float(r["time_s"]) for r in rs),
        "wall_s": sum(float(r["wall_s"]) for r in rs),
        "cpu_s": sum(float(r.get("cpu_s") or 0.0) for r in rs),
    }
    for k in ("checks", "recalls", "fresh_plans") + MOVING_COUNTS:
        vals = [int(r[k]) for r in rs if r.get(k) is not None]
        if vals:
            out[k] = sum(vals)
    return out


def summarise(records: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """The JSON summary of an experiment's records (see the module docstring).

    With several noise scales (a sweep), ``conditions`` covers them all and
    ``by_noise_scale`` lists each scale's summary.
    """
    recs = list(records)
    head: dict[str, Any] = {}
    for k in ("family", "seed", "noise", "world"):
        vals = sorted({str(r[k]) for r in recs if k in r})
        if vals:
            head[k] = vals[0] if len(vals) == 1 else vals
    out: dict[str, Any] = {**head, **_block(recs)}
    scales = sorted({float(r.get("noise_scale", 1.0)) for r in recs})
    out["noise_scales"] = scales
    if len(scales) > 1:
        out["by_noise_scale"] = [{"noise_scale": s, **_block([r for r in recs if float(r.get("noise_scale", 1.0)) == s])}
                                 for s in scales]
    out["success_radius_m"] = SUCCESS_RADIUS_M
    return out


_NAMES = CONDITIONS  # the conditions, in the table's order


BASELINES: tuple[tuple[str, str], ...] = tuple((n, "" if n == "reactive" else f"_{n}") for n in CONDITIONS if n != "planning")
"""Each baseline paired against planning, with the suffix of its tests' keys in a summary
(``mcnemar_success_dwa``; the paper's reactive has none)."""


def _pair_key(r: dict[str, Any]) -> tuple[float, str, int, str]:
    # a run is paired with the same layout under the other condition: same noise scale, seed,
    # run and gyro setting (a sweep's cell spans seeds; keyed by run alone, seed 1's run 0
    # overwrote seed 0's and the tests saw one pair per run index)
    return (float(r.get("noise_scale", 1.0)), str(r.get("seed")), int(r["run"]), str(r.get("gyro")))


def _block(recs: list[dict[str, Any]]) -> dict[str, Any]:
    conds: dict[str, Any] = {}
    by: dict[str, list[dict[str, Any]]] = {}
    for r in recs:
        by.setdefault(r["condition"], []).append(r)
    for name in _NAMES:
        if name in by:
            conds[name] = _condition(by[name])
    out: dict[str, Any] = {"conditions": conds}
    for other, suffix in BASELINES:  # each baseline paired against planning
        if "planning" in by and other in by:
            p = {_pair_key(r): r for r in by["planning"]}
            q = {_pair_key(r): r for r in by[other]}
            pairs = sorted(set(p) & set(q))
            out["ttest_collisions" + suffix] = paired_ttest([p[k]["collisions"] for k in pairs], [q[k]["collisions"] for k in pairs])
            out["mcnemar_success" + suffix] = mcnemar([int(p[k]["success"]) for k in pairs], [int(q[k]["success"]) for k in pairs])
    return out


def _ci(d: dict[str, Any]) -> str:
    lo, hi = d["success_ci95"]
    return f"{d['success']}/{d['runs']} [{lo:.2f}, {hi:.2f}]"


def _per_run(d: dict[str, Any], key: str) -> str:
    m = d[key]
    if m["mean"] is None:
        return "—"
    if m["lo"] is None:
        return f"{m['mean']:.2f}"
    return f"{m['mean']:.2f} [{max(0.0, m['lo']):.2f}, {m['hi']:.2f}]"


def table(summary: dict[str, Any], paper: dict[str, Any] | None = None) -> str:
    """The summary as a text table (the paper's figures beside it when given)."""
    c = summary["conditions"]
    names = [n for n in _NAMES if n in c]
    rows: list[tuple[str, list[str]]] = [
        ("success (95 % Wilson)", [_ci(c[n]) for n in names]),
        ("truly at the goal", [f"{c[n]['reached_goal']}/{c[n]['runs']}" for n in names]),
        ("believed at the goal", [f"{c[n]['believed_goal']}/{c[n]['runs']}" for n in names]),
        ("unconfirmed at the goal", [f"{c[n].get('goal_unconfirmed', 0)}/{c[n]['runs']}" for n in names]),
        ("false successes", [f"{c[n].get('false_successes', 0)}/{c[n]['runs']}" for n in names]),
        ("collisions (total)", [f"{c[n]['collisions']} (in {c[n]['runs_with_collision']} runs)" for n in names]),
        ("brushes (total)", [str(c[n]["brushes"]) for n in names]),
        ("collisions per run (95 %)", [_per_run(c[n], "collisions_per_run") for n in names]),
        ("final error, median (m)", ["—" if c[n]["final_error_median_m"] is None else f"{c[n]['final_error_median_m']:.3f}"
                                     for n in names]),
        ("planning time (s, 1st plan)", ["—" if c[n]["planning_time_s"]["mean"] is None else
                                         f"{c[n]['planning_time_s']['mean']:.3f} ± {c[n]['planning_time_s']['sd']:.3f}"
                                         for n in names]),
        ("states (1st plan)", ["—" if c[n]["states"]["mean"] is None else
                               f"{c[n]['states']['mean']:.1f} ± {c[n]['states']['sd']:.1f}" for n in names]),
    ]
    for k in ("checks", "recalls", "fresh_plans"):
        if any(k in c[n] for n in names):
            rows.append((k.replace("_", " "), [str(c[n].get(k, "—")) for n in names]))
    w0 = max(len(r[0]) for r in rows) + 2
    w1 = 26
    head = f"{summary.get('family', '')} · noise {summary.get('noise', '')} × {', '.join(f'{s:g}' for s in summary.get('noise_scales', [1.0]))}" \
           f" · seed {summary.get('seed', '')} · world {summary.get('world', '')}"
    lines = [head, f"{'':<{w0}}" + "".join(f"{n:<{w1}}" for n in names) + ("paper (planning | reactive)" if paper else "")]
    paper_col = {}
    if paper:
        pp, pr = paper["planning"], paper["reactive"]
        paper_col = {
            "success (95 % Wilson)": f"{pp['reached_goal']}/{pp['runs']} | {pr['reached_goal']}/{pr['runs']}",
            "collisions (total)": f"{pp['collisions']} | {pr['collisions']}",
            "brushes (total)": f"{pp['brushes']} | —",
            "planning time (s, 1st plan)": f"{pp['planning_time_s'][0]:.3f} ± {pp['planning_time_s'][1]:.3f} | —",
            "states (1st plan)": f"{pp['states'][0]:.1f} ± {pp['states'][1]:.1f} | —",
        }
    for label, vals in rows:
        lines.append(f"{label:<{w0}}" + "".join(f"{v:<{w1}}" for v in vals) + paper_col.get(label, ""))
    for other, suffix in BASELINES:
        t = summary.get("ttest_collisions" + suffix)
        if t:
            mine = f"T = {t['t']:.3f}, p = {t['p']:.3g}" if t["t"] is not None else t["note"]
            ref = f"   [paper: T = {paper['ttest']['t']}, p = {paper['ttest']['p']}]" if paper and not suffix else ""
            lines.append(f"paired t-test on collisions (planning − {other}, n={t['n']}): {mine}{ref}")
        m = summary.get("mcnemar_success" + suffix)
        if m:
            lines.append(f"McNemar on success: only planning {m['b10']}, only {other} {m['b01']}, exact p = {m['p']:.4g}")
    lines.append(f"success = truly within {summary.get('success_radius_m', SUCCESS_RADIUS_M)} m of the goal (ground truth); "
                 "collision = contact episode (gaps < 1 s merged), brush = < 1 cm deep and < 0.5 s")
    return "\n".join(lines)


MARKDOWN_HEADER = ("| family | noise | runs | planning: success [95 %] | reactive: success [95 %] | "
                   "planning: collisions / brushes | reactive: collisions / brushes | "
                   "collisions per run, planning − reactive (paired t, p) | McNemar p |\n"
                   "|---|---|---|---|---|---|---|---|---|")


def markdown_rows(summary: dict[str, Any]) -> str:
    """One Markdown row of the experiment table for one (family, noise) summary."""
    c = summary["conditions"]
    p, r = c.get("planning"), c.get("reactive")
    if p is None or r is None:
        raise ValueError("the README row needs both conditions")
    t, m = summary.get("ttest_collisions", {}), summary.get("mcnemar_success", {})
    diff = (p["collisions_per_run"]["mean"] or 0.0) - (r["collisions_per_run"]["mean"] or 0.0)
    tp = "—" if t.get("p") is None else f"{t['p']:.2g}"
    return (f"| {summary.get('family')} | {summary.get('noise')} | {p['runs']} | {_ci(p)} | {_ci(r)} | "
            f"{p['collisions']} / {p['brushes']} | {r['collisions']} / {r['brushes']} | {diff:+.2f} (p {tp}) | "
            f"{m.get('p', float('nan')):.2g} |")


CONDITIONS_HEADER = ("| family | noise | condition | runs | reached (success) [95 % CI] | collisions | false successes | "
                     "unconfirmed | median time to goal (s) | paired vs planning (McNemar p) |\n"
                     "|---|---|---|---|---|---|---|---|---|---|")
"""The header of the every-condition table (docs/experiment-room.md): one row per condition."""


def condition_rows(summary: dict[str, Any]) -> str:
    """One Markdown row per condition of one (family, noise) summary, under :data:`CONDITIONS_HEADER`.

    Success with its Wilson interval, collisions, false successes, unconfirmed ends, the median
    time to the goal of the runs that truly reached it, and McNemar's p of each baseline paired
    with planning on the same layouts ("—" for planning itself or without a planning run).

    >>> recs = [{"condition": c, "run": 0, "seed": 0, "success": 1, "reached_goal": 1, "believed_goal": 1,
    ...          "collisions": 0, "brushes": 0, "final_error_m": 0.02, "time_s": 9.0, "time_to_goal_s": 9.0,
    ...          "wall_s": 1.0, "expect": "reach"} for c in ("planning", "dwa")]
    >>> print(condition_rows({"family": "corridor", "noise": "paper", **summarise(recs)}).splitlines()[1])
    | corridor | paper | dwa | 1 | 1 [0.21, 1.00] | 0 | 0 | 0 | 9.0 | 1 |
    """
    c = summary["conditions"]
    rows = []
    for name in (n for n in _NAMES if n in c):
        d = c[name]
        lo, hi = d["success_ci95"]
        t = d.get("time_to_goal_median_s")
        suffix = dict(BASELINES).get(name)
        m = summary.get("mcnemar_success" + suffix) if suffix is not None else None
        p = "—" if m is None else f"{m['p']:.2g}"
        rows.append(f"| {summary.get('family')} | {summary.get('noise')} | {name} | {d['runs']} | "
                    f"{d['success']} [{lo:.2f}, {hi:.2f}] | {d['collisions']} | {d.get('false_successes', 0)} | "
                    f"{d.get('goal_unconfirmed', 0)} | {'—' if t is None else f'{t:.1f}'} | "
                    f"{p} |")
    return "\n".join(rows)


def conditions_table(records: Iterable[dict[str, Any]]) -> str:
    """The every-condition Markdown table of a sweep's records: a cell per (family, noise,
    noise scale, gyro), in the order the families and presets first appear, rows from
    :func:`condition_rows` ("no gyro" added to the noise of a cell run without it).

    >>> recs = [{"family": "corridor", "noise": "paper", "condition": "planning", "run": 0, "seed": 0, "success": 1,
    ...          "reached_goal": 1, "believed_goal": 1, "collisions": 0, "brushes": 0, "final_error_m": 0.02,
    ...          "time_s": 9.0, "time_to_goal_s": 9.0, "wall_s": 1.0, "expect": "reach", "gyro": 0}]
    >>> conditions_table(recs).splitlines()[-1]
    '| corridor | paper, no gyro | planning | 1 | 1 [0.21, 1.00] | 0 | 0 | 0 | 9.0 | — |'
    """
    cells: dict[tuple[str, str, float, int], list[dict[str, Any]]] = {}
    for r in records:
        key = (str(r.get("family", "")), str(r.get("noise", "")), float(r.get("noise_scale", 1.0)), int(r.get("gyro", 1)))
        cells.setdefault(key, []).append(r)
    fam_order = {k[0]: i for i, k in reversed(list(enumerate(cells)))}
    noise_order = {k[1]: i for i, k in reversed(list(enumerate(cells)))}
    out = [CONDITIONS_HEADER]
    for key in sorted(cells, key=lambda k: (fam_order[k[0]], noise_order[k[1]], k[2], -k[3])):
        fam, noise, scale, gyro = key
        label = noise + ("" if scale == 1.0 else f" ×{scale:g}") + ("" if gyro else ", no gyro")
        out.append(condition_rows({**summarise(cells[key]), "family": fam, "noise": label}))
    return "\n".join(out)
