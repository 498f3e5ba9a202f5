"""The rl condition's learning curve: success on held-out layouts against environment steps and CPU time.

Trains a linear policy by the cross-entropy method (:func:`clomp.runtime.gym.train.train_linear`)
on training layouts (runs 1,000,000 and up of each family) and, every ``--eval-every``
iterations, runs the current policy as the experiment's ``rl`` condition on the held-out
layouts (runs 0 … ``--eval-runs``−1 of seed ``--seed``, what ``clomp experiment`` scores),
beside the planner's success on the same layouts with zero training. Prints one row per
evaluation and the environment steps at which the policy first matched the planner (or
that it never did within the budget). ``--save`` writes the final policy (a
``clomp-policy/1`` JSON the ``rl`` condition loads).

``--algo ppo`` or ``--algo dqn`` trains a stable-baselines3 model instead (``pip install
'clomp[rl]'``: torch; CPU, one torch thread) on the raw observation, one environment per family
each taking the next training layout at every reset (:class:`clomp.runtime.gym.train.TrainingLayouts`),
evaluated every ``--eval-steps`` environment steps the same way; ``--save`` writes its ``.zip``
(what ``clomp experiment F --condition rl --policy FILE.zip`` loads).

    python bench/rl_curve.py --families overtaking,corridor,doorway,slalom,clutter --iterations 15
    python bench/rl_curve.py --algo ppo --steps 200000 --eval-steps 50000 --save ppo.zip
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path
from typing import Any

from clomp.runtime.experiment.onerun import run_once
from clomp.runtime.experiment.policy import LinearPolicy, Policy
from clomp.runtime.experiment.runspec import RunSpec, noise_seed, scene_for
from clomp.runtime.gym.train import train_linear


def held_out_success(condition: str, families: list[str], runs: int, seed: int, noise: str,
                     policy: Policy | None = None) -> tuple[int, int, int]:
    """(truly reached, runs, false successes) of ``condition`` on runs 0..runs-1 of each family."""
    reached = total = false = 0
    for fam in families:
        for k in range(runs):
            scene, expect = scene_for(RunSpec(fam, seed, k, condition, noise))
            r = run_once(scene, condition, noise_seed(seed, k), run=k, noise=noise, expect=expect,
                         reactive={"policy": policy} if policy is not None else None)
            reached += int(r.reached_goal)
            false += int(r.end_state == "GOAL_REACHED" and not r.reached_goal)
            total += 1
    return reached, total, false


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--families", default="overtaking,corridor,doorway,slalom,clutter")
    ap.add_argument("--noise", default="paper")
    ap.add_argument("--iterations", type=int, default=15)
    ap.add_argument("--population", type=int, default=16)
    ap.add_argument("--elite", type=int, default=4)
    ap.add_argument("--episodes", type=int, default=8, help="training episodes per iteration (round-robin over families)")
    ap.add_argument("--eval-every", type=int, default=5)
    ap.add_argument("--eval-runs", type=int, default=10, help="held-out layouts per family")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--init", choices=("zeros", "goal-seeker"), default="zeros")
    ap.add_argument("--save", type=Path, default=None)
    ap.add_argument("--algo", choices=("cem", "ppo", "dqn"), default="cem",
                    help="cem: the numpy linear policy; ppo/dqn: stable-baselines3 (clomp[rl])")
    ap.add_argument("--steps", type=int, default=200_000, help="ppo/dqn: environment steps of training")
    ap.add_argument("--eval-steps", type=int, default=50_000, help="ppo/dqn: evaluate every this many steps")
    a = ap.parse_args(argv)
    fams = [f.strip() for f in a.families.split(",") if f.strip()]
    c0, w0 = time.thread_time(), time.perf_counter()
    plan = held_out_success("planning", fams, a.eval_runs, a.seed, a.noise)
    print(f"planner (zero training) on {plan[1]} held-out layouts ({', '.join(fams)}, noise {a.noise}, seed {a.seed}): "
          f"reached {plan[0]}/{plan[1]}, false successes {plan[2]} "
          f"[{time.thread_time() - c0:.0f} s CPU, {time.perf_counter() - w0:.0f} s wall]", flush=True)
    if a.algo != "cem":
        return sb3_curve(a, fams, plan)
    print("iteration  env steps  train CPU s  wall s  held-out reached (rl)  false successes  elite return", flush=True)
    matched: dict[str, Any] | None = None
    policy = LinearPolicy.goal_seeker() if a.init == "goal-seeker" else None
    done = 0
    steps = 0
    train_cpu = 0.0
    while done < a.iterations:
        n = min(a.eval_every, a.iterations - done)
        policy, curve = train_linear(fams, iterations=n, population=a.population, elite=a.elite, episodes=a.episodes,
                                     seed=a.seed * 1000 + done, noise=a.noise, init=policy)
        done += n
        steps += curve[-1]["steps"]
        train_cpu += curve[-1]["cpu_s"]
        rl = held_out_success("rl", fams, a.eval_runs, a.seed, a.noise, policy)
        print(f"{done:>9}  {steps:>9}  {train_cpu:>11.1f}  {time.perf_counter() - w0:>6.0f}  "
              f"{rl[0]:>10}/{rl[1]:<10}  {rl[2]:>15}  {curve[-1]['elite_return']:>12.3f}", flush=True)
        if matched is None and rl[0] >= plan[0]:
            matched = {"iteration": done, "steps": steps, "cpu_s": train_cpu}
    if matched:
        print(f"the policy matched the planner's {plan[0]}/{plan[1]} after {matched['steps']} environment steps "
              f"({matched['cpu_s']:.0f} s training CPU)")
    else:
        print(f"the policy never matched the planner's {plan[0]}/{plan[1]} within {steps} environment steps "
              f"({train_cpu:.0f} s training CPU)")
    if a.save is not None and policy is not None:
        policy.trained.update({"families": fams, "iterations": a.iterations, "steps": steps, "init": a.init})
        print(f"wrote {policy.save(a.save)}")
    return 0


def sb3_curve(a: argparse.Namespace, fams: list[str], plan: tuple[int, int, int]) -> int:
    """The learning curve of a stable-baselines3 PPO or DQN model (``--algo``); see the module."""
    try:
        import stable_baselines3 as sb3
        import torch
        from stable_baselines3.common.monitor import Monitor
        from stable_baselines3.common.vec_env import DummyVecEnv
    except ImportError as exc:
        print(f"rl_curve: --algo {a.algo} needs stable-baselines3 and torch (pip install 'clomp[rl]'): {exc}",
              file=sys.stderr)
        return 2
    from gymnasium.wrappers import TimeLimit

    from clomp.runtime.experiment.policy import _Sb3Policy
    from clomp.runtime.gym.env import MAX_STEPS, ClompEnv
    from clomp.runtime.gym.train import TRAIN_RUN_BASE, TrainingLayouts

    torch.set_num_threads(1)  # one core: the thread CPU below is then all of training's CPU

    def maker(k: int, fam: str) -> Any:
        return lambda: Monitor(TimeLimit(TrainingLayouts(ClompEnv(fam, noise=a.noise), seed=a.seed * 1000 + k),
                                         max_episode_steps=MAX_STEPS))

    venv = DummyVecEnv([maker(k, f) for k, f in enumerate(fams)])
    if a.algo == "ppo":
        model = sb3.PPO("MlpPolicy", venv, n_steps=1024, batch_size=256, seed=a.seed, device="cpu", verbose=0)
    else:
        model = sb3.DQN("MlpPolicy", venv, learning_starts=5_000, buffer_size=100_000, exploration_fraction=0.3,
                        seed=a.seed, device="cpu", verbose=0)
    print(f"{a.algo.upper()} on {len(fams)} training environments (layout runs {TRAIN_RUN_BASE:,} and up), "
          f"{a.steps:,} steps, held-out evaluation every {a.eval_steps:,}", flush=True)
    print("env steps  train CPU s  train wall s  held-out reached (rl)  false successes  episodes  mean ep. return",
          flush=True)
    matched: tuple[int, float] | None = None
    train_cpu = train_wall = 0.0
    while model.num_timesteps < a.steps:
        c0, w0 = time.thread_time(), time.perf_counter()
        model.learn(total_timesteps=min(a.eval_steps, a.steps - model.num_timesteps), reset_num_timesteps=False)
        train_cpu += time.thread_time() - c0
        train_wall += time.perf_counter() - w0
        rl = held_out_success("rl", fams, a.eval_runs, a.seed, a.noise, _Sb3Policy(model))
        rets = [r for env in venv.envs for r in env.get_episode_rewards()]  # type: ignore[attr-defined]
        recent = rets[-200:]
        print(f"{model.num_timesteps:>9}  {train_cpu:>11.1f}  {train_wall:>12.0f}  {rl[0]:>10}/{rl[1]:<10}  "
              f"{rl[2]:>15}  {len(rets):>8}  {sum(recent) / max(len(recent), 1):>15.3f}", flush=True)
        if matched is None and rl[0] >= plan[0]:
            matched = (model.num_timesteps, train_cpu)
        if a.save is not None:  # after every evaluation: a cut-short run keeps the policy it scored last
            model.save(str(a.save))
    if matched:
        print(f"the {a.algo.upper()} policy matched the planner's {plan[0]}/{plan[1]} after {matched[0]} environment "
              f"steps ({matched[1]:.0f} s training CPU)")
    else:
        print(f"the {a.algo.upper()} policy never matched the planner's {plan[0]}/{plan[1]} within {model.num_timesteps} "
              f"environment steps ({train_cpu:.0f} s training CPU, {train_wall:.0f} s wall)")
    if a.save is not None:
        print(f"wrote {a.save}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
