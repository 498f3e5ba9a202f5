"""``clomp simulate --log`` and ``clomp convert``: a simulated overtaking run as MCAP,
read back with the mcap package (and Foxglove's ROS 2 decoder, mcap-ros2-support) and
with rosbags."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.records.bags import LaserScanTopic, bag_topics
from clomp.runtime.records.mcap_writer import A1_BINS, write_mcap
from clomp.runtime.records.runlog import read_log


def clomp(*args: str) -> subprocess.CompletedProcess[str]:
    script = Path(sys.executable).with_name("clomp")
    cmd = [str(script)] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli"]
    return subprocess.run([*cmd, *args], capture_output=True, text=True, timeout=600)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A simulated overtaking run's log and its MCAP."""
    d = tmp_path_factory.mktemp("mcap")
    log, mcap = d / "run.jsonl", d / "run.mcap"
    r = clomp("simulate", "--scenario", "overtaking", "--log", str(log), "--out", str(d), "--json")
    assert r.returncode == 0, r.stderr
    c = clomp("convert", str(log), "-o", str(mcap), "--json")
    assert c.returncode == 0, c.stderr
    return list(read_log(log)), mcap, json.loads(c.stdout), json.loads(r.stdout)


def _yaw(q) -> float:
    return 2 * math.atan2(q.z, q.w)


def test_simulate_writes_the_supervisors_run_log_in_simulated_time(run):
    records, _, _, summary = run
    kinds = {r["event"] for r in records}
    assert {"run", "start", "scan", "plan", "task", "state", "stop"} <= kinds
    assert records[0]["event"] == "run" and records[0]["simulated"] is True
    assert records[-1]["event"] == "stop" and records[-1]["status"] == "GOAL_REACHED"
    # times are the simulated clock's: the run took time_s simulated seconds, not wall seconds
    assert records[-1]["t"] == pytest.approx(summary["time_s"], abs=0.2)
    scans = [r for r in records if r["event"] == "scan"]
    assert all(len(r["truth"]) == 3 and len(r["pose"]) == 3 for r in scans)
    plan = next(r for r in records if r["event"] == "plan")
    assert plan["path"][0] == pytest.approx(plan["origin"]) and len(plan["obstacles"]) >= 1
    assert summary["reached_goal"]


def test_the_mcap_has_one_message_per_logged_record(run):
    from mcap.reader import make_reader

    records, mcap, printed, _ = run
    scans = [r for r in records if r["event"] == "scan"]
    plans = [r for r in records if r["event"] == "plan" and "path" in r]
    want = {"/scan": len(scans), "/pose": len(scans), "/truth": len(scans), "/tf": len(scans),
            "/plan": len(plans), "/obstacles": len(plans), "/goal": 1}
    assert printed["messages"] == want
    with open(mcap, "rb") as f:
        reader = make_reader(f)
        s = reader.get_summary()
        assert reader.get_header().profile == "ros2"
        got = {c.topic: s.statistics.channel_message_counts[c.id] for c in s.channels.values()}
        names = {c.topic: s.schemas[c.schema_id].name for c in s.channels.values()}
        encodings = {(c.message_encoding, s.schemas[c.schema_id].encoding) for c in s.channels.values()}
    assert got == want
    assert names == {"/scan": "sensor_msgs/msg/LaserScan", "/pose": "geometry_msgs/msg/PoseStamped",
                     "/truth": "geometry_msgs/msg/PoseStamped", "/tf": "tf2_msgs/msg/TFMessage",
                     "/plan": "nav_msgs/msg/Path", "/obstacles": "visualization_msgs/msg/MarkerArray",
                     "/goal": "geometry_msgs/msg/PoseStamped"}
    assert encodings == {("cdr", "ros2msg")}
    # rosbags reads the same file as a ROS 2 bag
    assert bag_topics(mcap) == names
    with LaserScanTopic(mcap, "/scan") as topic:
        assert topic.count == len(scans) and len(list(topic)) == len(scans)


def test_a_decoded_scan_is_the_logged_one_and_times_are_the_logs(run):
    """Decoded by Foxglove's own ROS 2 decoder (mcap-ros2-support), not by clomp."""
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    records, mcap, _, _ = run
    wall_ns = int(round(records[0]["wall"] * 1e9))
    scans = [r for r in records if r["event"] == "scan"]
    k = max(range(len(scans)), key=lambda i: len(scans[i]["points"]))  # the richest scan
    with open(mcap, "rb") as f:
        msgs = [(m, d) for _, _, m, d in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages(
            topics=["/scan"])]
    assert [m.log_time for m, _ in msgs] == [wall_ns + int(round(r["t"] * 1e9)) for r in scans]
    msg, scan = msgs[k]
    assert scan.header.frame_id == "base_link" and len(scan.ranges) == A1_BINS
    assert scan.header.stamp.sec * 10**9 + scan.header.stamp.nanosec == msg.log_time
    r = np.asarray(scan.ranges, dtype=float)
    a = scan.angle_min + scan.angle_increment * np.arange(len(r))
    keep = np.isfinite(r)
    got = np.column_stack((r[keep] * np.cos(a[keep]), r[keep] * np.sin(a[keep])))
    logged = np.unique(np.asarray(scans[k]["points"], dtype=float), axis=0)
    assert len(logged) >= 10
    rl = np.hypot(logged[:, 0], logged[:, 1])
    d = np.hypot(*(logged[:, None, :] - got[None, :, :]).transpose(2, 0, 1))
    bound = rl * scan.angle_increment / 2 + 1e-5
    # every logged point is in the message (on its bearing), unless a nearer one hides it
    hidden = d.min(axis=1) > bound
    assert np.count_nonzero(hidden) <= 0.1 * len(logged)  # each one checked below
    b_logged = np.round((np.arctan2(logged[:, 1], logged[:, 0]) - scan.angle_min) / scan.angle_increment) % A1_BINS
    for i in np.flatnonzero(hidden):
        assert r[int(b_logged[i])] < rl[i]
    assert np.all(d.min(axis=0) <= np.hypot(got[:, 0], got[:, 1]) * scan.angle_increment / 2 + 1e-5)


