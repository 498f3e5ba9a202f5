"""The scan fuzz corpus through the command line: one line on stderr and exit 2, or a
warning and a defined outcome; never a traceback, never a hang (each case under 5 s)."""

from __future__ import annotations

import os
import struct
import subprocess
import sys
import threading
from pathlib import Path

import numpy as np
import pytest

from clomp.runtime.cli import main

_CASE_TIMEOUT = 5.0


def _run(argv: list[str]) -> int:
    """``main(argv)`` in a thread so that a blocking read fails the test instead of hanging it."""
    box: dict[str, object] = {}

    def target() -> None:
        try:
            box["rc"] = main(argv)
        except SystemExit as exc:  # argparse usage errors
            box["rc"] = exc.code
        except BaseException as exc:  # noqa: BLE001 - a traceback is what the test rules out
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(_CASE_TIMEOUT)
    assert not t.is_alive(), f"clomp {' '.join(argv)} still running after {_CASE_TIMEOUT} s"
    assert "error" not in box, f"uncaught {box.get('error')!r}"
    return int(box["rc"])  # type: ignore[call-overload]


def _npy(header: str) -> bytes:
    body = header.encode("latin1")
    return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(body)) + body


_CORPUS: dict[str, bytes] = {
    "unterminated-header.npy": _npy("{'descr': '<f8, 'fortran_order': False, 'shape': (3, 2), }"),
    "huge-shape.npy": _npy("{'descr': '<f8', 'fortran_order': False, 'shape': (10**9, 2), }"),
    "truncated.npy": _npy("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }") + b"\x00" * 8,
    "not-npy.npy": b"PK\x03\x04 a zip file",
    "complex.npy": b"",  # written with numpy below
    "three-columns.dat": b"0.5 0.1 0.2\n",
    "words.dat": b"x y\n",
    "nan.dat": b"nan 0.1\n",
    "binary.dat": b"\xff\xd8\xff\xe0JFIF",
    "huge-line.dat": b"0.5 " + b"9" * 5_000_000 + b"x\n",
}


@pytest.fixture(scope="module")
def corpus(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("corpus")
    for name, data in _CORPUS.items():
        (d / name).write_bytes(data)
    np.save(d / "complex.npy", np.array([[0.5 + 1j, 0.0]]))
    os.mkfifo(d / "fifo.dat")
    return d


@pytest.mark.parametrize("name", [*sorted(_CORPUS), "fifo.dat", "/dev/zero", "/dev/urandom", "."])
def test_each_bad_scan_is_one_line_and_exit_2(corpus, capsys, name):
    target = name if name.startswith("/") else str(corpus / name)
    if name == ".":
        target = str(corpus / "no-such-scan.dat")
    rc = _run(["plan", "--scan", target, "--goal", "1.0,0.0"])
    out, err = capsys.readouterr()
    assert rc == 2, err
    lines = err.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("clomp: error: "), err[:500]
    assert len(lines[0]) < 400 and out == ""


def test_a_scan_in_millimetres_is_refused_with_the_hint(scans_dir, tmp_path, capsys):
    """Issue #39: it warned and planned one straight through the obstacles, exit 0; now exit 2
    and one line saying what to pass (tests/runtime/test_cli_units.py: ``--units mm``)."""
    mm = np.loadtxt(scans_dir / "map0100.dat").reshape(-1, 2) * 1000
    f = tmp_path / "mm.dat"
    np.savetxt(f, mm)
    assert _run(["plan", "--scan", str(f), "--goal", "1.0,0.0", "--json"]) == 2
    out, err = capsys.readouterr()
    assert out == "" and err.startswith("clomp: error: --scan: looks like millimetres") and len(err.splitlines()) == 1
    assert "pass --units mm" in err


def test_a_real_console_run_prints_no_traceback(corpus):
    # the installed entry point, as a user runs it (warnings, tokenizer errors and all)
    code = "import sys; from clomp.runtime.cli import main; sys.exit(main())"
    p = subprocess.run(
        [sys.executable, "-c", code, "plan", "--scan", str(corpus / "unterminated-header.npy")],
        capture_output=True, text=True, timeout=120,
    )
    assert p.returncode == 2 and "Traceback" not in p.stderr
    assert p.stderr.startswith("clomp: error: ") and "bad header" in p.stderr
