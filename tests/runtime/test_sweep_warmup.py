"""Issue #41: a sweep compiles its numba kernels once, in the driver, before a local
cluster's workers start (each worker compiled them itself on an empty cache: ~30 s of CPU
per worker)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from clomp.runtime.experiment import driver, warmup
from clomp.runtime.experiment.runspec import RunSpec

REPO = Path(__file__).resolve().parents[2]


class _Stop(Exception):
    pass


def test_a_local_cluster_starts_only_after_the_kernels_are_warm(monkeypatch: pytest.MonkeyPatch) -> None:
    seen: list[Any] = []
    monkeypatch.setattr(driver, "warm_kernels", lambda specs: seen.append(("warm", [s.key for s in specs])))

    def client(workers: int, scheduler: str | None, dashboard: bool = False) -> Any:
        seen.append(("cluster", workers))
        raise _Stop

    monkeypatch.setattr(driver, "_dask_client", client)
    specs = [RunSpec("open", 0, 0, "reactive", "ideal")]
    with pytest.raises(_Stop):
        driver._run_on_dask(specs, 2, None, driver._Store(specs, None, False, None, None))
    assert seen == [("warm", [specs[0].key]), ("cluster", 2)]
    seen.clear()
    with pytest.raises(_Stop):  # another scheduler's workers may be on other machines: nothing to warm here
        driver._run_on_dask(specs, 0, "tcp://127.0.0.1:1", driver._Store(specs, None, False, None, None))
    assert seen == [("cluster", 0)]


def test_the_warm_up_runs_a_short_piece_of_one_run_per_condition(monkeypatch: pytest.MonkeyPatch) -> None:
    ran: list[RunSpec] = []

    def fake(spec: RunSpec) -> dict[str, Any]:
        ran.append(spec)
        if spec.condition == "dwa":
            raise RuntimeError("a broken condition")
        return {}

    monkeypatch.setattr(warmup, "run_spec", fake)
    specs = [RunSpec("overtaking", 0, k, c, n) for n in ("paper", "harsh") for k in range(3)
             for c in ("planning", "reactive", "dwa")]
    keys = warmup.warm_kernels(specs, seconds=5.0)
    assert [(s.condition, s.run, s.noise, s.max_time) for s in ran] == [
        ("planning", 0, "paper", 5.0), ("reactive", 0, "paper", 5.0), ("dwa", 0, "paper", 5.0)]
    assert keys == [ran[0].key, ran[1].key]  # the one that raised is passed over


_COUNT = """
import json, sys
from numba.core.registry import CPUDispatcher
from clomp.runtime.experiment.runspec import RunSpec
from clomp.runtime.experiment.runrecords import run_spec
from clomp.runtime.experiment.warmup import warm_kernels
specs = [RunSpec("overtaking", 2, k, c, n) for n in ("paper", "harsh") for c in ("planning", "reactive") for k in range(2)]
if sys.argv[1] == "warm":
    warm_kernels(specs)
else:
    for s in specs:
        run_spec(s)
kernels = {id(v): v for m in list(sys.modules.values()) if getattr(m, "__name__", "").startswith("clomp")
           for v in list(vars(m).values()) if isinstance(v, CPUDispatcher)}.values()
print(json.dumps({"hits": sum(sum(k._cache_hits.values()) for k in kernels),
                  "misses": sum(sum(k._cache_misses.values()) for k in kernels)}))
"""


@pytest.mark.slow
def test_after_the_warm_up_a_worker_compiles_nothing(tmp_path: Path) -> None:
    """On an empty cache, the warm-up (one process) compiles every kernel the sweep's runs
    use: a second process, as a worker, then runs them, paper and harsh, planning and
    reactive, loading every kernel from the cache and compiling none."""
    env = {**os.environ, "PYTHONPATH": str(REPO), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}

    def count(mode: str) -> dict[str, int]:
        out = subprocess.run([sys.executable, "-c", _COUNT, mode], env=env, capture_output=True, text=True,
                             check=True, timeout=900)
        got: dict[str, int] = json.loads(out.stdout.strip().splitlines()[-1])
        return got

    warm = count("warm")
    assert warm["misses"] > 0  # the cache was empty: the warm-up compiled
    worker = count("runs")
    assert worker["hits"] > 0 and worker["misses"] == 0, worker
