"""Every input the command line reads, tried as a careless or hostile user would (issue #43):
one line ``clomp: error: …`` and exit 2, or a defined outcome; never a traceback, never a
hang (each case runs in a thread joined with a bound, or a subprocess with a timeout)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.cli import main

_BOUND_S = 30.0  # a hang bound, not a timing measure: a passing case takes well under a second
REPO = Path(__file__).resolve().parents[2]


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    """``main(argv)`` in a thread, so that a blocking read fails the test instead of hanging it."""
    box: dict[str, object] = {}

    def target() -> None:
        try:
            box["rc"] = main(list(argv))
        except SystemExit as exc:
            box["rc"] = exc.code
        except BaseException as exc:  # noqa: BLE001 - a traceback is what the test rules out
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(_BOUND_S)
    assert not t.is_alive(), f"clomp {' '.join(argv)} still running after {_BOUND_S} s"
    assert "error" not in box, f"uncaught {box.get('error')!r}"
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return int(box["rc"]), out, err  # type: ignore[call-overload]


def _refused(capsys: pytest.CaptureFixture[str], *argv: str, says: str = "") -> str:
    """Exit 2 with exactly one line ``clomp: error: …`` (containing ``says``)."""
    rc, out, err = _run(capsys, *argv)
    assert rc == 2, (argv, out, err)
    assert err.startswith("clomp: error: ") and len(err.splitlines()) == 1, err
    assert says in err, err
    return err


def _log(tmp_path: Path, *records: str, name: str = "run.jsonl") -> Path:
    p = tmp_path / name
    p.write_text("".join(r + "\n" for r in records))
    return p


# -- unreadable folders, as a user who is not root -------------------------------------------
_AS_NOBODY = """
import os, sys
from clomp.runtime.cli import main, build_parser
build_parser()  # every command module imported while the interpreter's files are readable
import clomp.planner.configurator
os.setgid(65534); os.setuid(65534)
sys.exit(main(sys.argv[1:]))
"""


def _as_nobody(*argv: str) -> subprocess.CompletedProcess[str]:
    if os.geteuid() != 0:  # already unprivileged: run as we are
        return subprocess.run([sys.executable, "-m", "clomp.runtime.cli", *argv], capture_output=True, text=True,
                              timeout=120, env={**os.environ, "PYTHONPATH": str(REPO)})
    return subprocess.run([sys.executable, "-c", _AS_NOBODY, *argv], capture_output=True, text=True, timeout=120,
                          env={**os.environ, "PYTHONPATH": str(REPO)})


@pytest.fixture
def locked(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder with a scan in it that its user cannot list or enter (mode 000), inside a
    folder everyone may write to (so only the lock is in the way)."""
    import tempfile

    top = Path(tempfile.mkdtemp(prefix="clomp-locked-"))
    top.chmod(0o777)
    d = top / "d"
    d.mkdir()
    (d / "s.dat").write_text("0.5 0.1\n")
    d.chmod(0)
    yield d
    d.chmod(0o755)
    import shutil

    shutil.rmtree(top)


@pytest.mark.parametrize("argv", [
    ["plan", "--scan", "{d}", "--goal", "1,0"],
    ["plan", "--scan", "{d}/s.dat"],
    ["replay", "{d}"],
    ["replay", "{d}/run.jsonl"],
    ["export", "--scan", "{d}", "--learn", "-f", "json", "-o", "{top}/m.json"],
    ["export", "--scan", "{d}/s.dat", "-f", "json", "-o", "{top}/m.json"],
    ["plan", "--scenario", "{d}/s.json"],
])
def test_an_unreadable_folder_is_one_line_for_a_user(locked: Path, argv: list[str]) -> None:
    args = [a.format(d=locked, top=locked.parent) for a in argv]
    p = _as_nobody(*args)
    assert p.returncode == 2, (p.stdout, p.stderr)
    assert p.stderr.startswith("clomp: error: ") and len(p.stderr.splitlines()) == 1, p.stderr
    assert "permission denied" in p.stderr


