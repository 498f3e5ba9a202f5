"""Stateful tests: a map grown transition by transition (rules are tasks, preconditions
the guard, invariants the map's invariants, initialize the reset), and a plan executed
step by step under Ψ."""

from __future__ import annotations

from functools import lru_cache

import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import RuleBasedStateMachine, initialize, invariant, precondition, rule

from clomp.formal import CognitiveMap, Disturbance, DisturbanceKind, Guard, Pose, Reset, ResetUndefined, State, TaskKind
from clomp.formal.export import export_model
from clomp.formal.invariants import check_map
from clomp.formal.supervisory import extract_plan
from clomp.planner import Configurator
from clomp.planner.scenarios import builtin_scenarios, load_scenario

GOAL = Disturbance.goal(1.0, 0.0)
HIT = Disturbance(DisturbanceKind.OBSTACLE, 0.5, 0.0, (), 0)
costs = st.floats(0.0, 0.99, allow_nan=False)


class MapGrowth(RuleBasedStateMachine):
    """Grow a cognitive map as Algorithm 1 does, one option (task) at a time."""

    @initialize()
    def reset(self) -> None:
        # q0 is the present task, contingent on the goal D_G
        self.map = CognitiveMap(goal=GOAL)
        self.R = Reset(self.map)
        q0 = State(0, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(0, 0), cost=0.5)
        self.map.add_state(self.R.inject(q0, q0))
        self.used: set[tuple[int, TaskKind]] = set()

    def _open(self, kind: TaskKind) -> list[int]:
        # the guard of a rule: only uninterrupted STRAIGHT (frontier) states expand, once per task
        return [
            s.ident
            for s in self.map.states()
            if s.task is TaskKind.STRAIGHT and not s.interrupted and (s.ident, kind) not in self.used
        ]

    def _add(self, source: int, task: TaskKind, hit: bool, cost: float) -> State:
        s = State(len(self.map), task, None, HIT if hit else None, Pose(0, 0), Pose(0.1 * len(self.map), 0),
                  distance=0.27 if task is TaskKind.STRAIGHT else 0.0, cost=1.0 + cost if hit else cost)
        s = self.map.add_state(self.R.inject(self.map[source], s))
        self.map.add_transition(source, s.ident)
        return s

    def _option(self, kind: TaskKind, data, hit: bool, hit2: bool, cost: float, cost2: float) -> None:
        source = data.draw(st.sampled_from(self._open(kind)), label="q_E")
        self.used.add((source, kind))
        first = self._add(source, kind, hit, cost)
        if kind.is_turn and not first.interrupted:
            self._add(first.ident, TaskKind.STRAIGHT, hit2, cost2)

    @precondition(lambda self: self._open(TaskKind.STRAIGHT))
    @rule(data=st.data(), hit=st.booleans(), cost=costs)
    def straight(self, data, hit, cost) -> None:
        self._option(TaskKind.STRAIGHT, data, hit, False, cost, 0.0)

    @precondition(lambda self: self._open(TaskKind.LEFT))
    @rule(data=st.data(), hit=st.booleans(), hit2=st.booleans(), cost=costs, cost2=costs)
    def left(self, data, hit, hit2, cost, cost2) -> None:
        self._option(TaskKind.LEFT, data, hit, hit2, cost, cost2)

    @precondition(lambda self: self._open(TaskKind.RIGHT))
    @rule(data=st.data(), hit=st.booleans(), hit2=st.booleans(), cost=costs, cost2=costs)
    def right(self, data, hit, hit2, cost, cost2) -> None:
        self._option(TaskKind.RIGHT, data, hit, hit2, cost, cost2)

    @precondition(lambda self: any(s.interrupted for s in self.map.states()))
    @rule(data=st.data())
    def continue_after_a_collision(self, data) -> None:
        # the reset is undefined after D_N ≠ ∅: the Configurator cannot continue from here
        hit = data.draw(st.sampled_from([s for s in self.map.states() if s.interrupted]))
        with pytest.raises(ResetUndefined):
            self.R.inject(hit, State(999, TaskKind.STRAIGHT, None, None, Pose(0, 0), Pose(0, 0)))

    @invariant()
    def every_invariant_holds(self) -> None:
        assert check_map(self.map) == []

    @invariant()
    def exports_keep_every_transition(self) -> None:
        m = export_model(self.map)
        assert m.n_states == len(self.map)
        assert m.n_transitions == self.map.n_transitions + len(m.self_loops)
        assert all(not self.map.out_transitions(m.states[k].ident) for k in m.self_loops)


TestMapGrowth = MapGrowth.TestCase
TestMapGrowth.settings = settings(max_examples=40, stateful_step_count=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])


@lru_cache(maxsize=None)
def _planned(name: str):
    conf = Configurator()
    scene = load_scenario(name)
    return conf.plan(scene.scan(max_range=conf.robot.sensor_range), tuple(scene.goal_in_robot_frame()))


class PlanExecution(RuleBasedStateMachine):
    """Execute a plan one task at a time: the supervisor takes only what Ψ enables."""

    @initialize(name=st.sampled_from(sorted(builtin_scenarios())))
    def start(self, name: str) -> None:
        r = _planned(name)
        self.map, self.plan = r.map, extract_plan(r.map)
        self.psi = Guard(self.map, self.plan)
        self.R = Reset(self.map)
        self.at = self.map.initial_id
        self.trace = [self.at]

    @precondition(lambda self: bool(self.psi.enabled(self.at)))
    @rule()
    def execute_the_enabled_task(self) -> None:
        (t,) = self.psi.enabled(self.at)
        assert self.psi(t) == 1
        assert self.R(t) == self.map.goal  # the next task is contingent on D_G
        self.at = t.target
        self.trace.append(self.at)

    @precondition(lambda self: any(self.psi(t) == 0 for t in self.map.out_transitions(self.at)))
    @rule(data=st.data())
    def a_disabled_task_is_refused(self, data) -> None:
        t = data.draw(st.sampled_from([t for t in self.map.out_transitions(self.at) if self.psi(t) == 0]))
        assert (t.source, t.target) not in self.plan.steps()

    @rule()
    def the_supervisor_looks_at_its_options(self) -> None:
        # always possible (also at the end of the plan): Ψ enables at most one task
        assert len(self.psi.enabled(self.at)) <= 1

    @invariant()
    def on_the_plan_and_collision_free(self) -> None:
        assert list(self.plan.states[: len(self.trace)]) == self.trace
        assert not self.map[self.at].interrupted

    @invariant()
    def stops_only_at_the_end_of_the_plan(self) -> None:
        if not self.psi.enabled(self.at):
            assert self.at == self.plan.end


TestPlanExecution = PlanExecution.TestCase
TestPlanExecution.settings = settings(max_examples=30, stateful_step_count=20, deadline=None)
