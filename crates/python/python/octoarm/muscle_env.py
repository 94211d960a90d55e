"""Gymnasium environment of COOMM's muscular octopus arm reaching a pose in 3D.

``MuscleReach3DEnv`` (id ``octoarm/MuscleReach3D-v0``): COOMM's arm (muscles-3d spec §1: 0.2 m,
tapered 24 -> 2.4 mm, E = 10 kPa, clamped at the origin along +x with d1 = -e_z) discretised
with **20 elements** (``n_elements``), its seven muscle groups (thirteen fibres: TM, LM0..LM3,
OM+, OM-; cubic force-length curve), Morison drag in water and the ``coomm`` damping preset
(spec §3), time step 50 us. No gravity (COOMM's arm is neutrally buoyant).

* **Action** (``7 * n_segments`` = 28 floats in [0, 1]): the seven group activations per
  segment, group-major: ``action[g * n_segments + s]`` is group g (``octoarm.MUSCLE_GROUPS[g]``)
  on segment s. The arm is split into ``n_segments`` = 4 equal segments; element j belongs to
  segment ``j * n_segments // n_elements``. The muscles' activations follow the command with a
  first-order lag of time constant ``activation_time`` (50 ms), updated every time step (a
  step change of full activation would shock the thin tip). An action holds for one **control
  period of 50 ms** (1000 steps). Actions outside [0, 1] are clipped; an action must have
  exactly the action space's shape and finite entries (``ValueError`` names the shape or the
  entry otherwise).
* **Observation** (float32, ``6 (n + 1) + 24 + 14 n_segments`` = 206 values by default), every
  component dimensionless, with finite bounds (``observation_space``) that it never leaves:

  ==================  ===========================  =======================  ============
  slice               component                    normalisation            bounds
  ==================  ===========================  =======================  ============
  ``[0, 3(n+1))``     node x, y, z (triples)       / L0 (0.2 m)             [-1.5, 1.5]
  next ``3(n+1)``     node velocities              / (10 L0/s = 2 m/s)      [-5, 5]
  next 9              tip frame (rows d1, d2, d3)  none                     [-1, 1]
  next 3              target point                 / L0                     [-1.5, 1.5]
  next 9              target frame (rows)          none                     [-1, 1]
  next 3              target point - tip point     / L0                     [-3, 3]
  next ``7 S``        lagged activations           none                     [0, 1]
  last ``7 S``        last (clipped) action        none                     [0, 1]
  ==================  ===========================  =======================  ============

  The tip point is the last element's midpoint and the tip frame the last element's directors
  (COOMM's tip). Values are clipped to their bounds (which only matters in pathological runs).
* **Target**: a pose (point and frame) reachable by construction: at each reset, random
  activations (each group switched on with probability 1/2, its level per segment uniform in
  [0, 1]) are drawn from the seeded ``np_random`` and the exact static equilibrium of the arm
  under them (``MuscleBatch.reachable_pose``, Newton on the discrete statics) gives the target
  tip point and frame. ``reset(options={"target": p, "orientation": Q})`` sets one instead
  (p shape (3,) [m], each coordinate within +-1.5 L0; Q (3, 3), a rotation; both needed).
* **Reward**: ``-d / L0 - orientation_weight * theta / pi - effort_weight * mean(a**2)`` with d
  the tip-point distance [m], theta = |Log(Q_tip Q*^T)| the tip-frame error [rad],
  ``orientation_weight`` = 0.1, ``effort_weight`` = 0.01.
* **Episode**: 100 steps (5 s), truncated by Gymnasium's TimeLimit; never terminated.
  ``info``: ``tip_distance`` [m], ``orientation_error`` [rad], ``is_success`` (tip within
  ``success_radius`` = 1 cm, 5 % of L0).
* **Instability**: if the stability guard stops the arm during a step, the episode ends
  (``truncated = True``, ``info["unstable"]`` the guard's message) with the observation of the
  arm at the start of that step, as in ``octoarm/ArmReach-v0``.
* ``render_mode="rgb_array"``: two orthographic views side by side (top: x right, y up; front:
  x right, z up), drawn in Rust, default 800 x 400 pixels.

``MuscleReach3DVectorEnv``: ``num_envs`` arms stepped in parallel by Rust threads (rayon,
``num_threads``), next-step autoreset. Same seeding contract as ``ArmReachVectorEnv``: arm i's
generator is seeded with ``seed + i`` as Gymnasium's ``sync`` vectorisation seeds
sub-environment i, and every target of arm i is drawn from it exactly as ``MuscleReach3DEnv``
draws it, so the results equal ``gym.make_vec("octoarm/MuscleReach3D-v0", n,
vectorization_mode="sync")``'s bit for bit, whatever ``num_threads``.
"""

