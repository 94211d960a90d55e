"""Rod systems from Python: Rod, Motion, Joint, Simulation.from_rods, end conditions, per-rod
state access with shape checks, rod selection, and the one-rod shortcuts."""

import numpy as np
import pytest

import octoarm
from octoarm import Joint, Motion, Rod, Simulation


def _bits_equal(a, b):
    for name in ["positions", "velocities", "directors", "angular_velocities"]:
        np.testing.assert_array_equal(a[name], b[name], err_msg=name)
    assert a["time"] == b["time"]


def _two_rods(**joint):
    arm = Rod("arm", n_elements=10, length=0.2, base_diameter=0.02, tip_diameter=0.01)
    hand = Rod("hand", n_elements=6, length=0.1, base_diameter=0.01, tip_diameter=0.005,
               base_position=[0.2, 0.0, 0.0], base="free")
    joints = [Joint("fixed", "arm.tip", "hand.base", **joint)]
    return Simulation.from_rods([arm, hand], joints, dt=1e-5)


def test_one_rod_from_rods_equals_the_constructor_bit_for_bit():
    a = Simulation(n_elements=20, dt=2e-5)
    b = Simulation.from_rods([Rod(n_elements=20)], dt=2e-5)
    assert a.rod_names == b.rod_names == ["rod"]
    for s in (a, b):
        s.add_gravity([0.0, -9.81, 0.0])
        s.set_damping(rate=5.0)
        s.step(3000)
    _bits_equal(a.rod_state(), b.rod_state())
    assert a.energies() == b.energies()


def test_rod_parameters_and_defaults():
    r = Rod()
    assert r.name == "rod" and r.n_elements == 100 and r.length == 0.2
    assert (r.base, r.tip) == ("clamped", "free")
    assert r.direction == [1.0, 0.0, 0.0] and r.normal == [0.0, 1.0, 0.0]
    m = Motion([0.0, 1.0], displacement=[[0, 0, 0], [0.01, 0, 0]])
    r = Rod("x", n_elements=5, tip=m, base="pinned", rest_curvature=[0.0, 2.0, 0.0])
    assert r.base == "pinned" and isinstance(r.tip, Motion) and r.rest_curvature[1] == 2.0
    np.testing.assert_array_equal(r.tip.displacement, [[0, 0, 0], [0.01, 0, 0]])
    with pytest.raises(ValueError, match="length"):
        Rod(length=-1.0)
    with pytest.raises(ValueError, match=r"tip = \"driven\" is not allowed"):
        Rod(tip="driven")
    with pytest.raises(TypeError, match="base must be"):
        Rod(base=3)
    with pytest.raises(ValueError, match="name"):
        Rod("")


def test_end_conditions_of_the_one_rod_constructor():
    free = Simulation(n_elements=10, boundary="free")
    both = Simulation(n_elements=10, base="free", tip="free")
    for s in (free, both):
        s.add_node_force([0.0, 1e-5, 0.0], node=0)
        s.step(500)
    _bits_equal(free.rod_state(), both.rod_state())
    assert free.positions[0, 1] > 0.0  # a free base moves
    pinned = Simulation(n_elements=10, base="pinned")
    pinned.add_node_force([0.0, 1e-5, 0.0])
    pinned.step(2000)
    np.testing.assert_array_equal(pinned.positions[0], [0.0, 0.0, 0.0])  # node held
    assert not np.array_equal(pinned.directors[0], Simulation(n_elements=10).directors[0])
    with pytest.raises(ValueError, match="boundary"):
        Simulation(boundary="free", base="pinned")


def test_driven_end_follows_its_motion():
    motion = Motion([0.0, 0.01, 0.02], displacement=[[0, 0, 0], [0, 0.001, 0], [0, 0.001, 0]],
                    rotation=[[0, 0, 0], [0, 0, 0.05], [0, 0, 0.1]])
    # A stiff rod: the guard's energy bound does not count the work of a driven end, so a soft
    # one (the paper arm) trips it when its base is moved this fast.
    sim = Simulation(n_elements=10, base_diameter=0.01, tip_diameter=0.01, youngs_modulus=1e6,
                     shear_modulus=4e5, base=motion, dt=1e-5)
    sim.set_damping(rate=10.0)
    sim.step(500)  # t = 5 ms: half way through the first segment
    d, r = motion.at(sim.time)
    np.testing.assert_allclose(d, [0.0, 0.0005, 0.0], rtol=1e-9)
    np.testing.assert_allclose(sim.positions[0], d, atol=1e-15)
    sim.step(2000)  # past the last sample: held
    np.testing.assert_allclose(sim.positions[0], [0.0, 0.001, 0.0], atol=1e-15)
    c, s = np.cos(0.1), np.sin(0.1)
    # Directors turn as d -> R d about z by 0.1 rad: d3 = e_x -> (c, s, 0), d1 = e_y -> (-s, c, 0).
    np.testing.assert_allclose(sim.directors[0][2], [c, s, 0.0], atol=1e-12)
    np.testing.assert_allclose(sim.directors[0][0], [-s, c, 0.0], atol=1e-12)
    with pytest.raises(ValueError, match=r"motion.times\[0\]"):
        Motion([0.5, 1.0])
    with pytest.raises(ValueError, match=r"displacement has shape \(3, 3\), expected \(2, 3\)"):
        Motion([0.0, 1.0], displacement=np.zeros((3, 3)))
    with pytest.raises(ValueError, match="motion.times"):
        Motion([0.0])


