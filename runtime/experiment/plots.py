"""Pictures of executed runs: where the robot went, what it planned, where it hit something.

Drawn headless (matplotlib's Agg backend) in the scene's world frame. Obstacles are grey,
the target a red heart and collisions red stars (as in the paper's figure 3); the
executed (ground-truth) path is a solid line, the supervisor's planned paths dashed, and
the robot's body outline is drawn at the start and at the end.
"""

from __future__ import annotations

import math
import os
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from planner.robot import RobotModel
from planner.scenarios import Scene

__all__ = ["RunTrace", "plot_run", "plot_runs"]

_HEART = r"$\heartsuit$"


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


def _axes_limits(traces: Sequence[RunTrace]) -> tuple[float, float, float, float]:
    xs: list[float] = []
    ys: list[float] = []
    for t in traces:
        pts = list(t.path) + [t.scene.goal, (t.scene.start.x, t.scene.start.y)]
        for poly in t.plans:
            pts += poly
        xs += [p[0] for p in pts]
        ys += [p[1] for p in pts]
    margin = 0.3
    x0, x1, y0, y1 = min(xs) - margin, max(xs) + margin, min(ys) - margin, max(ys) + margin
    # square-ish: grow the shorter side
    w, h = x1 - x0, y1 - y0
    if h < 0.6 * w:
        c = (y0 + y1) / 2
        y0, y1 = c - 0.3 * w, c + 0.3 * w
    return x0, x1, y0, y1


def _body(ax: Any, pose: tuple[float, float, float], model: RobotModel, **kw: Any) -> None:
    from matplotlib.patches import Polygon

    x, y, th = pose
    c, s = math.cos(th), math.sin(th)
    corners = [(-model.rear_offset, -model.width / 2), (model.front_offset, -model.width / 2),
               (model.front_offset, model.width / 2), (-model.rear_offset, model.width / 2)]
    ax.add_patch(Polygon([(x + c * u - s * v, y + s * u + c * v) for u, v in corners], closed=True, fill=False, **kw))


def _draw(ax: Any, t: RunTrace, model: RobotModel, legend: bool) -> None:
    from matplotlib.patches import Circle, Polygon

    for s in t.scene.shapes:
        if s.kind == "circle":
            ax.add_patch(Circle(s.center, s.radius, color="0.55", zorder=1))
        else:
            ax.add_patch(Polygon(s.vertices, closed=True, color="0.55", zorder=1))
    for k, poly in enumerate(t.plans):
        if len(poly) > 1:
            ax.plot([p[0] for p in poly], [p[1] for p in poly], "--", color="tab:orange", lw=1.0, alpha=0.8,
                    zorder=2, label="planned" if k == 0 else None)
    if t.estimate:
        ax.plot([p[0] for p in t.estimate], [p[1] for p in t.estimate], ":", color="tab:purple", lw=1.0,
                zorder=3, label="robot's estimate")
    if t.path:
        ax.plot([p[0] for p in t.path], [p[1] for p in t.path], "-", color="tab:blue", lw=1.8, zorder=4, label="executed")
    for pose in t.poses:
        _body(ax, pose, model, edgecolor="tab:blue", lw=0.8, zorder=4)
    ax.plot(*t.scene.goal, marker=_HEART, color="red", markersize=16, ls="none", zorder=5, label="target")
    ax.plot(t.scene.start.x, t.scene.start.y, "o", color="tab:blue", markersize=4, zorder=5)
    if t.collisions:
        ax.plot([c[0] for c in t.collisions], [c[1] for c in t.collisions], "*", color="red", markeredgecolor="black",
                markersize=15, ls="none", zorder=6, label="collision")
    ax.set_title(t.title, fontsize=9, color="black" if t.ok else "firebrick")
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    if legend:
        ax.legend(loc="upper left", fontsize=7, framealpha=0.8)


def plot_run(trace: RunTrace, path: str | os.PathLike[str], model: RobotModel | None = None, title: str | None = None) -> None:
    """Draw one run to a PNG file."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

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
    """Draw many runs, one small panel each (same scale), to a PNG file."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = max(1, len(traces))
    cols = min(cols, n)
    rows = int(math.ceil(n / cols))
    fig, axes = plt.subplots(rows, cols, figsize=(3.2 * cols, 2.9 * rows + 0.6), squeeze=False, sharex=True, sharey=True)
    try:
        lim = _axes_limits(traces) if traces else (-1.0, 1.0, -1.0, 1.0)
        for k, ax in enumerate(axes.flat):
            if k >= len(traces):
                ax.axis("off")
                continue
            _draw(ax, traces[k], model or RobotModel(), legend=(k == 0))
            ax.set_xlim(lim[0], lim[1])
            ax.set_ylim(lim[2], lim[3])
        fig.suptitle(title)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
    finally:
        plt.close(fig)