def test_a_read_only_output_file_is_refused_before_work(locked: Path) -> None:
    out = locked.parent / "ro.mcap"
    out.write_text("")
    out.chmod(0o444)
    log = locked.parent / "run.jsonl"
    log.write_text('{"t": 0, "event": "scan", "points": [[0.5, 0.1]]}\n')
    log.chmod(0o644)
    p = _as_nobody("convert", str(log), "-o", str(out))
    assert p.returncode == 2 and p.stderr == f"clomp: error: -o: {out} is read-only\n", p.stderr


# -- scans --------------------------------------------------------------------------------------
def test_a_npy_header_whose_shape_holds_a_boolean_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from clomp.planner import ScanError, plan

    header = b"{'descr': '<f8', 'fortran_order': False, 'shape': (True, 2), }"
    header += b" " * (63 - (10 + len(header)) % 64) + b"\n"
    p = tmp_path / "s.npy"
    p.write_bytes(b"\x93NUMPY\x01\x00" + len(header).to_bytes(2, "little") + header + np.zeros(2).tobytes())
    _refused(capsys, "plan", "--scan", str(p), says="bad shape")
    with pytest.raises(ScanError, match="bad shape"):
        plan(str(p), (1.0, 0.0))


# -- run logs -----------------------------------------------------------------------------------
def test_replay_a_record_whose_points_are_no_scan_is_that_scan_s_error(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, '{"t":0,"event":"scan","points":[[0.5,0.1,0.2]]}', '{"t":1,"event":"scan","points":[[0.5,0.1]]}')
    rc, out, err = _run(capsys, "replay", str(log))
    assert rc == 0, err
    first = out.splitlines()[0]
    assert first.startswith("scan0001@0.000s: error: ") and ":1: field 'points'" in first, first
    assert "summary: 2 scans" in out


@pytest.mark.parametrize("goal", ['"x"', "[1]", "[1e400, 0]", "[true, 0]", '{"x": 1}'])
def test_replay_a_bad_goal_names_the_line_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str], goal: str) -> None:
    log = _log(tmp_path, '{"t":0,"event":"start"}', f'{{"t":0,"event":"scan","points":[[0.5,0.1]],"goal":{goal}}}')
    _refused(capsys, "replay", str(log), says=":2: field 'goal'")


@pytest.mark.parametrize("t", ['"soon"', "1e300", "-1", "true", "null"])
def test_replay_a_bad_time_names_the_line_and_field(tmp_path: Path, capsys: pytest.CaptureFixture[str], t: str) -> None:
    log = _log(tmp_path, f'{{"t":{t},"event":"scan","points":[[0.5,0.1]]}}', '{"t":1,"event":"stop"}')
    _refused(capsys, "replay", str(log), says=":1: field 't'")


def test_convert_a_time_of_1e300_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, '{"t":1e300,"event":"scan","points":[[0.5,0.1]]}', '{"t":1,"event":"stop"}')
    _refused(capsys, "convert", str(log), says=":1: field 't'")


def test_convert_a_time_of_1e12_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, '{"t":1e12,"event":"scan","points":[[0.5,0.1]]}')
    _refused(capsys, "convert", str(log), says=":1: field 't'")


@pytest.mark.parametrize("record", [
    '{"t":0.5,"event":"plan","path":[[0,0,0]],"obstacles":[[1,2,3,4]]}',
    '{"t":0.5,"event":"plan","path":[[0,0,0]],"obstacles":[[[0,0],[1,"a"],[1,1],[0,1]]]}',
    '{"t":0.5,"event":"plan","path":[[0,0,"x"]],"obstacles":[[[0,0],[1,0],[1,1]]]}',
    '{"t":0.5,"event":"start","goal":["a","b"]}',
    '{"t":0.5,"event":"start","goal":[1e308, 1e308]}',
])
def test_convert_malformed_plan_boxes_or_goal_are_passed_over(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                              record: str) -> None:
    """The defined outcome of convert: what it cannot draw is passed over (a malformed box or
    pose left out, a start without a readable goal counted as passed over), exit 0."""
    log = _log(tmp_path, '{"t":0,"event":"run","wall":1.7e9}', record)
    rc, out, err = _run(capsys, "convert", str(log), "--json")
    assert rc == 0, err
    assert json.loads(out)["mcap"].endswith("run.mcap")


