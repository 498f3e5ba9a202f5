"""LaserScan from ROS bags: bags written here with rosbags' writers from recorded scans
replay as the same scans, and every way a bag can be wrong is one line, exit 2.

The honest comparison: a LaserScan holds one range per bearing on a grid of
``angle_increment``, so a point moves by at most r·increment/2 sideways (plus float32
rounding of the range), and of several points on one bearing only the nearest survives
(what a LiDAR sees). The bags use the RPLIDAR A1's own angular resolution (1/64°).
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from clomp.runtime.records.bags import BagError, LaserScanTopic, bag_topics, laserscan_points, points_to_ranges

INC = 2 * math.pi / (360 * 64)  # the A1's 1/64° steps
COUNT = 360 * 64
ANGLE_MIN = -math.pi
RANGE_MIN, RANGE_MAX = 0.05, 12.0
KINDS = ("ros2-sqlite3", "ros2-mcap", "ros1")


def clomp(*args: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("clomp")
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli"]
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=600)


def cli(capsys, *args: str) -> subprocess.CompletedProcess[str]:
    """clomp in this process (faster than a subprocess for the one-line error cases)."""
    from clomp.runtime.cli import main

    capsys.readouterr()
    rc = main(list(args))
    out, err = capsys.readouterr()
    return subprocess.CompletedProcess(list(args), rc, out, err)


def _laserscan(ts, k: int, points: np.ndarray):
    T = ts.types["builtin_interfaces/msg/Time"]
    H = ts.types["std_msgs/msg/Header"]
    header = {"stamp": T(sec=1_700_000_000 + k // 5, nanosec=(k % 5) * 200_000_000), "frame_id": "laser"}
    if "seq" in H.__dataclass_fields__:  # ROS 1
        header["seq"] = k
    return ts.types["sensor_msgs/msg/LaserScan"](
        header=H(**header), angle_min=ANGLE_MIN, angle_max=ANGLE_MIN + INC * (COUNT - 1), angle_increment=INC,
        time_increment=0.0, scan_time=0.18, range_min=RANGE_MIN, range_max=RANGE_MAX,
        ranges=points_to_ranges(points, ANGLE_MIN, INC, COUNT), intensities=np.zeros(0, np.float32),
    )


def write_bag(path: Path, kind: str, scans: list[np.ndarray], topic: str = "/scan", odom: bool = True) -> Path:
    """A bag of ``kind`` with one LaserScan per scan at 5 Hz (and an empty /odom topic)."""
    from rosbags.typesys import Stores, get_typestore

    t0 = 1_700_000_000 * 10**9
    if kind == "ros1":
        from rosbags.rosbag1 import Writer as Writer1

        ts = get_typestore(Stores.ROS1_NOETIC)
        path = path.with_suffix(".bag")
        with Writer1(path) as w:
            c = w.add_connection(topic, "sensor_msgs/msg/LaserScan", typestore=ts)
            if odom:
                w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
            for k, pts in enumerate(scans):
                w.write(c, t0 + k * 200_000_000, ts.serialize_ros1(_laserscan(ts, k, pts), c.msgtype))
        return path
    from rosbags.rosbag2 import StoragePlugin
    from rosbags.rosbag2 import Writer as Writer2

    ts = get_typestore(Stores.ROS2_HUMBLE)
    plugin = StoragePlugin.MCAP if kind == "ros2-mcap" else StoragePlugin.SQLITE3
    with Writer2(path, version=9, storage_plugin=plugin) as w:
        c = w.add_connection(topic, "sensor_msgs/msg/LaserScan", typestore=ts)
        if odom:
            w.add_connection("/odom", "nav_msgs/msg/Odometry", typestore=ts)
        for k, pts in enumerate(scans):
            w.write(c, t0 + k * 200_000_000, ts.serialize_cdr(_laserscan(ts, k, pts), c.msgtype))
    return path


def on_the_grid(points: np.ndarray) -> np.ndarray:
    """What a LaserScan on this test's grid can carry of ``points``, worked out here
    independently of clomp: the nearest point per bearing bin, moved onto the bin's
    bearing, with the message's float32 angle_min, angle_increment and ranges."""
    if len(points) == 0:
        return np.zeros((0, 2))
    amin, inc = float(np.float32(ANGLE_MIN)), float(np.float32(INC))
    nearest: dict[int, float] = {}
    for x, y in points:
        k = int(round((math.atan2(y, x) - amin) / inc)) % COUNT
        r = float(np.float32(math.hypot(x, y)))
        nearest[k] = min(r, nearest.get(k, math.inf))
    ks = np.array(sorted(nearest))
    r = np.array([nearest[k] for k in ks])
    a = amin + inc * ks
    return np.column_stack((r * np.cos(a), r * np.sin(a)))


