"""octoarm/ArmReach-v0 with Ray RLlib (issue 14): registered with RLlib's env registry, an RLlib
env runner built from ``octoarm.rllib.ppo_config`` steps the Rust vector environment (all its
arms in one call) and samples complete episodes of 200 steps, with the same transitions as
Gymnasium's own vectorisation of the single environment. Skipped without ``ray[rllib]``."""

import numpy as np
import pytest

pytest.importorskip("ray.rllib")
pytest.importorskip("torch")

import octoarm  # noqa: E402
from octoarm.env import ArmReachEnv, ArmReachVectorEnv  # noqa: E402
from octoarm.rllib import ENV_NAME, make_env, ppo_config  # noqa: E402


def test_env_creator_gives_the_rust_vector_env_or_a_time_limited_single_env():
    v = make_env({"num_envs": 3, "num_threads": 1})
    assert isinstance(v, ArmReachVectorEnv) and v.num_envs == 3
    one = make_env({})
    assert isinstance(one.unwrapped, ArmReachEnv)
    one.reset(seed=0)
    for k in range(200):
        _, _, terminated, truncated, _ = one.step(np.zeros(4, dtype=np.float32))
        assert not terminated and truncated == (k == 199)


@pytest.mark.parametrize("mode", ["vector_entry_point", "sync"])
def test_rllib_env_runner_samples_episodes_from_octoarm(mode):
    from ray.rllib.env.single_agent_env_runner import SingleAgentEnvRunner

    config = ppo_config(num_envs_per_env_runner=2, env_config={"num_threads": 1},
                        vectorize_mode=mode).env_runners(rollout_fragment_length=200)
    assert config.env == ENV_NAME
    runner = SingleAgentEnvRunner(config=config)
    try:
        inner = runner.env.unwrapped
        if mode == "vector_entry_point":
            assert isinstance(inner, ArmReachVectorEnv), type(inner)
        else:
            assert not isinstance(inner, ArmReachVectorEnv)
        episodes = runner.sample(num_timesteps=401, random_actions=True)
        done = [e for e in episodes if e.is_done]
        assert len(done) >= 2
        for e in done:
            assert len(e) == 200 and e.is_truncated and not e.is_terminated
            rewards = e.get_rewards()
            # Reward = -|tip - target| - 0.01 mean(a^2): between -(0.2 + 0.3 + 0.01) and 0.
            assert np.all(rewards < 0) and np.all(rewards > -0.6)
    finally:
        runner.stop()

