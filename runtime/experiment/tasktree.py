"""The paper's Fig. 3C: the explored task tree drawn in the scene the planner saw.

Everything is in the planner's frame (the robot at the origin, x forward, y left, metres):
the scan points (black dots), the obstacle boxes perception built from them (grey, outlined orange:
a box is often a few millimetres thin), every
simulated task of the cognitive map as a line from its start to its end — a turn in place
as a small arc around its pivot — each state labelled as in the map (``q0``, ``q1`` …), the
interrupted states (collisions) starred where their trace ends, the plan drawn bold and the goal as a red heart.
Labels that would crowd (several turns at one pivot) stand in a column beside the spot, each
with a thin grey leader to it.

- :func:`draw_task_tree` — onto a matplotlib axes (returns the artists, for tests);
- :func:`plot_task_tree` — a PNG/SVG/PDF file (``clomp plan --figure``, ``clomp demo``).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from clomp.formal.geometry import polar_to_xy
from clomp.formal.model import State, TaskKind
from clomp.planner.configurator import PlanResult

__all__ = ["TaskTreeArtists", "draw_task_tree", "plot_task_tree"]

_PLAN_WIDTH = 3.0
_TREE_WIDTH = 0.9
_TURN_RADIUS = 0.035  # m: the arc that shows a turn in place
_LABEL_OFFSET = 0.02  # m: labels sit ahead of a state's end, along its heading


@dataclass
class TaskTreeArtists:
    """What :func:`draw_task_tree` drew, by role (matplotlib artists)."""

    scan: Any = None
    boxes: list[Any] = field(default_factory=list)
    tasks: dict[int, Any] = field(default_factory=dict)
    labels: dict[int, Any] = field(default_factory=dict)
    collisions: Any = None
    goal: Any = None


def _task_path(s: State) -> tuple[list[float], list[float]]:
    """The task's trace: a straight line, or for a turn in place an arc from start to end heading."""
    if s.task is TaskKind.STRAIGHT or math.hypot(s.end.x - s.start.x, s.end.y - s.start.y) > 1e-6:
        return [s.start.x, s.end.x], [s.start.y, s.end.y]
    a = np.linspace(s.start.theta, s.end.theta, 12)
    arc = polar_to_xy(np.full_like(a, _TURN_RADIUS), a)
    return list(s.start.x + arc[:, 0]), list(s.start.y + arc[:, 1])


def _label_at(s: State) -> tuple[float, float]:
    """Where a state's label goes: its end, pushed along its heading (turns: beyond the arc)."""
    r = _LABEL_OFFSET if s.task is TaskKind.STRAIGHT else _TURN_RADIUS + _LABEL_OFFSET
    return s.end.x + r * math.cos(s.end.theta), s.end.y + r * math.sin(s.end.theta)


def _label_groups(result: PlanResult, pts: np.ndarray) -> list[list[tuple[State, tuple[float, float]]]]:
    """The states whose labels would crowd — anchors within about a label's size of each other
    (5 % of the drawing's span across, 3 % up; e.g. several turns at one pivot), chained — gathered
    into groups of (state, anchor), each sorted top to bottom."""
    anchors = [(s, _label_at(s)) for s in result.map]
    xs = [a[0] for _, a in anchors] + list(pts[:, 0])
    ys = [a[1] for _, a in anchors] + list(pts[:, 1])
    span = max(max(xs) - min(xs), max(ys) - min(ys), 0.1)
    root = list(range(len(anchors)))

    def find(i: int) -> int:
        while root[i] != i:
            root[i] = root[root[i]]
            i = root[i]
        return i

    for i, (_, a) in enumerate(anchors):
        for j in range(i):
            b = anchors[j][1]
            if abs(a[0] - b[0]) < 0.05 * span and abs(a[1] - b[1]) < 0.03 * span:
                root[find(i)] = find(j)
    groups: dict[int, list[tuple[State, tuple[float, float]]]] = {}
    for i, sa in enumerate(anchors):
        groups.setdefault(find(i), []).append(sa)
    return [sorted(g, key=lambda sa: -sa[1][1]) for g in groups.values()]


