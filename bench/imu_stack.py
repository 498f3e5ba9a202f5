"""The whole hardware stack with and without the IMU (``clomp run --imu``), in the harsh world.

Run: ``python bench/imu_stack.py [--runs 20] [--noise harsh] [--scenario overtaking]``.
Prints figures; asserts nothing.

Each run is the drivers, the hardware robot and the supervisor against the emulated world's
devices (tests/runtime/_stack.py: the emulator logic on simulated serial lines, time flowing
only while the supervisor sleeps, so a run is the software's own and not the machine's
load), seeds 0..runs-1, once with the LiDAR and the wheels only and once with the world's
IMU too (its errors drawn from the preset: runtime/backends/_imu.py). Per setting:

- ``reached``: runs that ended GOAL_REACHED (``clomp run``'s exit 0);
- ``false success``: of those, the ones truly farther than 0.1 m from the goal (the world
  knows the truth);
- ``unconfirmed``: runs that ended GOAL_UNCONFIRMED, when the supervisor has that outcome
  (else 0, and the line says so);
- ``true final error``: median true distance from the goal at the end (m);
- ``estimate error``: median distance between the supervisor's estimate and the true pose
  at the end (m, in the start frame);
- ``faults``: runs that ended on a device fault (an IMU fault would show here);
- wall time, the process's CPU time and the main thread's (the supervisor's) CPU time.

``--pty`` instead runs what a user runs, in real time: ``clomp emulate world``'s world (an
:class:`EmulatedWorldProcess`) and ``clomp run --lidar … --motors … [--imu …] --goal X,Y`` (the
scenario's goal, as ``bench/ros_loop.py`` gives it to ``clomp ros node``) as a subprocess, at
each ``--scales`` time scale (1 and 2), ``--imu`` on, off or both, for each of ``--scenarios``
(default ``--scenario``) and ``--seeds`` (default 0..runs-1); one JSON line a run (also
appended to ``--json``; the run logs kept in ``--logs``), and per setting the figures above
(reached = exit 0; the estimate's error from the run log's last fused pose; the world's
pushes counted) with wall-clock time and the load average, and at the end the per-family
table of docs/ros2.md. Its figures depend on how busy the machine is (say so beside them)::

    python bench/imu_stack.py --pty --scenarios overtaking,corridor,doorway --seeds 0,1,2,3,4,5,6,7,8,9 --scales 1
    python bench/imu_stack.py --pty --seeds 0,1,2,3,4,5,6,7,8,9 --scales 1,2 --imu both

``--told on`` tells ``clomp run`` the world's calibration (``--calibration``, the file ``clomp
emulate world --calibration-out`` writes), ``off`` runs it as ``clomp run`` without one (its
default ``--drive-delay``), ``both`` (simulated time) does each; by default the simulated-time
runs keep the supervisor's defaults (told nothing, delay 0), as before::

    python bench/imu_stack.py --runs 10 --noise paper --imu on --told both
"""

from __future__ import annotations

import argparse
import math
import statistics
import sys
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from clomp.formal.geometry import relative  # noqa: E402
from clomp.runtime.supervision import SupervisorState  # noqa: E402
from tests.runtime._stack import run_stack  # noqa: E402

UNCONFIRMED = getattr(SupervisorState, "GOAL_UNCONFIRMED", None)


