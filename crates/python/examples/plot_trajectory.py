"""Design a reaching shape with the controller, run the energy-shaping loop, plot the arm.

    pip install ./crates/python matplotlib
    python crates/python/examples/plot_trajectory.py   # writes trajectory.png

The paper's arm reaches (9, 9) cm: the statics gives the target strains and shape, the
energy-shaping controller drives the simulated arm there (snapshots every 0.1 s, 1.5 s).
"""

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

import octoarm  # noqa: E402

sim = octoarm.Simulation.paper_arm()
design = octoarm.OfflineSolver(sim).solve(target=[0.09, 0.09, 0.0], mu_tip=1e3)
ctrl = octoarm.EnergyShapingController(sim, damping_rate=10.0)
ctrl.set_design(sim, design)

times, shapes, tips = [0.0], [sim.positions], [sim.tip]
for _ in range(15):
    ctrl.step(sim, 10_000)  # 0.1 s at dt = 1e-5 s
    times.append(sim.time)
    shapes.append(sim.positions)
    tips.append(sim.tip)

fig, (ax, bx) = plt.subplots(1, 2, figsize=(10, 4.5))
colors = plt.cm.viridis(np.linspace(0, 1, len(shapes)))
for t, x, c in zip(times, shapes, colors):
    ax.plot(100 * x[:, 0], 100 * x[:, 1], color=c, lw=1.5, label=f"{t:.1f} s" if t in (0.0, times[-1]) else None)
ax.plot(100 * design.positions[:, 0], 100 * design.positions[:, 1], "k--", lw=1, label="design")
ax.plot(9, 9, "r*", ms=12, label="target")
ax.set(xlabel="x [cm]", ylabel="y [cm]", aspect="equal", title="arm every 0.1 s")
ax.legend()
dist = [np.linalg.norm(p - design.positions[-1]) for p in tips]
bx.semilogy(times, np.maximum(dist, 1e-9))
bx.set(xlabel="t [s]", ylabel="|tip - designed tip| [m]", title="convergence")
fig.tight_layout()
fig.savefig("trajectory.png", dpi=120)
print(f"wrote trajectory.png; tip error at {times[-1]:.1f} s: {dist[-1]:.2e} m")
