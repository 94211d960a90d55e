"""Train a PPO agent (Stable-Baselines3) on octoarm/ArmReach-v0.

    pip install "./crates/python[examples]"      # octoarm + matplotlib + stable-baselines3
    python crates/python/examples/ppo_reach.py --steps 5000

By default the arms are stepped in Rust (``octoarm.sb3.RustVecEnv``: all arms in one call, in
parallel); ``--vec dummy`` uses SB3's own ``make_vec_env`` (one Python env per arm, the path
that needs octoarm to raise TypeError for ``render_mode``). A few thousand steps only show the
loop working; reaching well takes ~1e6. CI runs ``--steps 256 --eval-episodes 1 --no-save``
with both ``--vec`` values as a smoke test.
"""

import argparse
import time

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env
from stable_baselines3.common.vec_env import VecMonitor

import octoarm  # noqa: F401  (registers octoarm/ArmReach-v0)
from octoarm.sb3 import RustVecEnv


def evaluate(model, episodes):
    """Mean final tip distance [m] of the deterministic policy on `episodes` seeded episodes."""
    env = gym.make("octoarm/ArmReach-v0")
    final = []
    for ep in range(episodes):
        obs, _ = env.reset(seed=1000 + ep)
        done = False
        while not done:
            action, _ = model.predict(obs, deterministic=True)
            obs, reward, terminated, truncated, info = env.step(action)
            done = terminated or truncated
        final.append(info["tip_distance"])
    return float(np.mean(final))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--steps", type=int, default=5000, help="environment steps to train")
    p.add_argument("--envs", type=int, default=4, help="arms simulated in parallel")
    p.add_argument("--vec", choices=["rust", "dummy"], default="rust",
                   help="rust: octoarm.sb3.RustVecEnv; dummy: SB3's make_vec_env")
    p.add_argument("--eval-episodes", type=int, default=3)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--no-save", action="store_true", help="do not save the trained model")
    a = p.parse_args()
    if a.steps < 1 or a.envs < 1 or a.eval_episodes < 1:
        p.error("--steps, --envs and --eval-episodes must be at least 1")

    if a.vec == "rust":
        env = VecMonitor(RustVecEnv(num_envs=a.envs))
        env.seed(a.seed)
    else:
        env = make_vec_env("octoarm/ArmReach-v0", n_envs=a.envs, seed=a.seed)
    # One rollout is n_steps per arm; keep it no longer than the requested training.
    n_steps = max(8, min(256, -(-a.steps // a.envs)))
    model = PPO("MlpPolicy", env, n_steps=n_steps, batch_size=min(64, n_steps * a.envs),
                seed=a.seed, verbose=1)
    print(f"final tip distance before training: {evaluate(model, a.eval_episodes):.4f} m")
    t0 = time.perf_counter()
    model.learn(total_timesteps=a.steps)
    wall = time.perf_counter() - t0
    print(f"trained {model.num_timesteps} steps in {wall:.1f} s")
    print(f"final tip distance after training: {evaluate(model, a.eval_episodes):.4f} m")
    if not a.no_save:
        model.save("ppo_octoarm_reach")


if __name__ == "__main__":
    main()