def _draw_labels(ax: Any, result: PlanResult, pts: np.ndarray) -> dict[int, Any]:
    """One label per state: alone, at its anchor; in a crowd, the crowd's labels stacked in a
    column right of it (offset in points, so at any scale), each with a thin grey leader to its spot."""
    from matplotlib.transforms import offset_copy

    out = {}
    box = {"boxstyle": "round,pad=0.1", "facecolor": "white", "edgecolor": "none", "alpha": 0.7}  # legible over a line
    for group in _label_groups(result, pts):
        right = max(a[0] for _, a in group)
        middle = sum(a[1] for _, a in group) / len(group)
        for i, (s, (x, y)) in enumerate(group):
            weight = "bold" if s.ident in result.plan.states else "normal"
            if len(group) == 1:
                out[s.ident] = ax.text(x, y, f"q{s.ident}", fontsize=7, ha="center", va="center", zorder=7,
                                       fontweight=weight, bbox=box)
                continue
            place = offset_copy(ax.transData, fig=ax.figure, x=12, y=8.5 * ((len(group) - 1) / 2 - i), units="points")
            out[s.ident] = ax.annotate(f"q{s.ident}", (x, y), xytext=(right, middle), textcoords=place, fontsize=7,
                                       ha="left", va="center", zorder=7, fontweight=weight, bbox=box,
                                       arrowprops={"arrowstyle": "-", "color": "0.5", "lw": 0.5, "shrinkA": 0, "shrinkB": 1})
    return out


def draw_task_tree(ax: Any, result: PlanResult, scan: Any = None) -> TaskTreeArtists:
    """Draw ``result``'s explored task tree over ``scan`` (N×2, planner frame; default: the
    points the obstacle boxes cover) and the boxes; the plan bold, collisions starred.

    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> import clomp
    >>> scene = clomp.load_scenario("overtaking")
    >>> r = clomp.plan(scene.scan(), goal=scene.goal_in_robot_frame())
    >>> fig, ax = plt.subplots()
    >>> art = draw_task_tree(ax, r, scene.scan())
    >>> sorted(art.labels) == sorted(q.ident for q in r.map), art.labels[0].get_text()
    (True, 'q0')
    >>> plt.close(fig)
    """
    from matplotlib.patches import Polygon

    out = TaskTreeArtists()
    pts = np.asarray(result.obstacles.points if scan is None else scan, dtype=np.float64).reshape(-1, 2)
    out.scan = ax.scatter(pts[:, 0], pts[:, 1], s=4, color="black", zorder=4, label="scan points")
    for i in range(len(result.obstacles)):
        box = Polygon(result.obstacles.outline(i), closed=True, facecolor="0.75", edgecolor="tab:orange", lw=2.5, zorder=2,
                      label="obstacle boxes" if i == 0 else None)
        out.boxes.append(ax.add_patch(box))
    on_plan = set(result.plan.steps())
    parent = {t.target: t.source for t in result.map.transitions()}
    for s in result.map:
        bold = (parent.get(s.ident), s.ident) in on_plan
        xs, ys = _task_path(s)
        (line,) = ax.plot(xs, ys, color="black" if bold else "tab:blue", lw=_PLAN_WIDTH if bold else _TREE_WIDTH,
                          alpha=1.0 if bold else 0.7, zorder=5 if bold else 3, solid_capstyle="round")
        out.tasks[s.ident] = line
    out.labels = _draw_labels(ax, result, pts)
    hit = [(xs[-1], ys[-1]) for xs, ys in (_task_path(s) for s in result.map if s.interrupted)]
    if hit:
        out.collisions = ax.plot(*zip(*hit), marker="*", color="red", markersize=12, ls="none", zorder=6,
                                 label="collision (interrupted task)")[0]
    out.goal = ax.plot(result.goal.x, result.goal.y, marker=r"$\heartsuit$", color="red", markersize=14, ls="none",
                       zorder=6, label="goal")[0]
    ax.plot([], [], color="black", lw=_PLAN_WIDTH, label="plan")
    ax.plot([], [], color="tab:blue", lw=_TREE_WIDTH, label="explored task")
    ax.set_aspect("equal")
    ax.set_xlabel("x (m, robot frame at planning)")
    ax.set_ylabel("y (m)")
    return out


def plot_task_tree(result: PlanResult, path: str | os.PathLike[str], scan: Any = None, title: str | None = None) -> None:
    """Write the task-tree figure of ``result`` to ``path`` (the format from its suffix),
    the legend outside the data.

    >>> import tempfile
    >>> from pathlib import Path
    >>> import clomp
    >>> scene = clomp.load_scenario("overtaking")
    >>> r = clomp.plan(scene.scan(), goal=scene.goal_in_robot_frame())
    >>> with tempfile.TemporaryDirectory() as d:
    ...     plot_task_tree(r, Path(d) / "tree.png", scene.scan())
    ...     (Path(d) / "tree.png").stat().st_size > 0
    True
    """
    from clomp.runtime.experiment.plots import _pyplot

    plt = _pyplot()
    fig, ax = plt.subplots(figsize=(8, 6))
    try:
        draw_task_tree(ax, result, scan)
        ax.set_title(title or f"explored task tree: {len(result.map)} states, plan " + " ".join(f"q{i}" for i in result.plan.states),
                     fontsize=10)
        ax.legend(loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
        fig.savefig(path, dpi=150, bbox_inches="tight")
    finally:
        plt.close(fig)
