"""Gymnasium environments of the planar octopus arm reaching a target.

``ArmReachEnv`` (id ``octoarm/ArmReach-v0``): one planar arm (the paper's geometry, 20 elements
by default), clamped at the origin along +x, bending in the x-y plane.

* **Action** (``n_segments`` = 4 floats in [-1, 1]): rest-curvature commands. The arm is split
  into ``n_segments`` equal segments; segment s gets the in-plane rest curvature
  ``a_s * max_curvature`` (20 1/m by default), like a muscle that shortens one side of the arm.
  An action holds for one **control period of 10 ms** (200 steps of dt = 50 us): one environment
  step = 10 ms of simulated time. Actions outside [-1, 1] are clipped. An action must have
  exactly the action space's shape (never reshaped) and finite entries; any real dtype is
  converted to float64. Otherwise ``ValueError`` names the expected shape, or the entry that is
  NaN or infinite.
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
  ``reset(options={"target": [x, y]})`` sets one [m] (shape (2,), each coordinate within
  +-1.5 L0 = 0.3 m) for that reset only.
* **Instability**: if the stability guard stops the arm during a step, the episode ends:
  ``truncated = True`` and ``info["unstable"]`` holds the guard's message; the observation,
  reward and ``info["tip_distance"]`` are those of the arm at the start of that step (the last
  state the guard passed). Reset before stepping again.

**Task options** (keyword arguments of both environments; ``octoarm/ArmReach-v1`` sets
``reward="reach", observe_error=True, action="increment", targets="reachable",
control_period=0.05, damping_rate=5``; v0 keeps the defaults):

* ``reward``: ``"distance"`` (the v0 reward above) or ``"reach"``, a reward whose last
  millimetres carry signal: ``r = -d / L0 + exp(-d / 1 cm) - effort_weight * mean(a**2)``
  (d the tip distance [m]; the exponential success bonus is 1 at the target, 0.37 at 1 cm).
* ``control_period`` (an ``ArmBatch`` argument, 10 ms in v0): v1 acts every 50 ms, 40 steps per
  2 s episode: fewer, larger decisions (the arm's muscle lag is 50 ms anyway), which shortens
  the credit-assignment horizon five-fold.
* ``observe_error``: append ``(target - tip) / L0`` (2 values, clipped to [-3, 3]) to the
  observation: the quantity a reaching policy acts on, given directly.
* ``action``: ``"absolute"`` (the action is the command, as above) or ``"increment"``: the
  action moves the command, ``cmd <- clip(cmd + 0.1 * clip(a, -1, 1), -1, 1)``, starting from
  0 at reset; the command is what the arm receives, the effort term and the "last action"
  slots of the observation hold it. A policy can then hold a pose with a = 0.
* ``targets``: ``"sector"`` (v0: radius 0.08-0.18 m, angle +-60 deg) or ``"reachable"``: the
  tip of the arm's rest shape under a command drawn uniformly from [-0.9, 0.9] per segment
  (``ArmBatch.rest_tips``), so every target can be reached exactly by holding a command inside
  the action range. About a third of the sector's targets cannot be reached within 1 cm by any
  command of 4 segments at 20 1/m (a static optimisation over commands finds 64 % within 1 cm):
  no policy could reach 80 % of them.
* ``damping_rate`` (an ``ArmBatch`` argument, 10 1/s in v0): v1 uses 5 1/s. At 10 1/s the first
  bending mode is overdamped and creeps: holding the exact command of a reachable target from
  rest leaves the tip 1.8 cm away (median) after 2 s; at 5 1/s (near critical), ramping the
  command there at the increment limit leaves it 1 mm away (median; all within 5 mm), so a 2 s
  episode can end at the target.
* ``success_radius`` [m] (default 0.01 = 5 % of L0): ``info["is_success"]`` is
  ``tip_distance <= success_radius`` after every step (SB3 counts it at episode end).

``ArmReachGoalEnv`` (id ``octoarm/ArmReachGoal-v1``): the goal-conditioned twin for
hindsight experience replay (SB3's ``HerReplayBuffer``): a ``Dict`` observation with
``observation`` (the arm: nodes, velocities, rest curvatures, commands; the target is not in
it), ``achieved_goal`` (tip x, y / L0) and ``desired_goal`` (target x, y / L0), float32; the
reward is ``compute_reward(achieved_goal, desired_goal, info)``: ``-d / L0 + exp(-d / 1 cm)``
(no effort term, so that relabelled goals get exactly the reward the environment gave).

``ArmReachVectorEnv``: ``num_envs`` arms stepped in parallel by Rust threads (rayon,
``num_threads``; default all cores), with Gymnasium's next-step autoreset. The physics of
every arm is sequential and independent, so results do not depend on the thread count.

It gives the same results as Gymnasium's ``sync`` vectorisation of ``ArmReachEnv``
(``gym.make_vec("octoarm/ArmReach-v0", n, vectorization_mode="sync")``), bit for bit:
``reset(seed=s)`` seeds arm i's generator with ``s + i`` (a list of seeds gives one per arm),
as ``SyncVectorEnv`` seeds sub-environment i, and every target of arm i (first and autoreset
ones) is drawn from arm i's generator exactly as ``ArmReachEnv`` draws it. So the same seed
gives the same targets, observations, rewards, ``truncated`` flags and infos
(``tip_distance`` with its ``_tip_distance`` mask, ``unstable`` with ``_unstable``) in both
modes. ``reset(options=...)`` takes ``"target"``: shape (2,) for every arm (as ``sync`` passes
the options to every sub-environment) or (num_envs, 2), one per arm; and ``"reset_mask"``
(bool, (num_envs,)): reset only those arms. One unstable arm ends only its own episode
(``truncated[i]``, ``info["unstable"][i]``); the others continue.
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

from ._octoarm import ArmBatch, Simulation

EPISODE_STEPS = 200

Array = npt.NDArray[Any]
FloatArray = npt.NDArray[np.float64]
ObsArray = npt.NDArray[np.float32]


def _sample_targets(rng: np.random.Generator, k: int) -> FloatArray:
    radius = rng.uniform(0.08, 0.18, size=k)
    angle = rng.uniform(-np.pi / 3, np.pi / 3, size=k)
    return np.stack([radius * np.cos(angle), radius * np.sin(angle)], axis=1)


def _spaces(batch: ArmBatch) -> tuple[spaces.Box, spaces.Box]:
    low, high = batch.observation_bounds()
    obs = spaces.Box(low, high, dtype=np.float32)
    act = spaces.Box(-1.0, 1.0, shape=(batch.action_dim,), dtype=np.float32)
    return obs, act


RENDER_MODES = ["rgb_array"]
"""Render modes of the environments: ``"rgb_array"``, an (H, W, 3) uint8 image drawn in Rust."""


def _check_render(owner: str, render_mode: str | None, width: int, height: int) -> None:
    # TypeError for an unsupported mode, as for any unsupported keyword argument:
    # Stable-Baselines3's make_vec_env tries render_mode="rgb_array" and falls back to no
    # render_mode on TypeError only.
    if render_mode is not None and render_mode not in RENDER_MODES:
        raise TypeError(
            f"{owner}() got an unsupported keyword argument render_mode={render_mode!r}: "
            "octoarm's environments render only 'rgb_array': use render_mode=None or "
            "render_mode='rgb_array'"
        )
    for name, v in (("render_width", width), ("render_height", height)):
        if not isinstance(v, (int, np.integer)) or not 16 <= v <= 4096:
            raise ValueError(f"{name} = {v!r} is outside the allowed range [16, 4096]")


def _shape(shape: Sequence[int]) -> str:
    return f"({shape[0]},)" if len(shape) == 1 else "(" + ", ".join(map(str, shape)) + ")"


def _real_array(value: Any, name: str, shape: tuple[int, ...]) -> FloatArray:
    """``value`` as a float64 array of exactly ``shape`` with finite entries (never reshaped);
    any real dtype is converted. ``ValueError`` names ``name`` and the expected shape, or the
    entry that is not finite."""
    try:
        a = np.asarray(value)
    except Exception as e:  # e.g. ragged nested lists
        raise ValueError(f"{name} is not an array of numbers: {e}") from None
    if a.dtype.kind not in "fiuO":
        raise ValueError(
            f"{name} has dtype {a.dtype}; expected real numbers (any float or integer dtype, "
            "converted to float64)"
        )
    try:
        a = a.astype(np.float64)
    except (TypeError, ValueError) as e:
        raise ValueError(f"{name} is not an array of numbers: {e}") from None
    if a.shape != shape:
        raise ValueError(f"{name} has shape {_shape(a.shape)}, expected {_shape(shape)}")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        index = tuple(int(i) for i in bad[0])
        v = float(a[index])
        text = "NaN" if np.isnan(v) else ("inf" if v > 0 else "-inf")
        raise ValueError(
            f"{name} must be finite: entry [{', '.join(map(str, index))}] is {text}"
        )
    return a


def _check_options(options: dict[str, Any] | None, allowed: Sequence[str]) -> dict[str, Any]:
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise TypeError(f"options must be a dict or None, not {type(options).__name__}")
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ValueError(
            f"options has unknown key(s) {', '.join(map(repr, unknown))}; allowed: "
            + ", ".join(map(repr, allowed))
        )
    return options


V1_TASK: dict[str, Any] = {
    "reward": "reach",
    "observe_error": True,
    "action": "increment",
    "targets": "reachable",
    "control_period": 0.05,
    "damping_rate": 5.0,
}
"""Keyword arguments of ``octoarm/ArmReach-v1``: the reach reward, the error observed,
incremental commands, reachable targets, one environment step = 50 ms, damping near critical
for the first bending mode (the arm settles within the 2 s episode)."""
V1_EPISODE_STEPS = 40
"""Episode length of the v1 environments: 40 steps of 50 ms = 2 s, as v0's 200 of 10 ms."""

