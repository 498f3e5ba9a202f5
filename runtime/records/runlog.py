"""The run log: every scan, plan, task change, motor command and fault as JSON lines.

One JSON object per line, flushed as it is written, so that a run cut short loses
nothing already seen. Every record has ``t`` (seconds since the log was opened, from a
monotonic clock; simulated time in a simulated run's log) and ``event``; the other keys
depend on the event:

=========  ==============================================================================
event      keys
=========  ==============================================================================
run        ``argv``, ``lidar``, ``motors`` (ports), ``dry_run``, ``goal``, ``config``,
           ``monotonic`` (the clock origin, to line log times up with other clocks),
           ``wall`` (Unix time when the log was opened); from ``clomp simulate``:
           ``scenario``, ``condition``, ``seed``, ``noise``, ``simulated`` (true)
start      ``goal`` [x, y] (odometry frame), ``robot`` (RobotModel as a dict)
device     ``device``, ``port``, and what the device reported (LiDAR info and health)
scan       ``points`` [[x, y], …] (robot frame, metres), ``goal`` [x, y] (robot frame),
           ``pose`` [x, y, theta] (odometry); simulated: ``truth`` [x, y, theta] (the
           ground truth in the odometry frame)
plan       ``reached_goal``, ``states``, ``transitions``, ``planning_time_s``, ``tasks``,
           ``origin`` (odometry pose planned from), ``path`` [[x, y, theta], …] (the
           plan's states, odometry frame), ``obstacles`` [[[x, y] × 4], …] (perceived
           boxes, odometry frame)
state      ``from``, ``to`` (supervisor states)
task       ``task``, ``phase`` (start / end / interrupted), ``pose``; simulated: ``truth``
motor      ``left``, ``right`` (m/s); from the hardware robot also ``sent`` (what reached
           the Maestro), ``dry_run``, ``reason`` and ``error``
fault      ``reason``, ``source`` (lidar, motors, control, start, run …)
stop       ``reason``, ``status``
=========  ==============================================================================

Readers ignore keys they do not know, so records may carry more than listed here.
"""

from __future__ import annotations

import json
import math
import os
import time
from collections.abc import Iterator
from pathlib import Path
from typing import IO, Any, Protocol

import numpy as np

from clomp.planner.inputs import json_lines

__all__ = ["MAX_LOG_TIME_S", "RunLog", "RunLogLike", "LogError", "enumerate_records", "read_log", "scans_from_log", "plan_fields"]


class RunLogLike(Protocol):
    """Where the supervisor and the robots record what they do (e.g. :class:`RunLog`)."""

    def write(self, event: str, **fields: Any) -> None:
        """Append one record."""
        ...


def plan_fields(result: Any, origin: Any) -> dict[str, Any]:
    """The keys of a ``plan`` record for a :class:`clomp.planner.PlanResult` planned from the
    odometry pose ``origin`` (a :class:`clomp.formal.model.Pose`): the outcome, and where the
    plan goes and what it avoids in the odometry frame (what a viewer draws).

    >>> import numpy as np
    >>> from clomp.formal.model import Pose
    >>> from clomp.planner import Configurator
    >>> f = plan_fields(Configurator().plan(np.zeros((0, 2)), (0.5, 0.0)), Pose(1.0, 0.0, 0.0))
    >>> f["tasks"], f["path"][-1], f["obstacles"].shape
    (['STRAIGHT'], [1.5, 0.0, 0.0], (0, 4, 2))
    """
    from clomp.formal.geometry import compose, points_from_frame

    boxes = np.asarray(result.obstacles.boxes, dtype=float).reshape(-1, 2)
    return {
        "reached_goal": result.reached_goal,
        "states": result.n_states,
        "transitions": result.transitions,
        "planning_time_s": result.planning_time_s,
        "tasks": [q.task.value for q in result.steps],
        "origin": origin.as_list(),
        "path": [compose(origin, result.map[i].end).as_list() for i in result.plan.states],
        "obstacles": np.round(points_from_frame(boxes, origin), 4).reshape(-1, 4, 2),
    }


class LogError(ValueError):
    """A run log cannot be read (names the line)."""


def _clean(value: Any) -> Any:
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, np.ndarray):
        return _clean(value.tolist())
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (np.floating, np.integer)):
        return _clean(value.item())
    return value


