"""Helpers shared by the subcommands: the scene ``--scenario`` names (:func:`load_scene`), a
log's records (:func:`log_records`), the per-scan outcome of ``clomp plan`` (folders, bags)
and ``clomp replay``, and the summary of such a run.

:func:`scan_outcomes` plans on one scan and never raises for the scan's own faults, so a
many-scan run never stops at one scan; :func:`many_summary` counts the outcomes. The
commands differ only in the lines they print.

>>> import numpy as np
>>> from clomp.planner import Configurator
>>> conf = Configurator()
>>> [scan_outcomes(conf, s, g)[1]["outcome"] for s, g in
...  [(np.zeros((0, 2)), (1.0, 0.0)), (np.zeros((0, 2)), (0.0, 0.0)), (np.full((1, 2), np.nan), (1.0, 0.0))]]
['goal', 'at_goal', 'error']
>>> many_summary(["goal", "error"], [0.01])["error"]
1
"""

from __future__ import annotations

import argparse
import itertools
import math
import os
import stat
import warnings
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np

from clomp.planner import Configurator, PlanningError, PlanResult, ScanError, load_scan, scan_files
from clomp.planner.deepening import plan_deepening
from clomp.planner.inputs import InputError, check_output
from clomp.planner.perception import ScanWarning
from clomp.planner.units import UNITS, ScanUnitsError, in_metres
from clomp.planner.scenarios import Scene, ScenarioError, load_scenario
from clomp.runtime.cli import CliError, plural
from clomp.runtime.records.runlog import LogError

__all__ = ["Notes", "add_mover_options", "add_units_option", "folder_scans", "load_scene", "log_records", "many_summary", "output_folder", "output_path",
           "path_kind", "read_points", "scan_outcomes", "scene_movers", "summary_line"]

T = TypeVar("T")


def load_scene(scenario: str) -> Scene:
    """The scene ``--scenario NAME|FILE`` names (a built-in scenario or a scenario JSON file),
    for every command that takes one; a scenario that cannot be loaded is one CliError line.

    >>> load_scene("open").name
    'open'
    >>> load_scene("atlantis")
    Traceback (most recent call last):
    clomp.runtime.cli.CliError: unknown scenario 'atlantis'; built in: ...
    """
    try:
        return load_scenario(scenario)
    except ScenarioError as exc:
        raise CliError(str(exc)) from None


def add_mover_options(p: Any, movers: bool = True) -> None:
    """``--moving`` (WAIT and REVERSE on: a world that moves, issue #42) and, with ``movers``,
    ``--mover JSON`` (a body that moves or appears, added to the scenario's own ``movers``)."""
    p.add_argument("--moving", action="store_true",
                   help="a world that moves (issue #42): plan and run with WAIT and REVERSE, and treat what appears "
                        "between revolutions as possibly moving (on by itself when the world has movers)")
    if movers:
        p.add_argument("--mover", action="append", default=[], metavar="JSON",
                       help="a body that moves or appears, as in a scenario file's 'movers' (a person, a box, a door "
                            "that closes; docs/experiment-room.md); repeatable")


def scene_movers(scene: Scene, extra: Iterable[str] = ()) -> tuple[Any, ...]:
    """The movers of ``scene`` (its file's ``movers``) and the ``--mover`` JSON texts ``extra``;
    one CliError line naming what is wrong.

    >>> scene_movers(load_scenario("open"), ['{"kind": "box", "appear": 2, "ahead": 0.05}'])[0].kind
    'box'
    >>> scene_movers(load_scenario("open"), ['{"kind": "cat"}'])
    Traceback (most recent call last):
    clomp.runtime.cli.CliError: --mover: mover kind must be 'person', 'box' or 'door', got 'cat'
    """
    import json

    from clomp.runtime.backends.world import parse_movers

    try:
        own = parse_movers(scene.raw.get("movers") or ())
    except (TypeError, ValueError) as exc:
        raise CliError(f"{scene.name}: movers: {exc}") from None
    added: list[Any] = []
    for text in extra:
        try:
            raw = json.loads(text)
        except json.JSONDecodeError as exc:
            raise CliError(f"--mover: not JSON ({exc.msg}): {text!r}") from None
        if not isinstance(raw, dict):
            raise CliError(f"--mover: expected a JSON object, got {text!r}")
        try:
            added += parse_movers([raw])
        except (TypeError, ValueError) as exc:
            raise CliError(f"--mover: {exc}") from None
    return own + tuple(added)


def log_records(read: Callable[[Path], Iterable[T]], path: Path, what: str) -> Iterator[T]:
    """The records ``read`` finds in the run log at ``path``, streamed (one line in memory
    at a time); a log that cannot be read, or holds none (``what`` names them), is one
    CliError line — an empty log before anything is yielded, a bad line when it is reached."""
    it = iter(_cli_errors(read, path))
    first = next(it, None)
    if first is None:
        raise CliError(f"{path}: the log holds no {what}")
    return itertools.chain([first], it)


