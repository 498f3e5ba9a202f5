"""Learned policies for the ``rl`` condition: what a policy sees, the file it lives in, how it is loaded.

A policy maps the observation of :class:`~clomp.runtime.gym.ClompEnv` (``bins`` ranges of the
newest LiDAR revolution, one per bearing sector counter-clockwise from straight ahead, then the
goal in the robot frame) to one of the three discrete actions (0 straight, 1 left, 2 right).
The experiment's ``rl`` condition (:mod:`clomp.runtime.experiment.rl`) builds that observation
on the robot from its *estimate* (not the world's truth) and the newest scan, and holds each
action for one step.

Two kinds of file load (:func:`load_policy`):

- ``.json``: a :class:`LinearPolicy` — numpy only, what the default suite trains
  (:func:`clomp.runtime.gym.train.train_linear`), the shipped default
  (:data:`DEFAULT_POLICY`) included. Format ``clomp-policy/1``: ``{"format", "kind":
  "linear", "bins", "max_range", "weights": 3 rows of len(FEATURES)+1 numbers, "trained":
  {...}}``; the action is the argmax of ``weights @ [features, 1]``.
- ``.zip``: a stable-baselines3 model (PPO, DQN or A2C saved by ``model.save``) trained on
  the environment's discrete actions; needs ``pip install 'clomp[rl]'``.

>>> p = LinearPolicy.goal_seeker()
>>> obs = np.r_[np.full(64, 1.1), [1.0, 0.0]].astype(np.float32)  # nothing near, goal 1 m ahead
>>> p.act(obs), p.act(np.r_[np.full(64, 1.1), [0.0, 1.0]])  # ahead: straight; to the left: left
(0, 1)
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Protocol

import numpy as np

from clomp.specs import SPECS_DIR

__all__ = ["ACTION_TASKS", "DEFAULT_POLICY", "FEATURES", "POLICY_FORMAT", "LinearPolicy", "Policy", "PolicyError", "features",
           "load_policy", "policy_id", "scan_ranges"]

ACTION_TASKS = ("straight", "left", "right")
"""The discrete actions, in order: the planner's three tasks (the Gymnasium environment's ``ACTIONS``)."""
POLICY_FORMAT = "clomp-policy/1"
"""The ``format`` field of a linear policy file."""
DEFAULT_POLICY = SPECS_DIR / "policies" / "linear-default.json"
"""The shipped policy the ``rl`` condition loads unless told another (trained on layouts
disjoint from every experiment's; its ``trained`` field says how)."""
FEATURES = ("goal_cos", "goal_sin", "goal_near", "clear_ahead", "clear_left", "clear_right",
            "clear_left_side", "clear_right_side")
"""What a :class:`LinearPolicy` weighs: the goal's bearing (cos, sin), min(1, goal distance),
then the nearest range (÷ max range) in the sectors ahead (±20°), front-left (20°–70°),
front-right, left (70°–110°) and right."""
_SECTORS = ((-20.0, 20.0), (20.0, 70.0), (-70.0, -20.0), (70.0, 110.0), (-110.0, -70.0))


class PolicyError(ValueError):
    """A policy file that is missing, malformed or of an unknown kind.

    >>> issubclass(PolicyError, ValueError)
    True
    """


class Policy(Protocol):
    """Anything that maps an observation to a discrete action (0 straight, 1 left, 2 right)."""

    def act(self, obs: np.ndarray) -> int:
        """The action for one observation."""
        ...  # pragma: no cover


def scan_ranges(points: np.ndarray, bins: int, max_range: float) -> np.ndarray:
    """Scan points (robot frame, (N, 2)) as ``bins`` ranges, sector k spanning bearings
    [k, k+1)·2π/bins counter-clockwise from straight ahead, each the nearest return there,
    clipped to ``max_range`` (an empty sector reads ``max_range``); float32.

    >>> scan_ranges(np.array([[0.5, 0.0], [0.0, 2.0]]), 4, 1.1).tolist()
    [0.5, 1.100000023841858, 1.100000023841858, 1.100000023841858]
    """
    out = np.full(bins, max_range, dtype=np.float32)
    p = np.asarray(points, dtype=float).reshape(-1, 2)
    if len(p):
        r = np.hypot(p[:, 0], p[:, 1])
        k = np.floor(np.mod(np.arctan2(p[:, 1], p[:, 0]), 2 * math.pi) / (2 * math.pi) * bins).astype(int) % bins
        np.minimum.at(out, k, np.minimum(r, max_range).astype(np.float32))
    return out


def features(obs: np.ndarray, bins: int, max_range: float) -> np.ndarray:
    """The :data:`FEATURES` of one observation (``bins`` ranges + the goal), float64.

    >>> features(np.r_[np.full(8, 1.1), [0.0, 2.0]], 8, 1.1).round(2).tolist()
    [0.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0]
    """
    o = np.asarray(obs, dtype=float).reshape(-1)
    if o.shape != (bins + 2,) or not np.all(np.isfinite(o)):
        raise PolicyError(f"an observation of {bins} ranges and the goal has {bins + 2} finite values, got {o.shape[0]}")
    ranges, (gx, gy) = o[:bins], o[bins:]
    d = math.hypot(gx, gy)
    out = [gx / d if d > 0 else 1.0, gy / d if d > 0 else 0.0, min(1.0, d)]
    centres = (np.arange(bins) + 0.5) * 360.0 / bins
    centres = np.where(centres > 180.0, centres - 360.0, centres)
    for lo, hi in _SECTORS:
        sel = ranges[(centres >= lo) & (centres < hi)]
        out.append(float(sel.min()) / max_range if len(sel) else 1.0)
    return np.asarray(out)


@dataclass
class LinearPolicy:
    """Action = argmax of ``weights @ [features(obs), 1]``; ``weights`` is 3 × (len(FEATURES) + 1).

    >>> LinearPolicy.goal_seeker().weights.shape
    (3, 9)
    """

    weights: np.ndarray
    bins: int = 64
    max_range: float = 1.1
    trained: dict[str, Any] = field(default_factory=dict)

    def __post_init__(self) -> None:
        w = np.asarray(self.weights, dtype=float)
        if w.shape != (3, len(FEATURES) + 1) or not np.all(np.isfinite(w)):
            raise PolicyError(f"weights must be 3 × {len(FEATURES) + 1} finite numbers, got shape {w.shape}")
        if not (isinstance(self.bins, int) and self.bins >= 8):
            raise PolicyError(f"bins must be an integer >= 8, got {self.bins!r}")
        if not (math.isfinite(self.max_range) and self.max_range > 0):
            raise PolicyError(f"max_range must be a positive number, got {self.max_range!r}")
        self.weights = w

    def act(self, obs: np.ndarray) -> int:
        """The action for one observation (ties: the lowest index, straight first)."""
        f = np.r_[features(obs, self.bins, self.max_range), 1.0]
        return int(np.argmax(self.weights @ f))

    @classmethod
    def goal_seeker(cls, bins: int = 64, max_range: float = 1.1) -> LinearPolicy:
        """A hand-set policy: straight while the goal is ahead, else turn towards it; a
        reference point for what training should at least find.

        >>> LinearPolicy.goal_seeker().trained["kind"]
        'hand-set'
        """
        w = np.zeros((3, len(FEATURES) + 1))
        w[0, 0] = 1.0      # straight: the goal's cos
        w[1, 1] = 1.0      # left: the goal's sin
        w[2, 1] = -1.0     # right: minus it
        w[1:, 8] = -0.95   # turn only when the goal is more than ~18° off the heading
        return cls(w, bins, max_range, {"kind": "hand-set"})

    def to_json(self) -> dict[str, Any]:
        """The file's content (:data:`POLICY_FORMAT`)."""
        return {"format": POLICY_FORMAT, "kind": "linear", "bins": self.bins, "max_range": self.max_range,
                "features": list(FEATURES), "weights": [[round(float(v), 6) for v in row] for row in self.weights],
                "trained": self.trained}

    def save(self, path: str | os.PathLike[str]) -> Path:
        """Write the policy as JSON to ``path``; the path."""
        p = Path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        p.write_text(json.dumps(self.to_json(), indent=1) + "\n", encoding="utf-8")
        return p

    @classmethod
    def from_json(cls, raw: Any, where: str = "policy") -> LinearPolicy:
        """The policy of a file's parsed JSON; PolicyError naming what is wrong."""
        if not isinstance(raw, dict) or raw.get("format") != POLICY_FORMAT or raw.get("kind") != "linear":
            raise PolicyError(f"{where}: not a {POLICY_FORMAT} linear policy (format/kind fields)")
        if list(raw.get("features", FEATURES)) != list(FEATURES):
            raise PolicyError(f"{where}: features {raw.get('features')!r} are not this version's {list(FEATURES)}")
        try:
            return cls(np.asarray(raw["weights"], dtype=float), int(raw.get("bins", 64)), float(raw.get("max_range", 1.1)),
                       dict(raw.get("trained") or {}))
        except (KeyError, TypeError, ValueError) as exc:
            raise PolicyError(f"{where}: {exc}") from None


class _Sb3Policy:
    """A stable-baselines3 model's deterministic action."""

    def __init__(self, model: Any) -> None:
        self.model = model

    def act(self, obs: np.ndarray) -> int:
        action, _ = self.model.predict(np.asarray(obs, dtype=np.float32), deterministic=True)
        return int(np.asarray(action).reshape(-1)[0])


def load_policy(path: str | os.PathLike[str] | None = None) -> Policy:
    """The policy in ``path`` (None: :data:`DEFAULT_POLICY`); see the module for the kinds.

    >>> load_policy().act(np.r_[np.full(64, 1.1), [1.0, 0.0]])
    0
    >>> load_policy("missing.json")
    Traceback (most recent call last):
    ...
    clomp.runtime.experiment.policy.PolicyError: policy file missing.json: not found
    """
    p = Path(path) if path is not None else DEFAULT_POLICY
    if not p.is_file():
        raise PolicyError(f"policy file {p}: not found")
    if p.suffix == ".zip":
        return _load_sb3(p)
    try:
        raw = json.loads(p.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise PolicyError(f"policy file {p}: not JSON ({exc})") from None
    return LinearPolicy.from_json(raw, f"policy file {p}")


def _load_sb3(p: Path) -> Policy:
    try:
        import stable_baselines3 as sb3  # type: ignore[import-not-found, unused-ignore]
    except ImportError:
        raise PolicyError(f"policy file {p}: a stable-baselines3 model needs pip install 'clomp[rl]'") from None
    errors: list[str] = []
    for name in ("PPO", "DQN", "A2C"):
        try:
            return _Sb3Policy(getattr(sb3, name).load(str(p), device="cpu"))
        except Exception as exc:  # the wrong algorithm's loader: try the next
            errors.append(f"{name}: {exc}")
    raise PolicyError(f"policy file {p}: no stable-baselines3 loader took it ({'; '.join(errors)})")


def policy_id(path: str | os.PathLike[str] | None) -> str:
    """A short content hash of a policy file (the experiment's run keys carry it, so a resume
    never mixes two policies); ``"default"`` for :data:`DEFAULT_POLICY`.

    >>> policy_id(None)
    'default'
    """
    if path is None or Path(path).resolve() == DEFAULT_POLICY.resolve():
        return "default"
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()[:12]

