"""Gymnasium environments: API checker, determinism, vectorised env thread-count independence,
observation layout and bounds."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv


def test_registered_and_check_env_passes():
    assert "octoarm/ArmReach-v0" in gym.registry
    env = gym.make("octoarm/ArmReach-v0")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped, skip_render_check=True)
    assert not caught, [str(w.message) for w in caught]  # no warning, in particular on bounds
    space = env.observation_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    assert env.spec.max_episode_steps == 200
    obs, info = env.reset(seed=3)
    assert obs.dtype == np.float32 and obs.shape == env.observation_space.shape
    assert env.action_space.shape == (4,)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert isinstance(reward, float) and reward < 0 and not terminated and not truncated
    assert -reward >= info["tip_distance"] > 0


def test_episode_truncates_and_reward_is_distance_plus_effort():
    env = gym.make("octoarm/ArmReach-v0")
    env.reset(seed=0, options={"target": [0.1, 0.05]})
    a = np.full(4, 0.5, dtype=np.float32)
    for i in range(200):
        obs, reward, terminated, truncated, info = env.step(a)
    assert truncated and not terminated
    assert reward == pytest.approx(-info["tip_distance"] - 0.01 * 0.25)
    # target / L0 (L0 = 0.2 m), lagged rest curvature (settled after 2 s), last action
    np.testing.assert_allclose(obs[-10:-8], [0.5, 0.25], rtol=1e-6)
    np.testing.assert_allclose(obs[-8:-4], 0.5, rtol=1e-6)
    np.testing.assert_array_equal(obs[-4:], 0.5)


def test_seeded_reset_is_deterministic():
    a, b = ArmReachEnv(), ArmReachEnv()
    oa, _ = a.reset(seed=42)
    ob, _ = b.reset(seed=42)
    np.testing.assert_array_equal(oa, ob)
    act = np.linspace(-1, 1, 4)
    np.testing.assert_array_equal(a.step(act)[0], b.step(act)[0])


def _rollout(num_threads, steps=30, num_envs=6):
    env = ArmReachVectorEnv(num_envs=num_envs, num_threads=num_threads, max_episode_steps=12)
    obs, _ = env.reset(seed=7)
    rng = np.random.default_rng(0)
    out = [obs]
    rewards = []
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(rng.uniform(-1, 1, (num_envs, 4)))
        out.append(obs)
        rewards.append(r)
    return np.array(out), np.array(rewards)


def test_vector_env_identical_with_1_and_2_threads():
    o1, r1 = _rollout(1)
    o2, r2 = _rollout(2)
    assert o1.dtype == np.float32 and o1.shape == (31, 6, o1.shape[2])
    np.testing.assert_array_equal(o1, o2)
    np.testing.assert_array_equal(r1, r2)
    # And equal to independent single-arm environments driven the same way (arms are independent).
    o3, _ = _rollout(2, steps=5, num_envs=3)
    np.testing.assert_array_equal(o3[:, :, :], _rollout(1, steps=5, num_envs=3)[0])


def test_vector_env_spaces_and_autoreset():
    env = gym.make_vec("octoarm/ArmReach-v0", num_envs=3, vectorization_mode="vector_entry_point")
    assert env.num_envs == 3
    obs, _ = env.reset(seed=1)
    assert obs.shape == (3, env.single_observation_space.shape[0])
    assert env.action_space.shape == (3, 4)
    venv = ArmReachVectorEnv(num_envs=2, num_threads=2, max_episode_steps=3)
    first, _ = venv.reset(seed=5)
    for i in range(3):
        obs, r, term, trunc, _ = venv.step(np.zeros((2, 4)))
    assert trunc.all()
    obs, r, term, trunc, _ = venv.step(np.zeros((2, 4)))  # next-step autoreset
    np.testing.assert_array_equal(r, 0.0)
    assert not trunc.any()
    np.testing.assert_array_equal(obs[:, :-10], first[:, :-10])  # arm back at rest
    np.testing.assert_array_equal(obs[:, -8:], 0.0)  # actuator state and last action reset
    assert not np.array_equal(obs[:, -10:-8], first[:, -10:-8])  # new targets


def test_bad_env_config():
    with pytest.raises(ValueError, match="n_segments"):
        ArmReachEnv(n_segments=0)
    with pytest.raises(ValueError, match="num_threads"):
        ArmReachVectorEnv(num_envs=2, num_threads=0)
    with pytest.raises(ValueError, match="actions has shape"):
        octoarm.ArmBatch(n_envs=2).step(np.zeros((1, 4)))
    with pytest.raises(ValueError, match=r"target y = -0.4 is outside the allowed range"):
        ArmReachEnv().reset(options={"target": [0.1, -0.4]})


def test_observation_layout_and_lagged_curvature():
    """obs = [x, y / L0 (n+1 pairs); vx, vy / (10 L0/s); target / L0; kappa / max_curvature; a]."""
    env = ArmReachEnv(n_elements=12, n_segments=3)
    n_nodes, m = 13, 3
    assert env.observation_space.shape == (4 * n_nodes + 2 + 2 * m,)
    obs, _ = env.reset(seed=0, options={"target": [0.12, -0.06]})
    pos = obs[: 2 * n_nodes].reshape(n_nodes, 2)
    np.testing.assert_allclose(pos[:, 0], np.linspace(0, 1, n_nodes), atol=1e-6)  # straight, / L0
    np.testing.assert_array_equal(obs[2 * n_nodes : 4 * n_nodes], 0.0)  # at rest
    np.testing.assert_allclose(obs[4 * n_nodes : 4 * n_nodes + 2], [0.6, -0.3], rtol=1e-6)
    np.testing.assert_array_equal(obs[-2 * m :], 0.0)
    a = np.array([1.0, -0.5, 3.0])  # clipped to [-1, 1]
    obs, *_ = env.step(a)
    sim = env.simulation()
    pos = obs[: 2 * n_nodes].reshape(n_nodes, 2)
    np.testing.assert_allclose(pos, sim.positions[:, :2] / 0.2, rtol=1e-6, atol=1e-7)
    vel = obs[2 * n_nodes : 4 * n_nodes].reshape(n_nodes, 2)
    np.testing.assert_allclose(vel, sim.velocities[:, :2] / 2.0, rtol=1e-5, atol=1e-9)
    # One control period (10 ms) of the 50 ms first-order lag from rest.
    lag = 1 - np.exp(-0.01 / 0.05)
    np.testing.assert_allclose(obs[-2 * m : -m], [lag, -0.5 * lag, lag], rtol=1e-6)
    np.testing.assert_array_equal(obs[-m:], [1.0, -0.5, 1.0])
    # The observed curvature is the simulator's rest curvature of each segment (x max_curvature).
    kappa = sim.rest_kappa[:, 1]
    seg = np.arange(kappa.size) * m // kappa.size
    np.testing.assert_allclose(kappa, 20.0 * obs[-2 * m : -m][seg], rtol=1e-6)
    # With the command released the actuator relaxes along the same lag: its state carries over.
    obs, *_ = env.step(np.zeros(3))
    expected = np.array([lag, -0.5 * lag, lag]) * (1 - lag)
    np.testing.assert_allclose(obs[-2 * m : -m], expected, rtol=1e-6)
    np.testing.assert_array_equal(obs[-m:], 0.0)


@pytest.mark.parametrize("mode", ["uniform", "random_bang_bang", "periodic_bang_bang"])
def test_observations_stay_inside_their_bounds(mode):
    num_envs = 8
    env = ArmReachVectorEnv(num_envs=num_envs, num_threads=2, max_episode_steps=100)
    space = env.single_observation_space
    rng = np.random.default_rng(11)
    obs, _ = env.reset(seed=11)
    signs = rng.choice([-1.0, 1.0], (num_envs, 4))
    periods = rng.integers(1, 40, num_envs)  # per arm, steps between sign flips
    peak = np.zeros_like(space.high)
    for t in range(250):  # 2.5 episodes: crosses autoresets
        assert all(space.contains(o) for o in obs), mode
        peak = np.maximum(peak, np.abs(obs).max(axis=0))
        if mode == "uniform":
            a = rng.uniform(-1.5, 1.5, (num_envs, 4))  # also beyond the action bounds
        elif mode == "random_bang_bang":
            a = rng.choice([-1.0, 1.0], (num_envs, 4))
        else:
            signs[t % periods == 0] *= -1
            a = signs
        obs, *_ = env.step(a)
    assert all(space.contains(o) for o in obs), mode
    # The clipping is a safeguard, not in use: positions and velocities stay well inside.
    n2 = obs.shape[1] - 10
    assert peak[: n2 // 2].max() < 1.1 and peak[n2 // 2 : n2].max() < 2.5