def _cli_errors(read: Callable[[Path], Iterable[T]], path: Path) -> Iterator[T]:
    try:
        yield from read(path)
    except LogError as exc:
        raise CliError(str(exc)) from None


def path_kind(path: Path, what: str) -> str:
    """``"file"``, ``"folder"``, ``"other"`` (a FIFO, device, socket) or ``"missing"`` for
    ``path``; a path that cannot be reached (an unreadable folder on the way, a NUL byte)
    is one CliError line naming ``what`` (the option)."""
    try:
        info = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return "missing"
    except PermissionError:
        raise CliError(f"{what}: {path}: cannot reach: permission denied") from None
    except (OSError, ValueError) as exc:
        raise CliError(f"{what}: {path}: cannot reach: {getattr(exc, 'strerror', None) or exc}") from None
    return "folder" if stat.S_ISDIR(info.st_mode) else "file" if stat.S_ISREG(info.st_mode) else "other"


def output_folder(path: str | os.PathLike[str], what: str = "--out") -> Path:
    """The folder ``path``, created if missing, checked writable before any work; else one
    CliError line naming ``what``."""
    p = Path(path)
    if "\x00" in str(p):
        raise CliError(f"{what}: the path holds a NUL byte")
    try:
        p.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise CliError(f"{what}: cannot create {p}: {exc.strerror or exc}") from None
    if not os.access(p, os.W_OK | os.X_OK):
        raise CliError(f"{what}: {p} is not writable")
    return p


def output_path(path: str | os.PathLike[str], what: str) -> Path:
    """``path`` checked before any work: a file can be written there (no device, FIFO or
    folder, not read-only, its folder exists); else one CliError line naming ``what``."""
    try:
        return check_output(path, what)
    except InputError as exc:
        raise CliError(str(exc)) from None


def add_units_option(p: argparse.ArgumentParser) -> None:
    """``--units m|mm``: the units of the scans a command reads (:func:`read_points`)."""
    p.add_argument("--units", choices=tuple(UNITS), default=None,
                   help="the units of the scans read (default: metres, and a scan that looks like millimetres — "
                        "its returns mostly beyond 20 m, or a median range above 50 m — is refused)")


def read_points(scan: Any, units: str | None = None, what: str = "--scan") -> np.ndarray:
    """The points of ``scan`` (a file, an array, or a callable giving one) in metres
    (:func:`clomp.planner.units.in_metres`): a scan that looks like millimetres, read without
    ``--units``, is one CliError line naming ``what`` (exit 2), not a scan error; other
    faults of the scan are its :class:`~clomp.planner.ScanError`.

    >>> read_points(np.array([[1200.0, 0.0], [0.0, 900.0]]), "mm").tolist()
    [[1.2, 0.0], [0.0, 0.9]]
    >>> read_points(np.array([[1200.0, 0.0], [0.0, 900.0]]))
    Traceback (most recent call last):
    clomp.runtime.cli.CliError: --scan: looks like millimetres (2 of 2 returns lie beyond 20 m, median range 1050 m); pass --units mm (or --units m if it is in metres)
    """
    points = load_scan(scan() if callable(scan) else scan)
    try:
        return in_metres(points, units)
    except ScanUnitsError as exc:
        raise CliError(f"{what}: {exc}") from None


def scan_outcomes(conf: Configurator, scan: Any, goal: tuple[float, float], units: str | None = None,
                  label: str = "scan") -> tuple[PlanResult | None, dict[str, Any]]:
    """Plan on one scan of a many-scan run; never raises for the scan's own faults (a scan
    that looks like millimetres, read without ``units``, is the command's: a CliError naming
    ``label``, see :func:`read_points`).

    Returns (result or None, record): the record has ``outcome`` — ``goal``, ``partial``,
    ``no_move``, ``at_goal`` (the goal lies within the goal tolerance of the robot: being
    there is an outcome, not an error) or ``error`` (with ``error``: why the scan cannot
    be planned) —, ``returns`` and ``beyond_horizon`` (how many of them lie beyond the
    planning horizon, cropped: :class:`Notes` sums them) once the scan is read, and
    ``warnings`` when any.
    """
    rec: dict[str, Any] = {}
    if math.hypot(goal[0], goal[1]) <= conf.robot.goal_tolerance:
        rec.update(outcome="at_goal", reached_goal=True, plan=[])
        return None, rec
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        if units is not None:
            warnings.simplefilter("ignore", ScanWarning)  # the units were given: no "millimetres?"
        try:
            scan = read_points(scan, units, label)
            if len(scan) and not scan.any():
                raise ScanError(f"a placeholder scan: all {plural(len(scan), 'point')} at the origin (0, 0); not planned")
            horizon = conf.robot.sensor_range
            rec.update(returns=len(scan), beyond_horizon=int(np.count_nonzero(np.einsum("ij,ij->i", scan, scan) > horizon * horizon)))
            r = plan_deepening(conf, scan, goal)  # as the supervisor plans
        except (ScanError, PlanningError) as exc:
            r = None
            rec.update(outcome="error", error=str(exc))
    if caught:
        rec["warnings"] = [str(w.message) for w in caught]
    if r is not None:
        rec["outcome"] = "goal" if r.reached_goal else "partial" if r.steps else "no_move"
    return r, rec


