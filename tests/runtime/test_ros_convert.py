"""ROS message conversions (runtime/ros/convert.py) and the ``clomp ros`` command line, without
rclpy: messages are stand-ins with the same fields. (With rclpy: test_ros_node.py.)"""

from __future__ import annotations

import math
from types import SimpleNamespace as M
from typing import Any

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from clomp.runtime.cli import main
from clomp.runtime.ros.convert import (
    MessageError,
    imu_yaw,
    laserscan_to_points,
    odometry_pose,
    points_to_laserscan,
    scan_point_times,
    twist_from_wheels,
    wheels_from_twist,
    yaw_quaternion,
)
from clomp.runtime.ros.robot import RosRobotConfig


def scan(angle_min: float, inc: float, ranges: list[float], range_min: float = 0.05, range_max: float = 10.0,
         time_increment: float = 0.0) -> Any:
    return M(angle_min=angle_min, angle_max=angle_min + inc * (len(ranges) - 1), angle_increment=inc,
             ranges=ranges, range_min=range_min, range_max=range_max, time_increment=time_increment, scan_time=0.1)


def odom(x: float, y: float, theta: float, frame: str = "odom", child: str = "base_link") -> Any:
    qx, qy, qz, qw = yaw_quaternion(theta)
    return M(header=M(frame_id=frame), child_frame_id=child,
             pose=M(pose=M(position=M(x=x, y=y), orientation=M(x=qx, y=qy, z=qz, w=qw))))


def test_a_scan_in_either_direction_gives_the_same_points() -> None:
    a = np.linspace(-2.0, 2.0, 681)
    r = 1.0 + 0.5 * np.sin(3 * a)
    ccw = laserscan_to_points(scan(-2.0, 4.0 / 680, r.tolist()))
    cw = laserscan_to_points(scan(2.0, -4.0 / 680, r[::-1].tolist()))
    assert len(ccw) == 681 and np.allclose(ccw, cw[::-1])
    assert np.allclose(ccw[340], [1.0, 0.0])  # the middle beam looks ahead


def test_no_return_nan_inf_and_out_of_range_readings() -> None:
    pts = laserscan_to_points(scan(0.0, math.pi / 2, [1.0, math.nan, math.inf, 0.01, 20.0], 0.05, 10.0))
    assert pts.round(6).tolist() == [[1.0, 0.0]]


def test_the_lidar_offset_moves_the_points_to_the_base() -> None:
    pts = laserscan_to_points(scan(0.0, math.pi / 2, [1.0, 2.0]), offset=(0.1, -0.05, math.pi / 2))
    assert pts.round(6).tolist() == [[0.1, 0.95], [-1.9, -0.05]]


@pytest.mark.parametrize("msg, why", [
    (scan(0.0, 0.0, [1.0, 1.0]), "angle_increment is 0"),
    (M(**{**vars(scan(0.0, 0.1, [1.0] * 10)), "ranges": [1.0] * 4}), "has 4 ranges but its angles"),
    (M(**{**vars(scan(0.0, 0.1, [1.0] * 10)), "angle_min": math.nan}), "angles must be finite"),
    (M(**{**vars(scan(0.0, 0.1, [1.0] * 10)), "angle_increment": -0.1}), "points away from angle_max"),
], ids=["increment-0", "length", "nan-angle", "wrong-sign"])
def test_a_scan_that_makes_no_sense_is_a_specific_error(msg: Any, why: str) -> None:
    with pytest.raises(MessageError, match=why):
        laserscan_to_points(msg)


def test_point_times_end_at_the_last_reading() -> None:
    t = scan_point_times(scan(0.0, 0.1, [1.0, math.inf, 1.0, 1.0], time_increment=0.01))
    assert t is not None and np.allclose(t, [-0.03, -0.01, 0.0])
    assert scan_point_times(scan(0.0, 0.1, [1.0, 1.0])) is None


