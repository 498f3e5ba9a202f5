"""Risk-aware planning for the closed loop: Storm's scheduler on the probabilistic map.

:class:`RobustConfigurator` is a Configurator whose plans are the policy that maximises
the chance of reaching the plan's target without a collision (:func:`plan_target`) on
a probabilistic map (:func:`clomp.planner.probabilistic.sample_map`) sampled as the closed
loop runs; a supervisor executes and replans with it. Needs stormpy.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from clomp.formal.lts import CognitiveMap
from clomp.formal.model import Disturbance, Pose, TaskKind
from clomp.formal.scheduler import RobustPlan
from clomp.formal.supervisory import Plan, is_frontier
from clomp.planner.configurator import Configurator, PlanResult
from clomp.planner.perception import load_scan
from clomp.planner.probabilistic import (
    POSITION_TOLERANCE,
    SUPERVISOR_TOLERANCE,
    HazardRule,
    ProbabilisticMap,
    RolloutNoise,
    sample_map,
)
from clomp.planner.pushes import Pushes
from clomp.planner.robot_model import RobotModel

__all__ = ["plan_target", "frontier_outcomes", "RobustChoice", "RobustDecision", "RobustConfigurator", "SUPERVISOR_HAZARD", "CLOSED_LOOP_HAZARD",
           "CLOSED_LOOP_TERMS",
           "closed_loop_noise", "rollout_noise"]

_CONFIRM_SEED = 2**40
"""Added to a plan's sampling seed for the map that confirms a deviation (its own worlds)."""

SUPERVISOR_HAZARD = HazardRule()
"""The supervisor's scan test with its defaults (2 points, 5.5 Hz)."""

CLOSED_LOOP_HAZARD = HazardRule(contacts=True)
"""The same test applied to the rollouts that touch an obstacle too: a contact it sees
coming is a stop (replanned from), not a collision (:mod:`clomp.planner.hazard`); what
``clomp export --closed-loop`` samples with."""

_HARSH_TERMS = {"wheel_bias": 0.005, "drift": 0.002, "turn_sd": 0.035, "turn_mean": 0.006,
                "straight_sd": 0.054, "straight_mean": 0.007}
CLOSED_LOOP_TERMS: dict[str, dict[str, float]] = {
    "harsh": _HARSH_TERMS,
    "unmodelled": _HARSH_TERMS,
    "harsh-modelled": {"wheel_bias": 0.005, "drift": 0.002, "turn_sd": 0.058, "turn_mean": 0.058,
                       "straight_sd": 0.041, "straight_mean": 0.061},
}
"""Rollout terms of a preset as the execution world's closed loop turns them out: the
truth's motion over a task against what the supervisor's scan-corrected estimate
believed it did (it ends a task on that estimate).

``harsh`` (with the error sources the estimator does not model; ``unmodelled`` is the
same preset): fitted to the tasks of the calibration bench's greedy runs,
``python bench/calibration_model.py RUNS.jsonl --fit`` (six families, 57 runs, 193
turns and 228 straights, outliers beyond 4 median deviations, mostly a push during the
task, left out): a turn truly turns 0.9 % more than believed (sd 4.1 %), a straight
drives 1.5 % short (sd 5.5 %) and drifts 3.2 cm sideways per metre (sd). With these
terms the rollouts give a turn +0.8 % (sd 3.7 %), a straight -1.2 % (sd 5.1 %) and
6.9 cm/m (300 rollouts, seed 0; the sideways spread is the preset's wheels', which no
closed-loop term narrows).

``harsh-modelled`` (the old ``harsh``, every term of ``paper`` x5): fitted to
``python bench/rollout_calibration.py --runs 20`` (doorway and clutter, after the pose
filter: 70 turns and 101 straights): a turn truly turned 6.2 % more than believed (sd
6.2 %), a straight drove 4.1 % farther (sd 4.2 %) and drifted 6.6 cm per metre; with
these terms the rollouts give +6.1 % (sd 6.2 %), +4.0 % (sd 4.2 %) and 6.9 cm/m."""


