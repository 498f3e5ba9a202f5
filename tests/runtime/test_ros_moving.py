"""``clomp ros node --moving`` (issue #42) with real rclpy, over DDS on this host only: in a
nook with a box 5 cm ahead of its front and walls along both sides, where no turn fits, the
node backs off — a REVERSE goes out on /cmd_vel as a negative ``linear.x`` at the straight
speed with no turn — and the run log records the WAIT/REVERSE setting."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("rclpy", reason="ROS 2 (rclpy) is not installed: pip install 'clomp[ros2]'")

from clomp.runtime.backends._raycast import first_hits  # noqa: E402
from tests.runtime.test_ros_node import Base, NodeThread, localhost_dds, records, wait_for  # noqa: E402,F401

# a box 5 cm ahead of the front edge (0.09 m), walls 0.08 m beside the body on either side from the
# rotation centre forwards: backed off 0.15 m, the body turns clear of them
NOOK = np.array([[0.14, -0.08, 0.0, 0.16], [0.0, 0.17, 0.3, 0.0], [0.0, -0.17, 0.3, 0.0]])


def _nook(msg) -> None:
    msg.angle_min, msg.angle_increment = -math.pi, 2 * math.pi / 360
    msg.angle_max = msg.angle_min + 359 * msg.angle_increment
    msg.range_min, msg.range_max = 0.02, 12.0
    a = msg.angle_min + msg.angle_increment * np.arange(360)
    msg.ranges = [float(v) for v in first_hits(0.0, 0.0, a, NOOK, np.zeros((0, 3)), 12.0)]


@pytest.fixture
def nook_base():
    b = Base()
    b.scan = _nook
    yield b
    b.close()


def test_a_reverse_goes_out_as_a_negative_linear_x(nook_base, tmp_path: Path) -> None:
    log = tmp_path / "run.jsonl"
    node = NodeThread("--goal", "1,0", "--moving", "--max-time", "30", "--log", str(log))
    wait_for(lambda: any(v < 0 for _, v, _ in list(nook_base.cmds)), 30, "a command backwards")
    back = [(v, w) for _, v, w in list(nook_base.cmds) if v < 0]
    assert all(v >= -0.1 - 1e-9 for v, _ in back) and any(math.isclose(v, -0.1, abs_tol=0.01) and abs(w) < 0.2 for v, w in back), back
    node.join(60)
    recs = records(log)
    assert recs[0]["event"] == "run" and recs[0]["parameters"]["moving"] is True
    tasks = [r for r in recs if r["event"] == "task"]
    assert tasks and tasks[0]["task"] == "REVERSE", tasks[:1]