REWARDS = ("distance", "reach")
TARGETS = ("sector", "reachable")
TARGET_COMMAND = 0.9
"""``targets="reachable"``: targets are the rest-shape tips of commands drawn uniformly from
``[-TARGET_COMMAND, TARGET_COMMAND]`` per segment (a 10 % margin inside the command range)."""
ACTIONS = ("absolute", "increment")
INCREMENT = 0.1
"""Largest change of a command per environment step with ``action="increment"``."""
ERROR_BOUND = 3.0
SUCCESS_SCALE = 0.01
"""Length scale [m] of the success bonus ``exp(-d / SUCCESS_SCALE)`` of ``reward="reach"``."""


def reach_reward(distance: Any, length: float) -> Any:
    """``-d / L0 + exp(-d / 1 cm)`` for tip distances ``d`` [m] (scalar or array)."""
    d = np.asarray(distance, dtype=np.float64)
    return -d / length + np.exp(-d / SUCCESS_SCALE)


class _Task:
    """What the agent sees, does and is paid on top of the Rust arms (``ArmBatch``): the
    reward, the optional error observation, absolute or incremental commands. Holds each arm's
    command for ``action="increment"``."""

    def __init__(
        self,
        batch: ArmBatch,
        reward: str,
        observe_error: bool,
        action: str,
        success_radius: float,
        effort_weight: float,
        targets: str = "sector",
    ) -> None:
        if targets not in TARGETS:
            raise ValueError(
                f"targets = {targets!r} is not one of {', '.join(map(repr, TARGETS))}"
            )
        if reward not in REWARDS:
            raise ValueError(f"reward = {reward!r} is not one of {', '.join(map(repr, REWARDS))}")
        if action not in ACTIONS:
            raise ValueError(f"action = {action!r} is not one of {', '.join(map(repr, ACTIONS))}")
        if not isinstance(observe_error, (bool, np.bool_)):
            raise ValueError(f"observe_error = {observe_error!r} must be True or False")
        r = float(success_radius)
        if not (np.isfinite(r) and 0.0 < r <= batch.length):
            raise ValueError(
                f"success_radius = {success_radius!r} is outside the allowed range "
                f"(0, {batch.length}] m"
            )
        self.batch = batch
        self.targets = targets
        self.reward = reward
        self.observe_error = bool(observe_error)
        self.action = action
        self.success_radius = r
        self.effort_weight = float(effort_weight)
        self.length = batch.length
        self.n_nodes = (batch.obs_dim - 2 - 2 * batch.action_dim) // 4
        self.command = np.zeros((batch.n_envs, batch.action_dim))

    def spaces(self, batch: ArmBatch) -> tuple[spaces.Box, spaces.Box]:
        obs, act = _spaces(batch)
        if self.observe_error:
            low = np.concatenate([obs.low, np.full(2, -ERROR_BOUND, dtype=np.float32)])
            high = np.concatenate([obs.high, np.full(2, ERROR_BOUND, dtype=np.float32)])
            obs = spaces.Box(low, high, dtype=np.float32)
        return obs, act

    def tip(self, obs: ObsArray) -> FloatArray:
        """Tip x, y [m] of each row of Rust observations (nodes are first, / L0)."""
        n = self.n_nodes
        return obs[:, 2 * (n - 1) : 2 * n].astype(np.float64) * self.length

    def target(self, obs: ObsArray) -> FloatArray:
        n = self.n_nodes
        return obs[:, 4 * n : 4 * n + 2].astype(np.float64) * self.length

    def observe(self, obs: ObsArray) -> ObsArray:
        if not self.observe_error:
            return obs
        n = self.n_nodes
        err = obs[:, 4 * n : 4 * n + 2] - obs[:, 2 * (n - 1) : 2 * n]
        err = np.clip(err, -ERROR_BOUND, ERROR_BOUND).astype(np.float32)
        return np.concatenate([obs, err], axis=1)

    def sample_targets(self, rng: np.random.Generator, k: int) -> FloatArray:
        """``k`` targets [m] drawn from ``rng``: in the sector (radius 0.08-0.18 m, angle
        +-60 deg; v0), or the rest-shape tips of random commands (``"reachable"``)."""
        if self.targets == "sector":
            return _sample_targets(rng, k)
        cmd = rng.uniform(-TARGET_COMMAND, TARGET_COMMAND, size=(k, self.command.shape[1]))
        return np.asarray(self.batch.rest_tips(cmd))

    def reset(self, indices: Sequence[int]) -> None:
        self.command[list(indices)] = 0.0

    def commands(self, actions: Any, name: str, n: int) -> Any:
        """The commands the arms receive for ``actions``: with absolute actions, ``actions``
        itself (``ArmBatch.step`` checks it); else the moved commands (checked here, named
        ``name``, shape (n, action_dim))."""
        if self.action == "absolute":
            return actions
        actions = _real_array(actions, name, (n, self.command.shape[1]))
        self.command = np.clip(
            self.command + INCREMENT * np.clip(actions, -1.0, 1.0), -1.0, 1.0
        )
        return self.command.copy()

    def rewards(self, rust_reward: FloatArray, distance: FloatArray, cmd: FloatArray) -> FloatArray:
        if self.reward == "distance":
            return rust_reward
        # (After ArmBatch.step accepted cmd, it converts to float64 of the right shape.)
        effort = np.mean(np.clip(np.asarray(cmd, dtype=np.float64), -1.0, 1.0) ** 2, axis=1)
        out: FloatArray = reach_reward(distance, self.length) - self.effort_weight * effort
        return out

    def success(self, distance: FloatArray) -> npt.NDArray[np.bool_]:
        return np.asarray(distance <= self.success_radius)


