"""Pictures of an experiment: runs, collisions per run, success against noise, a layout gallery.

Drawn headless (matplotlib's Agg backend) in the scene's world frame, axes in metres.
Obstacles are grey, the target a red heart and collisions red stars (as in the paper's
figure 3), the scan points black dots. The executed (ground-truth) path is a wide pale line drawn *under* the
robot's own estimate (dotted) and the planned paths (dashed), so neither hides the
other; arrowheads along it, each with its time, show which way and when the robot went
(a reactive run's loops are readable). The legend names every mark that is on the panel —
obstacle, scan, robot body (start and end), target, collision — and nothing that is not
(a reactive run has no plan); it stands outside the data. A panel's title says the run's
outcome in the words of :func:`outcome_words` ("unreachable: stopped at the frontier",
"goal unconfirmed" …): an honest stop is never called a failure.

- :func:`draw_run` — one run onto your own axes (returns the artists by role, for tests);
- :func:`run_figure` / :func:`plot_run` / :func:`plot_runs` — one run, or a grid of runs at one scale;
- :func:`plot_collisions` — collisions and brushes per run, both conditions side by side;
- :func:`plot_success_vs_noise` — success rate with Wilson 95 % intervals per noise scale;
- :func:`plot_gallery` — sample layouts of every family.
"""

from __future__ import annotations

import math
import os
import textwrap
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

from clomp.runtime.experiment.runspec import CONDITIONS
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene

__all__ = ["RunArtists", "RunTrace", "draw_run", "outcome_words", "plot_collisions", "plot_gallery", "plot_run", "plot_runs",
           "plot_success_vs_noise", "run_figure"]

_HEART = r"$\heartsuit$"
_EXEC = "#7fb3e0"


@dataclass
class RunTrace:
    """What one run leaves to draw, all in the scene's world frame.

    ``path``: executed (true) positions; ``estimate``: the robot's own pose estimate;
    ``plans``: planned paths (polylines through the planned task ends); ``collisions``:
    contact points; ``poses``: (x, y, theta) to outline the body at (start, end);
    ``ok``: the run succeeded; ``tone``: ``"ok"``, ``"stop"`` (an honest stop short of the goal)
    or ``"bad"`` (default: from ``ok``), the title's colour; ``scan``: scan points to draw,
    named ``scan_label`` in the legend; ``times``: the time (s) of each point of ``path``
    (empty: no time marks); ``headings``: the true heading (rad) there (for an animation).
    """

    scene: Scene
    title: str
    path: list[tuple[float, float]]
    collisions: list[tuple[float, float]] = field(default_factory=list)
    plans: list[list[tuple[float, float]]] = field(default_factory=list)
    estimate: list[tuple[float, float]] = field(default_factory=list)
    poses: list[tuple[float, float, float]] = field(default_factory=list)
    ok: bool = True
    tone: str = ""
    scan: list[tuple[float, float]] = field(default_factory=list)
    scan_label: str = "scan points"
    times: list[float] = field(default_factory=list)
    headings: list[float] = field(default_factory=list)


@dataclass
class RunArtists:
    """What :func:`draw_run` drew, by role (matplotlib artists)."""

    scan: Any = None
    path: Any = None
    marks: Any = None
    mark_labels: list[Any] = field(default_factory=list)
    collisions: Any = None
    title: Any = None


_TONE = {"ok": "black", "stop": "darkorange", "bad": "firebrick"}


def outcome_words(end_state: str, reached: bool, distance: float, expect: str = "reach", reason: str = "") -> tuple[str, str]:
    """The run's outcome in words, and its tone (``"ok"``, ``"stop"``: an honest stop short of
    the goal, ``"bad"``), from its end state, the ground truth (``reached``: truly within the
    success radius; ``distance``: truly this far from the goal, m) and what the layout allows
    (``expect``: ``"reach"`` or ``"unreachable"``). Every end state of the supervisor and of the
    baselines (``TIMEOUT``) has its words; none of them says "failed".

    >>> outcome_words("UNREACHABLE", False, 0.588)
    ('unreachable: stopped at the frontier, 0.59 m from the goal', 'stop')
    >>> outcome_words("GOAL_REACHED", False, 0.3)
    ('false success: claimed the goal, truly 0.30 m from it', 'bad')
    """
    d = f"{distance:.2f} m from the goal"
    if end_state == "GOAL_REACHED":
        return ("goal reached", "ok") if reached else (f"false success: claimed the goal, truly {distance:.2f} m from it", "bad")
    if end_state == "GOAL_UNCONFIRMED":
        return (f"goal unconfirmed (truly {'there' if reached else 'not there'}, {d})", "stop")
    if end_state == "UNREACHABLE":
        if expect == "unreachable":
            return "unreachable, as it is: stopped at the frontier", "ok"
        return f"unreachable: stopped at the frontier, {d}", "stop"
    truly = " (truly at the goal)" if reached else ""
    if end_state == "TIMEOUT" or "time limit" in reason:
        return f"time limit: stopped {d}{truly}", "bad"
    if end_state == "HALTED":
        return f"halted: stopped {d}{truly}", "bad"
    return f"{end_state.lower()}: {d}{truly}", "ok" if reached else "bad"


