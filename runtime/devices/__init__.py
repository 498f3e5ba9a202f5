"""Hardware devices of the runtime: the RPLIDAR A1 and the Pololu Maestro over pyserial,
and pseudo-terminal emulators of both for tests and demos without hardware."""

from runtime.devices.emulators import (
    LidarEmulator,
    MaestroEmulator,
    ScanSource,
    load_scan_file,
    recorded_scan_source,
)
from runtime.devices.maestro import (
    ErrorFlags,
    Maestro,
    MaestroDeviceError,
    MaestroError,
    MaestroPortError,
    MaestroTimeout,
    WheelConfig,
)
from runtime.devices.rplidar import (
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
    "LidarEmulator",
    "MaestroEmulator",
    "ScanSource",
    "load_scan_file",
    "recorded_scan_source",
]
