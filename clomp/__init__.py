"""clomp — Closed-LOop Multi-step Planning (Lafratta, Porr, Chandler, Miller).

One import name for the whole library. The repository keeps the design card's folders at
its top (``planner/``, ``formal/``, ``runtime/``, ``specs/``); they are installed only as
``clomp.planner``, ``clomp.formal``, ``clomp.runtime`` and ``clomp.specs``. The names most
users need are here too:

- :func:`plan` — plan on a scan (an N×2 array, metres, robot frame) toward a goal;
- :func:`load_scenario` — a built-in or JSON scenario (``overtaking``, ``corridor`` …);
- :class:`Configurator` — the planner itself, for repeated planning with one robot model;
- :class:`CognitiveMap`, :func:`check_map` — the map as a labelled transition system and
  its invariants;
- :func:`export_model`, :func:`write_prism`, :func:`write_dot` — the map for PRISM, Storm
  and Graphviz;
- :class:`Supervisor`, :class:`SimRobot` — execute plans closed-loop (imported on first use).

>>> import clomp
>>> scene = clomp.load_scenario("overtaking")
>>> result = clomp.plan(scene.scan(), goal=(0.8, -0.3))  # beside the box: seen, so it may be reached
>>> result.reached_goal, clomp.check_map(result.map)
(True, [])
>>> clomp.plan(scene.scan(), goal=scene.goal_in_robot_frame()).stop_reason  # behind it: in its shadow
'frontier'
"""

from __future__ import annotations

import importlib
from typing import Any

from clomp.formal import CognitiveMap, check_map
from clomp.formal.export import export_model, write_dot, write_prism
from clomp.planner import Configurator, RobotModel, load_scenario, plan

__version__ = "0.1.0"

_LAZY = {"Supervisor": "clomp.runtime", "SimRobot": "clomp.runtime"}

__all__ = [
    "CognitiveMap",
    "Configurator",
    "RobotModel",
    "SimRobot",
    "Supervisor",
    "check_map",
    "export_model",
    "load_scenario",
    "plan",
    "write_dot",
    "write_prism",
]


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'clomp' has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
