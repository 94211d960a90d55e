"""dt="auto" in the Python constructors (issue 13, item 4): dt is 0.2 of the system's stable
limit, re-chosen while no step has been taken, with the guard's re-check armed; the arm it
simulates settles where the fixed-dt arm does (the static answer does not depend on dt); bad
values are refused naming dt and what is allowed."""

import pickle

import numpy as np
import pytest

import octoarm


def test_auto_dt_is_a_fifth_of_the_stable_limit_on_every_constructor():
    sims = [
        octoarm.Simulation(n_elements=40, dt="auto"),
        octoarm.Simulation.paper_arm(dt="auto"),
        octoarm.Simulation.coomm_arm(dt="auto", n_elements=20),
        octoarm.Simulation.from_rods([octoarm.Rod("arm", n_elements=30)], dt="auto"),
    ]
    for sim in sims:
        assert sim.auto_dt
        assert sim.dt == 0.2 * sim.stable_dt
    fixed = octoarm.Simulation.paper_arm()
    assert not fixed.auto_dt and fixed.dt == 1e-5


def test_contact_added_before_the_first_step_rechooses_dt_and_not_after():
    sim = octoarm.Simulation.paper_arm(dt="auto", n_elements=50)
    limit = sim.stable_dt
    sim.add_plane([0.0, -0.05, 0.0], [0.0, 1.0, 0.0])
    sim.set_contact(beta=400.0)  # a contact spring 20x faster than the rod's fastest mode
    assert sim.stable_dt < 0.5 * limit
    assert sim.dt == 0.2 * sim.stable_dt
    sim.step(5)
    dt = sim.dt
    sim.set_contact(beta=1600.0)
    assert sim.dt == dt


def test_auto_dt_settles_where_the_papers_dt_does():
    # A tip force on the damped paper arm: the settled deflection is the static answer, the same
    # for any stable dt (to the decay left after 3 s at 10 1/s).
    tips = []
    for dt in ["auto", 1e-5]:
        sim = octoarm.Simulation.paper_arm(dt=dt, n_elements=50)
        sim.set_damping(rate=10.0)
        sim.add_node_force([0.0, 2e-5, 0.0])
        sim.step(round(3.0 / sim.dt))
        tips.append(sim.tip)
    auto_dt = octoarm.Simulation.paper_arm(dt="auto", n_elements=50).dt
    assert auto_dt > 2e-5  # the automatic step is larger than the paper's
    deflection = abs(tips[1][1])
    assert deflection > 1e-3
    assert np.max(np.abs(tips[0] - tips[1])) < 1e-4 * deflection


def test_auto_dt_survives_pickle_and_copy():
    sim = octoarm.Simulation.paper_arm(dt="auto")
    for other in [pickle.loads(pickle.dumps(sim)), sim.copy()]:
        assert other.auto_dt and other.dt == sim.dt


@pytest.mark.parametrize(
    "bad, error, words",
    [
        ("fast", ValueError, ["dt", "auto", "(0, inf)"]),
        ("Auto", ValueError, ["dt", "auto"]),
        ([1e-5], TypeError, ["dt", "auto", "list"]),
        (-1e-5, ValueError, ["dt", "(0, inf)"]),
        (float("nan"), ValueError, ["dt", "(0, inf)"]),
        (0.0, ValueError, ["dt", "(0, inf)"]),
    ],
)
def test_bad_dt_is_refused_with_the_allowed_values(bad, error, words):
    for make in [
        lambda: octoarm.Simulation(dt=bad),
        lambda: octoarm.Simulation.paper_arm(dt=bad),
        lambda: octoarm.Simulation.from_rods([octoarm.Rod("arm")], dt=bad),
    ]:
        with pytest.raises(error) as e:
            make()
        for w in words:
            assert w in str(e.value), str(e.value)
