"""The units of a scan: the planner works in metres; a scan in millimetres is recognised.

A LiDAR's returns lie beyond the planning horizon all the time (an RPLIDAR A1 returns to
12 m, the paper's horizon is 1.1 m): perception crops them without a word. What is *not*
normal is a scan whose returns are mostly beyond :data:`MOSTLY_BEYOND_M` (20 m) or whose
median range is above :data:`MEDIAN_ABOVE_M` (50 m): indoors that is a scan written in
millimetres, which would otherwise be cropped to nothing and planned through.
:func:`in_metres` refuses such a scan unless its units are given (``--units m|mm`` on the
command line); :func:`millimetres_suspected` says why it looks so.
"""

from __future__ import annotations

import numpy as np

from clomp.planner.scanfile import ScanError

__all__ = ["MEDIAN_ABOVE_M", "MOSTLY_BEYOND_M", "UNITS", "ScanUnitsError", "in_metres", "millimetres_suspected"]

#: the units a scan may be given in, and how many of each make a metre
UNITS: dict[str, float] = {"m": 1.0, "mm": 1000.0}
#: a scan with more than half of its returns beyond this (m) looks like millimetres
MOSTLY_BEYOND_M = 20.0
#: a scan whose median range is above this (m) looks like millimetres
MEDIAN_ABOVE_M = 50.0


class ScanUnitsError(ScanError):
    """A scan that looks like millimetres, read without its units (exit 2 on the command line).

    >>> issubclass(ScanUnitsError, ScanError)
    True
    """


def millimetres_suspected(points: np.ndarray) -> str | None:
    """Why ``points`` (N×2, as read) look like millimetres, or None when they look like metres.

    >>> millimetres_suspected(np.array([[500.0, 0.0], [0.0, 1200.0], [0.3, 0.0]]))
    '2 of 3 returns lie beyond 20 m, median range 500 m'
    >>> millimetres_suspected(np.array([[0.5, 0.0], [11.0, 0.0]])) is None   # an A1 sees 12 m
    True
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 2)
    if not len(pts):
        return None
    r = np.hypot(pts[:, 0], pts[:, 1])
    far = int(np.count_nonzero(r > MOSTLY_BEYOND_M))
    median = float(np.median(r))
    if far * 2 > len(r) or median > MEDIAN_ABOVE_M:
        return f"{far} of {len(r)} returns lie beyond {MOSTLY_BEYOND_M:g} m, median range {median:.4g} m"
    return None


def in_metres(points: np.ndarray, units: str | None = None) -> np.ndarray:
    """``points`` in metres: divided by 1000 for ``units="mm"``, as they are for ``"m"``; with
    ``units`` None, as they are unless they look like millimetres (:func:`millimetres_suspected`):
    then :class:`ScanUnitsError` with the hint.

    Dividing (not multiplying by 0.001) keeps a scan written in whole millimetres bit-equal to
    the same scan written in metres: both are the correctly rounded value.

    >>> in_metres(np.array([[1230.0, -40.0]]), "mm").tolist()
    [[1.23, -0.04]]
    >>> in_metres(np.array([[1230.0, -40.0], [900.0, 0.0]]))
    Traceback (most recent call last):
    clomp.planner.units.ScanUnitsError: looks like millimetres (2 of 2 returns lie beyond 20 m, median range 1065 m); pass --units mm (or --units m if it is in metres)
    """
    if units is not None and units not in UNITS:
        raise ValueError(f"units must be one of {', '.join(UNITS)}, got {units!r}")
    if units is None:
        why = millimetres_suspected(points)
        if why is not None:
            raise ScanUnitsError(f"looks like millimetres ({why}); pass --units mm (or --units m if it is in metres)")
        return points
    scale = UNITS[units]
    return points if scale == 1.0 else np.asarray(points, dtype=np.float64) / scale