def one(scenario: str, noise: str, seed: int, imu: bool, max_time: float, told: bool | None = None) -> dict[str, Any]:
    """One run's outcome and costs. ``told`` (True / False): as ``clomp run`` runs, told the
    world's calibration (``--calibration``) or not (its default ``--drive-delay``); None: the
    supervisor's defaults (told nothing, delay 0), as this bench ran before."""
    from clomp.planner.noise import NoiseTerms
    from clomp.runtime.backends.hardware import HardwareConfig
    from clomp.runtime.supervision import DRIVE_DELAY, SupervisorConfig

    wall, cpu, thread = time.perf_counter(), time.process_time(), time.thread_time()
    opts: dict[str, Any] = {}
    # as clomp run: the estimator reckons the commands itself, late by the drive delay
    as_run = HardwareConfig(watchdog_timeout=None, odometry=False)
    if told:
        opts = {"calibration": NoiseTerms.preset(noise), "supervisor": SupervisorConfig(), "hardware": as_run}
    elif told is not None:
        opts = {"supervisor": SupervisorConfig(drive_delay=DRIVE_DELAY), "hardware": as_run}
    run = run_stack(scenario, noise=noise, seed=seed, max_time=max_time, imu=imu, **opts)
    out: dict[str, Any] = {"wall": time.perf_counter() - wall, "cpu": time.process_time() - cpu,
                           "thread": time.thread_time() - thread}
    state = None if run.report is None else run.report.state
    sim = run.world.sim
    truth = relative(sim.start_pose, sim.pose) if hasattr(sim, "start_pose") else sim.pose
    est = run.supervisor.pose if run.supervisor is not None else truth
    out.update(state=state, true=run.world.goal_distance, est=math.hypot(est.x - truth.x, est.y - truth.y),
               fault=run.robot.fault if run.robot is not None else None, collisions=run.world.collisions,
               sim_s=run.elapsed)
    return out


def summary(label: str, rows: list[dict[str, Any]]) -> str:
    reached = [r for r in rows if r["state"] is SupervisorState.GOAL_REACHED]
    false = [r for r in reached if r["true"] > 0.1]
    unconf = "n/a (no GOAL_UNCONFIRMED here): 0" if UNCONFIRMED is None else \
        str(sum(r["state"] is UNCONFIRMED for r in rows))
    faults = sum(r["fault"] is not None for r in rows)
    med = statistics.median
    return (f"{label:>12}: reached {len(reached)}/{len(rows)}, false successes {len(false)}, unconfirmed {unconf}, "
            f"faults {faults}, collisions {sum(r['collisions'] for r in rows)}, "
            f"median true final error {med(r['true'] for r in rows):.3f} m, "
            f"median estimate error at end {med(r['est'] for r in rows):.3f} m, "
            f"truly within 0.1 m {sum(r['true'] <= 0.1 for r in rows)}/{len(rows)}; "
            f"wall {sum(r['wall'] for r in rows):.0f} s, CPU {sum(r['cpu'] for r in rows):.0f} s "
            f"(supervisor thread {sum(r['thread'] for r in rows):.0f} s) for {sum(r['sim_s'] for r in rows):.0f} simulated s")


def one_pty(scenario: str, noise: str, seed: int, scale: float, log: Path, imu: bool = True,
            told: bool = False) -> dict[str, Any]:
    """One real-time run over ptys: ``clomp run``'s exit status, the goal it was given, the
    true final distance (the world's), the estimate's error at the end (the run log's last
    fused pose against the world's pose in the start frame), collisions, the world's pushes
    and the last line on stderr. ``told``: ``clomp run --calibration`` with the world's terms
    (what ``clomp emulate world --calibration-out`` writes)."""
    import os
    import subprocess

    from clomp.runtime.backends.emulated import EmulatedWorldProcess

    t0 = time.perf_counter()
    with EmulatedWorldProcess(scenario, noise=noise, seed=seed, time_scale=scale) as world:
        gx, gy = world.scene.goal_in_robot_frame()
        extra: list[str] = []
        if told:
            from clomp.runtime.backends.calibration import write_calibration

            extra = ["--calibration", str(write_calibration(log.with_name(log.name + ".calibration.toml"),
                                                            world.calibration, f"--noise {noise}"))]
        argv = [sys.executable, "-m", "clomp.runtime.cli", "run", "--lidar", world.lidar_port, "--motors",
                world.motor_port, *(["--imu", world.imu_port] if imu else []), "--goal", f"{gx!r},{gy!r}",
                "--time-scale", f"{scale:g}", "--max-time", "120", "--log", str(log), *extra]
        load = os.getloadavg()[0]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=600)
        last = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or ["(nothing printed)"])[-1]
        truth = relative(world.scene.start, world.pose)
        est = _last_estimate(log)
        return {"scenario": scenario, "noise": noise, "seed": seed, "time_scale": scale, "imu": imu, "told": told,
                "goal": [gx, gy],
                "exit": done.returncode, "true": float(world.goal_distance), "collisions": int(world.collisions),
                "est": None if est is None else math.hypot(est[0] - truth.x, est[1] - truth.y),
                "pushes": [list(p) for p in world.pushes], "load": load,
                "last": last[:300], "wall": time.perf_counter() - t0, "log": str(log)}


