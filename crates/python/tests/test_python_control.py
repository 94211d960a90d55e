"""Controller from Python: statics for a task, target strains and shape, energy-shaping loop."""

import numpy as np
import pytest

import octoarm


def test_reach_design_and_shaping_loop():
    sim = octoarm.Simulation.paper_arm()
    design = octoarm.OfflineSolver(sim).solve(target=[0.09, 0.09, 0.0], mu_tip=1e3)
    n = sim.n_elements
    assert design.outcome == "converged"
    assert design.tip_error < 2e-5  # metres (docs/control.md: 1.1 um)
    assert design.nu.shape == (n, 3) and design.kappa.shape == (n - 1, 3)
    assert design.sigma.shape == (n, 3)
    np.testing.assert_array_equal(design.sigma[:, 2], design.nu[:, 2] - 1.0)
    assert design.positions.shape == (n + 1, 3) and design.directors.shape == (n, 3, 3)
    assert np.linalg.norm(design.positions[-1] - [0.09, 0.09, 0.0]) == pytest.approx(
        design.tip_error, rel=1e-6, abs=1e-12
    )
    ctrl = octoarm.EnergyShapingController(sim, damping_rate=10.0)
    ctrl.set_design(sim, design)
    h0 = ctrl.shaped_hamiltonian(sim)
    ctrl.step(sim, 300_000)  # 3 s
    assert ctrl.shaped_hamiltonian(sim) < 1e-2 * h0
    assert np.linalg.norm(sim.tip - design.positions[-1]) < 1e-3  # converging (docs: 1.5e-5 L0 at 4 s)


def test_tip_force_statics_and_bad_tasks():
    sim = octoarm.Simulation.paper_arm()
    solver = octoarm.OfflineSolver(sim)
    d = solver.solve(force=[-1e-4, 1e-6, 0.0])
    assert d.positions[-1, 0] < 0.2
    with pytest.raises(ValueError, match="exactly one"):
        solver.solve()
    with pytest.raises(ValueError, match="target"):
        solver.solve(target=[1.0, 1.0, 0.0])
    with pytest.raises(ValueError, match="space"):
        octoarm.OfflineSolver(sim, space="curved")
    with pytest.raises(ValueError, match="damping_rate"):
        octoarm.EnergyShapingController(sim, damping_rate=-1.0)
