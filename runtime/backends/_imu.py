"""The emulated world's IMU: a BNO08x's error terms drawn from the world's noise preset.

The preset's gyro terms become the IMU's (per run: ``rate_bias`` the standard deviation of
its drift in rad/s, ``rate_scale`` of its scale error; ``rate_sd`` its random walk in
rad/√s); each report's white noise is one report's step of that walk (``rate_sd / 10``
rad: a fused BNO08x yaw is smooth), the share of reports lost ``dropout`` (as the LiDAR's
returns) and the share preceded by a garbage burst a tenth of it. So ``ideal`` gives a perfect IMU on a clean
line, ``paper`` about 0.6°/s of drift at most and 2 % of reports lost, ``harsh`` five times
that. The draws come from a generator of their own (the run's seed and a tag), so the
world's other draws are the same with and without it.

>>> terms = imu_terms(NoiseTerms.preset("ideal"), seed=0)
>>> terms["drift"], terms["scale_error"], terms["drop_rate"]
(0.0, 0.0, 0.0)
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from clomp.planner.noise import NoiseTerms

__all__ = ["imu_terms"]

_TAG = 0x696D75  # "imu": the IMU's own stream of draws


def imu_terms(noise: NoiseTerms | None, seed: int | None, time_scale: float = 1.0) -> dict[str, Any]:
    """:class:`~clomp.runtime.devices.bno08x_emulator.Bno08xEmulator` arguments for a world
    with ``noise`` (None: the older simulated robot, a perfect IMU), seeded by ``seed``;
    ``time_scale`` (the world's speed over wall time) turns per-second terms into the
    emulator's clock, whose reports then come ``time_scale`` times as often."""
    rng = np.random.default_rng(None if seed is None else [int(seed), _TAG])
    z_drift, z_scale = (float(v) for v in rng.standard_normal(2))
    n = noise or NoiseTerms()
    return {
        "rate": 100.0 * time_scale,
        "drift": n.rate_bias * z_drift * time_scale,
        "scale_error": n.rate_scale * z_scale,
        "walk": n.rate_sd * math.sqrt(time_scale),
        "noise": n.rate_sd / math.sqrt(100.0),
        "drop_rate": n.dropout,
        "garbage_rate": n.dropout / 10.0,
        "seed": None if seed is None else int(rng.integers(2**31)),
    }
