"""Gymnasium environments: API checker, determinism, vectorised env thread-count independence."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv


def test_registered_and_check_env_passes():
    assert "octoarm/ArmReach-v0" in gym.registry
    env = gym.make("octoarm/ArmReach-v0")
    check_env(env.unwrapped, skip_render_check=True)
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
    np.testing.assert_allclose(obs[-6:-4], [0.1, 0.05], rtol=1e-6)  # target in the observation


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
    np.testing.assert_array_equal(obs[:, :-6], first[:, :-6])  # arm back at rest
    assert not np.array_equal(obs[:, -6:-4], first[:, -6:-4])  # new targets


def test_bad_env_config():
    with pytest.raises(ValueError, match="n_segments"):
        ArmReachEnv(n_segments=0)
    with pytest.raises(ValueError, match="num_threads"):
        ArmReachVectorEnv(num_envs=2, num_threads=0)
    with pytest.raises(ValueError, match="actions has shape"):
        octoarm.ArmBatch(n_envs=2).step(np.zeros((1, 4)))
