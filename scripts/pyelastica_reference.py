"""Reference trajectories from PyElastica 1.0.0 for crates/physics/tests/pyelastica_crosscheck.rs.

Not run in CI. Regenerate the committed data file with (any venv with pyelastica==1.0.0, numpy):

    python3 -m venv /tmp/pyel && /tmp/pyel/bin/pip install pyelastica==1.0.0
    /tmp/pyel/bin/python scripts/pyelastica_reference.py \
        --out crates/physics/tests/data/pyelastica_reference.json

It simulates a few small, short 3D cases with PyElastica's CosseratRod, position-Verlet stepper,
OneEndFixedBC, GravityForces, EndpointForces, UniformTorques and AnalyticalLinearDamper (all three
parameterisations), and writes for each case everything the Rust test needs to rebuild it — rest
lengths and radii (as PyElastica built them), material, loads, damper, the initial state after
`finalize()` — plus PyElastica's derived model arrays (node masses, inertias, stiffnesses, Voronoi
lengths) and the state (positions, velocities, directors, omegas) at a few step counts. Floats are
written with Python's repr, which round-trips exactly.

How the PyElastica set-up maps to octoarm (spec docs/cosserat-discretization.md; facts checked in
PyElastica 1.0.0's source):
  * shear coefficient: PyElastica 1.0 hard-codes alpha_c = 27/28 (octoarm's default); I3 = 2 I1;
    J = rho l diag(I1, I2, I3); node masses half an element each; bend stiffness rest-length
    weighted onto Voronoi points; rest Voronoi length the mean of neighbouring rest lengths.
  * directors are stored as rows d1, d2, d3 (director_collection[m, c, j] = (d_m)_c of element
    j), the same as octoarm's Q_j; omegas are material-frame in both.
  * step order: drift(dt/2), constrain values, internal loads, external loads at t + dt/2,
    kick, constrain rates, dampers, drift(dt/2), constrain values: octoarm's spec §6.
  * GravityForces -> Load::Gravity; EndpointForces(end_force, ramp_up_time) ->
    Load::NodeForce { node: n, ramp_time } (both scale by min(1, t / ramp)); UniformTorques(M)
    -> Load::UniformCouple { couple_per_length: M / L } (PyElastica adds Q_j M / n, octoarm
    Q_j c l_j); the lab tip couple is a small forcing class below (Q_{n-1} M, ramped like
    EndpointForces) -> Load::ElementCouple { element: n - 1 }.
  * AnalyticalLinearDamper uniform / physical / deprecated (damping_constant) parameterisation ->
    AnalyticalDamper::Uniform / Physical / Legacy (spec §8b), applied after the kick.
Known, intended differences in PyElastica's kernels that remain (all at round-off level here):
element lengths carry +1e-14 m, the rotation axis is normalised by |w| + 1e-14, the Log uses
arccos(trace) + 1e-14, and the dilatation rate is formed from x.v products.
"""

import argparse
import importlib.metadata
import json

import numpy as np
import elastica as ea


class Sim(ea.BaseSystemCollection, ea.Constraints, ea.Forcing, ea.Damping):
    pass


class TipCouple(ea.NoForces):
    """Lab-frame couple M on the last element, ramped as min(1, t / ramp_up_time)."""

    def __init__(self, couple, ramp_up_time):
        super().__init__()
        self.couple = np.array(couple, dtype=np.float64)
        self.ramp_up_time = float(ramp_up_time)

    def apply_torques(self, system, time=np.float64(0.0)):
        factor = min(1.0, float(time / self.ramp_up_time))
        q = system.director_collection[..., -1]
        system.external_torques[..., -1] += factor * (q @ self.couple)


def vec_list(a):
    """(3, n) array -> list of n [a0, a1, a2]."""
    return [[float(a[c, k]) for c in range(3)] for k in range(a.shape[1])]


def mat_list(q):
    """(3, 3, n) director array -> list of n matrices given as rows d1, d2, d3."""
    return [[[float(q[r, c, k]) for c in range(3)] for r in range(3)] for k in range(q.shape[2])]


def snapshot(rod, step, time):
    return {
        "step": step,
        "time": float(time),
        "position": vec_list(rod.position_collection),
        "velocity": vec_list(rod.velocity_collection),
        "director": mat_list(rod.director_collection),
        "omega": vec_list(rod.omega_collection),
    }


def perpendicular_normal(direction, hint):
    d = np.array(direction, dtype=np.float64)
    d /= np.linalg.norm(d)
    h = np.array(hint, dtype=np.float64)
    n = h - np.dot(h, d) * d
    return d, n / np.linalg.norm(n)


