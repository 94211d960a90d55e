"""Train PPO (Ray RLlib) on octoarm/ArmReach-v0 on a local Ray cluster.

    pip install "./crates/python[rllib]"          # octoarm + ray[rllib] + torch
    python crates/python/examples/rllib_reach.py --iterations 30

Each RLlib env runner steps its arms in one Rust call (``octoarm.env.ArmReachVectorEnv`` as the
env runner's vector env, ``gym_env_vectorize_mode="vector_entry_point"``). The script starts a
local Ray instance (``--address local``, on 127.0.0.1) or joins a cluster (``--address auto``
after ``ray start``, or ``HOST:PORT``), prints the mean episode return of every iteration and,
at the end, the mean return of the first and last iterations: the return must rise.
CI runs ``--iterations 2 --batch 400`` as a smoke test.
"""

import argparse
import os
import time

import numpy as np


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--iterations", type=int, default=30, help="PPO training iterations")
    p.add_argument("--envs", type=int, default=8, help="arms per env runner (one Rust batch)")
    p.add_argument("--runners", type=int, default=1, help="env-runner actors (0: the driver)")
    p.add_argument("--batch", type=int, default=4000, help="environment steps per iteration")
    p.add_argument("--address", default="local", help="local | auto | HOST:PORT")
    p.add_argument("--seed", type=int, default=0)
    a = p.parse_args()
    if min(a.iterations, a.envs, a.batch) < 1 or a.runners < 0:
        p.error("--iterations, --envs and --batch must be at least 1, --runners at least 0")

    if a.address == "local":
        os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")  # loopback only
    import ray  # after the variable above: Ray reads it on import

    from octoarm.rllib import ppo_config

    if a.address == "local":
        ray.init(include_dashboard=False, _node_ip_address="127.0.0.1",
                 log_to_driver=False, logging_level="ERROR")
    else:
        ray.init(address=a.address, log_to_driver=False, logging_level="ERROR")
    try:
        config = (
            ppo_config(num_envs_per_env_runner=a.envs, num_env_runners=a.runners,
                       env_config={"num_threads": 1})
            .training(train_batch_size_per_learner=a.batch, minibatch_size=min(256, a.batch),
                      num_epochs=10, lr=3e-4, gamma=0.98, lambda_=0.95,
                      entropy_coeff=0.0, vf_clip_param=100.0)
            .rl_module(model_config={"fcnet_hiddens": [128, 128], "fcnet_activation": "tanh"})
            # A loaded machine can take minutes per sample: do not give up on the env runner.
            .env_runners(sample_timeout_s=1800)
            .debugging(seed=a.seed)
            .reporting(metrics_num_episodes_for_smoothing=20)
        )
        algo = config.build_algo()
        returns = []
        t0 = time.perf_counter()
        for i in range(a.iterations):
            result = algo.train()
            runners = result.get("env_runners", {})
            ret = runners.get("episode_return_mean", float("nan"))
            steps = result.get("num_env_steps_sampled_lifetime",
                               runners.get("num_env_steps_sampled_lifetime", 0))
            returns.append(ret)
            print(f"iteration {i + 1:3d}: env steps {int(steps):7d}, mean episode return "
                  f"{ret:8.3f}, {time.perf_counter() - t0:6.1f} s", flush=True)
        algo.stop()
        finite = [r for r in returns if np.isfinite(r)]
        if len(finite) >= 2:
            k = max(1, len(finite) // 5)
            first, last = float(np.mean(finite[:k])), float(np.mean(finite[-k:]))
            print(f"mean episode return: first {k} iteration(s) {first:.3f}, last {k} "
                  f"iteration(s) {last:.3f} ({'improved' if last > first else 'NOT improved'})")
    finally:
        ray.shutdown()


if __name__ == "__main__":
    main()
