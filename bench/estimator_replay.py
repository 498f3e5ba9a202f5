"""The pose estimator judged offline: record what it was fed in closed-loop runs, replay variants.

    python bench/estimator_replay.py record [--families overtaking slalom] [--seeds 0 1]
                                            [--runs 20 10] [--noise harsh] [--dir DIR] [--workers 2]
    python bench/estimator_replay.py replay [--dir DIR] [--odometry JSON] [--filter JSON]
                                            [--match JSON] [--workers 2]

A closed-loop run's outcome (reached or not) depends on the estimate, the planner and the
supervisor together, and 20 runs give a count whose noise hides a small change to the
estimator. ``record`` runs the planning condition (scan feedback) and keeps, per run,
exactly what :class:`~clomp.runtime.estimation.odometry.ScanOdometry` was given — every
``reset``, ``advance`` (time, commanded wheel speeds, the gyro's heading when the world has
one), ``shock`` (the accelerometer's peak) and ``update`` (the revolution: its points,
timestamp and per-point times) — with the world's ground truth, in one ``.npz``
per run (numbers only, no pickles). ``replay`` feeds the same inputs to an estimator built
with other settings and prints, per family, the error of its final pose against the
ground truth (median, 75th percentile, the share within 5 cm) and of its heading: the
same trajectories for every variant, so a change's effect on the estimate is measured
without the closed loop's variance. (The trajectories are those the recording estimator
drove; a variant that would have driven elsewhere is judged on where this one went.)

Settings are JSON objects of keyword arguments: ``--odometry`` for ``ScanOdometry``,
``--filter`` for its ``OdometryFilter``, ``--match`` for every ``match_scans`` call, e.g.
``--odometry '{"noise_factor": 0}'`` (the weighting before the range noise was
measured) or ``--filter '{"hold_unobserved": false}' --match '{"min_information": 0.002}'``.
"""

from __future__ import annotations

import argparse
import glob
import json
import math
import os
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.formal.geometry import compose, relative  # noqa: E402
from clomp.formal.model import Pose  # noqa: E402
from clomp.runtime.devices.frame import ScanFrame  # noqa: E402
from clomp.runtime.estimation import odometry as odometry_module  # noqa: E402
from clomp.runtime.estimation.ekf import OdometryFilter  # noqa: E402
from clomp.runtime.estimation.odometry import ScanOdometry  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from estimate_ceiling import true_calibration  # noqa: E402

RESET, ADVANCE, UPDATE, SHOCK = 0, 1, 2, 3


