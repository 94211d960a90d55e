"""Time PyElastica on the paper's arm, the same case as octoarm's criterion bench (README "Speed").

Run through scripts/bench_pyelastica.sh, which makes a throw-away venv with PyElastica; not part
of CI. For each element count prints `pyelastica_us_per_step <N> <value>` (median over repeats).

The arm, as in `StraightRod::paper_arm()` and crates/physics/benches/step.rs:
  * N = 100 elements (or --elements), L = 0.2 m along +x, normal (d1) +y, clamped base;
  * radius tapered linearly from 10 mm (base) to 0.2 mm (tip), sampled at element midpoints
    (PyElastica accepts one base_radius per element);
  * E = 1e4 Pa, G = 1e3 Pa, rho = 700 kg/m^3, shear coefficient 27/28 (PyElastica's own value);
  * tip force 2e-5 N along +y, dt = 1e-5 s, position Verlet.

What differs between the two setups (none of it changes the work per step materially):
  * Damping: octoarm uses its mass-proportional module (rate 10 1/s, exponential kick inside the
    velocity update, spec §8a); PyElastica uses AnalyticalLinearDamper(uniform_damping_constant=10),
    a multiplicative factor exp(-10 dt) applied after the kick (spec §8b). Same decay rate, different
    splitting; both are one multiply-add per degree of freedom.
  * Tip force: PyElastica's EndpointForces needs a ramp time > 0; we use 1e-9 s (full force from the
    first step), octoarm applies the force at once.
  * Clamp: OneEndFixedBC holds node 0 and element 0, as octoarm's clamped base does.
  * octoarm also runs its stability guard every 100 steps and an orthonormality check every 1000
    steps inside the timed loop; PyElastica has no such checks.
  * octoarm's bench starts timing after 2000 steps from rest; here after --warmup steps (which
    also compile PyElastica's numba kernels).
"""

import argparse
import importlib.metadata
import statistics
import time

import numpy as np
import elastica as ea


class ArmSimulator(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
    pass


def build(n_elements: int, dt: float):
    length = 0.2
    base_diameter, tip_diameter = 0.02, 0.0004
    s = (np.arange(n_elements) + 0.5) * length / n_elements
    radius = 0.5 * (tip_diameter * s + base_diameter * (length - s)) / length
    sim = ArmSimulator()
    rod = ea.CosseratRod.straight_rod(
        n_elements,
        start=np.zeros(3),
        direction=np.array([1.0, 0.0, 0.0]),
        normal=np.array([0.0, 1.0, 0.0]),
        base_length=length,
        base_radius=radius,
        density=700.0,
        youngs_modulus=1.0e4,
        shear_modulus=1.0e3,
    )
    sim.append(rod)
    sim.constrain(rod).using(ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,))
    sim.add_forcing_to(rod).using(
        ea.EndpointForces, start_force=np.zeros(3), end_force=np.array([0.0, 2.0e-5, 0.0]), ramp_up_time=1e-9
    )
    sim.dampen(rod).using(ea.AnalyticalLinearDamper, uniform_damping_constant=10.0, time_step=dt)
    sim.finalize()
    return sim, rod


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--elements", type=int, nargs="+", default=[100])
    parser.add_argument("--steps", type=int, default=20000, help="timed steps per repeat")
    parser.add_argument("--warmup", type=int, default=2000)
    parser.add_argument("--repeats", type=int, default=3)
    args = parser.parse_args()

    dt = 1.0e-5
    version = importlib.metadata.version("pyelastica")
    for n in args.elements:
        sim, rod = build(n, dt)
        stepper = ea.PositionVerlet()
        t = np.float64(0.0)
        for _ in range(args.warmup):
            t = stepper.step(sim, t, dt)
        per_step = []
        for _ in range(args.repeats):
            start = time.perf_counter()
            for _ in range(args.steps):
                t = stepper.step(sim, t, dt)
            per_step.append((time.perf_counter() - start) * 1e6 / args.steps)
        if not np.all(np.isfinite(rod.position_collection)):
            raise SystemExit(f"PyElastica run with N={n} became non-finite")
        tip = rod.position_collection[:, -1]
        print(
            f"# pyelastica {version} N={n} steps={args.steps}x{args.repeats} t={float(t):.4f} s "
            f"tip=({tip[0]:.5f}, {tip[1]:.5f}) m, repeats [us/step]: " + " ".join(f"{v:.2f}" for v in per_step)
        )
        print(f"pyelastica_us_per_step {n} {statistics.median(per_step):.3f}", flush=True)

if __name__ == "__main__":
    main()
