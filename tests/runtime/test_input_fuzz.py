"""Fuzzing every input kind the command line reads (issue #43): run logs (``replay``,
``convert``), scenario files (``plan --scenario``), cognitive maps (``export --map``) and
property files (``check --specs``). Whatever the bytes: exit 0, 1 or 2 only; on exit 2
exactly one line ``clomp: error: …``; never an uncaught exception.

A few dozen examples per kind in the default run (seconds); ``-m slow`` runs many more.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from clomp.runtime.cli import main

_FAST = settings(max_examples=25, deadline=None, suppress_health_check=list(HealthCheck), derandomize=True)
_SLOW = settings(max_examples=400, deadline=None, suppress_health_check=list(HealthCheck))

_scalars = st.one_of(
    st.none(), st.booleans(), st.integers(min_value=-(10**40), max_value=10**40),
    st.floats(allow_nan=False, allow_infinity=False), st.sampled_from([1e300, -1e300, 1e-300, 0.0, -0.0]),
    st.text(max_size=8),
)
_json = st.recursive(_scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                      st.dictionaries(st.text(max_size=6), inner, max_size=4)),
                     max_leaves=12)
_pair = st.one_of(st.lists(st.floats(allow_nan=False, allow_infinity=False, min_value=-5, max_value=5), min_size=2, max_size=2), _json)


def _check(capsys: pytest.CaptureFixture[str], *argv: str) -> None:
    try:
        rc = main(list(argv))
    except SystemExit as exc:  # argparse: not expected with these arguments
        rc = int(exc.code or 0)
    out, err = capsys.readouterr()
    assert rc in (0, 1, 2), (argv, rc, err)
    assert "Traceback" not in err
    if rc == 2:
        assert err.startswith("clomp: error: ") and len(err.splitlines()) == 1, err


def _file(data: bytes, name: str) -> Path:
    d = Path(tempfile.mkdtemp(prefix="clomp-fuzz-"))
    p = d / name
    p.write_bytes(data)
    return p


# -- run logs ------------------------------------------------------------------------------------
_record = st.fixed_dictionaries(
    {"event": st.one_of(st.sampled_from(["run", "start", "scan", "plan", "motor", "fault", "stop", "task"]),
                        st.just("scan"), st.just("scan"), st.just("plan"), st.just("start"), _json)},
    optional={"t": st.one_of(st.floats(min_value=0, max_value=100), _json), "points": st.one_of(st.lists(_pair, max_size=5), _json),
              "goal": _pair, "pose": st.one_of(st.lists(st.floats(-5, 5), min_size=3, max_size=3), _json),
              "path": _json, "obstacles": _json, "wall": st.one_of(st.floats(0, 2e9), _json)},
)
_recline = _record.map(lambda r: json.dumps(r).encode())
_junk = st.one_of(st.binary(max_size=40), _json.map(lambda v: json.dumps(v).encode()))


@st.composite
def _log_bytes(draw: st.DrawFn) -> bytes:
    """Records (a log whose first line is junk would stop there), in one of four with a
    junk line somewhere (a line of binary bytes or JSON that is no record)."""
    lines = draw(st.lists(_recline, max_size=6))
    if draw(st.integers(0, 3)) == 0:
        lines.insert(draw(st.integers(0, len(lines))), draw(_junk))
    return b"\n".join(lines) + b"\n"


_log = _log_bytes()


def _fuzz_log(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    p = _file(data, "run.jsonl")
    _check(capsys, "replay", str(p))
    _check(capsys, "convert", str(p), "-o", str(p.with_suffix(".mcap")), "--bins", "64")


@_FAST
@given(data=_log)
def test_fuzz_run_logs(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_log(capsys, data)


@pytest.mark.slow
@_SLOW
@given(data=_log)
def test_fuzz_run_logs_long(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_log(capsys, data)


# -- scenarios -----------------------------------------------------------------------------------
_shape = st.fixed_dictionaries(
    {"type": st.one_of(st.sampled_from(["box", "wall", "circle", "polygon"]), _json)},
    optional={"center": _pair, "size": _pair, "from": _pair, "to": _pair, "radius": _scalars, "thickness": _scalars,
              "angle": _scalars, "points": st.one_of(st.lists(_pair, max_size=5), _json)},
)
_scenario_doc = st.fixed_dictionaries(
    {"goal": _pair},
    optional={"start": _json, "obstacles": st.one_of(st.lists(_shape, max_size=3), _json), "seed": _scalars,
              "name": _scalars, "description": _scalars, "noise": _json},
)
_scenario = st.one_of(_scenario_doc.map(lambda d: json.dumps(d).encode()), st.binary(max_size=60))


def _fuzz_scenario(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    p = _file(data, "s.json")
    _check(capsys, "plan", "--scenario", str(p), "--max-states", "8")


@_FAST
@given(data=_scenario)
def test_fuzz_scenarios(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_scenario(capsys, data)


@pytest.mark.slow
@_SLOW
@given(data=_scenario)
def test_fuzz_scenarios_long(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_scenario(capsys, data)


# -- cognitive maps --------------------------------------------------------------------------------
def _valid_map() -> dict[str, Any]:
    from clomp.planner import Configurator
    import numpy as np

    result: dict[str, Any] = Configurator().plan(np.array([[0.5, 0.05], [0.5, -0.05]]), (1.0, 0.0)).map.to_dict()
    return result


_MAP = _valid_map()


@st.composite
def _map_bytes(draw: st.DrawFn) -> bytes:
    """A valid map with one part replaced by an arbitrary value, or raw bytes."""
    if draw(st.booleans()):
        return draw(st.binary(max_size=60))
    doc = json.loads(json.dumps(_MAP))
    node: Any = doc
    for _ in range(draw(st.integers(0, 3))):
        keys = list(node) if isinstance(node, dict) else list(range(len(node))) if isinstance(node, list) else []
        if not keys:
            break
        k = draw(st.sampled_from(keys))
        if not isinstance(node[k], (dict, list)):
            node[k] = draw(_json)
            return json.dumps(doc).encode()
        node = node[k]
    if isinstance(node, dict) and node:
        node[draw(st.sampled_from(list(node)))] = draw(_json)
    elif isinstance(node, list) and node:
        node[draw(st.integers(0, len(node) - 1))] = draw(_json)
    return json.dumps(doc).encode()


def _fuzz_map(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    p = _file(data, "m.json")
    _check(capsys, "export", "--map", str(p), "-f", "prism", "-o", str(p.with_suffix(".prism")))


@_FAST
@given(data=_map_bytes())
def test_fuzz_maps(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_map(capsys, data)


@pytest.mark.slow
@_SLOW
@given(data=_map_bytes())
def test_fuzz_maps_long(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_map(capsys, data)


# -- property files ----------------------------------------------------------------------------------
_tokens = st.sampled_from(['Pmax=? [F "goal"]', "Pmin=?", "[", "]", '"collision"', "U", "F", "G", ">=", "0.9", "//",
                           "mdp", "dtmc", "\n", "# require", "P>=1", "!", "&", "(", ")", "name:", "required:", "≥"])
_specs = st.one_of(st.lists(_tokens, max_size=12).map(lambda t: " ".join(t).encode()), st.binary(max_size=60))


def _fuzz_specs(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    pytest.importorskip("stormpy")
    p = _file(data, "p.pctl")
    _check(capsys, "check", "--scenario", "open", "--specs", str(p))


@settings(_FAST, max_examples=10)
@given(data=_specs)
def test_fuzz_property_files(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_specs(capsys, data)


@pytest.mark.slow
@_SLOW
@given(data=_specs)
def test_fuzz_property_files_long(capsys: pytest.CaptureFixture[str], data: bytes) -> None:
    _fuzz_specs(capsys, data)