def test_convert_to_dev_full_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, '{"t":0,"event":"scan","points":[[0.5,0.1]]}')
    _refused(capsys, "convert", str(log), "-o", "/dev/full", says="/dev/full is a character device")


def test_convert_a_write_error_midway_is_one_line(tmp_path: Path, monkeypatch: pytest.MonkeyPatch,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    """A disk that fills mid-write (what /dev/full does to every write) is one line."""
    from clomp.runtime.records import mcap_writer

    def full(*a: object, **k: object) -> object:
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(mcap_writer, "_write_all", full)
    log = _log(tmp_path, '{"t":0,"event":"scan","points":[[0.5,0.1]]}')
    _refused(capsys, "convert", str(log), says="No space left on device")


def test_convert_a_billion_bins_is_refused_before_work(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, '{"t":0,"event":"scan","points":[[0.5,0.1]]}')
    _refused(capsys, "convert", str(log), "--bins", "1000000000", says="--bins: from 8 to")
    assert not (tmp_path / "run.mcap").exists()


# -- JSON limits --------------------------------------------------------------------------------
def test_a_log_nested_100000_deep_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    log = _log(tmp_path, "[" * 100_000 + "]" * 100_000, '{"t":0,"event":"stop"}')
    _refused(capsys, "replay", str(log), says="nested 100,000 deep")
    _refused(capsys, "convert", str(log), says="nested 100,000 deep")


def test_a_scenario_nested_100000_deep_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "s.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    _refused(capsys, "plan", "--scenario", str(p), says="nested 100,000 deep")


def test_a_scenario_with_a_5001_digit_integer_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "s.json"
    p.write_text('{"goal": [' + "9" * 5001 + ", 0]}")
    _refused(capsys, "plan", "--scenario", str(p), says="digits")


def test_a_map_nested_100000_deep_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "m.json"
    p.write_text("[" * 100_000 + "]" * 100_000)
    _refused(capsys, "export", "--map", str(p), "-f", "json", "-o", str(tmp_path / "o.json"), says="nested")


# -- special files given to every option that takes a path ---------------------------------------
@pytest.fixture
def specials(tmp_path: Path) -> dict[str, str]:
    fifo = tmp_path / "f.jsonl"
    os.mkfifo(fifo)
    sock_path = tmp_path / "s.sock"
    sock = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    sock.bind(str(sock_path))
    return {"fifo": str(fifo), "zero": "/dev/zero", "socket": str(sock_path)}


_PATH_OPTIONS = {
    "--scan": ["plan", "--scan", "{p}"],
    "--scan (export)": ["export", "--scan", "{p}", "-f", "json", "-o", "{tmp}/o.json"],
    "--map": ["export", "--map", "{p}", "-f", "json", "-o", "{tmp}/o.json"],
    "--specs": ["check", "--scenario", "open", "--specs", "{p}"],
    "--scenario": ["plan", "--scenario", "{p}"],
    "log (replay)": ["replay", "{p}"],
    "log (convert)": ["convert", "{p}", "-o", "{tmp}/o.mcap"],
    "-o (export)": ["export", "--scenario", "open", "-f", "json", "-o", "{p}"],
    "-o (convert)": ["convert", "{log}", "-o", "{p}"],
    "--map (plan, written)": ["plan", "--scenario", "open", "--map", "{p}"],
    "--log (simulate)": ["simulate", "--scenario", "open", "--out", "{tmp}", "--log", "{p}"],
    "--log (run)": ["run", "--lidar", "/dev/null", "--goal", "1,0", "--dry-run", "--log", "{p}"],
}


@pytest.mark.parametrize("special", ["fifo", "zero", "socket"])
@pytest.mark.parametrize("option", sorted(_PATH_OPTIONS))
def test_a_special_file_given_to_any_path_option_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                             specials: dict[str, str], option: str, special: str) -> None:
    log = _log(tmp_path, '{"t":0,"event":"scan","points":[[0.5,0.1]]}', name="ok.jsonl")
    argv = [a.format(p=specials[special], tmp=tmp_path, log=log) for a in _PATH_OPTIONS[option]]
    _refused(capsys, *argv)


