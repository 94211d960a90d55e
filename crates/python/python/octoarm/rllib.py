"""octoarm's Gymnasium environments for Ray RLlib (needs ``ray[rllib]``).

``register()`` registers ``octoarm/ArmReach-v0`` with RLlib (``ray.tune.register_env``; Ray ships
the registration to every env-runner process, on any node). RLlib's env runners build their
environment with ``gym.make_vec``: with ``gym_env_vectorize_mode="vector_entry_point"`` (what
``ppo_config`` sets) each env runner steps all its ``num_envs_per_env_runner`` arms in one Rust
call (:class:`octoarm.env.ArmReachVectorEnv`, a rayon pool of ``env_config["num_threads"]``
threads, default all cores of its node); with ``"sync"`` it steps single
:class:`octoarm.env.ArmReachEnv` (time-limited to 200 steps) one after another. ``env_config``
holds the environments' keyword arguments (``n_elements``, ``dt``, ``num_threads``, ...).
"""

from __future__ import annotations

from typing import Any, Mapping

import gymnasium as gym

from .env import EPISODE_STEPS, ArmReachEnv, ArmReachVectorEnv

ENV_NAME = "octoarm/ArmReach-v0"

__all__ = ["ENV_NAME", "make_env", "register", "ppo_config"]


def make_env(config: Mapping[str, Any]) -> gym.Env[Any, Any] | ArmReachVectorEnv:
    """RLlib's env creator: ``config`` (an ``EnvContext``) with ``num_envs`` (set by RLlib's
    env runner for its vector entry point) gives an :class:`ArmReachVectorEnv` of that many
    arms; without it, one :class:`ArmReachEnv` limited to 200 steps per episode."""
    kwargs = dict(config)
    num_envs = kwargs.pop("num_envs", None)
    if num_envs is None:
        kwargs.pop("num_threads", None)
        return gym.wrappers.TimeLimit(ArmReachEnv(**kwargs), max_episode_steps=EPISODE_STEPS)
    return ArmReachVectorEnv(num_envs=int(num_envs), **kwargs)


def register(name: str = ENV_NAME) -> str:
    """Register the environment with RLlib under ``name``; returns the name (for
    ``AlgorithmConfig.environment``)."""
    from ray.tune.registry import register_env

    register_env(name, make_env)
    return name


def ppo_config(
    num_envs_per_env_runner: int = 8,
    num_env_runners: int = 0,
    env_config: Mapping[str, Any] | None = None,
    vectorize_mode: str = "vector_entry_point",
) -> Any:
    """A ``PPOConfig`` (torch) on the registered environment: ``num_env_runners`` env-runner
    actors (0: sampling in the driver's process), each stepping ``num_envs_per_env_runner``
    arms in Rust (``vectorize_mode="vector_entry_point"``) or through Gymnasium's ``"sync"``
    vectorisation. Adjust training settings on the returned config."""
    from ray.rllib.algorithms.ppo import PPOConfig

    return (
        PPOConfig()
        .environment(register(), env_config=dict(env_config or {}))
        .framework("torch")
        .env_runners(
            num_env_runners=num_env_runners,
            num_envs_per_env_runner=num_envs_per_env_runner,
            gym_env_vectorize_mode=vectorize_mode,
        )
    )
