"""No memory growth over 1e5 steps (tracemalloc for Python objects, RSS for the Rust side)."""

import gc
import tracemalloc

import numpy as np
import psutil

import octoarm
from octoarm.env import ArmReachEnv


def _rss():
    gc.collect()
    return psutil.Process().memory_info().rss


def test_no_growth_over_1e5_simulation_steps():
    sim = octoarm.Simulation.paper_arm(n_elements=20, dt=5e-5)
    sim.set_damping(rate=10.0)
    sim.add_node_force([0.0, 2e-5, 0.0])
    for _ in range(2000):  # warm-up: allocator pools, lazily created types
        sim.step(1)
        sim.positions
    tracemalloc.start()
    rss0 = _rss()
    snap0 = tracemalloc.take_snapshot()
    for i in range(100_000):
        sim.step(1)
        if i % 10 == 0:
            x = sim.positions
            _ = sim.energies()["total"]
            _ = sim.strains()
    snap1 = tracemalloc.take_snapshot()
    rss1 = _rss()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in snap1.compare_to(snap0, "filename"))
    assert np.isfinite(x).all()
    assert grown < 100_000, f"Python heap grew by {grown} B"
    assert rss1 - rss0 < 2_000_000, f"RSS grew by {rss1 - rss0} B"


def test_no_growth_over_1e5_env_steps():
    env = ArmReachEnv(control_period=5e-5, dt=5e-5, n_elements=8, n_segments=2)
    env.reset(seed=0)
    a = np.array([0.3, -0.3])
    for _ in range(2000):
        env.step(a)
    tracemalloc.start()
    rss0 = _rss()
    snap0 = tracemalloc.take_snapshot()
    for i in range(100_000):
        if i % 5000 == 0:
            env.reset()
        env.step(a)
    snap1 = tracemalloc.take_snapshot()
    rss1 = _rss()
    tracemalloc.stop()
    grown = sum(s.size_diff for s in snap1.compare_to(snap0, "filename"))
    assert grown < 100_000, f"Python heap grew by {grown} B"
    assert rss1 - rss0 < 2_000_000, f"RSS grew by {rss1 - rss0} B"