from __future__ import annotations

from typing import Any, Sequence

import gymnasium as gym
import numpy as np
import numpy.typing as npt
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import VectorEnv
from gymnasium.vector.utils import batch_space

from ._octoarm import MuscleBatch, Simulation
from .env import RENDER_MODES, _check_options, _real_array

EPISODE_STEPS = 100
"""Episode length of ``octoarm/MuscleReach3D-v0``: 100 steps of 50 ms = 5 s."""
SUCCESS_RADIUS = 0.01
"""Default success radius [m] (5 % of L0)."""

Array = npt.NDArray[Any]
FloatArray = npt.NDArray[np.float64]
ObsArray = npt.NDArray[np.float32]


def _check_render(owner: str, render_mode: str | None, width: int, height: int) -> None:
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise TypeError(
            f"{owner}() got an unsupported keyword argument render_mode={render_mode!r}: "
            "octoarm's environments render only 'rgb_array': use render_mode=None or "
            "render_mode='rgb_array'"
        )
    for name, v in (("render_width", width), ("render_height", height)):
        if not isinstance(v, (int, np.integer)) or not 32 <= v <= 4096:
            raise ValueError(f"{name} = {v!r} is outside the allowed range [32, 4096]")


def _sample_activations(rng: np.random.Generator, n_segments: int) -> FloatArray:
    """Random activations (7, n_segments): each group on with probability 1/2, its level per
    segment uniform in [0, 1]."""
    on = rng.uniform(size=7) < 0.5
    level = rng.uniform(size=(7, n_segments))
    out: FloatArray = level * on[:, None]
    return out


def _target(
    batch: MuscleBatch, rng: np.random.Generator, options: dict[str, Any]
) -> tuple[FloatArray, FloatArray]:
    """The target pose of one reset: from ``options`` or drawn (see the module docstring)."""
    if "target" in options or "orientation" in options:
        if not ("target" in options and "orientation" in options):
            raise ValueError(
                "options must give both 'target' (shape (3,) [m]) and 'orientation' "
                "(shape (3, 3), a rotation), or neither"
            )
        p = _real_array(options["target"], "target", (3,))
        q = _real_array(options["orientation"], "orientation", (3, 3))
        return p, q
    p, q = batch.reachable_pose(_sample_activations(rng, batch.n_segments))
    return p, q[0]


def _spaces(batch: MuscleBatch) -> tuple[spaces.Box, spaces.Box]:
    low, high = batch.observation_bounds()
    obs = spaces.Box(low, high, dtype=np.float32)
    act = spaces.Box(0.0, 1.0, shape=(batch.action_dim,), dtype=np.float32)
    return obs, act


def _check_success_radius(r: Any, length: float) -> float:
    v = float(r)
    if not (np.isfinite(v) and 0.0 < v <= length):
        raise ValueError(
            f"success_radius = {r!r} is outside the allowed range (0, {length}] m"
        )
    return v


