"""Hypothesis strategies for property-testing code built on clomp (in the spirit of ``hypothesis.extra``).

Use them to state an invariant of your own cost function, task or exporter over many
generated worlds; the project's own property tests use the same strategies.

- :func:`scans` — a LiDAR scan (N×2 points, robot frame) of a few short walls;
- :func:`scenes` — a :class:`~clomp.planner.scenarios.Scene` of a few boxes around the robot;
- :func:`goals` — a goal (x, y) in the robot frame within a distance band;
- :func:`robot_models` — :class:`~clomp.planner.robot_model.RobotModel` variants (width, step, turn angle);
- :func:`planned_maps` — the :class:`~clomp.planner.configurator.PlanResult` of planning in a
  generated scene (its ``.map`` is the cognitive map; plans the Configurator rejects are
  skipped with ``assume``).

Hand-grown maps that need no planner are in :func:`clomp.formal.strategies.cognitive_maps`; the
invariant checker is :func:`clomp.formal.check_map`. Requires ``hypothesis`` (the ``testing``
extra: ``pip install 'clomp[testing]'``).

>>> from hypothesis import given, settings
>>> from clomp.formal import check_map
>>> @settings(max_examples=3, deadline=None)
... @given(planned_maps())
... def test_every_map_holds_the_invariants(result):
...     assert check_map(result.map, result.plan, result.psi) == []
>>> test_every_map_holds_the_invariants()
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from hypothesis import assume
from hypothesis import strategies as st

from clomp.planner.configurator import Configurator, PlanningError, PlanResult
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene, Shape, _rect

__all__ = ["goals", "planned_maps", "robot_models", "scans", "scenes"]


def goals(min_distance: float = 0.3, max_distance: float = 1.1) -> st.SearchStrategy[tuple[float, float]]:
    """Goals (x, y) in the robot frame, at a distance in [min_distance, max_distance], any bearing.

    >>> from hypothesis import find
    >>> x, y = find(goals(0.5, 0.6), lambda g: True)
    >>> 0.5 <= math.hypot(x, y) <= 0.6
    True
    """
    if not 0 <= min_distance <= max_distance:
        raise ValueError(f"need 0 <= min_distance <= max_distance, got {min_distance}, {max_distance}")

    @st.composite
    def _goal(draw: st.DrawFn) -> tuple[float, float]:
        d = draw(st.floats(min_distance, max_distance))
        a = draw(st.floats(-math.pi, math.pi))
        return d * math.cos(a), d * math.sin(a)

    return _goal()


def robot_models(
    widths: Sequence[float] = (0.14, 0.18, 0.22),
    step_lengths: Sequence[float] = (0.2, 0.27, 0.35),
    turn_angles: Sequence[float] = (math.pi / 2, math.pi / 3),
) -> st.SearchStrategy[RobotModel]:
    """Robot models differing in body width, straight step length and turn angle.

    >>> from hypothesis import find
    >>> find(robot_models(widths=[0.2]), lambda r: True).width
    0.2
    """
    return st.builds(
        RobotModel,
        width=st.sampled_from(list(widths)),
        step_length=st.sampled_from(list(step_lengths)),
        turn_angle=st.sampled_from(list(turn_angles)),
    )


@st.composite
def scans(draw: st.DrawFn, max_walls: int = 3, min_range: float = 0.35, max_range: float = 1.0) -> np.ndarray:
    """A scan (N×2, robot frame, metres) of up to ``max_walls`` short walls facing the robot.

    Points are 2 cm apart; walls stand ``min_range``..``max_range`` from the robot, so the
    robot's own body is clear. Zero walls give an empty (0×2) scan.

    >>> from hypothesis import find
    >>> find(scans(), lambda s: len(s) > 0).shape[1]
    2
    """
    pts: list[tuple[float, float]] = []
    for _ in range(draw(st.integers(0, max_walls))):
        r = draw(st.floats(min_range, max_range))
        a = draw(st.floats(-math.pi, math.pi))
        w = draw(st.floats(0.05, 0.4))
        cx, cy = r * math.cos(a), r * math.sin(a)
        n = max(2, int(w / 0.02))
        for k in range(n):
            u = -w / 2 + w * k / (n - 1)
            pts.append((cx - u * math.sin(a), cy + u * math.cos(a)))
    return np.array(pts, dtype=float).reshape(-1, 2)


@st.composite
def scenes(draw: st.DrawFn, max_boxes: int = 4, goal: st.SearchStrategy[tuple[float, float]] | None = None) -> Scene:
    """A scene of up to ``max_boxes`` boxes 0.35..1 m around the robot (not on it) and a goal.

    ``goal`` defaults to :func:`goals` (0.3..1.1 m away). ``scene.scan()`` gives its scan.

    >>> from hypothesis import find
    >>> s = find(scenes(), lambda s: len(s.shapes) == 2)
    >>> s.scan().shape[1], len(s.goal)
    (2, 2)
    """
    shapes = []
    for _ in range(draw(st.integers(0, max_boxes))):
        r = draw(st.floats(0.35, 1.0))
        a = draw(st.floats(-math.pi, math.pi))
        sx = draw(st.floats(0.03, 0.4))
        sy = draw(st.floats(0.03, 0.4))
        ang = draw(st.floats(0, math.pi))
        shapes.append(Shape("polygon", _rect(r * math.cos(a), r * math.sin(a), sx, sy, ang)))
    g = draw(goals() if goal is None else goal)
    return Scene("generated", tuple(shapes), g)


@st.composite
def planned_maps(
    draw: st.DrawFn,
    scene: st.SearchStrategy[Scene] | None = None,
    robot: st.SearchStrategy[RobotModel] | None = None,
    max_states: int = 120,
    rays: int = 180,
) -> PlanResult:
    """What the Configurator plans in a generated scene with a generated robot.

    ``result.map`` is the cognitive map, ``result.plan`` the plan ρ, ``result.psi`` the
    guard Ψ. Scenes the Configurator refuses (:class:`PlanningError`) are skipped.
    """
    s = draw(scenes() if scene is None else scene)
    r = draw(robot_models() if robot is None else robot)
    try:
        return Configurator(robot=r, max_states=max_states).plan(s.scan(rays=rays), s.goal)
    except PlanningError:
        assume(False)
        raise  # unreachable: assume(False) raises
