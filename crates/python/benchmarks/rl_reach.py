"""Learning curve of reaching (issue 16): PPO, SAC or SAC + HER on octoarm's reaching task,
evaluated on fixed targets until >= 80 % of episodes end within 1 cm of the target.

Not run in CI (minutes to an hour of training). Writes ``OUT/curve.csv`` (env steps, wall
seconds, success rate, median and 90th-percentile final distance) and ``OUT/curve.png``.

    python crates/python/benchmarks/rl_reach.py --algo ppo --steps 2000000 --out rl-ppo
    python crates/python/benchmarks/rl_reach.py --algo her --steps 200000 --out rl-her

* ``ppo``: PPO on ``octoarm.sb3.RustVecEnv`` with the v1 task (reach reward, error observed,
  incremental commands), ``--num-envs`` arms stepped in Rust.
* ``sac``: SAC on the same vector environment.
* ``her``: SAC with SB3's ``HerReplayBuffer`` on ``octoarm/ArmReachGoal-v1``.

Evaluation: ``--eval-episodes`` targets drawn once from ``--eval-seed`` (the task's target
distribution), all arms stepped together in Rust for one 2 s episode with the deterministic
policy; success = final tip distance <= 1 cm (``info["is_success"]`` of the last step).
"""

from __future__ import annotations

import argparse
import csv
import os
import time
from typing import Any

import numpy as np

import octoarm  # noqa: F401  (registers the environments)
from octoarm.env import V1_EPISODE_STEPS, V1_TASK, ArmReachVectorEnv

V1 = dict(V1_TASK)
EPISODE_STEPS = V1_EPISODE_STEPS


def goal_view(obs: np.ndarray, n_nodes: int) -> dict[str, np.ndarray]:
    """Batched ``ArmReachGoalEnv`` observations from vector-env observations without the error
    slots (the goal env's slicing, one row per arm)."""
    keep = np.r_[0 : 4 * n_nodes, 4 * n_nodes + 2 : obs.shape[1]]
    return {
        "observation": obs[:, keep],
        "achieved_goal": obs[:, 2 * (n_nodes - 1) : 2 * n_nodes],
        "desired_goal": obs[:, 4 * n_nodes : 4 * n_nodes + 2],
    }


class Evaluator:
    """Final tip distances of the deterministic policy on fixed targets."""

    def __init__(self, algo: str, episodes: int, seed: int) -> None:
        self.goal = algo == "her"
        task = dict(V1)
        if self.goal:
            task["observe_error"] = False
        self.env = ArmReachVectorEnv(num_envs=episodes, max_episode_steps=EPISODE_STEPS, **task)
        self.seed = seed

    def __call__(self, model: Any) -> np.ndarray:
        env = self.env
        obs, _ = env.reset(seed=self.seed)
        n = env._task.n_nodes
        distance = np.zeros(env.num_envs)
        for _ in range(EPISODE_STEPS):
            x = goal_view(obs, n) if self.goal else obs
            action, _ = model.predict(x, deterministic=True)
            obs, _, _, _, info = env.step(action)
            distance = info["tip_distance"]
        return np.asarray(distance)


