"""Sharing objects between threads (issue 16, item 13): a Simulation (and a controller, a
solver, an ArmBatch) used from several threads makes callers wait for a running step instead
of raising "RuntimeError: Already borrowed"; a step(n) is atomic for readers; the GIL stays
released while stepping and while waiting."""

import threading
import time

import numpy as np

import octoarm


def _run_threads(targets):
    errors = []

    def guard(f):
        def run():
            try:
                f()
            except BaseException as e:  # noqa: BLE001 - reported below
                errors.append(e)
        return run

    threads = [threading.Thread(target=guard(f), daemon=True) for f in targets]
    for t in threads:
        t.start()
    for t in threads:
        t.join(timeout=120)
        assert not t.is_alive(), "a thread hangs (deadlock?)"
    assert not errors, errors


def test_readers_and_writers_wait_for_a_running_step():
    sim = octoarm.Simulation.paper_arm(n_elements=40, dt=2e-5)
    sim.set_damping(rate=10.0)
    sim.add_node_force([0.0, 2e-5, 0.0])
    done = threading.Event()
    seen_steps = []

    def stepper():
        try:
            for _ in range(30):
                sim.step(400)
        finally:
            done.set()

    def reader():
        while not done.is_set():
            seen_steps.append(sim.steps)
            p = sim.positions
            assert p.shape == (41, 3) and np.isfinite(p).all()
            st = sim.state()["rod"]
            assert st["positions"].shape == (41, 3)
            assert sim.energies()["total"] >= 0.0
            sim.strains()
            repr(sim)

    def writer():
        while not done.is_set():
            sim.set_rod_state(velocities=sim.velocities)  # an exact copy: changes nothing
            sim.set_damping(rate=10.0)

    _run_threads([stepper, reader, reader, writer])
    assert sim.steps == 30 * 400
    # A reader never sees a step(400) half done.
    assert len(seen_steps) > 0 and all(s % 400 == 0 for s in seen_steps)


def test_two_threads_stepping_one_simulation_take_turns():
    sim = octoarm.Simulation.paper_arm(n_elements=20, dt=5e-5)
    ref = sim.copy()
    _run_threads([lambda: [sim.step(100) for _ in range(20)]] * 2)
    ref.step(4000)
    assert sim.steps == 4000
    np.testing.assert_array_equal(sim.positions, ref.positions)  # steps are serialised


def test_gil_is_released_while_a_reader_waits():
    sim = octoarm.Simulation.paper_arm()
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    stepper = threading.Thread(target=lambda: sim.step(40_000), daemon=True)  # ~0.2 s
    tick = threading.Thread(target=ticker, daemon=True)
    tick.start()
    stepper.start()
    time.sleep(0.02)
    start = time.perf_counter()
    _ = sim.positions  # waits for the stepper, without holding the GIL
    end = time.perf_counter()
    stepper.join()
    stop.set()
    tick.join()
    assert sim.steps == 40_000
    during = [x for x in ticks if start < x < end]
    if end - start > 0.05:
        assert len(during) >= 10, f"only {len(during)} ticks while waiting {end - start:.3f} s"


def test_controller_and_solver_shared_between_threads():
    sim = octoarm.Simulation.paper_arm(n_elements=30)
    solver = octoarm.OfflineSolver(sim)
    design = solver.solve(target=[0.1, 0.1, 0.0])
    ctrl = octoarm.EnergyShapingController(sim)
    ctrl.set_design(sim, design)
    done = threading.Event()
    values = []

    def control():
        try:
            for _ in range(10):
                ctrl.step(sim, 500)
        finally:
            done.set()

    def watch():
        while not done.is_set():
            values.append(ctrl.shaped_hamiltonian(sim))
            ctrl.stresses()

    def solve():
        solver.solve(target=[0.12, 0.05, 0.0])

    _run_threads([control, watch, solve, solve])
    assert sim.steps == 5000 and values and all(np.isfinite(values))


def test_arm_batch_shared_between_threads():
    batch = octoarm.ArmBatch(n_envs=3, num_threads=2)
    batch.reset(np.full((3, 2), 0.1))
    done = threading.Event()

    def step():
        try:
            for _ in range(20):
                obs, reward, distance, failures = batch.step(np.full((3, 4), 0.3))
                assert failures == [None, None, None]
        finally:
            done.set()

    def read():
        while not done.is_set():
            t = batch.simulation(1).time
            assert abs(t / 0.01 - round(t / 0.01)) < 1e-6  # whole control periods only

    _run_threads([step, read])
    assert abs(batch.simulation(0).time - 0.2) < 1e-12
