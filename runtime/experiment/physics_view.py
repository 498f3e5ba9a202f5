"""The "innate physics" itself: the pymunk world a plan was simulated in, drawn by pymunk.

:func:`plot_physics_world` builds the planner's reference world (:class:`clomp.planner.engine.World`:
the obstacle boxes perception made from the scan, as static pymunk polygons, and the robot's
footprint as a kinematic body) and draws its shapes as pymunk holds them (each polygon's
vertices through its body's transform; ``pymunk.matplotlib_util``, deprecated since pymunk 7,
is not needed) — the body once for each state of the plan, placed at the state's end pose —
over the scan points. It is the world of the paper's title: what the Configurator knows of
the scene when it imagines a task.
"""

from __future__ import annotations

import os
from typing import Any

from clomp.planner.configurator import PlanResult

__all__ = ["plot_physics_world"]


def plot_physics_world(result: PlanResult, path: str | os.PathLike[str], scan: Any = None, title: str | None = None) -> int:
    """Write the plan's pymunk world (boxes, and the body at each planned state) to ``path``;
    returns how many pymunk shapes it drew.

    >>> import tempfile
    >>> from pathlib import Path
    >>> import clomp
    >>> scene = clomp.load_scenario("overtaking")
    >>> r = clomp.plan(scene.scan(), goal=scene.goal_in_robot_frame())
    >>> with tempfile.TemporaryDirectory() as d:
    ...     n = plot_physics_world(r, Path(d) / "world.png", scene.scan())
    ...     n > len(r.obstacles), (Path(d) / "world.png").stat().st_size > 0
    (True, True)
    """
    import numpy as np
    from matplotlib.patches import Patch, Polygon

    from clomp.planner.engine import World
    from clomp.runtime.experiment.plots import _pyplot

    plt = _pyplot()
    world = World(result.obstacles, result.robot)
    fig, ax = plt.subplots(figsize=(8, 5))
    drawn = 0
    body_style: dict[str, Any] = {"facecolor": (31 / 255, 119 / 255, 180 / 255, 0.2), "edgecolor": "black", "lw": 0.8}

    def draw(shape: Any, style: dict[str, Any]) -> None:
        nonlocal drawn
        ax.add_patch(Polygon([tuple(shape.body.local_to_world(v)) for v in shape.get_vertices()], closed=True, **style))
        drawn += 1

    try:
        pts = np.asarray(result.obstacles.points if scan is None else scan, dtype=np.float64).reshape(-1, 2)
        ax.scatter(pts[:, 0], pts[:, 1], s=3, color="black", zorder=3, label="scan points")
        for shape in world.space.shapes:  # the static boxes
            if shape.body is not world.body:
                draw(shape, {"facecolor": "0.6", "edgecolor": "tab:orange", "lw": 2.0, "zorder": 4})  # often mm thin
        for i in result.plan.states:  # the kinematic body, where each planned task ends
            world.place(result.map[i].end)
            draw(world.shape, body_style)
        ax.plot(result.goal.x, result.goal.y, marker=r"$\heartsuit$", color="red", markersize=14, ls="none", label="goal")
        handles, _ = ax.get_legend_handles_labels()
        handles += [Patch(facecolor="0.6", edgecolor="tab:orange", label="static box (pymunk.Poly)"),
                    Patch(**body_style, label="robot body (kinematic), at each planned state")]
        ax.set_aspect("equal")
        ax.autoscale_view()
        ax.set_xlabel("x (m, robot frame at planning)")
        ax.set_ylabel("y (m)")
        ax.set_title(title or "the pymunk world of the plan: static boxes, the body at each planned state", fontsize=10)
        ax.legend(handles=handles, loc="upper left", bbox_to_anchor=(1.02, 1.0), fontsize=8, frameon=False)
        fig.savefig(path, dpi=130, bbox_inches="tight")
    finally:
        plt.close(fig)
    return drawn
