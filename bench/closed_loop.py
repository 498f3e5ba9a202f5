"""Closed-loop figures: plan check vs fresh plan, recall vs exploration, world speed, scan matching.

    python bench/closed_loop.py [--quick] [--false-alarms] [--experiments]

Prints, each beside its target (thread CPU time beside wall time):

1. per-revolution plan check (the remaining tasks tested on the raw scan) vs a fresh
   plan from the same scan (target: check <= 20 % of a fresh plan, median); 1b. the
   supervisor's own checks, recalls and fresh plans in closed-loop runs; 1c. where its
   successful recalls spend their time (the plan check of the recalled plan, the index
   lookup, the guard);
2. recall of a plan from the existing map vs exploring anew from the same pose and scan
   (target: recall >= 5x faster, median);
3. simulated seconds per wall second of the execution world alone (target >= 20x);
4. scan matching on simulated scan pairs with known motion in scenes like the recorded
   corridor scans (target: median translation error <= 1 cm, heading <= 1 deg), and the
   share of degenerate scenes detected (one wall, a corridor, no returns);
5. with ``--experiments``: ``clomp experiment``'s planning condition with scan feedback
   and with ``--feedback none`` side by side (overtaking paper/harsh x20, corridor, doorway,
   slalom harsh x10);
6. with ``--false-alarms``: how many of the plan checks and hazard interrupts the
   supervisor acted on in 20 harsh overtaking runs were false alarms (judged again on a
   noise-free revolution from the true pose), and how many shallow alarms it did not act on.
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.formal.geometry import compose, relative  # noqa: E402
from clomp.formal.model import Pose  # noqa: E402
from clomp.planner import Configurator, load_scenario  # noqa: E402
from clomp.planner.scenarios import parse_scenario  # noqa: E402
from clomp.runtime.estimation import match_scans  # noqa: E402
from clomp.runtime.experiment.layouts import make_layout  # noqa: E402
from clomp.runtime.backends import make_world_robot  # noqa: E402
from clomp.runtime.supervision.records import scan_to_frame  # noqa: E402
from clomp.runtime.supervision import plancheck as pc  # noqa: E402
from clomp.runtime.supervision.plancheck import RecallIndex, check_plan, perceive_near, perceive_scan, recall, resimulate_plan  # noqa: E402


def _timed(fn: Any, *args: Any, repeat: int = 5) -> tuple[float, float, Any]:
    """Median wall and thread-CPU seconds of ``fn(*args)`` over ``repeat`` calls, and its result."""
    walls, cpus, out = [], [], None
    for _ in range(repeat):
        t, c = time.perf_counter(), time.thread_time()
        out = fn(*args)
        walls.append(time.perf_counter() - t)
        cpus.append(time.thread_time() - c)
    return statistics.median(walls), statistics.median(cpus), out


def _scenes(quick: bool) -> list[Any]:
    n = 3 if quick else 8
    out = [load_scenario(s) for s in ("overtaking", "corridor", "doorway", "slalom")]
    for fam in ("overtaking", "corridor", "doorway", "slalom"):
        out += [make_layout(fam, 0, k).scene for k in range(n)]
    return out


def _seen_from(scene: Any, pose_world: Pose) -> np.ndarray:
    world = make_world_robot(scene, "paper", seed=0, start=pose_world)
    frame = world.read_scan()
    assert frame is not None
    return frame.points


def bench_check_and_recall(quick: bool) -> None:
    """Section 1 and 2, on the scans of the fixed scenarios and of layouts of each family.

    The supervisor checks and recalls on the raw scan (no perception: the check is the
    planner's closed-form geometry on the points) and a fresh plan perceives the scan and
    explores: each is timed for everything it needs. Perception alone, exploration alone
    and the former check (perceive the points near the plan, re-simulate each task with
    ``clomp.planner.rollout.simulate``) are printed beside them.
    """
    conf = Configurator()
    robot = conf.robot
    o = Pose(0.0, 0.0, 0.0)
    rows: dict[str, list[tuple[float, float]]] = {k: [] for k in ("check", "fresh", "perceive", "build", "old")}
    ratios_c: list[float] = []
    ratios_b: list[float] = []
    rec_rows: dict[str, list[tuple[float, float]]] = {k: [] for k in ("recall", "recall_kept", "fresh", "build", "index")}
    ratios_r: list[float] = []
    ratios_rb: list[float] = []
    ratios_ri: list[float] = []
    agree = disagree = 0
    recalled = tried = 0
    for scene in _scenes(quick):
        scan = _seen_from(scene, scene.start)
        goal = Pose(*scene.goal_in_robot_frame())
        wf, cf, result = _timed(conf.plan, scan, (goal.x, goal.y))
        if not result.steps:
            continue
        wc, cc, fast = _timed(check_plan, result.steps, o, o, goal, scan, robot)
        wp, cp, obstacles = _timed(perceive_scan, scan, robot)
        wb, cb, _ = _timed(conf.build, obstacles, (goal.x, goal.y))

        def old(steps: Any, scan: Any, goal: Pose) -> Any:
            return resimulate_plan(steps, o, o, goal, perceive_near(scan, steps, o, o, robot), robot)

        wo, co, slow = _timed(old, result.steps, scan, goal)
        agree += fast.ok == slow.ok
        disagree += fast.ok != slow.ok
        for k, v in (("check", (wc, cc)), ("fresh", (wf, cf)), ("perceive", (wp, cp)), ("build", (wb, cb)), ("old", (wo, co))):
            rows[k].append(v)
        ratios_c.append(wc / wf)
        ratios_b.append(wc / wb)
        # recall from each state along the plan, on the scan seen from there
        index = RecallIndex(result.map, plan=result.plan, psi=result.psi)
        wi, ci, _ = _timed(lambda: RecallIndex(result.map, plan=result.plan, psi=result.psi))  # noqa: B023
        rec_rows["index"].append((wi, ci))
        for ident in result.plan.states[1:-1]:
            here = result.map[ident].end
            try:
                seen = _seen_from(scene, compose(scene.start, here))
            except ValueError:  # the map's state touches an obstacle of the world: no view from there
                continue
            g = relative(here, goal)
            wr, cr, (found, _why, _t) = _timed(recall, result, o, here, goal, seen, robot, repeat=3)
            wk, ck, _ = _timed(lambda: recall(result, o, here, goal, seen, robot, index=index), repeat=3)  # noqa: B023
            we, ce, _ = _timed(conf.plan, seen, (g.x, g.y), repeat=3)
            wb2, cb2, _ = _timed(conf.build, perceive_scan(seen, robot), (g.x, g.y), repeat=3)
            tried += 1
            if found is not None:
                recalled += 1
                rec_rows["recall"].append((wr, cr))
                rec_rows["recall_kept"].append((wk, ck))
                rec_rows["fresh"].append((we, ce))
                rec_rows["build"].append((wb2, cb2))
                ratios_r.append((we + wi) / wk)
                ratios_ri.append(we / wr)
                ratios_rb.append(wb2 / wk)
    med = statistics.median

    def line(name: str, vals: list[tuple[float, float]], extra: str = "") -> None:
        print(f"   {name:<44} median {med(w for w, _ in vals) * 1e3:7.3f} ms wall, {med(c for _, c in vals) * 1e3:7.3f} ms CPU{extra}")

    print("1. plan check per revolution vs a fresh plan (same scan)")
    line("check (raw points, all remaining tasks)", rows["check"], f"   ({len(rows['check'])} plans)")
    line("fresh plan (perception + exploration)", rows["fresh"])
    line("  of which perception alone", rows["perceive"])
    line("  of which exploration alone", rows["build"])
    line("former check (perceive near + re-simulate)", rows["old"])
    print(f"   the check and the re-simulation agree on {agree} of {agree + disagree} plans")
    r = med(ratios_c)
    print(f"   check / fresh plan median {r:.1%}   target <= 20 %: {'reached' if r <= 0.2 else 'NOT reached'}"
          f"   (check / exploration alone {med(ratios_b):.1%})")
    print("2. recall from the map vs exploring anew (same pose, same scan)")
    if ratios_r:
        line("recall, the map's index kept (the supervisor)", rec_rows["recall_kept"], f"   ({recalled} of {tried} states recalled)")
        line("recall, the index built in the call", rec_rows["recall"])
        line("fresh plan (perception + exploration)", rec_rows["fresh"])
        line("  exploration alone (perceived scan given)", rec_rows["build"])
        line("the map's recall index (built with a fresh plan)", rec_rows["index"])
        x = med(ratios_r)
        print(f"   fresh plan / recall median {x:.1f}x   target >= 5x: {'reached' if x >= 5 else 'NOT reached'}"
              f"   (index built in the recall: {med(ratios_ri):.1f}x; exploration alone / recall {med(ratios_rb):.1f}x)")
    else:
        print(f"   no state recalled ({tried} tried)")


def bench_in_loop(quick: bool) -> None:
    """The same comparison as the supervisor meets it: every per-revolution check (on the
    remaining tasks, perceiving the points near them) and every recall (perceiving the
    fused scan) of closed-loop runs, against the fresh plans of the same runs."""
    from clomp.runtime.experiment.runner import noise_seed, run_once

    checks: list[Any] = []
    fresh: list[Any] = []
    recalls: list[Any] = []
    runs = 2 if quick else 10
    t, c = time.perf_counter(), time.thread_time()
    for fam in ("overtaking", "corridor", "doorway", "slalom"):
        for k in range(runs):
            lay = make_layout(fam, 0, k)
            rep = run_once(lay.scene, "planning", noise_seed(0, k), run=k, noise="paper", keep_report=True).report
            checks += rep.checks
            fresh += rep.fresh_plans
            recalls += [r for r in rep.recalls if r.ok]
    wall, cpu = time.perf_counter() - t, time.thread_time() - c
    med = statistics.median
    print(f"1b. in the closed loop ({4 * runs} runs, paper noise; {wall:.1f} s wall, {cpu:.1f} s thread CPU): durations as the"
          f" supervisor records them (a check and a recall on the raw points, a fresh plan with its perception)")
    for name, recs in (("check", checks), ("recall", recalls), ("fresh plan", fresh)):
        if recs:
            print(f"   {name:<11} median {med(r.duration_s for r in recs) * 1e3:7.3f} ms wall, "
                  f"{med(r.cpu_s for r in recs) * 1e3:7.3f} ms thread CPU   ({len(recs)})")
    for what, key in (("wall", "duration_s"), ("thread CPU", "cpu_s")):
        f = med(getattr(r, key) for r in fresh)
        r = med(getattr(x, key) for x in checks) / f
        line = f"   {what:<10}: check / fresh {r:.1%} (target <= 20 %: {'reached' if r <= 0.2 else 'NOT reached'})"
        if recalls:
            x = f / med(getattr(x, key) for x in recalls)
            line += f";  fresh / recall {x:.1f}x (target >= 5x: {'reached' if x >= 5 else 'NOT reached'})"
        print(line)
    with _RecallPhases() as phases:  # the same runs again (simulated time: the same recalls), timed by part
        for fam in ("overtaking", "corridor", "doorway", "slalom"):
            for k in range(runs):
                run_once(make_layout(fam, 0, k).scene, "planning", noise_seed(0, k), run=k, noise="paper")
    phases.report()


class _RecallPhases:
    """Section 1c: where the supervisor's successful in-loop recalls spend their thread CPU
    time, by the functions of :mod:`clomp.runtime.supervision.plancheck` they call (wrapped for
    a second pass over the runs of 1b, so that 1b's own figures carry no wrapper; the
    wrappers' cost is in each recall's total, not in its parts)."""

    PARTS = ("RecallIndex.near", "_legs", "_points", "_straight_contacts", "_turn_contacts", "_check", "RecallIndex.guard")

    def __init__(self) -> None:
        self.rows: list[dict[str, float]] = []
        self._acc: dict[str, float] = {}
        self._saved: list[tuple[Any, str, Any]] = []

    def _wrap(self, owner: Any, name: str) -> None:
        f = getattr(owner, name)
        acc = self._acc

        def timed(*a: Any, **k: Any) -> Any:
            c = time.thread_time()
            try:
                return f(*a, **k)
            finally:
                key = f"RecallIndex.{name}" if owner is not pc else name
                acc[key] = acc.get(key, 0.0) + time.thread_time() - c

        self._saved.append((owner, name, f))
        setattr(owner, name, timed)

    def __enter__(self) -> "_RecallPhases":
        import clomp.runtime.supervision.planwatch as pw

        for name in self.PARTS:
            owner, attr = (pc.RecallIndex, name.split(".")[1]) if name.startswith("RecallIndex.") else (pc, name)
            self._wrap(owner, attr)
        inner = pc.recall

        def recall_timed(*a: Any, **k: Any) -> Any:
            self._acc.clear()
            c = time.thread_time()
            out = inner(*a, **k)
            if out[0] is not None:
                self.rows.append(dict(self._acc, total=time.thread_time() - c))
            return out

        self._saved.append((pw, "recall", pw.recall))  # type: ignore[attr-defined]
        pw.recall = recall_timed  # type: ignore[attr-defined]
        return self

    def __exit__(self, *exc: Any) -> None:
        for owner, name, f in reversed(self._saved):
            setattr(owner, name, f)

    def report(self) -> None:
        if not self.rows:
            return
        med = statistics.median
        total = med(r["total"] for r in self.rows)
        print(f"1c. where a successful in-loop recall spends its thread CPU ({len(self.rows)} recalls; medians,"
              f" total {total * 1e3:.3f} ms with the timing wrappers)")
        for name in self.PARTS:
            v = med(r.get(name, 0.0) for r in self.rows)
            print(f"   {name:<22} {v * 1e3:7.3f} ms  ({v / total:.0%})")
        print("   (no perception: the check tests the fused scan's raw points; _legs, _straight_contacts and"
              " _turn_contacts are inside _check, the check of one candidate's continuation)")


def bench_world(seconds: float) -> None:
    world = make_world_robot(load_scenario("corridor"), "paper", seed=0)
    t, c = time.perf_counter(), time.thread_time()
    for k in range(int(seconds / 0.1)):
        world.set_wheel_speeds(0.08, 0.1 if k % 40 < 20 else 0.06)
        world.read_scan(timeout=0.0)
        world.sleep(0.1)
    wall, cpu = time.perf_counter() - t, time.thread_time() - c
    print("3. the execution world alone (driving, 360-ray LiDAR at 5.5 Hz, contacts)")
    x = world.now() / wall
    xc = world.now() / cpu
    print(f"   {world.now():.0f} s simulated in {wall:.2f} s wall, {cpu:.2f} s CPU: {x:.0f}x real time on the wall clock"
          f" (this machine's load included), {xc:.0f}x per CPU second   target >= 20x: "
          f"{'reached' if x >= 20 else 'NOT reached on the wall clock'}")


RECORDED_LIKE = [
    # corridor with a doorway gap and a post, as in the recorded scans (map0001, map0161)
    {"goal": [0.7, 0.0], "obstacles": [
        {"type": "wall", "from": [-1.0, 0.45], "to": [0.2, 0.45]}, {"type": "wall", "from": [0.6, 0.45], "to": [1.5, 0.45]},
        {"type": "wall", "from": [-1.0, -0.45], "to": [1.5, -0.45]}, {"type": "wall", "from": [0.9, -0.45], "to": [0.9, 0.45]},
        {"type": "box", "center": [0.5, -0.25], "size": [0.08, 0.08]}]},
    # a corridor bend (map0121)
    {"goal": [0.3, 0.0], "obstacles": [
        {"type": "wall", "from": [-0.5, -1.0], "to": [-0.5, 0.8]}, {"type": "wall", "from": [0.5, -0.3], "to": [0.5, 0.7]},
        {"type": "wall", "from": [0.4, -1.0], "to": [0.4, -0.6]}, {"type": "box", "center": [0.15, -0.2], "size": [0.06, 0.06]}]},
    # a narrow corridor with a gap each side and a marker ahead (map0041)
    {"goal": [0.5, 0.0], "obstacles": [
        {"type": "wall", "from": [-0.8, 0.5], "to": [0.3, 0.5]}, {"type": "wall", "from": [0.55, 0.5], "to": [1.2, 0.5]},
        {"type": "wall", "from": [-0.8, -0.45], "to": [0.0, -0.45]}, {"type": "wall", "from": [0.3, -0.45], "to": [1.2, -0.45]},
        {"type": "box", "center": [0.75, 0.05], "size": [0.05, 0.12]}]},
]
DEGENERATE = [
    ("one straight wall", {"goal": [0.5, 0.0], "obstacles": [{"type": "wall", "from": [-2.0, 0.4], "to": [2.0, 0.4]}]}),
    ("a long corridor", {"goal": [0.5, 0.0], "obstacles": [{"type": "wall", "from": [-3.0, 0.35], "to": [3.0, 0.35]},
                                                            {"type": "wall", "from": [-3.0, -0.35], "to": [3.0, -0.35]}]}),
    ("no returns", {"goal": [0.5, 0.0], "obstacles": []}),
]


def bench_matching(pairs: int) -> None:
    rng = np.random.default_rng(0)
    et, ea, wall, cpu, fails = [], [], [], [], 0
    for k in range(pairs):
        scene = parse_scenario(RECORDED_LIKE[k % len(RECORDED_LIKE)], "recorded-like")
        a = Pose(float(rng.uniform(-0.1, 0.1)), float(rng.uniform(-0.05, 0.05)), float(rng.uniform(-0.3, 0.3)))
        m = Pose(float(rng.uniform(0.0, 0.06)), float(rng.uniform(-0.02, 0.02)), float(rng.uniform(-0.15, 0.15)))
        try:
            ref = make_world_robot(scene, "paper", seed=k, start=a).read_scan()
            cur = make_world_robot(scene, "paper", seed=k + 1000, start=compose(a, m)).read_scan()
        except ValueError:
            continue
        assert ref is not None and cur is not None
        prior = Pose(m.x + float(rng.normal(0, 0.02)), m.y + float(rng.normal(0, 0.02)), m.theta + float(rng.normal(0, 0.05)))
        t, c = time.perf_counter(), time.thread_time()
        r = match_scans(ref.points, cur.points, prior)
        wall.append(time.perf_counter() - t)
        cpu.append(time.thread_time() - c)
        if not r.ok:
            fails += 1
            continue
        et.append(math.hypot(r.pose.x - m.x, r.pose.y - m.y))
        ea.append(abs(math.degrees(r.pose.theta - m.theta)))
    med = statistics.median
    print("4. scan matching on simulated pairs with known motion (paper noise, recorded-like scenes)")
    print(f"   {len(et)} pairs matched, {fails} rejected; {med(wall) * 1e3:.1f} ms wall, {med(cpu) * 1e3:.1f} ms CPU per match")
    print(f"   translation error median {med(et) * 100:.2f} cm (p90 {np.percentile(et, 90) * 100:.2f})"
          f"   target <= 1 cm: {'reached' if med(et) <= 0.01 else 'NOT reached'}")
    print(f"   heading error median {med(ea):.2f} deg (p90 {np.percentile(ea, 90):.2f})"
          f"   target <= 1 deg: {'reached' if med(ea) <= 1.0 else 'NOT reached'}")
    for name, doc in DEGENERATE:
        scene = parse_scenario(doc, name)
        hit = 0
        for k in range(10):
            ref = make_world_robot(scene, "paper", seed=k).read_scan()
            cur = make_world_robot(scene, "paper", seed=k + 50, start=Pose(0.03, 0.0, 0.02)).read_scan()
            assert ref is not None and cur is not None
            r = match_scans(ref.points, cur.points, Pose(0.05, 0.0, 0.0))
            hit += bool(r.unobservable)
            example = r
        print(f"   degenerate '{name}': detected in {hit}/10; e.g. unobservable {list(example.unobservable)}, "
              f"{'falls back: ' + example.reason if not example.ok else 'kept from dead reckoning'}")


def bench_experiments(quick: bool) -> None:
    from clomp.runtime.experiment.runner import run_experiment

    cases = [("overtaking", "paper", 20), ("overtaking", "harsh", 20), ("corridor", "harsh", 10),
             ("doorway", "harsh", 10), ("slalom", "harsh", 10)]
    if quick:
        cases = [(f, n, 4) for f, n, _ in cases]
    print("5. clomp experiment, planning condition: scan feedback vs dead reckoning (--feedback none)")
    print(f"   {'family':<11}{'noise':<7}{'feedback':<9}{'goal':>7}{'collisions':>11}{'brushes':>8}{'median err':>11}"
          f"{'checks':>8}{'recalls':>8}{'fresh':>6}")
    for fam, noise, runs in cases:
        for fb in ("scan", "none"):
            recs = run_experiment(fam, runs, 0, noise=noise, conditions=("planning",), feedback=fb)
            ok = sum(r["reached_goal"] for r in recs)
            col = sum(r["collisions"] for r in recs)
            br = sum(r["brushes"] for r in recs)
            err = statistics.median(r["final_error_m"] for r in recs)
            ch = sum(r["checks"] or 0 for r in recs)
            rc = sum(r["recalls"] or 0 for r in recs)
            fr = sum(r["fresh_plans"] or 0 for r in recs)
            print(f"   {fam:<11}{noise:<7}{fb:<9}{ok:>4}/{runs:<2}{col:>11}{br:>8}{err:>10.3f}m{ch:>8}{rc:>8}{fr:>6}",
                  flush=True)


def bench_false_alarms(runs: int, noise: str = "harsh", family: str = "overtaking", verbose: bool = False) -> None:
    """Section 6: how many failed plan checks and hazard interrupts were false alarms.

    Each failed check and each hazard interrupt of the supervisor is judged again at the
    same tick on a noise-free revolution taken from the true pose (``WorldRobot.scan_now``),
    seen from the same pose estimate: when that one passes, the alarm came from the
    sensor's noise (range noise, jitter, dropouts, the skew of a moving revolution), not
    from what is there. The pose estimate's error is kept in both.
    """
    from clomp.runtime.experiment.layouts import make_layout
    from clomp.runtime.experiment.runner import SUCCESS_RADIUS, noise_seed
    from clomp.runtime.experiment.groundtruth import make_robot
    from clomp.runtime.supervision import Supervisor
    from clomp.runtime.supervision.alarms import hazard_hits

    class Judged(Supervisor):
        """A supervisor that judges each of its alarms on the noise-free revolution."""

        def __init__(self, world: Any, *args: Any, **kw: Any) -> None:
            super().__init__(world, *args, **kw)
            self.world = world
            self.judged: list[tuple[str, bool]] = []  # (kind, false alarm)

        def _check_remaining(self) -> Any:
            rec = super()._check_remaining()
            if rec is not None and not rec.ok and self._plan is not None and self._record is not None:
                states = [self._record.state] + [q for q, _ in self._queue]
                ideal = scan_to_frame(self.world.scan_now(), self.pose, self.sensing.scan_pose)
                v = check_plan(states, self._plan.origin, self.sensing.scan_pose, self.goal, ideal, self.model,
                               tolerance=self.config.end_tolerance, running=True)
                self.judged.append(("check", v.ok))
            return rec

        def _hazard(self, task: Any, error: float) -> str | None:
            why = super()._hazard(task, error)
            if why is not None:
                soon, ahead = hazard_hits(self.world.scan_now(), task.kind, error, self.model, self.config.lookahead)
                kind = "imminent" if why.startswith("collision imminent") else "in the way"
                self.judged.append((kind, max(soon, ahead) < self.config.hazard_points))
            return why

    conf = Configurator()
    counts: dict[str, list[int]] = {}
    reached = deferred = 0
    t, c = time.perf_counter(), time.thread_time()
    for k in range(runs):
        lay = make_layout(family, 0, k)
        world = make_robot(lay.scene, noise=noise, seed=noise_seed(0, k), model=conf.robot)
        sup = Judged(world, tuple(lay.scene.goal_in_robot_frame()), conf)
        rep = sup.run(max_time=120.0)
        deferred += sup.alarms.deferred
        true = world.ground_truth_pose()
        err = math.hypot(true.x - lay.scene.goal[0], true.y - lay.scene.goal[1])
        reached += err <= SUCCESS_RADIUS
        if verbose:
            wrong = {kind: sum(f for k_, f in sup.judged if k_ == kind) for kind in {k_ for k_, _ in sup.judged}}
            print(f"   run {k:2d}: {rep.state.value:<12} {err:.3f} m from the goal, {len(rep.recalls)} recalls "
                  f"({sum(r.ok for r in rep.recalls)} ok), {len(rep.fresh_plans)} fresh plans, alarms acted on "
                  f"{len(sup.judged)} (false {wrong}); {rep.reason[:90]}", flush=True)
        for kind, false in sup.judged:
            row = counts.setdefault(kind, [0, 0])
            row[0] += 1
            row[1] += false
        world.close()
    print(f"6. false alarms in {runs} {noise} {family} runs ({reached}/{runs} reached; {time.perf_counter() - t:.0f} s wall,"
          f" {time.thread_time() - c:.0f} s thread CPU): each alarm judged again on a noise-free revolution from the true pose")
    for kind, (n, false) in sorted(counts.items()):
        print(f"   {kind:<11} {n:4d} alarms acted on, {false:4d} false ({false / n:.0%})")
    print(f"   shallow alarms seen once and not acted on: {deferred}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="fewer scenes, pairs and runs")
    ap.add_argument("--experiments", action="store_true", help="also run the experiment comparison (minutes)")
    ap.add_argument("--false-alarms", action="store_true", help="also judge the alarms of harsh overtaking runs (a minute)")
    ap.add_argument("--only-false-alarms", action="store_true", help="only section 6, one line per run")
    ap.add_argument("--only-in-loop", action="store_true", help="only sections 1b and 1c")
    args = ap.parse_args()
    if args.only_false_alarms:
        bench_false_alarms(5 if args.quick else 20, verbose=True)
        return
    if args.only_in_loop:
        bench_in_loop(args.quick)
        return
    bench_check_and_recall(args.quick)
    bench_in_loop(args.quick)
    bench_world(30.0 if args.quick else 120.0)
    bench_matching(30 if args.quick else 90)
    if args.false_alarms:
        bench_false_alarms(5 if args.quick else 20)
    if args.experiments:
        bench_experiments(args.quick)


if __name__ == "__main__":
    main()
