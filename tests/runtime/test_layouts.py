"""Layout families: reproducible from (family, seed, index), varying within the documented ranges."""

from __future__ import annotations

import math

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.runtime.experiment.layouts import (
    FAMILIES,
    GOAL_CLEARANCE,
    make_layout,
    shape_distance,
)
from clomp.runtime.backends.sim import SimRobot

seeds = st.integers(0, 2**20)
index = st.integers(0, 500)


@given(family=st.sampled_from(FAMILIES), seed=seeds, i=index)
@settings(max_examples=60, deadline=None)
def test_reproducible_and_valid(family, seed, i):
    a, b = make_layout(family, seed, i), make_layout(family, seed, i)
    assert a.scene == b.scene and a.scene.raw == b.scene.raw and a.params == b.params
    SimRobot(a.scene, seed=0)  # the body fits at the start (the simulator refuses an overlap)
    if a.expect == "reach":
        gx, gy = a.scene.goal
        assert min(shape_distance(s, gx, gy) for s in a.scene.shapes) >= GOAL_CLEARANCE - 1e-9


@pytest.mark.parametrize("family", FAMILIES)
def test_runs_of_one_seed_differ(family):
    scenes = {repr(make_layout(family, 0, i).scene.raw["obstacles"]) for i in range(10)}
    assert len(scenes) == 10
    assert make_layout(family, 0, 0).scene.raw != make_layout(family, 1, 0).scene.raw


@given(seed=seeds, i=index)
@settings(max_examples=80, deadline=None)
def test_overtaking_varies_as_specified(seed, i):
    p = make_layout("overtaking", seed, i).params
    assert 0.35 <= p["x"] <= 0.7 and abs(p["y"]) <= 0.15
    assert 0.1 <= p["width"] <= 0.3 and p["depth"] <= 0.3
    assert p["x"] + p["depth"] / 2 <= 0.8  # the body fits at the goal, 1 m ahead
    if p["walls"]:
        half = p["wall_half_width"]
        assert max(half - (p["y"] + p["width"] / 2), half + (p["y"] - p["width"] / 2)) >= 0.3 - 1e-9


def test_overtaking_spans_its_ranges_and_has_walls_in_about_half():
    ps = [make_layout("overtaking", 0, i).params for i in range(300)]
    xs, ys, ws = [p["x"] for p in ps], [p["y"] for p in ps], [p["width"] for p in ps]
    assert min(xs) < 0.4 and max(xs) > 0.65
    assert min(ys) < -0.12 and max(ys) > 0.12
    assert min(ws) < 0.13 and max(ws) > 0.27
    assert 0.4 < sum(p["walls"] for p in ps) / len(ps) < 0.6


@given(seed=seeds, i=index)
@settings(max_examples=40, deadline=None)
def test_the_other_families_vary_as_specified(seed, i):
    c = make_layout("corridor", seed, i).params
    assert 0.44 <= c["width"] <= 0.8 and 0.9 <= c["goal_x"] <= 1.4 and abs(c["heading"]) <= 0.15
    d = make_layout("doorway", seed, i).params
    assert 0.4 <= d["wall_x"] <= 0.65 and 0.3 <= d["door_width"] <= 0.5 and abs(d["door_y"]) <= 0.35
    s = make_layout("slalom", seed, i).params
    assert 2 <= len(s["boxes"]) <= 3
    sides = [math.copysign(1, b[1]) for b in s["boxes"]]
    assert all(a != b for a, b in zip(sides, sides[1:]))  # alternately left and right
    cl = make_layout("clutter", seed, i)
    assert 3 <= cl.params["posts"] <= 8 and len(cl.scene.shapes) == cl.params["posts"]
    u = make_layout("u-trap", seed, i)
    assert u.params["goal_x"] > u.params["back_x"] + 0.29 and u.params["back_x"] - u.params["arm"] >= 0.25 - 1e-9
    cds = make_layout("cul-de-sac", seed, i)
    assert cds.expect == "unreachable" and 0.5 <= cds.params["width"] <= 0.8


def test_cul_de_sac_goal_is_enclosed():
    lay = make_layout("cul-de-sac", 3, 0)
    gx, gy = lay.scene.goal
    # every ray from the goal hits a wall within the room
    import numpy as np

    d = lay.scene.raycast(np.array([gx, gy]), np.linspace(0, 2 * math.pi, 72, endpoint=False), 5.0)
    assert np.isfinite(d).all()


def test_bad_family_and_seed_are_refused():
    with pytest.raises(ValueError, match="unknown layout family 'maze'"):
        make_layout("maze", 0)
    with pytest.raises(ValueError, match="seed"):
        make_layout("overtaking", -1)


def test_gallery_png(tmp_path):
    from clomp.runtime.experiment.plots import plot_gallery

    p = tmp_path / "gallery.png"
    plot_gallery(p, per_family=2)
    assert p.stat().st_size > 20_000
