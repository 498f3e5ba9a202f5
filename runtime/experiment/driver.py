"""Many runs of an experiment: :func:`run_experiment` maps
:func:`~clomp.runtime.experiment.runrecords.run_spec` over every
:class:`~clomp.runtime.experiment.runspec.RunSpec` of it, in this process (``workers=0``)
or on Dask (a local cluster of ``workers`` processes, or an existing scheduler), streaming
each record to ``runs.jsonl`` as it finishes (``resume=True`` skips those there).
"""

from __future__ import annotations

import functools
import importlib
import importlib.util
import json
import os
import warnings
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.provenance import claim_folder
from clomp.runtime.experiment.runrecords import PLOTTED_RUNS, load_records, run_spec, summary_record
from clomp.runtime.experiment.runspec import DEFAULT_CONDITIONS, RunSpec, experiment_specs
from clomp.runtime.experiment.warmup import warm_kernels

__all__ = ["ExperimentInterrupted", "RunsFailed", "batch_size", "run_experiment", "run_specs"]


class ExperimentInterrupted(KeyboardInterrupt):
    """Ctrl-C during an experiment: ``records`` holds the runs that finished (all saved)."""

    def __init__(self, records: list[dict[str, Any]], total: int) -> None:
        super().__init__(f"interrupted: {len(records)} of {total} runs finished")
        self.records = records
        self.total = total


class RunsFailed(RuntimeError):
    """Some runs raised: ``records`` holds the ones that finished, ``failures`` key → error."""

    def __init__(self, records: list[dict[str, Any]], failures: dict[str, str]) -> None:
        first = next(iter(failures.items()))
        super().__init__(f"{len(failures)} run(s) failed, first {first[0]}: {first[1]}")
        self.records = records
        self.failures = failures


def run_experiment(
    family: str = "overtaking",
    runs: int = 10,
    seed: int = 0,
    *,
    noise: str = "paper",
    noise_scales: Sequence[float] = (1.0,),
    conditions: Sequence[str] = DEFAULT_CONDITIONS,
    max_time: float = 120.0,
    workers: int = 0,
    scheduler: str | None = None,
    out: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: Callable[[int, int], Any] | None = None,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    feedback: str = "scan",
    gyro: bool = True,
    policy: str | None = None,
) -> list[dict[str, Any]]:
    """Run an experiment; the records of every run (finished before or now), in spec order.

    ``workers=0`` runs in this process; ``workers=K`` starts a local Dask cluster of K
    processes; ``scheduler`` uses an existing one. With ``out``, each record is appended
    to ``out/runs.jsonl`` as it finishes; ``resume`` keeps the ones already there (same
    specs) and runs only the rest. Ctrl-C raises :class:`ExperimentInterrupted` holding
    what finished. A worker lost mid-run has its runs retried on another. A run that raises
    does not stop the others: at the end :class:`RunsFailed` names the failures (also in
    ``out/errors.jsonl``) and holds the records that finished. ``progress``
    makes a bar from (total, already done); it gets ``update(1)`` per run and ``close()``.
    ``policy``: the ``rl`` condition's policy file (None: the shipped one).
    ``gyro`` False takes the world's rate gyro off (the paper's robot; ``clomp run`` without an IMU).
    With ``out`` the records are kept whole on disk only: in memory (and in what this returns)
    the runs from :data:`~clomp.runtime.experiment.runrecords.PLOTTED_RUNS` on lose their
    traces (:func:`~clomp.runtime.experiment.runrecords.summary_record`), so memory stays
    flat however many runs (``load_records(out / "runs.jsonl")`` reads them back whole);
    ``on_record`` gets every record whole.

    >>> recs = run_experiment("overtaking", runs=1, noise="ideal", conditions=("reactive",))
    >>> [(r["condition"], r["run"]) for r in recs]
    [('reactive', 0)]
    """
    specs = experiment_specs(family, runs, seed, noise=noise, noise_scales=noise_scales, conditions=conditions,
                             max_time=max_time, feedback=feedback, gyro=gyro, policy=policy)
    return run_specs(specs, workers=workers, scheduler=scheduler, out=out, resume=resume, progress=progress,
                     on_record=on_record)


