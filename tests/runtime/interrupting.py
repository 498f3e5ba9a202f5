"""Shared by the Ctrl-C tests of long commands: wait for the first streamed record (the event),
then send SIGINT to the command's process group as a terminal's Ctrl-C does."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import time
from pathlib import Path


def records(path: Path) -> list[dict]:
    """The complete lines of runs.jsonl (a line being written has no newline yet)."""
    if not path.exists():
        return []
    text = path.read_text(encoding="utf-8")
    return [json.loads(line) for line in text.splitlines(keepends=True) if line.endswith("\n")]


def interrupt_after_first_record(proc: subprocess.Popen[str], jsonl: Path) -> tuple[str, str]:
    """SIGINT to ``proc``'s group once ``jsonl`` holds a record; its (stdout, stderr) once it ends.

    The deadline only bounds a hang (a loaded machine may take minutes); the process group is
    killed whatever happens, so no worker outlives the test.
    """
    try:
        deadline = time.monotonic() + 600
        while not records(jsonl):
            assert proc.poll() is None, f"exited {proc.returncode} before a run finished: {proc.stderr.read() if proc.stderr else ''}"
            assert time.monotonic() < deadline, f"no run streamed to {jsonl.name} within 600 s"
            time.sleep(0.01)
        os.killpg(proc.pid, signal.SIGINT)
        return proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
