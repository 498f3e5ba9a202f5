"""Train a :class:`~clomp.runtime.experiment.policy.LinearPolicy` in :class:`~clomp.runtime.gym.ClompEnv`.

The cross-entropy method (Rubinstein 1999; a standard gradient-free policy search, numpy only,
so the default suite can train end to end without torch): each iteration draws
``population`` weight matrices from a Gaussian, scores each by its mean return over the
same ``episodes`` training layouts (common random numbers: the layouts and world seeds of an
iteration are shared by every candidate), and refits the Gaussian to the ``elite`` best.

Training layouts are run indices :data:`TRAIN_RUN_BASE` and up of each family (an
experiment scores runs 0 … N−1 of its seed, so the two never meet unless an experiment is
run with a million runs). ``on_iteration`` gets each iteration's figures: what a learning
curve plots (environment steps, thread CPU, the elite's mean return).

>>> policy, curve = train_linear(("overtaking",), iterations=1, population=4, elite=2, episodes=1,
...                              max_steps=10, noise="ideal")
>>> len(curve), curve[0]["steps"] > 0, policy.trained["method"]
(1, True, 'cross-entropy')
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np

from clomp.runtime.experiment.policy import FEATURES, LinearPolicy
from clomp.runtime.gym.env import ClompEnv

__all__ = ["TRAIN_RUN_BASE", "TrainingLayouts", "episode_return", "train_linear"]

TRAIN_RUN_BASE = 1_000_000
"""The first layout run index training draws from (scored layouts are runs 0 … N−1)."""


class TrainingLayouts(gym.Wrapper[np.ndarray, Any, np.ndarray, Any]):
    """``env`` whose every reset takes the next training layout: runs ``first``, ``first`` + 1, …
    of the family's seed ``seed`` (from :data:`TRAIN_RUN_BASE`: never a scored layout), the world
    seeded from a generator seeded by ``seed``, so a library's training loop (stable-baselines3's
    auto-reset) sees only training layouts, in a reproducible order.

    >>> env = TrainingLayouts(ClompEnv("overtaking", noise="ideal"), seed=3)
    >>> _ = env.reset(); _ = env.reset()
    >>> env.layouts
    [(3, 1000000), (3, 1000001)]
    """

    def __init__(self, env: ClompEnv, seed: int = 0, first: int = TRAIN_RUN_BASE) -> None:
        super().__init__(env)
        self._seed, self._next = int(seed), int(first)
        self._rng = np.random.default_rng([int(seed), 2])
        self.layouts: list[tuple[int, int]] = []

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None) -> tuple[np.ndarray, dict[str, Any]]:
        """The next training layout (``options`` may not name another)."""
        layout = (self._seed, self._next)
        self._next += 1
        self.layouts.append(layout)
        world = int(self._rng.integers(2**31)) if seed is None else seed
        return self.env.reset(seed=world, options={**(options or {}), "layout": layout})


def episode_return(env: ClompEnv, policy: LinearPolicy, layout: tuple[int, int], world_seed: int,
                   max_steps: int) -> tuple[float, int, bool]:
    """One episode of ``policy`` on layout (seed, run) with the world seeded by ``world_seed``:
    (return, steps, reached the goal).

    >>> env = ClompEnv("overtaking", noise="ideal")
    >>> ret, steps, reached = episode_return(env, LinearPolicy.goal_seeker(), (0, 0), 1, 5)
    >>> steps, reached
    (5, False)
    """
    obs, _ = env.reset(seed=world_seed, options={"layout": layout})
    total, steps = 0.0, 0
    for steps in range(1, max_steps + 1):
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        total += float(reward)
        if terminated or truncated:
            return total, steps, bool(info.get("reached"))
    return total, steps, False


def train_linear(families: Sequence[str] = ("overtaking",), *, iterations: int = 10, population: int = 16,
                 elite: int = 4, episodes: int = 4, seed: int = 0, noise: str = "paper", max_steps: int = 120,
                 init: LinearPolicy | None = None, sigma: float = 1.0,
                 on_iteration: Callable[[dict[str, Any]], None] | None = None) -> tuple[LinearPolicy, list[dict[str, Any]]]:
    """The cross-entropy method over linear policies; (the final mean policy, one dict per
    iteration: ``iteration``, ``steps`` and ``cpu_s`` so far, ``elite_return``, ``mean_return``).

    ``episodes`` training layouts per iteration, drawn round-robin over ``families``;
    ``init`` the search's starting mean (default all zeros; a policy this function returned
    carries its search's spread in ``trained["sd"]``, so training continues where it stopped);
    ``sigma`` the starting spread otherwise.
    """
    if not (iterations >= 1 and population >= 2 and 1 <= elite <= population and episodes >= 1 and max_steps >= 1):
        raise ValueError("need iterations >= 1, population >= 2, 1 <= elite <= population, episodes >= 1, max_steps >= 1")
    rng = np.random.default_rng(seed)
    envs = {f: ClompEnv(f, noise=noise) for f in dict.fromkeys(families)}
    shape = (3, len(FEATURES) + 1)
    mean = np.zeros(shape) if init is None else np.asarray(init.weights, dtype=float).copy()
    sd = np.full(shape, float(sigma))
    if init is not None and "sd" in init.trained:  # continue a search where it stopped
        sd = np.asarray(init.trained["sd"], dtype=float).reshape(shape)
    curve: list[dict[str, Any]] = []
    steps_total, c0, run = 0, time.thread_time(), TRAIN_RUN_BASE
    for it in range(iterations):
        tasks = []
        for k in range(episodes):
            fam = list(envs)[k % len(envs)]
            tasks.append((fam, (seed, run), int(rng.integers(2**31))))
            run += 1
        cands = [mean] + [mean + sd * rng.standard_normal(shape) for _ in range(population - 1)]
        scores = []
        for w in cands:
            pol = LinearPolicy(w)
            rets = []
            for fam, layout, ws in tasks:
                ret, n, _ = episode_return(envs[fam], pol, layout, ws, max_steps)
                rets.append(ret)
                steps_total += n
            scores.append(float(np.mean(rets)))
        order = np.argsort(scores)[::-1][:elite]
        best = np.stack([cands[i] for i in order])
        mean, sd = best.mean(axis=0), best.std(axis=0) + 0.05 * sigma
        point = {"iteration": it + 1, "steps": steps_total, "cpu_s": round(time.thread_time() - c0, 3),
                 "elite_return": round(float(np.mean([scores[i] for i in order])), 4),
                 "mean_return": round(float(scores[0]), 4)}
        curve.append(point)
        if on_iteration is not None:
            on_iteration(point)
    for env in envs.values():
        env.close()
    info = {"method": "cross-entropy", "families": list(envs), "noise": noise, "iterations": iterations,
            "population": population, "elite": elite, "episodes": episodes, "seed": seed, "max_steps": max_steps,
            "steps": steps_total, "layout_runs_from": TRAIN_RUN_BASE,
            "sd": [[round(float(v), 6) for v in row] for row in sd]}
    return LinearPolicy(mean, trained=info), curve
