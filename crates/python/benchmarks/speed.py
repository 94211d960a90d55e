"""Environment steps per second (one step = one 10 ms control period) for 1, 8 and 64 arms,
octoarm (Rust, rayon) against a PyElastica-based environment on the same arm, plus single-arm
stepping from Python against the Rust loop. Not part of CI; run in one sitting on an idle machine:

    python -m venv /tmp/v && /tmp/v/bin/pip install ./crates/python pyelastica==1.0.0
    /tmp/v/bin/python crates/python/benchmarks/speed.py

The arm is the environment's: the paper's geometry with 20 elements, tip diameter 4 mm,
dt = 50 us, 200 steps per environment step, mass-proportional damping 10 1/s (PyElastica:
AnalyticalLinearDamper with the same rate), in-plane rest-curvature commands on 4 segments.
octoarm updates the lagged rest curvature every time step; the PyElastica environment sets it
once per control period (less work for PyElastica). PyElastica steps all its arms in one
collection on one core (it has no multi-arm parallelism); octoarm uses all cores.
"""

import argparse
import os
import time

import numpy as np

import octoarm

N_ELEMENTS, N_SEGMENTS, DT, PERIOD = 20, 4, 5e-5, 0.01
STEPS = round(PERIOD / DT)


def octoarm_rate(n_arms, min_time):
    b = octoarm.ArmBatch(n_envs=n_arms)
    rng = np.random.default_rng(0)
    b.reset(np.tile([0.1, 0.1], (n_arms, 1)))
    b.step(rng.uniform(-1, 1, (n_arms, N_SEGMENTS)))
    done, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < min_time:
        b.step(rng.uniform(-1, 1, (n_arms, N_SEGMENTS)))
        done += 1
    return done * n_arms / (time.perf_counter() - t0)


def pyelastica_rate(n_arms, min_time):
    import elastica as ea

    class Arms(ea.BaseSystemCollection, ea.Constraints, ea.Damping):
        pass

    length = 0.2
    s = (np.arange(N_ELEMENTS) + 0.5) * length / N_ELEMENTS
    radius = 0.5 * (0.004 * s + 0.02 * (length - s)) / length
    sim = Arms()
    rods = []
    for _ in range(n_arms):
        rod = ea.CosseratRod.straight_rod(
            N_ELEMENTS, start=np.zeros(3), direction=np.array([1.0, 0.0, 0.0]),
            normal=np.array([0.0, 1.0, 0.0]), base_length=length, base_radius=radius,
            density=700.0, youngs_modulus=1.0e4, shear_modulus=1.0e3,
        )
        sim.append(rod)
        sim.constrain(rod).using(
            ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
        )
        sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=10.0, time_step=DT)
        rods.append(rod)
    sim.finalize()
    stepper = ea.PositionVerlet()
    rng = np.random.default_rng(0)
    seg = np.arange(N_ELEMENTS - 1) * N_SEGMENTS // (N_ELEMENTS - 1)
    t = 0.0

    def env_step():
        nonlocal t
        for rod in rods:
            # PyElastica's rest_kappa is (3, n - 1); component 1 is the in-plane bend.
            rod.rest_kappa[1, :] = 20.0 * rng.uniform(-1, 1, N_SEGMENTS)[seg]
        for _ in range(STEPS):
            t = stepper.step(sim, t, DT)

    env_step()  # numba compilation
    done, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < min_time:
        env_step()
        done += 1
    return done * n_arms / (time.perf_counter() - t0)


def python_vs_rust(min_time):
    """Paper arm (100 elements, dt = 1e-5 s); Python calls step(100) = 1 ms simulated."""
    sim = octoarm.Simulation.paper_arm()
    sim.set_damping(rate=10.0)
    sim.add_node_force([0.0, 2e-5, 0.0])
    sim.step(2000)
    best_py, best_rs = 0.0, 0.0
    for _ in range(5):
        calls, t0 = 0, time.perf_counter()
        while time.perf_counter() - t0 < min_time:
            sim.step(100)
            calls += 1
        best_py = max(best_py, calls * 100 / (time.perf_counter() - t0))
        best_rs = max(best_rs, octoarm.rust_step_rate(sim, int(best_py * min_time)))
    return best_py, best_rs


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--time", type=float, default=3.0, help="seconds per measurement")
    p.add_argument("--no-pyelastica", action="store_true")
    a = p.parse_args()
    print(f"cores: {os.cpu_count()}, octoarm {octoarm.__version__}")
    print("| arms | octoarm env steps/s | PyElastica env steps/s | ratio |")
    print("|---:|---:|---:|---:|")
    for n in (1, 8, 64):
        ours = octoarm_rate(n, a.time)
        theirs = float("nan") if a.no_pyelastica else pyelastica_rate(n, a.time)
        print(f"| {n} | {ours:.0f} | {theirs:.1f} | {ours / theirs:.0f} |", flush=True)
    py, rs = python_vs_rust(a.time / 3)
    print(f"single arm, paper arm n=100, dt=1e-5 s, step(100) = 1 ms per call: "
          f"Python {py:.0f} steps/s, Rust loop {rs:.0f} steps/s, Python/Rust = {py / rs:.3f}")


if __name__ == "__main__":
    main()
