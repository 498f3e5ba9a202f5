"""A world that moves on every runner (issue #42): the hardware drivers run WAIT (both wheels
at neutral while the scans keep coming) and REVERSE (both wheels backwards at the task's
speed) through the real Maestro and LiDAR drivers in simulated time; ``--moving`` and
``--mover`` on the commands."""

from __future__ import annotations

import json

import pytest

import clomp.runtime.cli as cli
from clomp.formal.model import TaskKind
from clomp.planner import Configurator
from clomp.runtime.experiment.layouts import make_layout
from clomp.runtime.supervision import SupervisorConfig
from tests.runtime._stack import NEUTRAL, run_stack

BOX = {"kind": "box", "appear": 4.0, "ahead": 0.05}  # the box appearing 5 cm ahead


def _wheels(events, t0):
    """The two wheels' targets over time: [(t - t0, left, right)] after every change."""
    now = {0: NEUTRAL, 1: NEUTRAL}
    out = []
    for t, ch, target in events:
        if ch in now:
            now[ch] = target or NEUTRAL
            out.append((t - t0, now[0], now[1]))
    return out


@pytest.fixture(scope="module")
def box_run():
    lay = make_layout("appearing", 0, 0)
    return run_stack(lay.scene, noise="paper", seed=0, max_time=90.0, conf=Configurator(recovery=True),
                     supervisor=SupervisorConfig(moving=True), movers=(BOX,))


def test_a_box_appearing_ahead_is_backed_off_and_gone_round_through_the_hardware_stack(box_run):
    run = box_run
    assert run.report is not None and run.report.state.value in ("GOAL_REACHED", "GOAL_UNCONFIRMED"), run.report
    assert run.world.goal_distance <= 0.12 and run.world.collisions == 0, run.world.pose
    kinds = [t.state.task for t in run.report.tasks]
    assert TaskKind.REVERSE in kinds and TaskKind.WAIT in kinds, kinds


def test_a_reverse_turns_both_wheels_backwards_at_the_tasks_speed_on_the_maestro(box_run):
    run = box_run
    t0 = run.supervisor._t0
    wheels = _wheels(run.world.maestro.events, t0)
    full = 0.1 / 0.2 * 100 * 4  # straight_speed / max_speed of the span (100 µs), in quarter-µs: 200
    for rec in (t for t in run.report.tasks if t.state.task is TaskKind.REVERSE):
        during = [(left, right) for t, left, right in wheels if rec.start_time <= t <= rec.end_time]
        # left servo sign +1, right -1 (mirrored): backwards is left below neutral, right above
        back = [(NEUTRAL - left, right - NEUTRAL) for left, right in during if left < NEUTRAL and right > NEUTRAL]
        assert back, during
        assert any(abs((a + b) / 2 - full) <= 0.1 * full for a, b in back), back  # the straight speed, backwards


def test_a_wait_holds_both_wheels_at_neutral_while_the_scans_keep_coming(box_run):
    run = box_run
    t0 = run.supervisor._t0
    wheels = _wheels(run.world.maestro.events, t0)
    waits = [t for t in run.report.tasks if t.state.task is TaskKind.WAIT]
    assert waits
    for rec in waits:
        assert rec.end_time - rec.start_time >= 0.2, (rec.start_time, rec.end_time)
        inside = [(left, right) for t, left, right in wheels if rec.start_time + 0.05 < t < rec.end_time]
        assert all(v == (NEUTRAL, NEUTRAL) for v in inside), inside
        before = [(left, right) for t, left, right in wheels if t <= rec.start_time + 0.05]
        assert before and before[-1] == (NEUTRAL, NEUTRAL)  # stopped as it began


@pytest.fixture(autouse=False)
def commands(monkeypatch):
    mods = list(cli._COMMAND_MODULES)
    for m in ("clomp.runtime.cli.simulate", "clomp.runtime.cli.demo", "clomp.runtime.cli.run", "clomp.runtime.cli.ros",
              "clomp.runtime.cli.emulate"):
        if m not in mods:
            mods.append(m)
    monkeypatch.setattr(cli, "_COMMAND_MODULES", mods)


def test_simulate_runs_a_scenario_files_movers_and_reports_their_contacts_apart(tmp_path, capsys, commands):
    lay = make_layout("shut", 0, 1)
    f = tmp_path / "shut.json"
    f.write_text(json.dumps({**lay.scene.raw, "name": "shut", "movers": [
        {"kind": m.kind, "size": list(m.size), "angle": m.angle, "path": [list(p) for p in m.path]} for m in lay.movers]}))
    code = cli.main(["simulate", "--scenario", str(f), "--json", "--out", str(tmp_path / "out")])
    out = json.loads(capsys.readouterr().out)
    assert code == 1 and out["end_state"] == "UNREACHABLE" and not out["reached_goal"], out
    assert out["moving"] == {"static_collisions": 0, "moving_collisions": 0, "moving_brushes": 0, "robot_caused_collisions": 0}


@pytest.mark.parametrize("argv,message", [
    (["simulate", "--scenario", "open", "--mover", "{"], "--mover: not JSON"),
    (["simulate", "--scenario", "open", "--mover", "[1]"], "--mover: expected a JSON object"),
    (["demo", "--mover", '{"kind": "door", "path": [[0, 1, 0]]}'], "--mover: door: needs a size"),
    (["emulate", "world", "--mover", '{"kind": "cat"}'], "--mover: mover kind must be"),
])
def test_a_bad_mover_is_one_line_and_exit_2(argv, message, capsys, commands, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert cli.main(argv) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1, err


def test_moving_turns_on_wait_and_reverse_in_run_and_the_ros_node(commands):
    from types import SimpleNamespace as M

    from clomp.runtime.cli.plan import configurator_from_args
    from clomp.runtime.cli.ros import _overrides, make_supervisor
    from clomp.runtime.ros.node import configure

    from clomp.planner import load_scenario
    from clomp.runtime.backends.sim import SimRobot

    parser = cli.build_parser()
    args = parser.parse_args(["run", "--lidar", "x", "--goal", "1,0", "--moving"])
    assert args.moving and configurator_from_args(args).recovery
    assert not configurator_from_args(parser.parse_args(["run", "--lidar", "x", "--goal", "1,0"])).recovery
    overrides = _overrides(parser.parse_args(["ros", "node", "--goal", "1,0", "--moving"]))
    assert overrides["moving"] is True
    conf, _, _ = configure(M(declare_parameter=lambda name, value: M(value=overrides.get(name, value))))
    assert conf.recovery
    assert make_supervisor(SimRobot(load_scenario("open"), seed=0), (1.0, 0.0), conf).config.moving


def test_bodies_that_move_need_the_execution_world():
    from clomp.planner import load_scenario
    from clomp.runtime.backends.emulated import EmulatedWorld
    from clomp.runtime.experiment.onerun import run_once

    with pytest.raises(ValueError, match="execution world"):
        EmulatedWorld("open", movers=(BOX,))  # the older simulated robot has no movers
    with pytest.raises(ValueError, match="execution world"):
        run_once(load_scenario("open"), "planning", 0, noise=None, movers=(BOX,))
