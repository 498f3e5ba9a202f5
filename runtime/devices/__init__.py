"""Hardware devices of the runtime: the RPLIDAR A1, the Pololu Maestro and the BNO08x IMU
(heading, UART-RVC mode) over pyserial, and pseudo-terminal emulators of them for tests and
demos without hardware.

Per device: a pure-bytes codec (``rplidar_codec``, ``maestro_codec``, ``bno08x_codec``), a
driver doing the port I/O (``rplidar``, ``maestro``, ``bno08x``) and an emulator
(``rplidar_emulator``, ``maestro_emulator``, ``bno08x_emulator``); :class:`ScanFrame`
(``frame``) is what a LiDAR delivers.
May import: numpy, pyserial and itself only — never the robots, the supervisor or the
planner (a test checks it), so the devices can be used on their own.

Time: every driver and emulator takes ``clock``, a monotonic source (``() -> float``,
seconds; ``time.monotonic`` by default) that its deadlines, timeouts and timestamps read —
the ``now`` of a :class:`clomp.runtime.clock.Clock` is one (``clock=robot_clock.now``), so
a test's manual or simulated time reaches the devices unchanged. A device never lets time
pass by its clock: its waits block on a port or a thread (which only wall time serves), so
it needs ``now`` alone, and no import from above. The waits themselves (a line falling
quiet after STOP, a test helper's ``wait_for``) are on wall time.

>>> from clomp.runtime.devices import ScanDecoder
>>> ScanDecoder().feed(b"") == []
True
"""

from clomp.runtime.devices.bno08x import (
    Bno08xRvc,
    ImuError,
    ImuPortError,
    ImuProtocolError,
    ImuSample,
    ImuTimeout,
    RvcDecoder,
    RvcReport,
)
from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from clomp.runtime.devices.frame import ScanFrame
from clomp.runtime.devices.maestro_emulator import MaestroEmulator
from clomp.runtime.devices.rplidar_emulator import (
    LidarEmulator,
    ScanSource,
    load_scan_file,
    recorded_scan_source,
)
from clomp.runtime.devices.maestro import (
    ErrorFlags,
    Maestro,
    MaestroDeviceError,
    MaestroError,
    MaestroPortError,
    MaestroTimeout,
    WheelConfig,
)
from clomp.runtime.devices.rplidar import (
    DeviceInfo,
    HealthStatus,
    LidarError,
    LidarHealthError,
    LidarPortError,
    LidarProtocolError,
    LidarSampleError,
    LidarTimeout,
    RPLidar,
    ScanDecoder,
)

__all__ = [
    "ScanFrame",
    "RPLidar",
    "ScanDecoder",
    "DeviceInfo",
    "HealthStatus",
    "LidarError",
    "LidarPortError",
    "LidarProtocolError",
    "LidarSampleError",
    "LidarTimeout",
    "LidarHealthError",
    "Maestro",
    "WheelConfig",
    "ErrorFlags",
    "MaestroError",
    "MaestroPortError",
    "MaestroTimeout",
    "MaestroDeviceError",
    "Bno08xRvc",
    "ImuSample",
    "RvcDecoder",
    "RvcReport",
    "ImuError",
    "ImuPortError",
    "ImuProtocolError",
    "ImuTimeout",
    "LidarEmulator",
    "MaestroEmulator",
    "Bno08xEmulator",
    "ScanSource",
    "load_scan_file",
    "recorded_scan_source",
]