@pytest.fixture(scope="module")
def recorded(scans_dir, tmp_path_factory):
    """20 recorded scans spread over the corridor run (empty ones among them): the folder
    of their text files, the same scans as a LaserScan carries them (``grid``, .npy),
    and one bag of each kind."""
    files = sorted(scans_dir.glob("*.dat"))[::14][:20]
    assert len(files) == 20
    root = tmp_path_factory.mktemp("bags")
    folder, grid = root / "scans", root / "grid"
    folder.mkdir()
    grid.mkdir()
    scans = []
    for f in files:
        (folder / f.name).write_bytes(f.read_bytes())
        pts = np.loadtxt(f, ndmin=2).reshape(-1, 2) if f.stat().st_size else np.zeros((0, 2))
        scans.append(pts)
        np.save(grid / f"{f.stem}.npy", on_the_grid(pts))
    assert any(len(s) == 0 for s in scans) and sum(len(s) > 0 for s in scans) >= 15
    bags = {kind: write_bag(root / kind, kind, scans) for kind in KINDS}
    return folder, scans, bags, grid


def _json_lines(out: str) -> list[dict]:
    return [json.loads(line) for line in out.splitlines() if line.strip()]


@pytest.mark.parametrize("kind", KINDS)
def test_bag_scans_are_the_recorded_points_up_to_the_bearing_grid(recorded, kind):
    _, scans, bags, _ = recorded
    with LaserScanTopic(bags[kind], "/scan") as topic:
        got = list(topic)
        assert topic.count == 20
    assert [s.index for s in got] == list(range(20))
    assert [s.time_ns - got[0].time_ns for s in got] == [k * 200_000_000 for k in range(20)]
    assert all(s.frame_id == "laser" for s in got)
    for s, text in zip(got, scans):
        pts = s.points()
        uniq = np.unique(np.round(text * 1e4), axis=0) / 1e4 if len(text) else text
        if len(uniq) == 0:
            assert len(pts) == 0  # an empty scan stays free space
            continue
        r = np.hypot(uniq[:, 0], uniq[:, 1])
        bound = r * INC / 2 + 1e-5  # sideways shift to the bearing + float32 range
        d = np.hypot(*(uniq[:, None, :] - pts[None, :, :]).transpose(2, 0, 1))
        nearest = d.min(axis=1)
        # every bag point is one of the recorded points, moved onto its bearing
        assert np.all(d.min(axis=0) <= (np.hypot(pts[:, 0], pts[:, 1]) * INC / 2 + 1e-5))
        # every recorded point is in the bag, or hidden behind a nearer one on its bearing
        bins = np.round((np.arctan2(uniq[:, 1], uniq[:, 0]) - ANGLE_MIN) / INC).astype(int) % COUNT
        pbins = np.round((np.arctan2(pts[:, 1], pts[:, 0]) - ANGLE_MIN) / INC).astype(int) % COUNT
        prange = dict(zip(pbins.tolist(), np.hypot(pts[:, 0], pts[:, 1]).tolist()))
        for k in np.flatnonzero(nearest > bound):
            assert prange[int(bins[k])] < r[k]
        assert np.count_nonzero(nearest > bound) <= 0.02 * len(uniq)  # a handful hidden, no more


