"""clomp.runtime — executing plans on robots: supervisor, devices, simulation, command line.

The public names below are imported lazily (on first use), so that ``import runtime``
and the command line stay light and free of import cycles.

>>> from runtime import SimRobot, Supervisor
>>> from planner import load_scenario
>>> scene = load_scenario("open")
>>> Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run().state.value
'GOAL_REACHED'
"""

from __future__ import annotations

import importlib
from typing import Any

_LAZY = {
    "Robot": "runtime.robot",
    "RobotFault": "runtime.robot",
    "ScanFrame": "runtime.robot",
    "Supervisor": "runtime.supervisor",
    "SupervisorReport": "runtime.supervisor",
    "SupervisorState": "runtime.supervisor",
    "Event": "runtime.supervisor",
    "TRANSITIONS": "runtime.supervisor",
    "Clock": "runtime.supervisor",
    "WallClock": "runtime.supervisor",
    "state_machine_dot": "runtime.supervisor",
    "state_machine_prism": "runtime.supervisor",
    "SimRobot": "runtime.sim",
    "NoiseConfig": "runtime.sim",
    "scenario_scan_source": "runtime.sim",
    "ReactiveController": "runtime.reactive",
    "ReactiveReport": "runtime.reactive",
    "run_once": "runtime.experiment",
    "run_experiment": "runtime.experiment",
    "ExperimentResult": "runtime.experiment",
    "RunResult": "runtime.experiment",
    "FaultyRobot": "runtime.faults",
    "HardwareRobot": "runtime.hardware",
    "HardwareConfig": "runtime.hardware",
    "RunLog": "runtime.runlog",
    "read_log": "runtime.runlog",
    "plot_run": "runtime.plot",
    "plot_runs": "runtime.plot",
}

__all__ = sorted(_LAZY)


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'runtime' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
