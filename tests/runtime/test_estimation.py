"""Scan matching, de-skewing, scan odometry and revolution fusion."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.formal.geometry import compose, points_to_frame, relative
from clomp.formal.model import Pose
from clomp.planner.scenarios import parse_scenario
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.estimation import match_scans
from clomp.runtime.estimation.fusion import fuse_revolutions
from clomp.runtime.estimation.odometry import ScanOdometry, deskew
from clomp.runtime.backends import make_world_robot

# a corridor with a doorway gap, a post and an end wall: like the recorded scans
ROOM = {
    "goal": [0.7, 0.0],
    "obstacles": [
        {"type": "wall", "from": [-1.0, 0.45], "to": [0.2, 0.45]},
        {"type": "wall", "from": [0.6, 0.45], "to": [1.5, 0.45]},
        {"type": "wall", "from": [-1.0, -0.45], "to": [1.5, -0.45]},
        {"type": "wall", "from": [0.9, -0.45], "to": [0.9, 0.45]},
        {"type": "box", "center": [0.5, -0.25], "size": [0.08, 0.08]},
    ],
}
CORRIDOR = {"goal": [1.0, 0.0], "obstacles": [
    {"type": "wall", "from": [-3.0, 0.35], "to": [3.0, 0.35]},
    {"type": "wall", "from": [-3.0, -0.35], "to": [3.0, -0.35]},
]}


def _pair(scene_doc, a: Pose, motion: Pose, noise="paper", seed=0):
    scene = parse_scenario(scene_doc, "t")
    b = compose(a, motion)
    sa = make_world_robot(scene, noise, seed=seed, start=a).read_scan()
    sb = make_world_robot(scene, noise, seed=seed + 100, start=b).read_scan()
    assert sa is not None and sb is not None
    return sa.points, sb.points


@pytest.mark.parametrize("seed", range(6))
def test_known_motion_is_recovered_within_a_centimetre_and_a_degree(seed):
    rng = np.random.default_rng(seed)
    a = Pose(float(rng.uniform(-0.2, 0.3)), float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.3, 0.3)))
    motion = Pose(float(rng.uniform(0.0, 0.08)), float(rng.uniform(-0.02, 0.02)), float(rng.uniform(-0.15, 0.15)))
    ref, cur = _pair(ROOM, a, motion, seed=seed)
    prior = Pose(motion.x + 0.02, motion.y - 0.02, motion.theta + 0.05)  # dead reckoning is off
    m = match_scans(ref, cur, prior)
    assert m.ok and not m.unobservable, m.reason
    assert math.hypot(m.pose.x - motion.x, m.pose.y - motion.y) < 0.01
    assert abs(m.pose.theta - motion.theta) < math.radians(1)


def test_a_corridor_leaves_the_way_along_it_to_dead_reckoning():
    ref, cur = _pair(CORRIDOR, Pose(0.0, 0.0, 0.0), Pose(0.05, 0.01, 0.05))
    prior = Pose(0.08, 0.03, 0.0)
    m = match_scans(ref, cur, prior)
    assert m.ok and m.unobservable == ("x",), (m.unobservable, m.reason)
    assert m.pose.x == pytest.approx(prior.x, abs=0.002)  # the prior's value along the corridor
    assert m.pose.y == pytest.approx(0.01, abs=0.005) and m.pose.theta == pytest.approx(0.05, abs=0.01)


def test_no_returns_is_a_failed_match_that_keeps_the_prior():
    prior = Pose(0.1, 0.0, 0.0)
    m = match_scans(np.zeros((0, 2)), np.zeros((0, 2)), prior)
    assert not m.ok and m.pose == prior and set(m.unobservable) == {"x", "y", "heading"}
    assert "too few points" in m.reason


def test_a_match_far_from_the_prior_is_gated_out():
    ref, cur = _pair(ROOM, Pose(0.0, 0.0, 0.0), Pose(0.06, 0.0, 0.0), noise="ideal")
    ok = match_scans(ref, cur, Pose(0.0, 0.0, 0.0))
    assert ok.ok and ok.pose.x == pytest.approx(0.06, abs=0.005)
    gated = match_scans(ref, cur, Pose(0.0, 0.0, 0.0), gate=(0.02, 0.1))
    assert not gated.ok and "disagrees with the prior" in gated.reason and gated.pose == Pose(0.0, 0.0, 0.0)


def test_deskew_puts_each_point_where_it_was_at_the_revolutions_end():
    # a point straight ahead seen 0.5 s before the end while turning left at 1 rad/s in place
    p = deskew(np.array([[1.0, 0.0]]), np.array([-0.5]), 0.0, 1.0)
    assert p[0] == pytest.approx([math.cos(-0.5), math.sin(-0.5)])
    pts = np.array([[1.0, 0.0]])
    assert deskew(pts, None, 0.1, 0.0) is pts


def _run_commands(world: Any, odo: ScanOdometry, commands: list[tuple[float, float]], feedback: bool) -> float:
    """Drive ``world`` through one wheel command a 0.1 s tick, ``odo`` estimating (with the
    scans when ``feedback``); the final estimate's true error (m)."""
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    cmd = (0.0, 0.0)
    for nxt in commands:
        odo.advance(world.now(), cmd)
        frame = world.read_scan(0.0)
        if frame is not None and feedback:
            odo.update(frame)
        cmd = nxt
        world.set_wheel_speeds(*cmd)
        world.sleep(0.1)
    odo.advance(world.now(), cmd)
    truth = relative(world.start_pose, world.ground_truth_pose())
    return math.hypot(odo.pose.x - truth.x, odo.pose.y - truth.y)