@pytest.mark.parametrize("kind", KINDS)
def test_replaying_a_bag_plans_as_on_the_text_files(recorded, kind):
    """20 messages replay as 20 scans, each planned exactly as its text file is once
    put on the LaserScan's grid; and on most scans the grid changes nothing at all."""
    folder, _, bags, grid = recorded
    text = _json_lines(clomp("replay", str(folder), "--json").stdout)
    on_grid = _json_lines(clomp("replay", str(grid), "--json").stdout)
    r = clomp("replay", str(bags[kind]), "--topic", "/scan", "--json")
    assert r.returncode == 0, r.stderr
    bag = _json_lines(r.stdout)
    assert bag[-1]["summary"]["scans"] == 20 and bag[-1]["summary"]["errors"] == 0
    assert len(bag) == len(text) == len(on_grid) == 21
    assert [x["scan"] for x in bag[:-1]] == [f"/scan#{k}@{k * 0.2:.3f}s" for k in range(20)]

    def key(x: dict) -> tuple:
        return (x["plan"], x["reached_goal"], x["states"])

    for g, b in zip(on_grid[:-1], bag[:-1]):
        assert key(g) == key(b), g["scan"]
    same = sum(t["plan"] == b["plan"] for t, b in zip(text[:-1], bag[:-1]))
    assert same >= 15, f"only {same}/20 plans survive the 1/64° grid unchanged"


def test_planning_on_a_bag_gives_the_grid_scans_plans_pose_by_pose(recorded):
    _, _, bags, grid = recorded
    want = _json_lines(clomp("plan", "--scan", str(grid), "--json").stdout)[:-1]  # the last line: the summary
    got = _json_lines(clomp("plan", "--scan", str(bags["ros2-mcap"]), "--json").stdout)[:-1]
    assert len(want) == len(got) == 20
    for x, y in zip(want, got):
        assert [s["task"] for s in x["plan"]] == [s["task"] for s in y["plan"]]
        ends = np.array([s["end"] for s in x["plan"]] or [[0, 0, 0]])
        assert np.allclose(ends, np.array([s["end"] for s in y["plan"]] or [[0, 0, 0]]), atol=1e-6)


def test_plan_on_one_scan_by_index_or_time(recorded, capsys):
    folder, _, bags, grid = recorded
    files = sorted(grid.glob("*.npy"))
    want = json.loads(cli(capsys, "plan", "--scan", str(files[7]), "--json").stdout)
    for pick in (["--index", "7"], ["--time", "1.43"], ["--index", "-13"]):
        r = cli(capsys, "plan", "--scan", str(bags["ros1"]), "--topic", "/scan", *pick, "--json")
        assert r.returncode == 0, r.stderr
        got = json.loads(r.stdout)
        assert [s["task"] for s in got["plan"]] == [s["task"] for s in want["plan"]]
        assert got["states"] == want["states"]
    readable = cli(capsys, "plan", "--scan", str(bags["ros1"]), "--index", "7")
    assert "/scan#7@1.400s" in readable.stdout.splitlines()[0]
    for bad in (["--index", "20"], ["--index", "-21"], ["--time", "-1"], ["--time", "nan"]):
        r = cli(capsys, "plan", "--scan", str(bags["ros1"]), *bad)
        assert r.returncode == 2 and len(r.stderr.strip().splitlines()) == 1, (bad, r.stderr)
        assert r.stderr.startswith("clomp: error:") and "Traceback" not in r.stderr


def test_a_missing_topic_names_the_topics_there_are(recorded):
    _, _, bags, _ = recorded
    for kind in KINDS:
        r = clomp("replay", str(bags[kind]), "--topic", "/nosuch")
        assert r.returncode == 2 and r.stdout == ""
        (line,) = r.stderr.strip().splitlines()
        assert "/nosuch" in line and "/scan (sensor_msgs/msg/LaserScan)" in line
        assert "/odom (nav_msgs/msg/Odometry)" in line
    assert bag_topics(bags["ros2-sqlite3"]) == {"/scan": "sensor_msgs/msg/LaserScan", "/odom": "nav_msgs/msg/Odometry"}


