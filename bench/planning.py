"""Planning benchmark: median and p90 planning time and map size per scenario and scan set.

Run: ``python bench/planning.py [--repeat N] [--scans DIR]``. Prints figures; asserts nothing.
Planning time covers perception (scan → obstacle boxes) and map construction.

``python bench/planning.py --cpu [--scans DIR ...] [--repeat N]`` times what the authors'
C++ figures time (``../shared/reference/cpp_anchor.md``): the thread CPU time of a whole
``plan()`` call on the scan's points, perception included, median of ``--repeat`` runs
per scan (CPU time is not inflated by a busy machine; wall time is printed beside it).
Per folder it prints median and p90 over scans, state counts, the median per-scan ratio
to ``cpp_anchor.csv`` (``cpp_anchor_lab.csv`` for the 2022 lab runs), the honest reach (goal reached with the body inside the sensed
disc, by the independent sweep of ``tests/planner/sweepcheck.py``), plans over a sensed
point, the perception time of a 400-point scan and a 200k-point scan's time and memory;
then issue #39's targets per folder and for the lab runs together (median per-scan ratio
clomp/C++ <= 1.0 and p90 <= the C++'s, on scans with something ahead and on all with data),
each marked met or NOT met. ``--shared`` times all five shared runs (corridor and lab).

Thread CPU time still varies by up to 1.5x between runs on a shared virtual machine (a busy
sibling, the host's frequency, cache contention), so beside the times it prints:

- the calibration of this machine (``workcount.calibration``: thread CPU time of a fixed
  pure-Python workload, before and after the scans) and the times in its units, which can
  be set beside those of a run on another host;
- with ``--count``, the work each plan executes (bytecodes, Python calls, C calls; the same
  on any host for the same code), per category;
- with ``--callgrind`` (valgrind installed), the machine instructions (Ir) each plan
  executes, numpy included, counted by callgrind in a child process (a few minutes).

``python bench/planning.py --cpu --repeat 5 --count --callgrind`` prints all of them.
"""

from __future__ import annotations

import argparse
import csv
import functools
import math
import os
import statistics
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from clomp.planner import Configurator, ScanWarning, builtin_scenarios, load_scan, load_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))
from workcount import calibration, callgrind_available, callgrind_counts, count_python, marked, p90, reference_numpy  # noqa: E402

DEFAULT_SCANS = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "scans" / "corridor-2023-10-25"


def _row(name: str, times: list[float], states: list[int]) -> str:
    t = np.array(times) * 1e3
    return (
        f"{name:<28} n={len(times):4d}  median {np.median(t):7.3f} ms  p90 {np.percentile(t, 90):7.3f} ms"
        f"  states median {statistics.median(states):6.1f}  p90 {np.percentile(states, 90):6.1f}"
    )


ANCHOR = Path(__file__).resolve().parents[1].parent / "shared" / "reference" / "cpp_anchor.csv"
#: the same figures for the four 2022 lab runs (a ``folder`` column names the run)
ANCHOR_LAB = ANCHOR.with_name("cpp_anchor_lab.csv")


def _anchor(*paths: Path) -> dict[tuple[str, str], dict[str, str]]:
    """The C++ figures by (folder name, scan name); ``cpp_anchor.csv`` (no ``folder``
    column) is the corridor run's."""
    out: dict[tuple[str, str], dict[str, str]] = {}
    for path in paths:
        if path.is_file():
            with path.open() as f:
                for row in csv.DictReader(f):
                    out[(row.get("folder") or DEFAULT_SCANS.name, row["scan"])] = row
    return out


def _anchor_row(anchor: dict[tuple[str, str], dict[str, str]], folder: Path, f: Path) -> dict[str, str] | None:
    """The C++ figures of scan ``f`` of ``folder`` (a shared run: matched by the folder's name), or None."""
    return anchor.get((folder.resolve().name, f.name))


def _ahead(points: np.ndarray) -> bool:
    """A return within 0.6 m ahead in the robot's lane (the anchor's ``ahead``)."""
    if not len(points):
        return False
    x, y = points[:, 0], points[:, 1]
    return bool(((x > 0) & (x <= 0.6) & (np.abs(y) <= 0.15)).any())


