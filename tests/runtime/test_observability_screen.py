"""The compiled screen of :func:`observed_information` (issue #41) gives the exact answer bit for bit."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.runtime.estimation import observability
from clomp.runtime.estimation._shape_core import shape_estimate
from clomp.runtime.estimation.observability import observed_information, shape_information


def _scene(seed: int, kind: int, noise: float, n: int) -> np.ndarray:
    """Walls of a corridor, a room's end wall, or clutter boxes, with range-like noise."""
    rng = np.random.default_rng(seed)
    xs = rng.uniform(-1.5, 1.5, n)
    pts = [np.c_[xs, np.full(n, 0.36)], np.c_[xs[::-1], np.full(n, -0.36)]]
    if kind >= 1:
        pts.append(np.c_[np.full(n // 2, 1.2), rng.uniform(-0.36, 0.36, n // 2)])
    if kind >= 2:
        pts.append(rng.uniform(-0.1, 0.1, (n // 4, 2)) + rng.uniform(-1.0, 1.0, 2))
    world = np.concatenate(pts)
    return world + rng.normal(0.0, noise, world.shape)


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10**6), st.integers(0, 2), st.sampled_from([0.0, 0.005, 0.025]), st.integers(8, 120),
       st.floats(-0.5, 0.5), st.floats(-3.2, 3.2), st.floats(0.0, 1.0))
def test_screen_is_the_exact_answer(seed: int, kind: int, noise: float, n: int, x: float, th: float, keep: float) -> None:
    rng = np.random.default_rng(seed + 1)
    pose = Pose(x, 0.0, th)
    world = _scene(seed, kind, noise, n)
    points = np.c_[np.cos(-th) * (world[:, 0] - x) - np.sin(-th) * world[:, 1],
                   np.sin(-th) * (world[:, 0] - x) + np.cos(-th) * world[:, 1]]  # robot frame, test data only
    paired = rng.uniform(size=len(points)) < max(keep, 0.05)
    a = rng.normal(size=(3, 3))
    info = a @ a.T * rng.uniform(1.0, 500.0) + np.diag([0.0, 0.0, 0.0] if seed % 3 else [0.0, 0.0, 1e-3])
    fast = observed_information(info, points, pose, paired)
    exact = observed_information(info, points, pose, paired, screen=False)
    assert fast[1] == exact[1]
    assert fast[0].tobytes() == exact[0].tobytes()


@settings(max_examples=60, deadline=None)
@given(st.integers(0, 10**6), st.integers(0, 2), st.sampled_from([0.0, 0.005, 0.025]), st.integers(4, 120),
       st.floats(-0.5, 0.5), st.sampled_from([0.15, 0.2]), st.sampled_from([0.25, 0.4]))
def test_compiled_shape_is_the_shared_line_test(seed: int, kind: int, noise: float, n: int, x: float, radius: float,
                                                ratio: float) -> None:
    """The compiled copy of the line test (``shape_estimate``) gives what the python one
    (``icp.neighbour_lines``, through ``shape_information``) gives, up to rounding, whenever it
    does not say a comparison was a tie: a point judged a line by one and not the other
    would move the figure by a whole point's worth."""
    world = _scene(seed, kind, noise, n)
    fast, m, unsure = shape_estimate(np.ascontiguousarray(world), x, 0.0, radius, 32, ratio, 0.5)
    exact, n_exact = shape_information(world, (x, 0.0), radius=radius, line_ratio=ratio)
    if not unsure:
        assert m == n_exact
        assert np.allclose(fast, exact, rtol=0.0, atol=1e-9 * max(float(np.trace(exact)), 1.0))


def test_screen_decides_a_rich_scene_without_the_exact_shape(monkeypatch: object) -> None:
    """A room (an end wall) is decided by the screen alone; a corridor needs the exact figure."""
    calls: list[int] = []
    real = observability.shape_information

    def counted(*args: object, **kw: object) -> object:
        calls.append(1)
        return real(*args, **kw)  # type: ignore[arg-type]

    monkeypatch.setattr(observability, "shape_information", counted)  # type: ignore[attr-defined]
    room = _scene(3, 1, 0.0, 81)
    full = np.diag([160.0, 160.0, 40.0])
    assert observed_information(full, room, Pose(0.0, 0.0, 0.0), np.ones(len(room), bool))[1] == ()
    assert not calls
    corridor = _scene(3, 0, 0.0, 81)
    assert observed_information(full, corridor, Pose(0.0, 0.0, 0.0), np.ones(len(corridor), bool))[1] == ("x",)
    assert calls


@settings(max_examples=80, deadline=None)
@given(st.lists(st.floats(0.0, 0.04), min_size=1, max_size=60), st.integers(1, 40))
def test_nearest_cut_selects_the_k_nearest(values: list[float], k: int) -> None:
    """The quickselect cut keeps exactly the ``k`` nearest, or says the k-th and the next tie."""
    from clomp.runtime.estimation._shape_core import _nearest_cut

    near = np.array(values)
    cut, tie = _nearest_cut(near, len(near), k, 0.04, np.empty(len(near)))
    ranked = np.sort(near)
    if len(near) <= k:
        assert cut == 0.04 and not tie
    elif not tie:
        assert int((near <= cut).sum()) == k
        assert ranked[k] - ranked[k - 1] > 0.04 * 1e-8
    else:
        assert ranked[k] - ranked[k - 1] <= 0.04 * 1e-8