class RunLog:
    """Append-only JSON-lines writer, flushed (and fsync'ed for faults) per record.

    >>> import io
    >>> buf = io.StringIO()
    >>> log = RunLog(buf)
    >>> log.write("fault", reason="LiDAR unplugged", source="lidar")
    >>> json.loads(buf.getvalue())["event"]
    'fault'
    """

    def __init__(self, dest: str | os.PathLike[str] | IO[str], clock: Any = None) -> None:
        """``clock``: anything with ``now()`` in seconds (a simulated robot keeps simulated
        time, so a simulated run's log has the simulated times); default a monotonic clock."""
        self._now: Any = clock.now if clock is not None else time.monotonic
        if hasattr(dest, "write"):
            self._fh: IO[str] = dest  # type: ignore[assignment]
            self._own = False
            self.path: Path | None = None
        else:
            self.path = Path(dest)
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._fh = open(self.path, "a", encoding="utf-8", buffering=1)
            self._own = True
        self._t0 = self._now()

    def write(self, event: str, **fields: Any) -> None:
        """Append one record and flush it."""
        rec = {"t": round(self._now() - self._t0, 6), "event": event, **_clean(fields)}
        self._fh.write(json.dumps(rec, allow_nan=False) + "\n")
        self._fh.flush()
        if event in ("fault", "stop") and self._own:
            try:
                os.fsync(self._fh.fileno())
            except OSError:
                pass

    def close(self) -> None:
        """Close the file (when the log opened it)."""
        if self._own and not self._fh.closed:
            self._fh.close()

    def __enter__(self) -> "RunLog":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def read_log(src: str | os.PathLike[str]) -> Iterator[dict[str, Any]]:
    """The records of a run log, in order, read one line at a time (bounded memory,
    :func:`clomp.planner.inputs.json_lines`: special files refused, a record at most
    :data:`~clomp.planner.inputs.MAX_LINE_BYTES`, JSON depth and numbers limited). A
    truncated last line (a run cut short mid-write) is skipped; any other malformed line,
    or a record without an ``event`` or with a ``t`` that is not a finite number, raises
    :class:`LogError` naming the line.

    >>> import tempfile
    >>> path = Path(tempfile.mkdtemp()) / "run.jsonl"
    >>> with RunLog(path) as log:
    ...     log.write("stop", reason="done", status=0)
    >>> [(r["event"], r["reason"]) for r in read_log(path)]
    [('stop', 'done')]
    """
    for _, rec in enumerate_records(Path(src)):
        yield rec


#: the largest time a run log's record may carry (s): a year
MAX_LOG_TIME_S = 366 * 86400.0


def _short(value: Any) -> str:
    text = repr(value)
    return text if len(text) <= 60 else text[:60] + "…"


def _goal(rec: dict[str, Any], where: str) -> tuple[float, float] | None:
    goal = rec.get("goal")
    if goal is None:
        return None
    if (not isinstance(goal, list) or len(goal) != 2
            or not all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in goal)):
        raise LogError(f"{where}: field 'goal': expected [x, y] in metres, got {_short(goal)}")
    return float(goal[0]), float(goal[1])


def scans_from_log(src: str | os.PathLike[str]) -> Iterator[tuple[str, Any, tuple[float, float] | None]]:
    """(label, points, goal in the robot frame or None) for every scan record of a log,
    streamed. ``points`` is an N×2 array, or — for a record whose points are no scan — a
    callable raising that scan's :class:`~clomp.planner.ScanError` (a many-scan run
    records it and goes on); a bad ``goal`` is a :class:`LogError` naming the line."""
    from clomp.planner.scanfile import ScanError, validate_scan

    path = Path(src)
    k = 0
    for n, rec in enumerate_records(path):
        if rec["event"] != "scan":
            continue
        k += 1
        where = f"{path}:{n}"
        g = _goal(rec, where)
        label = f"scan{k:04d}@{rec.get('t', 0):.3f}s"
        try:
            pts: Any = validate_scan(rec.get("points") or np.zeros((0, 2)), f"{where}: field 'points'")
        except ScanError as exc:
            pts = _raiser(exc)
        yield label, pts, g


def _raiser(exc: Exception) -> Any:
    def fail() -> Any:
        raise exc
    return fail


def enumerate_records(path: Path) -> Iterator[tuple[int, dict[str, Any]]]:
    """(line number, record) of every record of the run log at ``path`` (see :func:`read_log`)."""
    for n, rec in json_lines(path, "run log", LogError):
        if not isinstance(rec, dict) or "event" not in rec:
            raise LogError(f"{path}:{n}: a record needs an 'event' key")
        t = rec.get("t", 0.0)
        if isinstance(t, bool) or not isinstance(t, (int, float)) or not 0 <= t <= MAX_LOG_TIME_S:
            raise LogError(f"{path}:{n}: field 't': expected seconds from 0 to {MAX_LOG_TIME_S:g}, got {_short(t)}")
        yield n, rec
