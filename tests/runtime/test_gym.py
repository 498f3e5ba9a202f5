"""clomp.runtime.gym: every registered id passes Gymnasium's checker, and a seed fixes an episode."""

from __future__ import annotations

import numpy as np
import pytest

gymnasium = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from clomp.runtime.experiment.layouts import ALL_FAMILIES, MOVING_FAMILIES  # noqa: E402
from clomp.runtime.gym import ENV_IDS, GOAL_RADIUS, ClompEnv, env_id  # noqa: E402


def test_one_id_per_layout_family() -> None:
    assert ENV_IDS == tuple(env_id(f) for f in ALL_FAMILIES)
    assert set(ENV_IDS) <= set(gymnasium.registry)
    assert {"clomp/Crossing-v0", "clomp/Stopper-v0", "clomp/Appearing-v0", "clomp/Closing-v0", "clomp/Shut-v0"} <= set(ENV_IDS)


@pytest.mark.parametrize("family", MOVING_FAMILIES)
def test_a_moving_familys_bodies_move_in_its_environment(family: str) -> None:
    """The people, boxes and doors of a moving family are in its episodes' world (issue #42)."""
    env = gymnasium.make(env_id(family), noise="ideal")
    env.reset(seed=0, options={"layout": (0, 0)})
    world = env.unwrapped.robot
    assert world.movers is not None and len(world.movers.movers) >= 1
    env.close()


@pytest.mark.parametrize("action", ["discrete", "continuous"])
@pytest.mark.parametrize("name", ENV_IDS)
def test_every_registered_id_passes_the_env_checker(name: str, action: str) -> None:
    env = gymnasium.make(name, action=action, render_mode="rgb_array")
    check_env(env.unwrapped, skip_render_check=False)
    env.close()


def _rollout(env: gymnasium.Env, seed: int, steps: int = 200) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs]
    for _ in range(steps):
        obs, reward, terminated, truncated, _ = env.step(env.action_space.sample())
        out.append(np.r_[obs, reward, terminated, truncated])
        if terminated or truncated:
            obs, _ = env.reset()
            out.append(obs)
    return out


@pytest.mark.parametrize("action", ["discrete", "continuous"])
def test_a_seeded_rollout_of_200_steps_is_the_same_twice(action: str) -> None:
    env = gymnasium.make("clomp/Overtaking-v0", noise="paper", action=action)
    a, b = _rollout(env, 7), _rollout(env, 7)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))
    c = _rollout(env, 8)
    assert not all(len(x) == len(y) and np.array_equal(x, y) for x, y in zip(a, c))


def test_straight_at_an_open_goal_earns_progress_then_the_goal() -> None:
    env = ClompEnv("corridor", noise="ideal")
    obs, _ = env.reset(seed=0)
    env.scene = env.scene.__class__(name="free", shapes=(), goal=(0.6, 0.0))  # the goal 0.6 m ahead, nothing in the way
    env._distance = env._goal_distance()
    rewards, terminated, info = [], False, {}
    while not terminated and len(rewards) < 40:
        _, r, terminated, _, info = env.step(0)
        rewards.append(float(r))
    assert terminated and info["reached"] and not info["collided"]
    assert all(r > 0 for r in rewards[:-1]) and rewards[-1] > 1.0
    assert env._goal_distance() <= GOAL_RADIUS


def test_driving_into_a_wall_ends_the_episode_with_minus_one() -> None:
    env = ClompEnv("doorway", noise="ideal")  # a wall across the way 0.4-0.65 m ahead
    env.reset(seed=0)
    for _ in range(60):
        _, r, terminated, _, info = env.step(0)
        if terminated:
            break
    assert terminated and info["collided"] and float(r) < -0.5


def test_the_observation_is_the_scan_by_bearing_and_the_goal_in_the_robot_frame() -> None:
    env = ClompEnv("overtaking", noise="ideal", bins=64)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (66,) and obs.dtype == np.float32
    assert np.all(obs[:64] <= env.max_range) and obs[:64].min() < env.max_range  # something seen
    gx, gy = env.scene.goal
    assert obs[64] == pytest.approx(gx, abs=0.02) and obs[65] == pytest.approx(gy, abs=0.02)


def test_render_draws_an_rgb_image() -> None:
    env = ClompEnv("clutter", render_mode="rgb_array")
    env.reset(seed=1)
    img = env.render()
    assert img is not None and img.shape == (400, 400, 3) and img.dtype == np.uint8
    assert len(np.unique(img.reshape(-1, 3), axis=0)) > 2  # not a blank canvas
    assert ClompEnv("clutter").render() is None