def test_a_topic_of_another_type_and_a_default_topic(recorded):
    _, _, bags, _ = recorded
    r = clomp("replay", str(bags["ros2-mcap"]), "--topic", "/odom")
    assert r.returncode == 2
    (line,) = r.stderr.strip().splitlines()
    assert "nav_msgs/msg/Odometry" in line and "LaserScan topics: /scan" in line
    # without --topic the bag's only LaserScan topic is read
    r = clomp("replay", str(bags["ros2-mcap"]), "--json")
    assert r.returncode == 0 and _json_lines(r.stdout)[-1]["summary"]["scans"] == 20


def test_bare_storage_files_read_like_their_bag(recorded, tmp_path):
    _, _, bags, _ = recorded
    for kind, suffix in (("ros2-mcap", ".mcap"), ("ros2-sqlite3", ".db3")):
        (storage,) = bags[kind].glob(f"*{suffix}")
        bare = tmp_path / f"bare{suffix}"
        bare.write_bytes(storage.read_bytes())  # no metadata.yaml beside it
        with LaserScanTopic(bare, "/scan") as a, LaserScanTopic(bags[kind], "/scan") as b:
            pa, pb = [s.points() for s in a], [s.points() for s in b]
        assert len(pa) == 20 and all(np.array_equal(x, y) for x, y in zip(pa, pb))