def closed_loop_noise(preset: str) -> RolloutNoise:
    """The rollout noise of ``preset`` with the terms :data:`CLOSED_LOOP_TERMS` measured for
    it in the execution world (the preset unchanged where nothing was measured).

    >>> closed_loop_noise("harsh").turn_error_sd, closed_loop_noise("harsh-modelled").turn_error_sd
    (0.035, 0.058)
    >>> closed_loop_noise("paper") == RolloutNoise.preset("paper")
    True
    """
    return replace(RolloutNoise.preset(preset), **CLOSED_LOOP_TERMS.get(preset, {}))


def rollout_noise(noise: RolloutNoise | str) -> RolloutNoise:
    """The rollouts' noise for ``noise``: a preset name gives :func:`closed_loop_noise`
    (what the closed loop turns the preset into, where measured), a
    :class:`RolloutNoise` is taken as it is. What :class:`RobustConfigurator` and
    ``clomp plan --robust`` sample with.

    >>> rollout_noise("harsh") == closed_loop_noise("harsh"), rollout_noise(RolloutNoise()) == RolloutNoise()
    (True, True)
    """
    return closed_loop_noise(noise) if isinstance(noise, str) else noise


def plan_target(cmap: CognitiveMap, nominal_end: Pose, goal: Disturbance, radius: float = 0.1,
                slack: float = POSITION_TOLERANCE, frontier: bool | None = None) -> set[int]:
    """The states a plan on ``cmap`` is for, as the closed loop measures success: when the
    best-first plan reaches the goal (its end ``nominal_end`` lies within ``radius``, the
    experiment's success radius, 0.1 m), the free states that end within ``radius`` of
    the goal (on the rollouts' true poses); when it does not (the goal lies beyond the
    sensed disc, or the search stopped short of it), the free states that end no
    farther from the goal than ``nominal_end`` plus ``slack`` (default
    :data:`POSITION_TOLERANCE`): the progress the supervisor replans from. When that end
    is a frontier state (``frontier``; None: a frontier state of ``cmap`` ends there),
    only the frontier states among them: the plan-end rule ends an exploring plan at a
    frontier and never inside a U, whose states may lie nearer the goal but from which
    the next plan sees nothing new (:func:`clomp.formal.supervisory.plan_end`, rule 3b).

    Before, the inside of a U was a target as good as the frontier: on ``u-trap`` at
    harsh noise Storm found driving into it surer than going round (P 1.00 against
    0.90, layout 3), and where a second look confirmed it the robust run drove into the
    trap and ended ``UNREACHABLE`` where the best-first run reached the goal (robust
    27/39 against greedy 32/39, docs/calibration.md).

    Before, a map in which one noisy outcome of many happened to end within ``radius``
    made the goal the target of a plan that aims at a frontier (P the chance of that
    outcome, e.g. 0.03, for a plan that surely makes its progress), and only leaves were
    frontier targets, so a plan whose search spent its budget, ending at an argmin φ the
    search had expanded, did not reach its own target (P = 0): calibration bench,
    docs/calibration.md.

    >>> import numpy as np
    >>> r = sample_map(np.zeros((0, 2)), (3.0, 0.0), samples=2, noise="ideal")
    >>> r.nominal.plan.end in plan_target(r.map, r.map[r.nominal.plan.end].end, r.nominal.goal)
    True
    """
    q0 = cmap.initial.ident
    reach = cmap.reachable()
    free = [s for s in cmap.states() if s.ident in reach and s.ident != q0 and not s.interrupted]
    d = nominal_end.distance_to(goal.x, goal.y)
    near = {s.ident for s in free if s.end.distance_to(goal.x, goal.y) <= radius}
    if near and d <= radius:
        return near
    close = [s for s in free if s.end.distance_to(goal.x, goal.y) <= d + slack]
    if frontier is None:
        frontier = any(is_frontier(s) and s.end.distance_to(nominal_end.x, nominal_end.y) <= 1e-9 for s in close)
    ends = {s.ident for s in close} & frontier_outcomes(cmap) if frontier else set()
    return ends or {s.ident for s in close}