def run_specs(
    specs: Sequence[RunSpec],
    *,
    workers: int = 0,
    scheduler: str | None = None,
    out: str | os.PathLike[str] | None = None,
    resume: bool = False,
    progress: Callable[[int, int], Any] | None = None,
    on_record: Callable[[dict[str, Any]], None] | None = None,
    on_dashboard: Callable[[str], None] | None = None,
) -> list[dict[str, Any]]:
    """Run any list of :class:`~clomp.runtime.experiment.runspec.RunSpec` (several families,
    presets, seeds and conditions: a sweep) as :func:`run_experiment` runs one experiment's;
    ``on_dashboard`` gets the Dask dashboard's address when the local cluster serves one
    (bokeh installed: ``clomp[dask]``).

    >>> from clomp.runtime.experiment.runspec import RunSpec
    >>> [r["key"] for r in run_specs([RunSpec("open", 0, 0, "reactive", "ideal")])]
    ['open/0/0/reactive/ideal/1/120']
    """
    specs = list(specs)
    if len({s.key for s in specs}) != len(specs):
        raise ValueError("the same run is listed twice")
    store = _Store(specs, out, resume, progress, on_record)
    todo = [s for s in specs if s.key not in store.done]
    try:
        if todo and (workers > 0 or scheduler):
            _run_on_dask(todo, workers, scheduler, store, on_dashboard)
        else:
            _run_here(todo, store)
    except KeyboardInterrupt:
        raise ExperimentInterrupted(store.finished(specs), len(specs)) from None
    finally:
        store.close()
    if store.failures:
        raise RunsFailed(store.finished(specs), store.failures)
    return [store.done[s.key] for s in specs]


class _Store:
    """Where the runs of an experiment go as they finish: ``done`` (key → record) and
    ``failures`` (key → error); with ``out``, ``out/runs.jsonl`` (resumed: every record
    there is kept, the file rewritten clean, and those of the same specs count as done) and ``out/errors.jsonl``
    (started afresh); the progress bar and ``on_record``."""

    def __init__(self, specs: list[RunSpec], out: str | os.PathLike[str] | None, resume: bool,
                 progress: Callable[[int, int], Any] | None,
                 on_record: Callable[[dict[str, Any]], None] | None) -> None:
        self.done: dict[str, dict[str, Any]] = {}
        self.failures: dict[str, str] = {}
        self._on_record = on_record
        self._sink = None if out is None else self._open(Path(out), resume, {s.key for s in specs})
        self._errors = None if out is None else Path(out) / "errors.jsonl"
        self._bar = progress(len(specs), len(self.done)) if progress else None
        if self._errors is not None and self._errors.exists():
            self._errors.unlink()

    def _open(self, folder: Path, resume: bool, wanted: set[str]) -> Any:
        claim_folder(folder, resume)  # refuses to resume another code version's runs
        path = folder / "runs.jsonl"
        if resume:
            # every finished run stays on disk, also those outside this selection (a narrower
            # resume must not delete a wider sweep's runs); only the selection's count as done
            kept = {rec["key"]: rec for rec in load_records(path)}
            # rewrite clean (drops a line cut short by a crash, and a run written twice)
            path.write_text("".join(json.dumps(r, allow_nan=False) + "\n" for r in kept.values()), encoding="utf-8")
            self.done.update((key, self._in_memory(rec, on_disk=True)) for key, rec in kept.items() if key in wanted)
        else:
            path.write_text("", encoding="utf-8")
        return open(path, "a", encoding="utf-8")

    @staticmethod
    def _in_memory(rec: dict[str, Any], on_disk: bool) -> dict[str, Any]:
        """What of a record stays in memory: all of it unless it is on disk and not plotted."""
        return summary_record(rec) if on_disk and int(rec["run"]) >= PLOTTED_RUNS else rec

    def keep(self, rec: dict[str, Any]) -> None:
        """A run finished: its record."""
        self.done[rec["key"]] = self._in_memory(rec, on_disk=self._sink is not None)
        if self._sink is not None:
            self._sink.write(json.dumps(rec, allow_nan=False) + "\n")
            self._sink.flush()
        if self._bar is not None:
            self._bar.update(1)
        if self._on_record is not None:
            self._on_record(rec)

    def fail(self, key: str, exc: BaseException | str | None) -> None:
        """A run raised (the exception, or its ``"Type: message"``): one broken run must not cost the others."""
        self.failures[key] = exc if isinstance(exc, str) else f"{type(exc).__name__}: {exc}"
        if self._errors is not None:
            with open(self._errors, "a", encoding="utf-8") as fh:
                fh.write(json.dumps({"key": key, "error": self.failures[key]}) + "\n")
        if self._bar is not None:
            self._bar.update(1)

    def finished(self, specs: list[RunSpec]) -> list[dict[str, Any]]:
        """The records of the runs that finished, in spec order."""
        return [self.done[s.key] for s in specs if s.key in self.done]

    def close(self) -> None:
        """Close the bar and ``runs.jsonl``."""
        if self._bar is not None:
            self._bar.close()
        if self._sink is not None:
            self._sink.close()


def _run_here(todo: list[RunSpec], store: _Store) -> None:
    """Every run of ``todo`` in this process, one after the other."""
    for s in todo:
        try:
            rec = run_spec(s)
        except Exception as exc:  # one broken run must not cost the others
            store.fail(s.key, exc)
        else:
            store.keep(rec)


