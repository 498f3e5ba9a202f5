"""clomp.formal — the cognitive map as a verified labelled transition system.

Knows nothing of physics: states, transitions, the plan ρ, the guard Ψ and the reset R.
"""

if __name__ != "clomp.formal":  # the repository keeps formal/ at the top; it is installed only as clomp.formal
    raise ImportError(f"{__name__} is part of clomp: import clomp.formal, not {__name__}")

from clomp.formal.lts import FORMAT_VERSION, CognitiveMap, MapError, Transition
from clomp.formal.model import PAPER_TASKS, Disturbance, DisturbanceKind, Pose, State, TaskKind
from clomp.formal.invariants import Invariant, InvariantError, Violation, assert_map_valid, check_map
from clomp.formal.supervisory import Guard, Plan, Reset, ResetUndefined, extract_plan, frontier_end, plan_end

__all__ = [
    "CognitiveMap",
    "Disturbance",
    "DisturbanceKind",
    "FORMAT_VERSION",
    "Guard",
    "Invariant",
    "InvariantError",
    "MapError",
    "Plan",
    "Pose",
    "Reset",
    "ResetUndefined",
    "State",
    "TaskKind",
    "PAPER_TASKS",
    "Transition",
    "Violation",
    "assert_map_valid",
    "check_map",
    "extract_plan",
    "frontier_end",
    "plan_end",
]
