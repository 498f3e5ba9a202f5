"""clomp.planner — core knowledge (a pymunk world) and the Configurator.

>>> import numpy as np
>>> from planner import plan
>>> result = plan(np.zeros((0, 2)), goal=(1.0, 0.0))
>>> result.reached_goal, [s.task.value for s in result.steps]
(True, ['STRAIGHT'])
"""

from formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind
from planner.configurator import (
    GOAL_LIMIT_M,
    Configurator,
    CostContext,
    CostFunction,
    PlanningError,
    PlanResult,
    chi,
    default_cost,
    gamma,
    plan,
)
from planner.perception import Obstacles, ScanError, ScanWarning, load_scan, perceive, scan_files, validate_scan
from planner.physics import simulate
from planner.robot import RobotModel
from planner.scenarios import Scene, ScenarioError, builtin_scenarios, load_scenario
from planner.tasks import Task

__all__ = [
    "GOAL_LIMIT_M",
    "Configurator",
    "CostContext",
    "CostFunction",
    "Disturbance",
    "DisturbanceKind",
    "Obstacles",
    "PlanResult",
    "PlanningError",
    "Pose",
    "RobotModel",
    "ScanError",
    "ScanWarning",
    "Scene",
    "ScenarioError",
    "State",
    "Task",
    "TaskKind",
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