def make_model(args: argparse.Namespace) -> Any:
    import torch
    from stable_baselines3 import PPO, SAC, HerReplayBuffer
    from stable_baselines3.common.env_util import make_vec_env
    from stable_baselines3.common.vec_env import VecMonitor

    from octoarm.sb3 import RustVecEnv

    torch.set_num_threads(args.torch_threads)
    if args.algo == "her":
        env = make_vec_env("octoarm/ArmReachGoal-v1", n_envs=args.num_envs, seed=args.seed)
        return SAC(
            "MultiInputPolicy",
            env,
            replay_buffer_class=HerReplayBuffer,
            replay_buffer_kwargs={"n_sampled_goal": 4, "goal_selection_strategy": "future"},
            learning_rate=args.lr,
            gamma=args.gamma,
            batch_size=256,
            buffer_size=1_000_000,
            learning_starts=1_000,
            train_freq=1,
            gradient_steps=args.gradient_steps,
            policy_kwargs={"net_arch": [256, 256]},
            seed=args.seed,
            verbose=args.verbose,
        )
    env = VecMonitor(
        RustVecEnv(num_envs=args.num_envs, max_episode_steps=EPISODE_STEPS, **V1)
    )
    env.seed(args.seed)
    if args.algo == "sac":
        return SAC(
            "MlpPolicy",
            env,
            learning_rate=args.lr,
            gamma=args.gamma,
            batch_size=256,
            learning_starts=1_000,
            train_freq=1,
            gradient_steps=args.gradient_steps,
            policy_kwargs={"net_arch": [256, 256]},
            seed=args.seed,
            verbose=args.verbose,
        )
    return PPO(
        "MlpPolicy",
        env,
        n_steps=256,
        batch_size=512,
        n_epochs=10,
        learning_rate=args.lr,
        gamma=args.gamma,
        gae_lambda=0.95,
        ent_coef=0.0,
        policy_kwargs={"net_arch": [256, 256], "log_std_init": -1.0},
        seed=args.seed,
        verbose=args.verbose,
    )


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--algo", choices=["ppo", "sac", "her"], default="ppo")
    p.add_argument("--steps", type=int, default=1_000_000, help="environment steps to train")
    p.add_argument("--num-envs", type=int, default=16)
    p.add_argument("--eval-every", type=int, default=50_000, help="environment steps")
    p.add_argument("--eval-episodes", type=int, default=200)
    p.add_argument("--eval-seed", type=int, default=12345)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--lr", type=float, default=3e-4)
    p.add_argument("--gamma", type=float, default=0.98)
    p.add_argument("--gradient-steps", type=int, default=1, help="SAC: per env step call")
    p.add_argument("--torch-threads", type=int, default=1)
    p.add_argument("--stop-at", type=float, default=1.01, help="stop once success >= this")
    p.add_argument("--verbose", type=int, default=0, help="SB3's training log (1: on)")
    p.add_argument("--out", default="rl-reach")
    args = p.parse_args()

    from stable_baselines3.common.callbacks import BaseCallback

    os.makedirs(args.out, exist_ok=True)
    model = make_model(args)
    evaluate = Evaluator(args.algo, args.eval_episodes, args.eval_seed)
    rows: list[dict[str, float]] = []
    start = time.perf_counter()
    train_time = [0.0]

    def record(steps: int) -> float:
        t0 = time.perf_counter()
        d = evaluate(model)
        row = {
            "env_steps": steps,
            "wall_s": round(time.perf_counter() - start, 1),
            "success": float(np.mean(d <= 0.01)),
            "median_cm": float(np.median(d) * 100),
            "p90_cm": float(np.quantile(d, 0.9) * 100),
        }
        rows.append(row)
        print(
            f"{row['env_steps']:>9} steps {row['wall_s']:>8.1f} s  success {row['success']:.0%}  "
            f"median {row['median_cm']:.2f} cm  p90 {row['p90_cm']:.2f} cm "
            f"(eval {time.perf_counter() - t0:.1f} s)",
            flush=True,
        )
        with open(os.path.join(args.out, "curve.csv"), "w", newline="") as f:
            w = csv.DictWriter(f, fieldnames=list(row))
            w.writeheader()
            w.writerows(rows)
        return row["success"]

    class Every(BaseCallback):  # type: ignore[misc]
        def __init__(self) -> None:
            super().__init__()
            self.next = args.eval_every

        def _on_step(self) -> bool:
            if self.num_timesteps >= self.next:
                self.next += args.eval_every
                if record(self.num_timesteps) >= args.stop_at:
                    return False
            return True

    record(0)
    model.learn(args.steps, callback=Every())
    if not rows or rows[-1]["env_steps"] != model.num_timesteps:
        record(model.num_timesteps)
    model.save(os.path.join(args.out, "model"))
    plot(rows, args)


def plot(rows: list[dict[str, float]], args: argparse.Namespace) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    steps = [r["env_steps"] for r in rows]
    fig, ax = plt.subplots(1, 2, figsize=(9, 3.4))
    ax[0].plot(steps, [100 * r["success"] for r in rows], "o-")
    ax[0].axhline(80, color="gray", ls="--", lw=1)
    ax[0].set_xlabel("environment steps")
    ax[0].set_ylabel("episodes ending within 1 cm [%]")
    ax[0].set_ylim(0, 100)
    ax[1].plot(steps, [r["median_cm"] for r in rows], "o-", label="median")
    ax[1].plot(steps, [r["p90_cm"] for r in rows], "s--", label="90th percentile")
    ax[1].axhline(1.0, color="gray", ls="--", lw=1)
    ax[1].set_yscale("log")
    ax[1].set_xlabel("environment steps")
    ax[1].set_ylabel("final tip distance [cm]")
    ax[1].legend()
    fig.suptitle(
        f"{args.algo.upper()} on octoarm reaching ({args.eval_episodes} fixed targets; "
        f"{rows[-1]['wall_s']:.0f} s wall)"
    )
    fig.tight_layout()
    fig.savefig(os.path.join(args.out, "curve.png"), dpi=120)


if __name__ == "__main__":
    main()
