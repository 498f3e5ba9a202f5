"""Perception: reading scans, rejecting bad ones, and covering points tightly."""

from __future__ import annotations

import math
from unittest import mock

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.planner import perception
from clomp.planner.perception import Obstacles, ScanError, load_scan, perceive, validate_scan


def test_text_scan_with_tabs_spaces_and_comments(tmp_path):
    f = tmp_path / "s.dat"
    f.write_text("0.5\t0.1\n# a comment\n\n0.6 -0.2\n")
    assert load_scan(f).tolist() == [[0.5, 0.1], [0.6, -0.2]]


def test_empty_file_is_free_space(tmp_path):
    f = tmp_path / "empty.dat"
    f.write_text("")
    pts = load_scan(f)
    assert pts.shape == (0, 2)
    assert len(perceive(pts)) == 0


def test_npy_and_array(tmp_path):
    a = np.array([[0.3, 0.0], [0.31, 0.0]])
    np.save(tmp_path / "s.npy", a)
    assert np.array_equal(load_scan(tmp_path / "s.npy"), a)
    assert np.array_equal(load_scan(a), a)


@pytest.mark.parametrize(
    "content, message",
    [
        ("0.5 0.1\n0.3\n", ":2: expected two numbers"),
        ("0.5 abc\n", ":1: not a number"),
        ("nan 0.1\n", "not finite"),
        ("0.1 inf\n", "not finite"),
    ],
)
def test_malformed_lines_are_named(tmp_path, content, message):
    f = tmp_path / "bad.dat"
    f.write_text(content)
    with pytest.raises(ScanError, match=message):
        load_scan(f)


def test_missing_file_and_bad_arrays(tmp_path):
    with pytest.raises(ScanError, match="no such file"):
        load_scan(tmp_path / "nope.dat")
    with pytest.raises(ScanError, match="N×2"):
        validate_scan(np.zeros((3, 3)))
    with pytest.raises(ScanError, match="not finite"):
        validate_scan(np.array([[0.1, np.nan]]))


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
@pytest.mark.parametrize("order", ["C", "F"])
def test_perceive_refuses_a_float_array_with_a_point_that_is_not_finite(bad, order):
    # perceive checks a float array's finiteness only when a point is not kept (a NaN or
    # an inf never is): the refusal must still name the point, whatever its place
    for where in (0, 2, 4):
        pts = np.array([[0.5, 0.0], [0.5, 0.01], [0.5, 0.02], [0.5, 0.03], [0.5, 0.04]], order=order)
        pts[where, where % 2] = bad
        with pytest.raises(ScanError, match=f"point {where} is not finite"):
            perceive(pts)
        with pytest.raises(ScanError, match=f"point {where} is not finite"):
            perceive(pts, body=(0.09, 0.09, 0.09))
    # a finite point whose squared range overflows is beyond the range, not bad input
    with pytest.warns(UserWarning, match="beyond"):
        assert len(perceive(np.array([[0.5, 0.0], [1e200, 0.0]]))) == 1


def test_points_beyond_range_are_dropped():
    pts = np.array([[0.5, 0.0], [1.5, 0.0]])
    obs = perceive(pts, sensor_range=1.1)
    assert len(obs) == 1
    assert obs.contains_point(0.5, 0.0) is not None
    assert obs.contains_point(1.5, 0.0) is None


def test_far_apart_points_are_separate_clusters_close_ones_join():
    pts = np.array([[0.5, 0.0], [0.55, 0.0], [0.5, 0.5]])
    obs = perceive(pts)
    assert len(obs) == 2


