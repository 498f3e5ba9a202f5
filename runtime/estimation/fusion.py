"""Revolutions taken from one standing pose fused into one: median range per bearing.

A robot that stops to plan sees the same scene several times. :func:`fuse_revolutions`
bins every revolution's points by bearing, takes each revolution's mean range per bin
and then the median over the revolutions, keeping bins that at least ``min_support``
revolutions saw. Range noise shrinks, a dropout leaves no hole and a lone outlier
(a ray that hit nothing one revolution and a wall the next) disappears.

>>> import numpy as np
>>> wall = np.c_[np.full(5, 0.5), np.linspace(-0.1, 0.1, 5)]
>>> noisy = [wall + [d, 0.0] for d in (0.02, -0.01, 0.0)]
>>> fused = fuse_revolutions(noisy, bin_deg=2.0)
>>> bool(np.all(np.abs(fused[:, 0] - 0.5) < 0.005)), len(fused)
(True, 5)

:func:`range_spread` reads the sensor's range noise off the same revolutions: what one
bearing's range does from one revolution to the next, while nothing moved, is the noise.

>>> rng = np.random.default_rng(0)
>>> ring = [np.c_[np.cos(a), np.sin(a)] * (1.0 + rng.normal(0, 0.02, a.size))[:, None]
...         for a in [np.radians(np.arange(0.0, 360.0, 1.0))] * 4]
>>> round(range_spread(ring), 2)                    # 2 cm of range noise, measured
0.02
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from clomp.formal.geometry import polar_to_xy
from clomp.runtime.estimation._exact import nanmedian_columns

__all__ = ["bin_ranges", "fuse_revolutions", "range_spread"]


def bin_ranges(clouds: Sequence[np.ndarray], bin_deg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Each revolution's mean range per bearing bin of ``bin_deg`` degrees (NaN where it saw
    nothing), and the summed sines and cosines of the bearings per bin: what
    :func:`fuse_revolutions`, :func:`range_spread` and
    :func:`~clomp.runtime.estimation.standing.moved_standing` compare revolutions by.

    >>> import numpy as np
    >>> near, far = np.array([[0.5, 0.0], [0.0, 1.0]]), np.array([[0.6, 0.0]])
    >>> ranges, _, _ = bin_ranges([near, far], 90.0)      # four bins: ahead, left, behind, right
    >>> ranges.round(2).tolist()
    [[0.5, 1.0, nan, nan], [0.6, nan, nan, nan]]
    """
    nbins = int(math.ceil(360.0 / bin_deg))
    ranges = np.full((len(clouds), nbins), np.nan)
    sin_sum = np.zeros(nbins)
    cos_sum = np.zeros(nbins)
    for k, pts in enumerate(clouds):
        if len(pts) == 0:
            continue
        a = np.arctan2(pts[:, 1], pts[:, 0])
        r = np.hypot(pts[:, 0], pts[:, 1])
        b = np.minimum((np.mod(a, 2 * math.pi) / math.radians(bin_deg)).astype(int), nbins - 1)
        n = np.bincount(b, minlength=nbins)
        s = np.bincount(b, weights=r, minlength=nbins)
        seen = n > 0
        ranges[k, seen] = s[seen] / n[seen]
        sin_sum += np.bincount(b, weights=np.sin(a), minlength=nbins)
        cos_sum += np.bincount(b, weights=np.cos(a), minlength=nbins)
    return ranges, sin_sum, cos_sum


def range_spread(scans: Sequence[np.ndarray], bin_deg: float = 0.5, min_pairs: int = 20) -> float | None:
    """The standard deviation (m) of one range reading, from revolutions taken at one pose.

    Each bearing bin's range in consecutive revolutions differs by the noise of two readings:
    sigma = 1.4826 * median(|difference|) / sqrt(2) — the median, so that a bin at an
    object's edge, which sees the object one revolution and the wall behind it the next,
    does not count as noise. None with fewer than ``min_pairs`` such differences (one
    revolution, or a scene with almost no returns).
    """
    clouds = [np.asarray(s, dtype=float).reshape(-1, 2) for s in scans]
    if len(clouds) < 2:
        return None
    ranges, _, _ = bin_ranges(clouds, bin_deg)
    diff = np.diff(ranges, axis=0)
    diff = diff[np.isfinite(diff)]
    if len(diff) < min_pairs:
        return None
    return float(1.4826 * np.median(np.abs(diff)) / math.sqrt(2.0))


def fuse_revolutions(scans: Sequence[np.ndarray], bin_deg: float = 0.5, min_support: int = 2) -> np.ndarray:
    """One N×2 scan from several taken at the same pose (robot frame); see the module.

    With fewer revolutions than ``min_support`` the newest is returned unchanged.
    """
    clouds = [np.asarray(s, dtype=float).reshape(-1, 2) for s in scans]
    if len(clouds) < max(2, min_support):
        return clouds[-1] if clouds else np.zeros((0, 2))
    ranges, sin_sum, cos_sum = bin_ranges(clouds, bin_deg)
    support = np.sum(np.isfinite(ranges), axis=0)
    keep = support >= min_support
    if not keep.any():
        return np.zeros((0, 2))
    med = nanmedian_columns(ranges[:, keep])  # np.nanmedian(…, axis=0) bit for bit, without its masked arrays
    ang = np.arctan2(sin_sum[keep], cos_sum[keep])
    return polar_to_xy(med, ang)
