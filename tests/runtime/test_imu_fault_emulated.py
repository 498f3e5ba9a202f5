"""``clomp emulate world --imu-fault KIND --imu-fault-at T`` (issue #36): the world's IMU fails
at T s of world time, as a user would make it fail mid-run. The stream is decoded here in
simulated time (a manual clock; the world's IMU ticked every 10 ms): the fault shows at the
asked time and not before. The run that meets it over ptys is test_imu_fault_pty.py's; the
same faults in simulated time through the whole stack are test_imu_stack_simtime.py's."""

from __future__ import annotations

import math

import pytest

from clomp.runtime import cli
from clomp.runtime.backends.imu_fault import ImuFault, fault_summary
from clomp.runtime.backends.emulated import EmulatedWorld
from clomp.runtime.clock import ManualClock
from clomp.runtime.devices.bno08x_codec import RvcDecoder

AT = 1.0  # world s
PERIOD = 0.01  # one report


def _stream(kind: str, seconds: float = 2.0, **fault: float) -> tuple[EmulatedWorld, list[tuple[float, float, float]], RvcDecoder]:
    """The world's IMU stream decoded: (world time of the tick it came in, reported yaw since the
    start, true heading turned since the start) per report; the world turns gently from t = 0."""
    clock = ManualClock(0.0)
    world = EmulatedWorld("overtaking", noise="ideal", seed=0, clock=clock, imu_fault=ImuFault(kind, at=AT, **fault))
    imu, decoder = world.imu, RvcDecoder()
    imu._tick(clock.now())  # the device's start (its reset: yaw 0)
    start = world.sim.pose.theta
    world._on_speeds(0.2, 0.4)  # the wheels commanded: the world's time runs from now
    out: list[tuple[float, float, float]] = []
    while clock.now() < seconds - 1e-9:
        clock.advance(PERIOD)
        imu._tick(clock.now())
        t, truth = world.sim.now(), world.sim.pose.theta - start  # the body's, not what the IMU was told
        data, imu._out[:] = bytes(imu._out), b""
        out += [(t, r.yaw, truth) for r in decoder.feed(data)]
        if imu._vanish.is_set():
            break
    return world, out, decoder


def _wrapped(a: float) -> float:
    return math.remainder(a, math.tau)


def test_before_its_time_the_stream_is_the_world_s_heading() -> None:
    world, reports, decoder = _stream("wrong-yaw", seconds=AT - 0.05)
    assert len(reports) >= 90 and decoder.dropped_bytes == 0
    assert max(abs(_wrapped(yaw - truth)) for _, yaw, truth in reports) < 0.01
    assert reports[-1][2] > 0.05  # the world turned: the reports follow it
    assert world.imu_fault is not None and not world.imu_fault.applied


def test_silent_the_reports_stop_at_the_asked_time() -> None:
    world, reports, _ = _stream("silent")
    last = reports[-1][0]
    assert AT - PERIOD - 1e-9 <= last < AT, last  # none made at or after it
    assert world.imu.silent and world.imu_fault is not None
    assert world.imu_fault.world_time == pytest.approx(AT, abs=PERIOD)


def test_garbage_replaces_the_reports_at_the_asked_time() -> None:
    world, reports, decoder = _stream("garbage")
    assert AT - PERIOD - 1e-9 <= reports[-1][0] < AT
    assert decoder.dropped_bytes >= 0.9 * (2.0 - AT) / PERIOD * 19  # a report's worth of bytes, no report
    assert world.imu.garbage_only


def test_unplug_closes_the_port_at_the_asked_time() -> None:
    world, reports, _ = _stream("unplug")
    assert world.imu._vanish.is_set()
    assert AT - PERIOD - 1e-9 <= reports[-1][0] < AT
    assert world.sim.now() == pytest.approx(AT, abs=PERIOD)  # the stream loop ended on it


def test_wrong_yaw_jumps_by_the_asked_angle_and_stays_off() -> None:
    _, reports, _ = _stream("wrong-yaw", jump=math.radians(90.0))
    before = [_wrapped(y - tr) for t, y, tr in reports if t < AT - 1e-9]
    after = [_wrapped(y - tr) for t, y, tr in reports if t >= AT + PERIOD]
    assert before and max(map(abs, before)) < 0.01
    assert len(after) >= 90 and all(abs(d - math.pi / 2) < 0.01 for d in after), after[:3]


def test_spin_turns_the_yaw_while_the_body_does_not() -> None:
    rate = math.radians(30.0)
    _, reports, _ = _stream("spin", spin=rate)
    for t, yaw, truth in reports:
        want = rate * max(0.0, t - AT)
        assert abs(_wrapped(yaw - truth - want)) < PERIOD * rate + 0.01, (t, yaw - truth, want)
    assert reports[-1][0] > AT + 0.9


def test_the_summary_says_when_the_fault_never_came() -> None:
    world, _, _ = _stream("silent", seconds=0.5)
    assert "never came" in fault_summary(world)
    assert fault_summary(EmulatedWorld("open")) == ""


@pytest.mark.parametrize("argv, said", [
    (["--imu-fault", "melt"], "invalid choice"),
    (["--imu-fault", "silent", "--imu-fault-at", "-1"], "--imu-fault"),
    (["--imu-fault", "wrong-yaw", "--imu-yaw-jump", "inf"], "--imu-fault"),
])
def test_a_bad_fault_option_is_a_usage_error(argv: list[str], said: str, capsys: pytest.CaptureFixture[str]) -> None:
    try:
        rc = cli.main(["emulate", "world", *argv])
    except SystemExit as exc:  # argparse's own refusal
        rc = exc.code
    assert rc == 2
    assert said in capsys.readouterr().err


def test_a_fault_is_one_of_the_named_kinds() -> None:
    with pytest.raises(ValueError, match="known: silent, unplug, garbage, wrong-yaw, spin"):
        ImuFault("melt", at=1.0)
