"""clomp.formal — the cognitive map as a verified labelled transition system.

Knows nothing of physics: states, transitions, the plan ρ, the guard Ψ and the reset R.
"""

from formal.lts import FORMAT_VERSION, CognitiveMap, MapError, Transition
from formal.model import Disturbance, DisturbanceKind, Pose, State, TaskKind
from formal.supervisory import Plan, ResetUndefined, extract_plan, guard, plan_end, reset

__all__ = [
    "FORMAT_VERSION",
    "CognitiveMap",
    "Disturbance",
    "DisturbanceKind",
    "MapError",
    "Plan",
    "Pose",
    "ResetUndefined",
    "State",
    "TaskKind",
    "Transition",
    "extract_plan",
    "guard",
    "plan_end",
    "reset",
]
