"""An experiment's or a sweep's results as one static HTML page, viewable offline.

:func:`write_report` groups the records by (family, noise preset, noise scale, gyro) — one
block per cell of a sweep, one for a plain experiment — and writes, per block: the summary
table of every condition (truly at the goal with its Wilson 95 % interval, believed,
unconfirmed, false successes, collisions with a t interval per run, brushes, median final
error and time to the goal), each baseline's paired tests against planning (McNemar on
success, the paired t-test on collisions), the paper's figures beside ``overtaking``, and
a drill-down: every run a row, its trajectory (the layout, the true path, the estimate, the
contacts, the goal) drawn as inline SVG behind a ``<details>`` (the lines thinned to the
pixel, so a 10,000-run sweep's page stays tens of MB, not hundreds). A sweep's page opens
on "Every cell": one row per cell and condition, each linking to its block. The experiment's PNGs in the
same folder are embedded (base64), so the page is one file with no external reference.

>>> import tempfile, pathlib
>>> rec = {"key": "k", "family": "open", "noise": "ideal", "noise_scale": 1.0, "gyro": 1, "condition": "planning",
...        "run": 0, "success": 1, "reached_goal": 1, "believed_goal": 1, "collisions": 0, "brushes": 0,
...        "final_error_m": 0.02, "time_s": 11.0, "time_to_goal_s": 11.0, "wall_s": 0.5, "end_state": "GOAL_REACHED",
...        "obstacles": [], "goal": [1.0, 0.0], "start": [0.0, 0.0, 0.0], "path": [[0, 0], [1, 0]], "estimate": [],
...        "contacts": []}
>>> page = write_report([rec], pathlib.Path(tempfile.mkdtemp()) / "report.html", "demo")
>>> "<svg" in page.read_text() and "1/1" in page.read_text()
True
"""

from __future__ import annotations

import base64
import html
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.results import BASELINES, PAPER, summarise

__all__ = ["block_key", "write_report"]

_CSS = """body{font:14px/1.4 system-ui,sans-serif;margin:2em auto;max-width:1100px;color:#222}
table{border-collapse:collapse;margin:.5em 0}td,th{border:1px solid #ccc;padding:.2em .5em;text-align:right}
th:first-child,td:first-child{text-align:left}h2{border-top:2px solid #888;padding-top:.5em}
details{margin:.1em 0}summary{cursor:pointer}.bad{color:#b00}.ok{color:#070}img{max-width:100%}
nav a{margin-right:1em}"""


_LEGEND = "grey: obstacles · blue: the true path · dashed orange: the robot's estimate · red rings: contacts · ♥: the goal"


def block_key(rec: dict[str, Any]) -> tuple[str, str, float, int]:
    """The cell of a sweep a record belongs to: (family, noise, noise scale, gyro).

    >>> block_key({"family": "corridor", "noise": "harsh", "noise_scale": 1.0, "gyro": 0})
    ('corridor', 'harsh', 1.0, 0)
    """
    return (str(rec.get("family", "")), str(rec.get("noise", "")), float(rec.get("noise_scale", 1.0)),
            int(rec.get("gyro", 1)))


def _e(x: Any) -> str:
    return html.escape(str(x))


def _interval(lo: float | None, hi: float | None) -> str:
    return "" if lo is None or hi is None else f" [{max(0.0, lo):.2f}, {hi:.2f}]"  # counts: never below 0


def _num(v: Any, fmt: str = "{:.3f}") -> str:
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else fmt.format(v)


def _summary_table(summary: dict[str, Any]) -> str:
    c = summary["conditions"]
    names = list(c)
    rows: list[tuple[str, list[str]]] = [
        ("truly at the goal / success [95 % Wilson]",
         [f"{c[n]['success']}/{c[n]['runs']}{_interval(*c[n]['success_ci95'])}" for n in names]),
        ("believed at the goal", [f"{c[n]['believed_goal']}/{c[n]['runs']}" for n in names]),
        ("unconfirmed at the goal", [f"{c[n].get('goal_unconfirmed', 0)}/{c[n]['runs']}" for n in names]),
        ("false successes", [f"{c[n].get('false_successes', 0)}/{c[n]['runs']}" for n in names]),
        ("collisions (runs with one)", [f"{c[n]['collisions']} ({c[n]['runs_with_collision']})" for n in names]),
        ("collisions per run [95 % t]", [_num(c[n]["collisions_per_run"]["mean"], "{:.2f}")
                                         + _interval(c[n]["collisions_per_run"]["lo"], c[n]["collisions_per_run"]["hi"])
                                         for n in names]),
        ("brushes", [str(c[n]["brushes"]) for n in names]),
        ("final error, median (m)", [_num(c[n]["final_error_median_m"]) for n in names]),
        ("time to the goal, mean (s)", [_num(c[n]["time_to_goal_s"]["mean"], "{:.1f}") for n in names]),
    ]
    head = "<tr><th></th>" + "".join(f"<th>{_e(n)}</th>" for n in names) + "</tr>"
    body = "".join("<tr><td>" + _e(label) + "</td>" + "".join(f"<td>{_e(v)}</td>" for v in vals) + "</tr>"
                   for label, vals in rows)
    return f"<table>{head}{body}</table>"