def _drive(feedback: bool, seed: int) -> float:
    """Drive a biased robot in the room; return the final estimate's true error (m)."""
    world = make_world_robot(parse_scenario(ROOM, "t"), "harsh-modelled", seed=seed)
    commands = [(0.0, 0.0) if k < 5 else ((0.08, 0.1) if k < 50 else (0.1, 0.08)) for k in range(90)]
    return _run_commands(world, ScanOdometry(0.15), commands, feedback)


def test_scan_odometry_beats_dead_reckoning_in_a_harsh_world():
    """Over six noise draws the scan-matched estimate ends within 5 cm of the truth every
    time and, in the median, within half of dead reckoning's error (measured over seeds
    0-9: 0.2-3.9 cm, median 2 cm, against 6.2 cm blind; no gyro here). At ``harsh-modelled``,
    the world whose errors the filter models: ``harsh``'s pushes and slip events move the
    body where no estimate built on wheels and matches follows at once (seed 0 ended 12 cm
    off); what the estimator owes there is the doubt (tests/runtime/test_doubt.py)."""
    with_scans = [_drive(True, s) for s in range(6)]
    blind = [_drive(False, s) for s in range(6)]
    assert max(with_scans) < 0.05, with_scans
    assert np.median(with_scans) < 0.5 * np.median(blind), (with_scans, blind)


def test_scan_odometry_records_why_it_fell_back():
    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    first = odo.update(ScanFrame(np.zeros((0, 2)), 0.0))
    assert not first.ok and "too few to seed" in first.reason
    odo.advance(0.5, (0.1, 0.1))
    rec = odo.update(ScanFrame(np.zeros((0, 2)), 0.5))
    assert not rec.ok and rec.source == "dead-reckoning" and "too few" in rec.reason
    assert odo.pose.x == pytest.approx(0.05)


def test_fusing_revolutions_shrinks_range_noise_and_drops_lone_outliers():
    rng = np.random.default_rng(0)
    ang = np.radians(np.arange(-40, 40, 0.5))
    truth = 0.6 / np.cos(ang)  # a wall at x = 0.6
    scans = []
    for _ in range(5):
        r = truth + 0.025 * rng.standard_normal(len(ang))
        scans.append(np.c_[r * np.cos(ang), r * np.sin(ang)])
    scans[2] = np.r_[scans[2], [[0.2, 0.9]]]  # one stray return, seen once
    fused = fuse_revolutions(scans)
    raw_err = np.std(scans[0][:, 0] - 0.6)
    assert np.std(fused[:, 0] - 0.6) < 0.7 * raw_err
    assert not np.any(np.hypot(fused[:, 0] - 0.2, fused[:, 1] - 0.9) < 0.05)
    assert np.array_equal(fuse_revolutions(scans[:1]), scans[0])


