"""The dwa condition's compiled clearance is the numpy statement's bit for bit, and so are its decisions."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.model import Pose
from clomp.planner.robot_model import RobotModel
from clomp.runtime.experiment._dwa_clearance import arc_clearance, arc_clearance_numpy
from clomp.runtime.experiment.dwa import DwaController

_BODY = (RobotModel().rear_offset, RobotModel().front_offset, RobotModel().clearance, RobotModel().width)


def _same(a: np.ndarray, b: np.ndarray) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()  # bit for bit, inf and -0.0 included


def _points(rng: np.random.Generator, n: int) -> np.ndarray:
    """Scan-like points: scattered, a wall, and points on the inflated body's edges (a leg exactly 0)."""
    rear, front, clearance, width = _BODY
    edge_x, edge_y = [-rear - clearance, front + clearance], [-(width / 2 + clearance), width / 2 + clearance]
    on_edges = np.array([[x, y] for x in edge_x for y in edge_y] + [[front + clearance, 0.0], [0.0, width / 2 + clearance]])
    wall = np.c_[np.full(n // 2, rng.uniform(0.1, 0.6)), np.linspace(-0.5, 0.5, n // 2)]
    out: np.ndarray = np.r_[rng.uniform(-1.2, 1.2, (n, 2)), wall, on_edges]
    return out


class _Still:
    """A robot that stands still (the controller only reads its model here)."""


class _ReferenceDwa(DwaController):
    """The dwa controller with the numpy statement as its clearance."""

    def _clearance(self, pts: np.ndarray, x: np.ndarray, y: np.ndarray, th: np.ndarray, cap: float = np.inf,
                   stop: float = 0.0) -> np.ndarray:
        out: np.ndarray = arc_clearance_numpy(pts, x, y, th, self._body()).min(axis=1)  # exact, cap and stop unused
        return out


@settings(max_examples=80, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 300), arcs=st.integers(1, 40), poses=st.integers(1, 9))
def test_the_compiled_clearance_is_the_numpy_statement(seed: int, n: int, arcs: int, poses: int) -> None:
    rng = np.random.default_rng(seed)
    pts = _points(rng, n)[: n + 6 * (n > 0)]
    th = rng.uniform(-3.5, 3.5, (arcs, poses))
    th[0] = 0.0  # a straight arc: the edges' points exactly on the body
    x, y = rng.uniform(-0.4, 0.4, (arcs, poses)), rng.uniform(-0.4, 0.4, (arcs, poses))
    x[0], y[0] = 0.0, 0.0
    assert _same(arc_clearance(pts, x, y, th, _BODY), arc_clearance_numpy(pts, x, y, th, _BODY).min(axis=1))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 120), cap=st.floats(0.0, 1.0), stop=st.floats(-0.1, 0.3))
def test_a_cap_and_a_stop_leave_the_clearance_exact_between_them(seed: int, n: int, cap: float, stop: float) -> None:
    """Above ``stop`` the distance is the exact minimum, or ``cap`` when that is larger; at or below, it is at most ``stop``."""
    rng = np.random.default_rng(seed)
    pts = _points(rng, n)
    th = rng.uniform(-2.0, 2.0, (30, 6))
    x, y = rng.uniform(-0.6, 0.6, (30, 6)), rng.uniform(-0.6, 0.6, (30, 6))
    exact = arc_clearance_numpy(pts, x, y, th, _BODY).min(axis=1)
    got = arc_clearance(pts, x, y, th, _BODY, cap=cap, stop=stop)
    above = np.minimum(exact, cap) > stop
    assert _same(got[above], np.minimum(exact, cap)[above])
    assert (got[~above] <= stop).all()


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(1, 8))
def test_a_few_points_ahead_of_straight_and_turning_arcs(seed: int, n: int) -> None:
    """Clear arcs (no hit): the minimum is one point's front, side or corner distance, to the last bit."""
    rng = np.random.default_rng(seed)
    pts = np.c_[rng.uniform(0.15, 1.0, n), rng.uniform(-0.4, 0.4, n)]
    t = np.linspace(0.1, 0.4, 4)
    w = np.r_[0.0, rng.uniform(-1.5, 1.5, 5)]
    th = np.outer(w, t)
    x, y = np.outer(np.full(6, 0.1), t), np.zeros((6, 4))
    assert _same(arc_clearance(pts, x, y, th, _BODY), arc_clearance_numpy(pts, x, y, th, _BODY).min(axis=1))


@settings(max_examples=60, deadline=None)
@given(seed=st.integers(0, 2**31 - 1), n=st.integers(0, 250), vl=st.floats(-0.2, 0.2), vr=st.floats(-0.2, 0.2),
       gx=st.floats(-2.0, 2.0), gy=st.floats(-2.0, 2.0), recover=st.sampled_from([-1, 0, 1]), sparse=st.booleans())
def test_the_decisions_are_the_numpy_statements(seed: int, n: int, vl: float, vr: float, gx: float, gy: float,
                                                recover: int, sparse: bool) -> None:
    rng = np.random.default_rng(seed)
    if sparse:  # a few points a little way off: the arcs' clearances between the margin and the cap decide
        r, a = rng.uniform(0.25, 0.7, n % 8 + 1), rng.uniform(-np.pi, np.pi, n % 8 + 1)
        scan = np.c_[r * np.cos(a), r * np.sin(a)]
    else:
        scan = _points(rng, n)[: n + 6 * (n > 0)]
    fast, ref = DwaController(_Still(), (gx, gy)), _ReferenceDwa(_Still(), (gx, gy))
    for c in (fast, ref):
        c._scan, c._scan_pose, c._t0, c._cmd, c._recover = scan, c.pose, 0.0, (vl, vr), recover
    g = Pose(gx, gy, 0.0)
    pts = fast._body_points()
    assert fast._best(pts, g) == ref._best(pts, g)
    assert fast._control(g, 0.0) == ref._control(g, 0.0)
    assert fast._recovery(pts, g) == ref._recovery(pts, g)
    assert fast._recover == ref._recover and fast.avoid_ticks == ref.avoid_ticks