def test_slanted_wall_becomes_a_thin_slanted_box():
    # a wall at 45 degrees from (0.3, -0.3) to (0.8, 0.2): its axis-aligned box would be 0.5 x 0.5
    t = np.linspace(0, 1, 60)
    pts = np.c_[0.3 + 0.5 * t, -0.3 + 0.5 * t]
    obs = perceive(pts)
    total_area = 0.0
    for box in obs.boxes:
        x, y = box[:, 0], box[:, 1]
        total_area += 0.5 * abs(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    assert total_area < 0.05 * 0.5 * math.sqrt(2)  # a slab a few cm thick, not 0.25 m²
    # the corridor beside the wall stays open: a point 10 cm off the wall is free
    assert obs.contains_point(0.55 + 0.07, -0.05 - 0.07) is None
    assert all(obs.contains_point(*p) is not None for p in pts)


def test_l_shaped_corner_is_not_one_fat_box():
    a = np.c_[np.linspace(0.4, 0.8, 40), np.full(40, 0.3)]
    b = np.c_[np.full(40, 0.4), np.linspace(0.3, -0.1, 40)]
    obs = perceive(np.r_[a, b])
    # the inside of the L is free
    assert obs.contains_point(0.6, 0.1) is None


@settings(max_examples=60, deadline=None)
@given(
    st.lists(
        st.tuples(st.floats(-1.0, 1.0), st.floats(-1.0, 1.0)),
        min_size=1,
        max_size=80,
    )
)
def test_every_point_in_range_is_covered(points):
    pts = np.array(points)
    obs = perceive(pts)
    for x, y in pts:
        if 1e-3 < math.hypot(x, y) <= 1.1:
            assert obs.contains_point(x, y, margin=1e-9) is not None


def test_parallel_walls_of_one_cluster_are_not_bridged():
    # a cul-de-sac: two walls 0.6 m apart joined by an end wall form one cluster; no box
    # may span the corridor between them
    left = np.c_[np.linspace(-0.4, 0.6, 60), np.full(60, 0.3)]
    right = np.c_[np.linspace(-0.4, 0.6, 60), np.full(60, -0.3)]
    end = np.c_[np.full(40, 0.6), np.linspace(-0.3, 0.3, 40)]
    obs = perceive(np.r_[left, right, end])
    for x in np.linspace(-0.35, 0.5, 18):
        assert obs.contains_point(x, 0.0) is None, f"corridor closed at x={x:.2f}"
        assert obs.contains_point(x, 0.15) is None and obs.contains_point(x, -0.15) is None


def test_short_stubs_across_a_gap_are_not_bridged():
    # two short stubs 0.6 m apart: their points are far apart along any order, so no box
    # may join them across the corridor between them
    stub = np.linspace(0.0, 0.03, 3)
    pts = np.r_[np.c_[stub, np.full(3, 0.3)], np.c_[stub, np.full(3, -0.3)]]
    obs = perceive(pts)
    assert len(obs) == 2
    for box in obs.boxes:
        assert np.ptp(box[:, 1]) < 0.1  # each box stays on its own wall


def _to_polyline(q: np.ndarray, line: np.ndarray) -> float:
    if len(line) == 1:
        return float(np.hypot(*(q - line[0])))
    a, b = line[:-1], line[1:]
    ab = b - a
    t = np.clip(((q - a) * ab).sum(1) / np.maximum((ab * ab).sum(1), 1e-18), 0, 1)
    return float(np.hypot(*(a + t[:, None] * ab - q).T).min())


@settings(max_examples=60, deadline=None)
@given(st.floats(0.1, 1.0), st.floats(0.05, 0.4), st.floats(-math.pi, math.pi), st.floats(0.2, 1.0))
def test_boxes_hug_a_curved_wall(radius, gap, direction, fraction):
    """Covering shapes stay within 1 cm of the surface through their points, also on a
    curved wall (here the visible side of a round pillar, sampled every 5 mm)."""
    d = radius + gap
    c = d * np.array([math.cos(direction), math.sin(direction)])
    half = math.acos(radius / d) * fraction
    a = direction + math.pi + np.linspace(-half, half, int(2 * half * radius / 0.005) + 2)
    obs = perceive(c + radius * np.c_[np.cos(a), np.sin(a)])
    assert len(obs)
    for i, box in enumerate(obs.boxes):
        mine = obs.box_points(i)
        for k in range(4):
            for t in np.linspace(0, 1, 9):
                assert _to_polyline(box[k] + t * (box[(k + 1) % 4] - box[k]), mine) <= 0.01 + 1e-9


def _same_obstacles(a, b) -> bool:
    """Bit-equal boxes, points and pieces (NaN-free arrays: ``tobytes`` compares the bits)."""
    return all(x.tobytes() == y.tobytes() for x, y in ((a.boxes, b.boxes), (a.points, b.points), (a.starts, b.starts)))


@settings(max_examples=150, deadline=None)
@given(
    st.lists(
        st.tuples(st.integers(-110, 110), st.integers(-110, 110), st.integers(1, 4), st.booleans()),
        min_size=1,
        max_size=80,
    )
)
def test_a_repeated_return_changes_nothing(spec):
    """A recorded scan repeats most returns; perception drops a point bit-equal to the one
    before it before sorting by bearing (scans of more than ``_DEDUPE_FROM`` points). The
    obstacles are those of the scan with each return once, and those of the plain path
    (no dropping before the sort), to the bit, also with signed zeros (-0.0 is not 0.0 to
    atan2) and with points on one bearing at several ranges."""
    once, repeated = [], []
    for ix, iy, times, negzero in spec:
        x, y = ix / 100, iy / 100
        if negzero and y == 0.0:
            y = -0.0
        once.append((x, y))
        repeated.extend([(x, y)] * times)
    # drop consecutive repeats from ``once`` as the scan without them would have none
    single = [p for i, p in enumerate(once) if i == 0 or np.array(p).tobytes() != np.array(once[i - 1]).tobytes()]
    scan_once, scan = np.array(single, dtype=float).reshape(-1, 2), np.array(repeated, dtype=float).reshape(-1, 2)
    with mock.patch.object(perception, "_DEDUPE_FROM", 1):
        a, b = perceive(scan_once), perceive(scan)
    with mock.patch.object(perception, "_DEDUPE_FROM", 10**9):
        plain = perceive(scan)
    assert _same_obstacles(a, b) and _same_obstacles(b, plain)
    # every distinct return in range is kept (1 cm apart: none is a near-repeat)
    seen = {(x, y) for x, y in once if 1e-6 < x * x + y * y <= 1.1 * 1.1}
    assert set(map(tuple, b.points.tolist())) == seen
    # and one bearing at several ranges, repeated
    ray = np.array([(0.2, 0.1), (0.4, 0.2), (0.4, 0.2), (0.6, 0.3), (0.2, 0.1), (0.2, 0.1)])
    # and neighbours sharing one coordinate are not repeats
    column = np.array([(0.5, 0.1), (0.5, 0.2), (0.6, 0.2), (-0.4, 0.0), (-0.4, -0.0)])
    with mock.patch.object(perception, "_DEDUPE_FROM", 1):
        assert _same_obstacles(perceive(ray), perceive(ray[[0, 1, 3, 4]]))
        assert len(perceive(column).points) == 4  # 0.0 and -0.0: one point (a zero step)


def test_hand_built_obstacles_that_disagree_are_refused_with_a_reason():
    # boxes without the starts that say which points each covers used to fail deep in the
    # planner with a bare numpy broadcast error
    box = np.array([[(0.5, -0.1), (0.6, -0.1), (0.6, 0.1), (0.5, 0.1)]], float)
    with pytest.raises(ValueError, match="1 boxes need 1 centres, 1 radii and 2 starts"):
        Obstacles(box, box.mean(axis=1), np.array([0.1]))
    with pytest.raises(ValueError, match="1 radii"):
        Obstacles(box, box.mean(axis=1), np.zeros(0), np.zeros((0, 2)), np.array([0, 0]))
    ok = Obstacles.from_boxes(box)
    assert Obstacles(ok.boxes, ok.centres, ok.radii, ok.points, ok.starts).contains_point(0.55, 0.0) == 0