def test_the_supervisor_runs_its_tasks_on_the_scan_matched_estimate():
    """In a structured room under harsh noise the estimate the tasks run on tracks the truth,
    better than dead reckoning alone does on the same worlds (``harsh-modelled``: the
    tracking of the modelled errors, as measured; ``harsh``'s pushes are the doubt's)."""
    from clomp.runtime.supervision import Supervisor, SupervisorConfig

    scene = parse_scenario(ROOM, "room")

    def final_error(feedback: str, seed: int) -> tuple[float, Any]:
        world = make_world_robot(scene, "harsh-modelled", seed=seed)
        sup = Supervisor(world, scene.goal_in_robot_frame(), config=SupervisorConfig(feedback=feedback))
        rep = sup.run(max_time=150)
        truth = relative(world.start_pose, world.ground_truth_pose())
        return math.hypot(sup.pose.x - truth.x, sup.pose.y - truth.y), rep

    scan = [final_error("scan", s) for s in range(3)]
    blind = [final_error("none", s)[0] for s in range(3)]
    assert max(e for e, _ in scan) < 0.04 and np.median([e for e, _ in scan]) < np.median(blind)
    rep = scan[0][1]
    assert rep.feedback and all(r.ok for r in rep.feedback[1:])
    assert not blind or all(not r.feedback for r in [final_error("none", 0)[1]])
    with pytest.raises(ValueError, match="feedback"):
        SupervisorConfig(feedback="lidar")