def _last_estimate(log: Path) -> tuple[float, float] | None:
    """The last fused pose (x, y in the start frame) of a run log, None without one."""
    import json

    pose = None
    try:
        with open(log) as f:
            for line in f:
                if '"feedback"' in line:
                    pose = json.loads(line).get("pose", pose)
    except OSError:
        return None
    return None if pose is None else (float(pose[0]), float(pose[1]))


def pty_summary(label: str, rows: list[dict[str, Any]]) -> str:
    """The benchmark's line for real-time runs (reached = exit 0), as :func:`summary`'s."""
    med = statistics.median
    ests = [r["est"] for r in rows if r["est"] is not None]
    return (f"{label}: reached (exit 0) {sum(r['exit'] == 0 for r in rows)}/{len(rows)}, "
            f"false successes {sum(r['exit'] == 0 and r['true'] > 0.1 for r in rows)}, "
            f"unconfirmed {sum(_unconfirmed(r) for r in rows)}, faults (exit 3) {sum(r['exit'] == 3 for r in rows)}, "
            f"collisions {sum(r['collisions'] for r in rows)}, "
            f"median true final error {med(r['true'] for r in rows):.3f} m, "
            f"median estimate error at end {med(ests) if ests else math.nan:.3f} m, "
            f"truly within 0.1 m {sum(r['true'] <= 0.1 for r in rows)}/{len(rows)}, "
            f"pushed runs {sum(bool(r.get('pushes')) for r in rows)}; "
            f"wall {sum(r['wall'] for r in rows):.0f} s, load {min(r['load'] for r in rows):.1f}-{max(r['load'] for r in rows):.1f}")


def _unconfirmed(r: dict[str, Any]) -> bool:
    return bool(r["exit"] == 1 and "unconfirmed" in r["last"].lower())


def family_table(rows: list[dict[str, Any]]) -> str:
    """The per-family Markdown table of docs/ros2.md (pty runs): truly within 0.1 m, exit 0,
    false successes (exit 0, truly > 0.1 m), unconfirmed (exit 1 on GOAL_UNCONFIRMED), collisions,
    median true final error."""
    out = ["| scenario | time scale | runs | truly within 0.1 m | exit 0 (claimed) | false successes | unconfirmed "
           "| collisions | median true final error (m) |", "|---|---|---|---|---|---|---|---|---|"]
    keys = sorted({(r["scenario"], r["time_scale"]) for r in rows}, key=lambda k: ([r["scenario"] for r in rows].index(k[0]), k[1]))
    for scenario, scale in keys:
        rs = [r for r in rows if r["scenario"] == scenario and r["time_scale"] == scale]
        out.append(f"| {scenario} | {scale:g} | {len(rs)} | {sum(r['true'] <= 0.1 for r in rs)} "
                   f"| {sum(r['exit'] == 0 for r in rs)} | {sum(r['exit'] == 0 and r['true'] > 0.1 for r in rs)} "
                   f"| {sum(r['exit'] == 1 and 'unconfirmed' in r['last'].lower() for r in rs)} "
                   f"| {sum(r['collisions'] for r in rs)} | {statistics.median(r['true'] for r in rs):.3f} |")
    return "\n".join(out)