class MuscleReach3DEnv(gym.Env[Array, Array]):
    """One muscular arm reaching a 3D pose; see the module docstring for spaces and reward.

    Keyword arguments are those of :class:`octoarm.MuscleBatch` (``n_elements``,
    ``n_segments``, ``control_period``, ``dt``, ``activation_time``, ``effort_weight``,
    ``orientation_weight``), ``success_radius`` [m] and ``render_mode`` (None or
    ``"rgb_array"``, with ``render_width`` x ``render_height`` pixels, default 800 x 400).
    """

    metadata: dict[str, Any] = {"render_modes": RENDER_MODES, "render_fps": 20}

    def __init__(
        self,
        render_mode: str | None = None,
        render_width: int = 800,
        render_height: int = 400,
        success_radius: float = SUCCESS_RADIUS,
        **config: Any,
    ) -> None:
        _check_render("MuscleReach3DEnv", render_mode, render_width, render_height)
        self.render_mode = render_mode
        self.render_size = (int(render_height), int(render_width))
        self._batch = MuscleBatch(n_envs=1, num_threads=1, **config)
        self.success_radius = _check_success_radius(success_radius, self._batch.length)
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._batch.control_period)}
        self.observation_space, self.action_space = _spaces(self._batch)
        self.control_period: float = self._batch.control_period
        self.target: FloatArray = np.zeros(3)
        self.orientation: FloatArray = np.eye(3)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObsArray, dict[str, Any]]:
        super().reset(seed=seed)
        options = _check_options(options, ["target", "orientation"])
        self.target, self.orientation = _target(self._batch, self.np_random, options)
        obs = self._batch.reset(self.target[None, :], self.orientation[None, :, :])
        return obs[0], {}

    def step(self, action: Any) -> tuple[ObsArray, float, bool, bool, dict[str, Any]]:
        a = _real_array(action, "action", (self._batch.action_dim,))
        obs, reward, distance, theta, failures = self._batch.step(a[None, :])
        info: dict[str, Any] = {
            "tip_distance": float(distance[0]),
            "orientation_error": float(theta[0]),
            "is_success": bool(distance[0] <= self.success_radius),
        }
        unstable = failures[0] is not None
        if unstable:
            info["unstable"] = str(failures[0])
        return obs[0], float(reward[0]), False, unstable, info

    def render(self) -> npt.NDArray[np.uint8] | None:
        """With ``render_mode="rgb_array"``: top and front views of the arm and its target as an
        (H, W, 3) uint8 image; else None."""
        if self.render_mode != "rgb_array":
            return None
        h, w = self.render_size
        return self._batch.render(0, w, h)

    def simulation(self) -> Simulation:
        """A copy of the arm as an :class:`octoarm.Simulation`."""
        return self._batch.simulation(0)


