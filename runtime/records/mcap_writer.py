"""A run log as MCAP with ROS 2 message types, for Foxglove, rviz and ``ros2 bag play``.

One channel per kind of record, CDR-encoded with ``ros2msg`` schemas (the MCAP "ros2"
profile, what ``ros2 bag record -s mcap`` writes), messages stamped with the log's times
(seconds since the run started, on the run's wall-clock start when the log has it):

==============  ===================================  ==========================================
topic           type                                 from
==============  ===================================  ==========================================
``/scan``       ``sensor_msgs/msg/LaserScan``        every ``scan`` record (frame ``base_link``)
``/pose``       ``geometry_msgs/msg/PoseStamped``    the pose estimate of every ``scan`` record
``/truth``      ``geometry_msgs/msg/PoseStamped``    the ground truth beside a scan (simulated runs)
``/tf``         ``tf2_msgs/msg/TFMessage``           ``odom`` → ``base_link`` at every scan
``/plan``       ``nav_msgs/msg/Path``                every ``plan`` record with a path
``/obstacles``  ``visualization_msgs/msg/MarkerArray``  the perceived boxes of every plan
``/goal``       ``geometry_msgs/msg/PoseStamped``    the ``start`` record's goal
==============  ===================================  ==========================================

A scan's points become ``ranges`` on a bearing grid of ``bins`` readings over the full
circle (default the RPLIDAR A1's 1/64°), so a point moves by at most r·π/bins sideways;
of two points on one bearing the nearer is kept, as a LiDAR would. Records of other
kinds, and keys this writer does not know, are passed over (logs grow new kinds).

Needs ``rosbags`` and ``mcap`` (``pip install 'clomp[ros]'``).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from clomp.runtime.records.bags import points_to_ranges

__all__ = ["ConvertError", "McapSummary", "write_mcap", "TOPICS", "A1_BINS", "MAX_BINS"]

A1_BINS = 360 * 64  #: the RPLIDAR A1's angular resolution: 1/64°

TOPICS: dict[str, str] = {
    "/scan": "sensor_msgs/msg/LaserScan",
    "/pose": "geometry_msgs/msg/PoseStamped",
    "/truth": "geometry_msgs/msg/PoseStamped",
    "/tf": "tf2_msgs/msg/TFMessage",
    "/plan": "nav_msgs/msg/Path",
    "/obstacles": "visualization_msgs/msg/MarkerArray",
    "/goal": "geometry_msgs/msg/PoseStamped",
}


class ConvertError(ValueError):
    """A log cannot be converted (one line)."""


@dataclass
class McapSummary:
    """What :func:`write_mcap` wrote: messages per topic, and the records passed over."""

    path: Path
    counts: dict[str, int] = field(default_factory=dict)
    skipped: dict[str, int] = field(default_factory=dict)


def _imports() -> tuple[Any, Any]:
    try:
        from mcap.writer import CompressionType, Writer
        from rosbags.typesys import Stores, get_typestore
    except ImportError:
        raise ConvertError("writing MCAP needs rosbags and mcap: pip install 'clomp[ros]'") from None
    return (Writer, CompressionType), get_typestore(Stores.ROS2_HUMBLE)


class _Out:
    """The MCAP writer with one channel per topic, registered on first use."""

    def __init__(self, fh: Any, typestore: Any, writer_cls: Any, compression: Any) -> None:
        self.ts = typestore
        self.w = writer_cls(fh, compression=compression.ZSTD)
        self.w.start(profile="ros2", library="clomp")
        self.channels: dict[str, int] = {}
        self.schemas: dict[str, int] = {}
        self.counts: dict[str, int] = {}

    def write(self, topic: str, t_ns: int, msg: Any) -> None:
        msgtype = TOPICS[topic]
        if topic not in self.channels:
            if msgtype not in self.schemas:
                text, _ = self.ts.generate_msgdef(msgtype, ros_version=2)
                self.schemas[msgtype] = self.w.register_schema(name=msgtype, encoding="ros2msg", data=text.encode())
            self.channels[topic] = self.w.register_channel(topic=topic, message_encoding="cdr",
                                                           schema_id=self.schemas[msgtype])
        n = self.counts.get(topic, 0)
        self.w.add_message(channel_id=self.channels[topic], log_time=t_ns, publish_time=t_ns, sequence=n,
                           data=bytes(self.ts.serialize_cdr(msg, msgtype)))
        self.counts[topic] = n + 1

    # -- message builders -----------------------------------------------------------------
    def header(self, t_ns: int, frame: str) -> Any:
        T = self.ts.types["builtin_interfaces/msg/Time"]
        return self.ts.types["std_msgs/msg/Header"](stamp=T(sec=t_ns // 10**9, nanosec=t_ns % 10**9), frame_id=frame)

    def pose(self, p: list[float], z: float = 0.0) -> Any:
        t = self.ts.types
        th = float(p[2]) if len(p) > 2 else 0.0
        return t["geometry_msgs/msg/Pose"](
            position=t["geometry_msgs/msg/Point"](x=float(p[0]), y=float(p[1]), z=z),
            orientation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
        )

    def pose_stamped(self, t_ns: int, p: list[float]) -> Any:
        return self.ts.types["geometry_msgs/msg/PoseStamped"](header=self.header(t_ns, "odom"), pose=self.pose(p))

    def transform(self, t_ns: int, p: list[float]) -> Any:
        t = self.ts.types
        th = float(p[2])
        tf = t["geometry_msgs/msg/TransformStamped"](
            header=self.header(t_ns, "odom"), child_frame_id="base_link",
            transform=t["geometry_msgs/msg/Transform"](
                translation=t["geometry_msgs/msg/Vector3"](x=float(p[0]), y=float(p[1]), z=0.0),
                rotation=t["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=math.sin(th / 2), w=math.cos(th / 2)),
            ),
        )
        return t["tf2_msgs/msg/TFMessage"](transforms=[tf])

    def laserscan(self, t_ns: int, points: np.ndarray, bins: int, range_max: float) -> Any:
        inc = 2 * math.pi / bins
        return self.ts.types["sensor_msgs/msg/LaserScan"](
            header=self.header(t_ns, "base_link"), angle_min=-math.pi, angle_max=-math.pi + inc * (bins - 1),
            angle_increment=inc, time_increment=0.0, scan_time=0.0, range_min=0.0, range_max=range_max,
            ranges=points_to_ranges(points, -math.pi, inc, bins, range_max), intensities=np.zeros(0, np.float32),
        )

    def path(self, t_ns: int, poses: list[list[float]]) -> Any:
        return self.ts.types["nav_msgs/msg/Path"](header=self.header(t_ns, "odom"),
                                                  poses=[self.pose_stamped(t_ns, p) for p in poses])

    def markers(self, t_ns: int, boxes: list[Any]) -> Any:
        t = self.ts.types
        M = t["visualization_msgs/msg/Marker"]
        D = t["builtin_interfaces/msg/Duration"]
        colour = t["std_msgs/msg/ColorRGBA"]

        def marker(ident: int, action: int, pts: list[Any]) -> Any:
            return M(
                header=self.header(t_ns, "odom"), ns="obstacles", id=ident, type=M.LINE_STRIP, action=action,
                pose=self.pose([0.0, 0.0, 0.0]), scale=t["geometry_msgs/msg/Vector3"](x=0.01, y=0.0, z=0.0),
                color=colour(r=1.0, g=0.35, b=0.1, a=1.0), lifetime=D(sec=0, nanosec=0), frame_locked=False,
                points=[t["geometry_msgs/msg/Point"](x=float(x), y=float(y), z=0.0) for x, y in pts],
                colors=[], texture_resource="", texture=t["sensor_msgs/msg/CompressedImage"](
                    header=self.header(0, ""), format="", data=np.zeros(0, np.uint8)),
                uv_coordinates=[], text="", mesh_resource="",
                mesh_file=t["visualization_msgs/msg/MeshFile"](filename="", data=np.zeros(0, np.uint8)),
                mesh_use_embedded_materials=False,
            )

        out = [marker(0, M.DELETEALL, [])]  # the previous plan's boxes go
        for k, box in enumerate(boxes, 1):
            corners = [tuple(c) for c in box]
            out.append(marker(k, M.ADD, [*corners, corners[0]]))
        return t["visualization_msgs/msg/MarkerArray"](markers=out)


def _finite(x: Any, bound: float = 1e9) -> bool:
    """A number (not a bool), finite and within ``bound`` of 0 (metres, seconds)."""
    return isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and abs(x) <= bound


def _seconds(x: Any, bound: float) -> float | None:
    """``x`` as seconds from 0 to ``bound``, or None."""
    return float(x) if _finite(x, bound) and x >= 0 else None


def _pose3(v: Any) -> list[float] | None:
    if isinstance(v, list) and len(v) >= 2 and all(_finite(x) for x in v[:3]):
        return [float(x) for x in v[:3]] + [0.0] * (3 - len(v[:3]))
    return None


def _box(b: Any) -> bool:
    """True for an obstacle box of a plan record: four [x, y] corners of finite numbers."""
    return isinstance(b, list) and len(b) == 4 and all(isinstance(c, list) and len(c) == 2 and all(_finite(x) for x in c) for c in b)


#: at most this many LaserScan readings per revolution (4 × the A1's 1/64°)
MAX_BINS = 4 * A1_BINS
#: the latest wall-clock origin a log may give (Unix time, s): the year 2100
MAX_WALL_S = 4.1e9


def write_mcap(
    records: Iterable[dict[str, Any]],
    dest: str | os.PathLike[str],
    *,
    bins: int = A1_BINS,
    range_max: float = 12.0,
    origin_ns: int | None = None,
) -> McapSummary:
    """Write the run-log ``records`` (see :func:`clomp.runtime.records.runlog.read_log`) to
    ``dest`` as MCAP; see the module docstring for the topics.

    ``origin_ns``: the time of ``t = 0`` (default: the ``run`` record's ``wall`` time,
    else 0).

    >>> import tempfile, pathlib
    >>> log = [{"t": 0.0, "event": "run", "wall": 1.7e9}, {"t": 0.1, "event": "scan", "points": [[0.5, 0.0]],
    ...        "pose": [0.0, 0.0, 0.0]}, {"t": 0.2, "event": "recall"}]
    >>> s = write_mcap(log, pathlib.Path(tempfile.mkdtemp()) / "run.mcap")
    >>> s.counts, s.skipped
    ({'/scan': 1, '/pose': 1, '/tf': 1}, {'recall': 1})
    """
    if not 8 <= bins <= MAX_BINS:
        raise ConvertError(f"--bins: from 8 to {MAX_BINS:,} readings per revolution, got {bins:,}")
    (writer_cls, compression), ts = _imports()
    dest = Path(dest)
    summary = McapSummary(dest)
    try:
        fh = open(dest, "wb")
    except OSError as exc:
        raise ConvertError(f"cannot write {dest}: {exc.strerror or exc}") from None
    try:
        with fh:
            out = _write_all(fh, records, ts, writer_cls, compression, summary, bins, range_max, origin_ns)
    except OSError as exc:  # a full disk, /dev/full, an I/O error mid-write
        raise ConvertError(f"cannot write {dest}: {exc.strerror or exc}") from None
    summary.counts = dict(out.counts)
    return summary


def _write_all(fh: Any, records: Iterable[dict[str, Any]], ts: Any, writer_cls: Any, compression: Any,
               summary: McapSummary, bins: int, range_max: float, origin_ns: int | None) -> _Out:
    """Write every record to the open file ``fh``; the counts of what was passed over go to ``summary``."""
    out = _Out(fh, ts, writer_cls, compression)
    base = origin_ns
    for rec in records:
        kind = rec.get("event")
        if base is None:
            wall = rec.get("wall") if kind == "run" else None
            wall_s = _seconds(wall, MAX_WALL_S)
            base = 0 if wall_s is None else int(round(wall_s * 1e9))
        t = _seconds(rec.get("t"), 1e9)
        if t is None:
            summary.skipped[str(kind)] = summary.skipped.get(str(kind), 0) + 1
            continue
        t_ns = base + int(round(t * 1e9))
        if not _write_record(out, kind, rec, t_ns, bins, range_max):
            summary.skipped[str(kind)] = summary.skipped.get(str(kind), 0) + 1
    out.w.finish()
    return out


def _write_record(out: _Out, kind: Any, rec: dict[str, Any], t_ns: int, bins: int, range_max: float) -> bool:
    """Write what ``rec`` shows; False when it shows nothing this writer knows."""
    if kind == "scan":
        try:
            pts = np.asarray(rec.get("points") or [], dtype=float).reshape(-1, 2)
        except (TypeError, ValueError):
            return False
        if not np.all(np.isfinite(pts)):
            return False
        out.write("/scan", t_ns, out.laserscan(t_ns, pts, bins, range_max))
        pose = _pose3(rec.get("pose"))
        if pose is not None:
            out.write("/pose", t_ns, out.pose_stamped(t_ns, pose))
            out.write("/tf", t_ns, out.transform(t_ns, pose))
        truth = _pose3(rec.get("truth"))
        if truth is not None:
            out.write("/truth", t_ns, out.pose_stamped(t_ns, truth))
        return True
    if kind == "plan":
        path = rec.get("path")
        if not isinstance(path, list):
            return False  # a plan record without geometry (an older log, or a planning error)
        poses = [p for p in (_pose3(q) for q in path) if p is not None]
        out.write("/plan", t_ns, out.path(t_ns, poses))
        boxes = rec.get("obstacles")
        if isinstance(boxes, list):
            ok = [b for b in boxes if _box(b)]
            out.write("/obstacles", t_ns, out.markers(t_ns, ok))
        return True
    if kind == "start":
        goal = rec.get("goal")
        if isinstance(goal, list) and len(goal) == 2 and all(_finite(x) for x in goal):
            out.write("/goal", t_ns, out.pose_stamped(t_ns, [float(goal[0]), float(goal[1]), 0.0]))
            return True
        return False
    return kind in ("run", "state", "task", "motor", "fault", "stop", "device")