def _cpu_row(name: str, cpu: list[float], wall: list[float], states: list[int], ratios: list[float]) -> str:
    if not cpu:
        return f"{name:<30} n=   0"
    c, w = np.array(cpu) * 1e3, np.array(wall) * 1e3
    ratio = f"  ratio to C++ median {np.median(ratios):5.2f}x (n={len(ratios)})" if ratios else ""
    return (
        f"{name:<30} n={len(cpu):4d}  cpu median {np.median(c):6.3f} ms  p90 {np.percentile(c, 90):6.3f} ms"
        f"  (wall median {np.median(w):6.3f}, p90 {np.percentile(w, 90):6.3f})"
        f"  states median {statistics.median(states):5.1f} p90 {np.percentile(states, 90):5.1f} max {max(states):4d}{ratio}"
    )


CATEGORIES = ("something ahead", "all with data", "nothing ahead", "empty")


def _categories(folder: Path, files: list[Path], anchor: dict[tuple[str, str], dict[str, str]]) -> list[list[str]]:
    """Each scan's categories (the anchor's ``ahead`` on the shared scans, else :func:`_ahead`)."""
    out = []
    for f in files:
        pts = load_scan(f)
        row = _anchor_row(anchor, folder, f)
        ahead = bool(int(row["ahead"])) if row and row.get("ahead") else _ahead(pts)
        out.append(["all with data", "something ahead" if ahead else "nothing ahead"] if len(pts) else ["empty"])
    return out


def _scan400(rng: np.random.Generator | None = None) -> np.ndarray:
    """The 400-point scan whose perception is timed (the first draws of ``default_rng(0)``)."""
    rng = np.random.default_rng(0) if rng is None else rng
    a = np.sort(rng.uniform(-math.pi, math.pi, 400))
    r = 0.5 + 0.1 * np.sin(3 * a)
    return np.round(np.c_[r * np.cos(a), r * np.sin(a)], 2)


def _count_row(name: str, values: list[list[int]], labels: tuple[str, ...], scale: float, unit: str) -> str:
    if not values:
        return f"{name:<30} n=   0"
    cols = []
    for i, label in enumerate(labels):
        v = [x[i] / scale for x in values]
        cols.append(f"{label} median {statistics.median(v):8.1f}{unit} p90 {p90(v):8.1f}{unit} total {sum(v):9.1f}{unit}")
    return f"{name:<30} n={len(values):4d}  " + "; ".join(cols)


#: one planned scan of the --cpu run: its categories, clomp's thread CPU median (s) and the C++'s (None unless it planned)
Timed = tuple[list[str], float, float | None]


def _cpu_bench(folders: list[Path], repeat: int, count: bool = False, callgrind: bool = False) -> None:
    conf = Configurator()
    conf.plan(np.zeros((0, 2)), (1.0, 0.0))
    anchor = _anchor(ANCHOR, ANCHOR_LAB)
    cal0, np0 = calibration(), calibration(workload=reference_numpy)
    print(f"clomp planning, thread CPU time of plan() per scan, median of {repeat} (python {sys.version.split()[0]})")
    print(
        f"  load average {_load()}; calibration (thread CPU of fixed workloads): pure Python median {cal0[0] * 1e3:.3f} ms"
        f" (min {cal0[1] * 1e3:.3f}), numpy on small arrays median {np0[0] * 1e3:.3f} ms (min {np0[1] * 1e3:.3f})"
    )
    medians: dict[str, float] = {}
    timed: dict[Path, list[Timed]] = {}
    for folder in folders:
        timed[folder] = _cpu_folder(conf, folder, anchor, repeat, count, medians)
    print("targets (issue #39): median per-scan ratio clomp/C++ <= 1.0 and clomp p90 <= C++ p90, on the scans both planned:")
    for folder, rows in timed.items():
        _targets(folder.name, rows)
    lab = [r for folder, rows in timed.items() if folder.name.startswith("lab-") for r in rows]
    if sum(folder.name.startswith("lab-") for folder in timed) > 1:
        _targets("the lab runs together", lab)
    cal1, np1 = calibration(), calibration(workload=reference_numpy)
    print(
        f"  load average {_load()}; calibration after the scans: pure Python median {cal1[0] * 1e3:.3f} ms"
        f" (min {cal1[1] * 1e3:.3f}), numpy median {np1[0] * 1e3:.3f} ms (min {np1[1] * 1e3:.3f})"
    )
    cal, cnp = (cal0[0] + cal1[0]) / 2, (np0[0] + np1[0]) / 2
    print(
        "  in calibration units (plan time / workload time, comparable across hosts): "
        + ", ".join(f"{k} {v / cal:.4f} (numpy units {v / cnp:.4f})" for k, v in medians.items())
    )
    _perception_and_large(count)
    if callgrind:
        _callgrind_report(folders, anchor)


