"""Scan input as an attacker would feed it: every bad file gets one ScanError, never a hang.

The fuzz corpus: Hypothesis-generated text and ``.npy`` bytes, fixed malformed files,
special files (FIFO, character device, folder, unreadable), oversized and wrong-unit
scans. Whatever comes in, :func:`load_scan` returns a finite N×2 array or raises one
:class:`ScanError` whose message is a single bounded line naming the file.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import struct
import tempfile
import threading
import warnings
from collections.abc import Iterator
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from clomp.planner import plan, scanfile
from clomp.planner.perception import (
    MAX_SCAN_BYTES,
    MAX_SCAN_POINTS,
    ScanError,
    ScanWarning,
    load_scan,
    perceive,
    range_warning,
    scan_files,
    validate_scan,
)

# an error message is one line, short enough to read (a 5 MB line is never echoed whole)
_MAX_MESSAGE = 400


def _outcome(path: Path) -> np.ndarray | ScanError:
    """load_scan's answer: an array or the ScanError (anything else fails the test)."""
    try:
        arr = load_scan(path)
    except ScanError as exc:
        msg = str(exc)
        assert "\n" not in msg and len(msg) <= _MAX_MESSAGE, msg[:1000]
        assert str(path) in msg
        return exc
    assert arr.dtype == np.float64 and arr.ndim == 2 and arr.shape[1] == 2
    assert np.isfinite(arr).all()
    return arr


def _in_thread(fn, timeout: float = 5.0):
    """Run ``fn`` in a daemon thread; fail (instead of hanging the suite) if it blocks."""
    box: dict[str, object] = {}

    def target() -> None:
        try:
            box["value"] = fn()
        except BaseException as exc:  # noqa: BLE001 - handed back to the test
            box["error"] = exc

    t = threading.Thread(target=target, daemon=True)
    t.start()
    t.join(timeout)
    assert not t.is_alive(), f"blocked for more than {timeout} s"
    if "error" in box:
        raise box["error"]  # type: ignore[misc]
    return box["value"]


# ---------------------------------------------------------------- generated corpus

_tokens = st.sampled_from(
    ["0.5", "-0.2", "1e3", "nan", "inf", "-inf", "0x10", "abc", "#", ",", " ", "\t", "\n", "\r\n",
     "1,2", "1 2 3", "\x00", "é", "1_0", "+", "-", ".", "e", "{", "'", '"', "\\", "(", "\x0c"]
)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_tokens, max_size=40).map("".join) | st.text(max_size=200))
def test_generated_text_scans_get_an_array_or_one_scan_error(tmp_path, text):
    f = tmp_path / "fuzz.dat"
    f.write_bytes(text.encode("utf-8", "surrogatepass"))
    _outcome(f)


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.binary(max_size=300))
def test_random_bytes_as_text_or_npy_get_an_array_or_one_scan_error(tmp_path, data):
    for name in ("fuzz.dat", "fuzz.npy"):
        f = tmp_path / name
        f.write_bytes(data)
        _outcome(f)


def _npy_header(header: str, version: tuple[int, int] = (1, 0)) -> bytes:
    body = header.encode("utf-8")
    if version == (1, 0):
        return b"\x93NUMPY\x01\x00" + struct.pack("<H", len(body)) + body
    return b"\x93NUMPY" + bytes(version) + struct.pack("<I", len(body)) + body