def _task_args(config: dict[str, Any]) -> dict[str, Any]:
    """Split the task options out of ``config`` (the rest goes to ``ArmBatch``)."""
    return {
        "reward": config.pop("reward", "distance"),
        "observe_error": config.pop("observe_error", False),
        "action": config.pop("action", "absolute"),
        "success_radius": config.pop("success_radius", 0.01),
        "targets": config.pop("targets", "sector"),
        "effort_weight": config.get("effort_weight", 0.01),
    }


class ArmReachEnv(gym.Env[Array, Array]):
    """One planar arm reaching a target; see the module docstring for spaces and reward.

    Keyword arguments are those of :class:`octoarm.ArmBatch` (``n_elements``, ``n_segments``,
    ``max_curvature``, ``control_period``, ``dt``, ``damping_rate``, ``effort_weight``,
    ``tip_diameter``, ``activation_time``), plus ``render_mode`` (None or ``"rgb_array"``:
    :meth:`render` returns an (render_height, render_width, 3) uint8 image of the arm and its
    target, drawn in Rust without a display; default 400 x 400 pixels); any other render mode
    or keyword raises ``TypeError``.

    Observation: node x, y / L0 in [-1.5, 1.5]; node vx, vy / (10 L0/s) in [-5, 5]; target x, y
    / L0 in [-1.5, 1.5]; lagged rest curvature per segment / max_curvature in [-1, 1]; last
    action in [-1, 1] (L0 = 0.2 m; details in the module docstring).
    """

    metadata: dict[str, Any] = {"render_modes": RENDER_MODES, "render_fps": 100}

    def __init__(
        self,
        render_mode: str | None = None,
        render_width: int = 400,
        render_height: int = 400,
        **config: Any,
    ) -> None:
        _check_render("ArmReachEnv", render_mode, render_width, render_height)
        self.render_mode = render_mode
        self.render_size = (int(render_height), int(render_width))
        task = _task_args(config)
        self._batch = ArmBatch(n_envs=1, num_threads=1, **config)
        self._task = _Task(self._batch, **task)
        # Frames per second of a video in real time: one frame per control period.
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self._batch.control_period)}
        self.observation_space, self.action_space = self._task.spaces(self._batch)
        self.control_period: float = self._batch.control_period
        self.target: FloatArray = np.zeros(2)

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[ObsArray, dict[str, Any]]:
        super().reset(seed=seed)
        options = _check_options(options, ["target"])
        if "target" in options:
            self.target = _real_array(options["target"], "target", (2,))
        else:
            self.target = self._task.sample_targets(self.np_random, 1)[0]
        self._task.reset([0])
        obs = self._task.observe(self._batch.reset(self.target[None, :]))
        return obs[0], {}

    def step(self, action: Any) -> tuple[ObsArray, float, bool, bool, dict[str, Any]]:
        a = _real_array(action, "action", (self._batch.action_dim,))
        cmd = self._task.commands(a[None, :], "action", 1)
        obs, reward, distance, failures = self._batch.step(cmd)
        obs = self._task.observe(obs)
        reward = self._task.rewards(reward, distance, cmd)
        info: dict[str, Any] = {
            "tip_distance": float(distance[0]),
            "is_success": bool(self._task.success(distance)[0]),
        }
        unstable = failures[0] is not None
        if unstable:
            info["unstable"] = str(failures[0])
        return obs[0], float(reward[0]), False, unstable, info

    def render(self) -> npt.NDArray[np.uint8] | None:
        """With ``render_mode="rgb_array"``: the arm, its target and the clamp as an
        (H, W, 3) uint8 image (x right, y up, a fixed +-0.22 m window, 5 cm grid); else None."""
        if self.render_mode != "rgb_array":
            return None
        h, w = self.render_size
        return self._batch.render(0, w, h)

    def simulation(self) -> Simulation:
        """A copy of the arm as an :class:`octoarm.Simulation`."""
        return self._batch.simulation(0)


