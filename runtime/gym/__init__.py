"""Gymnasium environments of clomp's execution world (``pip install clomp[gym]``; issue #41).

Importing this package registers one id per layout family, the static and the moving
(:data:`~clomp.runtime.experiment.layouts.ALL_FAMILIES`): ``clomp/Overtaking-v0``,
``clomp/Corridor-v0`` … ``clomp/CulDeSac-v0``, ``clomp/Crossing-v0`` … ``clomp/Shut-v0``
(:data:`ENV_IDS`; issue #42's people, boxes and doors move in the latter), each a :class:`ClompEnv`
whose options (``noise``, ``action``, ``bins``, ``step_time``, ``render_mode``) go to
``gymnasium.make``. ``gymnasium.make("clomp.runtime.gym:clomp/Overtaking-v0")`` imports it
first. docs/gym.md describes the observation, the actions and the reward.

>>> import gymnasium
>>> env = gymnasium.make("clomp/Doorway-v0", noise="ideal", action="continuous")
>>> env.spec.max_episode_steps, env.action_space.shape
(240, (2,))
"""

from __future__ import annotations

import gymnasium

from clomp.runtime.experiment.layouts import ALL_FAMILIES
from clomp.runtime.gym.env import ACTIONS, GOAL_RADIUS, MAX_STEPS, ClompEnv

__all__ = ["ACTIONS", "ENV_IDS", "GOAL_RADIUS", "MAX_STEPS", "ClompEnv", "env_id", "register_envs"]


def env_id(family: str) -> str:
    """The registered id of a layout family.

    >>> env_id("u-trap"), env_id("cul-de-sac")
    ('clomp/UTrap-v0', 'clomp/CulDeSac-v0')
    """
    return "clomp/" + "".join(part.capitalize() for part in family.split("-")) + "-v0"


ENV_IDS: tuple[str, ...] = tuple(env_id(f) for f in ALL_FAMILIES)
"""Every registered id, in the order of the families."""


def register_envs() -> None:
    """Register every id of :data:`ENV_IDS` with Gymnasium (those not registered yet)."""
    for family in ALL_FAMILIES:
        if env_id(family) in gymnasium.registry:
            continue
        gymnasium.register(env_id(family), entry_point="clomp.runtime.gym.env:ClompEnv", max_episode_steps=MAX_STEPS,
                           kwargs={"family": family})


register_envs()
