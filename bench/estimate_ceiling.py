"""How much of the closed loop's misses is the estimate's: the same runs on the true pose (or calibration).

    python bench/estimate_ceiling.py [--families overtaking slalom] [--runs 20 10]
                                     [--noise harsh] [--seed 0] [--workers 2]
                                     [--modes scan none truth calibration]
                                     [--term range_sd]   # paper, with this one term at harsh

Runs ``clomp experiment``'s planning condition in each mode on the same layouts and noise
seeds, and prints each family's reach beside the issue's target:

- ``scan``: the supervisor as shipped (scan-matched estimate, :mod:`clomp.runtime.estimation`);
- ``none``: dead reckoning alone (``--feedback none``);
- ``truth``: an ablation that no robot has — the supervisor's pose, and the pose its
  newest revolution is placed at, are the execution world's ground truth. What ``truth``
  still misses is the planner's and the supervisor's (a gap that noisy ranges close, a
  plan check that gives up), not the estimate's: it bounds what estimation work alone can
  gain;
- ``calibration``: another ablation — the scan-matched estimate as shipped, but its
  filter starts knowing the drive's systematic terms this run drew (each wheel's bias, the
  heading drift, the mean slip: :meth:`~clomp.runtime.backends.world.WorldRobot.drive_truth`, as
  the filter's speed and turn scales, curvature and drift; with the gyro, its scale and
  offset, :meth:`~clomp.runtime.backends.world.WorldRobot.gyro_truth`) to within 1e-4. What it gains
  over ``scan`` is what learning the wheels' calibration within the run could gain.

Each line gives the runs reached (ground truth within 0.1 m of the goal), the median
final error, how the misses ended (``believed``: the robot stopped believing it was at the
goal; ``unreachable``: it gave up; ``other``) and the runs' thread CPU time. ``--term
NAME`` runs every mode at ``paper`` noise with that one term raised to its ``harsh`` value
(``clomp.runtime.backends.world.WorldNoise``'s fields): which of harsh's terms costs what.
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from clomp.formal.geometry import relative  # noqa: E402
from clomp.formal.model import Pose  # noqa: E402
from clomp.runtime.estimation.odometry import ScanOdometry  # noqa: E402
from clomp.runtime.experiment.runner import RunSpec, noise_seed, run_once, scene_for  # noqa: E402
from clomp.runtime.supervision import Supervisor  # noqa: E402
from clomp.runtime.supervision.sensing import Sensing  # noqa: E402

TARGETS = {("overtaking", "harsh"): "18/20", ("slalom", "harsh"): "9/10", ("corridor", "harsh"): "9/10",
           ("doorway", "harsh"): "9/10", ("overtaking", "paper"): "20/20"}


class _TruthSensing(Sensing):
    """The supervisor's sensing with the pose estimate replaced by the world's ground truth,
    in the supervisor's frame (the robot's at the start: a corridor layout starts turned up
    to 0.15 rad in the world, and the world's pose taken as is would turn the goal with it)."""

    def __init__(self, robot: Any, *args: Any) -> None:
        super().__init__(robot, *args)
        self._origin: Pose = robot.ground_truth_pose()

    def true_pose(self) -> Pose:
        """The world's pose of the robot, seen from where it started."""
        return relative(self._origin, self.robot.ground_truth_pose())  # type: ignore[attr-defined]

    def update_pose(self, now: float, cmd: tuple[float, float]) -> None:
        super().update_pose(now, cmd)
        self.pose = self.true_pose()

    def _feedback(self, frame: Any, now: float) -> Any:
        rec = super()._feedback(frame, now)
        self.pose = self.true_pose()
        if frame.point_times is not None:  # the de-skewed revolution, placed at the true pose
            self.scan_pose = self.pose
        return rec


class _TruthFed(Supervisor):
    """The ablation: the pose estimate replaced by the world's ground truth (:class:`_TruthSensing`)."""

    def __init__(self, robot: Any, *args: Any, **kwargs: Any) -> None:
        super().__init__(robot, *args, **kwargs)
        self.sensing = _TruthSensing(robot, self.model, self.config)


class _KnownWheels(ScanOdometry):
    """Scan odometry whose filter starts with the drive's true calibration, held firmly
    (with a gyro: the wheels' forward scale and the gyro's scale and offset)."""

    def __init__(self, wheel_base: float, calibration: tuple[float, ...]) -> None:
        super().__init__(wheel_base)
        self.known = calibration

    def reset(self, pose: Pose, t: float) -> None:
        super().reset(pose, t)
        n = len(self.known)
        self.filter.x[3:3 + n] = self.known
        self.filter.P[3:3 + n, :] = 0.0
        self.filter.P[:, 3:3 + n] = 0.0
        self.filter.P[3:3 + n, 3:3 + n] = np.eye(n) * 1e-8


def true_calibration(robot: Any, wheel_base: float) -> tuple[float, float, float, float]:
    """The filter's (s, k, c, d) (:class:`~clomp.runtime.estimation.ekf.OdometryFilter`) for the
    world's drive: a straight's and a turn's speed is scaled by the wheels' mean bias less
    the mean slip, a straight curves by the bias difference over the wheel base, and the
    drift is the world's."""
    t = robot.drive_truth()
    scale = (t["bias_left"] + t["bias_right"]) / 2 * (1.0 - t["slip_mean"]) - 1.0
    return scale, scale, (t["bias_right"] - t["bias_left"]) / wheel_base, t["drift"]


