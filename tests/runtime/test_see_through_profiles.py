"""The displaced profiles of :func:`~clomp.runtime.estimation.seethrough.see_through_along` come
from one pass over the map (issue #41: it re-read the map for each of its 16 displacements):
each row is, bit for bit, the profile :func:`_drawn` gives from that displaced pose alone, so
the see-through judgement and the behaviour digest do not move."""

from __future__ import annotations

import math

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.runtime.estimation.seethrough import _displaced, _drawn, _drawn_from

_coord = st.floats(-2.0, 2.0, allow_nan=False, width=64)


@settings(max_examples=80, deadline=None)
@given(points=st.lists(st.tuples(_coord, _coord), min_size=0, max_size=300),
       x=st.floats(-1.0, 1.0), y=st.floats(-1.0, 1.0), theta=st.floats(-math.pi, math.pi),
       steps=st.lists(st.floats(0.0, 0.4), min_size=1, max_size=2), directions=st.integers(1, 16),
       reach=st.floats(0.3, 1.5), bins=st.sampled_from([36, 180, 181]))
def test_one_pass_gives_each_displaced_profile_bit_for_bit(points: list[tuple[float, float]], x: float, y: float,
                                                           theta: float, steps: list[float], directions: int,
                                                           reach: float, bins: int) -> None:
    every = np.array(points, dtype=float).reshape(-1, 2)
    pose = Pose(x, y, theta)
    rows = _displaced(every, pose, tuple(steps), directions, reach, bins)
    assert rows.shape == (len(steps) * directions, bins)
    j = 0
    for step in steps:  # the order see_through_along counts them in: steps outer
        for k in range(directions):
            phi = 2 * math.pi * k / directions
            u = np.array([math.cos(phi), math.sin(phi)])
            alone = _drawn(every, Pose(pose.x + step * u[0], pose.y + step * u[1], pose.theta), reach, bins)
            assert rows[j].tobytes() == alone.tobytes(), (step, k)
            j += 1


def test_points_on_the_edge_of_reach_and_of_the_square_count_as_alone() -> None:
    """Points at exactly ``reach`` (and a hair beyond, and on the square's corner) from a
    displaced pose: the one pass keeps and drops the same ones as the pose alone."""
    centre = (0.15, 0.0)
    ring = [(centre[0] + r * math.cos(a), centre[1] + r * math.sin(a))
            for r in (1.2, math.nextafter(1.2, 2.0), 1.2 + 1e-6, 1.2 - 1e-12) for a in np.linspace(-math.pi, math.pi, 73)]
    every = np.array(ring + [(centre[0] + 1.2, centre[1] + 1.2), (centre[0] + 1.2 + 1e-6, centre[1])])
    for theta in (0.0, 0.3, -2.9):
        rows = _drawn_from(every, [centre, (0.0, 0.0)], theta, 1.2, 180)
        assert rows[0].tobytes() == _drawn(every, Pose(*centre, theta), 1.2, 180).tobytes()
        assert rows[1].tobytes() == _drawn(every, Pose(0.0, 0.0, theta), 1.2, 180).tobytes()

    # exactly at reach (dyadic: no rounding anywhere), kept; a hair beyond, dropped
    centre, dyadic = (0.25, 0.0), np.array([[1.25, 0.0], [0.25, 1.0], [-0.75, 0.0], [0.25, -1.0], [1.25, 2.0 ** -40]])
    rows = _drawn_from(dyadic, [centre], 0.0, 1.0, 180)
    assert rows[0].tobytes() == _drawn(dyadic, Pose(*centre, 0.0), 1.0, 180).tobytes()
    assert int(np.isfinite(rows[0]).sum()) == 4


def test_no_map_and_no_displacement() -> None:
    assert _drawn_from(np.zeros((0, 2)), [(0.0, 0.0)], 0.0, 1.2, 180).tolist() == [[math.inf] * 180]
    assert _drawn_from(np.ones((3, 2)), [], 0.0, 1.2, 180).shape == (0, 180)
