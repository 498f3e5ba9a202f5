"""``bench/robust_vs_greedy.py --workers K``: the runs are independent, so the figures
do not depend on K (the CPU times aside)."""

from __future__ import annotations

import importlib
import sys
from pathlib import Path
from types import ModuleType
from typing import Any

import pytest

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")

BENCH = Path(__file__).resolve().parents[2] / "bench" / "robust_vs_greedy.py"


def _bench() -> ModuleType:
    # by its own name on sys.path, as a worker process (spawned: sys.path passed on) imports it
    if str(BENCH.parent) not in sys.path:
        sys.path.insert(0, str(BENCH.parent))
    return importlib.import_module(BENCH.stem)


def _without_cpu(pair: dict[str, Any]) -> dict[str, Any]:
    return {k: ({kk: vv for kk, vv in v.items() if kk != "cpu"} if isinstance(v, dict) else v) for k, v in pair.items()}


def test_workers_give_the_same_pairs_in_the_same_order() -> None:
    bench = _bench()
    argv = ["--runs", "3", "--first-run", "3", "--families", "doorway", "--max-time", "4", "--samples", "4"]
    serial = [_without_cpu(p) for p in bench._pairs(bench.parse_args(argv + ["--workers", "1"]))]
    parallel = [_without_cpu(p) for p in bench._pairs(bench.parse_args(argv + ["--workers", "2"]))]
    assert [(p["family"], p["run"]) for p in serial] == [("doorway", 3), ("doorway", 4), ("doorway", 5)]
    assert all(p["greedy"]["per_plan"] for p in serial)  # the runs planned: there is something to compare
    assert repr(parallel) == repr(serial)  # repr: nan (a plan not predicted) equals itself there


def test_bad_workers_and_runs_are_refused(capsys: pytest.CaptureFixture[str]) -> None:
    bench = _bench()
    for argv in (["--workers", "-1"], ["--runs", "0"]):
        with pytest.raises(SystemExit) as exc:
            bench.parse_args(argv)
        assert exc.value.code == 2
    assert "--workers" in capsys.readouterr().err
