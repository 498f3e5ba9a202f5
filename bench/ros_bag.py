"""A recorded bag played into ``clomp ros node --dry-run`` over DDS: a plan on every scan,
nothing commanded.

Reads the bag's LaserScan topic with clomp's own reader (:mod:`clomp.runtime.records.bags`:
ROS 1 or ROS 2, no ROS install), publishes each scan on ``/scan`` once the node's plan of
the one before came back on ``/plan`` (the first until the node has it: a best-effort
message sent while DDS still matches the two ends is lost), and counts ``/cmd_vel``
messages (there must be none). DDS stays on this host (localhost discovery, shared
memory, a private domain id)::

    python bench/ros_bag.py [BAG] [--goal 1,0]
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

BAG = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "bags" / "laser-scan-matcher-demo.bag"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("bag", nargs="?", default=str(BAG))
    ap.add_argument("--goal", default="1,0")
    ap.add_argument("--domain", type=int, default=40 + os.getpid() % 50, help="ROS_DOMAIN_ID (0-101)")
    args = ap.parse_args()

    from clomp.runtime.ros.session import localhost_only

    localhost_only(args.domain)
    from geometry_msgs.msg import Twist
    from nav_msgs.msg import Path as PathMsg
    from rclpy.qos import DurabilityPolicy, QoSProfile, qos_profile_sensor_data
    from sensor_msgs.msg import LaserScan

    from clomp.runtime.cli import main as clomp
    from clomp.runtime.records.bags import LaserScanTopic
    from clomp.runtime.ros.session import RosSession

    with LaserScanTopic(args.bag) as topic:
        scans = list(topic)
        name = topic.topic
    plans: list[object] = []
    cmds: list[object] = []
    with tempfile.TemporaryDirectory() as tmp, RosSession("bag_player") as player:
        node = player.node
        pub = node.create_publisher(LaserScan, "/scan", qos_profile_sensor_data)
        node.create_subscription(PathMsg, "/plan", plans.append, QoSProfile(depth=50, durability=DurabilityPolicy.TRANSIENT_LOCAL))
        node.create_subscription(Twist, "/cmd_vel", cmds.append, 10)
        log = Path(tmp) / "run.jsonl"
        code: list[int] = []
        runner = threading.Thread(target=lambda: code.append(clomp(["ros", "node", "--dry-run", "--goal", args.goal,
                                                                    "--log", str(log)])), daemon=True)
        runner.start()

        def message(s: object) -> LaserScan:
            m = LaserScan()
            m.header.stamp = node.get_clock().now().to_msg()
            m.header.frame_id = s.frame_id  # type: ignore[attr-defined]
            m.angle_min, m.angle_increment = s.angle_min, s.angle_increment  # type: ignore[attr-defined]
            m.angle_max = s.angle_min + s.angle_increment * (len(s.ranges) - 1)  # type: ignore[attr-defined]
            m.range_min, m.range_max = s.range_min, s.range_max  # type: ignore[attr-defined]
            m.ranges = s.ranges.astype(float).tolist()  # type: ignore[attr-defined]
            return m

        end = time.monotonic() + 60
        while not plans and time.monotonic() < end:
            pub.publish(message(scans[0]))
            time.sleep(0.3)
        for s in scans[1:]:
            seen = len(plans)
            pub.publish(message(s))
            end = time.monotonic() + 20
            while len(plans) <= seen and time.monotonic() < end:
                time.sleep(0.002)
        runner.join(30)
        records = [json.loads(line) for line in log.read_text().splitlines()]
    got = [r for r in records if r["event"] == "plan"]
    errors = [r for r in got if "error" in r]
    times = np.asarray([r["planning_time_s"] for r in got if "planning_time_s" in r]) * 1e3
    print(f"{Path(args.bag).name} {name}: {len(scans)} scans played, the node read {sum(r['event'] == 'scan' for r in records)}, "
          f"{len(got)} plans ({len(errors)} errors, {sum(bool(r.get('reached_goal')) for r in got)} reach the goal), "
          f"{len(cmds)} /cmd_vel messages; planning time median {np.median(times):.2f} ms, p99 {np.percentile(times, 99):.2f} ms; "
          f"exit {code[0] if code else '?'} (3: the scans stopped with the bag)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
