"""pickle and copy.deepcopy of a Simulation are exact: a copy taken mid-run and stepped N steps
equals the original stepped N steps to the last bit (state, time, energies, guard history)."""

import copy
import pickle

import numpy as np
import pytest

import octoarm
from octoarm import Joint, Motion, Rod, Simulation


def _assert_same(a, b):
    assert a.rod_names == b.rod_names
    assert a.time == b.time and a.steps == b.steps and a.dt == b.dt
    for name in a.rod_names:
        sa, sb = a.rod_state(name), b.rod_state(name)
        for k in ["positions", "velocities", "directors", "angular_velocities"]:
            assert sa[k].tobytes() == sb[k].tobytes(), (name, k)
        assert sa["time"] == sb["time"]
        ea, eb = a.energies(rod=name), b.energies(rod=name)
        assert ea == eb, name  # every energy, the external work and dissipation, exactly
        for x, y in zip(a.rest_strains(rod=name), b.rest_strains(rod=name)):
            assert x.tobytes() == y.tobytes()


STIFF = dict(youngs_modulus=1e6, shear_modulus=4e5)


def _loaded_arm():
    sim = Simulation(n_elements=30, length=0.3, base_diameter=0.01, tip_diameter=0.005,
                     dt=1e-5, **STIFF)
    sim.add_gravity([0.0, -9.81, 0.0])
    sim.add_node_force([0.0, 2e-4, 1e-4], ramp_time=0.02)  # a ramp crossing the pickle time
    sim.add_element_couple([0.0, 0.0, 1e-6], element=10, follower=True)
    # A sphere rising into the arm: contact starts after the pickle.
    sim.add_obstacle([0.2, -0.025, 0.0], 0.005, velocity=[0.0, 0.5, 0.0])
    sim.set_damping(rate=3.0, gamma=1e-3)
    kappa = np.zeros((29, 3))
    kappa[:, 1] = 1.5
    sim.set_rest_strains(np.zeros((30, 3)), kappa)
    return sim


def _system():
    motion = Motion([0.0, 0.02, 0.05], displacement=[[0, 0, 0], [0, 0.001, 0], [0, 0.001, 5e-4]],
                    rotation=[[0, 0, 0], [0.0, 0.0, 0.05], [0.02, 0.0, 0.05]])
    rods = [
        Rod("arm", n_elements=12, base_diameter=0.01, tip_diameter=0.008, base=motion, **STIFF),
        Rod("hand", n_elements=8, length=0.08, base_diameter=0.008, tip_diameter=0.006,
            base_position=[0.2, 0.0, 0.0], base="free", **STIFF),
        Rod("finger", n_elements=5, length=0.03, base_diameter=0.006, tip_diameter=0.005,
            base_position=[0.28, 0.0, 0.0], base="free", tip="pinned", **STIFF),
    ]
    joints = [Joint("hinge", "arm.tip", "hand.base", axis=[0, 0, 1], damping=1e-3),
              Joint("free", "hand.tip", "finger.base")]
    sim = Simulation.from_rods(rods, joints, dt=1e-5, energy_consistent=True)
    for name in sim.rod_names:
        sim.add_gravity([0.0, -9.81, 0.0], rod=name)
        sim.set_damping(rate=5.0, rod=name)
    return sim


def _arm_on_floor():
    # A uniform arm resting on a floor with anisotropic friction, pushed sideways: the floor's
    # stick springs (the friction's memory, part of the state) are loaded when it is copied.
    sim = Simulation(n_elements=30, length=0.3, base_diameter=0.01, tip_diameter=0.01,
                     dt=1e-5, **STIFF)
    sim.add_gravity([0.0, 0.0, -9.81])
    sim.add_plane([0.0, 0.0, -0.005], [0.0, 0.0, 1.0], friction=[0.2, 0.4, 0.6],
                  kinetic_friction=[0.15, 0.3, 0.5])
    sim.add_node_force([0.0, 2e-3, 0.0], ramp_time=0.02)
    sim.set_damping(rate=3.0)
    return sim


@pytest.mark.parametrize("make", [_loaded_arm, _system, _arm_on_floor],
                         ids=["arm", "system", "floor"])
@pytest.mark.parametrize("how", ["pickle", "deepcopy", "bytes"])
def test_copy_mid_run_steps_to_the_same_bits(make, how):
    sim = make()
    sim.step(1237)  # not a multiple of the guard (100) or orthonormality (1000) intervals
    if how == "pickle":
        other = pickle.loads(pickle.dumps(sim, protocol=pickle.HIGHEST_PROTOCOL))
    elif how == "deepcopy":
        other = copy.deepcopy(sim)
    else:
        other = Simulation.from_bytes(sim.to_bytes())
    assert type(other) is Simulation and other is not sim
    _assert_same(sim, other)
    for n in [1, 763, 2000]:  # across guard checks, a re-orthonormalisation and the ramp's end
        sim.step(n)
        other.step(n)
        _assert_same(sim, other)


def test_every_pickle_protocol_and_independence():
    sim = _loaded_arm()
    sim.step(50)
    for protocol in range(pickle.HIGHEST_PROTOCOL + 1):
        other = pickle.loads(pickle.dumps(sim, protocol=protocol))
        _assert_same(sim, other)
    other = copy.deepcopy(sim)
    other.step(10)
    other.clear_loads()
    assert sim.steps == 50 and other.steps == 60
    shallow = copy.copy(sim)
    shallow.step(1)
    assert sim.steps == 50  # a copy owns its state


def test_pickled_controlled_arm_keeps_its_actuation():
    sim = Simulation.paper_arm(n_elements=40)
    design = octoarm.OfflineSolver(sim).solve(target=[0.1, 0.08, 0.0])
    ctrl = octoarm.EnergyShapingController(sim, damping_rate=10.0)
    ctrl.set_design(sim, design)
    ctrl.step(sim, 500)
    other = pickle.loads(pickle.dumps(sim))
    ctrl.step(sim, 1500)
    other.step(1500)  # the law's stresses are in the simulation's actuation: plain steps suffice
    _assert_same(sim, other)
    assert ctrl.shaped_hamiltonian(sim) == ctrl.shaped_hamiltonian(other)


def test_bad_bytes_are_refused():
    with pytest.raises(ValueError, match="not a pickled octoarm.Simulation"):
        Simulation.from_bytes(b"nonsense")
    data = Simulation(n_elements=4).to_bytes()
    with pytest.raises(ValueError, match="not a pickled octoarm.Simulation"):
        Simulation.from_bytes(data[:-10])
    with pytest.raises(ValueError, match="left over"):
        Simulation.from_bytes(data + b"\0")
    tag = b"octoarm.Simulation"
    assert data.startswith(tag)
    other_version = data[: len(tag)] + bytes([99]) + data[len(tag) + 1:]
    with pytest.raises(ValueError, match="format 99"):
        Simulation.from_bytes(other_version)
