"""Robot backends behind the :class:`runtime.robot.Robot` interface.

- :mod:`.sim` — the simulated robot (pymunk world, noisy LiDAR and wheels);
- :mod:`.hardware` — the real robot over serial ports (RPLIDAR A1 + Pololu Maestro);
- :mod:`.emulated` — the device emulators wired to a simulated robot (hardware stack, no hardware);
- :mod:`.faults` — a wrapper that injects faults into any backend.

May import: formal, planner, :mod:`runtime.robot`, :mod:`runtime.clock`, :mod:`runtime.devices`,
:mod:`runtime.records`; never :mod:`runtime.supervision` (a test checks it).
Import the modules themselves (``from runtime.robots.sim import SimRobot``) or the
lazy names of :mod:`runtime`.
"""

__all__: list[str] = []
