"""The compiled ray cast gives the numpy statement's ranges bit for bit (scenes, random rays, movers' origins)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.planner.scenarios import load_scenario
from clomp.runtime.backends._lidar import obstacle_arrays
from clomp.runtime.backends._raycast import first_hits, first_hits_numpy

coords = st.floats(-3.0, 3.0, allow_nan=False)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()  # bit for bit, inf and -0.0 included


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n_edges=st.integers(0, 12), n_circles=st.integers(0, 5), column=st.booleans(),
       reach=st.floats(0.1, 6.0))
def test_the_compiled_cast_is_the_numpy_statement(seed: int, n_edges: int, n_circles: int, column: bool, reach: float) -> None:
    rng = np.random.default_rng(seed)
    edges = np.c_[rng.uniform(-3, 3, (n_edges, 2)), rng.uniform(-2, 2, (n_edges, 2))]
    edges[: n_edges // 3, 3] = 0.0  # axis-aligned edges, as walls are: rays parallel to them (det 0)
    circles = np.c_[rng.uniform(-3, 3, (n_circles, 2)), rng.uniform(0.01, 1.0, n_circles)]
    angles = rng.uniform(-7, 7, 50)
    angles[:4] = [0.0, np.pi / 2, np.pi, -np.pi / 2]
    if column:  # one origin per ray, as a revolution cast at once
        x, y = rng.uniform(-3, 3, (50, 1)), rng.uniform(-3, 3, (50, 1))
    else:
        x, y = float(rng.uniform(-3, 3)), float(rng.uniform(-3, 3))
    assert _same(first_hits(x, y, angles, edges, circles, reach), first_hits_numpy(x, y, angles, edges, circles, reach))


@given(x=coords, y=coords)
@settings(max_examples=40, deadline=None)
def test_the_compiled_cast_in_the_scenes(x: float, y: float) -> None:
    angles = np.arange(360) * (2 * np.pi / 360)
    for name in ("overtaking", "corridor", "doorway"):
        edges, circles = obstacle_arrays(load_scenario(name))
        got = first_hits(x, y, angles, edges, circles, 1.32)
        assert _same(got, first_hits_numpy(x, y, angles, edges, circles, 1.32))


def test_no_obstacle_and_no_ray() -> None:
    none4, none3 = np.zeros((0, 4)), np.zeros((0, 3))
    assert first_hits(0.0, 0.0, np.array([0.0, 1.0]), none4, none3, 5.0).tolist() == [np.inf, np.inf]
    assert first_hits(0.0, 0.0, np.zeros(0), np.array([[1.0, -1.0, 0.0, 2.0]]), none3, 5.0).shape == (0,)
