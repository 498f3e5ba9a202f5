"""LiDAR scans from ROS bags, without a ROS install: ``sensor_msgs/LaserScan`` → points.

Reads ROS 2 bags (a folder with ``metadata.yaml`` and sqlite3 or MCAP storage, or a
bare ``.mcap`` / ``.db3`` file) and ROS 1 ``.bag`` files through `rosbags
<https://pypi.org/project/rosbags/>`_ (pure Python; ``pip install -e '.[ros]'``).

A LaserScan becomes robot-frame points the way the planner takes a scan: reading
``i`` is at angle ``angle_min + i * angle_increment`` in the LiDAR's frame; a reading
that is not finite or lies outside ``[range_min, range_max]`` is *no return* (free
space up to the sensor's reach, never a point); the LiDAR's mounting pose on the robot
(x, y, θ; the paper's robot has it at the rotation centre, ``(0, 0, 0)``) moves the
points into the robot frame.

>>> import math
>>> laserscan_points(-math.pi / 2, math.pi / 2, [1.0, float("inf"), 0.5], 0.1, 10.0).round(3).tolist()
[[0.0, -1.0], [0.0, 0.5]]

Everything that can go wrong with a bag — no such file, not a bag, truncated, no such
topic, a topic of another type, rosbags not installed — is one :class:`BagError` whose
message is a single line (naming the topics that exist where that helps).
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from types import TracebackType
from typing import Any

import numpy as np

from clomp.formal.geometry import polar_to_xy

__all__ = [
    "BagError",
    "LaserScan",
    "LaserScanTopic",
    "LASERSCAN",
    "laserscan_points",
    "points_to_ranges",
    "bag_topics",
    "read_laserscans",
    "is_bag",
    "parse_offset",
]

LASERSCAN = "sensor_msgs/msg/LaserScan"

_INSTALL_HINT = "reading ROS bags needs rosbags: pip install -e '.[ros]' (from the clomp source folder, as in the README)"


class BagError(ValueError):
    """A bag cannot be read as asked; the message is one line."""


def parse_offset(text: str) -> tuple[float, float, float]:
    """``"0.05,0,3.1416"`` → (0.05, 0.0, 3.1416): the LiDAR's pose on the robot (m, m, rad).

    >>> parse_offset("0.1, 0, 0")
    (0.1, 0.0, 0.0)
    """
    try:
        parts = [float(p) for p in text.replace(" ", "").split(",")]
    except ValueError:
        raise BagError(f"--lidar-offset: expected X,Y,THETA (m, m, rad), got {text!r}") from None
    if len(parts) != 3 or not all(math.isfinite(p) for p in parts):
        raise BagError(f"--lidar-offset: expected three finite numbers X,Y,THETA (m, m, rad), got {text!r}")
    return parts[0], parts[1], parts[2]


def laserscan_points(
    angle_min: float,
    angle_increment: float,
    ranges: Sequence[float] | np.ndarray,
    range_min: float,
    range_max: float,
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0),
) -> np.ndarray:
    """The robot-frame points (N×2, metres) of one LaserScan's readings.

    A reading that is inf, NaN, below ``range_min`` or above ``range_max`` is no return.
    ``offset`` is the LiDAR's pose (x, y, θ) in the robot frame.

    >>> laserscan_points(0.0, math.pi / 2, [1.0, float("nan")], 0.1, 5.0, offset=(0.1, 0.0, math.pi)).round(3).tolist()
    [[-0.9, 0.0]]
    """
    if not (math.isfinite(angle_min) and math.isfinite(angle_increment)):
        raise BagError(f"a LaserScan needs finite angle_min and angle_increment, got {angle_min}, {angle_increment}")
    r = np.asarray(ranges, dtype=float).reshape(-1)
    a = angle_min + angle_increment * np.arange(len(r))
    lo = range_min if math.isfinite(range_min) else 0.0
    hi = range_max if not math.isnan(range_max) else math.inf
    keep = np.isfinite(r) & (r >= lo) & (r <= hi)
    r, a = r[keep], a[keep] + offset[2]
    pts = polar_to_xy(r, a)
    if offset[0] or offset[1]:
        pts += (offset[0], offset[1])
    return pts


def points_to_ranges(
    points: np.ndarray, angle_min: float, angle_increment: float, count: int, range_max: float = math.inf,
) -> np.ndarray:
    """The LaserScan ``ranges`` (float32, inf = no return) that a LiDAR at the robot's
    origin would report for ``points``: each point falls in the reading of its nearest
    angle, and a reading keeps the nearest of its points (what a LiDAR sees).

    >>> points_to_ranges(np.array([[1.0, 0.0], [2.0, 0.0], [0.0, 0.5]]), 0.0, math.pi / 2, 4).tolist()
    [1.0, 0.5, inf, inf]
    """
    pts = np.asarray(points, dtype=float).reshape(-1, 2)
    out = np.full(count, np.inf, dtype=np.float32)
    if len(pts) == 0:
        return out
    r = np.hypot(pts[:, 0], pts[:, 1])
    a = np.arctan2(pts[:, 1], pts[:, 0])
    k = np.round((a - angle_min) / angle_increment).astype(np.int64)
    full = round(2 * math.pi / angle_increment)
    if full > 0:
        k = np.where(k < 0, k + full, k)
        k = np.where(k >= full, k - full, k)
    keep = (k >= 0) & (k < count) & (r <= range_max) & (r > 0)
    np.minimum.at(out, k[keep], r[keep].astype(np.float32))
    return out


@dataclass(frozen=True)
class LaserScan:
    """One ``sensor_msgs/LaserScan`` message as recorded, with where it is in the bag.

    >>> s = LaserScan(0, 0, 0, "laser", 0.0, math.pi / 2, 0.05, 10.0, np.array([1.0, np.inf], np.float32))
    >>> s.points().round(3).tolist()
    [[1.0, 0.0]]
    """

    index: int  #: position on its topic, from 0
    time_ns: int  #: the bag's timestamp (when it was recorded)
    stamp_ns: int  #: ``header.stamp``
    frame_id: str
    angle_min: float
    angle_increment: float
    range_min: float
    range_max: float
    ranges: np.ndarray = field(repr=False)

    def points(self, offset: tuple[float, float, float] = (0.0, 0.0, 0.0)) -> np.ndarray:
        """Robot-frame points of this scan (see :func:`laserscan_points`)."""
        return laserscan_points(self.angle_min, self.angle_increment, self.ranges, self.range_min,
                                self.range_max, offset)


def _rosbags() -> Any:
    try:
        import rosbags  # noqa: F401
    except ImportError:
        raise BagError(_INSTALL_HINT) from None
    return rosbags


def is_bag(path: str | os.PathLike[str]) -> bool:
    """True when ``path`` looks like a ROS bag: a ``.bag``, ``.mcap`` or ``.db3`` file, or a
    folder with ``metadata.yaml``.

    >>> is_bag("run.bag"), is_bag("rec.mcap"), is_bag("map0001.dat")
    (True, True, False)
    """
    p = Path(path)
    try:
        return p.suffix in (".bag", ".mcap", ".db3") or (p.is_dir() and (p / "metadata.yaml").is_file())
    except OSError:  # an unreadable folder: not a bag that can be read (its reader says why)
        return False


#: ``--time`` beyond this many seconds after a bag's first scan is refused: a year
_MAX_BAG_SECONDS = 366 * 86400.0


class _Bag:
    """The messages and connections of one bag, whatever its kind."""

    def __init__(self, path: Path) -> None:
        _rosbags()
        from rosbags.typesys import Stores, get_typestore

        self.path = path
        self._any: Any = None
        self._storage: Any = None
        self._typestore = get_typestore(Stores.LATEST)
        if not path.exists():
            raise BagError(f"{path}: no such file or folder")
        if path.is_dir() and not (path / "metadata.yaml").is_file():
            raise BagError(f"{path}: not a ROS bag (a ROS 2 bag folder has a metadata.yaml)")
        if path.is_file() and path.suffix in (".mcap", ".db3") and (path.parent / "metadata.yaml").is_file():
            path = path.parent  # a storage file inside its bag folder: read the bag
        try:
            if path.is_dir() or path.suffix == ".bag":
                from rosbags.highlevel import AnyReader

                self._any = AnyReader([path], default_typestore=self._typestore)
                self._any.open()
                self.connections = list(self._any.connections)
            elif path.suffix == ".mcap":
                from rosbags.rosbag2.storage_mcap import McapReader

                self._storage = McapReader(path)
                self._storage.open()
                self.connections = list(self._storage.connections)
            elif path.suffix == ".db3":
                from rosbags.rosbag2.storage_sqlite3 import Sqlite3Reader

                self._storage = Sqlite3Reader(path)
                self._storage.open()
                self.connections = list(self._storage.connections)
            else:
                raise BagError(f"{path}: not a ROS bag (expected a ROS 2 bag folder, a .mcap or .db3 file, or a ROS 1 .bag)")
        except BagError:
            raise
        except Exception as exc:  # rosbags, apsw, lz4, struct … raise many kinds for a bad file
            self.close()
            raise BagError(f"{path}: cannot read the bag: damaged, truncated or not a bag ({_one_line(exc)})") from None

    def messages(self, connections: list[Any]) -> Iterator[tuple[Any, int, bytes]]:
        src = self._any.messages(connections=connections) if self._any else self._storage.messages(connections)
        try:
            yield from src
        except Exception as exc:
            raise BagError(f"{self.path}: cannot read the bag past a point ({_one_line(exc)}); truncated?") from None

    def deserialize(self, raw: bytes, msgtype: str) -> Any:
        try:
            if self._any is not None:
                return self._any.deserialize(raw, msgtype)
            return self._typestore.deserialize_cdr(raw, msgtype)
        except Exception as exc:
            raise BagError(f"{self.path}: a {msgtype} message cannot be decoded ({_one_line(exc)})") from None

    def close(self) -> None:
        for r in (self._any, self._storage):
            if r is not None:
                try:
                    r.close()
                except Exception:  # closing a half-open reader: nothing left to save
                    pass
        self._any = self._storage = None


def _one_line(exc: BaseException) -> str:
    text = " ".join(str(exc).split()) or type(exc).__name__
    return text if len(text) <= 200 else text[:197] + "..."


def _topics_text(connections: list[Any]) -> str:
    seen: dict[str, str] = {}
    for c in connections:
        seen.setdefault(c.topic, c.msgtype)
    return ", ".join(f"{t} ({m})" for t, m in sorted(seen.items())) or "none"


def bag_topics(path: str | os.PathLike[str]) -> dict[str, str]:
    """Topic → message type of every topic in a bag.

    >>> bag_topics("missing.bag")
    Traceback (most recent call last):
    clomp.runtime.records.bags.BagError: missing.bag: no such file or folder
    """
    bag = _Bag(Path(path))
    try:
        return {c.topic: c.msgtype for c in bag.connections}
    finally:
        bag.close()


class LaserScanTopic:
    """The LaserScan messages on one topic of a bag, in time order.

    Opening checks the topic (it exists and carries LaserScan; else :class:`BagError`
    naming the topics there are). ``count`` is the number of messages; iterate for the
    scans; :meth:`at_index` and :meth:`at_time` pick one.

    >>> import tempfile, pathlib
    >>> from clomp.runtime.records.mcap_writer import write_mcap
    >>> bag = pathlib.Path(tempfile.mkdtemp()) / "run.mcap"
    >>> _ = write_mcap([{"t": 0.2 * k, "event": "scan", "points": [[1.0, 0.1 * k]]} for k in range(3)], bag)
    >>> with LaserScanTopic(bag, "/scan") as topic:
    ...     topic.count, topic.at_time(0.3).index, topic.at_index(2).points().round(2).tolist()
    (3, 1, [[1.0, 0.2]])
    >>> LaserScanTopic(bag, "/nosuch")
    Traceback (most recent call last):
    clomp.runtime.records.bags.BagError: ...: no topic /nosuch; topics in the bag: /scan (sensor_msgs/msg/LaserScan)
    """

    def __init__(self, path: str | os.PathLike[str], topic: str | None = None) -> None:
        self.path = Path(path)
        self._bag = _Bag(self.path)
        everything = self._bag.connections
        if topic is None:  # the bag's only LaserScan topic
            scans = sorted({c.topic for c in everything if c.msgtype == LASERSCAN})
            if len(scans) != 1:
                self._bag.close()
                if not scans:
                    raise BagError(f"{self.path}: no {LASERSCAN} topic; topics in the bag: {_topics_text(everything)}")
                raise BagError(f"{self.path}: several LaserScan topics, choose one with --topic: {', '.join(scans)}")
            topic = scans[0]
        self.topic = topic
        conns = [c for c in everything if c.topic == topic]
        if not conns:
            self._bag.close()
            raise BagError(f"{self.path}: no topic {topic}; topics in the bag: {_topics_text(everything)}")
        wrong = sorted({c.msgtype for c in conns if c.msgtype != LASERSCAN})
        if wrong:
            scans = sorted({c.topic for c in everything if c.msgtype == LASERSCAN})
            self._bag.close()
            hint = f"LaserScan topics: {', '.join(scans)}" if scans else "the bag has no LaserScan topic"
            raise BagError(f"{self.path}: topic {topic} carries {', '.join(wrong)}, not {LASERSCAN}; {hint}")
        self._conns = conns
        self.count = int(sum(getattr(c, "msgcount", 0) or 0 for c in conns))

    def __iter__(self) -> Iterator[LaserScan]:
        for k, (conn, t_ns, raw) in enumerate(self._bag.messages(self._conns)):
            msg = self._bag.deserialize(raw, conn.msgtype)
            yield _scan(k, t_ns, msg)

    def start_ns(self) -> int | None:
        """The bag time of the first message on the topic (None when it has none)."""
        for _, t_ns, _ in self._bag.messages(self._conns):
            return int(t_ns)
        return None

    def at_index(self, index: int) -> LaserScan:
        """The ``index``-th scan (from 0; negative counts from the end)."""
        if index < 0:
            index += self.count
        if index < 0:
            raise BagError(f"--index: {self.topic} has {self.count} scans")
        for s in self:
            if s.index == index:
                return s
        raise BagError(f"--index {index}: {self.topic} has {self.count} scans (0 … {self.count - 1})")

    def at_time(self, seconds: float) -> LaserScan:
        """The scan nearest to ``seconds`` after the topic's first message (bag time)."""
        if not math.isfinite(seconds) or seconds < 0:
            raise BagError(f"--time: expected seconds >= 0 from the first scan, got {seconds}")
        if seconds > _MAX_BAG_SECONDS:
            raise BagError(f"--time: {seconds:g} s is beyond any recording (the limit is {_MAX_BAG_SECONDS:g} s, a year)")
        t0 = self.start_ns()
        if t0 is None:
            raise BagError(f"{self.path}: topic {self.topic} has no messages")
        want = t0 + round(seconds * 1e9)
        best: LaserScan | None = None
        for s in self:
            if best is None or abs(s.time_ns - want) < abs(best.time_ns - want):
                best = s
            if s.time_ns > want:
                break
        assert best is not None
        return best

    def close(self) -> None:
        """Close the bag."""
        self._bag.close()

    def __enter__(self) -> "LaserScanTopic":
        return self

    def __exit__(self, exc_type: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:
        self.close()


def _scan(index: int, t_ns: int, msg: Any) -> LaserScan:
    stamp = msg.header.stamp
    return LaserScan(
        index=index,
        time_ns=int(t_ns),
        stamp_ns=int(stamp.sec) * 1_000_000_000 + int(getattr(stamp, "nanosec", getattr(stamp, "nsec", 0))),
        frame_id=str(msg.header.frame_id),
        angle_min=float(msg.angle_min),
        angle_increment=float(msg.angle_increment),
        range_min=float(msg.range_min),
        range_max=float(msg.range_max),
        ranges=np.asarray(msg.ranges, dtype=np.float32),
    )


def read_laserscans(path: str | os.PathLike[str], topic: str | None = None) -> Iterator[LaserScan]:
    """Every LaserScan on ``topic`` (default: the bag's only LaserScan topic) of the bag
    at ``path``, in time order."""
    with LaserScanTopic(path, topic) as scans:
        yield from scans
