"""Robot backends behind the :class:`clomp.runtime.interface.Robot` interface.

- :mod:`.world` — the execution world: the ground truth simulated runs execute in,
  independent of the planner's model (:func:`make_world_robot`);
- :mod:`.sim` — the simulated robot (pymunk world, noisy LiDAR and wheels);
- :mod:`.hardware` — the real robot over serial ports (RPLIDAR A1 + Pololu Maestro);
- :mod:`.emulated` — the device emulators wired to a simulated robot (hardware stack, no hardware);
- :mod:`.faults` — a wrapper that injects faults into any backend;
- :mod:`.imu_fault` — a named IMU fault at a moment of an emulated world's time (``emulate world --imu-fault``).

May import: formal, planner, :mod:`clomp.runtime.interface`, :mod:`clomp.runtime.clock`, :mod:`clomp.runtime.devices`,
:mod:`clomp.runtime.records`; never :mod:`clomp.runtime.supervision` (a test checks it).
Import the modules themselves (``from clomp.runtime.backends.sim import SimRobot``) or the
lazy names of :mod:`clomp.runtime`.
"""

from __future__ import annotations

from typing import Any

__all__ = ["make_world_robot"]


def make_world_robot(*args: Any, **kwargs: Any) -> Any:
    """The execution world for a scene; see :func:`clomp.runtime.backends.world.make_world_robot`."""
    from clomp.runtime.backends.world import make_world_robot as make

    return make(*args, **kwargs)
