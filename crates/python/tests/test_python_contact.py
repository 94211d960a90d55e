"""Contact from Python (issue 11): planes, cylinders and rod contact reach the physics, and bad
friction input is refused with the field named. The physics itself is tested in Rust
(crates/physics/tests/{plane,cylinder,rod}_contact.rs); here the bindings: a free rod dropped on a
floor comes to rest on it (its centreline one radius above, to 1 % of the radius), where without
the floor it falls through."""

import numpy as np
import pytest

import octoarm


def rod_above_floor(floor: bool) -> octoarm.Simulation:
    sim = octoarm.Simulation(
        n_elements=20, length=0.2, base_diameter=0.01, tip_diameter=0.01, density=1000.0,
        youngs_modulus=1e6, shear_modulus=1e6 / 3, base_position=(0.0, 0.0, 0.01),
        boundary="free", dt=2e-5,
    )
    sim.add_gravity((0.0, 0.0, -9.81))
    sim.set_damping(rate=20.0)
    if floor:
        sim.add_plane((0.0, 0.0, 0.0), (0.0, 0.0, 2.0), friction=0.5, kinetic_friction=0.4)
    return sim


def test_a_rod_dropped_on_a_floor_rests_on_it():
    sim = rod_above_floor(True)
    sim.step(50_000)
    z = sim.positions[:, 2]
    assert np.all(np.abs(z - 0.005) < 0.01 * 0.005), z
    free = rod_above_floor(False)
    free.step(50_000)
    assert free.positions[:, 2].max() < -0.1


@pytest.mark.parametrize("geometry", ["polyline", "smooth"])
def test_cylinder_and_rod_contact_are_accepted(geometry):
    sim = rod_above_floor(False)
    sim.add_cylinder((0.1, 0.0, -0.02), (0.0, 1.0, 0.0), 0.02, 0.1, friction=(0.2, 0.3, 0.4))
    sim.set_contact(self_contact=True, rod_friction=0.3, rod_geometry=geometry)
    sim.step(20_000)
    # Resting on top of the cylinder (radius 2 cm + rod radius 5 mm around its axis).
    mid = sim.positions[10]
    assert abs(np.hypot(mid[0] - 0.1, mid[2] + 0.02) - 0.025) < 1e-3, mid


@pytest.mark.parametrize(
    "call, field",
    [
        (lambda s: s.add_plane((0, 0, 0), (0, 0, 1), friction=-0.1), "friction.static"),
        (lambda s: s.add_plane((0, 0, 0), (0, 0, 1), friction=0.2, kinetic_friction=0.3),
         "friction.kinetic"),
        (lambda s: s.add_plane((0, 0, 0), (0, 0, 0)), "plane.normal"),
        (lambda s: s.add_cylinder((0, 0, 0), (0, 0, 1), -1.0, 1.0), "cylinder.radius"),
        (lambda s: s.set_contact(friction_eta=2.0), "contact.friction_eta"),
        (lambda s: s.set_contact(rods=True, rod_geometry="curved"), "rod_geometry"),
    ],
)
def test_bad_contact_input_names_the_field(call, field):
    sim = rod_above_floor(False)
    with pytest.raises(ValueError, match=field.replace(".", r"\.")):
        call(sim)