def test_damaged_and_unknown_bags_are_one_line(recorded, tmp_path, capsys):
    _, _, bags, _ = recorded
    (mcap,) = bags["ros2-mcap"].glob("*.mcap")
    (db3,) = bags["ros2-sqlite3"].glob("*.db3")
    cases = {
        "cut.bag": bags["ros1"].read_bytes()[: bags["ros1"].stat().st_size // 2],
        "cut.mcap": mcap.read_bytes()[: mcap.stat().st_size // 2],
        "cut.db3": db3.read_bytes()[:8192],
        "noise.bag": bytes(range(256)) * 8,
        "text.mcap": b"not a bag\n",
    }
    for name, data in cases.items():
        (tmp_path / name).write_bytes(data)
    (tmp_path / "folder").mkdir()
    (tmp_path / "scan.dat").write_text("1 0\n")
    for name in [*cases, "folder", "scan.dat", "missing.bag"]:
        r = cli(capsys, "replay", str(tmp_path / name), "--topic", "/scan")
        assert r.returncode == 2, (name, r.stdout, r.stderr)
        (line,) = r.stderr.strip().splitlines()
        assert line.startswith("clomp: error:") and name in line, line
    with pytest.raises(BagError):
        bag_topics(tmp_path / "cut.mcap")


def test_a_bag_cut_between_messages_stops_with_one_line(recorded, tmp_path):
    """A ROS 1 bag whose index survives but whose data is damaged: the scans before the
    damage are planned, then one line and exit 2."""
    _, _, bags, _ = recorded
    data = bytearray(bags["ros1"].read_bytes())
    mid = len(data) // 2
    data[mid : mid + 4096] = b"\xff" * 4096
    bad = tmp_path / "damaged.bag"
    bad.write_bytes(bytes(data))
    r = clomp("replay", str(bad), "--topic", "/scan")
    assert r.returncode == 2
    (line,) = r.stderr.strip().splitlines()
    assert line.startswith("clomp: error:") and "damaged.bag" in line


def test_lidar_offset_moves_the_scan_into_the_robot_frame(recorded, tmp_path, capsys):
    """A LiDAR mounted 5 cm ahead, 2 cm right, turned 90° left: planning on the bag with
    that offset is planning on the recorded points moved by it."""
    _, scans, bags, _ = recorded
    x, y, th = 0.05, -0.02, math.pi / 2
    c, s = math.cos(th), math.sin(th)
    pts = scans[3]
    moved = np.column_stack((x + c * pts[:, 0] - s * pts[:, 1], y + s * pts[:, 0] + c * pts[:, 1]))
    np.savetxt(tmp_path / "moved.dat", moved)
    want = json.loads(cli(capsys, "plan", "--scan", str(tmp_path / "moved.dat"), "--json").stdout)
    plain = json.loads(cli(capsys, "plan", "--scan", str(bags["ros1"]), "--index", "3", "--json").stdout)
    got = json.loads(cli(capsys, "plan", "--scan", str(bags["ros1"]), "--index", "3", "--lidar-offset",
                         f"{x},{y},{th}", "--json").stdout)
    tasks = [[q["task"] for q in d["plan"]] for d in (want, plain, got)]
    assert tasks[2] == tasks[0] and got["states"] == want["states"]
    assert (tasks[1], plain["states"]) != (tasks[0], want["states"])  # the offset matters here
    r = cli(capsys, "plan", "--scan", str(bags["ros1"]), "--index", "0", "--lidar-offset", "0.1,0")
    assert r.returncode == 2 and "--lidar-offset" in r.stderr and len(r.stderr.splitlines()) == 1
    for cmd in (["plan", "--scan"], ["replay"]):  # text scans are in the robot frame already
        r = cli(capsys, *cmd, str(tmp_path / "moved.dat"), "--lidar-offset", "0.1,0,0")
        assert r.returncode == 2 and "--lidar-offset" in r.stderr and len(r.stderr.splitlines()) == 1
    for extra in (["--lidar-offset", "0.1,0,0"], ["--index", "2"], ["--topic", "/scan"]):
        r = cli(capsys, "plan", "--scenario", "overtaking", *extra)
        assert r.returncode == 2 and len(r.stderr.splitlines()) == 1 and "ROS bag" in r.stderr


def test_no_return_readings():
    nan, inf = float("nan"), float("inf")
    pts = laserscan_points(0.0, math.pi / 2, [1.0, inf, nan, 0.01, 20.0, -1.0, 2.0], 0.05, 10.0)
    assert pts.round(9).tolist() == [[1.0, 0.0], [-2.0, 0.0]]
    assert laserscan_points(0.0, 0.1, [], 0.05, 10.0).shape == (0, 2)
    with pytest.raises(BagError):
        laserscan_points(nan, 0.1, [1.0], 0.05, 10.0)


@settings(max_examples=60, deadline=None)
@given(
    r=st.floats(0.1, 10.0),
    a=st.floats(-math.pi, math.pi),
    off=st.tuples(st.floats(-0.3, 0.3), st.floats(-0.3, 0.3), st.floats(-math.pi, math.pi)),
)
def test_a_point_survives_the_bearing_grid_and_the_mounting_offset(r, a, off):
    """Invariant: a point written to a LaserScan comes back within r·increment/2 of
    where it was, in the LiDAR frame, and the offset is a rigid motion of it."""
    p = np.array([[r * math.cos(a), r * math.sin(a)]])
    ranges = points_to_ranges(p, ANGLE_MIN, INC, COUNT)
    (q,) = laserscan_points(ANGLE_MIN, INC, ranges, RANGE_MIN, RANGE_MAX)
    assert math.dist(q, p[0]) <= r * INC / 2 + 1e-5
    (w,) = laserscan_points(ANGLE_MIN, INC, ranges, RANGE_MIN, RANGE_MAX, off)
    c, s = math.cos(off[2]), math.sin(off[2])
    assert math.dist(w, (off[0] + c * q[0] - s * q[1], off[1] + s * q[0] + c * q[1])) <= 1e-9


@pytest.mark.parametrize("time", ["1e300", "1e12"])
def test_a_time_far_beyond_any_recording_is_one_line(recorded, capsys, time):
    """``--time 1e300`` overflowed to a traceback (issue #43): it is beyond any bag."""
    _, _, bags, _ = recorded
    r = cli(capsys, "plan", "--scan", str(bags["ros1"]), "--time", time)
    assert r.returncode == 2 and r.stderr.startswith("clomp: error: --time: ") and len(r.stderr.splitlines()) == 1, r.stderr


@pytest.mark.parametrize("command", ["plan", "replay"])
def test_a_fifo_named_like_a_bag_is_refused_before_it_is_opened(tmp_path, capsys, command):
    fifo = tmp_path / "run.mcap"
    os.mkfifo(fifo)
    r = cli(capsys, command, *(["--scan"] if command == "plan" else []), str(fifo))
    assert r.returncode == 2 and r.stderr == f"clomp: error: {fifo}: is a FIFO (named pipe), not a ROS bag\n", r.stderr
