"""``bench/robust_vs_greedy.py --workers K``: the runs are independent, so the figures
do not depend on K (the CPU times aside)."""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType
from typing import Any

import pytest

pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")


@pytest.fixture
def bench(bench_script: Callable[[str], ModuleType]) -> ModuleType:
    # by its own name on sys.path, as a worker process (spawned: sys.path passed on) imports it
    return bench_script("robust_vs_greedy")


def _without_cpu(pair: dict[str, Any]) -> dict[str, Any]:
    return {k: ({kk: vv for kk, vv in v.items() if kk != "cpu"} if isinstance(v, dict) else v) for k, v in pair.items()}


def test_workers_give_the_same_pairs_in_the_same_order(bench: ModuleType) -> None:
    argv = ["--runs", "3", "--first-run", "3", "--families", "doorway", "--max-time", "4", "--samples", "4"]
    serial = [_without_cpu(p) for p in bench._pairs(bench.parse_args(argv + ["--workers", "1"]))]
    parallel = [_without_cpu(p) for p in bench._pairs(bench.parse_args(argv + ["--workers", "2"]))]
    assert [(p["family"], p["run"]) for p in serial] == [("doorway", 3), ("doorway", 4), ("doorway", 5)]
    assert all(p["greedy"]["per_plan"] for p in serial)  # the runs planned: there is something to compare
    assert repr(parallel) == repr(serial)  # repr: nan (a plan not predicted) equals itself there


def test_bad_workers_and_runs_are_refused(capsys: pytest.CaptureFixture[str], bench: ModuleType) -> None:
    for argv in (["--workers", "-1"], ["--runs", "0"]):
        with pytest.raises(SystemExit) as exc:
            bench.parse_args(argv)
        assert exc.value.code == 2
    assert "--workers" in capsys.readouterr().err