_header_text = st.one_of(
    st.text(max_size=80),
    st.builds(
        "{{'descr': {}, 'fortran_order': {}, 'shape': {}, }}".format,
        st.sampled_from(["'<f8'", "'<c16'", "'|O'", "'<U3'", "'|b1'", "[('x', '<f8')]", "'<i4'", "'xx'", "'<f8"]),
        st.sampled_from(["False", "True", "0", "'no'"]),
        st.sampled_from(["(3, 2)", "(2,)", "(0, 2)", "(10**12, 2)", "(-1, 2)", "(3, 2", "()", "(1, 1, 2)", "'x'"]),
    ),
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(_header_text, st.sampled_from([(1, 0), (2, 0), (3, 0), (9, 9)]), st.binary(max_size=64))
@example("{'descr':'B','fortran_order':False,'shape':(-1,2)}", (1, 0), b"\x00")  # found by Hypothesis: a negative dimension
def test_malformed_npy_headers_get_one_scan_error(tmp_path, header, version, payload):
    f = tmp_path / "fuzz.npy"
    f.write_bytes(_npy_header(header, version) + payload)
    _outcome(f)


# ---------------------------------------------------------------- fixed corpus


@pytest.mark.parametrize(
    "header, needle",
    [
        # the tokenizer error the issue saw as a traceback (an unterminated string)
        ("{'descr': '<f8, 'fortran_order': False, 'shape': (3, 2), }", "bad header"),
        ("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2\n", "bad header"),
        ("{'descr': '<c16', 'fortran_order': False, 'shape': (3, 2), }", "complex"),
        ("{'descr': '|O', 'fortran_order': False, 'shape': (3, 2), }", "bad header|numeric"),
        ("{'descr': '<U4', 'fortran_order': False, 'shape': (3, 2), }", "numeric"),
        ("{'descr': [('x', '<f8'), ('y', '<f8')], 'fortran_order': False, 'shape': (3,), }", "numeric"),
        ("{'descr': '<f8', 'fortran_order': False, 'shape': (1000000000000, 2), }", "limit"),
        ("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 2), }", "truncated"),
        ("{'descr': '<f8', 'fortran_order': False, 'shape': (3, 3), }", "N×2"),
    ],
)
def test_fixed_malformed_npy_files(tmp_path, header, needle):
    f = tmp_path / "bad.npy"
    f.write_bytes(_npy_header(header) + b"\x00" * 16)
    with pytest.raises(ScanError, match=needle):
        _in_thread(lambda: load_scan(f))


def test_npy_files_numpy_writes_round_trip(tmp_path):
    a = np.array([[0.3, 0.0], [0.31, -0.1], [0.5, 0.2]])
    for arr in (a, a.astype(np.float32), np.asfortranarray(a), (a * 10).astype(np.int16)):
        np.save(tmp_path / "s.npy", arr)
        np.testing.assert_array_equal(load_scan(tmp_path / "s.npy"), arr.astype(np.float64))
    np.save(tmp_path / "e.npy", np.zeros((0, 2)))
    assert load_scan(tmp_path / "e.npy").shape == (0, 2)


def test_complex_npy_is_refused_not_truncated(tmp_path):
    np.save(tmp_path / "c.npy", np.array([[0.5 + 1j, 0.1]]))
    with pytest.raises(ScanError, match="complex"):
        load_scan(tmp_path / "c.npy")
    with pytest.raises(ScanError, match="complex"):
        validate_scan(np.array([[0.5 + 0j, 0.1]]))


def test_masked_points_are_missing_returns():
    pts = np.ma.array([[0.5, 0.1], [0.4, 0.0], [0.3, -0.1]], mask=[[False, False], [False, True], [False, False]])
    assert validate_scan(pts).tolist() == [[0.5, 0.1], [0.3, -0.1]]
    # the masked point must not become an obstacle
    assert perceive(np.ma.array([[0.4, 0.0]], mask=[[True, True]])).boxes.shape[0] == 0


def test_a_huge_malformed_line_is_not_echoed_whole(tmp_path):
    f = tmp_path / "big.dat"
    f.write_text("0.5 0.1\n" + "x" * 5_000_000 + "\n")
    with pytest.raises(ScanError) as exc:
        load_scan(f)
    msg = str(exc.value)
    assert ":2:" in msg and "5,000,000 characters" in msg and len(msg) < _MAX_MESSAGE


def test_commas_comments_and_crlf_are_accepted(tmp_path):
    f = tmp_path / "s.txt"
    f.write_bytes(b"# x, y in metres\r\n0.5,0.1\r\n0.6 , -0.2  # a wall\r\n\r\n")
    assert load_scan(f).tolist() == [[0.5, 0.1], [0.6, -0.2]]


def test_binary_content_is_named(tmp_path):
    f = tmp_path / "s.dat"
    f.write_bytes(b"\xff\xfe\x00garbage")
    with pytest.raises(ScanError, match="binary content"):
        load_scan(f)


# ---------------------------------------------------------------- special files


def test_a_fifo_is_refused_without_blocking(tmp_path):
    fifo = tmp_path / "scan.dat"
    os.mkfifo(fifo)
    with pytest.raises(ScanError, match="FIFO"):
        _in_thread(lambda: load_scan(fifo))


@pytest.mark.parametrize("device", ["/dev/zero", "/dev/urandom", "/dev/null"])
def test_a_character_device_is_refused_without_reading_it(device):
    if not os.path.exists(device):
        pytest.skip(f"{device} absent")
    with pytest.raises(ScanError, match="character device"):
        _in_thread(lambda: load_scan(device))


def test_a_folder_or_missing_file_is_named(tmp_path):
    with pytest.raises(ScanError, match="is a folder"):
        load_scan(tmp_path)
    with pytest.raises(ScanError, match="no such file"):
        load_scan(tmp_path / "nope.dat")


def test_the_read_is_bounded_even_when_the_size_is_not_known(monkeypatch):
    # /proc files are regular with st_size 0 yet have content: only the bounded read
    # (not the size check) can stop an endless one
    proc = Path("/proc/self/status")
    if not proc.exists() or proc.stat().st_size != 0:
        pytest.skip("no /proc file of unknown size here")
    monkeypatch.setattr(scanfile, "MAX_SCAN_BYTES", 100)  # where the reader looks it up
    with pytest.raises(ScanError, match="limit"):
        _in_thread(lambda: load_scan(proc))


def test_oversized_files_and_scans_are_refused(tmp_path):
    f = tmp_path / "huge.dat"
    with open(f, "wb") as fh:  # sparse: no real disk used
        fh.truncate(MAX_SCAN_BYTES + 1)
    with pytest.raises(ScanError, match="MiB limit"):
        _in_thread(lambda: load_scan(f))
    many = tmp_path / "many.dat"
    many.write_text("0.5 0.1\n" * (MAX_SCAN_POINTS + 1))
    with pytest.raises(ScanError, match="limit of 50,000 points"):
        _in_thread(lambda: load_scan(many))
    with pytest.raises(ScanError, match="limit of 50,000"):
        validate_scan(np.zeros((MAX_SCAN_POINTS + 1, 2)))
    with pytest.raises(ScanError, match="limit"):
        plan(np.full((1_000_000, 2), 0.5), goal=(1.0, 0.0))


@contextlib.contextmanager
def _as_nobody() -> Iterator[None]:
    """Run the block without root's right to read anything (effective uid ``nobody``)."""
    if os.geteuid() != 0:
        yield
        return
    os.setegid(65534)
    os.seteuid(65534)
    try:
        yield
    finally:
        os.seteuid(0)
        os.setegid(0)


@pytest.fixture
def open_dir() -> Iterator[Path]:
    """A folder every user may enter (tmp_path's parents are private to root)."""
    d = Path(tempfile.mkdtemp(prefix="clomp-perm-"))
    d.chmod(0o755)
    yield d
    for p in d.rglob("*"):
        p.chmod(0o700)
    shutil.rmtree(d)


def test_unreadable_file_and_folder_are_named(open_dir):
    f = open_dir / "secret.dat"
    f.write_text("0.5 0.1\n")
    f.chmod(0)
    folder = open_dir / "locked"
    folder.mkdir()
    (folder / "map0001.dat").write_text("0.5 0.1\n")
    folder.chmod(0)
    with _as_nobody():
        with pytest.raises(ScanError, match="permission denied"):
            load_scan(f)
        with pytest.raises(ScanError, match="permission denied"):
            scan_files(folder)


def test_scan_files_lists_by_suffix_and_names_empty_folders(tmp_path):
    (tmp_path / "map0002.dat").write_text("")
    (tmp_path / "map0001.dat").write_text("")
    (tmp_path / "README.md").write_text("hello")
    (tmp_path / ".hidden.dat").write_text("")
    assert [p.name for p in scan_files(tmp_path)] == ["map0001.dat", "map0002.dat"]
    with pytest.raises(ScanError, match="not a folder"):
        scan_files(tmp_path / "map0001.dat")
    with pytest.raises(ScanError, match="no such folder"):
        scan_files(tmp_path / "nope")
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises(ScanError, match="no scan files"):
        scan_files(empty)


# ---------------------------------------------------------------- wrong units


def test_returns_beyond_the_horizon_are_cropped_silently_and_millimetres_are_suspected(scans_dir):
    """Issue #39: cropping to the planning horizon is normal (an A1 returns to 12 m), not a
    warning; a scan that looks like millimetres still warns in the library (the commands
    refuse it: ``--units``)."""
    metres = load_scan(scans_dir / "map0100.dat")
    far = np.c_[np.linspace(2.0, 11.0, 50), np.linspace(-3.0, 3.0, 50)]  # an A1's far returns
    with warnings.catch_warnings():
        warnings.simplefilter("error", ScanWarning)
        perceive(metres)  # a recorded scan in metres: no warning
        assert len(perceive(np.vstack([metres, far]))) == len(perceive(metres))  # cropped, silently
    mm = metres * 1000.0
    with pytest.warns(ScanWarning, match=r"looks like millimetres.*beyond the 1.1 m planning horizon"):
        obs = perceive(mm)
    assert len(obs) == 0
    assert range_warning(np.array([[0.5, 0.0], [2.0, 0.0], [0.7, 0.0]]), 1.1) is None
    assert range_warning(metres, 1.1) is None
