"""The learnable reaching task (issue 16): ArmReach-v1 (reach reward, error observed,
incremental commands, is_success) and the goal-conditioned ArmReachGoal-v1 for HER."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils import seeding
from gymnasium.utils.env_checker import check_env

import octoarm  # noqa: F401
from octoarm.env import V1_TASK, ArmReachEnv, ArmReachGoalEnv, ArmReachVectorEnv

L0 = 0.2


def test_v1_registered_and_check_env_passes():
    for name in ("octoarm/ArmReach-v1", "octoarm/ArmReachGoal-v1"):
        env = gym.make(name)
        assert env.spec.max_episode_steps == 40  # 40 x 50 ms = 2 s
        assert env.unwrapped.control_period == pytest.approx(0.05)
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            check_env(env.unwrapped, skip_render_check=True)
        assert not caught, [str(w.message) for w in caught]
    v0 = gym.make("octoarm/ArmReach-v0")
    v1 = gym.make("octoarm/ArmReach-v1")
    assert v1.observation_space.shape == (v0.observation_space.shape[0] + 2,)


def test_error_slots_are_target_minus_tip_over_length():
    env = ArmReachEnv(observe_error=True)
    obs, _ = env.reset(seed=1, options={"target": [0.1, 0.05]})
    # straight arm along +x, tip at (L0, 0)
    np.testing.assert_allclose(obs[-2:], [(0.1 - L0) / L0, 0.05 / L0], atol=1e-6)
    for _ in range(5):
        obs, _, _, _, info = env.step(np.array([1.0, -0.5, 0.3, 0.0]))
    n = 21
    tip = obs[2 * (n - 1) : 2 * n].astype(np.float64)
    np.testing.assert_allclose(obs[-2:], np.array([0.5, 0.25]) - tip, atol=1e-6)
    assert np.linalg.norm(obs[-2:]) * L0 == pytest.approx(info["tip_distance"], rel=1e-5)


def test_reach_reward_formula_and_success_flag():
    env = ArmReachEnv(reward="reach")
    env.reset(seed=0, options={"target": [0.12, 0.08]})
    a = np.array([0.6, 0.2, -0.1, 0.4])
    for _ in range(3):
        _, r, _, _, info = env.step(a)
    d = info["tip_distance"]
    assert r == pytest.approx(-d / L0 + np.exp(-d / 0.01) - 0.01 * np.mean(a**2), rel=1e-12)
    assert info["is_success"] is (d <= 0.01)
    # Target at the straight arm's tip: zero command keeps it there -> success, reward ~ 1.
    env.reset(options={"target": [L0, 0.0]})
    _, r, _, _, info = env.step(np.zeros(4))
    assert info["is_success"] and info["tip_distance"] < 1e-6
    assert r == pytest.approx(1.0, abs=1e-4)
    # A target 2 cm away is not a success
    env.reset(options={"target": [L0 - 0.02, 0.0]})
    _, _, _, _, info = env.step(np.zeros(4))
    assert not info["is_success"]
    # success_radius is a parameter
    env = ArmReachEnv(success_radius=0.03)
    env.reset(options={"target": [L0 - 0.02, 0.0]})
    assert env.step(np.zeros(4))[4]["is_success"]


def test_increment_commands_accumulate_clip_and_hold():
    env = ArmReachEnv(action="increment")
    obs, _ = env.reset(seed=0)
    np.testing.assert_array_equal(obs[-4:], 0.0)
    obs = env.step(np.array([1.0, -1.0, 0.5, 5.0]))[0]
    np.testing.assert_allclose(obs[-4:], [0.1, -0.1, 0.05, 0.1], rtol=1e-6)
    obs = env.step(np.array([1.0, -1.0, 0.5, 5.0]))[0]
    np.testing.assert_allclose(obs[-4:], [0.2, -0.2, 0.1, 0.2], rtol=1e-6)
    for _ in range(20):
        obs = env.step(np.array([1.0, -1.0, 0.0, 0.0]))[0]
    np.testing.assert_allclose(obs[-4:], [1.0, -1.0, 0.1, 0.2], rtol=1e-6)
    # Same arm driven by the absolute commands it received: identical observation.
    ref = ArmReachEnv()
    ref.reset(seed=0)
    cmds = [[0.1, -0.1, 0.05, 0.1], [0.2, -0.2, 0.1, 0.2]]
    c = np.array(cmds[-1])
    for _ in range(20):
        c = np.clip(c + 0.1 * np.array([1.0, -1.0, 0.0, 0.0]), -1, 1)
        cmds.append(list(c))
    for c in cmds:
        ref_obs = ref.step(np.array(c))[0]
    np.testing.assert_array_equal(obs, ref_obs)
    # reset zeroes the commands
    obs, _ = env.reset(seed=1)
    np.testing.assert_array_equal(obs[-4:], 0.0)


@pytest.mark.parametrize("kwargs, words", [
    ({"reward": "dist"}, r"reward = 'dist' is not one of 'distance', 'reach'"),
    ({"action": "delta"}, r"action = 'delta' is not one of 'absolute', 'increment'"),
    ({"success_radius": 0.0}, r"success_radius = 0.0 is outside the allowed range \(0, 0.2\]"),
    ({"success_radius": float("nan")}, r"success_radius = nan is outside"),
    ({"observe_error": 1}, r"observe_error = 1 must be True or False"),
    ({"targets": "anywhere"}, r"targets = 'anywhere' is not one of 'sector', 'reachable'"),
])
def test_bad_task_options_are_refused(kwargs, words):
    with pytest.raises(ValueError, match=words):
        ArmReachEnv(**kwargs)
    with pytest.raises(ValueError, match=words):
        ArmReachVectorEnv(num_envs=2, **kwargs)


def test_increment_actions_are_checked():
    env = ArmReachVectorEnv(num_envs=2, action="increment")
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"actions has shape \(8,\), expected \(2, 4\)"):
        env.step(np.zeros(8))
    with pytest.raises(ValueError, match=r"actions must be finite: entry \[1, 2\] is NaN"):
        a = np.zeros((2, 4))
        a[1, 2] = np.nan
        env.step(a)


def test_rest_tips_are_where_a_held_command_settles():
    # The closed-form rest shape against the simulated arm: hold each command (absolute
    # actions) for 12 s from rest and compare the settled tip.
    rng = np.random.default_rng(7)
    cmds = np.vstack([np.zeros(4), np.full(4, 1.0), rng.uniform(-1, 1, (4, 4))])
    batch = octoarm.ArmBatch(n_envs=len(cmds), control_period=0.05, damping_rate=5.0)
    tips = batch.rest_tips(cmds)
    assert tips.shape == (len(cmds), 2)
    np.testing.assert_allclose(tips[0], [0.2, 0.0], atol=1e-15)  # straight arm
    # All segments at 20 1/m: 19 equal turns of 0.2 rad between 20 chords of 1 cm.
    turns = np.arange(20) * 0.2
    np.testing.assert_allclose(tips[1], 0.01 * np.array([np.cos(turns).sum(), np.sin(turns).sum()]),
                               rtol=1e-12)
    batch.reset(tips)
    for _ in range(240):
        obs, _, distance, failures = batch.step(cmds)
    assert all(f is None for f in failures)
    assert distance.max() < 2e-5, distance
    # Commands are clipped to [-1, 1] as actions are; shape and finiteness are checked.
    np.testing.assert_array_equal(batch.rest_tips(np.full((1, 4), 3.0)), tips[1:2])
    with pytest.raises(ValueError, match=r"commands has shape \(1, 3\), expected \(1, 4\)"):
        batch.rest_tips(np.zeros((1, 3)))
    with pytest.raises(ValueError, match=r"commands must be finite"):
        batch.rest_tips(np.array([[0.0, np.inf, 0.0, 0.0]]))


def test_v1_targets_are_reachable_and_v0_targets_stay_in_the_sector():
    env = gym.make("octoarm/ArmReach-v1").unwrapped
    batch = env._batch
    for seed in range(5):
        env.reset(seed=seed)
        # The environment's draw: a command in [-0.9, 0.9]^4 from np_random, its rest tip.
        cmd = seeding.np_random(seed)[0].uniform(-0.9, 0.9, size=(1, 4))
        np.testing.assert_array_equal(env.target, batch.rest_tips(cmd)[0])
    # The vector env draws arm i's targets from its own generator (seed + i), as `sync` does.
    vec = ArmReachVectorEnv(num_envs=4, **V1_TASK)
    vec.reset(seed=3)
    for i in range(4):
        cmd = seeding.np_random(3 + i)[0].uniform(-0.9, 0.9, size=(1, 4))
        np.testing.assert_array_equal(vec.targets[i], batch.rest_tips(cmd)[0])
    v0 = ArmReachVectorEnv(num_envs=16)
    v0.reset(seed=5)
    r = np.linalg.norm(v0.targets, axis=1)
    assert np.all((r >= 0.08) & (r <= 0.18))
    assert np.all(np.abs(np.arctan2(v0.targets[:, 1], v0.targets[:, 0])) <= np.pi / 3)


def _rollout_v1(vec, steps=30):
    obs, _ = vec.reset(seed=11)
    rng = np.random.default_rng(3)
    out = []
    for _ in range(steps):
        a = rng.uniform(-1, 1, size=(vec.num_envs, 4))
        obs, r, term, trunc, info = vec.step(a)
        if "is_success" not in info:  # every arm autoreset this step: no info at all
            assert not info
            info = {k: np.zeros(vec.num_envs, dtype=bool)
                    for k in ("is_success", "_is_success", "tip_distance")}
        out.append((obs.copy(), r.copy(), trunc.copy(), info["is_success"].copy(),
                    info["_is_success"].copy(), info["tip_distance"].copy()))
    return out


def test_vector_v1_equals_sync_vectorisation_bit_for_bit():
    n = 4
    rust = ArmReachVectorEnv(num_envs=n, max_episode_steps=12, num_threads=2, **V1_TASK)
    sync = gym.make_vec("octoarm/ArmReach-v1", n, vectorization_mode="sync",
                        max_episode_steps=12)
    for (o1, r1, t1, s1, m1, d1), (o2, r2, t2, s2, m2, d2) in zip(
        _rollout_v1(rust), _rollout_v1(sync)
    ):
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1, t2)
        np.testing.assert_array_equal(s1 & m1, s2 & m2)
        np.testing.assert_array_equal(m1, m2)
        np.testing.assert_array_equal(d1[m1], d2[m2])


def test_sb3_rust_vec_env_v1_equals_dummy_vec_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3.common.env_util import make_vec_env

    from octoarm.sb3 import RustVecEnv

    n = 3
    rust = RustVecEnv(num_envs=n, max_episode_steps=10, **V1_TASK)
    rust.seed(5)
    dummy = make_vec_env("octoarm/ArmReach-v1", n_envs=n, seed=5,
                         env_kwargs={"max_episode_steps": 10})
    o1, o2 = rust.reset(), dummy.reset()
    np.testing.assert_array_equal(o1, o2)
    rng = np.random.default_rng(0)
    for _ in range(25):
        a = rng.uniform(-1, 1, size=(n, 4)).astype(np.float32)
        o1, r1, d1, i1 = rust.step(a)
        o2, r2, d2, i2 = dummy.step(a)
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        assert [i["is_success"] for i in i1] == [i["is_success"] for i in i2]


def test_goal_env_reward_is_compute_reward_and_goals_are_tip_and_target():
    env = ArmReachGoalEnv()
    obs, _ = env.reset(seed=2, options={"target": [0.1, -0.06]})
    np.testing.assert_allclose(obs["desired_goal"], [0.5, -0.3], rtol=1e-6)
    np.testing.assert_allclose(obs["achieved_goal"], [1.0, 0.0], atol=1e-6)
    assert obs["observation"].shape == env.observation_space["observation"].shape
    rewards, achieved, desired = [], [], []
    for k in range(6):
        obs, r, _, _, info = env.step(np.array([0.5, 0.5, -0.2, 0.1]))
        rewards.append(r)
        achieved.append(obs["achieved_goal"])
        desired.append(obs["desired_goal"])
        d = np.linalg.norm(obs["achieved_goal"].astype(np.float64)
                           - obs["desired_goal"].astype(np.float64)) * L0
        assert r == pytest.approx(-d / L0 + np.exp(-d / 0.01), rel=1e-12)
        assert d == pytest.approx(info["tip_distance"], rel=1e-5)
    # batched, as HerReplayBuffer calls it
    batch = env.compute_reward(np.array(achieved), np.array(desired), [{}] * 6)
    np.testing.assert_array_equal(batch, rewards)


def test_goal_env_observation_does_not_contain_the_goal():
    a, b = ArmReachGoalEnv(), ArmReachGoalEnv()
    oa, _ = a.reset(seed=0, options={"target": [0.1, 0.1]})
    ob, _ = b.reset(seed=0, options={"target": [0.15, -0.05]})
    act = np.array([0.3, -0.2, 0.4, 0.1])
    for _ in range(4):
        oa = a.step(act)[0]
        ob = b.step(act)[0]
    np.testing.assert_array_equal(oa["observation"], ob["observation"])
    np.testing.assert_array_equal(oa["achieved_goal"], ob["achieved_goal"])
    assert not np.array_equal(oa["desired_goal"], ob["desired_goal"])
    with pytest.raises(TypeError, match="reward"):
        ArmReachGoalEnv(reward="distance")


def test_her_replay_buffer_trains_on_goal_env():
    pytest.importorskip("stable_baselines3")
    from stable_baselines3 import SAC, HerReplayBuffer

    env = gym.make("octoarm/ArmReachGoal-v1")
    model = SAC("MultiInputPolicy", env, replay_buffer_class=HerReplayBuffer,
                learning_starts=50, batch_size=32, policy_kwargs={"net_arch": [16]}, seed=0)
    model.learn(100)  # past one 40-step episode: HER samples only finished episodes
    assert model.replay_buffer.size() > 0
    # relabelled rewards are the env's compute_reward of the stored goals
    sample = model.replay_buffer.sample(16)
    d = np.linalg.norm(
        sample.next_observations["achieved_goal"].numpy().astype(np.float64)
        - sample.observations["desired_goal"].numpy(), axis=-1) * L0
    np.testing.assert_allclose(sample.rewards.numpy()[:, 0], -d / L0 + np.exp(-d / 0.01),
                               rtol=1e-5, atol=1e-6)
