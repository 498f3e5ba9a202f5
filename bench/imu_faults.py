"""IMU faults mid-run as a user meets them: ``clomp emulate world --imu-fault KIND`` + ``clomp run --imu``.

Run: ``python bench/imu_faults.py [--faults silent,unplug,garbage,wrong-yaw] [--seeds 0,1]
[--scales 1,2] [--at 5] [--noise harsh] [--scenario overtaking]``. Prints figures; asserts nothing.

Each run starts ``clomp emulate world --scenario S --noise N --seed K --imu-fault F
--imu-fault-at T [--time-scale k]`` as a subprocess, reads the ``run:`` command it prints,
runs it (``clomp run --lidar … --motors … --imu … --goal …``, the same ``--time-scale``),
then stops the world with Ctrl-C (SIGINT) and reads its last line: where the robot ended,
when the fault came, how long (world seconds) after it the Maestro was last commanded to
stop the wheels, how far the robot went after it and the world's wheel speeds at the end.
One JSON line a run (also appended to ``--json``), then per fault: exit codes, the longest
time to the stop and the farthest the robot went after the fault. Real time: the figures
depend on how busy the machine is (the load average is printed beside them).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

ROOT = Path(__file__).resolve().parents[1]
_STOP = re.compile(r"wheels commanded to stop ([0-9.]+) s \(world\) after it")
_MOVED = re.compile(r"the robot moved ([0-9.]+) m after it")
_SPEEDS = re.compile(r"wheel speeds now \(([-0-9.e]+), ([-0-9.e]+)\) m/s")
_GOAL = re.compile(r"([0-9.]+) m from the goal")


def _clomp() -> list[str]:
    return [sys.executable, "-m", "clomp"]


def _wait_for_run_line(emu: subprocess.Popen[str], out: Path, wall: float = 600.0) -> list[str]:
    """The emulator's lines up to its ``run:`` line (polled from its output file)."""
    deadline = time.monotonic() + wall
    while time.monotonic() < deadline:
        lines = out.read_text().splitlines()
        if any(ln.startswith("run: ") for ln in lines):
            return lines[: next(i for i, ln in enumerate(lines) if ln.startswith("run: ")) + 1]
        if emu.poll() is not None:
            break
        time.sleep(0.1)
    raise RuntimeError(f"the emulator printed no run: line (exit {emu.poll()}): {out.read_text()!r}")


def one(kind: str, seed: int, scale: float, at: float, args: argparse.Namespace, log: Path) -> dict[str, Any]:
    """One run with the IMU failing ``kind`` at ``at`` s of world time."""
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    emu_argv = [*_clomp(), "emulate", "world", "--scenario", args.scenario, "--noise", args.noise, "--seed", str(seed),
                "--imu-fault", kind, "--imu-fault-at", f"{at:g}", "--time-scale", f"{scale:g}"]
    t0 = time.perf_counter()
    out_path, err_path = log.with_suffix(".emu.out"), log.with_suffix(".emu.err")
    with open(out_path, "w") as out, open(err_path, "w") as errf:
        emu = subprocess.Popen(emu_argv, stdout=out, stderr=errf, text=True, env=env)
    try:
        lines = _wait_for_run_line(emu, out_path)
        cmd = shlex.split(lines[-1][len("run: "):])
        assert cmd[:2] == ["clomp", "run"], cmd
        run_argv = [*_clomp(), *cmd[1:], "--max-time", f"{args.max_time:g}", "--log", str(log)]
        if "--time-scale" not in cmd:
            run_argv += ["--time-scale", f"{scale:g}"]
        load = os.getloadavg()[0]
        done = subprocess.run(run_argv, capture_output=True, text=True, env=env, timeout=900)
        time.sleep(1.0)  # the world comes to rest (it is held once the robot stands and the scan stopped)
    finally:
        emu.send_signal(signal.SIGINT)
        try:
            emu.wait(timeout=60)
        except subprocess.TimeoutExpired:
            emu.kill()
            emu.wait()
    lines = out_path.read_text().splitlines()
    err = err_path.read_text()
    summary = next((ln for ln in reversed(lines) if ln.startswith("robot at ")), "")
    came = next((ln for ln in lines if ln.startswith("imu fault: ")), "")
    last = (done.stderr.strip().splitlines() or done.stdout.strip().splitlines() or ["(nothing printed)"])[-1]
    stop, moved, speeds, goal = (_STOP.search(summary), _MOVED.search(summary), _SPEEDS.search(summary),
                                 _GOAL.search(summary))
    return {"fault": kind, "seed": seed, "time_scale": scale, "at": at, "exit": done.returncode, "last": last[:400],
            "came": came, "stop_after": float(stop.group(1)) if stop else None,
            "moved_after": float(moved.group(1)) if moved else None,
            "speeds": [float(speeds.group(1)), float(speeds.group(2))] if speeds else None,
            "goal_distance": float(goal.group(1)) if goal else None, "summary": summary,
            "emulator_stderr": err.strip()[-300:], "load": load, "wall": time.perf_counter() - t0}


def table(rows: list[dict[str, Any]]) -> str:
    """Per fault and time scale: runs, exit 3, wheels stopped, the longest time to the stop
    (world s after the fault), the farthest the robot went after it."""
    out = ["| fault | time scale | runs | exit 3 | wheels at rest at the end | stop after fault, max (world s) "
           "| moved after fault, max (m) |", "|---|---|---|---|---|---|---|"]
    for kind in dict.fromkeys(r["fault"] for r in rows):
        for scale in sorted({r["time_scale"] for r in rows if r["fault"] == kind}):
            rs = [r for r in rows if r["fault"] == kind and r["time_scale"] == scale]
            stops = [r["stop_after"] for r in rs if r["stop_after"] is not None]
            moved = [r["moved_after"] for r in rs if r["moved_after"] is not None]
            at_rest = sum(r["speeds"] is not None and max(map(abs, r["speeds"])) < 1e-3 for r in rs)
            out.append(f"| {kind} | {scale:g} | {len(rs)} | {sum(r['exit'] == 3 for r in rs)} | {at_rest} "
                       f"| {max(stops) if len(stops) == len(rs) else 'not stopped in ' + str(len(rs) - len(stops))} "
                       f"| {max(moved) if moved else 'n/a'} |")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--faults", default="silent,unplug,garbage,wrong-yaw")
    ap.add_argument("--seeds", default="0")
    ap.add_argument("--scales", default="1")
    ap.add_argument("--at", type=float, default=5.0, help="world time of the fault (s)")
    ap.add_argument("--noise", default="harsh")
    ap.add_argument("--scenario", default="overtaking")
    ap.add_argument("--max-time", type=float, default=60.0)
    ap.add_argument("--json", metavar="FILE", help="also append each run as a JSON line")
    args = ap.parse_args(argv)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        for scale in (float(k) for k in args.scales.split(",")):
            for kind in args.faults.split(","):
                for seed in (int(s) for s in args.seeds.split(",")):
                    r = one(kind, seed, scale, args.at, args, Path(tmp) / f"{kind}-{seed}-{scale:g}.jsonl")
                    rows.append(r)
                    print(json.dumps(r), flush=True)
                    if args.json:
                        with open(args.json, "a") as f:
                            f.write(json.dumps(r) + "\n")
    print(f"{args.scenario}, noise {args.noise}, IMU fault at {args.at:g} s of world time, over ptys in real time "
          f"(load average {min(r['load'] for r in rows):.1f}-{max(r['load'] for r in rows):.1f}):")
    print(table(rows))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
