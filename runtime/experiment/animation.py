"""A run as an animated GIF (``clomp simulate --animate run.gif``, the docs' front page).

The still picture of :func:`~clomp.runtime.experiment.plots.draw_run` — obstacles, scan
points, the target, the plans — stays in the background; on top, frame by frame, the robot's
body moves along its true path (the executed trail growing behind it) with the simulated time
in the corner, and the last frame holds the run's outcome in words. Written with matplotlib's
:class:`~matplotlib.animation.PillowWriter` (Pillow comes with matplotlib), small by design:
at most :data:`MAX_FRAMES` frames at a low resolution, well under 2 MB.
"""

from __future__ import annotations

import math
import os
from typing import Any

from clomp.planner.robot_model import RobotModel
from clomp.runtime.experiment.plots import RunTrace, _axes_limits, _draw_scene, _outline, _panel_size, _pyplot

__all__ = ["MAX_FRAMES", "animate_run", "frame_indices"]

#: frames in a GIF at most (the path is sampled evenly in time; the last frame is the end)
MAX_FRAMES = 80


def frame_indices(times: list[float], frames: int = MAX_FRAMES) -> list[int]:
    """Indices into a path sampled at ``times``: evenly spaced in time, the first and last kept.

    >>> frame_indices([0.0, 1.0, 2.0, 3.0, 4.0], 3)
    [0, 2, 4]
    """
    n = len(times)
    if n <= frames:
        return list(range(n))
    t0, t1 = times[0], times[-1]
    out: list[int] = []
    k = 0
    for i in range(frames):
        target = t0 + (t1 - t0) * i / (frames - 1)
        while k < n - 1 and times[k] < target:
            k += 1
        if not out or k != out[-1]:
            out.append(k)
    return out


def _heading(t: RunTrace, k: int) -> float:
    if len(t.headings) == len(t.path):
        return t.headings[k]
    for j in range(k + 1, len(t.path)):  # no headings kept: the way it went next
        dx, dy = t.path[j][0] - t.path[k][0], t.path[j][1] - t.path[k][1]
        if math.hypot(dx, dy) > 1e-3:
            return math.atan2(dy, dx)
    return t.scene.start.theta


def animate_run(trace: RunTrace, path: str | os.PathLike[str], model: RobotModel | None = None, fps: int = 10,
                title: str | None = None, dpi: int = 100) -> int:
    """Write ``trace`` as an animated GIF to ``path``; returns the number of frames (the last,
    with the outcome, is held for two seconds).

    >>> import tempfile
    >>> from pathlib import Path
    >>> from clomp.planner import load_scenario
    >>> tr = RunTrace(load_scenario("open"), "run 0: goal reached", [(0.1 * k, 0.0) for k in range(11)],
    ...               times=[float(k) for k in range(11)])
    >>> gif = Path(tempfile.mkdtemp()) / "run.gif"
    >>> animate_run(tr, gif), gif.read_bytes()[:6]
    (31, b'GIF89a')
    """
    from matplotlib.animation import FuncAnimation, PillowWriter
    from matplotlib.patches import Polygon

    if not trace.path:
        raise ValueError("animate_run: the trace has no path to animate")
    model = model or RobotModel()
    times = trace.times if len(trace.times) == len(trace.path) else [float(k) for k in range(len(trace.path))]
    moving = frame_indices(times)
    frames = moving + [moving[-1]] * (2 * fps)  # the end held, its outcome readable
    plt = _pyplot()
    lim = _axes_limits([trace])
    pw, ph = _panel_size(lim, 5.0)
    fig, ax = plt.subplots(figsize=(pw, ph + 0.5))
    try:
        _draw_scene(ax, trace.scene)
        if trace.scan:
            ax.scatter([p[0] for p in trace.scan], [p[1] for p in trace.scan], s=2, color="black", linewidths=0, zorder=2.5)
        for poly in trace.plans:
            if len(poly) > 1:
                ax.plot([p[0] for p in poly], [p[1] for p in poly], "--", color="tab:orange", lw=1.0, zorder=4)
        (trail,) = ax.plot([], [], "-", color="#7fb3e0", lw=3, solid_capstyle="round", zorder=2)
        body = ax.add_patch(Polygon(_outline((0.0, 0.0, 0.0), model), closed=True, facecolor="#c6dcf0", edgecolor="tab:blue",
                                    lw=1.2, zorder=5))
        clock = ax.text(0.02, 0.96, "", transform=ax.transAxes, fontsize=9, va="top", zorder=8,
                        bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "edgecolor": "none", "alpha": 0.8})
        ax.set_xlim(lim[0], lim[1])
        ax.set_ylim(lim[2], lim[3])
        ax.set_aspect("equal")
        ax.set_xticks([])
        ax.set_yticks([])
        ax.set_title(title or trace.scene.name, fontsize=9)
        fig.tight_layout()

        def draw(i: int) -> tuple[Any, ...]:
            k = frames[i]
            trail.set_data([p[0] for p in trace.path[:k + 1]], [p[1] for p in trace.path[:k + 1]])
            x, y = trace.path[k]
            body.set_xy(_outline((x, y, _heading(trace, k)), model))
            last = i >= len(moving) - 1
            clock.set_text(f"t = {times[k]:.0f} s" + (f"\n{trace.title}" if last else ""))
            return trail, body, clock

        anim = FuncAnimation(fig, draw, frames=len(frames), blit=False)
        anim.save(os.fspath(path), writer=PillowWriter(fps=fps), dpi=dpi)
    finally:
        plt.close(fig)
    return len(frames)