# Material shared by the cases: a soft rod (rho = 1000, E = 1 MPa or 10 MPa, G given directly).
CASES = [
    {
        # (a) Everything internal: taper, twist, out-of-plane bending, stretch rates.
        "name": "tapered_clamped_free_vibration",
        "description": "tapered clamped rod, 3D initial v and omega (incl. twist), no loads, "
        "no damping",
        "n": 16,
        "length": 0.5,
        "base_diameter": 0.04,
        "tip_diameter": 0.016,
        "density": 1000.0,
        "youngs_modulus": 1.0e6,
        "shear_modulus": 4.0e5,
        "boundary": "clamped",
        "direction": [1.0, 0.0, 0.0],
        "normal": [0.0, 1.0, 0.0],
        "dt": 5.0e-5,
        "steps": 4000,
        "snapshots": [1, 1000, 2000, 3000, 4000],
        "initial_motion": "field",
    },
    {
        # (b) Loads and the uniform analytical damper.
        "name": "uniform_clamped_gravity_tip_loads_uniform_damper",
        "description": "uniform clamped rod, gravity -z, lab tip couple and tip force with "
        "components on all axes (ramped), AnalyticalLinearDamper uniform",
        "n": 16,
        "length": 0.5,
        "base_diameter": 0.03,
        "tip_diameter": 0.03,
        "density": 1000.0,
        "youngs_modulus": 1.0e7,
        "shear_modulus": 4.0e6,
        "boundary": "clamped",
        "direction": [1.0, 0.0, 0.0],
        "normal": [0.0, 1.0, 0.0],
        "dt": 4.0e-5,
        "steps": 5000,
        "snapshots": [1, 1250, 2500, 3750, 5000],
        "gravity": [0.0, 0.0, -9.81],
        "tip_force": [0.4, 0.8, -0.6],
        "tip_couple": [0.03, -0.05, 0.04],
        "ramp_time": 0.05,
        "damper": {"kind": "uniform", "nu": 2.0},
    },
    {
        # (c) Free rod curling into a helix, physical damper.
        "name": "free_rod_rest_curvature_physical_damper",
        "description": "free rod, uniform 3D rest curvature (k1, k2, k3 != 0), relaxing from "
        "straight, AnalyticalLinearDamper physical",
        "n": 16,
        "length": 0.5,
        "base_diameter": 0.03,
        "tip_diameter": 0.03,
        "density": 1000.0,
        "youngs_modulus": 1.0e6,
        "shear_modulus": 4.0e5,
        "boundary": "free",
        "direction": [1.0, 0.0, 0.0],
        "normal": [0.0, 1.0, 0.0],
        "dt": 5.0e-5,
        "steps": 4000,
        "snapshots": [1, 1000, 2000, 3000, 4000],
        "rest_kappa": [3.0, -2.0, 4.0],
        "damper": {"kind": "physical", "translational": 0.05, "rotational": 4.0e-6},
    },
    {
        # (d) Oblique frame, rest shear/stretch, uniform lab couple, legacy damper.
        "name": "oblique_clamped_rest_sigma_uniform_torque_legacy_damper",
        "description": "clamped rod with direction/normal not axis-aligned, rest strain sigma0 "
        "!= 0, UniformTorques and a tip force, AnalyticalLinearDamper deprecated "
        "(damping_constant) protocol",
        "n": 12,
        "length": 0.4,
        "base_diameter": 0.03,
        "tip_diameter": 0.02,
        "density": 1200.0,
        "youngs_modulus": 2.0e6,
        "shear_modulus": 5.0e5,
        "boundary": "clamped",
        "direction": [1.0, 2.0, -0.5],
        "normal": [0.3, -0.4, 1.0],
        "base_position": [0.1, -0.2, 0.3],
        "dt": 5.0e-5,
        "steps": 4000,
        "snapshots": [1, 1000, 2000, 3000, 4000],
        "rest_sigma": [0.01, -0.02, 0.005],
        "uniform_torque": [0.02, -0.01, 0.015],
        "tip_force": [-0.1, 0.2, 0.3],
        "ramp_time": 0.02,
        "damper": {"kind": "legacy", "nu": 0.05},
    },
]


def initial_field(rod, spec):
    """Case (a): smooth 3D velocity and angular-velocity fields, zero at node 0 / element 0."""
    n, length = spec["n"], spec["length"]
    s_node = np.concatenate(([0.0], np.cumsum(rod.rest_lengths)))
    s_elem = 0.5 * (s_node[:-1] + s_node[1:])
    u = s_node / length
    v = np.zeros((3, n + 1))
    v[0] = 0.3 * u**2
    v[1] = 1.0 * u**2 + 0.2 * np.sin(np.pi * u)
    v[2] = -0.6 * u**2 + 0.5 * np.sin(2.0 * np.pi * u)
    w = np.zeros((3, n))
    ue = s_elem / length
    w[0] = 2.0 * ue
    w[1] = -3.0 * ue**2
    w[2] = 12.0 * np.sin(np.pi * ue)
    v[:, 0] = 0.0
    w[:, 0] = 0.0
    return v, w


