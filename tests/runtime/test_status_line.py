"""``clomp run``'s status line: drawn on a terminal only, cleared before the final line."""

from __future__ import annotations

import io
import threading
from types import SimpleNamespace

from clomp.planner import Configurator, load_scenario
from clomp.runtime.backends.sim import SimRobot
from clomp.runtime.cli._status import StatusLine, _snapshot
from clomp.runtime.supervision import Supervisor


def _run(imu_fault: object = None) -> tuple[SimpleNamespace, SimpleNamespace]:
    sup = SimpleNamespace(state=SimpleNamespace(value="EXECUTING"), _task=None,
                          sensing=SimpleNamespace(position_bound=lambda sigmas: None),
                          config=SimpleNamespace(vouch_sigmas=2.45),
                          goal_in_robot_frame=lambda: (0.3, 0.4))
    imu = SimpleNamespace(fault=imu_fault)
    robot = SimpleNamespace(fault=None if imu_fault is None else "IMU on x failed", scans=12, imu=imu)
    return sup, robot


def test_no_status_line_into_a_pipe_or_a_file() -> None:
    stream = io.StringIO()  # not a terminal
    sup, robot = _run()
    with StatusLine(sup, robot, stream=stream, period=0.001) as line:
        assert not line.enabled
        threading.Event().wait(0.02)
    assert stream.getvalue() == ""


def test_the_status_line_says_what_the_run_does_and_is_cleared_at_the_end() -> None:
    stream = io.StringIO()
    sup, robot = _run(imu_fault="silent")
    drawn = threading.Event()
    write = stream.write

    def seen(text: str) -> int:
        if "rev" in text:
            drawn.set()
        return write(text)

    stream.write = seen  # type: ignore[method-assign]
    with StatusLine(sup, robot, stream=stream, period=0.001, enabled=True):
        assert drawn.wait(30.0)
    out = stream.getvalue()
    assert "\rEXECUTING  -  goal 0.50 m  12 rev  lidar ok  imu fault" in out.replace("\x1b[2K", "")
    assert out.endswith("\r\x1b[2K")  # cleared: the final line stands alone


def test_the_status_line_reads_a_real_supervisor() -> None:
    sim = SimRobot(load_scenario("open"), seed=0)
    sup = Supervisor(sim, (1.0, 0.0), Configurator(), clock=sim)
    sup.start()
    robot = SimpleNamespace(fault=None, scans=3, imu=None)
    text = _snapshot(sup, robot)
    assert text.startswith(f"{sup.state.value}  -  goal 1.00 m ± 0.00  3 rev  lidar ok"), text
