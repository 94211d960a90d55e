"""Gymnasium environments of the planar octopus arm reaching a target.

``ArmReachEnv`` (id ``octoarm/ArmReach-v0``): one planar arm (the paper's geometry, 20 elements
by default), clamped at the origin along +x, bending in the x-y plane.

* **Action** (``n_segments`` = 4 floats in [-1, 1]): rest-curvature commands. The arm is split
  into ``n_segments`` equal segments; segment s gets the in-plane rest curvature
  ``a_s * max_curvature`` (20 1/m by default), like a muscle that shortens one side of the arm.
  An action holds for one **control period of 10 ms** (200 steps of dt = 50 us): one environment
  step = 10 ms of simulated time.
* **Observation** (float32, ``4 (n + 1) + 2 + 2 n_segments`` = 94 values by default), every
  component dimensionless, with finite bounds (``observation_space``) that it never leaves:

  ====================  =====================  =============================  ==============
  slice                 component              normalisation                  bounds
  ====================  =====================  =============================  ==============
  ``[0, 2(n+1))``       node x, y (pairs)      / L0 (L0 = 0.2 m, arm length)  [-1.5, 1.5]
  ``[2(n+1), 4(n+1))``  node vx, vy (pairs)    / (10 L0/s = 2 m/s)            [-5, 5]
  next 2                target x, y            / L0                           [-1.5, 1.5]
  next ``n_segments``   rest curvature         / max_curvature (20 1/m)       [-1, 1]
  last ``n_segments``   last (clipped) action  none                           [-1, 1]
  ====================  =====================  =============================  ==============

  The rest curvature is the actuator state: the lagged rest curvature of each segment, which
  follows ``a_s * max_curvature`` with the time constant ``activation_time`` (50 ms). Without
  it the effect of an action would depend on unobserved history. (The elements' orientations
  and angular velocities are not observed either; the arm barely shears, so they follow closely
  from the node positions and velocities.) Positions and velocities are clipped to their
  bounds, which only matters in pathological runs: the arm barely stretches (nodes stay within
  about 1.01 L0 of the base), and the fastest node seen under bang-bang commands moves at
  1.7 m/s (0.9 normalised).
* **Reward**: ``-|tip - target| [m] - effort_weight * mean(a**2)`` (effort_weight = 0.01).
* **Episode**: 200 steps (2 s), truncated by Gymnasium's TimeLimit; never terminated.
  Targets are drawn from the seeded ``np_random`` at radius 0.08-0.18 m, angle +-60 deg;
  ``reset(options={"target": [x, y]})`` sets one [m] (each coordinate within +-1.5 L0 = 0.3 m).

``ArmReachVectorEnv``: ``num_envs`` arms stepped in parallel by Rust threads (rayon,
``num_threads``; default all cores), with Gymnasium's next-step autoreset. The physics of
every arm is sequential and independent, so results do not depend on the thread count.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from ._octoarm import ArmBatch

EPISODE_STEPS = 200


def _sample_targets(rng: np.random.Generator, k: int) -> np.ndarray:
    radius = rng.uniform(0.08, 0.18, size=k)
    angle = rng.uniform(-np.pi / 3, np.pi / 3, size=k)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def _spaces(batch: ArmBatch) -> tuple[spaces.Box, spaces.Box]:
    low, high = batch.observation_bounds()
    obs = spaces.Box(low, high, dtype=np.float32)
    act = spaces.Box(-1.0, 1.0, shape=(batch.action_dim,), dtype=np.float32)
    return obs, act


class ArmReachEnv(gym.Env):
    """One planar arm reaching a target; see the module docstring for spaces and reward.

    Keyword arguments are those of :class:`octoarm.ArmBatch` (``n_elements``, ``n_segments``,
    ``max_curvature``, ``control_period``, ``dt``, ``damping_rate``, ``effort_weight``,
    ``tip_diameter``, ``activation_time``).

    Observation: node x, y / L0 in [-1.5, 1.5]; node vx, vy / (10 L0/s) in [-5, 5]; target x, y
    / L0 in [-1.5, 1.5]; lagged rest curvature per segment / max_curvature in [-1, 1]; last
    action in [-1, 1] (L0 = 0.2 m; details in the module docstring).
    """

    metadata = {"render_modes": []}

    def __init__(self, render_mode: str | None = None, **config: Any) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r} is not supported; use None")
        self._batch = ArmBatch(n_envs=1, num_threads=1, **config)
        self.observation_space, self.action_space = _spaces(self._batch)
        self.control_period = self._batch.control_period
        self.target = np.zeros(2)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        if options and "target" in options:
            self.target = np.asarray(options["target"], dtype=np.float64).reshape(2)
        else:
            self.target = _sample_targets(self.np_random, 1)[0]
        obs = self._batch.reset(self.target.reshape(1, 2))
        return obs[0], {}

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(1, -1)
        obs, reward, distance = self._batch.step(a)
        return obs[0], float(reward[0]), False, False, {"tip_distance": float(distance[0])}

    def simulation(self):
        """A copy of the arm as an :class:`octoarm.Simulation`."""
        return self._batch.simulation(0)


class ArmReachVectorEnv(VectorEnv):
    """``num_envs`` arms stepped in parallel in Rust; next-step autoreset (Gymnasium >= 1.0).

    Same spaces, observation and reward per arm as :class:`ArmReachEnv`; observations are
    (num_envs, obs_dim) float32.
    """

    metadata = {"render_modes": [], "autoreset_mode": "NextStep"}

    def __init__(
        self,
        num_envs: int = 8,
        num_threads: int | None = None,
        max_episode_steps: int = EPISODE_STEPS,
        render_mode: str | None = None,
        **config: Any,
    ) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode = {render_mode!r} is not supported; use None")
        if max_episode_steps < 1:
            raise ValueError(
                f"max_episode_steps = {max_episode_steps} is outside the allowed range [1, inf)"
            )
        try:  # Gymnasium >= 1.1 names the mode with an enum
            from gymnasium.vector import AutoresetMode

            self.metadata = {**self.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        except ImportError:  # pragma: no cover
            pass
        self._batch = ArmBatch(n_envs=num_envs, num_threads=num_threads, **config)
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.single_observation_space, self.single_action_space = _spaces(self._batch)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.control_period = self._batch.control_period
        self.targets = np.zeros((num_envs, 2))
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._np_random = None

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self.targets = _sample_targets(self.np_random, self.num_envs)
        self._elapsed[:] = 0
        self._autoreset[:] = False
        return self._batch.reset(self.targets), {}

    def step(self, actions):
        a = np.asarray(actions, dtype=np.float64).reshape(self.num_envs, -1)
        obs, reward, distance = self._batch.step(a)
        self._elapsed += 1
        done = self._autoreset
        if done.any():
            idx = np.flatnonzero(done)
            self.targets[idx] = _sample_targets(self.np_random, idx.size)
            obs = self._batch.reset(self.targets[idx], [int(i) for i in idx])
            reward[idx] = 0.0
            self._elapsed[idx] = 0
        truncated = self._elapsed >= self.max_episode_steps
        terminated = np.zeros(self.num_envs, dtype=bool)
        self._autoreset = truncated.copy()
        return obs, reward, terminated, truncated, {"tip_distance": distance}
