"""A probabilistic cognitive map: task outcomes estimated from repeated noisy rollouts.

Under sensor and actuation noise the outcome of a task started from a state is
uncertain. :func:`sample_map` estimates it: the Configurator first builds the nominal
(noise-free) map; then every (state, task) choice of that map is rolled out ``samples``
times, rollout *k* in noisy world *k*: the scan's ranges perturbed and some returns
dropped (then perceived again), the wheels off by a per-run bias and a per-tick error, a
heading drift, and a turn's angle off by a relative error (:class:`RolloutNoise`). The
outcomes are grouped into successor states — same outcome kind (collision, goal, free)
and end pose within a tolerance — first onto the nominal successor, then onto any state
of the map with the same task, else into a new state; each group's probability is
exactly ``k/N``. New free states are frontier leaves (not expanded; a new uninterrupted
turn gets its nominal STRAIGHT, as Algorithm 1's frontier rule asks), so the chance of
reaching the goal from them is counted as zero: the estimate is conservative. With a
:class:`HazardRule`, a rollout the supervisor's scan test interrupts is a *stop*, its own
outcome kind (never grouped with a contact, nor with another source's stop), named in
``metadata["stops"]`` with the state its task started from, so that an objective can
retry it as the supervisor does (:mod:`clomp.formal.retry`). With
``HazardRule(contacts=True)`` (the closed loop, :mod:`clomp.planner.hazard`) a rollout
that touches an obstacle is a stop too when a revolution before the contact sees it
coming; only a contact the test cannot foresee stays a collision.

WAIT and REVERSE (issue #42, a ``Configurator(recovery=True)``) are sampled too: a WAIT
stands (probability 1 of its nominal outcome), a REVERSE backs off its planned length off
by a straight's relative error, cut by what is behind it in each noisy world
(:func:`clomp.planner.recovery.noisy_recovery`); the choices after a WAIT are rolled out
in each noisy world without the returns the configurator was told are ``transient``, as
the nominal map simulated them.

:func:`learn_from_scans` learns the same kind of map from repeated *observation*:
consecutive scans of a recorded run (or the scans of a run log) each give a map; states
are matched across scans by the tasks that lead to them from q0, and each observation
of a (state, task) adds one count to the outcome group it falls into.

Noise numbers come from ``specs/noise_presets.json`` (``clomp.planner.noise.noise_presets()``), the
presets the execution world uses; a rollout uses the terms that concern one task
(ranges, beam angles, dropout, wheel error, bias, drift, slip), not ``latency``.

>>> import numpy as np
>>> r = sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=4, noise="ideal")
>>> [str(t.probability) for t in r.map.out_transitions(0)]
['1']
>>> noisy = sample_map(np.zeros((0, 2)), (1.0, 0.0), samples=4, noise="harsh", seed=1)
>>> sum(t.probability for t in noisy.map.out_transitions(0))
Fraction(1, 1)
"""

from __future__ import annotations

import math
import time
import warnings
from collections.abc import Iterable
from dataclasses import dataclass, field, replace
from fractions import Fraction
from typing import Any

import numpy as np

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, State, TaskKind
from clomp.formal.retry import LOST_KEY, OFFS_KEY, STOPS_KEY
from clomp.formal.supervisory import extract_plan
from clomp.planner.configurator import Configurator, CostContext, PlanResult
from clomp.planner.hazard import HazardRule, hazard_stop
from clomp.planner.noise import NoiseError, RolloutNoise, preset_names
from clomp.planner.perception import Obstacles, load_scan, perceive
from clomp.planner.pushes import Pushes, push_lost, push_outcome
from clomp.planner.recovery import RECOVERY_TASKS, after_wait, noisy_recovery
from clomp.planner.rollout import Outcome, World, frontier_distance, in_the_way, make_task
from clomp.planner.tick_blocks import rollout_in_blocks
from clomp.planner.visibility import KnownFree
from clomp.planner.robot_model import RobotModel
from clomp.formal.geometry import polar_to_xy, wrap_angle
from clomp.planner.tasks import Task

__all__ = [
    "RolloutNoise",
    "HazardRule",
    "NoiseError",
    "preset_names",
    "ProbabilisticMap",
    "sample_map",
    "learn_from_scans",
    "POSITION_TOLERANCE",
    "HEADING_TOLERANCE",
    "SUPERVISOR_TOLERANCE",
    "MAX_SAMPLES",
]

