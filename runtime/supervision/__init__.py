"""Supervision: the state machine (:mod:`.machine`) and the supervisor that runs it (:mod:`.supervisor`).

May import: formal, planner, :mod:`clomp.runtime.interface`, :mod:`clomp.runtime.clock`, :mod:`clomp.runtime.records`.
Devices, robots and the command line's lower layers do not import this room.

>>> from clomp.runtime.supervision import SupervisorState
>>> SupervisorState.HALTED.value
'HALTED'
"""

from clomp.runtime.supervision.states import (
    MOTOR_STATES,
    TERMINAL,
    TRANSITIONS,
    Event,
    SupervisorState,
    TransitionRecord,
    state_machine_dot,
    state_machine_prism,
)
from clomp.runtime.supervision.supervisor import (
    GuardViolation,
    PlanRecord,
    Supervisor,
    SupervisorReport,
    TaskRecord,
)

__all__ = [
    "Event",
    "GuardViolation",
    "MOTOR_STATES",
    "PlanRecord",
    "Supervisor",
    "SupervisorReport",
    "SupervisorState",
    "TERMINAL",
    "TRANSITIONS",
    "TaskRecord",
    "TransitionRecord",
    "state_machine_dot",
    "state_machine_prism",
]