def outcome_title(run: int, end_state: str, reached: bool, distance: float, collisions: int, brushes: int,
                  expect: str = "reach", reason: str = "") -> tuple[str, str]:
    """A panel's title (run number, outcome words, contacts) and its tone (collisions make it ``"bad"``)."""
    words, tone = outcome_words(end_state, reached, distance, expect, reason)
    return f"run {run}: {words}; {collisions} coll., {brushes} brush.", "bad" if collisions else tone


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
        pts = list(t.path) + list(t.scan) + [t.scene.goal, (t.scene.start.x, t.scene.start.y)]
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


def start_scan(scene: Scene) -> list[tuple[float, float]]:
    """The noise-free LiDAR scan from the scene's start, in the world frame (what the robot
    first sees; a picture's scan where the run kept none)."""
    from clomp.formal.geometry import compose
    from clomp.formal.model import Pose

    st = scene.start
    out = []
    for x, y in scene.scan().tolist():
        w = compose(st, Pose(x, y, 0.0))
        out.append((w.x, w.y))
    return out


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
    labels = sorted({x.scan_label for x in ts if x.scan})
    for lab in labels:
        h.append(Line2D([], [], marker=".", color="black", ls="none", markersize=4, label=lab))
    if any(x.path for x in ts):
        h.append(Line2D([], [], color=_EXEC, lw=4, label="executed (ground truth)"))
    if any(x.times for x in ts):
        h.append(Line2D([], [], marker=">", color="navy", ls="none", markersize=6, label="direction, time (s)"))
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


def _nice_step(duration: float, most: int = 10) -> float:
    """A round time step (s) giving at most ``most`` marks over ``duration``."""
    for step in (1.0, 2.0, 5.0, 10.0, 15.0, 20.0, 30.0, 60.0, 120.0, 300.0):
        if duration / step <= most:
            return step
    return duration / most


def _time_marks(t: RunTrace) -> list[tuple[float, float, float, float, float]]:
    """(x, y, ux, uy, time) every round number of seconds along the path: where the robot was
    then (between two samples, on the line joining them) and its unit direction of travel
    (the next stretch it actually moved along: a turn in place does not move)."""
    if len(t.times) != len(t.path) or len(t.path) < 2:
        return []
    step = _nice_step(t.times[-1] - t.times[0])
    out = []
    k = 1
    mark = t.times[0] + step
    while mark < t.times[-1]:
        while t.times[k] < mark:
            k += 1
        (x0, y0), (x1, y1), t0, t1 = t.path[k - 1], t.path[k], t.times[k - 1], t.times[k]
        f = (mark - t0) / (t1 - t0) if t1 > t0 else 1.0
        x, y = x0 + f * (x1 - x0), y0 + f * (y1 - y0)
        for j in range(k, len(t.path)):
            dx, dy = t.path[j][0] - x, t.path[j][1] - y
            n = math.hypot(dx, dy)
            if n > 1e-3:
                out.append((x, y, dx / n, dy / n, mark))
                break
        mark += step
    return out


def draw_run(ax: Any, t: RunTrace, model: RobotModel | None = None) -> RunArtists:
    """Draw one run onto ``ax`` (no legend: see :func:`run_figure`); returns the artists by role.

    >>> import matplotlib
    >>> matplotlib.use("Agg")
    >>> import matplotlib.pyplot as plt
    >>> from clomp.planner import load_scenario
    >>> fig, ax = plt.subplots()
    >>> tr = RunTrace(load_scenario("open"), "run 0", [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)], times=[0.0, 5.0, 10.0],
    ...               scan=[(1.5, 0.2)])
    >>> art = draw_run(ax, tr)
    >>> len(art.scan.get_offsets()), [x.get_text() for x in art.mark_labels]
    (1, ['1 s', '2 s', '3 s', '4 s', '5 s', '6 s', '7 s', '8 s', '9 s'])
    >>> plt.close(fig)
    """
    from matplotlib.patches import Polygon

    model = model or RobotModel()
    out = RunArtists()
    _draw_scene(ax, t.scene)
    if t.scan:
        out.scan = ax.scatter([p[0] for p in t.scan], [p[1] for p in t.scan], s=3, color="black", zorder=2.5, linewidths=0)
    if t.path:  # underneath, wide and pale: the thin lines stay visible on top of it
        (out.path,) = ax.plot([p[0] for p in t.path], [p[1] for p in t.path], "-", color=_EXEC, lw=4,
                              solid_capstyle="round", zorder=2)
    for poly in t.plans:
        if len(poly) > 1:
            ax.plot([p[0] for p in poly], [p[1] for p in poly], "--", color="tab:orange", lw=1.2, zorder=4)
    if t.estimate:
        ax.plot([p[0] for p in t.estimate], [p[1] for p in t.estimate], ":", color="tab:purple", lw=1.4, zorder=5)
    marks = _time_marks(t)
    if marks:
        out.marks = ax.quiver([m[0] for m in marks], [m[1] for m in marks], [m[2] for m in marks], [m[3] for m in marks],
                              color="navy", angles="xy", pivot="mid", scale=40, width=0.006, headwidth=4,
                              headlength=4.5, headaxislength=4, zorder=6)
        for x, y, ux, uy, when in marks:  # the time beside its arrow, off the path to its left
            out.mark_labels.append(ax.annotate(f"{when:g} s", (x, y), xytext=(-9 * uy, 9 * ux), textcoords="offset points",
                                               fontsize=6, color="navy", ha="center", va="center", zorder=8))
    for pose in t.poses:
        ax.add_patch(Polygon(_outline(pose, model), closed=True, fill=False, edgecolor="tab:blue", lw=0.9, zorder=3))
    ax.plot(t.scene.start.x, t.scene.start.y, "o", color="tab:blue", markersize=3, zorder=6)
    if t.collisions:
        out.collisions = ax.plot([c[0] for c in t.collisions], [c[1] for c in t.collisions], "*", color="red",
                                 markeredgecolor="black", markersize=13, ls="none", zorder=7)[0]
    out.title = ax.set_title(t.title, fontsize=9, color=_TONE.get(t.tone or ("ok" if t.ok else "bad"), "black"))
    ax.set_aspect("equal")
    ax.grid(alpha=0.3)
    return out


