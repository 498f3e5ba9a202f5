"""``clomp ros node``'s reaction time: from a ``/scan`` message to the ``/cmd_vel`` it causes,
and the node's CPU per LiDAR revolution, at 10 Hz scans.

``clomp ros sim`` runs in its own process (10 revolutions a second, ``paper`` noise) and
the node drives it to the goal; a probe node records when each ``/scan`` and each
``/cmd_vel`` arrives. The node and the probe have their own rclpy contexts in this
process (one monotonic clock); all talk over DDS on this host only (localhost discovery,
shared memory, a private domain id). Figures:

- *in the node*: from the moment the node received a scan to the moment it published the
  first command of the control step that read that scan;
- *at a probe*: from the probe receiving that scan (matched by its stamp) to the probe
  receiving that command: the node's reaction as another node on the bus sees it;
- *CPU per revolution*: ``time.thread_time()`` of the node's control loop and of its
  executor thread (callbacks, conversions, the watchdog), over the scans it read.

Target: p99 end to end <= 50 ms. ::

    python bench/ros_latency.py [--scenario overtaking] [--seed 0]
"""

from __future__ import annotations

import argparse
import bisect
import os
import signal
import subprocess
import sys
import threading
import time

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--scenario", default="overtaking")
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--domain", type=int, default=40 + os.getpid() % 50, help="ROS_DOMAIN_ID (0-101)")
    args = ap.parse_args()

    from clomp.runtime.ros.session import localhost_only

    localhost_only(args.domain)  # before any rclpy context; the sim's process inherits it
    from geometry_msgs.msg import Twist
    from rclpy.qos import qos_profile_sensor_data
    from sensor_msgs.msg import LaserScan

    from clomp.planner import load_scenario
    from clomp.runtime.cli.ros import make_supervisor
    from clomp.runtime.ros.node import GoalInbox, NodeOutputs, configure, supervise
    from clomp.runtime.ros.robot import RosRobot
    from clomp.runtime.ros.session import RosSession

    scene = load_scenario(args.scenario)
    sim = subprocess.Popen([sys.executable, "-m", "clomp", "ros", "sim", "--scenario", args.scenario, "--noise", args.noise,
                            "--seed", str(args.seed), "--scan-rate", "10", "--max-time", "300"],
                           stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
    scans: dict[int, float] = {}
    cmds: list[float] = []
    lock = threading.Lock()

    def on_scan(msg: LaserScan) -> None:
        with lock:
            scans[int(msg.header.stamp.sec) * 10**9 + int(msg.header.stamp.nanosec)] = time.monotonic()

    def on_cmd(_msg: object) -> None:
        with lock:
            cmds.append(time.monotonic())

    try:
        with RosSession("probe") as probe, RosSession("clomp") as node_session:
            probe.node.create_subscription(LaserScan, "/scan", on_scan, qos_profile_sensor_data)
            probe.node.create_subscription(Twist, "/cmd_vel", on_cmd, 10)
            conf, rc, _ = configure(node_session.node)
            robot = RosRobot(node_session.node, conf.robot.wheel_base, rc)
            outputs = NodeOutputs(node_session.node, rc.odom_frame, rc.base_frame)
            inbox = GoalInbox(node_session.node, rc.odom_frame)
            c0 = time.thread_time()
            report = supervise(robot, lambda g: make_supervisor(robot, g, conf), scene.goal_in_robot_frame(), outputs,
                               inbox, lambda s: None, max_time=120)
            loop_cpu = time.thread_time() - c0
            time.sleep(0.2)
            spin_cpu = node_session.spin_cpu
            robot.close()
    finally:
        sim.send_signal(signal.SIGINT)
        out, _ = sim.communicate(timeout=30)
    with lock:
        got, seen = list(cmds), dict(scans)
    inside, end_to_end = [], []
    for stamp, arrived, published in robot.latencies:
        inside.append(published - arrived)
        j = bisect.bisect_left(got, published)  # the command's arrival at the probe
        if stamp in seen and j < len(got):
            end_to_end.append(got[j] - seen[stamp])

    def pct(xs: list[float]) -> str:
        a = np.asarray(xs) * 1e3
        return f"p50 {np.percentile(a, 50):.1f} ms, p99 {np.percentile(a, 99):.1f} ms, max {a.max():.1f} ms ({len(a)} scans)"

    truth = [line for line in out.splitlines() if line.startswith("robot at")]
    print(f"{args.scenario} ({args.noise}, seed {args.seed}), 10 Hz scans: {report.state.value}; sim: {truth[-1] if truth else '?'}")
    print(f"scan -> /cmd_vel in the node: {pct(inside)}")
    print(f"scan -> /cmd_vel at a probe:  {pct(end_to_end)}")
    scans_read = max(robot.scans, 1)
    print(f"node CPU per revolution: {(loop_cpu + spin_cpu) / scans_read * 1e3:.2f} ms (control loop "
          f"{loop_cpu / scans_read * 1e3:.2f} ms + executor {spin_cpu / scans_read * 1e3:.2f} ms; {robot.scans} scans)")
    p99 = float(np.percentile(np.asarray(end_to_end), 99)) * 1e3
    print(f"target p99 <= 50 ms: {'met' if p99 <= 50 else 'NOT met'} ({p99:.1f} ms); load average {os.getloadavg()[0]:.1f} "
          f"on {os.cpu_count()} cores")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