class _Recorder(ScanOdometry):
    """A ScanOdometry that keeps what it is fed (the supervisor's own estimator, unchanged)."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.fed: list[tuple[Any, ...]] = []

    def reset(self, pose: Pose, t: float) -> None:
        if hasattr(self, "fed"):
            self.fed.append((RESET, float(t), pose.x, pose.y, pose.theta))
        super().reset(pose, t)

    def advance(self, t: float, wheels: tuple[float, float], odometry: Pose | None = None,
                rotation: float | None = None, covariance: Any = None) -> None:
        if odometry is not None or covariance is not None:
            raise SystemExit("estimator_replay: a backend with its own odometry is not recorded")
        turned = math.nan if rotation is None else float(rotation)
        self.fed.append((ADVANCE, float(t), float(wheels[0]), float(wheels[1]), turned))
        super().advance(t, wheels, odometry, rotation, covariance)

    def shock(self, peak: float) -> None:
        self.fed.append((SHOCK, float(peak)))
        super().shock(peak)

    def update(self, frame: ScanFrame, twist: tuple[float, float] | None = None) -> Any:
        if twist is not None:
            raise SystemExit("estimator_replay: an explicit twist is not recorded")
        self.fed.append((UPDATE, frame))
        return super().update(frame, twist)


def _record_one(args: tuple[str, int, int, str, str]) -> str:
    return record(*args)


def record(family: str, seed: int, run: int, noise: str, folder: str, max_time: float = 120.0) -> str:
    """Run (family, seed, run) at ``noise`` closed loop for at most ``max_time`` simulated
    seconds, keeping what its estimator was fed; the path of the ``.npz`` written in ``folder``."""
    import clomp.runtime.supervision.supervisor as sup_module
    from clomp.runtime.experiment.onerun import _ground_truth_path
    from clomp.runtime.experiment.runner import RunSpec, scene_for, noise_seed
    from clomp.runtime.experiment.groundtruth import make_robot
    from clomp.planner import Configurator

    scene, _ = scene_for(RunSpec(family, seed, run, "planning", noise))
    conf = Configurator()
    robot = make_robot(scene, noise=noise, seed=noise_seed(seed, run), model=conf.robot)
    sup = sup_module.Supervisor(robot, tuple(scene.goal_in_robot_frame()), conf, config=sup_module.SupervisorConfig(feedback="scan"))
    sup.estimator = _Recorder(conf.robot.wheel_base)  # the same estimator, keeping what it is fed
    # the world's drive as built (a harsh world's wheel bias then wanders during the run)
    calibration = true_calibration(robot, conf.robot.wheel_base)
    rep = sup.run(max_time=max_time)
    est = sup.estimator
    assert isinstance(est, _Recorder)
    truth = np.array(_ground_truth_path(robot, robot.ground_truth_pose()), dtype=float)
    kinds, scalars, offsets, points, times, stamped = [], [], [0], [], [], []
    for item in est.fed:
        kinds.append(item[0])
        if item[0] == UPDATE:
            frame = item[1]
            pts = np.asarray(frame.points, dtype=float).reshape(-1, 2)
            points.append(pts)
            offsets.append(offsets[-1] + len(pts))
            stamped.append(frame.point_times is not None)
            times.append(np.zeros(len(pts)) if frame.point_times is None else np.asarray(frame.point_times, dtype=float))
            scalars.append((frame.timestamp, math.nan, math.nan, math.nan))
        else:
            scalars.append(tuple(item[1:]) + (math.nan,) * (4 - len(item[1:])))
    name = os.path.join(folder, f"{family}-{seed}-{run}-{noise}.npz")
    np.savez_compressed(
        name, kinds=np.array(kinds, dtype=np.int8), scalars=np.array(scalars, dtype=float),
        offsets=np.array(offsets, dtype=np.int64), stamped=np.array(stamped, dtype=bool),
        points=np.concatenate(points) if points else np.zeros((0, 2)),
        point_times=np.concatenate(times) if times else np.zeros(0), truth=truth,
        goal=np.array(scene.goal, dtype=float), outcome=np.array(rep.state.value), reason=np.array(rep.reason),
        estimate=np.array(est.pose.as_list(), dtype=float),
        calibration=np.array(calibration, dtype=float))
    return name


def _variant(spec: dict[str, Any]) -> ScanOdometry:
    from clomp.planner.robot_model import RobotModel

    odo = ScanOdometry(RobotModel().wheel_base, **spec.get("odometry", {}))
    if spec.get("filter"):
        odo.filter = OdometryFilter(odo.wheel_base, **spec["filter"])
    return odo


Result = tuple[str, float, float, float, tuple[float, ...], tuple[float, ...] | None]
"""(file, final position error m, heading error deg, thread CPU s, the filter's learnt (s, k,
c, d), the world's (s, k, c, d) or None in a recording made before it was kept)."""


def _replay_one(args: tuple[str, dict[str, Any]]) -> Result:
    path, spec = args
    base = odometry_module.match_scans
    if spec.get("match"):  # every match the estimator makes, with these settings (restored below)
        odometry_module.match_scans = lambda *a, **k: base(*a, **{**k, **spec["match"]})  # type: ignore[assignment]
    try:
        return _replay(path, spec)
    finally:
        odometry_module.match_scans = base  # type: ignore[assignment]