def _tests(summary: dict[str, Any]) -> str:
    out = []
    for other, suffix in BASELINES:
        m, t = summary.get("mcnemar_success" + suffix), summary.get("ttest_collisions" + suffix)
        if m:
            out.append(f"<li>planning vs {other}: McNemar on success — only planning {m['b10']}, only {other} "
                       f"{m['b01']}, exact p = {m['p']:.3g}")
        if t:
            mine = f"T = {t['t']:.3f}, p = {t['p']:.3g}" if t.get("t") is not None else _e(t.get("note", ""))
            out.append(f"<li>planning − {other}: paired t-test on collisions (n = {t['n']}): {mine}")
    return "<ul>" + "".join(out) + "</ul>" if out else ""


def _paper(family: str) -> str:
    if family != "overtaking":
        return ""
    pp, pr = PAPER["planning"], PAPER["reactive"]
    return (f"<p>The paper (overtaking, real robot, 10 runs each): planning reached {pp['reached_goal']}/{pp['runs']} "
            f"with {pp['collisions']} collisions; reactive {pr['reached_goal']}/{pr['runs']} with {pr['collisions']}.</p>")


def _thin(line: Sequence[Sequence[float]], step: float) -> list[Sequence[float]]:
    """The polyline's points at least ``step`` (m, a pixel) from the last one kept, and its end.

    A run's path holds a point every 0.1 s, most of them within a pixel of the last (the robot
    stands or creeps): drawn at 260 px they add bytes, not ink — a 10,000-run sweep's page
    would be ~100 MB.

    >>> _thin([(0.0, 0.0), (0.001, 0.0), (0.002, 0.0), (0.5, 0.0), (0.501, 0.0)], 0.01)
    [(0.0, 0.0), (0.5, 0.0), (0.501, 0.0)]
    """
    if len(line) < 3:
        return list(line)
    kept = [line[0]]
    for p in line[1:-1]:
        q = kept[-1]
        if abs(p[0] - q[0]) >= step or abs(p[1] - q[1]) >= step:
            kept.append(p)
    kept.append(line[-1])
    return kept


def _svg(rec: dict[str, Any], size: int = 260) -> str:
    """The run drawn in the plane: obstacles grey, true path blue, estimate dashed, contacts red, goal ♥."""
    from clomp.runtime.experiment.report import record_scene

    try:
        scene = record_scene(rec)
    except Exception:  # a record without its layout (a summary record): nothing to draw
        return "<em>no trace kept for this run</em>"
    pts = [tuple(p) for p in rec.get("path", [])] + [tuple(scene.goal), (scene.start.x, scene.start.y)]
    xs, ys = [p[0] for p in pts], [p[1] for p in pts]
    x0, x1, y0, y1 = min(xs) - 0.4, max(xs) + 0.4, min(ys) - 0.4, max(ys) + 0.4
    w = max(x1 - x0, y1 - y0)
    x0, y1 = x0 - (w - (x1 - x0)) / 2, y1 + (w - (y1 - y0)) / 2  # the drawing centred in its square
    k = size / w

    def xy(p: Sequence[float]) -> str:
        return f"{(p[0] - x0) * k:.1f},{(y1 - p[1]) * k:.1f}"

    parts = []
    for s in scene.shapes:
        if s.kind == "circle":
            parts.append(f'<circle cx="{(s.center[0] - x0) * k:.1f}" cy="{(y1 - s.center[1]) * k:.1f}" '
                         f'r="{s.radius * k:.1f}" fill="#999"/>')
        else:
            parts.append(f'<polygon points="{" ".join(xy(v) for v in s.vertices)}" fill="#999"/>')
    for key, style in (("estimate", 'stroke="#e80" stroke-dasharray="4 3"'), ("path", 'stroke="#14c"')):
        line = _thin(rec.get(key) or [], 2.0 / k)  # 2 px: under the 2 px stroke
        if len(line) > 1:
            parts.append(f'<polyline points="{" ".join(xy(p) for p in line)}" fill="none" {style} stroke-width="2"/>')
    for c in rec.get("contacts") or []:
        parts.append(f'<circle cx="{(c[0] - x0) * k:.1f}" cy="{(y1 - c[1]) * k:.1f}" r="5" fill="none" stroke="#d00" stroke-width="2"/>')
    gx, gy = (scene.goal[0] - x0) * k, (y1 - scene.goal[1]) * k
    parts.append(f'<text x="{gx:.1f}" y="{gy:.1f}" fill="red" font-size="16" text-anchor="middle" dominant-baseline="central">♥</text>')
    return (f'<svg xmlns="http://www.w3.org/2000/svg" width="{size}" height="{size}" viewBox="0 0 {size} {size}" '
            f'style="background:#fafafa">{"".join(parts)}</svg>')


