"""Statistics of an experiment: 95 % intervals, the paired t-test, McNemar's test.

- :func:`wilson` — the Wilson score interval of a rate (well-behaved at 0/n and n/n,
  where the normal approximation collapses to a point).
- :func:`mean_ci` — a mean with its Student-t 95 % interval.
- :func:`paired_ttest` — the paper's test on collisions per run (planning − reactive).
- :func:`mcnemar` — the exact McNemar test on paired success (only the discordant pairs
  count: runs one condition solved and the other did not).

>>> lo, hi = wilson(10, 10)
>>> round(lo, 3), hi
(0.722, 1.0)
>>> mcnemar([1] * 10, [0] * 10)["p"] < 0.01
True
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

__all__ = ["Z95", "mcnemar", "mean_ci", "paired_ttest", "wilson"]

Z95 = 1.959963984540054
"""The two-sided 95 % normal quantile."""


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """Wilson score interval (lo, hi) of ``successes`` out of ``n``; (0, 1) when n is 0.

    >>> tuple(round(v, 3) for v in wilson(0, 10))
    (0.0, 0.278)
    """
    if n < 0 or successes < 0 or successes > n:
        raise ValueError(f"need 0 <= successes <= n, got {successes} of {n}")
    if n == 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    lo = 0.0 if successes == 0 else max(0.0, centre - half)
    hi = 1.0 if successes == n else min(1.0, centre + half)
    return (lo, hi)


def mean_ci(values: Sequence[float]) -> dict[str, float | None]:
    """``{"mean", "lo", "hi", "sd"}``: the mean and its 95 % Student-t interval (None when empty).

    >>> mean_ci([1.0, 1.0, 1.0])
    {'mean': 1.0, 'lo': 1.0, 'hi': 1.0, 'sd': 0.0}
    """
    if len(values) == 0:
        return {"mean": None, "lo": None, "hi": None, "sd": None}
    a = np.asarray(values, float)
    m = float(a.mean())
    if len(a) < 2:
        return {"mean": m, "lo": None, "hi": None, "sd": None}
    from scipy.stats import t

    sd = float(a.std(ddof=1))
    half = float(t.ppf(0.975, len(a) - 1)) * sd / math.sqrt(len(a))
    return {"mean": m, "lo": m - half, "hi": m + half, "sd": sd}


def paired_ttest(a: Sequence[float], b: Sequence[float]) -> dict[str, Any]:
    """Paired t-test (``scipy.stats.ttest_rel``) of ``a`` against ``b``.

    When every paired difference is the same the statistic is undefined; the result then
    has ``t`` and ``p`` None and a ``note`` saying so.

    >>> paired_ttest([0, 0, 0], [2, 2, 2])["note"]
    'undefined: every pair differs by -2 (zero variance)'
    """
    from scipy.stats import ttest_rel

    if len(a) != len(b):
        raise ValueError("paired samples must have the same length")
    d = np.asarray(a, float) - np.asarray(b, float)
    if len(d) < 2:
        return {"t": None, "p": None, "n": len(d), "note": "fewer than two pairs"}
    if np.all(d == d[0]):
        note = "no difference in any pair" if d[0] == 0 else f"every pair differs by {d[0]:g}"
        return {"t": None, "p": None, "n": len(d), "note": f"undefined: {note} (zero variance)"}
    res = ttest_rel(a, b)
    return {"t": float(res.statistic), "p": float(res.pvalue), "n": len(d), "note": ""}


def mcnemar(a: Sequence[int], b: Sequence[int]) -> dict[str, Any]:
    """Exact McNemar test on paired binary outcomes (``a`` vs ``b``, 1 = success).

    ``b01``: pairs where only ``b`` succeeded, ``b10``: only ``a``; p is the two-sided
    binomial test of ``b10`` out of ``b01 + b10`` at 1/2 (1.0 with no discordant pair).

    >>> r = mcnemar([1, 1, 0, 1], [0, 1, 0, 0])
    >>> r["b10"], r["b01"], r["p"]
    (2, 0, 0.5)
    """
    if len(a) != len(b):
        raise ValueError("paired samples must have the same length")
    b10 = sum(1 for x, y in zip(a, b) if x and not y)
    b01 = sum(1 for x, y in zip(a, b) if y and not x)
    n = b10 + b01
    if n == 0:
        return {"b10": 0, "b01": 0, "p": 1.0, "n": len(a), "note": "no discordant pair"}
    from scipy.stats import binomtest

    return {"b10": b10, "b01": b01, "p": float(binomtest(b10, n, 0.5).pvalue), "n": len(a), "note": ""}