# -- numbers ------------------------------------------------------------------------------------
@pytest.mark.parametrize("argv", [
    ["simulate", "--scenario", "open", "--seed", "-1"],
    ["simulate", "--scenario", "open", "--seed", "1.5"],
    ["export", "--scenario", "open", "--samples", "3", "--seed", "-1", "-f", "json", "-o", "-"],
    ["plan", "--scenario", "open", "--robust", "--samples", "3", "--seed", "99999999999999999999999"],
    ["demo", "--scenario", "open", "--seed", "-3"],
    ["experiment", "open", "--runs", "1", "--seed", "-1"],
])
def test_a_seed_is_a_non_negative_whole_number_for_every_command(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                 argv: list[str]) -> None:
    if argv[0] in ("simulate", "demo", "experiment"):
        argv = [*argv, "--out", str(tmp_path)]
    _refused(capsys, *argv, says="--seed: expected a whole number from 0 to")


@pytest.mark.parametrize("seed", ["-1", "1.5", '"1"', "true"])
def test_a_scenario_seed_follows_the_same_rule(tmp_path: Path, capsys: pytest.CaptureFixture[str], seed: str) -> None:
    p = tmp_path / "s.json"
    p.write_text(f'{{"goal": [1, 0], "seed": {seed}}}')
    _refused(capsys, "plan", "--scenario", str(p), says="s.seed: expected a whole number from 0 to")


@pytest.mark.parametrize("shape", [
    '{"type": "box", "center": [0.5, 0.3], "size": [1e-300, 0.1]}',
    '{"type": "circle", "center": [0.5, 0.3], "radius": 1e-300}',
    '{"type": "wall", "from": [0.5, 0.3], "to": [0.6, 0.3], "thickness": 1e-300}',
    '{"type": "box", "center": [1e300, 0.3], "size": [0.1, 0.1]}',
])
def test_a_shape_below_a_millimetre_or_beyond_a_kilometre_is_refused(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                     shape: str) -> None:
    p = tmp_path / "s.json"
    p.write_text(f'{{"goal": [1, 0], "obstacles": [{shape}]}}')
    _refused(capsys, "simulate", "--scenario", str(p), "--out", str(tmp_path), says="s.obstacles[0]")


def test_export_a_step_of_1e300_metres_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _refused(capsys, "export", "--scenario", "open", "--step-length", "1e300", "-f", "json", "-o", str(tmp_path / "m.json"),
             says="--step-length: expected metres")


def test_export_a_binary_map_is_one_line(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "m.json"
    p.write_bytes(b"\xff\xfe\x00binary\x93")
    _refused(capsys, "export", "--map", str(p), "-f", "json", "-o", str(tmp_path / "o.json"), says="binary content")


def test_the_library_refuses_special_and_binary_maps(tmp_path: Path) -> None:
    from clomp.formal.lts import CognitiveMap, MapError

    p = tmp_path / "m.json"
    p.write_bytes(b"\xff\xfe")
    for src in ("/dev/zero", str(p)):
        with pytest.raises(MapError):
            CognitiveMap.read_json(src)


# -- names taken from inputs -----------------------------------------------------------------------
def test_a_scenario_name_never_leaves_the_output_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "out"
    p = tmp_path / "s.json"
    p.write_text('{"name": "../escaped", "goal": [0.3, 0]}')
    rc, _, err = _run(capsys, "simulate", "--scenario", str(p), "--out", str(out), "--max-time", "5")
    assert rc in (0, 1), err
    assert not list(tmp_path.glob("escaped*")) and [f.name for f in out.iterdir()] == ["escaped_planning.png"]


def test_a_scenario_name_with_a_nul_byte_is_a_plain_file_name(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    p = tmp_path / "s.json"
    p.write_text('{"name": "a\\u0000b", "goal": [0.3, 0]}')
    rc, _, err = _run(capsys, "simulate", "--scenario", str(p), "--out", str(tmp_path / "out"), "--max-time", "5")
    assert rc in (0, 1), err
    assert [f.name for f in (tmp_path / "out").iterdir()] == ["a_b_planning.png"]
