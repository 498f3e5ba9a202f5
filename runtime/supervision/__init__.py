"""Supervision: the state machine (:mod:`.states`) and the supervisor that runs it (:mod:`.supervisor`),
with its settings (:mod:`.config`), its pose estimate and revolutions (:mod:`.sensing`) and its
judgement of progress (:mod:`.progress`).

May import: formal, planner, :mod:`clomp.runtime.interface`, :mod:`clomp.runtime.clock`, :mod:`clomp.runtime.records`,
:mod:`clomp.runtime.estimation`.
Devices, robots and the command line's lower layers do not import this room.

>>> from clomp.runtime.supervision import SupervisorState
>>> SupervisorState.HALTED.value
'HALTED'
"""

from clomp.runtime.supervision.config import DRIVE_DELAY, SupervisorConfig
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
    "SupervisorConfig",
    "DRIVE_DELAY",
    "SupervisorReport",
    "SupervisorState",
    "TERMINAL",
    "TRANSITIONS",
    "TaskRecord",
    "TransitionRecord",
    "state_machine_dot",
    "state_machine_prism",
]