POSITION_TOLERANCE = 0.03
"""Two outcomes end in the same successor when their end positions are this close (m)…"""
HEADING_TOLERANCE = 0.1
"""…and their headings this close (rad)."""
SUPERVISOR_TOLERANCE = (0.08, 0.3)
"""The supervisor's ``end_tolerance`` (m, rad): a task that ends this close to the map's
prediction continues the plan, so for a closed loop outcomes this close are one state."""
MAX_SAMPLES = 2000
"""The most rollouts per (state, task) :func:`sample_map` takes: a million ran for hours and
would need terabytes; 2,000 estimate a probability to within about ±0.02 (95 %)."""

@dataclass
class _World:
    """One sampled noisy world: perceived obstacles and the robot's per-run errors."""

    obstacles: Obstacles
    bias_l: float
    bias_r: float
    drift: float
    rng: np.random.Generator
    cache: dict[tuple[int, ...], World] = field(default_factory=dict)
    scan: np.ndarray | None = None
    """The scan as given (planner frame): each revolution of a hazard test perturbs it anew."""


@dataclass
class _NoisyTask(Task):
    """A task whose wheels do not do exactly what the motor law says."""

    bias_l: float = 0.0
    bias_r: float = 0.0
    wheel_sd: float = 0.0
    drift: float = 0.0
    rng: Any = None
    slip: float = 0.0

    errs: list[tuple[float, float]] | None = field(default=None, repr=False, compare=False)
    """The wheels' errors of the ticks drawn ahead (:meth:`predraw`), else None."""
    used: int = field(default=0, repr=False, compare=False)
    state: Any = field(default=None, repr=False, compare=False)

    def predraw(self, ticks: int) -> None:
        """Draw the wheels' errors of the next ``ticks`` ticks in one call: the numbers
        :meth:`wheel_speeds` draws a tick at a time (``normal(0, sd)`` is ``sd`` times the
        same standard normal), so the rollouts cost fewer generator calls;
        :meth:`settle` then gives back the draws of the ticks not driven."""
        k = (2 if self.wheel_sd else 0) + (2 if self.slip else 0)
        if self.rng is None or not k or ticks <= 0:
            return
        self.state = self.rng.bit_generator.state
        z = self.rng.standard_normal(ticks * k).reshape(ticks, k)
        el: Any = 0.0
        er: Any = 0.0
        if self.wheel_sd:
            el, er = self.wheel_sd * z[:, 0], self.wheel_sd * z[:, 1]
        if self.slip:
            j = 2 if self.wheel_sd else 0
            el, er = el - np.abs(self.slip * z[:, j]), er - np.abs(self.slip * z[:, j + 1])
        self.errs = list(zip(np.broadcast_to(el, ticks).tolist(), np.broadcast_to(er, ticks).tolist()))
        self.used = 0

    def settle(self, ticks: int) -> None:
        """After :meth:`predraw`: the generator left as if only ``ticks`` ticks had drawn."""
        if self.errs is None:
            return
        k = (2 if self.wheel_sd else 0) + (2 if self.slip else 0)
        if ticks < len(self.errs):
            self.rng.bit_generator.state = self.state
            self.rng.standard_normal(ticks * k)
        self.errs, self.state = None, None

    def wheel_speeds(self, error: float, turned: float = 0.0) -> tuple[float, float]:
        if self.errs is not None:
            vl, vr = super().wheel_speeds(error, turned)
            el, er = self.errs[self.used]
            self.used += 1
            dv = self.drift * self.robot.wheel_base / 2
            return vl * (1 + self.bias_l + el) - dv, vr * (1 + self.bias_r + er) + dv
        vl, vr = super().wheel_speeds(error, turned)
        if self.rng is not None and self.wheel_sd:
            el, er = self.rng.normal(0.0, self.wheel_sd, 2)
        else:
            el = er = 0.0
        if self.rng is not None and self.slip:
            sl, sr = np.abs(self.rng.normal(0.0, self.slip, 2))
            el, er = el - sl, er - sr
        dv = self.drift * self.robot.wheel_base / 2
        return vl * (1 + self.bias_l + el) - dv, vr * (1 + self.bias_r + er) + dv


