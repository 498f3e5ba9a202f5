"""The progress bar: drawn on a terminal, silent when standard error is piped."""

from __future__ import annotations

import io
import os
import select
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from clomp.runtime.cli._progress import Progress, echo, enabled_for, progress


def clomp_cmd() -> list[str]:
    script = Path(sys.executable).with_name("clomp")
    return [str(script)] if script.exists() else [sys.executable, "-m", "clomp.runtime.cli"]


def run_with_tty_stderr(args: list[str], timeout: float = 600) -> tuple[int, str, str]:
    """Run clomp with standard error on a pseudo-terminal, standard output on a pipe;
    returns (status, stdout, what the terminal received)."""
    master, slave = os.openpty()
    proc = subprocess.Popen([*clomp_cmd(), *args], stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL)
    os.close(slave)
    received = bytearray()
    assert proc.stdout is not None
    out_fd = proc.stdout.fileno()
    stdout = bytearray()
    open_fds = {master, out_fd}
    while open_fds:
        ready, _, _ = select.select(list(open_fds), [], [], timeout)
        if not ready:
            proc.kill()
            raise AssertionError(f"clomp {' '.join(args)} printed nothing for {timeout} s")
        for fd in ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # EIO: the terminal's other side is closed
                chunk = b""
            if not chunk:
                open_fds.discard(fd)
            elif fd == master:
                received += chunk
            else:
                stdout += chunk
    os.close(master)
    return proc.wait(timeout=timeout), stdout.decode(), received.decode(errors="replace")


def test_counter_without_a_terminal_prints_nothing():
    err = io.StringIO()
    with progress(total=3, desc="runs", file=err) as bar:
        for _ in range(3):
            bar.update()
    assert bar.n == 3 and not bar.enabled
    assert err.getvalue() == ""
    assert [x for x in progress(range(4), file=err)] == [0, 1, 2, 3]
    assert err.getvalue() == ""
    with pytest.raises(TypeError):
        iter(Progress(total=2, file=err)).__next__()


def test_a_forced_bar_draws_and_lines_go_above_it(capsys):
    err = io.StringIO()
    bar = progress(range(3), desc="scans", unit="scan", file=err, enabled=True)
    drawn = err.getvalue()
    assert "scans" in drawn and "0/3" in drawn  # drawn when the job starts
    for k in bar:
        echo(f"line {k}")
    assert capsys.readouterr().out.splitlines() == ["line 0", "line 1", "line 2"]
    assert "\r" in err.getvalue()


def test_enabled_only_on_a_terminal():
    master, slave = os.openpty()
    try:
        with os.fdopen(slave, "w", closefd=False) as tty:
            assert enabled_for(tty)
        assert not enabled_for(io.StringIO())
        with open(os.devnull, "w") as null:
            assert not enabled_for(null)
    finally:
        os.close(master)
        os.close(slave)


def _folder(tmp_path: Path, scans_dir: Path, n: int) -> Path:
    d = tmp_path / "scans"
    d.mkdir()
    for f in sorted(scans_dir.glob("*.dat"))[:n]:
        shutil.copy(f, d / f.name)
    return d


@pytest.mark.parametrize("command", [["replay"], ["plan", "--scan"]])
def test_folder_jobs_draw_a_bar_on_a_terminal_only(tmp_path, scans_dir, command):
    d = _folder(tmp_path, scans_dir, 4)
    status, out, tty = run_with_tty_stderr([*command, str(d)])
    assert status == 0, tty
    assert "0/4" in tty and "scan" in tty and "\r" in tty
    assert len([ln for ln in out.splitlines() if ln.startswith("map")]) == 4  # results still on stdout
    piped = subprocess.run([*clomp_cmd(), *command, str(d)], capture_output=True, text=True, timeout=600)
    assert piped.returncode == 0
    assert piped.stderr == ""
    assert [ln.split()[0] for ln in piped.stdout.splitlines()] == [ln.split()[0] for ln in out.splitlines()]


@pytest.mark.parametrize("command", ["export", "check"])
def test_learning_a_map_from_a_folder_draws_a_bar(tmp_path, scans_dir, command):
    d = _folder(tmp_path, scans_dir, 3)
    args = [command, "--scan", str(d), "--learn"] + (["-f", "json", "-o", str(tmp_path / "m.json")] if command == "export" else [])
    status, _, tty = run_with_tty_stderr(args)
    assert status in (0, 1), tty  # check: 1 when a property fails, still a finished job
    assert "learn" in tty and "0/3" in tty
    piped = subprocess.run([*clomp_cmd(), *args], capture_output=True, text=True, timeout=600)
    assert "learn" not in piped.stderr and "\r" not in piped.stderr


def _experiment(tmp_path: Path, runs: int, *extra: str) -> list[str]:
    return ["experiment", "overtaking", "--runs", str(runs), "--out", str(tmp_path / f"exp{runs}"), "--no-plots", *extra]


def test_experiment_draws_a_bar_on_a_terminal_and_none_when_piped(tmp_path):
    args = _experiment(tmp_path, 2, "--workers", "0")
    status, out, tty = run_with_tty_stderr(args)
    assert status == 0, tty
    assert "0/4" in tty and "run" in tty and "\r" in tty
    piped = subprocess.run([*clomp_cmd(), *args], capture_output=True, text=True, timeout=600)
    assert piped.returncode == 0 and piped.stderr == ""
    assert "\r" not in piped.stdout and "%|" not in piped.stdout


@pytest.mark.slow
def test_the_issues_experiment_of_20_runs_shows_a_bar_only_on_a_terminal(tmp_path):
    """``clomp experiment overtaking --runs 20``: both conditions, 40 runs, the default workers."""
    status, out, tty = run_with_tty_stderr(_experiment(tmp_path, 20))
    assert status == 0, tty
    assert "0/40" in tty and "\r" in tty
    piped = subprocess.run([*clomp_cmd(), *_experiment(tmp_path, 20)], capture_output=True, text=True, timeout=1200)
    assert piped.returncode == 0, piped.stderr
    assert "%|" not in piped.stderr and "\r" not in piped.stderr
