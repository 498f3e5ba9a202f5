"""Long commands stop on Ctrl-C even when started with SIGINT ignored, as a script's background
job is (``cmd &`` without job control): Python then installs no KeyboardInterrupt handler, and a
command relying on it runs to its end. The pytest run itself may be such a job: so may CI."""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path


sys.path.insert(0, str(Path(__file__).parent))
from interrupting import interrupt_after_first_record, records  # noqa: E402


def test_clomp_experiment_started_with_sigint_ignored_still_stops_on_ctrl_c(tmp_path: Path) -> None:
    out = tmp_path / "exp"
    argv = [sys.executable, "-m", "clomp.runtime.cli", "experiment", "overtaking", "--runs", "4", "--seed", "3",
            "--noise", "paper", "--max-time", "40", "--workers", "0", "--out", str(out), "--no-plots"]
    proc = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_IGN))
    _, stderr = interrupt_after_first_record(proc, out / "runs.jsonl")
    assert proc.returncode == 130, stderr
    assert "interrupted" in stderr and "--resume" in stderr and "Traceback" not in stderr
    assert 1 <= len(records(out / "runs.jsonl")) < 8