def _cpu_folder(
    conf: Configurator, folder: Path, anchor: dict[tuple[str, str], dict[str, str]], repeat: int, count: bool,
    medians: dict[str, float],
) -> list[Timed]:
    """Time every scan of ``folder`` (printing its rows) and return the per-scan figures.

    A scan's :class:`ScanWarning` (returns beyond the sensor range: every scan of the 2022
    runs) is not printed while timing: a terminal's output is no part of planning."""
    sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests" / "planner"))
    from sweepcheck import check_states

    files = sorted(folder.glob("*.dat"))
    cats = _categories(folder, files, anchor)
    groups: dict[str, tuple[list[float], list[float], list[int], list[float]]] = {k: ([], [], [], []) for k in CATEGORIES}
    counted: dict[str, list[list[int]]] = {k: [] for k in CATEGORIES}
    out: list[Timed] = []
    reach = honest = over = frontier = blocked = with_data = 0
    for f, keys in zip(files, cats):
        pts = load_scan(f)
        cpu, wall = [], []
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ScanWarning)
            for _ in range(repeat):
                w0, c0 = time.perf_counter(), time.thread_time()
                r = conf.plan(pts, (1.0, 0.0))
                cpu.append(time.thread_time() - c0)
                wall.append(time.perf_counter() - w0)
            work = list(count_python(functools.partial(conf.plan, pts, (1.0, 0.0)))) if count else None
        c, w = float(np.median(cpu)), float(np.median(wall))
        row = _anchor_row(anchor, folder, f)
        cpp = float(row["cpp_cpu_median_s"]) if row and row.get("cpp_status") == "ok" and row.get("cpp_cpu_median_s") else None
        out.append((keys, c, cpp))
        for k in keys:
            g = groups[k]
            g[0].append(c)
            g[1].append(w)
            g[2].append(r.n_states)
            if cpp is not None:
                g[3].append(c / cpp)
            if work is not None:
                counted[k].append(work)
        if len(pts):
            with_data += 1
            check = check_states(pts, r.steps, conf.robot)
            over += check.over_points > 0
            reach += r.reached_goal
            honest += r.reached_goal and check.ok
            frontier += r.stop_reason == "frontier"
            blocked += r.goal_blocked
    print(f"{folder} ({len(files)} scans)")
    for k, (cpu, wall, states, ratios) in groups.items():
        print("  " + _cpu_row(k, cpu, wall, states, ratios))
        if cpu:
            medians[k] = float(np.median(cpu))
    if count:
        print("  work per plan (Python level, sys.settrace/sys.setprofile; the same on any host):")
        for k in CATEGORIES:
            print("    " + _count_row(k, counted[k], ("bytecodes", "Python calls", "C calls"), 1e3, "k"))
    if with_data:
        print(
            f"  honest reach {honest}/{with_data} = {100 * honest / with_data:.1f} % of scans with data"
            f" (reached {reach}; plans over a sensed point {over}; ended at the frontier {frontier}; goal blocked {blocked})"
        )
    return out


