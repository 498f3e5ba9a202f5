"""The device emulators in one import: the RPLIDAR A1, the Pololu Maestro and the BNO08x IMU
on pseudo-terminals.

One module per device (:mod:`clomp.runtime.devices.rplidar_emulator`,
:mod:`clomp.runtime.devices.maestro_emulator`, :mod:`clomp.runtime.devices.bno08x_emulator`);
this module gathers them for convenience.

>>> from clomp.runtime.devices.emulators import Bno08xEmulator, LidarEmulator, MaestroEmulator
"""

from clomp.runtime.devices.bno08x_emulator import Bno08xEmulator
from clomp.runtime.devices.maestro_emulator import MaestroEmulator
from clomp.runtime.devices.rplidar_emulator import (
    LidarEmulator,
    ScanSource,
    load_scan_file,
    recorded_scan_source,
    scan_to_samples,
)

__all__ = [
    "Bno08xEmulator",
    "LidarEmulator",
    "MaestroEmulator",
    "ScanSource",
    "load_scan_file",
    "recorded_scan_source",
    "scan_to_samples",
]
