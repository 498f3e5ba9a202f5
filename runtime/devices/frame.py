"""The unit a LiDAR delivers: one revolution of points with its timestamp.

It lives with the devices so that a device driver stands alone (it needs nothing of the
robots or the supervisor); :mod:`clomp.runtime.interface` re-exports it for backends.

>>> import numpy as np
>>> f = ScanFrame(np.zeros((3, 2)), timestamp=1.5)
>>> f.points.shape, f.timestamp, f.quality
((3, 2), 1.5, None)
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

__all__ = ["ScanFrame"]


@dataclass(frozen=True)
class ScanFrame:
    """One LiDAR revolution: N×2 points (metres, robot frame) and when it was taken.

    ``timestamp`` is in the backend's clock (seconds, monotonic). ``quality`` is the
    per-point return strength when the sensor reports one. ``point_times`` is, when the
    backend knows it, when each point was measured, in seconds relative to ``timestamp``
    (<= 0): a revolution taken while moving can then be de-skewed.

    >>> ScanFrame(np.array([[0.5, 0.0]]), timestamp=2.0).points.tolist()
    [[0.5, 0.0]]
    """

    points: np.ndarray
    timestamp: float
    quality: np.ndarray | None = field(default=None)
    point_times: np.ndarray | None = field(default=None)
