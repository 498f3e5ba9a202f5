"""A door that closes (issue #42): a sliding panel the LiDAR sees once it is out of the wall;
the ``closing`` family (another doorway stays open: the robot goes round) and the ``shut``
family (no way is left: an honest UNREACHABLE, no false success)."""

from __future__ import annotations

import numpy as np
import pytest

from clomp.planner.scenarios import parse_scenario
from clomp.runtime.backends.world import Mover, make_world_robot
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.experiment.onerun import SUCCESS_RADIUS, run_once
from clomp.runtime.experiment.runspec import noise_seed

WALL = [{"type": "wall", "from": [0.6, -1.0], "to": [0.6, -0.2]}, {"type": "wall", "from": [0.6, 0.2], "to": [0.6, 1.0]}]
DOOR = {"kind": "door", "size": [0.44, 0.02], "path": [[1.0, 0.6, 0.42], [2.0, 0.6, 0.0]]}


def _ahead(w):
    """The nearest return within 5 cm of the robot's heading (m)."""
    pts = w.scan_now()
    return float(pts[np.abs(pts[:, 1]) < 0.05][:, 0].min(initial=np.inf))


def test_the_lidar_sees_the_doorway_open_then_shut_by_the_door():
    scene = parse_scenario({"name": "door", "goal": [1.2, 0.0], "obstacles": WALL}, "door")
    w = make_world_robot(scene, "ideal", seed=0, movers=[DOOR])
    w.sleep(0.5)
    assert _ahead(w) > 1.0  # before it moves: hidden in the wall, the doorway is open
    w.sleep(0.7)
    assert _ahead(w) > 1.0  # sliding: its edge is still 0.12 m to the side
    w.sleep(1.3)
    assert np.isclose(_ahead(w), 0.59, atol=1e-6)  # shut: its face where the wall's would be


@pytest.mark.parametrize("raw", [{"kind": "door", "path": [[0, 0.6, 0.0]]}, {"kind": "door", "size": [0.4, 0.02]},
                                 {"kind": "door", "size": [0.4, -1], "path": [[0, 0.6, 0.0]]},
                                 {"kind": "door", "size": [0.4, 0.02], "path": [[0, 0.6, 0.0]], "ahead": 0.1},
                                 {"kind": "door", "size": [0.4, 0.02], "path": [[0, 0.6, 0.0]], "angle": "x"}])
def test_a_malformed_door_is_refused_with_a_clear_error(raw):
    with pytest.raises(ValueError, match="door"):
        Mover.from_dict(raw)


def test_the_door_families_draw_a_door_in_the_doorway_ahead():
    for fam, expect in (("closing", "reach"), ("shut", "unreachable")):
        lay = make_layout(fam, 0, 4)
        (door,) = lay.movers
        p = lay.params
        assert lay.expect == expect and door.kind == "door"
        assert door.path[-1][1:] == (round(p["wall_x"], 4), round(p["door_y"], 4))  # it ends in the doorway
        assert 1.5 <= door.path[0][0] <= 4.0


def _run(family, k, noise="paper"):
    lay = make_layout(family, 0, k)
    return lay, run_once(lay.scene, "planning", noise_seed(0, k), run=k, noise=noise, movers=lay.movers,
                         expect=lay.expect, keep_report=True, max_time=120.0)


def test_when_the_doorway_ahead_closes_the_robot_goes_round_through_the_other():
    lay, r = _run("closing", 2)
    assert r.reached_goal and r.final_distance <= SUCCESS_RADIUS and r.end_state == "GOAL_REACHED", r.reason
    assert r.collisions == 0 and r.moving["moving_collisions"] == 0
    p = lay.params
    side_y = -p["side"] * 0.55
    crossing = [(x, y) for x, y in r.path if abs(x - p["wall_x"]) < 0.05]
    assert crossing and all(abs(y - side_y) < 0.18 for _, y in crossing), crossing  # through the side doorway


def test_when_the_only_doorway_closes_the_robot_says_unreachable_and_claims_nothing():
    lay, r = _run("shut", 1)
    assert r.end_state == "UNREACHABLE" and r.reached_goal, r.reason  # expect 'unreachable': success is saying so
    assert not r.believed_goal and r.final_distance > 0.3
    assert r.collisions == 0 and r.moving["moving_collisions"] == 0
