"""Train a PPO agent (Stable-Baselines3) on octoarm/ArmReach-v0 for a few thousand steps.

    pip install "./crates/python[examples]"      # octoarm + matplotlib + stable-baselines3
    python crates/python/examples/ppo_reach.py --steps 5000

Not run by CI. A few thousand steps only shows the loop working; reaching well takes ~1e6.
"""

import argparse

import gymnasium as gym
import numpy as np
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env

import octoarm  # noqa: F401  (registers octoarm/ArmReach-v0)


def evaluate(model, episodes=3):
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
    return np.mean(final)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--steps", type=int, default=5000)
    p.add_argument("--envs", type=int, default=4)
    a = p.parse_args()
    env = make_vec_env("octoarm/ArmReach-v0", n_envs=a.envs, seed=0)
    model = PPO("MlpPolicy", env, n_steps=256, batch_size=64, seed=0, verbose=1)
    print(f"final tip distance before training: {evaluate(model):.4f} m")
    model.learn(total_timesteps=a.steps)
    print(f"final tip distance after {a.steps} steps: {evaluate(model):.4f} m")
    model.save("ppo_octoarm_reach")


if __name__ == "__main__":
    main()