def test_still_revolutions_at_the_start_are_fused_into_the_map_seed() -> None:
    """Standing at the start pose (which fixes the frame), every revolution joins the
    seed, fused: the map's wall is less noisy than one revolution's, so matches later
    inherit less of its error."""
    rng = np.random.default_rng(3)
    ys = np.linspace(-0.6, 0.6, 121)

    def revolution() -> np.ndarray:
        return np.c_[np.full(len(ys), 1.0) + rng.normal(0.0, 0.025, len(ys)), ys]

    odo = ScanOdometry(0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    first = odo.update(ScanFrame(revolution(), 0.0))
    assert first.ok and odo._map_points is not None
    one = float(np.std(odo._map_points[:, 0] - 1.0))
    for k in range(1, 8):
        rec = odo.update(ScanFrame(revolution(), 0.18 * k))
    assert "8 still revolutions fused" in rec.reason
    fused = float(np.std(odo._map_points[:, 0] - 1.0))
    assert fused < 0.6 * one, (one, fused)
    # once the robot moves, the seed is fixed and revolutions are matched against it
    odo.advance(0.18 * 8 + 0.1, (0.1, 0.1))
    assert "seed" not in odo.update(ScanFrame(revolution() - [0.01, 0.0], 0.18 * 8 + 0.1)).reason


POSTS = {"goal": [1.6, 0.0], "obstacles": [
    {"type": "box", "center": [0.45, 0.35], "size": [0.1, 0.2]},
    {"type": "box", "center": [0.9, -0.35], "size": [0.1, 0.2]},
    {"type": "box", "center": [1.35, 0.35], "size": [0.1, 0.2]},
]}


def _past_posts(seed: int, feedback: bool, noise_factor: float = math.sqrt(2.0)) -> tuple[float, float | None]:
    """Stand 1 s, then drive 1.6 m straight past three posts on good wheels with a noisy
    LiDAR (2.5 cm of range noise, every other term at ``paper``); the estimate's true
    error (m) at the end, and the range noise the estimator measured."""
    from clomp.runtime.backends.world import WorldNoise

    noise = WorldNoise(**{**WorldNoise.preset("paper").to_dict(), "range_sd": 0.025})
    world = make_world_robot(parse_scenario(POSTS, "posts"), noise, seed=seed)
    # the face compass off: this measures how the matches are weighted, alone
    odo = ScanOdometry(0.15, noise_factor=noise_factor, compass=False)
    commands = [(0.0, 0.0) if k < 10 else (0.1, 0.1) for k in range(170)]
    return _run_commands(world, odo, commands, feedback), odo.range_sd


def test_a_noisy_lidar_is_trusted_only_as_far_as_its_measured_noise() -> None:
    """With 2.5 cm of range noise the still revolutions at the start measure it, and the
    matches are weighted by it: scan feedback then beats dead reckoning past small posts.
    Believing the matches' own residual (about 1 cm over the points they pair), as the
    estimator once did (``noise_factor=0``), made it drift further than dead reckoning.
    Over these 12 draws: 3.3 cm (median) honest, 4.7 cm overconfident, 4.0 cm blind (with
    the LiDAR's old 1 cm x-y grid: 2.6, 5.8 and 4.0)."""
    seeds = range(12)
    honest = [_past_posts(s, True) for s in seeds]
    overconfident = [_past_posts(s, True, noise_factor=0.0)[0] for s in seeds]
    blind = [_past_posts(s, False)[0] for s in seeds]
    assert all(sd is not None and 0.018 < sd < 0.04 for _, sd in honest), honest
    errors = [e for e, _ in honest]
    assert np.median(errors) < np.median(blind), (errors, blind)
    assert np.median(errors) < 0.8 * np.median(overconfident), (errors, overconfident)


def test_range_spread_reads_the_noise_and_ignores_edges() -> None:
    from clomp.runtime.estimation.fusion import range_spread

    rng = np.random.default_rng(1)
    ang = np.radians(np.arange(-60, 60, 1.0))
    base = 0.8 / np.cos(ang)
    revs = []
    for k in range(5):
        r = base + rng.normal(0.0, 0.01, len(ang))
        r[::15] = np.where(k % 2, 2.5, r[::15])  # edge bins: the object one revolution, the far wall the next
        revs.append(np.c_[r * np.cos(ang), r * np.sin(ang)])
    sd = range_spread(revs)
    assert sd is not None and 0.008 < sd < 0.013, sd
    assert range_spread(revs[:1]) is None                        # one revolution: nothing to compare
    assert range_spread([np.zeros((0, 2)), np.zeros((0, 2))]) is None  # no returns


# -- the compiled matcher's nearest-point search -------------------------------------------------
coords = st.floats(-3.0, 3.0, allow_nan=False)


@settings(max_examples=100, deadline=None)
@given(ref=st.lists(st.tuples(coords, coords), min_size=1, max_size=60),
       near=st.lists(st.tuples(st.integers(0, 59), st.floats(-0.7, 0.7), st.floats(-0.7, 0.7)), min_size=1, max_size=20),
       bound=st.floats(0.01, 0.6), cell=st.sampled_from([0.05, 0.1, 0.3]))
def test_the_grid_search_finds_what_a_kd_tree_finds(ref, near, bound, cell):
    """Invariant: within the bound, the grid's nearest point is as near as the k-d tree's
    nearest (ties may pick another point at the same distance); beyond it, none."""
    from scipy.spatial import cKDTree

    from clomp.runtime.estimation._icp_core import cell_keys, grid_index, nearest

    pts = np.array(ref, dtype=float)
    queries = [(pts[i % len(pts), 0] + dx, pts[i % len(pts), 1] + dy) for i, dx, dy in near]  # near a point, or not
    starts, grid = grid_index(pts, cell)
    ordered = pts[np.argsort(cell_keys(pts, grid), kind="stable")]
    d_tree, _ = cKDTree(pts).query(np.array(queries), distance_upper_bound=bound)
    for (qx, qy), want in zip(queries, d_tree):
        k, d2 = nearest(qx, qy, bound * bound, ordered, starts, *grid)
        if k < 0:
            assert not want < bound * (1 - 1e-12)
        else:
            assert math.isclose(math.hypot(qx - ordered[k, 0], qy - ordered[k, 1]), want, rel_tol=1e-9, abs_tol=1e-12)
            assert math.isclose(d2, want * want, rel_tol=1e-9, abs_tol=1e-15)


def test_integer_arguments_match_as_their_floats():
    """The compiled loop has one signature: a prior or thresholds given as integers are taken
    as the same numbers in floating point (numba cannot add a float step to an int pose)."""
    ref = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 51)] + [[x, 0.5] for x in np.linspace(0.0, 1.0, 51)])
    cur = ref - [0.05, 0.0]
    ints = match_scans(ref, cur, Pose(0, 0, 0), max_distance=1, final_distance=1, max_iterations=30)
    floats = match_scans(ref, cur, Pose(0.0, 0.0, 0.0), max_distance=1.0, final_distance=1.0, max_iterations=30)
    assert ints.ok and ints == floats


