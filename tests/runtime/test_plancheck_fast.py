"""The fast plan check (and recall) give exactly the reference check's answers."""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.geometry import relative
from clomp.formal.model import Pose
from clomp.formal.supervisory import Guard
from clomp.planner import Configurator
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.backends import make_world_robot
from tests.runtime._checkref import check_plan_reference
from clomp.runtime.supervision.checkgeometry import _legs
from clomp.runtime.supervision.plancheck import RecallIndex, check_plan, perceive_scan, recall

ORIGIN = Pose(0.0, 0.0, 0.0)


@functools.lru_cache(maxsize=64)
def _planned(name: str, layout: int, noise: str) -> tuple[Any, np.ndarray, Pose]:
    scene = make_layout(name, 0, layout).scene
    scan = make_world_robot(scene, noise, seed=layout).read_scan().points
    goal = Pose(*scene.goal_in_robot_frame())
    return Configurator().plan(scan, (goal.x, goal.y)), np.asarray(scan), goal


def _clutter(result: Any, pose: Pose, rng: np.random.Generator, n: int, spread: float) -> np.ndarray:
    """``n`` points around the plan's tasks (robot frame at ``pose``), where the check's
    rules differ: half scattered about their starts and ends, half within 3 cm of the body's
    outline where a task starts (inside the real body, in the clearance, just outside) or
    of the disc a turn sweeps."""
    m = result.robot
    legs = _legs(result.steps, relative(pose, ORIGIN), False)
    centres = np.array([g.start[:2] for g in legs] + [g.reached[:2] for g in legs])
    pick = centres[rng.integers(0, len(centres), n - n // 2)]
    out = [pick + rng.uniform(-spread, spread, (len(pick), 2))]
    for _ in range(n // 2):
        g = legs[int(rng.integers(0, len(legs)))]
        x, y, th = g.start
        if rng.random() < 0.25:  # on the rim of the disc the inflated body sweeps
            a, r = rng.uniform(-math.pi, math.pi), m.swept_radius + rng.uniform(-0.01, 0.01)
            u, v = r * math.cos(a), r * math.sin(a)
        elif rng.random() < 0.5:  # beside a side
            u, v = rng.uniform(-m.rear_offset, m.front_offset), rng.choice([-1, 1]) * (m.width / 2 + rng.uniform(-0.03, 0.03))
        else:  # before the front or behind the back
            u, v = rng.choice([m.front_offset, -m.rear_offset]) + rng.uniform(-0.03, 0.03), rng.uniform(-m.width / 2, m.width / 2)
        out.append(np.array([[x + u * math.cos(th) - v * math.sin(th), y + u * math.sin(th) + v * math.cos(th)]]))
    return np.concatenate(out)


@given(name=st.sampled_from(["overtaking", "corridor", "doorway", "slalom"]), layout=st.integers(0, 15),
       noise=st.sampled_from(["ideal", "paper", "harsh"]), dx=st.floats(-0.05, 0.05), dy=st.floats(-0.05, 0.05),
       dth=st.floats(-0.2, 0.2), extra=st.integers(0, 40), spread=st.sampled_from([0.05, 0.12, 0.25]),
       seed=st.integers(0, 2**16), allowance=st.sampled_from([0.0, 0.005, 0.01, 0.0275]), running=st.booleans(),
       first=st.integers(0, 3), perceived=st.booleans())
@settings(max_examples=400, deadline=None)
def test_the_fast_check_gives_the_reference_checks_answer(name, layout, noise, dx, dy, dth, extra, spread, seed,
                                                          allowance, running, first, perceived):
    """On random plans, pose errors and scans with points scattered inside, beside and
    along the body's path, :func:`check_plan` and :func:`check_plan_reference` agree on the
    verdict, the reason (with its figures) and the task named."""
    result, scan, _goal = _planned(name, layout, noise)
    if not result.steps:
        return
    rng = np.random.default_rng(seed)
    pose = Pose(dx, dy, dth)
    seen = np.r_[scan, _clutter(result, pose, rng, extra, spread)]
    states = list(result.steps[min(first, len(result.steps) - 1):])
    given_ = perceive_scan(seen, result.robot) if perceived else seen
    fast = check_plan(states, ORIGIN, pose, Pose(1.0, 0.0), given_, result.robot, running=running, allowance=allowance)
    ref = check_plan_reference(states, ORIGIN, pose, given_, result.robot, running=running, allowance=allowance)
    assert (fast.ok, fast.reason, fast.tasks) == (ref.ok, ref.reason, ref.tasks)


def test_the_reference_agrees_on_every_branch_at_least_once():
    """The random scans above reach each outcome: free, a straight blocked, a turn blocked,
    an end off the prediction (else the comparison would prove less than it says)."""
    seen: set[str] = set()
    robot = None
    for layout in range(6):
        result, scan, _ = _planned("slalom", layout, "paper")
        robot = result.robot
        rng = np.random.default_rng(layout)
        for k in range(40):
            off = 0.02 if k % 2 else 0.12  # within the tolerance of the map's ends, and beyond
            pose = Pose(*rng.uniform(-off, off, 2), float(rng.uniform(-4 * off, 4 * off)))
            pts = np.r_[scan, _clutter(result, pose, rng, int(rng.integers(0, 30)), 0.15)]
            fast = check_plan(result.steps, ORIGIN, pose, Pose(1.0, 0.0), pts, robot)
            ref = check_plan_reference(result.steps, ORIGIN, pose, pts, robot)
            assert (fast.ok, fast.reason, fast.tasks) == (ref.ok, ref.reason, ref.tasks)
            kind = "free" if fast.ok else "off" if "prediction" in fast.reason else \
                "straight" if "STRAIGHT" in fast.reason else "turn"
            seen.add(kind)
    assert seen == {"free", "off", "straight", "turn"}, seen


def test_a_recall_with_the_maps_guard_template_gives_the_maps_guard():
    """The recall index's guard (reusing the keys of the guard given with the index) gives Ψ
    of the recalled plan exactly as :meth:`clomp.formal.supervisory.Guard.table`, also when
    the index was made without it."""
    result, scan, goal = _planned("overtaking", 0, "ideal")
    for psi in (result.psi, None):
        index = RecallIndex(result.map, plan=result.plan, psi=psi)
        for ident in result.plan.states[1:-1]:
            here = result.map[ident].end
            rel = relative(here, ORIGIN)
            c, s = math.cos(rel.theta), math.sin(rel.theta)
            seen = np.c_[rel.x + c * scan[:, 0] - s * scan[:, 1], rel.y + s * scan[:, 0] + c * scan[:, 1]]
            found, why, _ = recall(result, ORIGIN, here, goal, seen, result.robot, index=index)
            if found is not None:
                assert found.result.psi == Guard(result.map, found.result.plan).table()
                plain, _, _ = recall(result, ORIGIN, here, goal, seen, result.robot)
                assert plain is not None and plain.result.psi == found.result.psi


def _legs_and_points(rng: np.random.Generator, m: Any, n_legs: int, n_pts: int) -> tuple[list[Any], np.ndarray]:
    """Random tasks of one kind family and points about their starts: uniform in the
    swept disc and within 3 cm of the real body's outline (inside it, in the clearance, out)."""
    from clomp.formal.model import TaskKind
    from clomp.runtime.supervision.checkgeometry import _Leg

    legs, pts = [], []
    for k in range(n_legs):
        kind = [TaskKind.STRAIGHT, TaskKind.LEFT, TaskKind.RIGHT][int(rng.integers(3))]
        x, y, th = float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-0.3, 0.3)), float(rng.uniform(-math.pi, math.pi))
        amount = float(rng.uniform(0.002, 0.6 if kind is TaskKind.STRAIGHT else math.pi))
        legs.append(_Leg(k, kind, (x, y, th), amount, (x, y, th), (x, y, th)))
        for _ in range(n_pts):
            r = rng.random()
            if r < 0.3:  # in the swept disc, a third of them on its rim
                a = rng.uniform(-math.pi, math.pi)
                d = m.swept_radius - rng.uniform(0.0, 0.006) if r < 0.1 else m.swept_radius * math.sqrt(rng.random()) + 0.01
                u, v = d * math.cos(a), d * math.sin(a)
            elif r < 0.65:
                u, v = rng.uniform(-m.rear_offset, m.front_offset), rng.choice([-1, 1]) * (m.width / 2 + rng.uniform(-0.03, 0.03))
            else:
                u = rng.choice([m.front_offset, -m.rear_offset]) + rng.uniform(-0.03, 0.03)
                v = rng.uniform(-m.width / 2 - 0.02, m.width / 2 + 0.02)
            pts.append(complex(x + u * math.cos(th) - v * math.sin(th), y + u * math.sin(th) + v * math.cos(th)))
    return legs, np.array(pts, dtype=complex)


@given(seed=st.integers(0, 2**32 - 1), n_legs=st.integers(1, 4), n_pts=st.integers(1, 12),
       allowance=st.sampled_from([0.0, 0.005, 0.01, 0.02, 0.0275]))
@settings(max_examples=400, deadline=None)
def test_the_fast_contacts_are_the_reference_contacts(seed, n_legs, n_pts, allowance):
    """Task by task, the fast straight and turn contacts are bit-equal to the reference's,
    whichever other tasks are tested with them (no task's answer depends on another's); a
    turn's also with far points added (which the reach filter of a large array drops)."""
    from clomp.formal.model import TaskKind
    from clomp.runtime.supervision import checkgeometry
    from tests.runtime import _checkref as checkref

    m = Configurator().robot
    legs, z = _legs_and_points(np.random.default_rng(seed), m, n_legs, n_pts)
    for which, fast, ref in ((lambda g: g.kind is TaskKind.STRAIGHT, checkgeometry._straight_contacts, checkref._straight_contacts),
                             (lambda g: g.kind is not TaskKind.STRAIGHT, checkgeometry._turn_contacts, checkref._turn_contacts)):
        group = [g for g in legs if which(g)]
        if group:
            together = fast(z, group, m, allowance)
            assert together == ref(z, group, m, allowance)
            assert together == [fast(z, [g], m, allowance)[0] for g in group]
            if fast is checkgeometry._turn_contacts:  # far points in a large array: the reach filter runs
                assert fast(np.r_[z, 5.0 * np.exp(1j * np.linspace(0.0, 6.0, 3000))], group, m, allowance) == together


def test_the_compiled_check_is_ready_before_the_robot_moves():
    """A fresh process: the supervisor's plan watch compiles (or loads) the check's loops
    with the types a check uses, so the first check of a driving robot does not compile."""
    import subprocess
    import sys

    code = """
from clomp.runtime.supervision import _contacts_core as c
from clomp.runtime.supervision.planwatch import PlanWatch
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.backends import make_world_robot
from clomp.planner import Configurator
from clomp.formal.model import Pose
from clomp.runtime.supervision.plancheck import check_plan
assert not c.straight_gaps.signatures and not c.turn_first_ticks.signatures
conf = Configurator()
PlanWatch(conf.robot)
before = (len(c.straight_gaps.signatures), len(c.turn_first_ticks.signatures))
scene = make_layout("slalom", 0, 1).scene
scan = make_world_robot(scene, "paper", seed=1).read_scan().points
result = conf.plan(scan, tuple(scene.goal_in_robot_frame()))
ORIGIN = Pose(0.0, 0.0, 0.0)
check_plan(list(result.steps), ORIGIN, ORIGIN, Pose(1.0, 0.0), scan, result.robot)
print(before, (len(c.straight_gaps.signatures), len(c.turn_first_ticks.signatures)))
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "(1, 1) (1, 1)"
