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
:class:`EmulatedWorldProcess`) and ``clomp run --lidar … --motors … --imu … --goal 1,0`` as
a subprocess, at ``--time-scale`` 1 and 2, ``--runs`` seeds each, and prints per setting how
many runs end truly within 0.1 m and how many exit 0 farther than that (false successes).
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


def one(scenario: str, noise: str, seed: int, imu: bool, max_time: float) -> dict[str, Any]:
    """One run's outcome and costs."""
    wall, cpu, thread = time.perf_counter(), time.process_time(), time.thread_time()
    run = run_stack(scenario, noise=noise, seed=seed, max_time=max_time, imu=imu)
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


def one_pty(scenario: str, noise: str, seed: int, scale: float, log: Path) -> tuple[int, float]:
    """One real-time run over ptys: ``clomp run``'s exit status and the true final distance."""
    import subprocess

    from clomp.runtime.backends.emulated import EmulatedWorldProcess

    with EmulatedWorldProcess(scenario, noise=noise, seed=seed, time_scale=scale) as world:
        gx, gy = world.scene.goal_in_robot_frame()
        argv = [sys.executable, "-m", "clomp.runtime.cli", "run", "--lidar", world.lidar_port, "--motors",
                world.motor_port, "--imu", world.imu_port, "--goal", f"{gx:g},{gy:g}", "--time-scale", f"{scale:g}",
                "--max-time", "120", "--log", str(log)]
        done = subprocess.run(argv, capture_output=True, text=True, timeout=600)
        if done.returncode != 0:
            print("   ", (done.stderr.strip().splitlines() or ["(nothing on stderr)"])[-1][:300], flush=True)
        return done.returncode, float(world.goal_distance)


def main_pty(args: argparse.Namespace) -> int:
    import tempfile

    with tempfile.TemporaryDirectory() as tmp:
        for scale in (1.0, 2.0):
            near = false = 0
            for seed in range(args.runs):
                t0 = time.perf_counter()
                code, dist = one_pty(args.scenario, args.noise, seed, scale, Path(tmp) / f"run-{scale}-{seed}.jsonl")
                near += dist <= 0.1
                false += code == 0 and dist > 0.1
                print(f"time scale {scale:g} seed {seed:2d}: exit {code}  true {dist:.3f} m  "
                      f"({time.perf_counter() - t0:.0f} s wall)", flush=True)
            print(f"time scale {scale:g}: truly within 0.1 m {near}/{args.runs}, false successes {false}", flush=True)
    return 0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=20)
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--scenario", default="overtaking")
    ap.add_argument("--max-time", type=float, default=90.0)
    ap.add_argument("--pty", action="store_true", help="real-time runs of clomp run --imu over ptys (see the module)")
    args = ap.parse_args(argv)
    if args.pty:
        return main_pty(args)
    results: dict[str, list[dict[str, Any]]] = {"without IMU": [], "with --imu": []}
    for seed in range(args.runs):
        for label, imu in (("without IMU", False), ("with --imu", True)):
            r = one(args.scenario, args.noise, seed, imu, args.max_time)
            results[label].append(r)
            state = r["state"].value if r["state"] is not None else "raised"
            print(f"seed {seed:2d} {label:>12}: {state:<13} true {r['true']:.3f} m  estimate off {r['est']:.3f} m"
                  f"{'  fault: ' + r['fault'] if r['fault'] else ''}  ({r['wall']:.1f} s wall)", flush=True)
    print(f"{args.runs} runs of {args.scenario}, noise {args.noise}, simulated time:", flush=True)
    for label, rows in results.items():
        print(summary(label, rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