def run_case(spec):
    n, length = spec["n"], spec["length"]
    ds = length / n
    s_mid = (np.arange(n) + 0.5) * ds
    radius = 0.5 * (spec["tip_diameter"] * s_mid + spec["base_diameter"] * (length - s_mid)) / length
    direction, normal = perpendicular_normal(spec["direction"], spec["normal"])
    start = np.array(spec.get("base_position", [0.0, 0.0, 0.0]), dtype=np.float64)
    kwargs = {}
    if "rest_kappa" in spec:
        kwargs["rest_kappa"] = np.tile(np.array(spec["rest_kappa"])[:, None], (1, n - 1))
    if "rest_sigma" in spec:
        kwargs["rest_sigma"] = np.tile(np.array(spec["rest_sigma"])[:, None], (1, n))
    rod = ea.CosseratRod.straight_rod(
        n,
        start=start,
        direction=direction,
        normal=normal.copy(),
        base_length=length,
        base_radius=radius.copy(),
        density=spec["density"],
        youngs_modulus=spec["youngs_modulus"],
        shear_modulus=spec["shear_modulus"],
        **kwargs,
    )
    if spec.get("initial_motion") == "field":
        v, w = initial_field(rod, spec)
        rod.velocity_collection[:] = v
        rod.omega_collection[:] = w

    sim = Sim()
    sim.append(rod)
    dt = spec["dt"]
    if spec["boundary"] == "clamped":
        sim.constrain(rod).using(
            ea.OneEndFixedBC, constrained_position_idx=(0,), constrained_director_idx=(0,)
        )
    loads = {}
    if "gravity" in spec:
        sim.add_forcing_to(rod).using(ea.GravityForces, acc_gravity=np.array(spec["gravity"]))
        loads["gravity"] = spec["gravity"]
    if "tip_force" in spec:
        sim.add_forcing_to(rod).using(
            ea.EndpointForces,
            start_force=np.zeros(3),
            end_force=np.array(spec["tip_force"]),
            ramp_up_time=spec["ramp_time"],
        )
        loads["tip_force"] = {"force": spec["tip_force"], "ramp_time": spec["ramp_time"]}
    if "tip_couple" in spec:
        sim.add_forcing_to(rod).using(
            TipCouple, couple=spec["tip_couple"], ramp_up_time=spec["ramp_time"]
        )
        loads["tip_couple"] = {"couple": spec["tip_couple"], "ramp_time": spec["ramp_time"]}
    if "uniform_torque" in spec:
        m = np.array(spec["uniform_torque"])
        sim.add_forcing_to(rod).using(
            ea.UniformTorques, torque=np.linalg.norm(m), direction=m / np.linalg.norm(m)
        )
        loads["uniform_torque"] = spec["uniform_torque"]
    damper = spec.get("damper")
    if damper is not None:
        if damper["kind"] == "uniform":
            args = {"uniform_damping_constant": damper["nu"]}
        elif damper["kind"] == "physical":
            args = {
                "translational_damping_constant": damper["translational"],
                "rotational_damping_constant": damper["rotational"],
            }
        else:
            args = {"damping_constant": damper["nu"]}
        sim.dampen(rod).using(ea.AnalyticalLinearDamper, time_step=dt, **args)

    # PyElastica's own derived model, before finalize (the block copies these arrays).
    model = {
        "node_mass": [float(m) for m in rod.mass],
        "inertia": [[float(rod.mass_second_moment_of_inertia[c, c, j]) for c in range(3)] for j in range(n)],
        "shear_stiffness": [[float(rod.shear_matrix[c, c, j]) for c in range(3)] for j in range(n)],
        "bend_stiffness": [[float(rod.bend_matrix[c, c, k]) for c in range(3)] for k in range(n - 1)],
        "rest_voronoi_length": [float(d) for d in rod.rest_voronoi_lengths],
    }
    rest_lengths = [float(l) for l in rod.rest_lengths]

    sim.finalize()
    stepper = ea.PositionVerlet()
    initial = snapshot(rod, 0, 0.0)
    snaps = []
    time = np.float64(0.0)
    wanted = set(spec["snapshots"])
    for step in range(1, spec["steps"] + 1):
        time = stepper.step(sim, time, dt)
        if step in wanted:
            snaps.append(snapshot(rod, step, time))
    assert np.all(np.isfinite(rod.position_collection))

    return {
        "name": spec["name"],
        "description": spec["description"],
        "boundary": spec["boundary"],
        "density": spec["density"],
        "youngs_modulus": spec["youngs_modulus"],
        "shear_modulus": spec["shear_modulus"],
        "shear_coefficient": 27.0 / 28.0,
        "dt": dt,
        "rest_length": rest_lengths,
        "radius": [float(r) for r in radius],
        "rest_sigma": spec.get("rest_sigma", [0.0, 0.0, 0.0]),
        "rest_kappa": spec.get("rest_kappa", [0.0, 0.0, 0.0]),
        "loads": loads,
        "damper": damper,
        "pyelastica_model": model,
        "initial": initial,
        "snapshots": snaps,
    }


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", default="crates/physics/tests/data/pyelastica_reference.json")
    args = p.parse_args()
    data = {
        "generator": "scripts/pyelastica_reference.py",
        "pyelastica_version": importlib.metadata.version("pyelastica"),
        "numpy_version": np.__version__,
        "cases": [run_case(spec) for spec in CASES],
    }
    with open(args.out, "w") as f:
        json.dump(data, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {args.out}")


if __name__ == "__main__":
    main()
