"""clomp.formal — the cognitive map as a verified labelled transition system.

Knows nothing of physics: states, transitions, the plan ρ, the guard Ψ and the reset R.
"""

from formal.lts import FORMAT_VERSION, CognitiveMap, MapError, Transition
from formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind
from formal.invariants import Invariant, InvariantError, Violation, assert_map_valid, check_map
from formal.supervisory import Guard, Plan, Reset, ResetUndefined, extract_plan, guard, plan_end, reset

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
    "Transition",
    "Violation",
    "assert_map_valid",
    "check_map",
    "extract_plan",
    "guard",
    "plan_end",
    "reset",
]