def main_pty(args: argparse.Namespace) -> int:
    import json
    import tempfile

    rows: list[dict[str, Any]] = []
    imus = {"on": (True,), "off": (False,), "both": (True, False)}[args.imu]
    with tempfile.TemporaryDirectory() as tmp:
        logs = Path(args.logs) if args.logs else Path(tmp)
        logs.mkdir(parents=True, exist_ok=True)
        for scale in (float(k) for k in args.scales.split(",")):
            for imu in imus:
                for scenario in args.scenarios.split(","):
                    for seed in _seeds(args):
                        name = f"{scenario}-{scale:g}-{'imu' if imu else 'noimu'}-{seed}.jsonl"
                        r = one_pty(scenario, args.noise, seed, scale, logs / name, imu, told=args.told == "on")
                        rows.append(r)
                        print(json.dumps(r), flush=True)
                        if args.json:
                            with open(args.json, "a") as f:
                                f.write(json.dumps(r) + "\n")
                    rs = [r for r in rows if r["scenario"] == scenario and r["time_scale"] == scale and r["imu"] == imu]
                    print(pty_summary(f"{scenario} time scale {scale:g} {'with --imu' if imu else 'without IMU'}", rs),
                          flush=True)
    print(f"real time over ptys, noise {args.noise}, {'told' if args.told == 'on' else 'not told'} the world's calibration:")
    for scale in sorted({r["time_scale"] for r in rows}):
        for imu in imus:
            rs = [r for r in rows if r["time_scale"] == scale and r["imu"] == imu]
            print(pty_summary(f"time scale {scale:g} {'with --imu' if imu else 'without IMU':>12}", rs))
    print(family_table([r for r in rows if r["imu"]]))
    return 0


def _seeds(args: argparse.Namespace) -> list[int]:
    return [int(s) for s in args.seeds.split(",")] if args.seeds else list(range(args.runs))


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--scenario", default="overtaking")
    ap.add_argument("--max-time", type=float, default=90.0)
    ap.add_argument("--pty", action="store_true", help="real-time runs of clomp run --imu over ptys (see the module)")
    ap.add_argument("--scenarios", default="", help="--pty: comma-separated scenarios (default: --scenario)")
    ap.add_argument("--seeds", default="", help="--pty: comma-separated seeds (default: 0..runs-1)")
    ap.add_argument("--scales", default="1,2", help="--pty: comma-separated --time-scale values")
    ap.add_argument("--json", metavar="FILE", help="--pty: also append each run as a JSON line")
    ap.add_argument("--logs", metavar="DIR", help="--pty: keep the run logs here")
    ap.add_argument("--imu", choices=("on", "off", "both"), default=None,
                    help="clomp run with --imu, without, or both (default: on with --pty, both in simulated time)")
    ap.add_argument("--told", choices=("on", "off", "both", "default"), default="default",
                    help="clomp run --calibration with the world's terms (on), as clomp run without it (off: its "
                         "default --drive-delay), both (simulated time), or the supervisor's defaults (default, as before; "
                         "--pty: off)")
    args = ap.parse_args(argv)
    if args.pty:
        args.scenarios = args.scenarios or args.scenario
        args.imu = args.imu or "on"
        return main_pty(args)
    tolds = {"on": (True,), "off": (False,), "both": (False, True), "default": (None,)}[args.told]
    settings = [(f"{'with --imu' if imu else 'without IMU'}{'' if t is None else ' told' if t else ' not told'}", imu, t)
                for imu in {"on": (True,), "off": (False,)}.get(args.imu, (False, True)) for t in tolds]
    results: dict[str, list[dict[str, Any]]] = {label: [] for label, _, _ in settings}
    for seed in range(args.runs):
        for label, imu, told in settings:
            r = one(args.scenario, args.noise, seed, imu, args.max_time, told)
            results[label].append(r)
            state = r["state"].value if r["state"] is not None else "raised"
            print(f"seed {seed:2d} {label:>12}: {state:<13} true {r['true']:.3f} m  estimate off {r['est']:.3f} m"
                  f"{'  fault: ' + r['fault'] if r['fault'] else ''}  ({r['wall']:.1f} s wall)", flush=True)
    print(f"{args.runs} runs of {args.scenario}, noise {args.noise}, in simulated time (the lockstep clock: the "
          "software's outcome, not the machine's load; --pty for real time):", flush=True)
    for label, rows in results.items():
        print(summary(label, rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