def _targets(name: str, rows: list[Timed]) -> None:
    """Print, per category of ``rows``, the median per-scan ratio clomp/C++ and both p90s
    over the scans the C++ planned, each against issue #39's target (met / NOT met)."""
    for k in ("something ahead", "all with data", "nothing ahead"):
        both = [(c, cpp) for keys, c, cpp in rows if k in keys and cpp is not None]
        if not both:
            continue
        ratio = float(np.median([c / cpp for c, cpp in both]))
        ours, theirs = p90([c for c, _ in both]), p90([cpp for _, cpp in both])
        goal = "" if k == "nothing ahead" else (
            "  met" if ratio <= 1.0 and ours <= theirs else "  NOT met"
        )
        print(
            f"  {name:<24} {k:<16} n={len(both):4d}  median ratio {ratio:5.2f}"
            f"  medians C++ {np.median([cpp for _, cpp in both]) * 1e3:6.3f} / clomp {np.median([c for c, _ in both]) * 1e3:6.3f} ms"
            f"  p90 C++ {theirs * 1e3:6.3f} / clomp {ours * 1e3:6.3f} ms{goal}"
        )


def _load() -> str:
    try:
        return " ".join(f"{v:.2f}" for v in os.getloadavg())
    except OSError:
        return "n/a"


def _callgrind_child(folders: list[Path]) -> None:
    """Under callgrind: plan each scan once through :func:`marked`, then perceive the 400-point scan."""
    from clomp.planner.perception import perceive

    conf = Configurator()
    conf.plan(np.zeros((0, 2)), (1.0, 0.0))
    scans = [load_scan(f) for folder in folders for f in sorted(folder.glob("*.dat"))]
    if scans:
        conf.plan(scans[0], (1.0, 0.0))
    scan400 = _scan400()
    perceive(scan400)
    for pts in scans:
        marked(conf.plan, pts, (1.0, 0.0))
    marked(perceive, scan400)


def _callgrind_report(folders: list[Path], anchor: dict[tuple[str, str], dict[str, str]]) -> None:
    if not callgrind_available():
        print("callgrind: valgrind is not installed (apt-get install valgrind); no instruction counts")
        return
    t0 = time.perf_counter()
    counts = callgrind_counts([str(Path(__file__).resolve()), "--callgrind-child", "--scans", *map(str, folders)])
    per_file = [(folder, f, k) for folder in folders for f, k in zip(sorted(folder.glob("*.dat")), _categories(folder, sorted(folder.glob("*.dat")), anchor))]
    if len(counts) != len(per_file) + 1:
        print(f"callgrind: {len(counts)} dumps for {len(per_file) + 1} marked calls; no instruction counts")
        return
    print(f"machine instructions per plan (valgrind callgrind Ir, numpy included; the same on any host; {time.perf_counter() - t0:.0f} s):")
    last = None
    for folder in folders:
        byk: dict[str, list[list[int]]] = {k: [] for k in CATEGORIES}
        for (fo, _, keys), n in zip(per_file, counts):
            if fo == folder:
                for k in keys:
                    byk[k].append([n])
        if folder != last:
            print(f"  {folder}")
            last = folder
        for k in CATEGORIES:
            print("    " + _count_row(k, byk[k], ("Ir",), 1e6, "M"))
    print(f"  perception of a 400-point scan: {counts[-1] / 1e6:.3f} M instructions")


