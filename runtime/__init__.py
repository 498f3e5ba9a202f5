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
    "ScanFrame": "runtime.devices.frame",
    "Supervisor": "runtime.supervision.supervisor",
    "SupervisorReport": "runtime.supervision.supervisor",
    "SupervisorState": "runtime.supervision.machine",
    "Event": "runtime.supervision.machine",
    "TRANSITIONS": "runtime.supervision.machine",
    "Clock": "runtime.clock",
    "WallClock": "runtime.clock",
    "ManualClock": "runtime.clock",
    "ScaledClock": "runtime.clock",
    "state_machine_dot": "runtime.supervision.machine",
    "state_machine_prism": "runtime.supervision.machine",
    "SimRobot": "runtime.robots.sim",
    "NoiseConfig": "runtime.robots.sim",
    "scenario_scan_source": "runtime.robots.sim",
    "ReactiveController": "runtime.experiment.reactive",
    "ReactiveReport": "runtime.experiment.reactive",
    "run_once": "runtime.experiment.runner",
    "run_experiment": "runtime.experiment.runner",
    "RunResult": "runtime.experiment.runner",
    "FaultyRobot": "runtime.robots.faults",
    "HardwareRobot": "runtime.robots.hardware",
    "HardwareConfig": "runtime.robots.hardware",
    "EmulatedWorld": "runtime.robots.emulated",
    "RunLog": "runtime.records.runlog",
    "read_log": "runtime.records.runlog",
    "plot_run": "runtime.experiment.plots",
    "plot_runs": "runtime.experiment.plots",
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
