"""Scan units on the command line (issue #39): a scan that looks like millimetres is refused
with exit 2 and the hint, unless ``--units`` says what it is; ``--units mm`` gives the plan of
the same scan in metres. Every command that reads scans takes ``--units``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.cli import EXIT_USAGE, build_parser, main


def _mm(scans_dir: Path, tmp_path: Path, name: str = "map0001.dat") -> tuple[Path, Path]:
    """``name`` of the corridor run (in metres, 1 cm steps) and the same scan × 1000, in whole millimetres."""
    metres = scans_dir / name
    mm = tmp_path / "mm.dat"
    np.savetxt(mm, np.round(np.loadtxt(metres) * 1000.0), fmt="%.0f")
    return metres, mm


def _run(capsys: pytest.CaptureFixture[str], *argv: str) -> tuple[int, str, str]:
    code = main(list(argv))
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return code, out, err


def test_a_scan_in_millimetres_is_refused_with_the_hint(scans_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    _, mm = _mm(scans_dir, tmp_path)
    code, out, err = _run(capsys, "plan", "--scan", str(mm), "--goal", "1,0")
    assert code == EXIT_USAGE and out == ""
    assert "looks like millimetres" in err and "pass --units mm" in err, err


def test_units_mm_gives_the_plan_of_the_scan_in_metres(scans_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    metres, mm = _mm(scans_dir, tmp_path)
    code_m, out, _ = _run(capsys, "plan", "--scan", str(metres), "--goal", "1,0", "--json", "--map", str(tmp_path / "m.json"))
    assert code_m in (0, 1)  # a plan (to the goal, or to the frontier when the goal lies in a shadow)
    want = json.loads(out)
    code, out, _ = _run(capsys, "plan", "--scan", str(mm), "--goal", "1,0", "--json", "--units", "mm",
                        "--map", str(tmp_path / "mm.json"))
    assert code == code_m
    got = json.loads(out)
    assert want["obstacles"] > 10 and want["plan"]  # a scan with something in it
    for key in ("plan", "reached_goal", "collision_free", "states", "transitions", "obstacles", "stop_reason"):
        assert got[key] == want[key], key
    # bit for bit: whole millimetres divided by 1000 are the metres the file holds
    maps = [json.loads((tmp_path / f).read_text()) for f in ("m.json", "mm.json")]
    assert maps[0]["states"] == maps[1]["states"] and maps[0]["metadata"]["obstacles"] == maps[1]["metadata"]["obstacles"]
    # said to be metres, the millimetre scan is planned as it is: every return beyond the horizon
    code, out, _ = _run(capsys, "plan", "--scan", str(mm), "--goal", "1,0", "--json", "--units", "m")
    assert code in (0, 1) and json.loads(out)["obstacles"] == 0


def test_a_folder_in_millimetres_is_refused_and_converted(scans_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    d = tmp_path / "scans"
    d.mkdir()
    for k in (1, 2):
        np.savetxt(d / f"map{k:04d}.dat", np.round(np.loadtxt(scans_dir / f"map{k:04d}.dat") * 1000.0), fmt="%.0f")
    for command in (["plan", "--scan"], ["replay"]):
        code, out, err = _run(capsys, *command, str(d))
        assert code == EXIT_USAGE and "map0001.dat: looks like millimetres" in err, err
        code, out, err = _run(capsys, *command, str(d), "--units", "mm")
        assert code == 0 and out.splitlines()[-1].startswith("summary: 2 scans"), out


def test_export_and_check_read_units_too(scans_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    metres, mm = _mm(scans_dir, tmp_path)
    code, _, err = _run(capsys, "export", "--scan", str(mm), "--format", "json", "--out", str(tmp_path / "a.json"))
    assert code == EXIT_USAGE and "pass --units mm" in err, err
    assert _run(capsys, "export", "--scan", str(mm), "--units", "mm", "--format", "json", "--out", str(tmp_path / "a.json"))[0] == 0
    assert _run(capsys, "export", "--scan", str(metres), "--format", "json", "--out", str(tmp_path / "b.json"))[0] == 0
    a, b = (json.loads((tmp_path / f).read_text()) for f in ("a.json", "b.json"))
    assert a["states"] == b["states"] and a["transitions"] == b["transitions"]
    code, _, err = _run(capsys, "plan", "--scenario", "open", "--units", "mm")
    assert code == EXIT_USAGE and "a scenario is in metres" in err


@pytest.mark.parametrize("command", ["plan", "replay", "export", "check"])
def test_every_scan_reading_command_takes_units(command: str) -> None:
    sub = next(a for a in build_parser()._actions if a.dest == "command")
    options = {o for a in sub.choices[command]._actions for o in a.option_strings}  # type: ignore[union-attr]
    assert "--units" in options


def test_the_lidar_emulator_reads_units_too(scans_dir: Path, tmp_path: Path) -> None:
    """``clomp emulate lidar --scans DIR`` plays recorded scans: a recording in millimetres is
    refused before the emulator starts, and with ``--units mm`` served in metres, in order."""
    import argparse

    from clomp.runtime.cli import CliError
    from clomp.runtime.cli.emulate import _scan_source

    d = tmp_path / "rec"
    d.mkdir()
    metres = [np.loadtxt(scans_dir / f"map{k:04d}.dat").reshape(-1, 2) for k in (1, 2)]
    for k, pts in enumerate(metres, 1):
        np.savetxt(d / f"map{k:04d}.dat", np.round(pts * 1000.0), fmt="%.0f")
    args = argparse.Namespace(scenario=None, scans=str(d), seed=None, units=None)
    with pytest.raises(CliError, match=r"looks like millimetres .*pass --units mm"):
        _scan_source(args)
    args.units = "mm"
    source = _scan_source(args)
    served = [source() for _ in range(3)]
    assert np.array_equal(served[0], metres[0]) and np.array_equal(served[1], metres[1]) and np.array_equal(served[2], metres[0])
    assert build_parser().parse_args(["emulate", "lidar", "--scans", str(d), "--units", "mm"]).units == "mm"