def replay_estimator(path: str, spec: dict[str, Any]) -> tuple[ScanOdometry, float]:
    """The estimator ``spec`` builds, fed the recording at ``path``; the thread CPU seconds it took.
    With ``spec == {}`` it ends where the recording's own estimator ended (``estimate``)."""
    d = np.load(path, allow_pickle=False)
    odo = _variant(spec)
    frame_no = 0
    c0 = time.thread_time()
    for kind, sc in zip(d["kinds"], d["scalars"]):
        if kind == RESET:
            odo.reset(Pose(float(sc[1]), float(sc[2]), float(sc[3])), float(sc[0]))
        elif kind == ADVANCE:  # a recording made before the gyro was kept has nan there: no gyro
            odo.advance(float(sc[0]), (float(sc[1]), float(sc[2])), rotation=None if math.isnan(sc[3]) else float(sc[3]))
        elif kind == SHOCK:
            odo.shock(float(sc[0]))
        else:
            a, b = d["offsets"][frame_no], d["offsets"][frame_no + 1]
            pt = d["point_times"][a:b] if d["stamped"][frame_no] else None
            odo.update(ScanFrame(d["points"][a:b], float(sc[0]), point_times=pt))
            frame_no += 1
    return odo, time.thread_time() - c0


def _replay(path: str, spec: dict[str, Any]) -> Result:
    d = np.load(path, allow_pickle=False)
    odo, cpu = replay_estimator(path, spec)
    # the truth is in the world's frame, the estimate in the supervisor's (its reset pose is
    # where the robot stood at the start): a corridor layout starts turned up to 0.15 rad
    first, last = d["truth"][0], d["truth"][-1]
    reset = next((Pose(float(sc[1]), float(sc[2]), float(sc[3])) for kind, sc in zip(d["kinds"], d["scalars"])
                  if kind == RESET), Pose(0.0, 0.0, 0.0))
    t = compose(reset, relative(Pose(*map(float, first[1:4])), Pose(*map(float, last[1:4]))))
    p = odo.pose
    heading = abs(math.degrees(math.atan2(math.sin(p.theta - t.theta), math.cos(p.theta - t.theta))))
    truth = tuple(float(v) for v in d["calibration"]) if "calibration" in d.files else None
    return (os.path.basename(path), math.hypot(p.x - t.x, p.y - t.y), heading, cpu,
            tuple(float(v) for v in odo.filter.calibration), truth)


def family_of(name: str) -> str:
    """The family of a recording named ``{family}-{seed}-{run}-{noise}.npz`` (a family's own
    name may hold hyphens: ``u-trap``, ``cul-de-sac``).

    >>> family_of("cul-de-sac-0-3-harsh.npz")
    'cul-de-sac'
    """
    return name.rsplit("-", 3)[0]