def _runs(recs: list[dict[str, Any]]) -> str:
    rows = []
    for i, r in enumerate(sorted(recs, key=lambda r: (int(r["run"]), str(r["condition"])))):
        ok = int(r.get("success", 0))
        false = int(r.get("false_success") or 0)
        cls = "bad" if false or int(r.get("collisions", 0)) else ("ok" if ok else "")
        label = (f"run {int(r['run'])} · {r['condition']} · {r.get('end_state', '')} · truly "
                 f"{_num(r.get('final_error_m'))} m off · {r.get('collisions', 0)} collisions"
                 + (" · FALSE SUCCESS" if false else ""))
        rows.append(f'<details{" open" if i == 0 else ""}><summary class="{cls}">{_e(label)}</summary>{_svg(r)}'
                    f"<p>{_e(r.get('reason', ''))}<br><small>{_LEGEND}</small></p></details>")
    return "".join(rows)


def _overview(cells: list[tuple[int, str, dict[str, Any]]]) -> str:
    """One row per cell and condition: success with its interval, false successes, unconfirmed,
    collisions — the sweep at a glance, each row linking to its cell's block."""
    head = ("<tr><th>cell</th><th>condition</th><th>runs</th><th>truly at the goal [95 % Wilson]</th>"
            "<th>false successes</th><th>unconfirmed</th><th>collisions (runs with one)</th></tr>")
    rows = []
    for i, name, s in cells:
        for cond, c in s["conditions"].items():
            fs = int(c.get("false_successes", 0))
            rows.append(f'<tr><td><a href="#b{i}">{_e(name)}</a></td><td>{_e(cond)}</td><td>{c["runs"]}</td>'
                        f"<td>{c['success']}{_interval(*c['success_ci95'])}</td>"
                        f'<td{" class=bad" if fs else ""}>{fs}</td><td>{c.get("goal_unconfirmed", 0)}</td>'
                        f"<td>{c['collisions']} ({c['runs_with_collision']})</td></tr>")
    return f"<h2>Every cell</h2><table>{head}{''.join(rows)}</table>"


def _images(folder: Path) -> str:
    out = []
    for png in sorted(folder.glob("*.png")):
        data = base64.b64encode(png.read_bytes()).decode("ascii")
        out.append(f'<figure><img alt="{_e(png.name)}" src="data:image/png;base64,{data}"><figcaption>{_e(png.name)}'
                   "</figcaption></figure>")
    return "".join(out)


def write_report(records: Iterable[dict[str, Any]], path: str | os.PathLike[str], title: str,
                 images: str | os.PathLike[str] | None = None) -> Path:
    """Write the page (see the module) to ``path``; ``images``: a folder whose PNGs it embeds."""
    recs = list(records)
    blocks: dict[tuple[str, str, float, int], list[dict[str, Any]]] = {}
    for r in recs:
        blocks.setdefault(block_key(r), []).append(r)
    nav, sections, cells = [], [], []
    for i, (key, rs) in enumerate(sorted(blocks.items())):
        fam, noise, scale, gyro = key
        name = f"{fam} · noise {noise} ×{scale:g}" + ("" if gyro else " · no gyro")
        nav.append(f'<a href="#b{i}">{_e(name)}</a>')
        s = summarise(rs)
        cells.append((i, name, s))
        sections.append(f'<h2 id="b{i}">{_e(name)} — {len(rs)} runs</h2>{_summary_table(s)}{_tests(s)}{_paper(fam)}'
                        f"<h3>Every run</h3>{_runs(rs)}")
    if len(cells) > 1:
        nav.append(_overview(cells))
    figures = _images(Path(images)) if images is not None else ""
    page = (f"<!doctype html><html lang=en><meta charset=utf-8><title>{_e(title)}</title><style>{_CSS}</style>"
            f"<h1>{_e(title)}</h1><p>{len(recs)} runs. Success = truly within 0.1 m of the goal (ground truth); a false "
            "success claims the goal while truly farther; collision = a contact episode.</p>"
            f"<nav>{''.join(nav)}</nav>{''.join(sections)}{figures}</html>\n")
    out = Path(path)
    out.parent.mkdir(parents=True, exist_ok=True)
    out.write_text(page, encoding="utf-8")
    return out
