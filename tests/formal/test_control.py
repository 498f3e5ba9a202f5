"""The supervisor's machine as data: its properties fail for a broken machine, and the
Ramadge-Wonham checks (controllability, non-blocking) name counterexamples."""

from __future__ import annotations

import pytest

from clomp.formal.control import PLANT, SUPERVISOR, Machine, controllability, machine_model, nonblocking

stormpy = pytest.importorskip("stormpy", reason="stormpy not installed: pip install -e '.[verify]'")

from clomp.formal.control import check_machine  # noqa: E402


def _verdicts(machine: Machine) -> dict[str, tuple[bool | None, list[str]]]:
    return {r.spec.name: (r.passed, r.witness) for r in check_machine(machine)}


def test_the_shipped_machine_satisfies_every_property():
    v = _verdicts(SUPERVISOR)
    assert set(v) == {"wheels_only_on_a_task", "fault_stops_the_wheels", "terminal_is_still", "nonblocking", "goal_possible",
                      "unconfirmed_stays_unconfirmed", "unconfirmed_only_after_confirming", "confirming_is_still",
                      "moving_away_then_replans", "moving_away_only_backing_off"}
    assert all(passed for passed, _ in v.values()), v


def test_a_fault_that_leaves_executing_in_place_fails_in_storm():
    broken = SUPERVISOR.with_transition("EXECUTING", "fault", "EXECUTING")
    v = _verdicts(broken)
    assert v["fault_stops_the_wheels"][0] is False and v["wheels_only_on_a_task"][0] is False
    path = v["fault_stops_the_wheels"][1]
    assert path[0].endswith("[idle]") and "after_fault" in path[-1] and "motors" in path[-1]


def test_wheels_on_in_replanning_fails_in_storm():
    broken = SUPERVISOR.with_wheels({"EXECUTING", "REPLANNING"})
    v = _verdicts(broken)
    assert v["wheels_only_on_a_task"][0] is False
    assert "replanning" in v["wheels_only_on_a_task"][1][-1]
    assert v["fault_stops_the_wheels"][0] is True


def test_events_are_split_into_controllable_and_uncontrollable():
    assert SUPERVISOR.controllable == {"start", "planned", "next_task", "abort", "approach", "move_away"}
    assert SUPERVISOR.uncontrollable == {"no_plan", "at_goal", "goal_unconfirmed", "plan_short", "disagree", "fault",
                                         "moved_away"}
    assert all(t.guard is None or t.guard in SUPERVISOR.guards for t in SUPERVISOR.transitions)


def test_controllability_holds_and_names_a_disabled_uncontrollable_event():
    assert controllability(SUPERVISOR, PLANT).ok
    broken = SUPERVISOR.with_transition("EXECUTING", "disagree", None)
    r = controllability(broken, PLANT)
    assert not r.ok
    (path, why), *_ = r.counterexamples
    assert path == ("start", "planned") and "EXECUTING disables uncontrollable 'disagree'" in why
    # ignoring a fault once the run is over is allowed only because the table says so
    assert not controllability(SUPERVISOR.with_transition("GOAL_REACHED", "fault", None), PLANT).ok


def test_nonblocking_holds_and_names_a_state_that_can_never_end():
    assert nonblocking(SUPERVISOR, PLANT).ok
    broken = SUPERVISOR.with_transition("EXECUTING", "fault", "EXECUTING").with_transition("EXECUTING", "abort", None)
    r = nonblocking(broken, PLANT)
    assert not r.ok
    assert ("start", "planned", "fault") in [p for p, _ in r.counterexamples]
    assert _verdicts(broken)["nonblocking"][0] is False


def test_a_table_with_two_transitions_on_one_event_is_refused():
    from clomp.formal.control import MachineTransition

    with pytest.raises(ValueError, match="two transitions from IDLE on start"):
        Machine("m", ("IDLE", "A"), "IDLE", frozenset({"A"}), frozenset(), SUPERVISOR.events,
                (MachineTransition("IDLE", "start", "A"), MachineTransition("IDLE", "start", "IDLE")))


def test_the_machine_renders_through_the_exporters_and_both_tools_agree():
    from clomp.formal.checking import read_properties
    from clomp.formal.crosscheck import cross_check
    from clomp.formal.control import machine_property_file
    from clomp.formal.prism import find_prism

    m = machine_model()
    assert m.title and len({s.name for s in m.states}) == m.n_states
    if find_prism() is None:
        pytest.skip("PRISM not found")
    cc = cross_check(m, "mdp", files=[read_properties(machine_property_file())], title="machine")
    assert cc.agrees, (cc.disagreements(), {k: v[:2] for k, v in cc.loads.items()})


