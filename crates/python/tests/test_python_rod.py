"""Rod construction, stepping, array shapes/dtypes/units, errors, GIL release."""

import threading
import time

import numpy as np
import pytest

import octoarm


def test_paper_arm_arrays_shapes_dtypes_units():
    sim = octoarm.Simulation.paper_arm()
    n = sim.n_elements
    assert n == 100 and sim.dt == 1e-5 and sim.time == 0.0
    for name, shape in [
        ("positions", (n + 1, 3)),
        ("velocities", (n + 1, 3)),
        ("directors", (n, 3, 3)),
        ("angular_velocities", (n, 3)),
        ("rest_sigma", (n, 3)),
        ("rest_kappa", (n - 1, 3)),
    ]:
        a = getattr(sim, name)
        assert a.shape == shape and a.dtype == np.float64 and a.flags.c_contiguous, name
    # Units: metres; the arm is 0.2 m long along +x with d1 = e_y, d3 = e_x.
    assert sim.positions[-1] == pytest.approx([0.2, 0.0, 0.0])
    np.testing.assert_array_equal(sim.directors[0], [[0, 1, 0], [0, 0, 1], [1, 0, 0]])
    sigma, kappa = sim.strains()
    assert sigma.shape == (n, 3) and kappa.shape == (n - 1, 3)
    assert np.abs(sigma).max() < 1e-13  # round-off of l/l̂ - 1 and np.abs(kappa).max() == 0.0
    e = sim.energies()
    assert set(e) >= {"kinetic", "potential", "total", "bend", "stretch", "dissipated"}
    assert 0.0 <= e["total"] < 1e-25  # J, round-off of the straight rest state
    m = sim.model()
    assert m["rest_length"].shape == (n,) and m["node_mass"].shape == (n + 1,)
    assert m["node_mass"].sum() == pytest.approx(1.49595e-2, rel=5e-5)  # kg, spec table


def test_arrays_are_copies():
    sim = octoarm.Simulation.paper_arm()
    x = sim.positions
    x[:] = 7.0
    assert sim.positions[-1, 0] == pytest.approx(0.2)
    sim.add_node_force([0.0, 2e-5, 0.0])
    before = sim.positions
    sim.step(100)
    assert before[-1, 1] == 0.0 and sim.positions[-1, 1] > 0.0


def test_tip_force_bends_and_energy_flows():
    sim = octoarm.Simulation.paper_arm()
    sim.set_damping(rate=10.0)
    sim.add_node_force([0.0, 2e-5, 0.0])
    sim.step(1000)
    assert sim.steps == 1000 and sim.time == pytest.approx(0.01)
    assert sim.tip[1] > 0.0
    e = sim.energies()
    assert e["external_work"] > 0 and e["dissipated"] > 0
    assert e["total"] <= e["external_work"]


def test_same_input_same_bits_and_copy():
    a = octoarm.Simulation.paper_arm()
    a.add_gravity([0.0, -9.81, 0.0])
    a.set_damping(rate=10.0)
    b = a.copy()
    a.step(500)
    for _ in range(5):
        b.step(100)
    np.testing.assert_array_equal(a.positions, b.positions)
    np.testing.assert_array_equal(a.directors, b.directors)


def test_custom_rod_rest_strains_obstacle_loads():
    sim = octoarm.Simulation(
        n_elements=20, length=0.5, base_diameter=0.01, tip_diameter=0.01,
        density=1000.0, youngs_modulus=1e6, shear_modulus=4e5, dt=1e-5,
    )
    n = sim.n_elements
    kappa = np.zeros((n - 1, 3))
    kappa[:, 1] = 2.0
    sim.set_rest_strains(np.zeros((n, 3)), kappa)
    np.testing.assert_array_equal(sim.rest_kappa, kappa)
    sim.add_obstacle([0.3, -0.2, 0.0], 0.05)
    sim.add_uniform_force([0.0, 0.0, 0.0])
    sim.add_uniform_couple([0.0, 0.0, 0.0], follower=True)
    sim.add_element_couple([0.0, 0.0, 0.0])
    sim.set_damping(rate=5.0, gamma=0.0)
    sim.step(200)
    assert np.isfinite(sim.positions).all()


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(length=-1.0), "length"),
        (dict(n_elements=1), "n_elements"),
        (dict(youngs_modulus=float("nan")), "youngs_modulus"),
        (dict(dt=0.0), "dt"),
        (dict(boundary="pinned"), "boundary"),
        (dict(normal=[1.0, 0.0, 0.0]), "normal"),
    ],
)
def test_bad_construction_raises_value_error_naming_argument(kwargs, field):
    with pytest.raises(ValueError, match=field) as info:
        octoarm.Simulation(**kwargs)
    assert "allowed" in str(info.value) or "must" in str(info.value)


def test_bad_calls_raise_value_error():
    sim = octoarm.Simulation.paper_arm()
    with pytest.raises(ValueError, match=r"node = 101 is outside the allowed range \[0, 100\]"):
        sim.add_node_force([0, 0, 0], node=101)
    with pytest.raises(ValueError, match="damping.rate"):
        sim.set_damping(rate=-1.0)
    with pytest.raises(ValueError, match="obstacle.radius"):
        sim.add_obstacle([0, 0, 0], 0.0)
    with pytest.raises(ValueError, match=r"kappa has shape \(3, 3\), expected \(99, 3\)"):
        sim.set_rest_strains(np.zeros((100, 3)), np.zeros((3, 3)))
    with pytest.raises(ValueError, match="n = -1"):
        sim.step(-1)
    with pytest.raises(ValueError, match="control_period"):
        octoarm.ArmBatch(control_period=0.01, dt=3e-5)


def test_instability_error_carries_time_element_and_suggested_dt():
    sim = octoarm.Simulation.paper_arm(dt=1e-3)
    with pytest.raises(octoarm.InstabilityError) as info:
        sim.step(1000)
    e = info.value
    assert isinstance(e, RuntimeError)
    assert e.time > 0 and e.dt == 1e-3 and 0 < e.suggested_dt < 1e-3
    assert e.domain in ("node", "element", "voronoi point")
    assert 0 <= e.element <= 100 and e.element == e.index and e.step > 0
    assert "dt" in str(e)


def test_gil_is_released_while_stepping():
    sim = octoarm.Simulation.paper_arm()
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.perf_counter())
            time.sleep(0.001)

    t = threading.Thread(target=ticker)
    t.start()
    time.sleep(0.01)
    start = time.perf_counter()
    sim.step(40_000)  # ~0.2 s
    end = time.perf_counter()
    stop.set()
    t.join()
    during = [x for x in ticks if start < x < end]
    assert end - start > 0.05
    assert len(during) >= 10, f"only {len(during)} ticks while stepping for {end - start:.3f} s"