def _perturb(points: np.ndarray, noise: RolloutNoise, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """The scan's returns perturbed by ``noise``, and which of them were kept (a mask over ``points``)."""
    if len(points) == 0:
        return points, np.zeros(0, dtype=bool)
    keep = rng.random(len(points)) >= noise.dropout
    pts = points[keep]
    r = np.hypot(pts[:, 0], pts[:, 1])
    a = np.arctan2(pts[:, 1], pts[:, 0]) + (rng.normal(0.0, noise.angle_sd, len(pts)) if noise.angle_sd else 0.0)
    r2 = np.clip(r + rng.normal(0.0, noise.range_sd, len(pts)), 0.0, None) if noise.range_sd else r
    out: np.ndarray = polar_to_xy(r2, a)
    return out, keep


def _rollout(kind: TaskKind, start: Pose, goal: Disturbance, world: _World, robot: RobotModel, noise: RolloutNoise,
             hazard: HazardRule | None = None) -> Outcome:
    """One noisy rollout of ``kind`` from ``start`` in ``world`` (see :func:`_rollout_stop`)."""
    return _rollout_stop(kind, start, goal, world, robot, noise, hazard)[0]


def _aimed_limit(kind: TaskKind, start: Pose, aim: State) -> float | None:
    """The limit the supervisor gives the task that is to end in ``aim`` when the robot
    starts it at ``start`` (runtime/supervision/supervisor.py, ``_start_next``): a straight
    drives the planned length from wherever it stands, a turn turns to the planned
    heading. None when ``aim`` gives no such figure (an interrupted outcome, a straight
    of no length)."""
    if aim.interrupted:
        return None
    if kind is TaskKind.STRAIGHT:
        return aim.distance if aim.distance > 0 else None
    turn = wrap_angle(aim.end.theta - start.theta)
    angle = turn if kind is TaskKind.LEFT else -turn
    if angle < -math.pi / 2:  # wrapped: a turn of nearly pi
        angle += 2 * math.pi
    return min(max(angle, 0.0), math.pi)


def _rollout_stop(kind: TaskKind, start: Pose, goal: Disturbance, world: _World, robot: RobotModel, noise: RolloutNoise,
                  hazard: HazardRule | None = None, aim: State | None = None) -> tuple[Outcome, bool]:
    """One noisy rollout and whether the ``hazard`` rule stopped it (a stop, not a contact).
    ``aim``: the state the plan means the task to end in; the task is then given the
    supervisor's limit for it from ``start`` (:func:`_aimed_limit`), as when the robot
    starts it from where the task before truly ended."""
    if kind in RECOVERY_TASKS:  # a WAIT stands; a REVERSE backs off, its length off as a straight's
        back = aim.distance if aim is not None and not aim.interrupted and aim.distance > 0 else None
        got = noisy_recovery(kind, start, goal, world.obstacles, robot, world.rng, noise.straight_sd,
                             noise.straight_mean, back)
        if got.d_n is None and got.end.distance_to(goal.x, goal.y) <= robot.goal_tolerance:
            got = replace(got, reached_goal=True)
        return got, False
    base = make_task(kind, world.obstacles, robot, start, goal)
    limit = base.limit
    aimed = None if aim is None else _aimed_limit(kind, start, aim)
    if aimed is not None:
        limit = aimed
    elif kind is TaskKind.STRAIGHT:
        limit = min(limit, frontier_distance(robot, start))  # as planned: cut at the sensed disc's rim
    if kind.is_turn and (noise.turn_error_sd or noise.turn_mean):
        err = world.rng.normal(0.0, noise.turn_error_sd) if noise.turn_error_sd else 0.0
        limit = min(limit * (1 + noise.turn_mean + err), math.pi)
    elif kind is TaskKind.STRAIGHT and (noise.straight_sd or noise.straight_mean):
        err = world.rng.normal(0.0, noise.straight_sd) if noise.straight_sd else 0.0
        limit = limit * (1 + noise.straight_mean + err)
    task = _NoisyTask(base.kind, robot, start, max(limit, 0.0), base.goal, base.goal_ahead,
                      world.bias_l, world.bias_r, noise.wheel_sd, world.drift, world.rng, noise.slip)
    length = task.limit if kind is TaskKind.STRAIGHT else 0.0
    idx = in_the_way(world.obstacles, robot, start, kind, length)
    key = tuple(idx.tolist())
    w = world.cache.get(key)
    if w is None:
        w = world.cache[key] = World(world.obstacles, robot, idx)
    out = rollout_in_blocks(task, w)  # w.rollout(task), bit for bit, the footprint tested in blocks
    stopped = False
    if hazard is not None:
        free = out
        out = hazard_stop(out, world.scan, world.rng, robot, noise, hazard, task.limit, world.obstacles.points)
        stopped = out is not free
    if out.d_n is None and out.end.distance_to(goal.x, goal.y) <= robot.goal_tolerance:
        out = replace(out, reached_goal=True)
    return out, stopped


def _kind(s: State | Outcome) -> str:
    if s.d_n is not None:
        return "collision"
    return "goal" if s.reached_goal else "free"


def _close(a: Pose, b: Pose, tolerance: tuple[float, float] | None = None) -> bool:
    d, h = (POSITION_TOLERANCE, HEADING_TOLERANCE) if tolerance is None else tolerance
    return a.distance_to(b.x, b.y) <= d and abs(wrap_angle(a.theta - b.theta)) <= h


@dataclass
class ProbabilisticMap:
    """The probabilistic map, the nominal planning result it refines, and its figures."""

    map: CognitiveMap
    nominal: PlanResult
    samples: int
    noise: RolloutNoise
    build_time_s: float
    build_cpu_s: float
    new_states: int

    @property
    def probabilistic_choices(self) -> int:
        """(state, task) choices with more than one outcome."""
        groups: dict[tuple[int, TaskKind], int] = {}
        for t in self.map.transitions():
            groups[(t.source, t.label)] = groups.get((t.source, t.label), 0) + 1
        return sum(1 for n in groups.values() if n > 1)


class _Builder:
    """Grows a copy of the nominal map with sampled outcome groups."""

    def __init__(self, nominal: CognitiveMap, goal: Disturbance, robot: RobotModel, cost: Any,
                 tolerance: tuple[float, float] | None = None) -> None:
        self.tolerance = tolerance
        self.map = CognitiveMap(goal=goal)
        for s in nominal.states():
            self.map.add_state(s)
        self.map.set_initial(nominal.initial.ident)
        self.map.metadata.update(nominal.metadata)
        self.ctx = CostContext(goal, nominal.initial.start, robot)
        self.cost = cost
        self.robot = robot
        self.by_task: dict[TaskKind, list[int]] = {k: [] for k in TaskKind}
        for s in nominal.states():
            if s.ident != nominal.initial.ident:
                self.by_task[s.task].append(s.ident)
        self.new: list[int] = []
        self.stops: dict[int, int] = {}
        self.aims: dict[int, int] = {}
        """New free states -> the nominal state their task aimed at."""
        """Stop states (interrupted by the hazard rule, not by a contact) -> their source."""
        self.lost: dict[int, int] = {}
        """Lost states (a push left the estimate off the truth, :func:`clomp.planner.pushes.push_lost`) -> their source."""

    def _state_kind(self, ident: int) -> str:
        return "stop" if ident in self.stops else "lost" if ident in self.lost else _kind(self.map[ident])

    def lost_state(self, source: int, kind: TaskKind, out: Outcome, d_i: Disturbance) -> int:
        """The dead end of the pushes from ``source`` by ``kind`` that left the estimate
        lost: one state per choice, ending where the task began (the run makes no
        progress it knows of; never a plan's end nor a target)."""
        for ident, src in self.lost.items():
            if src == source and self.map[ident].task is kind:
                return ident
        ident = max(s.ident for s in self.map.states()) + 1
        s = State(ident, out.task, d_i, None, out.start, out.start, 0.0, out.duration)
        self.map.add_state(replace(s, cost=self.cost(s, self.ctx)))
        self.new.append(ident)
        self.lost[ident] = source
        return ident

    def group(self, source: int, kind: TaskKind, nominal_target: int | None, out: Outcome, d_i: Disturbance,
              stop: bool = False) -> int:
        """The state an outcome falls into (created when no state matches); a ``stop``
        falls only into a stop of the same source (its retry re-enters that source)."""
        k = "stop" if stop else _kind(out)
        if nominal_target is not None:
            t = self.map[nominal_target]
            if self._state_kind(t.ident) == k and _close(t.end, out.end, self.tolerance) and self.stops.get(t.ident, source) == source:
                return t.ident
        src_end = self.map[source].end
        for ident in self.by_task[kind]:
            s = self.map[ident]
            if (self._state_kind(ident) == k and _close(s.start, src_end) and _close(s.end, out.end, self.tolerance)
                    and self.stops.get(ident, source) == source):
                return ident
        ident = max(s.ident for s in self.map.states()) + 1
        s = State(ident, out.task, d_i, out.d_n, out.start, out.end, out.distance, out.duration, reached_goal=out.reached_goal)
        s = replace(s, cost=self.cost(s, self.ctx))
        self.map.add_state(s)
        self.by_task[kind].append(ident)
        self.new.append(ident)
        if stop:
            self.stops[ident] = source
        elif nominal_target is not None and k == "free":
            self.aims[ident] = nominal_target
        return ident


def sample_map(
    scan: Any,
    goal: Disturbance | tuple[float, float],
    samples: int = 30,
    noise: RolloutNoise | str = "paper",
    seed: int = 0,
    configurator: Configurator | None = None,
    tolerance: tuple[float, float] | None = None,
    hazard: HazardRule | None = None,
    carry: bool = False,
    pushes: Pushes | None = None,
) -> ProbabilisticMap:
    """Build the nominal map of ``scan`` for ``goal`` and estimate every choice's outcome
    from ``samples`` noisy rollouts (see the module docstring); ``seed`` makes it
    reproducible. ``tolerance`` (m, rad): how close an outcome's end must be to a
    state's to fall into it (default :data:`POSITION_TOLERANCE`,
    :data:`HEADING_TOLERANCE`; the supervisor continues a plan whose task ended within
    its ``end_tolerance``, 0.08 m and 0.3 rad). ``hazard``: also interrupt a rollout as
    the supervisor's scan test would (:class:`HazardRule`); default: contacts only.
    ``carry``: each noisy world carries its robot's true pose from task to task, as the
    closed loop does: a task is rolled out from where that world's rollout of the task
    before truly ended (a world whose rollout fell into another state starts from the
    end of one that fell into this one), with the supervisor's limit for the planned
    outcome (a straight drives the planned length from there, a turn turns to the
    planned heading). Without it every rollout of a choice starts at the state's
    recorded end pose, so an error within the tolerance is forgotten at each step and a
    later task never meets the obstacle such an error leads it into. ``pushes``: the
    world's external pushes while a task runs (:mod:`clomp.planner.pushes`; default none),
    with its whole-run terms: a push that leaves the estimate lost ends in a dead end
    named in ``metadata["lost"]``, and the first task's exposure includes the run's standing."""
    if isinstance(samples, bool) or not isinstance(samples, int) or samples < 1:
        raise NoiseError(f"samples must be a whole number >= 1, got {samples!r}")
    if samples > MAX_SAMPLES:
        raise NoiseError(f"samples: at most {MAX_SAMPLES:,} rollouts per choice, got {samples:,} "
                         "(time and memory grow with them: about 12 s and 0.5 GB at 300 on overtaking)")
    nz = RolloutNoise.preset(noise) if isinstance(noise, str) else noise
    conf = configurator or Configurator()
    robot = conf.robot
    t0, c0 = time.perf_counter(), time.thread_time()
    points = load_scan(scan)
    transient = conf.transient if conf.recovery else None  # what may move away: plan() takes it
    nominal = conf.plan(points, goal)
    waited = after_wait(nominal.map) if conf.recovery else set()  # the states the search simulated after a WAIT
    gone = None if transient is None or not waited else np.asarray(transient, dtype=bool).reshape(-1)
    # the shadow rule (clomp.planner.visibility): a goal is claimed only through space the scan's rays crossed
    known = KnownFree.from_points(nominal.obstacles.points, robot.sensor_range, robot=robot)
    rng = np.random.default_rng(seed)
    worlds, cleared = [], []
    for _ in range(samples):
        r = np.random.default_rng(rng.integers(2**63))
        pts, held = _perturb(points, nz, r)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # noise pushes a few returns past the range: cropped, as meant
            obstacles = perceive(pts, robot.sensor_range, robot.cluster_distance)
        bl, br = r.normal(0.0, nz.wheel_bias, 2) if nz.wheel_bias else (0.0, 0.0)
        worlds.append(_World(obstacles, float(bl), float(br), float(r.normal(0.0, nz.drift)) if nz.drift else 0.0, r,
                             scan=points if hazard is not None else None))
        if gone is not None and gone.shape == (len(points),):  # the same noisy world once what appeared has gone
            w = worlds[-1]
            with warnings.catch_warnings():
                warnings.simplefilter("ignore")
                clear = perceive(pts[~gone[held]], robot.sensor_range, robot.cluster_distance)
            cleared.append(_World(clear, w.bias_l, w.bias_r, w.drift, r, scan=points[~gone] if hazard is not None else None))
    b = _Builder(nominal.map, nominal.goal, robot, conf.cost, tolerance)
    choices: dict[tuple[int, TaskKind], int] = {}
    for t in nominal.map.transitions():
        choices.setdefault((t.source, t.label), t.target)
    rank = _breadth_first(nominal.map) if carry else {}  # a choice's start is known once its source is reached
    arrivals: dict[int, dict[int, Pose]] = {}  # with carry: state -> world -> where that world's robot truly is
    q0 = nominal.map.initial.ident
    order = sorted(choices.items(), key=lambda kv: (rank.get(kv[0][0], kv[0][0]), list(TaskKind).index(kv[0][1])))
    for (source, kind), target in order:
        start = nominal.map[source].end
        here = arrivals.get(source, {})
        pool = [here[i] for i in sorted(here)]
        aim = nominal.map[target] if carry else None
        counts: dict[int, int] = {}
        for i, w in enumerate(worlds):
            if cleared and source in waited:  # after a WAIT: the world without what appeared (as planned)
                w = cleared[i]
            begin = here.get(i, pool[i % len(pool)] if pool else start) if carry else start
            out, stopped = _rollout_stop(kind, begin, nominal.goal, w, robot, nz, hazard, aim)
            lost = False
            if pushes is not None and not stopped and kind not in RECOVERY_TASKS:
                free = out
                out = push_outcome(out, w.obstacles.points, robot, pushes, w.rng, pushes.stand if source == q0 else 0.0)
                lost = out is not free and out.d_n is None and push_lost(pushes, w.rng)
            if out.reached_goal and not known.clear(out, robot):
                out = replace(out, reached_goal=False)
            if carry:
                out = replace(out, start=start)  # the map's states start where their source ends
            ident = b.lost_state(source, kind, out, nominal.goal) if lost else b.group(source, kind, target, out, nominal.goal, stopped)
            counts[ident] = counts.get(ident, 0) + 1
            if carry and not stopped and not lost and out.d_n is None:
                arrivals.setdefault(ident, {}).setdefault(i, out.end)
        for ident, k in sorted(counts.items()):
            b.map.add_transition(source, ident, kind, Fraction(k, samples))
    _complete_turns(b, nominal, conf, known)
    b.map = _reachable_part(b.map)
    plan = extract_plan(b.map)
    b.map.metadata.update({"plan": list(plan.states), "samples": samples, "noise": nz.to_dict(), "seed": seed, "nominal_plan": list(nominal.plan.states),
                           "carry": carry, **({"pushes": _pushes_record(pushes)} if pushes is not None and pushes.active else {}),
                           STOPS_KEY: {str(i): src for i, src in sorted(b.stops.items()) if i in b.map and src in b.map},
                           **({LOST_KEY: {str(i): src for i, src in sorted(b.lost.items()) if i in b.map}} if b.lost else {})})
    if hazard is not None and hazard.contacts:
        b.map.metadata[OFFS_KEY] = {str(i): a for i, a in sorted(_offs(b).items())}
    kept = sum(1 for i in b.new if i in b.map)
    return ProbabilisticMap(b.map, nominal, samples, nz, time.perf_counter() - t0, time.thread_time() - c0, kept)


def _pushes_record(p: Pushes) -> list[float]:
    """The map's record of its pushes: [rate, size], with [lost, stand] after them when
    the whole run's terms are on (a map sampled without them reads as before)."""
    return [p.rate, p.size] + ([p.lost, p.stand] if p.lost or p.stand else [])


def _offs(b: _Builder) -> dict[int, int]:
    """The closed loop's outcomes off the map's prediction: new free leaves (a task ended
    beyond the tolerance of every state) -> the state the task aimed at, where the plan
    check's replan picks up (:func:`clomp.formal.retry.loop_model`)."""
    m = b.map
    return {i: aim for i, aim in b.aims.items()
            if i in m and aim in m and not m[aim].interrupted and not m.out_transitions(i)}


def _breadth_first(cmap: CognitiveMap) -> dict[int, int]:
    """Each state's rank in a breadth-first walk from q0 (sources before their successors)."""
    rank = {cmap.initial.ident: 0}
    queue = [cmap.initial.ident]
    while queue:
        q = queue.pop(0)
        for t in cmap.out_transitions(q):
            if t.target not in rank:
                rank[t.target] = len(rank)
                queue.append(t.target)
    return rank


def _reachable_part(cmap: CognitiveMap) -> CognitiveMap:
    """``cmap`` without the states no transition reaches any more (a nominal outcome that
    no noisy rollout reproduced)."""
    reach = cmap.reachable()
    if len(reach) == len(cmap):
        return cmap
    out = CognitiveMap(goal=cmap.goal)
    for s in cmap.states():
        if s.ident in reach:
            out.add_state(s)
    out.set_initial(cmap.initial.ident)
    for t in cmap.transitions():
        if t.source in reach:
            out.add_transition(t.source, t.target, t.label, t.probability)
    out.metadata.update(cmap.metadata)
    return out


def _complete_turns(b: _Builder, nominal: PlanResult, conf: Configurator, known: KnownFree) -> None:
    """A new uninterrupted turn gets its nominal STRAIGHT (Algorithm 1's frontier rule)."""
    from clomp.planner.rollout import simulate

    for ident in list(b.new):
        s = b.map[ident]
        if s.task.is_turn and not s.interrupted and ident not in b.lost and not b.map.out_transitions(ident):
            out = simulate(TaskKind.STRAIGHT, s.end, nominal.goal, nominal.obstacles, conf.robot)
            if out.reached_goal and not known.clear(out, conf.robot):
                out = replace(out, reached_goal=False)
            target = b.group(ident, TaskKind.STRAIGHT, None, out, nominal.goal)
            b.map.add_transition(ident, target, TaskKind.STRAIGHT)


def learn_from_scans(
    scans: Iterable[Any],
    goal: Disturbance | tuple[float, float],
    configurator: Configurator | None = None,
) -> CognitiveMap:
    """A map learned from repeated observation: each scan of ``scans`` (consecutive scans
    of one place, e.g. a recorded run or a run log's scans) is planned, and every
    (state, task) it observes adds one count to the outcome group of that observation.
    States are matched across scans by their task sequence from q0; outcomes by kind and
    end pose (within :data:`POSITION_TOLERANCE` / :data:`HEADING_TOLERANCE`). A choice
    observed in M scans gets probabilities k/M. The first scan's map gives the states'
    records; later outcomes that match none become new states.

    >>> import numpy as np
    >>> m = learn_from_scans([np.zeros((0, 2))] * 3, (1.0, 0.0))
    >>> [str(t.probability) for t in m.out_transitions(0)]
    ['1']
    """
    conf = configurator or Configurator()
    maps = [conf.plan(s, goal) for s in scans]
    if not maps:
        raise NoiseError("learn_from_scans needs at least one scan")
    first = maps[0]
    b = _Builder(first.map, first.goal, conf.robot, conf.cost)
    counts: dict[tuple[int, TaskKind], dict[int, int]] = {}
    for result in maps:
        m = result.map
        # each observed state is matched to the learned state its observation fell into,
        # walking the map from q0 (sources before their successors)
        learned = {m.initial.ident: b.map.initial.ident}
        queue = [m.initial.ident]
        while queue:
            q = queue.pop(0)
            src = learned[q]
            for t in m.out_transitions(q):
                if b.map[src].interrupted:
                    break  # R is undefined after a hit: nothing may leave it
                o = m[t.target]
                out = Outcome(o.task, o.start, o.end, o.distance, o.duration, 0, o.d_n, o.reached_goal)
                nominal = next((u.target for u in b.map.out_transitions(src) if u.label is t.label), None)
                if nominal is None and m is first.map:
                    nominal = t.target
                ident = b.group(src, t.label, nominal, out, first.goal)
                c = counts.setdefault((src, t.label), {})
                c[ident] = c.get(ident, 0) + 1
                if t.target not in learned:
                    learned[t.target] = ident
                    queue.append(t.target)
    for (source, kind), c in sorted(counts.items(), key=lambda kv: (kv[0][0], list(TaskKind).index(kv[0][1]))):
        total = sum(c.values())
        for ident, k in sorted(c.items()):
            b.map.add_transition(source, ident, kind, Fraction(k, total))
    _complete_turns(b, first, conf, KnownFree.from_points(first.obstacles.points, conf.robot.sensor_range, robot=conf.robot))
    b.map = _reachable_part(b.map)
    plan = extract_plan(b.map)
    b.map.metadata.update({"plan": list(plan.states), "observations": len(maps)})
    return b.map
