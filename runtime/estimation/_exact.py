"""Cheaper, bit-identical stand-ins for numpy calls the estimator makes every revolution.

``np.median``, ``np.roll`` and ``np.unwrap`` are general (any axis, any shape, masked arrays, out=)
and spend tens of microseconds in Python on the small 1-d arrays a revolution gives
them; these do the same arithmetic on exactly that case. The tests in
``tests/runtime/test_exact_kernels.py`` hold each to its numpy reference, bit for bit.

>>> import numpy as np
>>> median(np.array([3.0, 1.0, 2.0, 10.0])) == float(np.median([3.0, 1.0, 2.0, 10.0]))
True
>>> ring_neighbours(np.array([True, False, False]), 1)[0].tolist()   # np.roll(a, 1)
[False, True, False]
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

_gufuncs: Any
try:  # the gufuncs behind np.linalg.eigh / eigvalsh (numpy >= 1.8; private, so checked)
    from numpy.linalg import _umath_linalg as _gufuncs
except ImportError:  # pragma: no cover - a numpy without them: numpy's own functions
    _gufuncs = None

__all__ = ["eigh", "eigvalsh", "mean", "mean_rows", "median", "nanmedian_columns", "ring_neighbours", "unwrap"]


def median(values: np.ndarray) -> float:
    """``float(np.median(values))`` of a 1-d float array: the middle value, or the two
    middle ones' mean (summed from +0.0 and halved, as ``np.mean`` computes it); NaN when
    any is NaN or there are none (numpy also warns then).

    >>> median(np.array([2.0, 1.0])), median(np.array([1.0, np.nan]))
    (1.5, nan)
    """
    v = np.asarray(values, dtype=float).reshape(-1)
    n = len(v)
    if n == 0 or bool(np.isnan(v).any()):
        return math.nan
    h = n // 2
    # numpy's mean sums from +0.0 (so a median of -0.0 is 0.0), then divides by the count
    if n % 2:
        return float(0.0 + np.partition(v, h)[h])
    part = np.partition(v, (h - 1, h))
    return float((0.0 + part[h - 1] + part[h]) / 2)


def _plain_square(a: np.ndarray) -> bool:
    """Whether ``a`` is a finite, non-empty, square float64 matrix (the case the gufuncs are called on directly)."""
    return (_gufuncs is not None and isinstance(a, np.ndarray) and a.dtype == np.float64 and a.ndim == 2
            and a.shape[0] == a.shape[1] and a.shape[0] > 0 and bool(np.isfinite(a).all()))


def eigh(a: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``np.linalg.eigh(a)`` (its lower triangle), bit for bit: on a finite float64 square
    matrix its gufunc directly (the wrapper's checks and error state cost three times the
    2×2 or 3×3 decomposition the estimator asks for each revolution); numpy's own otherwise
    (other dtypes, stacks, NaN: its errors and warnings as before).

    >>> w, v = eigh(np.array([[2.0, 0.0], [0.0, 1.0]]))
    >>> w.tolist(), np.abs(v).tolist()
    ([1.0, 2.0], [[0.0, 1.0], [1.0, 0.0]])
    """
    if not _plain_square(a):
        w, v = np.linalg.eigh(a)
        return w, v
    w, v = _gufuncs.eigh_lo(a, signature="d->dd")
    return w, v


def eigvalsh(a: np.ndarray) -> np.ndarray:
    """``np.linalg.eigvalsh(a)`` (lower triangle), bit for bit, as :func:`eigh` calls its gufunc.

    >>> eigvalsh(np.array([[2.0, 1.0], [1.0, 2.0]])).tolist()
    [1.0, 3.0]
    """
    if not _plain_square(a):
        return np.asarray(np.linalg.eigvalsh(a))
    w: np.ndarray = _gufuncs.eigvalsh_lo(a, signature="d->d")
    return w


def mean(values: np.ndarray) -> float:
    """``float(np.mean(values))`` of a non-empty 1-d float64 array, bit for bit: its sum
    (numpy's own pairwise reduction) over its count, without ``np.mean``'s Python wrapper.

    >>> mean(np.array([1.0, 2.0, 4.0]))
    2.3333333333333335
    """
    if values.dtype != np.float64 or values.ndim != 1 or not len(values):
        return float(np.mean(values))
    return float(np.add.reduce(values, axis=None) / len(values))