def test_two_rods_joint_and_rod_selection():
    sim = _two_rods()
    assert sim.rod_names == ["arm", "hand"] and sim.n_rods == 2
    st = sim.state()
    assert list(st) == ["arm", "hand"]
    assert st["arm"]["positions"].shape == (11, 3) and st["hand"]["directors"].shape == (6, 3, 3)
    assert st["hand"]["angular_velocities"].shape == (6, 3)
    for getter in ["positions", "velocities", "directors", "angular_velocities", "tip",
                   "rest_sigma", "rest_kappa", "n_elements"]:
        with pytest.raises(ValueError, match=r"rod_state\(name\)") as info:
            getattr(sim, getter)
        assert '"arm", "hand"' in str(info.value), getter
    with pytest.raises(ValueError, match=r'2 rods \("arm", "hand"\): pass rod=NAME'):
        sim.add_gravity([0.0, -9.81, 0.0])
    with pytest.raises(ValueError, match=r'rod = "leg" is not a rod of this simulation'):
        sim.rod_state("leg")
    with pytest.raises(ValueError, match="pass rod=NAME"):
        sim.rod_state()
    with pytest.raises(ValueError, match="pass rod=NAME"):
        sim.energies()
    for name in sim.rod_names:
        sim.add_gravity([0.0, -9.81, 0.0], rod=name)
        sim.set_damping(rate=20.0, rod=name)
    sim.add_node_force([0.0, 0.0, 1e-5], rod="hand")
    sim.step(5000)
    arm, hand = sim.rod_state("arm"), sim.rod_state("hand")
    assert arm["time"] == hand["time"] == sim.time == pytest.approx(0.05)
    gap = np.linalg.norm(arm["positions"][-1] - hand["positions"][0])
    assert gap < 1e-3 * 0.2  # the joint holds the hand on the arm's tip
    assert hand["positions"][-1, 1] < 0.0 and hand["positions"][-1, 2] > 0.0
    e = sim.energies(rod="hand")
    assert e["external_work"] != 0.0 and e["dissipated"] > 0.0
    sigma, kappa = sim.strains(rod="hand")
    assert sigma.shape == (6, 3) and kappa.shape == (5, 3)
    assert sim.model(rod="arm")["node_mass"].shape == (11,)


def test_joint_parameters_and_errors():
    j = Joint("hinge", "a.tip", "b.base", axis=[0, 0, 1], stiffness=10.0)
    assert (j.kind, j.first, j.second, j.axis, j.stiffness, j.damping) == (
        "hinge", "a.tip", "b.base", [0.0, 0.0, 1.0], 10.0, None)
    with pytest.raises(ValueError, match="axis is required"):
        Joint("hinge", "a.tip", "b.base")
    with pytest.raises(ValueError, match="axis is only for"):
        Joint("free", "a.tip", "b.base", axis=[0, 0, 1])
    with pytest.raises(ValueError, match="kind = \"ball\" is not allowed"):
        Joint("ball", "a.tip", "b.base")
    with pytest.raises(ValueError, match=r'first = "a" is not allowed; use "<rod name>.base"'):
        Joint("free", "a", "b.base")
    with pytest.raises(ValueError, match="stiffness = -1"):
        Joint("free", "a.tip", "b.base", stiffness=-1.0)
    with pytest.raises(ValueError, match=r'no rod called "c"; the rods are "a", "b"'):
        Simulation.from_rods([Rod("a", n_elements=4), Rod("b", n_elements=4)],
                             [Joint("free", "a.tip", "c.base")])
    with pytest.raises(ValueError, match="used twice"):
        Simulation.from_rods([Rod("a", n_elements=4), Rod("a", n_elements=4)])
    with pytest.raises(ValueError, match="rods"):
        Simulation.from_rods([])
    # A stiffer joint than the default holds the two ends closer together.
    gaps = []
    for k in [None, 1e3]:
        sim = _two_rods(stiffness=k)
        sim.add_node_force([0.0, 2e-4, 0.0], rod="hand")
        sim.set_damping(rate=20.0, rod="arm")
        sim.set_damping(rate=20.0, rod="hand")
        sim.step(3000)
        a, h = sim.rod_state("arm"), sim.rod_state("hand")
        gaps.append(np.linalg.norm(a["positions"][-1] - h["positions"][0]))
    assert gaps[1] < gaps[0]


