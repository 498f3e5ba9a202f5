"""One ROS 2 node in its own rclpy context, its executor spinning in a background thread.

Each :class:`RosSession` has its own ``rclpy.Context`` (so a test, the sim and the node can
live in one process, and shutting one down leaves the others), takes no signal handlers
(rclpy's own SIGINT handler would shut the context down before the node's last zero
Twist went out; clomp's commands handle Ctrl-C and SIGTERM themselves), and spins in a
daemon thread until :meth:`RosSession.close`.
"""

from __future__ import annotations

import os
import threading
import time
from collections.abc import MutableMapping
from typing import Any

__all__ = ["RosSession", "localhost_only", "ros_missing"]

_INSTALL = "ROS 2 (rclpy) is not installed: pip install 'clomp[ros2]'"


def ros_missing() -> str | None:
    """Why rclpy cannot be used here (one line), None when it can.

    >>> ros_missing() is None or "not installed" in ros_missing()
    True
    """
    try:
        import rclpy  # noqa: F401
        import sensor_msgs.msg  # noqa: F401
        import nav_msgs.msg  # noqa: F401
        import visualization_msgs.msg  # noqa: F401
    except ImportError as exc:
        return f"{_INSTALL} ({exc})"
    return None


def localhost_only(domain_id: int, env: MutableMapping[str, str] | None = None) -> None:
    """Keep ROS 2 traffic on this host: discovery on localhost, data over shared memory,
    a private domain id (0-101), set in ``env`` (default: this process's environment;
    call it before any rclpy context exists).

    >>> env = {}; localhost_only(55, env); sorted(env.items())
    [('FASTDDS_BUILTIN_TRANSPORTS', 'SHM'), ('ROS_AUTOMATIC_DISCOVERY_RANGE', 'LOCALHOST'), ('ROS_DOMAIN_ID', '55')]
    """
    if not 0 <= domain_id <= 101:
        raise ValueError(f"domain id must be 0..101, got {domain_id}")
    target = os.environ if env is None else env
    target["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    target["FASTDDS_BUILTIN_TRANSPORTS"] = "SHM"
    target["ROS_DOMAIN_ID"] = str(domain_id)


class RosSession:
    """A node named ``name`` with ``parameters`` (name → value overrides, declared by the
    caller) in a context of its own; ``args`` are ROS command-line arguments."""

    def __init__(self, name: str, parameters: dict[str, Any] | None = None, args: list[str] | None = None) -> None:
        import rclpy
        from rclpy.executors import SingleThreadedExecutor
        from rclpy.node import Node
        from rclpy.parameter import Parameter
        from rclpy.signals import SignalHandlerOptions

        self.context = rclpy.Context()
        rclpy.init(args=args, context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        overrides = [Parameter(k, value=v) for k, v in (parameters or {}).items()]
        self.node = Node(name, context=self.context, parameter_overrides=overrides)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.error: BaseException | None = None
        self.spin_cpu = 0.0  # CPU seconds of the executor's thread (callbacks, conversions, the watchdog)
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._spin, name=f"ros-{name}", daemon=True)
        self._thread.start()

    def _spin(self) -> None:
        c0 = time.thread_time()
        while not self._stop.is_set() and self.context.ok():
            try:
                self.executor.spin_once(timeout_sec=0.05)
            except Exception as exc:  # a callback that failed: say so, keep spinning (the watchdog must run)
                if self._stop.is_set() or not self.context.ok():
                    break
                if self.error is None:
                    self.error = exc
                    self.node.get_logger().error(f"callback failed: {type(exc).__name__}: {exc}")
            self.spin_cpu = time.thread_time() - c0

    def flush(self, publisher: Any, timeout: float = 0.5) -> None:
        """Wait (at most ``timeout`` s) until the reliable subscribers acknowledged what
        ``publisher`` sent: a last zero Twist must arrive before the context goes."""
        from rclpy.duration import Duration

        try:
            publisher.wait_for_all_acked(Duration(nanoseconds=int(timeout * 1e9)))
        except Exception:  # noqa: BLE001 - best effort: the context may be going already
            pass

    def close(self) -> None:
        """Stop spinning, destroy the node and shut the context down (idempotent)."""
        import rclpy

        if self._stop.is_set():
            return
        self._stop.set()
        self._thread.join(timeout=2.0)
        try:
            self.executor.shutdown(timeout_sec=1.0)
            self.node.destroy_node()
        finally:
            if self.context.ok():
                rclpy.shutdown(context=self.context)

    def __enter__(self) -> "RosSession":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