class ArmReachVectorEnv(VectorEnv[Array, Array, Array]):
    """``num_envs`` arms stepped in parallel in Rust; next-step autoreset (Gymnasium >= 1.0).

    Same spaces, observation and reward per arm as :class:`ArmReachEnv`; observations are
    (num_envs, obs_dim) float32, actions (num_envs, n_segments) (exactly that shape, finite,
    any real dtype). Same seeds give the same results as the ``sync`` vectorisation of
    :class:`ArmReachEnv` (see the module docstring), whatever ``num_threads``.
    """

    metadata: dict[str, Any] = {
        "render_modes": RENDER_MODES,
        "render_fps": 100,
        "autoreset_mode": "NextStep",
    }

    def __init__(
        self,
        num_envs: int = 8,
        num_threads: int | None = None,
        max_episode_steps: int = EPISODE_STEPS,
        render_mode: str | None = None,
        render_width: int = 400,
        render_height: int = 400,
        **config: Any,
    ) -> None:
        _check_render("ArmReachVectorEnv", render_mode, render_width, render_height)
        self.render_mode = render_mode
        self.render_size = (int(render_height), int(render_width))
        if max_episode_steps < 1:
            raise ValueError(
                f"max_episode_steps = {max_episode_steps} is outside the allowed range [1, inf)"
            )
        try:  # Gymnasium >= 1.1 names the mode with an enum
            from gymnasium.vector import AutoresetMode

            self.metadata = {**self.metadata, "autoreset_mode": AutoresetMode.NEXT_STEP}
        except ImportError:  # pragma: no cover
            pass
        task = _task_args(config)
        self._batch = ArmBatch(n_envs=num_envs, num_threads=num_threads, **config)
        self._task = _Task(self._batch, **task)
        self.num_envs = num_envs
        self.max_episode_steps = max_episode_steps
        self.single_observation_space, self.single_action_space = self._task.spaces(
            self._batch
        )
        self.observation_space = batch_space(self.single_observation_space, num_envs)
        self.action_space = batch_space(self.single_action_space, num_envs)
        self.control_period: float = self._batch.control_period
        self.metadata = {**self.metadata, "render_fps": round(1.0 / self.control_period)}
        self.targets: FloatArray = np.zeros((num_envs, 2))
        self._elapsed = np.zeros(num_envs, dtype=np.int64)
        self._autoreset = np.zeros(num_envs, dtype=bool)
        # One generator per arm, as each sub-environment of SyncVectorEnv has its own.
        self._arm_rngs: list[np.random.Generator | None] = [None] * num_envs
        self._obs: ObsArray | None = None

    # -- shared by reset, the autoreset and the Stable-Baselines3 adapter --------------------

    def _arm_seeds(self, seed: int | Sequence[int | None] | None) -> list[int | None]:
        if seed is None:
            return [None] * self.num_envs
        if isinstance(seed, (int, np.integer)):
            return [int(seed) + i for i in range(self.num_envs)]
        seeds = list(seed)
        if len(seeds) != self.num_envs:
            raise ValueError(
                f"seed is a list of {len(seeds)} seeds, expected one per arm (num_envs = "
                f"{self.num_envs}), an int or None"
            )
        return seeds

    def _arm_rng(self, i: int) -> np.random.Generator:
        rng = self._arm_rngs[i]
        if rng is None:  # as gym.Env.np_random: seeded from entropy on first use
            rng, _ = seeding.np_random()
            self._arm_rngs[i] = rng
        return rng

    def _reset_arms(
        self,
        indices: Sequence[int],
        seeds: Sequence[int | None],
        targets: Sequence[FloatArray | None],
    ) -> ObsArray:
        """Reset arms ``indices``: arm i's generator is reseeded if its seed is not None; its
        target is the given one, or else drawn from its generator (as ``ArmReachEnv.reset``)."""
        for i, s in zip(indices, seeds):
            if s is not None:
                self._arm_rngs[i], _ = seeding.np_random(int(s))
        rows = []
        for i, t in zip(indices, targets):
            rows.append(t if t is not None else self._task.sample_targets(self._arm_rng(i), 1)[0])
        idx = list(indices)
        if idx:
            new = np.array(rows, dtype=np.float64).reshape(len(idx), 2)
            self._task.reset(idx)
            self._obs = self._task.observe(self._batch.reset(new, idx))
            self.targets[idx] = new
            self._elapsed[idx] = 0
            self._autoreset[idx] = False
        assert self._obs is not None
        return self._obs

    def _step_arms(
        self, actions: Any
    ) -> tuple[ObsArray, FloatArray, FloatArray, list[str | None]]:
        """Step every arm without autoreset: (obs, rewards, tip distances, the guard's message
        or None per arm). Counts the step in each arm's episode."""
        cmd = self._task.commands(actions, "actions", self.num_envs)
        obs, reward, distance, failures = self._batch.step(cmd)
        obs = self._task.observe(obs)
        reward = self._task.rewards(reward, distance, cmd)
        self._obs = obs
        self._elapsed += 1
        return obs, reward, distance, [None if f is None else str(f) for f in failures]

    # -- Gymnasium API ----------------------------------------------------------------------

    def reset(
        self,
        *,
        seed: int | Sequence[int | None] | None = None,
        options: dict[str, Any] | None = None,
    ) -> tuple[ObsArray, dict[str, Any]]:
        seeds = self._arm_seeds(seed)
        if isinstance(seed, (int, np.integer)):
            super().reset(seed=int(seed))  # the vector env's own np_random (not used for targets)
        options = _check_options(options, ["target", "reset_mask"])
        n = self.num_envs
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
        targets: list[FloatArray | None] = [None] * len(indices)
        if "target" in options:
            t = np.asarray(options["target"])
            if t.ndim == 2:
                all_targets = _real_array(t, "target", (n, 2))
                targets = [all_targets[i] for i in indices]
            else:
                one = _real_array(t, "target", (2,))
                targets = [one] * len(indices)
        obs = self._reset_arms(indices, [seeds[i] for i in indices], targets)
        return obs.copy(), {}

    def step(
        self, actions: Any
    ) -> tuple[ObsArray, FloatArray, npt.NDArray[np.bool_], npt.NDArray[np.bool_], dict[str, Any]]:
        done = self._autoreset.copy()
        obs, reward, distance, failures = self._step_arms(actions)
        if done.any():  # next-step autoreset: these arms start a new episode instead
            idx = [int(i) for i in np.flatnonzero(done)]
            obs = self._reset_arms(idx, [None] * len(idx), [None] * len(idx))
            reward[idx] = 0.0
            distance[idx] = 0.0
        unstable = np.array([f is not None for f in failures]) & ~done
        truncated = (self._elapsed >= self.max_episode_steps) | unstable
        truncated[done] = False
        terminated = np.zeros(self.num_envs, dtype=bool)
        self._autoreset = truncated | terminated
        # As SyncVectorEnv batches the sub-environments' infos: a value and a mask per key.
        # (A key is present when at least one arm has it this step.)
        info: dict[str, Any] = {}
        if not done.all():
            info["tip_distance"] = distance
            info["_tip_distance"] = ~done
            info["is_success"] = self._task.success(distance) & ~done
            info["_is_success"] = ~done
        if unstable.any():
            messages = np.full(self.num_envs, None, dtype=object)
            for i in np.flatnonzero(unstable):
                messages[i] = failures[i]
            info["unstable"] = messages
            info["_unstable"] = unstable
        return obs.copy(), reward, terminated, truncated, info

    def render(self) -> tuple[npt.NDArray[np.uint8], ...] | None:
        """With ``render_mode="rgb_array"``: one (H, W, 3) uint8 image per arm (as Gymnasium's
        ``SyncVectorEnv`` returns its sub-environments' frames); else None."""
        if self.render_mode != "rgb_array":
            return None
        h, w = self.render_size
        return tuple(self._batch.render(i, w, h) for i in range(self.num_envs))

    def simulation(self, index: int) -> Simulation:
        """A copy of arm ``index`` as an :class:`octoarm.Simulation`."""
        return self._batch.simulation(index)