def _run_batch(run: Callable[[RunSpec], dict[str, Any]], specs: list[RunSpec]) -> list[tuple[str, dict[str, Any] | None, str | None]]:
    """Several runs as one Dask task: ``(key, record, None)`` for each that finished,
    ``(key, None, "Type: message")`` for each that raised (one broken run must not cost the
    others in its batch)."""
    out: list[tuple[str, dict[str, Any] | None, str | None]] = []
    for s in specs:
        try:
            out.append((s.key, run(s), None))
        except Exception as exc:
            out.append((s.key, None, f"{type(exc).__name__}: {exc}"))
    return out


def batch_size(runs: int, workers: int) -> int:
    """Runs per Dask task: a task's scheduling costs milliseconds of three processes' CPU and a
    round trip, a run about a second, so a long sweep batches up to 8 runs a task; a short one
    keeps about 16 tasks per worker, so that the last tasks do not leave a worker idle.

    >>> batch_size(80, 2), batch_size(10_000, 2), batch_size(5, 2)
    (2, 8, 1)
    """
    return max(1, min(8, runs // (16 * max(workers, 1))))


def _run_on_dask(todo: list[RunSpec], workers: int, scheduler: str | None, store: _Store,
                 on_dashboard: Callable[[str], None] | None = None) -> None:
    """Every run of ``todo`` on Dask in batches (:func:`batch_size`), each run kept as its
    batch finishes; a lost worker's batches are retried. A local cluster's workers start
    after :func:`~clomp.runtime.experiment.warmup.warm_kernels` (compiled once here, not
    once per worker; an external scheduler's workers may be on other machines)."""
    if not scheduler:
        warm_kernels(todo)
    client, cluster = _dask_client(workers, scheduler, dashboard=on_dashboard is not None)
    try:
        link = getattr(client, "dashboard_link", None) if on_dashboard is not None else None
        if link and (cluster is None or importlib.util.find_spec("bokeh") is not None):
            on_dashboard(str(link))  # type: ignore[misc]
        as_completed: Any = importlib.import_module("distributed").as_completed
        n = batch_size(len(todo), workers or len(client.scheduler_info().get("workers", ())) or 1)
        batches = [todo[k:k + n] for k in range(0, len(todo), n)]
        futures = client.map(functools.partial(_run_batch, run_spec), batches,
                             key=["clomp-" + b[0].key + (f"+{len(b) - 1}" if len(b) > 1 else "") for b in batches],
                             pure=False, retries=2)
        keys = {f.key: b for f, b in zip(futures, batches)}
        for fut in as_completed(futures):
            if fut.status == "error":  # the batch itself failed (not a run in it): every run of it
                for s in keys[fut.key]:
                    store.fail(s.key, fut.exception())
                continue
            for key, rec, error in fut.result():
                if rec is None:
                    store.fail(key, error)
                else:
                    store.keep(rec)
    finally:
        client.close()
        if cluster is not None:
            cluster.close()


#: a local cluster's background work that a sweep does not need: the workers' statistical
#: profiler (a sample every 10 ms), the system monitor's 0.5 s samples, the 20 ms event-loop tick
#: (measured idle: 2.5 s of CPU per 30 s for a scheduler and two workers, 0.9 s without), the
#: workers' memory check every 100 ms (a run holds a few hundred MB; once a second still
#: pauses or ends a worker that runs away: 0.55 s per 30 s idle without the 0.1 s checks)
_QUIET = {"distributed.worker.profile.enabled": False, "distributed.admin.system-monitor.interval": "2s",
          "distributed.admin.tick.interval": "200ms", "distributed.worker.memory.monitor-interval": "1s"}


def _dask_client(workers: int, scheduler: str | None, dashboard: bool = False) -> tuple[Any, Any]:
    import logging

    try:
        distributed: Any = importlib.import_module("distributed")
    except ImportError:
        raise RuntimeError("running on Dask needs dask.distributed: pip install 'clomp[dask]' "
                           "(or --workers 0 to run in this process)") from None
    if scheduler:
        return distributed.Client(scheduler), None
    # the worker processes ignore Ctrl-C (they inherit SIG_IGN): the terminal's SIGINT reaches the
    # whole process group, and only this process should answer it (cancel, keep what finished)
    import signal

    previous = signal.signal(signal.SIGINT, signal.SIG_IGN) if _main_thread() else None
    try:
        with warnings.catch_warnings():  # "port 8787 in use, using another": the scheduler's HTTP server, harmless
            warnings.simplefilter("ignore", UserWarning)
            with importlib.import_module("dask").config.set(_QUIET):
                cluster = distributed.LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                                                   host="127.0.0.1", dashboard_address="127.0.0.1:0" if dashboard else None,
                                                   silence_logs=logging.CRITICAL)
    finally:
        if previous is not None:
            signal.signal(signal.SIGINT, previous)
    return distributed.Client(cluster), cluster


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()