def true_gyro_calibration(robot: Any, wheel_base: float) -> tuple[float, float, float, float, float]:
    """The filter's (s, k, c, d, b) for a robot whose heading comes from its gyro: the
    wheels' forward scale, the gyro's scale as ``k`` (it reads ``gain`` times the turn, so
    ``1 + k = 1 / gain``) and its offset as ``b`` (rad/s, what it reads standing: the filter
    takes it off the reading before the gain); ``c`` and ``d`` act on the wheels' turn, which
    the heading no longer uses."""
    s = true_calibration(robot, wheel_base)[0]
    g = robot.gyro_truth()
    return s, 1.0 / g["gain"] - 1.0, 0.0, 0.0, g["offset"]


class _CalibrationFed(Supervisor):
    """The ablation: the scan-matched estimate, its filter told the drive's true calibration."""

    def __init__(self, robot: Any, *args: Any, **kwargs: Any) -> None:
        super().__init__(robot, *args, **kwargs)
        if self.estimator is not None:
            known = (true_gyro_calibration if robot.rotation() is not None else true_calibration)(robot, self.model.wheel_base)
            self.estimator = _KnownWheels(self.model.wheel_base, known)


def _one(args: tuple[str, int, int, str, str, str | None]) -> tuple[bool, float, str, float]:
    family, seed, run, preset, mode, term = args
    import clomp.runtime.experiment.onerun as onerun  # where run_once looks the Supervisor up
    from clomp.runtime.backends.world import WorldNoise

    noise: str | WorldNoise = preset
    if term is not None:
        noise = WorldNoise(**{**WorldNoise.preset("paper").to_dict(), term: getattr(WorldNoise.preset("harsh"), term)})

    spec = RunSpec(family, seed, run, "planning", preset)
    scene, expect = scene_for(spec)
    saved = onerun.Supervisor
    if mode == "truth":
        onerun.Supervisor = _TruthFed  # type: ignore[misc]
    elif mode == "calibration":
        onerun.Supervisor = _CalibrationFed  # type: ignore[misc]
    try:
        c0 = time.thread_time()
        r = run_once(scene, "planning", noise_seed(seed, run), run=run, noise=noise, expect=expect,
                     feedback="none" if mode == "none" else "scan")
        cpu = time.thread_time() - c0
    finally:
        onerun.Supervisor = saved  # type: ignore[misc]
    how = "reached" if r.reached_goal else ("believed" if r.believed_goal else
                                           "unreachable" if r.end_state == "UNREACHABLE" else "other")
    return r.reached_goal, r.final_distance, how, cpu


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--families", nargs="+", default=["overtaking", "slalom"])
    ap.add_argument("--runs", nargs="+", type=int, default=[20, 10], help="runs per family (one value, or one per family)")
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--modes", nargs="+", default=["scan", "none", "truth"], choices=["scan", "none", "truth", "calibration"])
    ap.add_argument("--term", default=None, help="paper noise with this one term at its harsh value")
    a = ap.parse_args()
    from clomp.runtime.backends.world import WorldNoise

    if a.term is not None and a.term not in WorldNoise.preset("paper").to_dict():
        ap.error(f"--term: one of {', '.join(WorldNoise.preset('paper').to_dict())}")
    runs = a.runs if len(a.runs) == len(a.families) else [a.runs[0]] * len(a.families)
    if min(runs) < 1:
        ap.error("--runs: at least 1 run per family")
    for family in a.families:
        try:
            scene_for(RunSpec(family, a.seed, 0, "planning", a.noise))
        except Exception as exc:  # an unknown family or scenario file: said here, not in a worker
            ap.error(f"--families: {family}: {exc}")
    label = f"paper with {a.term} at harsh" if a.term else a.noise
    print(f"noise {label}, seed {a.seed}; reached = ground truth within 0.1 m of the goal")
    with ProcessPoolExecutor(a.workers) as pool:
        for family, n in zip(a.families, runs):
            for mode in a.modes:
                t0 = time.perf_counter()
                res = list(pool.map(_one, [(family, a.seed, k, a.noise, mode, a.term) for k in range(n)]))
                wall = time.perf_counter() - t0
                reached = sum(1 for r in res if r[0])
                med = statistics.median(r[1] for r in res)
                ends = {k: sum(1 for r in res if r[2] == k) for k in ("believed", "unreachable", "other")}
                target = "-" if a.term else TARGETS.get((family, a.noise), "-")
                print(f"{family:11s} {mode:11s} {reached:3d}/{n:<3d} (target {target:>5s})  median error {med:.3f} m  "
                      f"misses: {ends['believed']} believed at goal, {ends['unreachable']} unreachable, "
                      f"{ends['other']} other   [{wall:.0f} s wall, {sum(r[3] for r in res):.0f} s thread CPU]",
                      flush=True)


if __name__ == "__main__":
    main()
