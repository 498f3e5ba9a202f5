"""The supervisor's settings: one frozen, validated object (:class:`SupervisorConfig`).

Every number the supervisor's state machine judges by lives here, with its unit and why
it has its default; :class:`~clomp.runtime.supervision.supervisor.Supervisor` takes one
(``Supervisor(robot, goal, config=SupervisorConfig(feedback="none"))``). A bad value is
refused when the config is made, not in the middle of a run.

>>> SupervisorConfig().patience, SupervisorConfig(feedback="none").fused_revolutions
(6, 1)
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from clomp.planner.deepening import DEEPEN

__all__ = ["DRIVE_DELAY", "FEEDBACK", "SupervisorConfig"]

FEEDBACK = ("scan", "none")

#: s: what ``clomp run`` takes a robot's drive to lag its commands by when told nothing
#: (``--drive-delay``): the order of a hobby-servo drive's — a Maestro's 20 ms servo frame and
#: the servo's response (latency) plus half the wheels' ramp to the straight speed (0.1 m/s at
#: about 1 m/s²: 0.05 s). A robot's own measure is better: command a start standing in front of
#: a wall and time its first motion in the scans or the IMU.
DRIVE_DELAY = 0.1


def _positive_int(name: str, n: object, least: int = 1) -> None:
    if not (isinstance(n, int) and not isinstance(n, bool) and n >= least):
        what = "a positive integer" if least == 1 else f"an integer >= {least}"
        raise ValueError(f"{name} must be {what}, got {n!r}")


def _non_negative(name: str, x: object, *, positive: bool = False) -> None:
    ok = isinstance(x, (int, float)) and not isinstance(x, bool) and math.isfinite(x) and (x > 0 if positive else x >= 0)
    if not ok:
        raise ValueError(f"{name} must be a {'positive' if positive else 'non-negative'} finite number, got {x!r}")


@dataclass(frozen=True)
class SupervisorConfig:
    """How the supervisor judges a run (SI units; see :mod:`clomp.runtime.supervision.supervisor`).

    Fields:

    - ``goal_radius`` (m): the goal is reached within it; None: the planner's own goal
      tolerance (:attr:`clomp.planner.robot_model.RobotModel.goal_tolerance`, 0.05 m).
    - ``scan_timeout`` (s): no revolution for this long is a silent sensor, a fault (HALTED).
    - ``max_plans``: fresh plans at most, then UNREACHABLE.
    - ``patience``: plans in a row that bring the robot no closer (by ``min_progress``)
      before UNREACHABLE (with 3, three of ten harsh slalom runs gave up 5-8 s in).
    - ``stall_time`` (s), ``real_progress`` (m): plans that in ``stall_time`` seconds of the
      run brought the robot less than ``real_progress`` closer to the goal (its best distance
      at a plan) before UNREACHABLE (:meth:`~clomp.runtime.supervision.progress.Progress.stalled_for`):
      ``patience`` counts plans, and deep plans that each creep a few centimetres on ran a
      cul-de-sac or a shut door into the time limit. 30 s and 0.1 m: in 59 runs of 10
      families whose goal can be reached (harsh and paper) the longest such lull was 28 s (a
      21 s detour in clutter at paper), and the 16 runs at a cul-de-sac or a shut door then
      all end by 97 s. Judged at every plan the robot sets out on (fresh, backing off,
      recalled); the seconds a WAIT stood before it timed out are not counted (issue #36).
      0 s: never.
    - ``max_recalls``: REPLANNING's recalls of the map in a row before it explores anew.
    - ``max_stuck``: plans in a row that end before the robot moved ``min_progress``
      before UNREACHABLE (standing by an obstacle, interrupted again and again).
    - ``min_progress`` (m): what counts as coming closer or as having moved.
    - ``end_tolerance`` (m, rad): a task that ends farther than this from the map's
      prediction, or a plan check that predicts so, sends the supervisor to REPLANNING.
    - ``lookahead`` (s): a collision this soon on the body's path interrupts the task.
    - ``hazard_points``: how many scan points in the body's path make a hazard.
    - ``settle_scans``: revolutions after a stop before the wheels count as settled.
    - ``feedback``: the pose estimate, ``"scan"`` (dead reckoning corrected by scan
      matching, :class:`~clomp.runtime.estimation.odometry.ScanOdometry`) or ``"none"``
      (dead reckoning alone).
    - ``fuse_scans``: revolutions fused (median range per bearing) into the scan a
      replan starts from (scan feedback only: without it, one).
    - ``start_scans``: revolutions taken standing at the start, the estimator's map seed
      (scan feedback only; at least ``fuse_scans``).
    - ``confirm``: plans in a row, each from fresh revolutions, that find no safe task
      before UNREACHABLE (one fused scan at ``harsh`` can put a surface 2-4 cm into the way).
    - ``deepen``: a search that spent the configurator's budget runs again with this many
      times the budget (:func:`clomp.planner.deepening.plan_deepening`).
    - ``back_off``: a plan that finds no safe task (not even a frontier to explore) is
      searched again with REVERSE offered before the robot stands
      (:func:`clomp.planner.deepening.plan_deepening`'s ``back_off``): a frontier plan's last
      task can leave the robot where nothing but backing off is free.
    - ``vouch_radius`` (m): with scan feedback, the goal is *reached* (GOAL_REACHED) only
      when the estimated distance plus the 95 % bound of the position
      (``vouch_sigmas`` standard deviations of
      :meth:`~clomp.runtime.estimation.odometry.ScanOdometry.position_sd`) is within it; an
      estimate at the goal (within ``goal_radius``) that cannot vouch for it ends
      GOAL_UNCONFIRMED. Default 0.1 m: the tolerance runs are judged by on ground truth
      (:data:`clomp.runtime.experiment.onerun.SUCCESS_RADIUS`). None: no bound is asked
      for (the goal is declared on the estimate alone, as before issue #36). Dead
      reckoning alone (``feedback="none"``) carries no uncertainty and declares on the
      estimate.
    - ``vouch_sigmas``: standard deviations in the bound; 2.45 is the 95 % radius of a
      2-D normal (the square root of chi-square's 95 % point with 2 degrees of freedom).
    - ``confirm_looks``: at the goal by the estimate but not vouched, the revolutions the
      supervisor stands and looks (CONFIRMING) before it ends GOAL_UNCONFIRMED; it declares
      the goal as soon as the settled estimate vouches for it
      (:mod:`clomp.runtime.supervision.goal`). 0: give up at once.
    - ``confirm_approaches``: confirming, times a run the supervisor plans to the goal again
      when the settled (or re-localised) estimate has left it.
    - ``relocate_at_goal``: with scan feedback, at the goal by the estimate, the revolutions
      seen standing are matched against the map from several guesses around the estimate;
      when they fit clearly better elsewhere the estimate moves there and the robot plans on
      (issue #36: a push or a slip the matcher's few centimetres of reach could not follow),
      at most this many times a run (0: never).
    - ``moving``: a world that moves (issue #42; off by default, so static worlds behave as
      before): what appears between revolutions where the map saw free space is marked
      possibly moving and handed to the planner (WAIT before a detour), WAIT and REVERSE
      tasks run (:mod:`clomp.runtime.supervision.moving`). Needs a configurator planning with
      them (``Configurator(recovery=True)``).
    - ``wait_timeout`` (s): the longest a WAIT stands watching before the plan is made anew
      around what stayed.
    - ``move_away`` (m): after a push felt (an IMU kick, a revolution seeing through the map)
      that left ``hazard_points`` scan points within ``push_margin`` (m) of the body, the
      supervisor drives or backs this far clear of them before it plans (MOVING_AWAY,
      :mod:`clomp.runtime.supervision.pushaway`); 0: never (as before). ``move_away_longest``
      (m): it drives or backs farther, up to this, when ``move_away`` leaves ``hazard_points``
      within the margin (a post beside the body slides along it to its corner).
    - ``replan_jump`` (m, rad): a revolution that moves the estimate farther than this while
      a task runs (a re-localisation after a push, a large correction: not the wheels) ends
      the task and the supervisor plans afresh (EXECUTING → REPLANNING, ``disagree``): the
      task was set from where the robot was believed to be, and would drive the rest of its
      length from the wrong place. Ordinary corrections at ``harsh`` stay under 3 cm and 1°;
      after a push they were 7-12 cm. Such a jump is also what makes a revolution seeing
      through the map evidence of a push (:mod:`clomp.runtime.supervision.pushaway`).
    - ``drive_delay`` (s): how long after a command the body follows it (the drive's latency
      and half its ramp to speed), as the robot's maker or a measurement tells it; the
      estimator dead-reckons on the commands that late
      (:attr:`~clomp.runtime.estimation.prior.OdometryPrior.delay`), whatever else its prior
      is. None: the backend's own (a :class:`~clomp.runtime.interface.Calibrated` robot's told
      delay, else 0). ``clomp run`` sets it (``--drive-delay``, default
      :data:`~clomp.runtime.supervision.config.DRIVE_DELAY`): taken as 0, every start's lead of
      the commands over the body (about 1.5 cm at 0.1 m/s) was learnt as a wheel scale.

    >>> SupervisorConfig(confirm=0)
    Traceback (most recent call last):
    ...
    ValueError: confirm must be a positive integer, got 0
    >>> SupervisorConfig(fuse_scans=5, start_scans=2).start_revolutions
    5
    """

    goal_radius: float | None = None
    scan_timeout: float = 1.0
    max_plans: int = 30
    patience: int = 6
    stall_time: float = 30.0
    real_progress: float = 0.1
    max_recalls: int = 5
    max_stuck: int = 8
    min_progress: float = 0.03
    end_tolerance: tuple[float, float] = (0.08, 0.3)
    lookahead: float = 0.5
    hazard_points: int = 2
    settle_scans: int = 2
    feedback: str = "scan"
    fuse_scans: int = 3
    start_scans: int = 10
    confirm: int = 3
    deepen: int = DEEPEN
    back_off: bool = True
    vouch_radius: float | None = 0.1
    vouch_sigmas: float = 2.45
    confirm_looks: int = 20
    confirm_approaches: int = 2
    relocate_at_goal: int = 0
    moving: bool = False
    wait_timeout: float = 4.0
    move_away: float = 0.12
    push_margin: float = 0.04
    move_away_longest: float = 0.3
    replan_jump: tuple[float, float] = (0.05, 0.1)
    drive_delay: float | None = None

    def __post_init__(self) -> None:
        if self.feedback not in FEEDBACK:
            raise ValueError(f"feedback must be one of {', '.join(FEEDBACK)}, got {self.feedback!r}")
        for name in ("max_plans", "patience", "max_stuck", "hazard_points", "fuse_scans", "start_scans", "confirm",
                     "deepen"):
            _positive_int(name, getattr(self, name))
        _positive_int("max_recalls", self.max_recalls, least=0)
        _positive_int("settle_scans", self.settle_scans, least=0)
        _positive_int("relocate_at_goal", self.relocate_at_goal, least=0)
        _positive_int("confirm_looks", self.confirm_looks, least=0)
        _positive_int("confirm_approaches", self.confirm_approaches, least=0)
        if self.goal_radius is not None:
            _non_negative("goal_radius", self.goal_radius, positive=True)
        if self.vouch_radius is not None:
            _non_negative("vouch_radius", self.vouch_radius, positive=True)
        _non_negative("vouch_sigmas", self.vouch_sigmas)
        _non_negative("scan_timeout", self.scan_timeout, positive=True)
        _non_negative("min_progress", self.min_progress)
        _non_negative("lookahead", self.lookahead)
        _non_negative("wait_timeout", self.wait_timeout, positive=True)
        _non_negative("stall_time", self.stall_time)
        _non_negative("real_progress", self.real_progress)
        _non_negative("move_away", self.move_away)
        _non_negative("push_margin", self.push_margin)
        _non_negative("move_away_longest", self.move_away_longest)
        if self.drive_delay is not None:
            _non_negative("drive_delay", self.drive_delay)
        if not (isinstance(self.end_tolerance, tuple) and len(self.end_tolerance) == 2):
            raise ValueError(f"end_tolerance must be (metres, radians), got {self.end_tolerance!r}")
        for name, x in zip(("end_tolerance[0]", "end_tolerance[1]"), self.end_tolerance):
            _non_negative(name, x, positive=True)
        if not (isinstance(self.replan_jump, tuple) and len(self.replan_jump) == 2):
            raise ValueError(f"replan_jump must be (metres, radians), got {self.replan_jump!r}")
        for name, x in zip(("replan_jump[0]", "replan_jump[1]"), self.replan_jump):
            if not (isinstance(x, (int, float)) and not isinstance(x, bool) and x > 0):  # inf: never
                raise ValueError(f"{name} must be a positive number, got {x!r}")

    @property
    def fused_revolutions(self) -> int:
        """Revolutions fused into a replan's scan: ``fuse_scans`` with scan feedback, else 1.

        >>> SupervisorConfig(fuse_scans=4).fused_revolutions
        4
        """
        return self.fuse_scans if self.feedback == "scan" else 1

    @property
    def start_revolutions(self) -> int:
        """Revolutions taken standing before the first plan: with scan feedback the map's
        seed (``start_scans``, at least the fused ones), else the fused ones.

        >>> SupervisorConfig(feedback="none").start_revolutions
        1
        """
        if self.feedback == "scan":
            return max(self.start_scans, self.fused_revolutions)
        return self.fused_revolutions
