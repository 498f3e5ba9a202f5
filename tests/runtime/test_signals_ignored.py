"""Long commands stop on Ctrl-C even when started with SIGINT ignored, as a script's background
job is (``cmd &`` without job control): Python then installs no KeyboardInterrupt handler, and a
command relying on it runs to its end. The pytest run itself may be such a job: so may CI."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path


def _records(path: Path) -> list[dict]:
    if not path.exists():
        return []
    return [json.loads(line) for line in path.read_text(encoding="utf-8").splitlines(keepends=True) if line.endswith("\n")]


def test_clomp_experiment_started_with_sigint_ignored_still_stops_on_ctrl_c(tmp_path: Path) -> None:
    out = tmp_path / "exp"
    argv = [sys.executable, "-m", "runtime.cli", "experiment", "overtaking", "--runs", "4", "--seed", "3",
            "--noise", "paper", "--max-time", "40", "--workers", "0", "--out", str(out), "--no-plots"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    try:
        deadline = time.monotonic() + 600  # the event is the first record on disk; the deadline only bounds a hang
        while not _records(out / "runs.jsonl"):
            assert proc.poll() is None, f"exited {proc.returncode} before a run finished: {proc.stderr.read()}"
            assert time.monotonic() < deadline
            time.sleep(0.01)
        os.killpg(proc.pid, signal.SIGINT)
        _, stderr = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "--resume" in stderr and "Traceback" not in stderr
    assert 1 <= len(_records(out / "runs.jsonl")) < 8