class MuscleReach3DVectorEnv(VectorEnv[Array, Array, Array]):
    """``num_envs`` muscular arms stepped in parallel in Rust; next-step autoreset.

    Same spaces, observation and reward per arm as :class:`MuscleReach3DEnv`; same seeds give
    the same results as the ``sync`` vectorisation of :class:`MuscleReach3DEnv`, whatever
    ``num_threads``. ``reset(options=...)`` takes ``"target"`` and ``"orientation"`` (one pose,
    shapes (3,) and (3, 3), for every reset arm, as ``sync`` passes options to every
    sub-environment) and ``"reset_mask"`` (bool, (num_envs,)).
    """

    metadata: dict[str, Any] = {
        "render_modes": RENDER_MODES,
        "render_fps": 20,
        "autoreset_mode": "NextStep",
    }

    def __init__(
        self,
        num_envs: int = 8,
        num_threads: int | None = None,
        max_episode_steps: int = EPISODE_STEPS,
        render_mode: str | None = None,
        render_width: int = 800,
        render_height: int = 400,
        success_radius: float = SUCCESS_RADIUS,
        **config: Any,
    ) -> None:
        _check_render("MuscleReach3DVectorEnv", render_mode, render_width, render_height)
        self.render_mode = render_mode
        self.render_size = (int(render_height), int(render_width))
        if max_episode_steps < 1:
            raise ValueError(
                f"max_episode_steps = {max_episode_steps} is outside the allowed range [1, inf)"
            )
        try:
            from gymnasium.vector import AutoresetMode

            self.metadata = {**self.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        except ImportError:  # pragma: no cover
            pass
        self._batch = MuscleBatch(n_envs=num_envs, num_threads=num_threads, **config)
        self.success_radius = _check_success_radius(success_radius, self._batch.length)
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.single_observation_space, self.single_action_space = _spaces(self._batch)
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.control_period: float = self._batch.control_period
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.control_period)}
        self.targets: FloatArray = np.zeros((num_envs, 3))
        self.orientations: FloatArray = np.tile(np.eye(3), (num_envs, 1, 1))
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        self._arm_rngs: list[np.random.Generator | None] = [None] * num_envs
        self._obs: ObsArray | None = None

    def _arm_rng(self, i: int) -> np.random.Generator:
        rng = self._arm_rngs[i]
        if rng is None:
            rng, _ = seeding.np_random()
            self._arm_rngs[i] = rng
        return rng

    def _reset_arms(
        self, indices: Sequence[int], seeds: Sequence[int | None], options: dict[str, Any]
    ) -> ObsArray:
        for i, s in zip(indices, seeds):
            if s is not None:
                self._arm_rngs[i], _ = seeding.np_random(int(s))
        poses = [_target(self._batch, self._arm_rng(i), options) for i in indices]
        idx = list(indices)
        p = np.array([t for t, _ in poses], dtype=np.float64).reshape(len(idx), 3)
        q = np.array([o for _, o in poses], dtype=np.float64).reshape(len(idx), 3, 3)
        self._obs = self._batch.reset(p, q, idx)
        self.targets[idx] = p
        self.orientations[idx] = q
        self._elapsed[idx] = 0
        self._autoreset[idx] = False
        return self._obs

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[ObsArray, dict[str, Any]]:
        n = self.num_envs
        if seed is None:
            seeds: list[int | None] = [None] * n
        elif isinstance(seed, (int, np.integer)):
            seeds = [int(seed) + i for i in range(n)]
            super().reset(seed=int(seed))
        else:
            seeds = list(seed)
            if len(seeds) != n:
                raise ValueError(
                    f"seed is a list of {len(seeds)} seeds, expected one per arm (num_envs = "
                    f"{n}), an int or None"
                )
        options = _check_options(options, ["target", "orientation", "reset_mask"])
        if "reset_mask" in options:
            mask = options["reset_mask"]
            if not (isinstance(mask, np.ndarray) and mask.dtype == np.bool_ and mask.shape == (n,)):
                raise ValueError(
                    f"options['reset_mask'] must be a bool NumPy array of shape ({n},)"
                )
            if not mask.any():
                raise ValueError("options['reset_mask'] must select at least one arm")
            indices = [int(i) for i in np.flatnonzero(mask)]
        else:
            indices = list(range(n))
        pose = {k: options[k] for k in ("target", "orientation") if k in options}
        obs = self._reset_arms(indices, [seeds[i] for i in indices], pose)
        return obs.copy(), {}

    def step(
        self, actions: Any
    ) -> tuple[ObsArray, FloatArray, npt.NDArray[np.bool_], npt.NDArray[np.bool_], dict[str, Any]]:
        done = self._autoreset.copy()
        obs, reward, distance, theta, failures = self._batch.step(actions)
        self._obs = obs
        self._elapsed += 1
        if done.any():
            idx = [int(i) for i in np.flatnonzero(done)]
            obs = self._reset_arms(idx, [None] * len(idx), {})
            reward[idx] = 0.0
            distance[idx] = 0.0
            theta[idx] = 0.0
        unstable = np.array([f is not None for f in failures]) & ~done
        truncated = (self._elapsed >= self.max_episode_steps) | unstable
        truncated[done] = False
        terminated = np.zeros(self.num_envs, dtype=bool)
        self._autoreset = truncated | terminated
        info: dict[str, Any] = {}
        if not done.all():
            info["tip_distance"] = distance
            info["_tip_distance"] = ~done
            info["orientation_error"] = theta
            info["_orientation_error"] = ~done
            info["is_success"] = (distance <= self.success_radius) & ~done
            info["_is_success"] = ~done
        if unstable.any():
            messages = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(unstable):
                messages[i] = str(failures[i])
            info["unstable"] = messages
            info["_unstable"] = unstable
        return obs.copy(), reward, terminated, truncated, info

    def render(self) -> tuple[npt.NDArray[np.uint8], ...] | None:
        """With ``render_mode="rgb_array"``: one (H, W, 3) uint8 image per arm; else None."""
        if self.render_mode != "rgb_array":
            return None
        h, w = self.render_size
        return tuple(self._batch.render(i, w, h) for i in range(self.num_envs))

    def simulation(self, index: int) -> Simulation:
        """A copy of arm ``index`` as an :class:`octoarm.Simulation`."""
        return self._batch.simulation(index)
