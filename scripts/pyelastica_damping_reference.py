"""Reference trajectories from PyElastica 1.0.0 for crates/app/tests/pyelastica_protocol.rs.

Not run in CI. Regenerate the committed data (any venv with pyelastica==1.0.0, numpy), from the
repository root:

    python3 -m venv /tmp/pyel && /tmp/pyel/bin/pip install pyelastica==1.0.0
    /tmp/pyel/bin/python scripts/pyelastica_damping_reference.py --out-dir crates/app/tests/data

It writes `pyelastica_damping.json` and, for every case, the octoarm scenario `<name>.toml` that
builds the same system, both from one case specification below, so that the PyElastica set-up
and the scenario cannot drift apart. The cases are damped by `AnalyticalLinearDamper(
uniform_damping_constant = nu, time_step = dt)`, which the scenarios express as
`[damping] rate = nu, protocol = "pyelastica"`; nu dt is 1e-3 and 1e-2, so that octoarm's default
("exact") damping protocol differs from PyElastica's operator split at first order in nu dt.

The PyElastica side reuses `run_case` of scripts/pyelastica_reference.py (the physics crate's
cross-check; its module docstring has the mapping PyElastica -> octoarm). What this script adds
is the mapping onto a scenario file:
  * `[rod]` builds a straight rod of n equal elements, length / n each, from `base_position`
    (here the origin) along `direction`, with diameters interpolated linearly between
    `base_diameter` and `tip_diameter` at the element midpoints. `run_case` passes PyElastica
    exactly these radii, radius_j = (tip s_j + base (L - s_j)) / (2 L) with
    s_j = (j + 1/2) L / n, the same formula and floating-point order as octoarm's StraightRod.
    PyElastica computes its rest lengths as |x_{j+1} - x_j| of start + direction * linspace(0, L,
    n + 1); with the origin as start, an axis-aligned direction and L / n a power of two
    (0.5 / 16 = 2^-5) they are exactly octoarm's L / n (the data file holds them: the test checks
    they are equal, bit for bit).
  * `shear_coefficient = 27/28` (PyElastica 1.0 hard-codes it; octoarm's default, written out);
    `shear_modulus` is passed to both directly.
  * `OneEndFixedBC` at node 0 / element 0 -> the scenario's default `base = "clamped"`.
  * `GravityForces(g)` -> `[[load]] kind = "gravity"`; `EndpointForces(0, F, ramp_up_time = T)`
    -> `kind = "tip_force", value = F, ramp_time = T` (both scale by min(1, t / T)); the lab tip
    couple of `run_case` (Q_{n-1} M, ramped the same way) -> `kind = "tip_couple"`.
  * PyElastica's `time` after k steps is a running sum of dt / 2; octoarm's is k dt. The two
    differ by round-off only (they enter through the ramps).
"""

import argparse
import importlib.metadata
import json
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from pyelastica_reference import run_case  # noqa: E402

SHEAR_COEFFICIENT = 27.0 / 28.0

CASES = [
    {
        # nu dt = 1e-3, near-critically damped first bending mode (omega_1 ~ 10 rad/s, nu = 25/s):
        # large 3D motion with twist (the tip couple), decaying after the ramps.
        "name": "pyelastica_damping_tapered",
        "description": "tapered clamped rod, gravity -z, ramped lab tip force and tip couple on "
        "all axes, AnalyticalLinearDamper uniform nu = 25 1/s, nu dt = 1e-3",
        "n": 16,
        "length": 0.5,
        "base_diameter": 0.04,
        "tip_diameter": 0.016,
        "density": 1000.0,
        "youngs_modulus": 4.0e6,
        "shear_modulus": 1.6e6,
        "boundary": "clamped",
        "direction": [1.0, 0.0, 0.0],
        "normal": [0.0, 1.0, 0.0],
        "dt": 4.0e-5,
        "steps": 5000,
        "save_interval": 0.01,
        "snapshots": [250, 1250, 2500, 3750, 5000],
        "gravity": [0.0, 0.0, -9.81],
        "tip_force": [0.3, 0.6, -0.4],
        "tip_couple": [0.02, -0.03, 0.025],
        "ramp_time": 0.05,
        "damper": {"kind": "uniform", "nu": 25.0},
    },
    {
        # nu dt = 1e-2, overdamped (nu = 100/s >> omega_1 ~ 10 rad/s): the rod creeps toward its
        # loaded equilibrium; along +y with d1 = +z (another frame than case 1).
        "name": "pyelastica_damping_uniform",
        "description": "uniform clamped rod along +y, gravity -z, ramped tip force on all axes, "
        "AnalyticalLinearDamper uniform nu = 100 1/s, nu dt = 1e-2",
        "n": 16,
        "length": 0.5,
        "base_diameter": 0.03,
        "tip_diameter": 0.03,
        "density": 1000.0,
        "youngs_modulus": 1.0e7,
        "shear_modulus": 4.0e6,
        "boundary": "clamped",
        "direction": [0.0, 1.0, 0.0],
        "normal": [0.0, 0.0, 1.0],
        "dt": 1.0e-4,
        "steps": 3000,
        "save_interval": 0.025,
        "snapshots": [250, 1000, 2000, 3000],
        "gravity": [0.0, 0.0, -9.81],
        "tip_force": [-0.5, 0.3, 0.8],
        "ramp_time": 0.05,
        "damper": {"kind": "uniform", "nu": 100.0},
    },
]