def frontier_outcomes(cmap: CognitiveMap) -> set[int]:
    """The frontier states of ``cmap`` and every other outcome of a choice that has one
    (a noisy rollout of a task that ends at the frontier ended off its state: at the
    rim too, not inside what the scan showed).

    >>> import numpy as np
    >>> r = sample_map(np.zeros((0, 2)), (3.0, 0.0), samples=2, noise="ideal")
    >>> r.nominal.plan.end in frontier_outcomes(r.map)
    True
    """
    front = {s.ident for s in cmap.states() if is_frontier(s)}
    choices = {(t.source, t.label) for t in cmap.transitions() if t.target in front}
    return front | {t.target for t in cmap.transitions() if (t.source, t.label) in choices}


@dataclass
class RobustChoice:
    """One robust planning step: the probabilistic map, the best-first plan it refines
    (``greedy_result``: the Configurator's own, unchanged, and ``greedy``: carried onto
    the map), the target, Storm's policy and both predictions."""

    pm: ProbabilisticMap
    greedy_result: PlanResult
    greedy: Plan
    target: set[int]
    robust: RobustPlan
    p_greedy: float


class RobustConfigurator(Configurator):
    """A Configurator whose plans are Storm's risk-aware ones: each :meth:`plan` builds
    the probabilistic map (``samples`` noisy rollouts per choice; ``noise``: a preset
    name, sampled with the terms the closed loop turns it into, :func:`rollout_noise`, or
    a :class:`RolloutNoise` as given) and
    returns the plan of the scheduler that maximises P[!collision U target] on it, so
    that a supervisor executes and replans with robust plans. The map is searched for
    ``routes`` ends (goal states or frontiers, :attr:`Configurator.routes`, within
    ``route_states`` states) so that the scheduler has alternatives to the best-first
    route; the best-first plan itself is the plain Configurator's. ``target`` is
    :func:`plan_target`: the goal within ``goal_radius`` or, beyond the sensed disc, a
    frontier within ``frontier_slack`` as close as the best-first plan gets (what the
    closed loop measures; P[goal] alone is 0 for every plan there). The best-first
    plan's task is kept wherever it is within ``margin`` of the optimum (Storm picks
    arbitrarily among equal choices, and k/N is an estimate): the plan leaves it only
    where a detour is safer by more than ``margin``. The map is sampled as the closed
    loop runs: outcomes within the supervisor's end tolerance are one state
    (``tolerance``), a rollout is interrupted where the supervisor's scan test would
    stop it (``hazard``), and each noisy world carries its robot's true pose from task to
    task (``carry``, :func:`clomp.planner.probabilistic.sample_map`): a task starts where the
    one before truly ended, as in the world, not at the state's recorded pose (``pushes``,
    :class:`clomp.planner.pushes.Pushes`, default none: the world's pushes too). A stop is retried up to ``retries`` times (default 1) in Storm's
    objective, as the supervisor replans after one (:func:`clomp.formal.retry.retry_model`; 0:
    a stop is final, as before; at harsh noise, 50 paired runs per family, 1 and 0 gave
    the same successes: doorway 42 vs greedy 41 both, clutter 16 vs 16 both). Needs
    stormpy.

    Where the scheduler keeps every task of the best-first plan, :meth:`plan` returns the
    plain Configurator's result itself (``decision`` "kept"). Where it leaves it, the
    deviation is confirmed on an independent map of fresh rollouts
    (:meth:`confirm_deviation`, when ``confirm``): the robust plan is taken only if there
    too its value beats the best-first plan's by more than ``margin`` ("confirmed"),
    else the best-first plan is returned unchanged ("rejected"). A maximum over k/N
    estimates is biased upwards, so without the second look the scheduler takes plans
    that are safer on sampling noise alone. A run of the closed loop with this
    Configurator thus differs from one with the plain Configurator only after a
    confirmed deviation. ``decisions`` lists each plan's decision, ``confirmations``
    the (robust, best-first) values of every second look.

    A robust plan is executed as a policy: the scheduler is kept on the map
    (:func:`clomp.formal.scheduler.attach_policy`), and the supervisor's recall after a task
    ended in another outcome continues with the scheduler's choice in the state it
    finds the robot in.

    ``last_probabilities`` holds (plan, greedy) of the latest plan: Storm's predictions
    of reaching the target without a collision for the plan returned and for the
    best-first plan (equal unless the plan is a confirmed deviation);
    ``predictions`` every plan's.

    >>> import numpy as np
    >>> conf = RobustConfigurator(samples=2, noise="ideal")
    >>> r = conf.plan(np.zeros((0, 2)), (1.0, 0.0))
    >>> r.reached_goal, conf.last_probabilities
    (True, (1.0, 1.0))
    """

    def __init__(
        self,
        robot: RobotModel | None = None,
        samples: int = 30,
        noise: RolloutNoise | str = "harsh",
        seed: int = 0,
        goal_radius: float = 0.1,
        margin: float = 0.1,
        tolerance: tuple[float, float] | None = SUPERVISOR_TOLERANCE,
        hazard: HazardRule | None = SUPERVISOR_HAZARD,
        routes: int = 1,
        route_states: int = 100,
        frontier_slack: float = POSITION_TOLERANCE,
        confirm: bool = True,
        retries: int = 1,
        carry: bool = True,
        pushes: Pushes | None = None,
        **options: Any,
    ) -> None:
        super().__init__(robot, **options)
        self.samples = samples
        self.noise = rollout_noise(noise)
        self.seed = seed
        self.goal_radius = goal_radius
        self.margin = margin
        self.tolerance = tolerance
        self.hazard = hazard
        self.search_routes = routes
        self.route_states = route_states
        self.frontier_slack = frontier_slack
        self.confirm = confirm
        if isinstance(retries, bool) or not isinstance(retries, int) or retries < 0:
            raise ValueError(f"retries must be a whole number >= 0, got {retries!r}")
        self.retries = retries
        self.carry = carry
        self.pushes = pushes
        self._calls = 0
        self.decisions: list[str] = []
        self.confirmations: list[tuple[float, float]] = []
        self.last_probabilities: tuple[float, float] | None = None
        self.predictions: list[tuple[float, float]] = []

    def _plain(self) -> Configurator:
        """The plain Configurator of this one's search: its budget, and its ``recovery``
        and ``transient`` (the supervisor's back-off sets ``recovery`` on a copy of the
        configurator, :func:`clomp.planner.deepening.plan_deepening`; without them here a
        robust run never backed off where a best-first run did)."""
        c = Configurator(self.robot, self.cost, self.max_states, self.horizon, recovery=self.recovery)
        c.transient = self.transient
        return c

    def probabilistic_map(self, scan: Any, goal: Disturbance | tuple[float, float],
                          seed: int | None = None) -> ProbabilisticMap:
        """The probabilistic map this configurator chooses on, for ``seed`` (default
        ``self.seed``: the map of the first :meth:`plan`): rollouts with the supervisor's
        tolerance, hazard stops and carried poses, on the map searched for ``routes``
        ends. Needs no Storm; ``clomp export --samples`` writes this map, so the model a
        user checks is the one ``clomp plan --robust`` and the runtime plan on.

        >>> import numpy as np
        >>> pm = RobustConfigurator(samples=2, noise="ideal").probabilistic_map(np.zeros((0, 2)), (1.0, 0.0))
        >>> pm.samples, pm.map.metadata["carry"]
        (2, True)
        """
        if self.search_routes > 1:
            base = Configurator(self.robot, self.cost, max(self.max_states, self.route_states), self.horizon,
                                routes=self.search_routes, recovery=self.recovery)
            base.transient = self.transient
        else:
            base = self._plain()
        return sample_map(scan, goal, self.samples, self.noise, self.seed if seed is None else seed, base,
                          self.tolerance, self.hazard, self.carry, self.pushes)

    def sample(self, scan: Any, goal: Disturbance | tuple[float, float]) -> RobustChoice:
        """The probabilistic map of ``scan``, the best-first plan and Storm's policy on it
        (one call to :meth:`plan` without the choice; seeds advance per call)."""
        from clomp.formal.scheduler import follow_tasks, plan_probability, robust_plan

        points = load_scan(scan)
        plain = self._plain()
        greedy_result = plain.plan(points, goal)
        pm = self.probabilistic_map(points, goal, self.seed + self._calls)
        self._calls += 1
        self.transient = None  # used once, as Configurator.plan uses it
        g = greedy_result
        target = plan_target(pm.map, g.map[g.plan.end].end, g.goal, self.goal_radius, self.frontier_slack)
        if all(pm.map.has_transition(a, b) for a, b in g.plan.steps()):
            greedy = g.plan  # the best-first plan itself: its states are the map's nominal ones
        else:  # some nominal outcome never happened in the rollouts: carried by its tasks
            greedy = follow_tasks(pm.map, [st.task for st in g.steps])
        prefer = {a: pm.map[b].task for a, b in greedy.steps()}
        rp = robust_plan(pm.map, target, prefer, self.margin, self.retries)
        p_greedy = plan_probability(pm.map, greedy, target, self.retries)
        self.last_probabilities = (rp.probability, p_greedy)
        self.predictions.append(self.last_probabilities)
        return RobustChoice(pm, greedy_result, greedy, target, rp, p_greedy)

    def confirm_deviation(self, points: np.ndarray, goal: Disturbance | tuple[float, float], c: RobustChoice,
                          seed: int) -> tuple[float, float]:
        """The values of the robust plan and of the best-first plan on an independent
        probabilistic map (the same rollouts' size and noise, seed ``seed``): each plan's
        tasks are carried onto it (:func:`clomp.formal.scheduler.follow_tasks`) and followed along
        its path, Storm's optimal choice elsewhere (the recall), so the two differ only
        in the choices that make them differ. Returns (robust, best-first).

        Why: the scheduler maximises over many k/N estimates, and the maximum of noisy
        estimates is biased upwards (the optimiser's curse); values measured on samples
        that did not choose the plan are not."""
        from clomp.formal.scheduler import follow_tasks, policy_probability, robust_plan

        base = c.pm.nominal
        g = c.greedy_result
        other = sample_map(points, goal, self.samples, self.noise, seed, _Fixed(base, self.cost), self.tolerance, self.hazard,
                           self.carry, self.pushes)
        target = plan_target(other.map, g.map[g.plan.end].end, g.goal, self.goal_radius, self.frontier_slack)
        best = robust_plan(other.map, target, retries=self.retries).scheduler

        def value(plan: Plan, cmap: CognitiveMap) -> float:
            carried = follow_tasks(other.map, [cmap[b].task for _, b in plan.steps()])
            policy = dict(best)
            policy.update({a: other.map[b].task for a, b in carried.steps()})
            return policy_probability(other.map, policy, target, self.retries)

        return value(c.robust.plan, c.pm.map), value(c.greedy, c.pm.map)

    def choose(self, scan: Any, goal: Disturbance | tuple[float, float]) -> RobustDecision:
        """One planning step without the plan: the probabilistic map, Storm's policy and
        the decision (see the class docstring). :meth:`plan` and ``clomp plan --robust``
        both come through here, so the command line shows the plan a supervisor runs."""
        points = load_scan(scan)
        call = self._calls
        c = self.sample(points, goal)
        cmap = c.pm.map
        sched = c.robust.scheduler
        kept = len(c.greedy) > 1 and all(sched.get(a) is cmap[b].task for a, b in c.greedy.steps())
        confirmation = None
        if kept or len(c.robust.plan) <= 1:  # nothing safer found, or no task at all
            decision = "kept"
        elif not self.confirm:
            decision = "deviated"
        else:
            confirmation = self.confirm_deviation(points, goal, c, self.seed + call + _CONFIRM_SEED)
            decision = "confirmed" if confirmation[0] > confirmation[1] + self.margin else "rejected"
            self.confirmations.append(confirmation)
        self.decisions.append(decision)
        d = RobustDecision(c, decision, confirmation)
        self.last_probabilities = (d.probability, c.p_greedy)
        self.predictions[-1] = self.last_probabilities
        return d

    def plan(self, scan: Any, goal: Disturbance | tuple[float, float]) -> PlanResult:
        """The robust plan on the probabilistic map of ``scan`` (see the class docstring)."""
        from clomp.formal.scheduler import attach_policy
        from clomp.formal.supervisory import Guard

        t0 = time.perf_counter()
        d = self.choose(scan, goal)
        c, g = d.choice, d.choice.greedy_result
        if not d.deviates:
            # the best-first plan, exactly as the plain Configurator made it (its map, its
            # states, their predicted ends): the supervisor executes and recalls it as it
            # would without Storm, so a run differs only where Storm found a safer plan
            return replace(g, planning_time_s=time.perf_counter() - t0)
        cmap = c.pm.map
        attach_policy(cmap, c.robust.scheduler)  # a recall on this map follows the scheduler
        cmap.metadata["target"] = sorted(c.target)
        plan = c.robust.plan
        return PlanResult(cmap, plan, g.goal, g.obstacles, g.robot, time.perf_counter() - t0, g.stop_reason, Guard(cmap, plan).table(),
                          g.goal_blocked)