GOAL_BOUND = 1.5
"""Bound of the goals (tip and target x, y / L0): the observation's position bound."""


class ArmReachGoalEnv(gym.Env[dict[str, Array], Array]):
    """Goal-conditioned reaching for hindsight experience replay (see the module docstring).

    Keyword arguments: those of :class:`ArmReachEnv` except ``reward`` and ``observe_error``
    (the reward is the goal reward, the goal is observed apart); ``action`` defaults to
    ``"increment"``. ``compute_reward(achieved_goal, desired_goal, info)`` works on single goals
    and on batches (the last axis holds x, y / L0), as SB3's ``HerReplayBuffer`` calls it.
    """

    metadata: dict[str, Any] = {"render_modes": RENDER_MODES, "render_fps": 100}

    def __init__(
        self,
        render_mode: str | None = None,
        render_width: int = 400,
        render_height: int = 400,
        action: str = "increment",
        **config: Any,
    ) -> None:
        for key in ("reward", "observe_error"):
            if key in config:
                raise TypeError(
                    f"ArmReachGoalEnv() got an unexpected keyword argument {key!r}: its reward "
                    "is the goal reward and the goal is observed apart"
                )
        self._env = ArmReachEnv(
            render_mode=render_mode,
            render_width=render_width,
            render_height=render_height,
            reward="reach",
            observe_error=False,
            action=action,
            **config,
        )
        self.render_mode = render_mode
        self.metadata = self._env.metadata
        self.length: float = self._env._task.length
        base = self._env.observation_space
        assert isinstance(base, spaces.Box)
        n = self._env._task.n_nodes
        # Everything but the target (slots 4n, 4n + 1): HER replaces the goal.
        self._keep = np.r_[0 : 4 * n, 4 * n + 2 : base.shape[0]]
        goal = spaces.Box(-GOAL_BOUND, GOAL_BOUND, shape=(2,), dtype=np.float32)
        self.observation_space = spaces.Dict(  # type: ignore[assignment]
            {
                "observation": spaces.Box(
                    base.low[self._keep], base.high[self._keep], dtype=np.float32
                ),
                "achieved_goal": goal,
                "desired_goal": goal,
            }
        )
        self.action_space = self._env.action_space
        self.control_period = self._env.control_period

    def _dict(self, obs: ObsArray) -> dict[str, ObsArray]:
        n = self._env._task.n_nodes
        return {
            "observation": obs[self._keep],
            "achieved_goal": obs[2 * (n - 1) : 2 * n].copy(),
            "desired_goal": obs[4 * n : 4 * n + 2].copy(),
        }

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[dict[str, ObsArray], dict[str, Any]]:
        super().reset(seed=seed)
        obs, info = self._env.reset(seed=seed, options=options)
        return self._dict(obs), info

    def step(
        self, action: Any
    ) -> tuple[dict[str, ObsArray], float, bool, bool, dict[str, Any]]:
        obs, _, terminated, truncated, info = self._env.step(action)
        d = self._dict(obs)
        reward = float(self.compute_reward(d["achieved_goal"], d["desired_goal"], info))
        return d, reward, terminated, truncated, info

    def compute_reward(self, achieved_goal: Any, desired_goal: Any, info: Any) -> Any:
        """``-d / L0 + exp(-d / 1 cm)``, d the distance [m] between the goals (x, y / L0)."""
        diff = np.asarray(achieved_goal, dtype=np.float64) - np.asarray(
            desired_goal, dtype=np.float64
        )
        d = np.linalg.norm(diff, axis=-1) * self.length
        return reach_reward(d, self.length)

    def render(self) -> npt.NDArray[np.uint8] | None:
        """As :meth:`ArmReachEnv.render`."""
        return self._env.render()

    def simulation(self) -> Simulation:
        """A copy of the arm as an :class:`octoarm.Simulation`."""
        return self._env.simulation()