def toml_float(x):
    """Python's repr of a float is a valid TOML float and round-trips exactly."""
    return repr(float(x))


def toml_vec(v):
    return "[" + ", ".join(toml_float(x) for x in v) + "]"


def scenario_toml(spec):
    """The octoarm scenario of a case (protocol = "pyelastica")."""
    assert spec["boundary"] == "clamped" and spec["damper"]["kind"] == "uniform"
    duration = spec["steps"] * spec["dt"]
    save_every = spec["save_interval"] / spec["dt"]
    assert round(duration / spec["dt"]) == spec["steps"]
    assert all(s % round(save_every) == 0 for s in spec["snapshots"])
    lines = [
        f"# Generated by scripts/pyelastica_damping_reference.py (with {spec['name']} in",
        "# pyelastica_damping.json): the rod, loads and damper of a PyElastica 1.0.0 run.",
        f'description = "{spec["description"]}"',
        "",
        "[rod]",
        f"n_elements = {spec['n']}",
        f"length = {toml_float(spec['length'])}",
        f"base_diameter = {toml_float(spec['base_diameter'])}",
        f"tip_diameter = {toml_float(spec['tip_diameter'])}",
        f"density = {toml_float(spec['density'])}",
        f"youngs_modulus = {toml_float(spec['youngs_modulus'])}",
        f"shear_modulus = {toml_float(spec['shear_modulus'])}",
        f"shear_coefficient = {toml_float(SHEAR_COEFFICIENT)}  # 27/28, PyElastica 1.0's",
        f"direction = {toml_vec(spec['direction'])}",
        f"normal = {toml_vec(spec['normal'])}",
        'base = "clamped"',
        "",
        "[time]",
        f"dt = {toml_float(spec['dt'])}",
        f"duration = {toml_float(duration)}  # {spec['steps']} steps",
        f"save_interval = {toml_float(spec['save_interval'])}",
        "",
        "[damping]",
        f"rate = {toml_float(spec['damper']['nu'])}",
        'protocol = "pyelastica"',
    ]
    if "gravity" in spec:
        lines += ["", "[[load]]", 'kind = "gravity"', f"value = {toml_vec(spec['gravity'])}"]
    for key, kind in [("tip_force", "tip_force"), ("tip_couple", "tip_couple")]:
        if key in spec:
            lines += [
                "",
                "[[load]]",
                f'kind = "{kind}"',
                f"value = {toml_vec(spec[key])}",
                f"ramp_time = {toml_float(spec['ramp_time'])}",
            ]
    return "\n".join(lines) + "\n"


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out-dir", default="crates/app/tests/data")
    args = p.parse_args()
    os.makedirs(args.out_dir, exist_ok=True)
    cases = []
    for spec in CASES:
        case = run_case(spec)
        case["scenario"] = spec["name"] + ".toml"
        case["steps"] = spec["steps"]
        case["save_interval"] = spec["save_interval"]
        cases.append(case)
        path = os.path.join(args.out_dir, case["scenario"])
        with open(path, "w") as f:
            f.write(scenario_toml(spec))
        print(f"wrote {path}")
    data = {
        "generator": "scripts/pyelastica_damping_reference.py",
        "pyelastica_version": importlib.metadata.version("pyelastica"),
        "numpy_version": np.__version__,
        "cases": cases,
    }
    path = os.path.join(args.out_dir, "pyelastica_damping.json")
    with open(path, "w") as f:
        json.dump(data, f, separators=(",", ":"))
        f.write("\n")
    print(f"wrote {path}")


if __name__ == "__main__":
    main()
