"""The environment's picture: the layout, the goal, the robot's body and its newest scan (matplotlib, Agg).

>>> from clomp.planner.scenarios import load_scenario
>>> from clomp.planner.robot_model import RobotModel
>>> scene = load_scenario("overtaking")
>>> draw(scene, scene.start, np.zeros((0, 2)), RobotModel()).shape
(400, 400, 3)
"""

from __future__ import annotations

import math

import numpy as np

from clomp.formal.geometry import points_from_frame
from clomp.formal.model import Pose
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene

__all__ = ["draw"]


def draw(scene: Scene, pose: Pose, points: np.ndarray, model: RobotModel, size: int = 400) -> np.ndarray:
    """An RGB image (``size`` × ``size`` × 3, uint8) of ``scene`` with the robot at ``pose`` (world
    frame) and ``points`` (its scan, robot frame)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Circle, Polygon

    fig = Figure(figsize=(size / 100, size / 100), dpi=100)
    canvas = FigureCanvasAgg(fig)
    ax = fig.add_axes((0.0, 0.0, 1.0, 1.0))
    for s in scene.shapes:
        patch = (Circle(s.center, s.radius, color="0.3") if s.kind == "circle"
                 else Polygon(np.asarray(s.vertices), closed=True, color="0.3"))
        ax.add_patch(patch)
    ax.add_patch(Circle(scene.goal, 0.05, color="tab:green", alpha=0.6))
    body = points_from_frame(np.asarray(model.corners, dtype=float), pose)
    ax.add_patch(Polygon(body, closed=True, fill=False, color="tab:blue", lw=2))
    ax.plot([pose.x, pose.x + 0.15 * math.cos(pose.theta)], [pose.y, pose.y + 0.15 * math.sin(pose.theta)], color="tab:blue")
    if len(points):
        w = points_from_frame(np.asarray(points, dtype=float), pose)
        ax.plot(w[:, 0], w[:, 1], ".", color="tab:red", ms=2)
    cx, cy = (scene.start.x + scene.goal[0]) / 2, (scene.start.y + scene.goal[1]) / 2
    half = max(abs(scene.goal[0] - scene.start.x), abs(scene.goal[1] - scene.start.y)) / 2 + 0.6
    ax.set_xlim(cx - half, cx + half)
    ax.set_ylim(cy - half, cy + half)
    ax.set_aspect("equal")
    ax.set_axis_off()
    canvas.draw()  # type: ignore[no-untyped-call]
    return np.asarray(canvas.buffer_rgba())[:, :, :3].copy()  # type: ignore[no-untyped-call]
