"""Stable-Baselines3 adapter: :class:`RustVecEnv`, an SB3 ``VecEnv`` over the Rust vector
environment (``num_envs`` arms stepped in parallel by Rust threads, one Python call per step).

Importable only when Stable-Baselines3 is installed (``pip install stable-baselines3``, or
``pip install "octoarm[examples]"``)::

    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecMonitor
    from octoarm.sb3 import RustVecEnv

    env = VecMonitor(RustVecEnv(num_envs=8))
    env.seed(0)
    PPO("MlpPolicy", env).learn(100_000)

It follows SB3's conventions: same-step autoreset (the observation returned for a finished arm
is the first of its next episode; the last one is in ``infos[i]["terminal_observation"]``),
``dones = terminated | truncated``, ``infos[i]["TimeLimit.truncated"]``, float32 rewards, seeds
from ``seed()`` and options from ``set_options()`` applied at the next ``reset()``. With the
same seed it gives the same observations, rewards, dones and terminal observations, bit for
bit, as SB3's ``DummyVecEnv`` of ``octoarm/ArmReach-v0`` built by
``make_vec_env("octoarm/ArmReach-v0", n_envs, seed=seed)`` (arm i is seeded with seed + i),
only faster. Per arm ``infos[i]`` also holds ``tip_distance`` [m] and, when the stability guard
stopped that arm (its episode then ends, ``TimeLimit.truncated``), ``unstable``: the guard's
message. Add episode statistics with SB3's ``VecMonitor``.
"""

from __future__ import annotations

from typing import Any, Sequence

import numpy as np

try:
    import gymnasium as gym
    from stable_baselines3.common.vec_env.base_vec_env import (  # type: ignore[import-not-found, unused-ignore]
        VecEnv,
        VecEnvIndices,
        VecEnvObs,
        VecEnvStepReturn,
    )
except ImportError as e:  # pragma: no cover - exercised without SB3 installed
    raise ImportError(
        "octoarm.sb3 needs Stable-Baselines3: pip install stable-baselines3 "
        '(or pip install "octoarm[examples]")'
    ) from e

from ._octoarm import Simulation
from .env import EPISODE_STEPS, ArmReachVectorEnv, FloatArray, _check_options, _real_array

__all__ = ["RustVecEnv"]


# (Without SB3 installed, mypy sees VecEnv as Any.)
class RustVecEnv(VecEnv):  # type: ignore[misc, unused-ignore]
    """SB3 ``VecEnv`` of ``num_envs`` reaching arms stepped in Rust (see the module docstring).

    Arguments: ``num_envs``, ``num_threads`` (Rust worker threads; default all cores; results
    do not depend on it), ``max_episode_steps`` (default 200, as ``octoarm/ArmReach-v0``) and
    the keyword arguments of :class:`octoarm.ArmBatch` (``n_elements``, ``n_segments``, ...).
    ``set_options({"target": [x, y]})`` (or a list of such dicts, one per arm) sets the targets
    of the next ``reset()``. ``render_mode="rgb_array"`` (with ``render_width``,
    ``render_height``) makes ``get_images()`` / ``render()`` return the arms' frames, so SB3's
    ``VecVideoRecorder`` works.
    """

    def __init__(
        self,
        num_envs: int = 8,
        num_threads: int | None = None,
        max_episode_steps: int = EPISODE_STEPS,
        **config: Any,
    ) -> None:
        self.venv = ArmReachVectorEnv(
            num_envs=num_envs,
            num_threads=num_threads,
            max_episode_steps=max_episode_steps,
            **config,
        )
        self._actions: Any = None
        super().__init__(
            num_envs, self.venv.single_observation_space, self.venv.single_action_space
        )

    def reset(self) -> VecEnvObs:
        targets: list[FloatArray | None] = []
        for i, options in enumerate(self._options):
            options = _check_options(options, ["target"])
            target = options.get("target")
            targets.append(None if target is None else _real_array(target, f"options[{i}]['target']", (2,)))
        obs = self.venv._reset_arms(range(self.num_envs), self._seeds, targets)
        self.reset_infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        self._reset_seeds()
        self._reset_options()
        self._actions = None
        return obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() called without step_async(actions)")
        actions, self._actions = self._actions, None
        obs, reward, distance, failures = self.venv._step_arms(actions)
        unstable = np.array([f is not None for f in failures])
        success = self.venv._task.success(distance)
        truncated = (self.venv._elapsed >= self.venv.max_episode_steps) | unstable
        dones = truncated.copy()  # never terminated
        infos: list[dict[str, Any]] = []
        for i in range(self.num_envs):
            info: dict[str, Any] = {
                "tip_distance": float(distance[i]),
                "is_success": bool(success[i]),
            }
            if failures[i] is not None:
                info["unstable"] = failures[i]
            info["TimeLimit.truncated"] = bool(truncated[i])
            infos.append(info)
        if dones.any():
            idx = [int(i) for i in np.flatnonzero(dones)]
            for i in idx:
                infos[i]["terminal_observation"] = obs[i].copy()
                self.reset_infos[i] = {}
            obs = self.venv._reset_arms(idx, [None] * len(idx), [None] * len(idx))
        return obs.copy(), reward.astype(np.float32), dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        """The attribute of the (shared) vector environment, once per index."""
        value = getattr(self.venv, attr_name)
        return [value for _ in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        """Set an attribute of the vector environment: it is shared by every arm, so
        ``indices`` must be None or name every arm."""
        if indices is not None and sorted(self._get_indices(indices)) != list(range(self.num_envs)):
            raise ValueError(
                "RustVecEnv's arms share one environment: set_attr applies to every arm "
                "(indices=None)"
            )
        setattr(self.venv, attr_name, value)

    def env_method(
        self,
        method_name: str,
        *method_args: Any,
        indices: VecEnvIndices = None,
        **method_kwargs: Any,
    ) -> list[Any]:
        """Per-arm methods: ``simulation`` (a copy of each arm as an
        :class:`octoarm.Simulation`) and ``render`` (with ``render_mode="rgb_array"`` the arm's
        (H, W, 3) uint8 image, else None)."""
        idx = list(self._get_indices(indices))
        if method_name == "simulation":
            return [self.simulation(i) for i in idx]
        if method_name == "render":
            frames = self.venv.render()
            return [None if frames is None else frames[i] for i in idx]
        raise AttributeError(
            f"RustVecEnv has no per-arm method {method_name!r}; its arms have 'simulation' "
            "and 'render'"
        )

    def env_is_wrapped(
        self, wrapper_class: type[gym.Wrapper[Any, Any, Any, Any]], indices: VecEnvIndices = None
    ) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    def get_images(self) -> Sequence[np.ndarray | None]:
        """One (H, W, 3) uint8 image per arm with ``render_mode="rgb_array"`` (what SB3's
        ``render()`` tiles and ``VecVideoRecorder`` records), else None per arm."""
        frames = self.venv.render()
        if frames is None:
            return [None for _ in range(self.num_envs)]
        return list(frames)

    def simulation(self, index: int) -> Simulation:
        """A copy of arm ``index`` as an :class:`octoarm.Simulation`."""
        return self.venv.simulation(index)
