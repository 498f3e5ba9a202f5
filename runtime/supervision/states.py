"""The supervisor's state machine, as data: states, events, the transition table, renderers.

::

    IDLE ─start→ PLANNING ─planned→ EXECUTING ─next_task→ EXECUTING
                 PLANNING ─at_goal→ GOAL_REACHED      EXECUTING ─at_goal→ GOAL_REACHED
                 PLANNING ─goal_unconfirmed→ CONFIRMING (also from EXECUTING, REPLANNING)
                 PLANNING ─no_plan→ UNREACHABLE       EXECUTING ─plan_short / disagree→ REPLANNING
                 REPLANNING ─planned / at_goal / goal_unconfirmed / no_plan→ (as from PLANNING)
                 CONFIRMING ─at_goal→ GOAL_REACHED    CONFIRMING ─approach→ REPLANNING
                 CONFIRMING ─goal_unconfirmed→ GOAL_UNCONFIRMED
    EXECUTING, REPLANNING ─move_away→ MOVING_AWAY ─moved_away / disagree→ REPLANNING
    any non-terminal state ─fault / abort→ HALTED

CONFIRMING (wheels stopped): the estimate put the robot at the goal but could not vouch for
it; the supervisor stands and looks before it gives up (:mod:`clomp.runtime.supervision.goal`).
MOVING_AWAY (wheels turning): a push felt left the robot against an obstacle; a short
straight or reverse takes it clear before it plans (:mod:`clomp.runtime.supervision.pushaway`).

The machine is described once, as data, in :data:`clomp.formal.control.SUPERVISOR` (states,
events with their controllability, guards, where the wheels may turn); this module
reads it: :data:`TRANSITIONS` (what :class:`~clomp.runtime.supervision.Supervisor` fires),
:data:`MOTOR_STATES` (where it may command the wheels) and :data:`TERMINAL`. A terminal
state ignores every further event (the formal table writes that as self-loops on the
uncontrollable events; the runtime simply fires nothing there). The wheels may turn only
in :data:`MOTOR_STATES`. :func:`state_machine_dot` and :func:`state_machine_prism` render
the machine through :mod:`clomp.formal.export` (:func:`clomp.formal.control.machine_model`).

>>> TRANSITIONS[(SupervisorState.IDLE, Event.START)].value
'PLANNING'
>>> sorted(s.value for s in TERMINAL)
['GOAL_REACHED', 'GOAL_UNCONFIRMED', 'HALTED', 'UNREACHABLE']
"""

from __future__ import annotations

import enum
import io
from dataclasses import dataclass

from clomp.formal.export import write_dot, write_prism
from clomp.formal.control import SUPERVISOR, machine_model

__all__ = [
    "Event",
    "MOTOR_STATES",
    "SupervisorState",
    "TERMINAL",
    "TRANSITIONS",
    "TransitionRecord",
    "state_machine_dot",
    "state_machine_prism",
]


class SupervisorState(str, enum.Enum):
    """The supervisor's states.

    >>> [s.value for s in SupervisorState if s in TERMINAL]
    ['GOAL_REACHED', 'GOAL_UNCONFIRMED', 'UNREACHABLE', 'HALTED']
    """

    IDLE = "IDLE"
    PLANNING = "PLANNING"
    EXECUTING = "EXECUTING"
    REPLANNING = "REPLANNING"
    CONFIRMING = "CONFIRMING"
    MOVING_AWAY = "MOVING_AWAY"
    GOAL_REACHED = "GOAL_REACHED"
    GOAL_UNCONFIRMED = "GOAL_UNCONFIRMED"
    UNREACHABLE = "UNREACHABLE"
    HALTED = "HALTED"


class Event(str, enum.Enum):
    """What moves the supervisor from one state to the next.

    >>> TRANSITIONS[(SupervisorState.EXECUTING, Event.DISAGREE)].value
    'REPLANNING'
    """

    START = "start"
    PLANNED = "planned"
    AT_GOAL = "at_goal"
    GOAL_UNCONFIRMED = "goal_unconfirmed"
    APPROACH = "approach"
    NO_PLAN = "no_plan"
    NEXT_TASK = "next_task"
    PLAN_SHORT = "plan_short"
    MOVE_AWAY = "move_away"
    MOVED_AWAY = "moved_away"
    DISAGREE = "disagree"
    FAULT = "fault"
    ABORT = "abort"


S, E = SupervisorState, Event
if {s.value for s in SupervisorState} != set(SUPERVISOR.states) or {e.value for e in Event} != {e.name for e in SUPERVISOR.events}:
    raise ImportError("clomp.runtime.supervision.states: the state and event names differ from clomp.formal.control.SUPERVISOR")
#: the states the supervisor never leaves (a run ends there)
TERMINAL: frozenset[SupervisorState] = frozenset(S(s) for s in SUPERVISOR.terminal)
#: the states in which the wheels may turn (every other state has them stopped)
MOTOR_STATES: frozenset[SupervisorState] = frozenset(S(s) for s in SUPERVISOR.wheels)
#: the supervisor's transition function: (state, event) -> next state; a pair not here is refused
TRANSITIONS: dict[tuple[SupervisorState, Event], SupervisorState] = {
    (S(t.source), E(t.event)): S(t.target) for t in SUPERVISOR.transitions if t.source not in SUPERVISOR.terminal
}
"""(state, event) → state, from :data:`clomp.formal.control.SUPERVISOR` (terminal states fire nothing)."""


@dataclass(frozen=True)
class TransitionRecord:
    """One transition the supervisor took, with the reason."""

    time: float
    source: SupervisorState
    event: Event
    target: SupervisorState
    reason: str


def state_machine_dot() -> str:
    """The supervisor's state machine as Graphviz DOT, drawn by :func:`clomp.formal.export.write_dot`
    from :func:`clomp.formal.control.machine_model` (states where the wheels may turn are
    filled, terminal states have a double border).

    >>> state_machine_dot().splitlines()[0]
    'digraph supervisor {'
    """
    buf = io.StringIO()
    write_dot(machine_model(SUPERVISOR, None), buf)
    return buf.getvalue()


def state_machine_prism() -> str:
    """The supervisor's state machine as a PRISM MDP (events are nondeterministic
    choices), written by :func:`clomp.formal.export.write_prism`: ``q`` is the state, labels
    ``motors`` (the wheels may turn), ``terminal`` and one per state in lower case, e.g.
    ``Pmax=? [F ("motors" & !"executing" & !"moving_away")]`` = 0 (the wheels turn only in
    EXECUTING and MOVING_AWAY).
    The closed loop with the robot is :func:`clomp.formal.control.machine_model` (checked by
    ``specs/properties/supervisor/machine.pctl``).

    >>> text = state_machine_prism()
    >>> "mdp" in text.splitlines() and '"motors"' in text
    True
    """
    buf = io.StringIO()
    write_prism(machine_model(SUPERVISOR, None), buf)
    return buf.getvalue()