def test_goal_unconfirmed_is_a_terminal_end_the_checks_keep():
    """Issue #36: an end at the goal the estimate cannot vouch for. Terminal, reached on the
    uncontrollable ``goal_unconfirmed`` from CONFIRMING, which every state where ``at_goal``
    can happen enters on it first; the machine stays controllable and non-blocking, and
    leaving the event out of EXECUTING or CONFIRMING breaks it."""
    assert "GOAL_UNCONFIRMED" in SUPERVISOR.terminal and "goal_unconfirmed" in SUPERVISOR.uncontrollable
    for s in ("PLANNING", "EXECUTING", "REPLANNING"):
        assert SUPERVISOR.target(s, "goal_unconfirmed") == "CONFIRMING"
    assert SUPERVISOR.target("CONFIRMING", "goal_unconfirmed") == "GOAL_UNCONFIRMED"
    assert controllability(SUPERVISOR, PLANT).ok and nonblocking(SUPERVISOR, PLANT).ok
    for s in ("EXECUTING", "CONFIRMING"):
        broken = SUPERVISOR.with_transition(s, "goal_unconfirmed", None)
        assert not controllability(broken, PLANT).ok, s


def test_confirming_stands_and_is_the_only_way_to_unconfirmed():
    """CONFIRMING: the wheels stay stopped, and GOAL_UNCONFIRMED is reached only through it.
    A machine that gives up straight from REPLANNING, or lets the wheels turn while
    confirming, fails the property that says so (in Storm)."""
    assert "CONFIRMING" not in SUPERVISOR.wheels and "CONFIRMING" not in SUPERVISOR.terminal
    assert SUPERVISOR.target("CONFIRMING", "approach") == "REPLANNING"
    assert SUPERVISOR.target("CONFIRMING", "at_goal") == "GOAL_REACHED"
    skip = SUPERVISOR.with_transition("REPLANNING", "goal_unconfirmed", "GOAL_UNCONFIRMED")
    assert controllability(skip, PLANT).ok  # the R-W checks cannot tell: the property does
    v = _verdicts(skip)
    assert v["unconfirmed_only_after_confirming"][0] is False and v["confirming_is_still"][0] is True
    v = _verdicts(SUPERVISOR.with_wheels({"EXECUTING", "CONFIRMING"}))
    assert v["confirming_is_still"][0] is False


def test_moving_away_after_a_push_keeps_the_checks_and_ends_in_a_replan():
    """A push that left the robot against an obstacle: MOVING_AWAY turns the wheels (the plant
    backs off), is entered on the supervisor's ``move_away`` from EXECUTING or REPLANNING, and
    ends on the uncontrollable ``moved_away`` (or a blocked way, ``disagree``) in REPLANNING.
    Controllable and non-blocking; ignoring ``moved_away`` breaks controllability, a move that
    ends in another move or one made with the plant stopped breaks the properties that say so."""
    assert "MOVING_AWAY" in SUPERVISOR.wheels and "MOVING_AWAY" not in SUPERVISOR.terminal
    assert "move_away" in SUPERVISOR.controllable and "moved_away" in SUPERVISOR.uncontrollable
    for s in ("EXECUTING", "REPLANNING"):
        assert SUPERVISOR.target(s, "move_away") == "MOVING_AWAY"
    assert SUPERVISOR.target("MOVING_AWAY", "moved_away") == "REPLANNING"
    assert controllability(SUPERVISOR, PLANT).ok and nonblocking(SUPERVISOR, PLANT).ok
    r = controllability(SUPERVISOR.with_transition("MOVING_AWAY", "moved_away", None), PLANT)
    assert not r.ok and "MOVING_AWAY disables uncontrollable 'moved_away'" in str(r)
    stuck = SUPERVISOR.with_transition("MOVING_AWAY", "moved_away", "EXECUTING")
    assert _verdicts(stuck)["moving_away_then_replans"][0] is False
    from clomp.formal.control import MachineTransition
    from dataclasses import replace

    still = replace(PLANT, transitions=tuple(t if (t.source, t.event) != ("STOPPED", "move_away")
                                             else MachineTransition("STOPPED", "move_away", "STOPPED")
                                             for t in PLANT.transitions))
    assert {r.spec.name: r.passed for r in check_machine(SUPERVISOR, still)}["moving_away_only_backing_off"] is False