def calibration_line(rows: list[Result], least: float = 0.05) -> str:
    """How well the filter learnt the drive within the runs: the curvature's sign (over runs
    whose true curvature is at least ``least`` rad/m) and the median errors of the curvature
    and the forward scale, beside the true terms' spread. A filter whose calibration learns
    from matches against a map drawn from its own estimate can learn the wrong sign.

    >>> world = (-0.05, -0.05, 0.3, 0.0)
    >>> right = ("f", 0.0, 0.0, 0.0, (0.0, 0.0, 0.1, 0.0), world)
    >>> wrong = ("f", 0.0, 0.0, 0.0, (0.0, 0.0, -0.2, 0.0), world)
    >>> calibration_line([right, wrong])
    'calibration learnt: curvature sign right in 1/2 runs, |c - true| median 0.35 rad/m (true |c| median 0.30), |s - true| median 0.050'
    """
    known = [(r[4], r[5]) for r in rows if r[5] is not None]
    if not known:
        return "calibration learnt: not recorded (record again to keep the world's drive terms)"
    big = [(a, b) for a, b in known if abs(b[2]) >= least]
    right = sum(1 for a, b in big if a[2] * b[2] > 0)
    c_err = statistics.median(abs(a[2] - b[2]) for a, b in known)
    c_true = statistics.median(abs(b[2]) for _, b in known)
    s_err = statistics.median(abs(a[0] - b[0]) for a, b in known)
    return (f"calibration learnt: curvature sign right in {right}/{len(big)} runs, |c - true| median {c_err:.2f} rad/m "
            f"(true |c| median {c_true:.2f}), |s - true| median {s_err:.3f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("mode", choices=["record", "replay"])
    ap.add_argument("--dir", default="clomp-estimator-streams")
    ap.add_argument("--families", nargs="+", default=["overtaking", "slalom"])
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1])
    ap.add_argument("--runs", nargs="+", type=int, default=[20, 10], help="runs per family and seed")
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--workers", type=int, default=2)
    for name in ("odometry", "filter", "match"):
        ap.add_argument(f"--{name}", default="{}", help=f"JSON keyword arguments ({name})")
    a = ap.parse_args()
    with ProcessPoolExecutor(max(1, a.workers)) as pool:
        if a.mode == "record":
            os.makedirs(a.dir, exist_ok=True)
            runs = a.runs if len(a.runs) == len(a.families) else [a.runs[0]] * len(a.families)
            from clomp.runtime.experiment.runner import RunSpec, scene_for

            for family in a.families:
                try:
                    scene_for(RunSpec(family, 0, 0, "planning", a.noise))
                except Exception as exc:  # an unknown family or scenario file: said here, not in a worker
                    ap.error(f"--families: {family}: {exc}")
            jobs = [(f, s, k, a.noise, a.dir) for f, n in zip(a.families, runs) for s in a.seeds for k in range(n)]
            t0 = time.perf_counter()
            done = list(pool.map(_record_one, jobs))
            print(f"recorded {len(done)} runs in {a.dir} ({time.perf_counter() - t0:.0f} s wall)")
            return
        try:
            spec = {n: json.loads(getattr(a, n)) for n in ("odometry", "filter", "match")}
            _variant(spec)  # a setting the estimator does not take is named here, not in a worker
            if spec["match"]:
                from clomp.runtime.estimation.icp import match_scans

                match_scans(np.zeros((0, 2)), np.zeros((0, 2)), Pose(0.0, 0.0, 0.0), **spec["match"])
        except json.JSONDecodeError as exc:
            ap.error(f"settings are JSON objects: {exc}")
        except (TypeError, ValueError) as exc:
            ap.error(f"a setting the estimator does not take: {exc}")
        files = sorted(glob.glob(os.path.join(a.dir, "*.npz")))
        if not files:
            ap.error(f"no recorded runs in {a.dir} (run: python bench/estimator_replay.py record --dir {a.dir})")
        out = list(pool.map(_replay_one, [(f, spec) for f in files]))
    print(f"settings {json.dumps(spec)}; {len(out)} recorded runs in {a.dir}")
    for family in sorted({family_of(r[0]) for r in out}):
        rows = [r for r in out if family_of(r[0]) == family]
        pos = [r[1] for r in rows]
        head = [r[2] for r in rows]
        within = sum(1 for e in pos if e <= 0.05)
        print(f"{family:11s} n={len(rows):3d}  final position error median {statistics.median(pos) * 100:5.1f} cm, "
              f"p75 {np.percentile(pos, 75) * 100:5.1f} cm, within 5 cm {within}/{len(rows)};  heading error median "
              f"{statistics.median(head):4.1f} deg;  {sum(r[3] for r in rows) / len(rows) * 1000:.0f} ms thread CPU a run")
        print(f"{'':11s} {calibration_line(rows)}")


if __name__ == "__main__":
    main()