def test_set_rod_state_checks_shapes_and_values_and_writes_nothing_on_error():
    sim = Simulation(n_elements=10)
    before = sim.rod_state()
    with pytest.raises(ValueError, match=r"positions has shape \(33,\), expected \(11, 3\)"):
        sim.set_rod_state(positions=np.zeros(33))
    with pytest.raises(ValueError, match=r"directors has shape \(10, 9\), expected \(10, 3, 3\)"):
        sim.set_rod_state(directors=np.zeros((10, 9)))
    with pytest.raises(ValueError, match=r"angular_velocities has shape \(11, 3\), expected \(10, 3\)"):
        sim.set_rod_state(angular_velocities=np.zeros((11, 3)))
    v = np.zeros((11, 3))
    v[4, 1] = np.nan
    with pytest.raises(ValueError, match=r"velocities must be finite: entry \[4, 1\] is NaN"):
        sim.set_rod_state(velocities=v, positions=before["positions"] + 1.0)
    q = before["directors"].copy()
    q[3] *= 2.0
    with pytest.raises(ValueError, match=r"directors\[3\] is not orthonormal"):
        sim.set_rod_state(directors=q)
    with pytest.raises(TypeError):
        sim.set_rod_state(None, np.zeros((11, 3)))  # arrays are keyword-only
    _bits_equal(sim.rod_state(), before)  # nothing written
    # A subset, from lists: velocities only; the clamped base keeps its held (zero) rate.
    v = np.zeros((11, 3))
    v[:, 1] = np.linspace(0.0, 0.01, 11)
    sim.set_rod_state(velocities=v.tolist())
    np.testing.assert_array_equal(sim.velocities, v)
    np.testing.assert_array_equal(sim.positions, before["positions"])
    sim.step(100)  # the guard takes the new kinetic energy as its reference
    assert sim.positions[-1, 1] > 0.0
    assert sim.velocities[0].tolist() == [0.0, 0.0, 0.0]


def test_state_and_set_state_copy_a_system_state():
    a, b = _two_rods(), _two_rods()
    a.add_node_force([0.0, 1e-4, 0.0], rod="hand")
    a.step(1000)
    b.set_state(a.state())
    for name in a.rod_names:
        sa, sb = a.rod_state(name), b.rod_state(name)
        for k in ["positions", "velocities", "directors", "angular_velocities"]:
            np.testing.assert_array_equal(sa[k], sb[k])
    assert b.time == 0.0  # time is the step count's, not state that is written
    b.set_state({"hand": {"velocities": np.zeros((7, 3))}})
    np.testing.assert_array_equal(b.rod_state("hand")["velocities"], 0.0)
    with pytest.raises(ValueError, match='rod "hand" has an entry "position"'):
        b.set_state({"hand": {"position": np.zeros((7, 3))}})
    with pytest.raises(ValueError, match='rod = "leg" is not a rod'):
        b.set_state({"leg": {}})
    good = b.rod_state("arm")
    with pytest.raises(ValueError, match="positions has shape"):
        b.set_state({"arm": {"velocities": np.ones((11, 3))},
                     "hand": {"positions": np.zeros((6, 3))}})
    _bits_equal(b.rod_state("arm"), good)  # all or nothing


def test_loads_and_rest_strains_per_rod():
    sim = _two_rods()
    n = 6
    kappa = np.zeros((n - 1, 3))
    kappa[:, 0] = 3.0
    sim.set_rest_strains(np.zeros((n, 3)), kappa, rod="hand")
    s, k = sim.rest_strains(rod="hand")
    np.testing.assert_array_equal(k, kappa)
    np.testing.assert_array_equal(sim.rest_strains(rod="arm")[1], 0.0)
    with pytest.raises(ValueError, match=r"kappa has shape \(9, 3\), expected \(5, 3\)"):
        sim.set_rest_strains(np.zeros((n, 3)), np.zeros((9, 3)), rod="hand")
    with pytest.raises(ValueError, match=r"node = 7 is outside the allowed range \[0, 6\]"):
        sim.add_node_force([0, 0, 0], node=7, rod="hand")
    with pytest.raises(ValueError, match="ramp_time"):
        sim.add_node_force([0, 0, 0], ramp_time=-1.0, rod="hand")
    sim.add_element_couple([0.0, 0.0, 1e-6], follower=True, ramp_time=0.01, rod="arm")
    sim.add_uniform_couple([0.0, 0.0, 1e-6], rod="arm")
    sim.add_uniform_force([0.0, 1e-5, 0.0], rod="hand")
    sim.add_obstacle([0.5, 0.5, 0.0], 0.01)
    sim.step(200)
    assert np.isfinite(sim.rod_state("hand")["positions"]).all()
    sim.clear_loads()
    sim.clear_obstacles()


def test_instability_names_the_rod_of_a_system():
    sim = _two_rods()
    sim.add_node_force([0.0, 1.0, 0.0], rod="hand")  # far too much for this thin hand
    with pytest.raises(octoarm.InstabilityError) as info:
        sim.step(20_000)
    assert info.value.rod in ("arm", "hand", None)
    single = Simulation.paper_arm(dt=1e-3)
    with pytest.raises(octoarm.InstabilityError) as info:
        single.step(1000)
    assert info.value.rod is None