def mean_rows(points: np.ndarray) -> np.ndarray:
    """``points.mean(axis=0)`` of a non-empty 2-d float64 array, bit for bit: the sum along the
    rows divided by their count, without ``np.mean``'s Python wrapper.

    >>> mean_rows(np.array([[0.0, 1.0], [1.0, 2.0]])).tolist()
    [0.5, 1.5]
    """
    if points.dtype != np.float64 or points.ndim != 2 or not len(points):
        return np.asarray(points.mean(axis=0))
    out: np.ndarray = np.add.reduce(points, axis=0) / len(points)
    return out


def nanmedian_columns(values: np.ndarray) -> np.ndarray:
    """``np.nanmedian(values, axis=0)`` of a 2-d float array (each column's median over its
    non-NaN values; NaN for a column of NaNs, without numpy's warning), bit for bit: the
    middle value, or the two middle ones summed from +0.0 and halved, as numpy's masked
    median does (an odd count's middle value summed twice).
    numpy's own for an array holding infinities (their order among masked values is its).

    >>> nanmedian_columns(np.array([[1.0, np.nan], [4.0, 2.0], [2.0, np.nan], [3.0, np.nan]])).tolist()
    [2.5, 2.0]
    """
    v = np.asarray(values, dtype=float)
    if v.ndim != 2 or not v.shape[0] or bool(np.isinf(v).any()):
        return np.asarray(np.nanmedian(v, axis=0), dtype=float)
    srt = np.sort(v, axis=0)  # NaN last, where the masked median sorts its masked values
    counts = v.shape[0] - np.count_nonzero(np.isnan(v), axis=0)
    h = np.minimum(counts // 2, v.shape[0] - 1)
    lo = np.where(counts % 2 == 1, h, np.maximum(h - 1, 0))
    cols = np.arange(v.shape[1])
    out: np.ndarray = (0.0 + srt[lo, cols] + srt[h, cols]) / 2.0  # numpy's masked sum starts from +0.0
    out[counts == 0] = math.nan
    return out


def ring_neighbours(a: np.ndarray, reach: int) -> list[np.ndarray]:
    """The 1-d array ``a`` shifted round a ring by 1, -1, 2, -2, … up to ``reach``: element
    for element ``[np.roll(a, 1), np.roll(a, -1), np.roll(a, 2), …]``, as views of one padded copy
    (``np.roll`` itself where ``reach`` exceeds the length).

    >>> [s.tolist() for s in ring_neighbours(np.array([1, 2, 3, 4]), 2)]
    [[4, 1, 2, 3], [2, 3, 4, 1], [3, 4, 1, 2], [3, 4, 1, 2]]
    """
    n = len(a)
    if reach < 0:
        raise ValueError(f"reach must be >= 0, got {reach}")
    if reach > n:  # shifts that wrap more than once (or an empty array): numpy's own
        return [np.roll(a, s) for k in range(1, reach + 1) for s in (k, -k)]
    ext = np.concatenate((a[n - reach:], a, a[:reach]))
    out: list[np.ndarray] = []
    for k in range(1, reach + 1):
        out.append(ext[reach - k:reach - k + n])  # np.roll(a, k)[i] = a[i - k]
        out.append(ext[reach + k:reach + k + n])  # np.roll(a, -k)[i] = a[i + k]
    return out


def unwrap(angles: np.ndarray) -> np.ndarray:
    """``np.unwrap(angles)`` of a 1-d float array. Where no step reaches half a turn (a
    heading history sampled every few milliseconds) numpy adds a zero correction to every
    element after the first, which is all this does (``+ 0.0`` turns a -0.0 into 0.0, as
    numpy's does); any other array goes to ``np.unwrap`` itself.

    >>> unwrap(np.array([3.0, -3.0])).round(4).tolist(), unwrap(np.array([0.1, 0.2])).tolist()
    ([3.0, 3.2832], [0.1, 0.2])
    """
    p = np.asarray(angles, dtype=float)
    if p.ndim == 1 and bool((np.abs(p[1:] - p[:-1]) < math.pi).all()):
        up = p.copy()
        up[1:] = p[1:] + 0.0
        return up
    out: np.ndarray = np.unwrap(p)
    return out
