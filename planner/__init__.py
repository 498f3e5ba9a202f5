"""clomp.planner — core knowledge (a pymunk world) and the Configurator.

The map's vocabulary (Pose, State, TaskKind, Disturbance) is :mod:`clomp.formal`'s, exported
there only.

>>> import numpy as np
>>> from clomp.planner import plan
>>> result = plan(np.zeros((0, 2)), goal=(1.0, 0.0))
>>> result.reached_goal, [s.task.value for s in result.steps]
(True, ['STRAIGHT'])
"""

if __name__ != "clomp.planner":  # the repository keeps planner/ at the top; it is installed only as clomp.planner
    raise ImportError(f"{__name__} is part of clomp: import clomp.planner, not {__name__}")

from clomp.planner.configurator import (
    GOAL_LIMIT_M,
    Configurator,
    CostContext,
    CostFunction,
    PlanningError,
    PlanResult,
    Rollout,
    chi,
    default_cost,
    gamma,
    plan,
)
from clomp.planner.perception import Obstacles, ScanError, ScanWarning, load_scan, perceive, scan_files, validate_scan
from clomp.planner.rollout import simulate
from clomp.planner.robot_model import RobotModel
from clomp.planner.scenarios import Scene, ScenarioError, builtin_scenarios, load_scenario
from clomp.planner.tasks import Task

__all__ = [
    "GOAL_LIMIT_M",
    "Configurator",
    "CostContext",
    "CostFunction",
    "Obstacles",
    "PlanResult",
    "PlanningError",
    "RobotModel",
    "Rollout",
    "ScanError",
    "ScanWarning",
    "Scene",
    "ScenarioError",
    "Task",
    "builtin_scenarios",
    "chi",
    "default_cost",
    "gamma",
    "load_scan",
    "load_scenario",
    "perceive",
    "plan",
    "scan_files",
    "simulate",
    "validate_scan",
]
