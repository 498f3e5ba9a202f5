"""What one run of an experiment depends on, and every run of one: :class:`RunSpec` and its seeding.

A run is (family, seed, run index, condition, noise preset, noise scale, time limit,
feedback, gyro). The layout is :func:`~clomp.runtime.experiment.layouts.make_layout` (family,
seed, run) and the world's noise seed (:func:`noise_seed`) depends on (seed, run) only,
so the two conditions of a run meet the same world and the same noise (paired), and a
result does not depend on which process computed it or when.

>>> [s.key for s in experiment_specs("overtaking", 1, 7)]
['overtaking/7/0/planning/paper/1/120', 'overtaking/7/0/reactive/paper/1/120']
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from clomp.planner.scenarios import Scene, load_scenario
from clomp.runtime.experiment.groundtruth import NOISE_PRESETS
from clomp.runtime.backends.world import parse_movers
from clomp.runtime.experiment.layouts import ALL_FAMILIES, MOVING_FAMILIES, make_layout
from clomp.runtime.experiment.policy import load_policy, policy_id

__all__ = ["CONDITIONS", "DEFAULT_CONDITIONS", "RunSpec", "check_condition", "experiment_specs", "movers_for", "noise_seed", "scene_for"]

CONDITIONS = ("planning", "reactive", "dwa", "rl")
"""The experiment's conditions: the planner, the authors' one-loop reactive controller, the
dynamic window approach (:mod:`clomp.runtime.experiment.dwa`) and a learned policy
(:mod:`clomp.runtime.experiment.rl`)."""
DEFAULT_CONDITIONS = ("planning", "reactive")
"""The conditions an experiment runs unless told: the paper's comparison."""


def check_condition(condition: str) -> None:
    """ValueError unless ``condition`` is one of :data:`CONDITIONS`.

    >>> check_condition("reactive")
    """
    if condition not in CONDITIONS:
        raise ValueError(f"condition must be one of {', '.join(CONDITIONS)}, got {condition!r}")


@dataclass(frozen=True)
class RunSpec:
    """Everything one run depends on. ``family`` is a layout family or a scenario (name or file).

    >>> RunSpec("overtaking", 0, 3, "reactive", "harsh", 0.5).key
    'overtaking/0/3/reactive/harsh/0.5/120'
    """

    family: str
    seed: int
    run: int
    condition: str
    noise: str = "paper"
    noise_scale: float = 1.0
    max_time: float = 120.0
    feedback: str = "scan"
    gyro: bool = True
    policy: str | None = None

    @property
    def key(self) -> str:
        """A stable name for the run (the Dask task key and the resume key; the defaults,
        scan feedback and the gyro on, add nothing, so older keys still resume; an ``rl`` run's key
        names its policy file by content, so a resume never mixes two policies).

        >>> RunSpec("open", 0, 0, "planning", gyro=False).key
        'open/0/0/planning/paper/1/120/gyro=off'
        """
        key = f"{self.family}/{self.seed}/{self.run}/{self.condition}/{self.noise}/{self.noise_scale:g}/{self.max_time:g}"
        key = key if self.feedback == "scan" else f"{key}/feedback={self.feedback}"
        key = key if self.gyro else f"{key}/gyro=off"
        return key if self.condition != "rl" else f"{key}/policy={policy_id(self.policy)}"


def noise_seed(seed: int, run: int) -> int:
    """The world's noise seed of run ``run`` (the same for both conditions: paired).

    >>> noise_seed(0, 3) == noise_seed(0, 3) != noise_seed(0, 4)
    True
    """
    return int(np.random.default_rng([int(seed), int(run), 1]).integers(2**31))


def scene_for(spec: RunSpec) -> tuple[Scene, str]:
    """The world a run is in and what success means there: ``(scene, expect)``, where
    ``expect`` is ``"reach"`` or ``"unreachable"``. A layout family draws run ``spec.run``
    of seed ``spec.seed`` (:func:`~clomp.runtime.experiment.layouts.make_layout`); any other
    name is a built-in scenario or a scenario file, the same world every run. Benchmarks
    and ablations use it to put a variant in exactly the world
    :func:`~clomp.runtime.experiment.runrecords.run_spec` would.

    >>> scene, expect = scene_for(RunSpec("overtaking", 0, 3, "planning", "paper"))
    >>> scene == scene_for(RunSpec("overtaking", 0, 3, "reactive", "harsh"))[0], expect
    (True, 'reach')
    """
    if spec.family in ALL_FAMILIES:
        lay = make_layout(spec.family, spec.seed, spec.run)
        return lay.scene, lay.expect
    scene = load_scenario(spec.family)
    expect = "unreachable" if scene.raw.get("expect") == "unreachable" else "reach"
    return scene, expect


def movers_for(spec: RunSpec) -> tuple[Any, ...]:
    """The moving and appearing bodies of a run's world (issue #42): a moving family's
    :attr:`~clomp.runtime.experiment.layouts.Layout.movers`, a scenario file's ``movers``
    list (the JSON forms of :class:`~clomp.runtime.backends.world.Mover`), else none.

    >>> len(movers_for(RunSpec("appearing", 0, 0, "planning"))), movers_for(RunSpec("overtaking", 0, 0, "planning"))
    (1, ())
    """
    if spec.family in MOVING_FAMILIES:
        return make_layout(spec.family, spec.seed, spec.run).movers
    if spec.family in ALL_FAMILIES:
        return ()
    return parse_movers(load_scenario(spec.family).raw.get("movers") or ())


def experiment_specs(family: str, runs: int, seed: int = 0, *, noise: str = "paper",
                     noise_scales: Sequence[float] = (1.0,), conditions: Sequence[str] = DEFAULT_CONDITIONS,
                     max_time: float = 120.0, feedback: str = "scan", gyro: bool = True,
                     policy: str | None = None) -> list[RunSpec]:
    """Every run of an experiment, in a fixed order (scale, run, condition); a ValueError
    (or the :class:`~clomp.planner.scenarios.ScenarioError` of an unknown family) now
    rather than in every worker. ``policy``: the ``rl`` condition's policy file (None: the shipped one).

    >>> [(s.run, s.condition, s.noise_scale) for s in experiment_specs("open", 2, conditions=("reactive",))]
    [(0, 'reactive', 1.0), (1, 'reactive', 1.0)]
    """
    if runs < 1:
        raise ValueError("runs must be at least 1")
    if noise not in NOISE_PRESETS:
        raise ValueError(f"unknown noise preset {noise!r} (known: {', '.join(NOISE_PRESETS)})")
    for c in conditions:
        check_condition(c)
    for s in noise_scales:
        if not (math.isfinite(s) and s >= 0):
            raise ValueError(f"noise scale must be a finite number >= 0, got {s!r}")
    if family not in ALL_FAMILIES:
        load_scenario(family)  # a clear ScenarioError now rather than in every worker
    if feedback not in ("scan", "none"):
        raise ValueError(f"feedback must be 'scan' or 'none', got {feedback!r}")
    if "rl" in conditions:
        load_policy(policy)  # a clear PolicyError now rather than in every worker
    return [RunSpec(family, seed, k, c, noise, float(s), max_time, feedback, bool(gyro), policy if c == "rl" else None)
            for s in noise_scales
            for k in range(runs) for c in conditions]
