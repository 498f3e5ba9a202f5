"""An IMU fault mid-run as a user meets it (issue #36): ``clomp emulate world --imu-fault KIND``
and ``clomp run --imu`` as two processes over ptys, in real time. Every wait is for an event
(a line printed, a process's exit), bounded only by :data:`HANG` (a hang, not a figure); the
detection's timing is measured in simulated time (test_imu_stack_simtime.py) and by
bench/imu_faults.py, not asserted here beyond its order of events."""

from __future__ import annotations

import re
import subprocess
from pathlib import Path

import pytest

from tests.runtime._ptycli import HANG, clomp, read_lines, stop_world


@pytest.mark.slow  # two interpreters and a run of several seconds in real time
@pytest.mark.parametrize(("kind", "said"), [("silent", "fell silent"), ("spin", "disagrees wildly")])
def test_an_imu_failing_mid_run_exits_3_with_the_wheels_stopped(kind: str, said: str, tmp_path: Path) -> None:
    world = subprocess.Popen(clomp("emulate", "world", "--scenario", "overtaking", "--noise", "harsh", "--seed", "1",
                                   "--imu-fault", kind, "--imu-fault-at", "4", "--time-scale", "2"),
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        ports = dict(line.split(": ", 1) for line in read_lines(world, 4))
        run = subprocess.run(
            clomp("run", "--lidar", ports["lidar"], "--motors", ports["motors"], "--imu", ports["imu"], "--goal", "1,0",
                  "--time-scale", "2", "--max-time", "120", "--log", str(tmp_path / "run.jsonl")),
            capture_output=True, text=True, timeout=HANG)
    finally:
        out, err = stop_world(world)
    assert world.returncode == 0, err
    last = run.stderr.strip().splitlines()[-1]
    assert run.returncode == 3, run.stderr
    assert "IMU" in last and said in last and "wheels stopped" in last and "Traceback" not in run.stderr
    assert f"imu fault: {kind}" in out  # it came, and then the run ended on it
    summary = out.strip().splitlines()[-1]
    stop = re.search(r"wheels commanded to stop ([0-9.]+) s \(world\) after it", summary)
    assert stop is not None, summary  # after the fault, and never commanded to move again
    assert "wheel speeds now (0, 0) m/s" in summary, summary