@dataclass
class RobustDecision:
    """What :meth:`RobustConfigurator.choose` decided: the step's :class:`RobustChoice`,
    ``decision`` ("kept", "confirmed", "rejected" or, without the second look,
    "deviated") and the second look's (robust, best-first) values, if one was taken."""

    choice: RobustChoice
    decision: str
    confirmation: tuple[float, float] | None = None

    @property
    def deviates(self) -> bool:
        """Whether Storm's policy is executed (else the best-first plan, unchanged)."""
        return self.decision in ("confirmed", "deviated")

    @property
    def plan(self) -> Plan:
        """The plan executed, on the probabilistic map: Storm's, or the best-first one."""
        return self.choice.robust.plan if self.deviates else self.choice.greedy

    @property
    def policy(self) -> dict[int, TaskKind]:
        """The task the supervisor starts in each state it may reach: Storm's scheduler,
        or the best-first plan's tasks along its path (its recall has no policy)."""
        if self.deviates:
            return dict(self.choice.robust.scheduler)
        cmap = self.choice.pm.map
        return {a: cmap[b].task for a, b in self.plan.steps()}

    @property
    def probability(self) -> float:
        """Storm's P[!collision U target] of the plan executed (with the retries)."""
        return self.choice.robust.probability if self.deviates else self.choice.p_greedy


class _Fixed(Configurator):
    """A Configurator that hands back one given planning result (a second probabilistic
    map of the same scan need not plan the nominal map again)."""

    def __init__(self, result: PlanResult, cost: Any) -> None:
        super().__init__(result.robot, cost)
        self.result = result

    def plan(self, scan: Any, goal: Disturbance | tuple[float, float]) -> PlanResult:
        return self.result