def _perception_and_large(count: bool = False) -> None:
    import tracemalloc

    from clomp.planner.perception import perceive

    rng = np.random.default_rng(0)
    scan400 = _scan400(rng)  # then the same rng draws the large scans, as before
    times = []
    for _ in range(200):
        c0 = time.thread_time()
        perceive(scan400)
        times.append(time.thread_time() - c0)
    work = ""
    if count:
        b, py, c = count_python(lambda: perceive(scan400))
        work = f"; {b} bytecodes, {py} Python calls, {c} C calls"
    print(f"perception of a 400-point scan: cpu median {np.median(times) * 1e3:.4f} ms, p90 {np.percentile(times, 90) * 1e3:.4f} ms{work}")
    conf = Configurator()
    for n in (50_000, 200_000):
        a = rng.uniform(-math.pi, math.pi, n)
        rad = np.where(rng.random(n) < 0.5, 0.45 / np.maximum(np.abs(np.sin(a)), 1e-3), rng.uniform(0.2, 1.1, n))
        pts = np.c_[rad * np.cos(a), rad * np.sin(a)]
        # timed without tracemalloc (which costs per allocation: it made the figure several
        # times too high), then run again under it for the peak memory
        w0, c0 = time.perf_counter(), time.thread_time()
        try:
            res = conf.plan(pts, (1.0, 0.0))
            what = f"planned: {res.n_states} states, reached={res.reached_goal}, stop {res.stop_reason}"
        except Exception as exc:  # a refusal is an answer too: say which
            what = f"refused: {type(exc).__name__}: {exc}"
        cpu, wall = time.thread_time() - c0, time.perf_counter() - w0
        tracemalloc.start()
        try:
            conf.plan(pts, (1.0, 0.0))
        except Exception:  # noqa: S110 - the same refusal as above
            pass
        peak = tracemalloc.get_traced_memory()[1]
        tracemalloc.stop()
        print(f"{n:>7}-point scan: cpu {cpu:.3f} s, wall {wall:.3f} s, peak memory {peak / 1e6:.1f} MB ({peak / n:.0f} B/point); {what}")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__)
    ap.add_argument("--cpu", action="store_true", help="per-scan thread CPU time of plan() beside the authors' C++")
    ap.add_argument("--repeat", type=int, default=50, help="runs per scenario (default 50)")
    ap.add_argument("--scans", type=Path, nargs="+", default=[DEFAULT_SCANS], help="folder(s) of recorded scans")
    ap.add_argument(
        "--shared",
        action="store_true",
        help="with --cpu: the corridor run and the four 2022 lab runs (all the runs the C++ figures cover)",
    )
    ap.add_argument(
        "--single",
        nargs="*",
        default=["map0001.dat", "map0141.dat"],
        help="recorded scans (with something ahead) each planned --repeat times, for a per-scan median/p90",
    )
    ap.add_argument(
        "--count",
        action="store_true",
        help="with --cpu: also count the work of each plan (bytecodes, Python and C calls), which no host speed moves",
    )
    ap.add_argument(
        "--callgrind",
        action="store_true",
        help="with --cpu: also count machine instructions per plan under valgrind's callgrind (minutes)",
    )
    ap.add_argument("--callgrind-child", action="store_true", help=argparse.SUPPRESS)
    args = ap.parse_args(argv)
    if args.callgrind_child:
        _callgrind_child(args.scans)
        return 0
    if args.shared:
        args.scans = [DEFAULT_SCANS, *sorted(DEFAULT_SCANS.parent.glob("lab-2022-*"))]
    if args.cpu:
        _cpu_bench(args.scans, args.repeat if args.repeat != 50 else 15, args.count, args.callgrind)
        return 0
    args.scans = args.scans[0]
    conf = Configurator()
    conf.plan(np.zeros((0, 2)), (1.0, 0.0))  # warm up imports
    print(f"clomp planning benchmark (python {sys.version.split()[0]}, repeat {args.repeat})")
    for name in builtin_scenarios():
        scene = load_scenario(name)
        scan, goal = scene.scan(), tuple(scene.goal_in_robot_frame())
        times, states = [], []
        for _ in range(args.repeat):
            t0 = time.perf_counter()
            r = conf.plan(scan, goal)
            times.append(time.perf_counter() - t0)
            states.append(r.n_states)
        print(_row(f"scenario {name}", times, states) + f"  reached={r.reached_goal}")
    if args.scans.is_dir():
        files = sorted(args.scans.glob("*.dat"))
        scans = [load_scan(f) for f in files]
        groups = {"scans (all)": scans, "scans (non-empty)": [s for s in scans if len(s)]}
        for label, group in groups.items():
            times, states = [], []
            for s in group:
                best = []
                for _ in range(3):
                    t0 = time.perf_counter()
                    r = conf.plan(s, (1.0, 0.0))
                    best.append(time.perf_counter() - t0)
                times.append(min(best))
                states.append(r.n_states)
            print(_row(label, times, states))
        for name in args.single:
            f = args.scans / name
            if not f.is_file():
                continue
            s = load_scan(f)
            times, states = [], []
            for _ in range(args.repeat):
                t0 = time.perf_counter()
                r = conf.plan(s, (1.0, 0.0))
                times.append(time.perf_counter() - t0)
                states.append(r.n_states)
            print(_row(f"scan {name} (repeated)", times, states) + f"  reached={r.reached_goal}")
    else:
        print(f"(recorded scans not found at {args.scans})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
