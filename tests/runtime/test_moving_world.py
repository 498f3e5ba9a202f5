"""A world that moves (issue #42): people and appearing boxes in the execution world, seen by
the LiDAR beam by beam, their contacts counted apart with who hit whom; the moving families
and their records."""

from __future__ import annotations

import numpy as np
import pytest

from clomp.planner.scenarios import load_scenario
from clomp.runtime.backends.world import Mover, make_world_robot
from clomp.runtime.experiment.layouts import ALL_FAMILIES, FAMILIES, MOVING_FAMILIES, make_layout
from clomp.runtime.experiment.onerun import moving_counts
from clomp.runtime.experiment.results import CSV_COLUMNS, summarise


def _world(*movers, noise="ideal"):
    return make_world_robot(load_scenario("open"), noise, seed=0, movers=list(movers))


def test_a_robot_driving_into_a_standing_person_caused_the_contact():
    w = _world({"kind": "person", "path": [[0, 0.5, 0.0]]})
    w.set_wheel_speeds(0.1, 0.1)
    w.sleep(4.0)
    assert moving_counts(w) == {"static_collisions": 0, "moving_collisions": 1, "moving_brushes": 0,
                                "robot_caused_collisions": 1}


def test_a_person_walking_into_a_standing_robot_did_not_make_the_robot_cause_it():
    w = _world({"kind": "person", "path": [[0, 0.0, -1.0], [3.0, 0.0, 1.0]], "stays": False})
    w.sleep(4.0)
    counts = moving_counts(w)
    assert counts["moving_collisions"] == 1 and counts["robot_caused_collisions"] == 0
    assert abs(w.ground_truth_pose().y) > 0.1  # the person pushed the robot aside


def test_a_turn_that_swings_the_body_into_a_box_is_the_robots_doing():
    w = _world({"kind": "box", "path": [[0, -0.13, 0.2]]})  # beside the rear: a left turn swings the tail into it
    w.set_wheel_speeds(0.05, -0.05)
    w.sleep(3.0)
    assert moving_counts(w)["robot_caused_collisions"] == 1


def test_static_contacts_are_counted_apart_from_moving_ones():
    scene = load_scenario("blocked")
    w = make_world_robot(scene, "ideal", seed=0, movers=[{"kind": "person", "path": [[0, -0.6, 0.6]]}])
    w.set_wheel_speeds(0.1, 0.1)
    w.sleep(8.0)
    counts = moving_counts(w)
    assert counts["static_collisions"] >= 1 and counts["moving_collisions"] == 0
    static, moving = w.contact_traces()
    assert static and not moving and len(static) == len(w.contact_trace())


def test_the_lidar_sees_a_person_beam_by_beam_where_it_is_then():
    w = _world({"kind": "person", "path": [[0.0, 0.6, -1.5], [3.0, 0.6, 1.5]], "stays": False})
    w.sleep(1.5)  # the person crosses the lane ahead now
    ahead = w.scan_now()
    near = ahead[np.hypot(ahead[:, 0] - 0.6, ahead[:, 1]) < 0.13]
    assert len(near) >= 5 and np.allclose(np.hypot(near[:, 0] - 0.6, near[:, 1]), 0.12, atol=1e-6)
    frames = []
    while len(frames) < 2:
        f = w.read_scan(timeout=0.0)
        if f is not None:
            frames.append(f)
        w.sleep(0.01)
    w.sleep(2.0)  # gone
    assert not (np.hypot(w.scan_now()[:, 0] - 0.6, w.scan_now()[:, 1]) < 0.2).any()


def test_a_person_walking_fast_is_in_the_revolutions_taken_while_it_walks():
    """The revolutions the robot reads (rays cast at their own times) show a person crossing at 2 m/s."""
    w = _world({"kind": "person", "path": [[0.0, 0.5, -2.0], [2.0, 0.5, 2.0]], "stays": False})
    seen = None
    while seen is None or w.now() < 1.0:
        f = w.read_scan(timeout=0.0)
        if f is not None and w.now() > 0.8:
            seen = f
        w.sleep(0.01)
    pts = seen.points
    person = pts[(np.abs(pts[:, 0] - 0.5) < 0.13) & (np.abs(pts[:, 1]) < 0.6)]
    assert len(person) >= 3


def test_a_box_appears_where_it_is_told_ahead_of_the_robot():
    w = _world({"kind": "box", "appear": 1.0, "ahead": 0.05})
    w.sleep(0.5)
    assert not (w.scan_now()[:, 0] < 0.5).any()
    w.sleep(0.6)
    pts = w.scan_now()
    front = pts[np.abs(pts[:, 1]) < 0.05]
    assert np.isclose(front[:, 0].min(), 0.09 + 0.05, atol=1e-6)


@pytest.mark.parametrize("raw", [{"kind": "cat", "path": [[0, 0, 0]]}, {"kind": "person"},
                                 {"kind": "box", "ahead": 0.1}, {"kind": "person", "path": [[1, 0, 0], [0, 1, 1]]},
                                 {"kind": "person", "path": [[0, float("nan"), 0]]}, {"kind": "person", "path": "x"}])
def test_a_malformed_mover_is_refused_with_a_clear_error(raw):
    with pytest.raises(ValueError, match="mover"):
        Mover.from_dict(raw)


def test_the_moving_families_are_reproducible_and_apart_from_the_static_ones():
    assert set(MOVING_FAMILIES) == {"crossing", "stopper", "appearing", "closing", "shut"}
    assert ALL_FAMILIES == FAMILIES + MOVING_FAMILIES and not set(FAMILIES) & set(MOVING_FAMILIES)
    for fam in MOVING_FAMILIES:
        a, b = make_layout(fam, 3, 7), make_layout(fam, 3, 7)
        assert a.scene == b.scene and a.movers == b.movers and a.movers
    for fam in FAMILIES:
        assert make_layout(fam, 0, 0).movers == ()


def test_old_records_without_the_moving_counts_still_summarise():
    old = {"family": "overtaking", "seed": 0, "run": 0, "condition": "planning", "success": 1, "reached_goal": 1,
           "believed_goal": 1, "collisions": 0, "brushes": 0, "final_error_m": 0.02, "time_s": 12.0, "wall_s": 1.0}
    new = dict(old, family="stopper", run=1, static_collisions=0, moving_collisions=2, moving_brushes=1,
               robot_caused_collisions=1)
    s = summarise([old, new])
    assert s["conditions"]["planning"]["moving_collisions"] == 2
    assert s["conditions"]["planning"]["robot_caused_collisions"] == 1
    assert "moving_collisions" not in summarise([old])["conditions"]["planning"]
    assert {"static_collisions", "moving_collisions", "robot_caused_collisions"} <= set(CSV_COLUMNS)


def test_a_scenario_file_may_carry_movers(tmp_path):
    import json

    from clomp.runtime.experiment.runspec import RunSpec, movers_for

    f = tmp_path / "room.json"
    f.write_text(json.dumps({"name": "room", "goal": [1.0, 0.0], "obstacles": [],
                             "movers": [{"kind": "box", "appear": 2.0, "ahead": 0.05}]}))
    (m,) = movers_for(RunSpec(str(f), 0, 0, "planning"))
    assert (m.kind, m.appear, m.ahead) == ("box", 2.0, 0.05)
    assert movers_for(RunSpec("open", 0, 0, "planning")) == ()
