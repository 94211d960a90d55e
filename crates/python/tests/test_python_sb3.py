"""Stable-Baselines3 (issue 16, item 12): unsupported keyword arguments, and render modes other
than None and "rgb_array" (issue 15), raise TypeError (SB3's make_vec_env falls back on
TypeError only), and octoarm.sb3.RustVecEnv
is an SB3 VecEnv over the Rust vector env with the same results as SB3's DummyVecEnv. The SB3
tests are skipped when Stable-Baselines3 is not installed."""

import importlib.util
import warnings

import gymnasium as gym
import numpy as np
import pytest

import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv

HAVE_SB3 = importlib.util.find_spec("stable_baselines3") is not None
needs_sb3 = pytest.mark.skipif(not HAVE_SB3, reason="stable-baselines3 is not installed")


@pytest.mark.parametrize("make", [
    lambda: ArmReachVectorEnv(num_envs=2, render_mode="human"),
    lambda: ArmReachEnv(render_mode="human"),
    lambda: ArmReachEnv(render_mode="ansi"),
    lambda: ArmReachEnv(no_such_option=1),
])
def test_unsupported_keyword_arguments_raise_type_error(make):
    with pytest.raises(TypeError) as info:
        make()
    text = str(info.value)
    assert "render_mode" in text or "no_such_option" in text
    if "render_mode" in text:
        assert "use render_mode=None" in text


def test_gym_make_with_render_mode_raises_type_error_and_falls_back():
    """What SB3's make_vec_env does: try a render mode, on TypeError retry without. An
    unsupported mode raises TypeError; "rgb_array" is supported (issue 15). ("human" is too,
    through Gymnasium's HumanRendering wrapper over "rgb_array".)"""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        with pytest.raises(TypeError, match="render_mode"):
            gym.make("octoarm/ArmReach-v0", render_mode="ansi")
    env = gym.make("octoarm/ArmReach-v0")
    assert env.render_mode is None and env.metadata["render_modes"] == ["rgb_array"]
    env = gym.make("octoarm/ArmReach-v0", render_mode="rgb_array")
    assert env.render_mode == "rgb_array"


def test_sb3_module_needs_sb3():
    if HAVE_SB3:
        import octoarm.sb3  # noqa: F401
    else:
        with pytest.raises(ImportError, match="pip install stable-baselines3"):
            import octoarm.sb3  # noqa: F401


@needs_sb3
def test_make_vec_env_works():
    from stable_baselines3.common.env_util import make_vec_env

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # gymnasium's note on render_mode='rgb_array'
        venv = make_vec_env("octoarm/ArmReach-v0", n_envs=2, seed=0)
    obs = venv.reset()
    assert obs.shape == (2, venv.observation_space.shape[0])
    obs, rewards, dones, infos = venv.step(np.zeros((2, 4), np.float32))
    assert rewards.shape == (2,) and "tip_distance" in infos[0]


def _run(venv, steps, seed):
    venv.seed(seed)
    out = [venv.reset()]
    for t in range(steps):
        a = (0.8 * np.sin(0.2 * t + np.arange(venv.num_envs)[:, None] + np.arange(4))).astype(
            np.float32)
        obs, rewards, dones, infos = venv.step(a)
        out.append((obs, rewards, dones, infos))
    return out


@needs_sb3
def test_rust_vec_env_equals_dummy_vec_env_bit_for_bit():
    from stable_baselines3.common.env_util import make_vec_env

    from octoarm.sb3 import RustVecEnv

    n, steps = 3, 14
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        dummy = make_vec_env("octoarm/ArmReach-v0", n_envs=n, seed=0,
                             env_kwargs={"max_episode_steps": 6})
    rust = RustVecEnv(num_envs=n, num_threads=2, max_episode_steps=6)
    a, b = _run(dummy, steps, seed=7), _run(rust, steps, seed=7)
    np.testing.assert_array_equal(a[0], b[0])
    n_done = 0
    for (o1, r1, d1, i1), (o2, r2, d2, i2) in zip(a[1:], b[1:]):
        np.testing.assert_array_equal(o1, o2)
        assert r1.dtype == r2.dtype == np.float32
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        for x, y in zip(i1, i2):
            assert x["TimeLimit.truncated"] == y["TimeLimit.truncated"]
            assert x["tip_distance"] == y["tip_distance"]
            assert ("terminal_observation" in x) == ("terminal_observation" in y)
            if "terminal_observation" in x:
                n_done += 1
                np.testing.assert_array_equal(x["terminal_observation"],
                                              y["terminal_observation"])
    assert n_done == 2 * n  # two episodes of 6 steps ended on every arm


@needs_sb3
def test_rust_vec_env_with_sb3_wrappers_and_unstable_arm():
    from stable_baselines3.common.vec_env import VecCheckNan, VecMonitor, VecNormalize

    from octoarm.sb3 import RustVecEnv

    raw = RustVecEnv(num_envs=3, num_threads=1, max_episode_steps=50, max_curvature=200.0,
                     activation_time=0.0)
    env = VecNormalize(VecMonitor(VecCheckNan(raw, raise_exception=True)))
    env.seed(1)
    obs = env.reset()
    assert obs.shape == (3, raw.observation_space.shape[0])
    a = np.full((3, 4), 0.02, np.float32)
    env.step(a)
    a[2] = [1, -1, 1, -1]
    obs, rewards, dones, infos = env.step(a)
    assert dones.tolist() == [False, False, True]
    assert infos[2]["unstable"].startswith("unstable:") and infos[2]["TimeLimit.truncated"]
    assert "episode" in infos[2] and infos[2]["episode"]["l"] == 2  # VecMonitor's statistics
    assert "terminal_observation" in infos[2] and "unstable" not in infos[0]
    np.testing.assert_array_equal(env.get_original_obs()[2, -8:], 0.0)  # already reset
    assert raw.get_attr("render_mode") == [None, None, None]
    assert raw.env_is_wrapped(gym.Wrapper) == [False, False, False]
    sims = raw.env_method("simulation", indices=[0, 2])
    assert len(sims) == 2 and all(isinstance(s, octoarm.Simulation) for s in sims)
    with pytest.raises(AttributeError, match="no per-arm method"):
        raw.env_method("reset")
    raw.set_options({"target": [0.1, 0.05]})
    raw.reset()
    np.testing.assert_array_equal(raw.venv.targets, [[0.1, 0.05]] * 3)
    with pytest.raises(ValueError, match=r"actions has shape \(12,\), expected \(3, 4\)"):
        raw.step(np.zeros(12))


@needs_sb3
def test_ppo_learns_a_few_steps_on_the_rust_vec_env():
    from stable_baselines3 import PPO

    from octoarm.sb3 import RustVecEnv

    env = RustVecEnv(num_envs=2, num_threads=1)
    env.seed(0)
    model = PPO("MlpPolicy", env, n_steps=32, batch_size=32, n_epochs=1, seed=0, device="cpu")
    model.learn(total_timesteps=64)
    assert model.num_timesteps == 64