def _panel_size(lim: tuple[float, float, float, float], width: float) -> tuple[float, float]:
    """A panel ``width`` inches wide as tall as the data's aspect asks (no blank band)."""
    w, h = lim[1] - lim[0], lim[3] - lim[2]
    return width, min(max(width * h / w, 1.6), 2.0 * width)


def run_figure(trace: RunTrace, model: RobotModel | None = None, title: str | None = None) -> Any:
    """One run as a matplotlib Figure: the panel sized to the data, the legend right of it.

    >>> from clomp.planner import load_scenario
    >>> fig = run_figure(RunTrace(load_scenario("open"), "run 0", [(0.0, 0.0), (1.0, 0.0)]))
    >>> fig.axes[0].get_legend() is not None
    True
    """
    plt = _pyplot()
    lim = _axes_limits([trace])
    pw, ph = _panel_size(lim, 6.0)
    fig, ax = plt.subplots(figsize=(pw + 2.4, ph + (0.9 if title else 0.6)))
    draw_run(ax, trace, model)
    ax.set_xlim(lim[0], lim[1])
    ax.set_ylim(lim[2], lim[3])
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.legend(handles=_handles([trace]), loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=7, frameon=False,
              borderaxespad=0.0)
    if title:
        fig.suptitle(title)
    fig.tight_layout()
    return fig


def plot_run(trace: RunTrace, path: str | os.PathLike[str], model: RobotModel | None = None, title: str | None = None) -> None:
    """Draw one run (:func:`run_figure`) to a PNG file.

    >>> import tempfile
    >>> from pathlib import Path
    >>> from clomp.planner import load_scenario
    >>> png = Path(tempfile.mkdtemp()) / "run.png"
    >>> plot_run(RunTrace(load_scenario("open"), "a straight run", [(0.0, 0.0), (0.5, 0.0), (1.0, 0.0)]), png)
    >>> png.read_bytes()[1:4] == b"PNG"
    True
    """
    plt = _pyplot()
    fig = run_figure(trace, model, title)
    try:
        fig.savefig(path, dpi=120, bbox_inches="tight")
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
    lim = _axes_limits(traces) if traces else (-1.0, 1.0, -1.0, 1.0)
    pw, ph = _panel_size(lim, 3.2)
    fig, axes = plt.subplots(rows, cols, figsize=(pw * cols, (ph + 0.5) * rows + 0.8), squeeze=False, sharex=True,
                             sharey=True)
    try:
        for k, ax in enumerate(axes.flat):
            if k >= len(traces):
                ax.axis("off")
                continue
            draw_run(ax, traces[k], model).title.set_text(textwrap.fill(traces[k].title, 44))  # narrow panels
            ax.set_xlim(lim[0], lim[1])
            ax.set_ylim(lim[2], lim[3])
            if k % cols == 0:
                ax.set_ylabel("y (m)")
            if k // cols == rows - 1 or k + cols >= len(traces):
                ax.set_xlabel("x (m)")
                ax.tick_params(labelbottom=True)
        fig.suptitle(title)
        handles = _handles(traces)
        fig.legend(handles=handles, loc="lower center", ncol=min(len(handles), 5), fontsize=8, frameon=False)
        fig.tight_layout(rect=(0, 0.7 / ((ph + 0.5) * rows + 0.8), 1, 1))
        fig.savefig(path, dpi=100, bbox_inches="tight")
    finally:
        plt.close(fig)


def plot_collisions(per_run: dict[str, list[tuple[int, int]]], path: str | os.PathLike[str], title: str) -> None:
    """Collisions (solid) and brushes (hatched) per run, one bar per condition and run.

    ``per_run``: condition → [(collisions, brushes)] in run order.
    """
    plt = _pyplot()
    names = [n for n in CONDITIONS if n in per_run]
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
