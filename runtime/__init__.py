"""clomp.runtime — executing plans on robots: supervisor, devices, simulation, command line.

The public names below are imported lazily (on first use), so that ``import runtime``
and the command line stay light and free of import cycles.

>>> from clomp.runtime import SimRobot, Supervisor
>>> from clomp.planner import load_scenario
>>> scene = load_scenario("open")
>>> Supervisor(SimRobot(scene, seed=0), scene.goal_in_robot_frame()).run().state.value  # nothing in sight to vouch
'GOAL_UNCONFIRMED'
"""

from __future__ import annotations

if __name__ != "clomp.runtime":  # the repository keeps runtime/ at the top; it is installed only as clomp.runtime
    raise ImportError(f"{__name__} is part of clomp: import clomp.runtime, not {__name__}")

import importlib
from typing import Any

_LAZY = {
    "Robot": "clomp.runtime.interface",
    "RobotFault": "clomp.runtime.interface",
    "ScanFrame": "clomp.runtime.devices.frame",
    "Supervisor": "clomp.runtime.supervision.supervisor",
    "SupervisorConfig": "clomp.runtime.supervision.config",
    "SupervisorReport": "clomp.runtime.supervision.supervisor",
    "SupervisorState": "clomp.runtime.supervision.states",
    "Event": "clomp.runtime.supervision.states",
    "TRANSITIONS": "clomp.runtime.supervision.states",
    "Clock": "clomp.runtime.clock",
    "WallClock": "clomp.runtime.clock",
    "ManualClock": "clomp.runtime.clock",
    "ScaledClock": "clomp.runtime.clock",
    "state_machine_dot": "clomp.runtime.supervision.states",
    "state_machine_prism": "clomp.runtime.supervision.states",
    "SimRobot": "clomp.runtime.backends.sim",
    "NoiseConfig": "clomp.runtime.backends.sim",
    "scenario_scan_source": "clomp.runtime.backends.sim",
    "ReactiveController": "clomp.runtime.experiment.reactive",
    "ReactiveReport": "clomp.runtime.experiment.reactive",
    "run_once": "clomp.runtime.experiment.runner",
    "run_experiment": "clomp.runtime.experiment.runner",
    "RunResult": "clomp.runtime.experiment.runner",
    "FaultyRobot": "clomp.runtime.backends.faults",
    "HardwareRobot": "clomp.runtime.backends.hardware",
    "HardwareConfig": "clomp.runtime.backends.hardware",
    "EmulatedWorld": "clomp.runtime.backends.emulated",
    "RunLog": "clomp.runtime.records.runlog",
    "read_log": "clomp.runtime.records.runlog",
    "plot_run": "clomp.runtime.experiment.plots",
    "plot_runs": "clomp.runtime.experiment.plots",
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