def test_the_matcher_compiles_without_a_writable_cache(monkeypatch):
    """Where numba finds nowhere to write its cache it raises at decoration; the matcher then
    compiles in each process instead of making the estimation package fail to import."""
    import importlib

    import numba.core.caching

    from clomp.runtime.estimation import _icp_core

    def nowhere(self: Any, py_func: Any) -> None:
        raise RuntimeError(f"cannot cache function {py_func!r}: no locator available for file '/ro'")

    monkeypatch.setattr(numba.core.caching.FunctionCache, "__init__", nowhere)
    try:
        fresh = importlib.reload(_icp_core)
        pts = np.array([[0.0, 0.0], [0.3, 0.0]])
        starts, grid = fresh.grid_index(pts, 0.1)
        assert fresh.nearest(0.28, 0.01, 0.01, pts, starts, *grid)[0] == 1
        assert fresh.icp_iterations._cache.__class__.__name__ == "NullCache"
    finally:
        monkeypatch.undo()
        importlib.reload(_icp_core)


def test_the_matcher_is_compiled_before_the_robot_moves():
    """A fresh process: making the odometry compiles (or loads) the matcher with the types a
    match uses, so the first match in a driving control loop does not stall it."""
    import subprocess
    import sys

    code = ("from clomp.runtime.estimation import _icp_core as c\n"
            "from clomp.runtime.estimation.odometry import ScanOdometry\n"
            "assert not c.icp_iterations.signatures\n"
            "ScanOdometry(0.2)\n"
            "n = len(c.icp_iterations.signatures)\n"
            "import numpy as np\n"
            "from clomp.formal.model import Pose\n"
            "from clomp.runtime.estimation import match_scans\n"
            "ref = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 51)] + [[x, 0.5] for x in np.linspace(0.0, 1.0, 51)])\n"
            "assert match_scans(ref, ref, Pose(0, 0, 0)).ok\n"
            "print(n, len(c.icp_iterations.signatures))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0, out.stderr
    assert out.stdout.split() == ["1", "1"]  # compiled once, and a real match needed no other signature


def test_ctrl_c_during_matching_is_a_keyboard_interrupt():
    """Interrupted in the middle of matches, a process sees KeyboardInterrupt — never a
    SystemError from the compiled matcher (as it did when the loop released the GIL: 157
    of 200 interrupts). Whenever each interrupt lands, the exception must be the same.

    The probe installs Python's own SIGINT handler first: started from a background job
    of a shell without job control (``cmd &``, as a CI script may be), a process inherits
    SIGINT *ignored*, Python then installs no handler, and every interrupt is dropped. The
    probe hung 300 s that way in a CI run started with ``nohup … &``. Every wait is also
    bounded, so a lost interrupt fails with a count instead of a hang. The SIGINTs come
    from an interval timer (SIGALRM, whose handler sends the SIGINT) rather than
    ``threading.Timer`` threads, so the interrupted loop never runs inside threading's
    locks."""
    import subprocess
    import sys

    code = """
import os, signal, time
import numpy as np
from clomp.formal.model import Pose
from clomp.runtime.estimation import ReferenceScan, match_scans
ref = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 151)] + [[x, 0.5] for x in np.linspace(0.0, 1.0, 151)])
cur, r = ref - [0.05, 0.0], ReferenceScan(ref)
match_scans(r, cur, Pose(0.0, 0.0, 0.0))
signal.signal(signal.SIGINT, signal.default_int_handler)  # also when the parent left SIGINT ignored
signal.signal(signal.SIGALRM, lambda signum, frame: os.kill(os.getpid(), signal.SIGINT))
seen, lost = [], 0
for i in range(40):
    try:
        signal.setitimer(signal.ITIMER_REAL, 0.001 + 0.0005 * i)
        deadline = time.monotonic() + 10.0
        while time.monotonic() < deadline:
            match_scans(r, cur, Pose(0.0, 0.0, 0.0))
        lost += 1  # no interrupt came
    except BaseException as e:
        seen.append(type(e).__name__)
print(sorted(set(seen)), lost)
"""
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "['KeyboardInterrupt'] 0"


def _interrupted_in_numba(*_args):
    """What a compiled call returns when a Python-level SIGINT handler ran inside one of
    numba's helpers: a SystemError whose chain holds the KeyboardInterrupt."""
    try:
        raise KeyboardInterrupt("interrupted by SIGINT")
    except KeyboardInterrupt as ki:
        inner = SystemError("<function _numba_unpickle> returned a result with an exception set")
        inner.__cause__ = ki
        raise SystemError("CPUDispatcher(icp_iterations) returned a result with an exception set") from inner


def test_interruptible_raises_the_interrupt_a_compiled_call_masked():
    from clomp.runtime.jit import interruptible

    with pytest.raises(KeyboardInterrupt, match="SIGINT"):
        interruptible(_interrupted_in_numba)

    def other():
        raise SystemError("something else")

    with pytest.raises(SystemError, match="something else"):
        interruptible(other)


def test_ctrl_c_masked_inside_the_matcher_or_the_plan_check_is_a_keyboard_interrupt(monkeypatch):
    """Both hot compiled calls go through :func:`clomp.runtime.jit.interruptible`: a run must never
    record a Ctrl-C as a failure (HALTED) and go on (1 in 30 interrupted experiments did)."""
    import clomp.runtime.estimation.icp as icp
    import clomp.runtime.supervision.checkgeometry as geometry
    from clomp.planner.robot_model import RobotModel

    ref = np.array([[1.0, y] for y in np.linspace(-0.5, 0.5, 51)])
    monkeypatch.setattr(icp, "icp_iterations", _interrupted_in_numba)
    with pytest.raises(KeyboardInterrupt):
        icp.match_scans(ref, ref, Pose(0.0, 0.0, 0.0))
    monkeypatch.setattr(geometry, "straight_gaps", _interrupted_in_numba)
    monkeypatch.setattr(geometry, "turn_first_ticks", _interrupted_in_numba)
    z = np.array([0.5 + 0.0j])
    for kind, contacts in ((geometry._STRAIGHT, geometry._straight_contacts), (geometry._LEFT, geometry._turn_contacts)):
        leg = geometry._Leg(0, kind, (0.0, 0.0, 0.0), 0.3, Pose(0.3, 0.0, 0.0), Pose(0.3, 0.0, 0.0))
        with pytest.raises(KeyboardInterrupt):
            contacts(z, [leg], RobotModel(), 0.0)


def test_a_surface_joins_the_map_once_whatever_the_map_held_before() -> None:
    """The new-surface test asks the map as it is now: a surface that joined it is known the
    next time, even seen 1.5 cm off (within ``new_surface``, on other grid cells)."""
    odo = ScanOdometry(0.15)
    wall = np.c_[np.full(40, 0.6), np.linspace(-0.3, 0.3, 40)]
    box = np.c_[np.linspace(0.3, 0.5, 20), np.full(20, 0.4)]
    at = Pose(0.0, 0.0, 0.0)
    assert odo._add(wall, at, reseed=True)            # the seed
    assert not odo._add(wall, at, reseed=False)       # known: nothing new (the map's tree is built here)
    assert odo._add(box, at, reseed=False)            # a new surface joins
    assert not odo._add(box + [0.0, 0.015], at, reseed=False)  # and is known from then on


def _room_points(n: int = 201) -> np.ndarray:
    """A closed room's four walls as dense points (x from -0.6 to 1.5 m, y ±0.6 m)."""
    s = np.linspace(0.0, 1.0, n)
    return np.r_[np.c_[1.5 + 0 * s, -0.6 + 1.2 * s], np.c_[-0.6 + 2.1 * s, 0.6 + 0 * s],
                 np.c_[-0.6 + 2.1 * s, -0.6 + 0 * s], np.c_[-0.6 + 0 * s, -0.6 + 1.2 * s]]


def test_a_robot_displaced_sideways_is_corrected_sideways() -> None:
    """The estimator's lateral correction, alone and fast: dead reckoning drove 0.5 m straight
    and believes y = 0, the walls of a closed room say the robot stands 3 cm to the left. The
    match must see y (walls on both sides observe it) and the estimate must follow it (it
    moved 2.8 of the 3 cm when written). Dropping the sideways part anywhere on the way
    (the matcher's step, the innovation, the filter's gain) leaves y near 0."""
    room = _room_points()
    m = match_scans(room, points_to_frame(room, Pose(0.0, 0.03, 0.0)), Pose(0.0, 0.0, 0.0))
    assert m.ok and "y" not in m.unobservable, m.reason
    assert m.pose.y == pytest.approx(0.03, abs=0.002)

    odo = ScanOdometry(wheel_base=0.15)
    odo.reset(Pose(0.0, 0.0, 0.0), 0.0)
    assert odo.update(ScanFrame(room, 0.0, point_times=np.zeros(len(room)))).ok  # the map's seed
    for k in range(1, 51):
        odo.advance(k / 10, (0.1, 0.1))  # 5 s at 0.1 m/s, straight
    believed = odo.pose
    assert believed.y == 0.0 and believed.x == pytest.approx(0.5)
    seen = points_to_frame(room, Pose(believed.x, 0.03, 0.0))  # where it truly is: 3 cm to the left
    rec = odo.update(ScanFrame(seen, 5.0, point_times=np.zeros(len(seen))))
    assert rec.ok, rec.reason
    assert rec.correction[1] > 0.02 and odo.pose.y == pytest.approx(0.03, abs=0.005), (rec.correction, odo.pose)
    assert abs(odo.pose.x - believed.x) < 0.005  # and nothing else moved much


def test_with_odometry_the_gyro_offset_is_learnt_standing_still() -> None:
    """A base with wheel odometry and a gyro that reads 0.05 rad/s standing (clomp ros node
    with /odom and /imu): standing, the offset is learnt, so 5 s of driving straight
    afterwards do not turn the estimate (without, it turned by 0.25 rad)."""
    est = ScanOdometry(0.15)
    est.reset(Pose(0.0, 0.0, 0.0), 0.0)
    t, bias = 0.0, 0.05
    for _ in range(50):  # 5 s standing, wheels commanded still
        t += 0.1
        est.advance(t, (0.0, 0.0), Pose(0.0, 0.0, 0.0), bias * t)
    heading = est.pose.theta
    x = 0.0
    for _ in range(50):  # 5 s straight at 0.1 m/s: the odometry moves, the gyro reads only its offset
        t += 0.1
        x += 0.01
        est.advance(t, (0.1, 0.1), Pose(x, 0.0, 0.0), bias * t)
    assert abs(est.pose.theta - heading) < 0.01
    assert est.pose.x == pytest.approx(0.5, abs=0.01)