class Notes:
    """What a many-scan run says once, before its summary, instead of once per scan: how
    many returns lay beyond the planning horizon (cropped: normal, an A1 returns to 12 m;
    one line), the scans that warned, placeholder scans, duplicate recordings.

    >>> n = Notes(["2 _smooth copies passed over"], horizon=1.1)
    >>> n.add("map0001.dat", {"returns": 9, "beyond_horizon": 3})
    >>> n.add("map0002.dat", {"outcome": "error", "error": "a placeholder scan: all 4 points at the origin (0, 0); not planned"})
    >>> for line in n.lines(): print(line)
    warning: 2 _smooth copies passed over
    beyond the 1.1 m planning horizon, cropped: 3 of 9 returns (in 1 of 1 scan read)
    warning: 1 placeholder scan (every point at the origin), not planned (first map0002.dat)
    >>> n.summary()
    {'returns': 9, 'beyond_horizon': 3}
    """

    def __init__(self, notes: list[str] | None = None, horizon: float | None = None) -> None:
        self.notes = list(notes or [])
        self.horizon = horizon
        self.warned: list[tuple[str, str]] = []
        self.placeholders: list[str] = []
        self.returns = self.beyond = self.read = self.cropped = 0

    def add(self, label: str, rec: dict[str, Any]) -> None:
        """Note what the outcome record ``rec`` of the scan ``label`` has to say."""
        if "returns" in rec:
            self.read += 1
            self.returns += rec["returns"]
            self.beyond += rec.get("beyond_horizon", 0)
            self.cropped += bool(rec.get("beyond_horizon"))
        if rec.get("warnings"):
            self.warned.append((label, rec["warnings"][0]))
        if rec.get("outcome") == "error" and str(rec.get("error", "")).startswith("a placeholder scan"):
            self.placeholders.append(label)

    def summary(self) -> dict[str, int]:
        """The counts for a JSON summary: the returns read and those beyond the horizon."""
        return {"returns": self.returns, "beyond_horizon": self.beyond}

    def lines(self) -> list[str]:
        """One ``warning:`` line per kind of suspicious data, and one line on the horizon."""
        out = [f"warning: {n}" for n in self.notes]
        if self.beyond and self.horizon is not None:
            out.append(f"beyond the {self.horizon:g} m planning horizon, cropped: {self.beyond:,} of "
                       f"{self.returns:,} returns (in {self.cropped} of {plural(self.read, 'scan')} read)")
        if self.warned:
            label, first = self.warned[0]
            out.append(f"warning: {plural(len(self.warned), 'scan')} warned (first {label}: {first})")
        if self.placeholders:
            out.append(f"warning: {plural(len(self.placeholders), 'placeholder scan')} (every point at the origin), "
                       f"not planned (first {self.placeholders[0]})")
        return out


def folder_scans(folder: Path) -> tuple[list[Path], list[str]]:
    """The scan files of ``folder`` for a many-scan run, and what to say about them once:
    ``NAME_smooth.dat`` beside ``NAME.dat`` is a smoothed copy of the same recording, passed
    over (not counted as a scan of its own); a folder that cannot be listed is a CliError."""
    try:
        files = scan_files(folder)
    except ScanError as exc:
        raise CliError(str(exc)) from None
    names = {f.name for f in files}
    copies = [f for f in files if f.stem.endswith("_smooth") and f.stem[: -len("_smooth")] + f.suffix in names]
    if not copies:
        return files, []
    note = (f"{plural(len(copies), '_smooth copy', '_smooth copies')} of other scans passed over "
            f"(first {copies[0].name}; give one with --scan to plan on it)")
    return [f for f in files if f not in copies], [note]


def many_summary(outcomes: list[str], times: list[float]) -> dict[str, Any]:
    """The summary of a many-scan run: counts per outcome and planning-time figures."""
    t = sorted(times)
    return {
        "scans": len(outcomes),
        **{k: outcomes.count(k) for k in ("goal", "partial", "no_move", "at_goal", "error")},
        "median_planning_time_s": float(np.median(t)) if t else None,
        "p90_planning_time_s": float(np.percentile(t, 90)) if t else None,
    }


def summary_line(s: dict[str, Any]) -> str:
    """The readable summary line of a many-scan run."""
    med = f"{s['median_planning_time_s'] * 1e3:.2f} ms" if s["median_planning_time_s"] is not None else "n/a"
    p90 = f"{s['p90_planning_time_s'] * 1e3:.2f} ms" if s["p90_planning_time_s"] is not None else "n/a"
    return (
        f"summary: {plural(s['scans'], 'scan')}: {s['goal']} reach the goal, {s['partial']} partial, "
        f"{s['no_move']} no move, {s['at_goal']} already at the goal, {plural(s['error'], 'error')}; "
        f"planning time median {med}, p90 {p90}"
    )
