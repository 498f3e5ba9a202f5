"""The uncertainty a robot base reports with its odometry, as a floor under a prediction step.

A base that publishes wheel odometry with a covariance (ROS's ``nav_msgs/Odometry``: the
pose's and the twist's) says how uncertain its own motion is. The estimator's prediction
noise for a step must then be *at least* what the base says: a base that knows its wheels
slip on this floor must not be believed to 1 mm by a model of another robot. Two readings
of that claim, both planar (x, y, yaw) in the robot frame at the start of the step:

- the **twist covariance** (vx, vy, wz, in the base frame) over a step of ``dt`` s: the
  displacement's covariance ``Σ_twist dt²`` (the speed's error taken as the same over the
  step, the cautious reading);
- the **growth of the pose covariance** (x, y, yaw, in the odometry frame) since the last
  step, turned into the robot frame at the previous pose: what the base added for the
  motion in between. A pose covariance that shrank or stayed the same adds nothing (a
  base that publishes a constant one says nothing about a step).

:func:`step_noise_floor` takes the larger of the two (:func:`psd_max`: a covariance not
smaller than either); :meth:`~clomp.runtime.estimation.ekf.OdometryFilter.predict` then makes
its own noise for the step no smaller than that. A covariance the base does not know (all
zeros, or -1 in its first element: REP 145's "unknown") is ``None`` here, and the model's own
noise stands alone.

>>> import numpy as np
>>> twist = np.diag([0.01**2, 0.01**2, 0.02**2])             # speeds good to 1 cm/s, 0.02 rad/s
>>> floor = step_noise_floor(None, None, twist, heading=0.0, dt=0.1)
>>> np.sqrt(np.diag(floor)).round(4).tolist()               # 1 mm, 1 mm, 2 mrad over 0.1 s
[0.001, 0.001, 0.002]
>>> step_noise_floor(None, None, None, heading=0.0, dt=0.1) is None
True
"""

from __future__ import annotations

import math

import numpy as np

__all__ = ["OdometryCovariance", "psd_max", "rotate_covariance", "step_noise_floor"]

#: a base's reported odometry covariance: (pose, twist), each planar 3×3 (x, y, yaw) or None (unknown)
OdometryCovariance = tuple[np.ndarray | None, np.ndarray | None]


def _psd_part(m: np.ndarray) -> np.ndarray:
    """The positive semi-definite part of a symmetric matrix (negative eigenvalues dropped)."""
    vals, vecs = np.linalg.eigh((m + m.T) / 2)
    out: np.ndarray = (vecs * np.clip(vals, 0.0, None)) @ vecs.T
    return out


def psd_max(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """A covariance no smaller than ``a`` nor ``b`` (in the positive semi-definite order):
    ``a`` plus the part of ``b - a`` that exceeds it.

    >>> psd_max(np.diag([1.0, 4.0]), np.diag([2.0, 3.0])).tolist()
    [[2.0, 0.0], [0.0, 4.0]]
    """
    a = np.asarray(a, dtype=float)
    out: np.ndarray = a + _psd_part(np.asarray(b, dtype=float) - a)
    return out


def rotate_covariance(cov: np.ndarray, angle: float) -> np.ndarray:
    """A planar (x, y, yaw) covariance in axes turned by ``-angle``: a robot-frame one in the
    frame the robot stands in at heading ``angle``.

    >>> rotate_covariance(np.diag([1.0, 0.0, 0.0]), math.pi / 2).round(6).tolist()[1]
    [0.0, 1.0, 0.0]
    """
    c, s = math.cos(angle), math.sin(angle)
    j = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    out: np.ndarray = j @ cov @ j.T
    return out


def step_noise_floor(pose_before: np.ndarray | None, pose_now: np.ndarray | None, twist: np.ndarray | None,
                     heading: float, dt: float) -> np.ndarray | None:
    """The covariance (3×3, x forward, y left, yaw; robot frame at the step's start) a base's
    reported odometry covariance gives a step of ``dt`` s (see the module): ``pose_before`` and
    ``pose_now`` the pose covariances (odometry frame) at its start and end, ``twist`` the
    twist covariance (base frame), ``heading`` the odometry's yaw at the start. None when
    nothing is known (each argument may be None: unknown).

    >>> grown = step_noise_floor(np.zeros((3, 3)), np.diag([0.0, 0.02**2, 0.0]), None,
    ...                          heading=math.pi / 2, dt=0.1)   # the odometry frame's y: the robot's x
    >>> np.sqrt(np.clip(np.diag(grown), 0, None)).round(4).tolist()
    [0.02, 0.0, 0.0]
    """
    floor: np.ndarray | None = None
    if twist is not None and dt > 0:
        floor = np.asarray(twist, dtype=float) * dt * dt
    if pose_before is not None and pose_now is not None:
        grown = _psd_part(rotate_covariance(np.asarray(pose_now, dtype=float) - np.asarray(pose_before, dtype=float), -heading))
        floor = grown if floor is None else psd_max(floor, grown)
    return floor
