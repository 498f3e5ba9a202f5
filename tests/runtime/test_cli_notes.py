"""Suspicious data said once per folder, not once per scan (issue #43): returns beyond the
planning horizon (issue #39: not a warning, a count), placeholder scans holding only the origin, ``_smooth`` copies of a recording."""

from __future__ import annotations

from pathlib import Path

import pytest

from clomp.runtime.cli import main


def _folder(tmp_path: Path, files: dict[str, str]) -> Path:
    d = tmp_path / "scans"
    d.mkdir()
    for name, text in files.items():
        (d / name).write_text(text)
    return d


def _out(capsys: pytest.CaptureFixture[str], *argv: str) -> list[str]:
    assert main(list(argv)) == 0
    out, err = capsys.readouterr()
    assert "Traceback" not in err
    return out.splitlines()


@pytest.mark.parametrize("command", ["plan", "replay"])
def test_long_range_returns_are_one_line_per_folder(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str) -> None:
    """Issue #39: cropping to the planning horizon is no warning; one line counts the returns beyond it."""
    far = "0.5 0.3\n9.0 1.0\n8.0 -2.0\n"
    d = _folder(tmp_path, {f"map{k:04d}.dat": far for k in range(1, 6)})
    lines = _out(capsys, command, *(["--scan"] if command == "plan" else []), str(d))
    assert not [x for x in lines if "warning" in x], lines
    horizon = [x for x in lines if "horizon" in x]
    assert horizon == ["beyond the 1.1 m planning horizon, cropped: 10 of 15 returns (in 5 of 5 scans read)"], lines
    assert lines[-1].startswith("summary: 5 scans")


@pytest.mark.parametrize("command", ["plan", "replay"])
def test_a_scan_of_only_the_origin_is_a_placeholder_not_free_space(tmp_path: Path, capsys: pytest.CaptureFixture[str],
                                                                   command: str) -> None:
    d = _folder(tmp_path, {"map0001.dat": "0 0\n0 0\n0.0 0.0\n", "map0002.dat": "0.5 0.3\n"})
    lines = _out(capsys, command, *(["--scan"] if command == "plan" else []), str(d))
    assert lines[0].startswith("map0001.dat: error: a placeholder scan: all 3 points at the origin"), lines
    assert "warning: 1 placeholder scan (every point at the origin), not planned (first map0001.dat)" in lines


@pytest.mark.parametrize("command", ["plan", "replay"])
def test_smooth_copies_are_not_counted_as_scans(tmp_path: Path, capsys: pytest.CaptureFixture[str], command: str) -> None:
    d = _folder(tmp_path, {"map0001.dat": "0.5 0.3\n", "map0001_smooth.dat": "0.5 0.3\n", "map0002.dat": "0.6 0.3\n"})
    lines = _out(capsys, command, *(["--scan"] if command == "plan" else []), str(d))
    assert not any(x.startswith("map0001_smooth.dat") for x in lines), lines
    assert any(x.startswith("warning: 1 _smooth copy of other scans passed over") for x in lines), lines
    assert lines[-1].startswith("summary: 2 scans"), lines