def test_the_sim_s_scan_reads_back_as_its_points() -> None:
    a = np.arange(360) * (2 * math.pi / 360)
    pts = np.c_[0.8 * np.cos(a), 0.8 * np.sin(a)][::3]
    a0, a1, inc, ranges = points_to_laserscan(pts, 360, 1.1)
    back = laserscan_to_points(M(angle_min=a0, angle_max=a1, angle_increment=inc, ranges=ranges,
                                 range_min=0.01, range_max=1.1))
    assert np.allclose(back, pts, atol=1e-6)


def test_odometry_pose_frame_and_garbage() -> None:
    p = odometry_pose(odom(1.0, 2.0, 0.5), "odom", "base_link")
    assert (round(p.x, 9), round(p.y, 9), round(p.theta, 9)) == (1.0, 2.0, 0.5)
    with pytest.raises(MessageError, match="Odometry in frame 'map', expected 'odom'"):
        odometry_pose(odom(0, 0, 0, frame="map"), "odom")
    with pytest.raises(MessageError, match="child frame 'wheel'"):
        odometry_pose(odom(0, 0, 0, child="wheel"), "odom", "base_link")
    with pytest.raises(MessageError, match="not finite"):
        odometry_pose(odom(math.nan, 0, 0))


def test_an_imu_without_orientation_has_no_heading() -> None:
    q = yaw_quaternion(1.0)
    with_q = M(orientation=M(x=q[0], y=q[1], z=q[2], w=q[3]), orientation_covariance=[0.0] * 9)
    assert imu_yaw(with_q) == pytest.approx(1.0)
    assert imu_yaw(M(orientation=with_q.orientation, orientation_covariance=[-1.0] + [0.0] * 8)) is None


@given(st.floats(-0.2, 0.2), st.floats(-0.2, 0.2))
def test_wheels_and_twist_are_inverse(left: float, right: float) -> None:
    v, w = twist_from_wheels(left, right, 0.15)
    assert np.allclose(wheels_from_twist(v, w, 0.15), (left, right), atol=1e-12)


def test_robot_config_refuses_nonsense() -> None:
    with pytest.raises(ValueError, match="sensor_timeout"):
        RosRobotConfig(sensor_timeout=0.0)
    with pytest.raises(ValueError, match="lidar_offset"):
        RosRobotConfig(lidar_offset=(0.0, math.nan, 0.0))


def test_without_rclpy_the_commands_say_how_to_install_it(monkeypatch: pytest.MonkeyPatch,
                                                          capsys: pytest.CaptureFixture[str]) -> None:
    import clomp.runtime.ros.session as session

    monkeypatch.setattr(session, "ros_missing", lambda: "ROS 2 (rclpy) is not installed: pip install 'clomp[ros2]'")
    for argv in (["ros", "node", "--goal", "1,0"], ["ros", "sim"]):
        assert main(argv) == 2
        assert "clomp: error: ROS 2 (rclpy) is not installed: pip install 'clomp[ros2]'" in capsys.readouterr().err


@pytest.mark.parametrize("param, why", [
    ("no_such:=1", "expected NAME:=VALUE with NAME one of body_length"),
    ("max_states:=many", "max_states takes a value like 50"),
    ("body_length=0.3", "expected NAME:=VALUE"),
])
def test_parameters_are_named_and_typed(param: str, why: str, capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["ros", "node", "--goal", "1,0", "-p", param]) == 2
    assert why in capsys.readouterr().err


def test_parameter_values_take_the_default_s_type() -> None:
    from clomp.runtime.cli.ros import parse_parameter
    from clomp.runtime.ros.node import PARAMETERS

    assert parse_parameter("use_odom:=false", PARAMETERS) == ("use_odom", False)
    assert parse_parameter("max_speed:=1", PARAMETERS) == ("max_speed", 1.0)
    assert parse_parameter("odom_frame:=odom_combined", PARAMETERS) == ("odom_frame", "odom_combined")
