"""``clomp ros node``'s reaction time: from a ``/scan`` message to the ``/cmd_vel`` it causes,
and the node's CPU per LiDAR revolution, at 10 Hz scans.

The execution world runs as ``clomp ros sim`` does (a ROS node, 10 revolutions a second,
``paper`` noise) and the node drives it to the goal; a probe node records when each
``/cmd_vel`` arrives. All three have their own rclpy contexts in this process (one
monotonic clock) and talk over DDS on this host only (localhost discovery, shared memory,
a private domain id). Figures:

- *in the node*: from the moment the node received a scan to the moment it published the
  first command of the control step that read that scan;
- *end to end*: from the sim publishing the scan to the probe receiving that command;
- *CPU per revolution*: ``time.thread_time()`` of the node's control loop and of its
  executor thread (callbacks, conversions, the watchdog), over the scans it read.

Target: p99 end to end <= 50 ms. ::

    python bench/ros_latency.py [--scenario overtaking] [--seed 0]
"""

from __future__ import annotations

import argparse
import bisect
import os
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

    localhost_only(args.domain)  # before any rclpy context
    from geometry_msgs.msg import Twist

    from clomp.planner import load_scenario
    from clomp.planner.robot_model import RobotModel
    from clomp.runtime.backends.world import make_world_robot
    from clomp.runtime.cli.ros import make_supervisor
    from clomp.runtime.ros.node import GoalInbox, NodeOutputs, configure, supervise
    from clomp.runtime.ros.robot import RosRobot
    from clomp.runtime.ros.session import RosSession
    from clomp.runtime.ros.sim import SimNode

    scene = load_scenario(args.scenario)
    model = RobotModel()
    world = make_world_robot(scene, args.noise, seed=args.seed, robot=model, scan_rate=10.0)
    received: list[float] = []
    lock = threading.Lock()

    def on_cmd(_msg: object) -> None:
        with lock:
            received.append(time.monotonic())

    with RosSession("clomp_sim") as sim_session, RosSession("probe") as probe, RosSession("clomp") as node_session:
        sim = SimNode(sim_session.node, world, model.wheel_base)
        probe.node.create_subscription(Twist, "/cmd_vel", on_cmd, 10)
        conf, rc, _ = configure(node_session.node)
        robot = RosRobot(node_session.node, conf.robot.wheel_base, rc)
        outputs = NodeOutputs(node_session.node, rc.odom_frame, rc.base_frame)
        inbox = GoalInbox(node_session.node, rc.odom_frame)
        c0 = time.thread_time()
        report = supervise(robot, lambda g: make_supervisor(robot, g, conf), scene.goal_in_robot_frame(), outputs, inbox,
                           lambda s: None, max_time=120)
        loop_cpu = time.thread_time() - c0
        time.sleep(0.2)
        spin_cpu = node_session.spin_cpu
        robot.close()
        summary = sim.summary()
        sim.close()
        sent = list(sim.scan_sent_at)
    with lock:
        got = list(received)
    inside, end_to_end = [], []
    for arrived, published in robot.latencies:
        inside.append(published - arrived)
        k = bisect.bisect_right(sent, arrived) - 1  # the scan the sim sent last before it arrived
        j = bisect.bisect_left(got, published)  # the command's arrival at the probe
        if k >= 0 and j < len(got):
            end_to_end.append(got[j] - sent[k])

    def pct(xs: list[float]) -> str:
        a = np.asarray(xs) * 1e3
        return f"p50 {np.percentile(a, 50):.1f} ms, p99 {np.percentile(a, 99):.1f} ms, max {a.max():.1f} ms ({len(a)} scans)"

    print(f"{args.scenario} ({args.noise}, seed {args.seed}), 10 Hz scans: {report.state.value}, "
          f"truly {summary['goal_distance']:.3f} m from the goal, {summary['collisions']} collisions")
    print(f"scan -> /cmd_vel in the node: {pct(inside)}")
    print(f"scan -> /cmd_vel end to end:  {pct(end_to_end)}")
    scans = max(robot.scans, 1)
    print(f"node CPU per revolution: {(loop_cpu + spin_cpu) / scans * 1e3:.2f} ms "
          f"(control loop {loop_cpu / scans * 1e3:.2f} ms + executor {spin_cpu / scans * 1e3:.2f} ms; {robot.scans} scans)")
    p99 = float(np.percentile(np.asarray(end_to_end), 99)) * 1e3
    print(f"target p99 <= 50 ms: {'met' if p99 <= 50 else 'NOT met'} ({p99:.1f} ms)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
