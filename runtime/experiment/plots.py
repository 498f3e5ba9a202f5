"""Pictures of an experiment: runs, collisions per run, success against noise, a layout gallery.

Drawn headless (matplotlib's Agg backend) in the scene's world frame, axes in metres.
Obstacles are grey, the target a red heart and collisions red stars (as in the paper's
figure 3). The executed (ground-truth) path is a wide pale line drawn *under* the
robot's own estimate (dotted) and the planned paths (dashed), so neither hides the
other; the legend names every mark that is on the panel — obstacle, robot body (start
and end), target, collision — and nothing that is not (a reactive run has no plan).

- :func:`plot_run` / :func:`plot_runs` — one run, or a grid of runs at one scale;
- :func:`plot_collisions` — collisions and brushes per run, both conditions side by side;
- :func:`plot_success_vs_noise` — success rate with Wilson 95 % intervals per noise scale;
- :func:`plot_gallery` — sample layouts of every family.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene

__all__ = ["RunTrace", "plot_collisions", "plot_gallery", "plot_run", "plot_runs", "plot_success_vs_noise"]

_HEART = r"$\heartsuit$"
_EXEC = "#7fb3e0"


@dataclass
class RunTrace:
    """What one run leaves to draw, all in the scene's world frame.

    ``path``: executed (true) positions; ``estimate``: the robot's own pose estimate;
    ``plans``: planned paths (polylines through the planned task ends); ``collisions``:
    contact points; ``poses``: (x, y, theta) to outline the body at (start, end).
    """

    scene: Scene
    title: str
    path: list[tuple[float, float]]
    collisions: list[tuple[float, float]] = field(default_factory=list)
    plans: list[list[tuple[float, float]]] = field(default_factory=list)
    estimate: list[tuple[float, float]] = field(default_factory=list)
    poses: list[tuple[float, float, float]] = field(default_factory=list)
    ok: bool = True


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _scene_points(scene: Scene) -> list[tuple[float, float]]:
    pts: list[tuple[float, float]] = [scene.goal, (scene.start.x, scene.start.y)]
    for s in scene.shapes:
        if s.kind == "circle":
            pts += [(s.center[0] - s.radius, s.center[1] - s.radius), (s.center[0] + s.radius, s.center[1] + s.radius)]
        else:
            pts += list(s.vertices)
    return pts


def _axes_limits(traces: Sequence[RunTrace]) -> tuple[float, float, float, float]:
    xs: list[float] = []
    ys: list[float] = []
    for t in traces:
        pts = list(t.path) + [t.scene.goal, (t.scene.start.x, t.scene.start.y)]
        for poly in t.plans:
            pts += poly
        # obstacles near the action, not a wall running off far away
        pts += [p for p in _scene_points(t.scene) if -0.8 <= p[0] <= 2.2 and abs(p[1]) <= 1.2]
        xs += [p[0] for p in pts]
        ys += [p[1] for p in pts]
    margin = 0.2
    x0, x1, y0, y1 = min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin
    w, h = x1 - x0, y1 - y0
    if h < 0.6 * w:
        c = (y0 + y1) / 2
        y0, y1 = c - 0.3 * w, c + 0.3 * w
    return x0, x1, y0, y1


def _outline(pose: tuple[float, float, float], model: RobotModel) -> list[tuple[float, float]]:
    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    corners = [(-model.rear_offset, -model.width / 2), (model.front_offset, -model.width / 2),
               (model.front_offset, model.width / 2), (-model.rear_offset, model.width / 2)]
    return [(x + c * u - s * v, y + s * u + c * v) for u, v in corners]


def _draw_scene(ax: Any, scene: Scene) -> None:
    from matplotlib.patches import Circle, Polygon

    for s in scene.shapes:
        if s.kind == "circle":
            ax.add_patch(Circle(s.center, s.radius, color="0.55", zorder=1))
        else:
            ax.add_patch(Polygon(s.vertices, closed=True, color="0.55", zorder=1))
    ax.plot(*scene.goal, marker=_HEART, color="red", markersize=14, ls="none", zorder=6)


def _handles(ts: Sequence[RunTrace]) -> list[Any]:
    """Legend entries for exactly the marks drawn on the panels of ``ts``."""
    from matplotlib.lines import Line2D
    from matplotlib.patches import Patch

    h: list[Any] = [Patch(color="0.55", label="obstacle")]
    if any(x.path for x in ts):
        h.append(Line2D([], [], color=_EXEC, lw=4, label="executed (ground truth)"))
    if any(x.estimate for x in ts):
        h.append(Line2D([], [], color="tab:purple", ls=":", lw=1.4, label="robot's estimate"))
    if any(len(p) > 1 for x in ts for p in x.plans):
        h.append(Line2D([], [], color="tab:orange", ls="--", lw=1.2, label="planned"))
    if any(x.poses for x in ts):
        h.append(Patch(fill=False, edgecolor="tab:blue", label="robot body (start, end)"))
    h.append(Line2D([], [], marker=_HEART, color="red", ls="none", markersize=10, label="target"))
    if any(x.collisions for x in ts):
        h.append(Line2D([], [], marker="*", color="red", markeredgecolor="black", ls="none", markersize=11,
                        label="collision / brush"))
    return h


def _draw(ax: Any, t: RunTrace, model: RobotModel, legend: bool) -> None:
    from matplotlib.patches import Polygon

    _draw_scene(ax, t.scene)
    if t.path:  # underneath, wide and pale: the thin lines stay visible on top of it
        ax.plot([p[0] for p in t.path], [p[1] for p in t.path], "-", color=_EXEC, lw=4, solid_capstyle="round",
                zorder=2)
    for poly in t.plans:
        if len(poly) > 1:
            ax.plot([p[0] for p in poly], [p[1] for p in poly], "--", color="tab:orange", lw=1.2, zorder=4)
    if t.estimate:
        ax.plot([p[0] for p in t.estimate], [p[1] for p in t.estimate], ":", color="tab:purple", lw=1.4, zorder=5)
    for pose in t.poses:
        ax.add_patch(Polygon(_outline(pose, model), closed=True, fill=False, edgecolor="tab:blue", lw=0.9, zorder=3))
    ax.plot(t.scene.start.x, t.scene.start.y, "o", color="tab:blue", markersize=3, zorder=6)
    if t.collisions:
        ax.plot([c[0] for c in t.collisions], [c[1] for c in t.collisions], "*", color="red", markeredgecolor="black",
                markersize=13, ls="none", zorder=7)
    ax.set_title(t.title, fontsize=9, color="black" if t.ok else "firebrick")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    if legend:
        ax.legend(handles=_handles([t]), loc="upper left", fontsize=7, framealpha=0.85)


def plot_run(trace: RunTrace, path: str | os.PathLike[str], model: RobotModel | None = None, title: str | None = None) -> None:
    """Draw one run to a PNG file.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from clomp.planner import load_scenario
    >>> png = Path(tempfile.mkdtemp()) / "run.png"
    >>> plot_run(RunTrace(load_scenario("open"), "a straight run", [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)]), png)
    >>> png.read_bytes()[1:4] == b"PNG"
    True
    """
    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(7, 6))
    try:
        _draw(ax, trace, model or RobotModel(), legend=True)
        x0, x1, y0, y1 = _axes_limits([trace])
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_xlabel("x (m)")
        ax.set_ylabel("y (m)")
        if title:
            fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(path, dpi=120)
    finally:
        plt.close(fig)


def plot_runs(traces: Sequence[RunTrace], path: str | os.PathLike[str], title: str, model: RobotModel | None = None,
              cols: int = 5) -> None:
    """Draw many runs, one small panel each (same scale, axes in metres), to a PNG file.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from clomp.planner import load_scenario
    >>> png = Path(tempfile.mkdtemp()) / "runs.png"
    >>> trace = RunTrace(load_scenario("open"), "run", [(0.0, 0.0), (1.0, 0.0)])
    >>> plot_runs([trace, trace], png, "two runs")
    >>> png.stat().st_size > 0
    True
    """
    plt = _pyplot()
    n = max(1, len(traces))
    cols = min(cols, n)
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.9 * rows + 0.8), squeeze=False, sharex=True, sharey=True)
    try:
        lim = _axes_limits(traces) if traces else (-1.0, 1.0, -1.0, 1.0)
        for k, ax in enumerate(axes.flat):
            if k >= len(traces):
                ax.axis("off")
                continue
            _draw(ax, traces[k], model or RobotModel(), legend=False)
            ax.set_xlim(lim[0], lim[1])
            ax.set_ylim(lim[2], lim[3])
            if k % cols == 0:
                ax.set_ylabel("y (m)")
            if k // cols == rows - 1 or k + cols >= len(traces):
                ax.set_xlabel("x (m)")
                ax.tick_params(labelbottom=True)
        fig.suptitle(title)
        handles = _handles(traces)
        fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=8, frameon=False)
        fig.tight_layout(rect=(0, 0.45 / (2.9 * rows + 0.8), 1, 1))
        fig.savefig(path, dpi=100)
    finally:
        plt.close(fig)


def plot_collisions(per_run: dict[str, list[tuple[int, int]]], path: str | os.PathLike[str], title: str) -> None:
    """Collisions (solid) and brushes (hatched) per run, one bar per condition and run.

    ``per_run``: condition → [(collisions, brushes)] in run order.
    """
    plt = _pyplot()
    names = [n for n in ("planning", "reactive", "dwa", "rl") if n in per_run]
    n = max((len(v) for v in per_run.values()), default=0)
    fig, ax = plt.subplots(figsize=(max(6.0, 0.35 * n + 2), 3.6))
    try:
        width = 0.8 / max(1, len(names))
        colours = {"planning": "tab:blue", "reactive": "tab:red", "dwa": "tab:green", "rl": "tab:purple"}
        for j, name in enumerate(names):
            xs = [k + (j - (len(names) - 1) / 2) * width for k in range(len(per_run[name]))]
            col = [c for c, _ in per_run[name]]
            bru = [b for _, b in per_run[name]]
            ax.bar(xs, col, width, color=colours[name], label=f"{name}: collisions ({sum(col)})")
            ax.bar(xs, bru, width, bottom=col, color="white", edgecolor=colours[name], hatch="///",
                   label=f"{name}: brushes ({sum(bru)})")
        ax.set_xlabel("run")
        ax.set_ylabel("contact episodes in the run")
        if n <= 40:
            ax.set_xticks(range(n))
        ax.yaxis.get_major_locator().set_params(integer=True)
        ax.legend(fontsize=8)
        ax.set_title(title, fontsize=10)
        ax.grid(axis="y", alpha=0.3)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def plot_success_vs_noise(points: dict[str, list[tuple[float, int, int]]], path: str | os.PathLike[str], title: str) -> None:
    """Success rate against the noise scale, with Wilson 95 % intervals.

    ``points``: condition → [(noise_scale, successes, runs)].
    """
    from clomp.runtime.experiment.stats import wilson

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(6.4, 4.0))
    try:
        colours = {"planning": "tab:blue", "reactive": "tab:red", "dwa": "tab:green", "rl": "tab:purple"}
        for name, pts in points.items():
            pts = sorted(pts)
            xs = [p[0] for p in pts]
            rate = [p[1] / p[2] for p in pts]
            ci = [wilson(p[1], p[2]) for p in pts]
            ax.fill_between(xs, [c[0] for c in ci], [c[1] for c in ci], color=colours.get(name, "0.5"), alpha=0.15)
            ax.plot(xs, rate, "o-", color=colours.get(name, "0.5"), label=f"{name} (band: 95 % Wilson)")
        ax.set_xlabel("noise scale (× every noise term of the preset)")
        ax.set_ylabel("success rate")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
        ax.set_title(title, fontsize=10)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)


def plot_gallery(path: str | os.PathLike[str], families: Sequence[str] | None = None, seed: int = 0,
                 per_family: int = 4) -> None:
    """Sample layouts (rows: families; columns: runs 0..per_family-1 of ``seed``), axes in metres."""
    from clomp.runtime.experiment.layouts import FAMILIES, make_layout

    fams = list(families or FAMILIES)
    plt = _pyplot()
    fig, axes = plt.subplots(len(fams), per_family, figsize=(2.8 * per_family, 2.5 * len(fams) + 0.5), squeeze=False)
    model = RobotModel()
    try:
        for i, fam in enumerate(fams):
            for j in range(per_family):
                ax = axes[i][j]
                lay = make_layout(fam, seed, j)
                _draw_scene(ax, lay.scene)
                st = lay.scene.start
                from matplotlib.patches import Polygon

                ax.add_patch(Polygon(_outline((st.x, st.y, st.theta), model), closed=True, fill=False,
                                     edgecolor="tab:blue", lw=0.9))
                ax.set_xlim(-0.5, 2.0)
                ax.set_ylim(-1.0, 1.0)
                ax.set_aspect("equal")
                ax.grid(alpha=0.3)
                ax.set_title(f"{lay.scene.name}" + (" (unreachable)" if lay.expect == "unreachable" else ""), fontsize=8)
                if j == 0:
                    ax.set_ylabel(f"{fam}\ny (m)")
                if i == len(fams) - 1:
                    ax.set_xlabel("x (m)")
        fig.suptitle(f"layout families, seed {seed}: robot body at the start (blue), target ♥, obstacles grey")
        fig.tight_layout()
        fig.savefig(path, dpi=90)
    finally:
        plt.close(fig)
