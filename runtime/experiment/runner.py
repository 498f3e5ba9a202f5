"""The paper's experiment, planning vs the reactive loop: one run as a pure function, many on Dask.

One place per noun; this module gathers their names (import from here or from the module itself):

- :mod:`.runspec` — :class:`RunSpec`, everything one run depends on, and its seeding
  (:func:`noise_seed`, :func:`scene_for`, :func:`experiment_specs`);
- :mod:`.onerun` — :func:`run_once`, one condition on a fresh robot measured on the ground
  truth (:class:`RunResult`, :data:`SUCCESS_RADIUS`);
- :mod:`.runrecords` — :func:`run_spec`, a run as a JSON-ready record, and :func:`load_records`;
- :mod:`.driver` — :func:`run_experiment`, every run in this process or on Dask, streamed to
  ``runs.jsonl`` and resumed from it (:class:`ExperimentInterrupted`, :class:`RunsFailed`);
- :data:`PAPER`, the paper's figures, lives with the tables of :mod:`.results`.

>>> from clomp.runtime.experiment import onerun
>>> run_once is onerun.run_once
True
"""

from __future__ import annotations

from clomp.runtime.experiment.driver import ExperimentInterrupted, RunsFailed, run_experiment
from clomp.runtime.experiment.onerun import SUCCESS_RADIUS, RunResult, run_once
from clomp.runtime.experiment.results import PAPER
from clomp.runtime.experiment.runrecords import load_records, run_spec
from clomp.runtime.experiment.runspec import CONDITIONS, RunSpec, experiment_specs, noise_seed, scene_for

__all__ = ["CONDITIONS", "PAPER", "SUCCESS_RADIUS", "ExperimentInterrupted", "RunsFailed", "RunResult", "RunSpec",
           "experiment_specs", "load_records", "noise_seed", "run_experiment", "run_once", "run_spec",
           "scene_for"]
