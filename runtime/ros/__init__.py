"""clomp on ROS 2: the supervisor on ROS topics (``clomp ros node``) and the execution
world as a ROS robot (``clomp ros sim``). Needs ``pip install 'clomp[ros2]'`` (rclpy and
the message packages); importing these modules does not: rclpy is imported when a node
is made.

Only :mod:`clomp.runtime.cli` imports this package (tests/test_architecture_ros.py).
"""

from clomp.runtime.ros.convert import MessageError
from clomp.runtime.ros.robot import RosRobot, RosRobotConfig
from clomp.runtime.ros.session import RosSession, ros_missing

__all__ = ["MessageError", "RosRobot", "RosRobotConfig", "RosSession", "ros_missing"]