def test_poses_paths_and_obstacles_decode_to_the_logged_values(run):
    from mcap.reader import make_reader
    from mcap_ros2.decoder import DecoderFactory

    records, mcap, _, _ = run
    scans = [r for r in records if r["event"] == "scan"]
    plan = next(r for r in records if r["event"] == "plan")
    with open(mcap, "rb") as f:
        dec: dict[str, list] = {}
        for _, ch, _, d in make_reader(f, decoder_factories=[DecoderFactory()]).iter_decoded_messages():
            dec.setdefault(ch.topic, []).append(d)
    for topic, key in (("/pose", "pose"), ("/truth", "truth")):
        got = [[m.pose.position.x, m.pose.position.y, _yaw(m.pose.orientation)] for m in dec[topic]]
        assert np.allclose(got, [r[key] for r in scans], atol=1e-9)
        assert all(m.header.frame_id == "odom" for m in dec[topic])
    path = [[p.pose.position.x, p.pose.position.y, _yaw(p.pose.orientation)] for p in dec["/plan"][0].poses]
    assert np.allclose(path, plan["path"], atol=1e-9)
    markers = dec["/obstacles"][0].markers
    assert markers[0].action == 3  # DELETEALL: the previous plan's boxes go
    boxes = [[[p.x, p.y] for p in m.points[:4]] for m in markers[1:]]
    assert np.allclose(boxes, plan["obstacles"], atol=1e-9)
    tf = dec["/tf"][5].transforms[0]
    assert (tf.header.frame_id, tf.child_frame_id) == ("odom", "base_link")
    assert [tf.transform.translation.x, tf.transform.translation.y] == pytest.approx(scans[5]["pose"][:2])


def test_convert_passes_over_records_it_does_not_know(tmp_path):
    """Logs grow new kinds of record (checks, recalls …): they are counted, not fatal."""
    log = tmp_path / "odd.jsonl"
    lines = [
        {"t": 0.0, "event": "run", "wall": 1700000000.0},
        {"t": 0.1, "event": "scan", "points": [[0.5, 0.0], [0.0, 0.5]], "goal": [1, 0], "pose": [0, 0, 0]},
        {"t": 0.2, "event": "check", "verdict": "ok", "states": 12},
        {"t": 0.3, "event": "plan", "error": "no scan"},
        {"t": 0.4, "event": "scan", "points": [], "goal": [1, 0]},
        {"t": 0.5, "event": "recall", "reason": "obstacle moved"},
    ]
    log.write_text("".join(json.dumps(x) + "\n" for x in lines) + '{"t": 0.6, "ev')  # cut mid-line
    r = clomp("convert", str(log), "--json")
    assert r.returncode == 0, r.stderr
    out = json.loads(r.stdout)
    assert out["mcap"] == str(log.with_suffix(".mcap"))
    assert out["messages"] == {"/scan": 2, "/pose": 1, "/tf": 1}
    assert out["skipped"] == {"check": 1, "plan": 1, "recall": 1}
    with LaserScanTopic(log.with_suffix(".mcap")) as topic:
        pts = [s.points() for s in topic]
    assert len(pts[0]) == 2 and len(pts[1]) == 0


def test_convert_errors_are_one_line(tmp_path):
    bad = tmp_path / "bad.jsonl"
    bad.write_text('{"t": 0, "event": "scan"}\nnot json\n{"t": 1, "event": "stop"}\n')
    empty = tmp_path / "empty.jsonl"
    empty.write_text("")
    ok = tmp_path / "ok.jsonl"
    ok.write_text('{"t": 0, "event": "stop"}\n')
    for args in ([str(tmp_path / "missing.jsonl")], [str(bad)], [str(empty)], [str(ok), "-o", str(tmp_path / "no" / "x.mcap")],
                 [str(ok), "-o", str(ok)], [str(ok), "--bins", "2"]):
        r = clomp("convert", *args)
        assert r.returncode == 2, (args, r.stderr)
        (line,) = r.stderr.strip().splitlines()
        assert line.startswith("clomp: error:")
    r = clomp("simulate", "--reactive", "--log", str(tmp_path / "r.jsonl"), "--out", str(tmp_path))
    assert r.returncode == 2 and "--log" in r.stderr


def test_write_mcap_takes_records_from_anywhere(tmp_path):
    recs = [{"t": 1.5, "event": "scan", "points": [[1.0, 0.0]], "pose": [0.1, 0.2, 0.3]}]
    s = write_mcap(recs, tmp_path / "a.mcap", bins=360, origin_ns=5 * 10**9)
    assert s.counts == {"/scan": 1, "/pose": 1, "/tf": 1}
    with LaserScanTopic(tmp_path / "a.mcap") as topic:
        (scan,) = list(topic)
    assert scan.time_ns == 6_500_000_000 and len(scan.ranges) == 360
    assert scan.points().round(6).tolist() == [[1.0, 0.0]]
