"""Array inputs (issue 16, item 9): any real dtype is converted to float64, shapes are never
adjusted (a misshaped array is a ValueError naming the expected shape), NaN / inf is refused
naming the entry, and non-real dtypes are refused naming the dtype."""

import gymnasium as gym
import numpy as np
import pytest

import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv

REAL_DTYPES = [np.float16, np.float32, np.float64, np.longdouble, np.int8, np.int32, np.int64,
               np.uint8, np.uint64]


@pytest.mark.parametrize("dtype", REAL_DTYPES)
def test_every_array_argument_accepts_any_real_dtype(dtype):
    sim = octoarm.Simulation(n_elements=10)
    n = 10
    kappa = np.zeros((n - 1, 3))
    kappa[:, 1] = 2
    sim.set_rest_strains(np.zeros((n, 3), dtype), kappa.astype(dtype))
    np.testing.assert_array_equal(sim.rest_kappa, kappa)
    assert sim.rest_kappa.dtype == np.float64
    x = np.round(sim.positions * 100)  # integral values, exact in every dtype with range
    x[:, 1] = 1
    sim.set_rod_state(positions=x.astype(dtype), velocities=np.zeros((n + 1, 3), dtype),
                      angular_velocities=np.zeros((n, 3), dtype))
    np.testing.assert_array_equal(sim.positions, x)
    sim.set_rod_state(directors=sim.directors.astype(dtype))  # entries 0 and 1: exact
    sim.set_state({"rod": {"velocities": np.ones((n + 1, 3), dtype)}})
    np.testing.assert_array_equal(sim.velocities, 1.0)
    m = octoarm.Motion(np.array([0, 1, 2], dtype), displacement=np.zeros((3, 3), dtype))
    assert m.times.dtype == np.float64 and m.times.tolist() == [0.0, 1.0, 2.0]
    batch = octoarm.ArmBatch(n_envs=2, num_threads=1)
    targets = np.array([[0.1, 0.0], [0.1, 0.1]])
    # Integer dtypes cannot hold 0.1 m: they are still accepted (e.g. a target at the origin).
    t = targets.astype(dtype) if np.issubdtype(dtype, np.floating) else np.zeros((2, 2), dtype)
    batch.reset(t)
    obs, reward, distance, failures = batch.step(np.ones((2, 4), dtype))
    assert obs.dtype == np.float32 and failures == [None, None]
    ref = octoarm.ArmBatch(n_envs=2, num_threads=1)
    ref.reset(np.asarray(t, dtype=np.float64))
    np.testing.assert_array_equal(ref.step(np.ones((2, 4)))[0], obs)  # same as float64


def test_vector_arguments_accept_any_real_dtype_and_name_themselves():
    sim = octoarm.Simulation(n_elements=10, direction=np.array([1, 0, 0], np.int64),
                             normal=np.array([0, 1, 0], np.float32))
    ref = octoarm.Simulation(n_elements=10)
    sim.add_gravity(np.array([0, 0, -9.81], np.float32))
    ref.add_gravity([0.0, 0.0, float(np.float32(-9.81))])
    sim.add_node_force(np.array([0, 1, 0], np.int32) * 1e-6, ramp_time=0.0)
    ref.add_node_force((0.0, 1e-6, 0.0))
    sim.step(10)
    ref.step(10)
    np.testing.assert_array_equal(sim.positions, ref.positions)
    rod = octoarm.Rod("arm", n_elements=10, base_position=np.zeros(3, np.int8))
    assert rod.base_position == [0.0, 0.0, 0.0]
    octoarm.Joint("hinge", "a.tip", "b.base", axis=np.array([0, 0, 1], np.uint8))
    octoarm.Motion.constant_rotation(np.array([0, 0, 1], np.float16), 1.0)
    for call, words in [
        (lambda: sim.add_gravity(np.zeros((1, 3))),
         r"acceleration has shape \(1, 3\), expected \(3,\)"),  # not flattened
        (lambda: sim.add_gravity([0, 0]), r"acceleration has shape \(2,\), expected \(3,\)"),
        (lambda: sim.add_node_force([0, 0, 1, 0]), r"force has shape \(4,\), expected \(3,\)"),
        (lambda: sim.add_uniform_force([0, np.nan, 0]),
         r"force_per_length must be finite: entry \[1\] is NaN"),
        (lambda: sim.add_element_couple(np.zeros(3, complex)), "couple has dtype complex128"),
        (lambda: sim.add_uniform_couple([True, False, False]), "couple_per_length has dtype bool"),
        (lambda: sim.add_obstacle([0.1, 0, 0], 0.01, velocity=[0, 0]),
         r"velocity has shape \(2,\), expected \(3,\)"),
        (lambda: octoarm.Simulation(normal=[0, 1, 0, 0]),
         r"normal has shape \(4,\), expected \(3,\)"),
        (lambda: octoarm.Rod(direction="x"), "direction has dtype <U1"),
        (lambda: octoarm.Joint("hinge", "a.tip", "b.base", axis=[0, np.inf, 0]),
         r"axis must be finite: entry \[1\] is inf"),
        (lambda: octoarm.OfflineSolver(ref).solve(target=[0.1, 0.1]),
         r"target has shape \(2,\), expected \(3,\)"),
    ]:
        with pytest.raises(ValueError, match=words):
            call()


@pytest.mark.parametrize("bad, words", [
    (np.zeros((10, 3), complex), "dtype complex128"),
    (np.zeros((10, 3), bool), "dtype bool"),
    (np.full((10, 3), "0"), "dtype <U1"),
    ([[0, 0, {}]] * 10, "not an array of numbers"),
    ([[0, 0, None]] * 10, r"must be finite: entry \[0, 2\] is NaN"),  # None is NaN to NumPy
    ([[0, 0]] * 10, r"has shape \(10, 2\), expected \(10, 3\)"),
])
def test_non_real_arrays_are_refused_naming_the_argument(bad, words):
    sim = octoarm.Simulation(n_elements=10)
    with pytest.raises(ValueError, match=words) as info:
        sim.set_rest_strains(bad, np.zeros((9, 3)))
    assert "sigma" in str(info.value)
    if "dtype" in words:
        assert "expected real numbers" in str(info.value)


def test_arrays_are_never_reshaped():
    sim = octoarm.Simulation(n_elements=10)
    with pytest.raises(ValueError, match=r"sigma has shape \(30,\), expected \(10, 3\)"):
        sim.set_rest_strains(np.zeros(30), np.zeros((9, 3)))
    with pytest.raises(ValueError, match=r"positions has shape \(3, 11\), expected \(11, 3\)"):
        sim.set_rod_state(positions=sim.positions.T)
    batch = octoarm.ArmBatch(n_envs=2)
    with pytest.raises(ValueError, match=r"targets has shape \(4,\), expected \(2, 2\)"):
        batch.reset(np.zeros(4))
    with pytest.raises(ValueError, match=r"actions has shape \(8,\), expected \(2, 4\)"):
        batch.step(np.zeros(8))
    with pytest.raises(ValueError, match=r"actions has shape \(4, 2\), expected \(2, 4\)"):
        batch.step(np.zeros((4, 2)))


@pytest.mark.parametrize("action, words", [
    (np.array([0.0, 0.0, np.nan, 0.0]), r"action must be finite: entry \[2\] is NaN"),
    (np.array([np.inf, 0.0, 0.0, 0.0]), r"action must be finite: entry \[0\] is inf"),
    (np.zeros((2, 2)), r"action has shape \(2, 2\), expected \(4,\)"),
    (np.zeros((1, 4)), r"action has shape \(1, 4\), expected \(4,\)"),
    (np.zeros(5), r"action has shape \(5,\), expected \(4,\)"),
    (0.5, r"action has shape \(\), expected \(4,\)"),
    (np.zeros(4, complex), "action has dtype complex128"),
])
def test_single_env_refuses_nan_and_misshaped_actions(action, words):
    env = ArmReachEnv()
    env.reset(seed=0)
    before = env.simulation().positions
    with pytest.raises(ValueError, match=words):
        env.step(action)
    np.testing.assert_array_equal(env.simulation().positions, before)  # nothing stepped
    # The same through gym.make (its wrappers pass the error through).
    wrapped = gym.make("octoarm/ArmReach-v0")
    wrapped.reset(seed=0)
    with pytest.raises(ValueError, match=words):
        wrapped.step(action)


def test_single_env_accepts_lists_and_any_real_dtype():
    env = ArmReachEnv()
    env.reset(seed=0)
    ref = ArmReachEnv()
    ref.reset(seed=0)
    o, *_ = env.step([1, 0, 0, -1])  # ints in a list
    np.testing.assert_array_equal(o, ref.step(np.array([1.0, 0.0, 0.0, -1.0]))[0])
    o, *_ = env.step(np.full(4, 0.5, np.float16))
    np.testing.assert_array_equal(o, ref.step(np.full(4, 0.5))[0])


@pytest.mark.parametrize("actions, words", [
    (np.zeros(16), r"actions has shape \(16,\), expected \(4, 4\)"),
    (np.zeros((4, 4, 1)), r"actions has shape \(4, 4, 1\), expected \(4, 4\)"),
    (np.zeros((2, 8)), r"actions has shape \(2, 8\), expected \(4, 4\)"),
    (np.where(np.arange(16).reshape(4, 4) == 13, np.nan, 0.0),
     r"actions must be finite: entry \[3, 1\] is NaN"),
])
def test_vector_env_refuses_nan_and_misshaped_actions(actions, words):
    env = ArmReachVectorEnv(num_envs=4, num_threads=1)
    env.reset(seed=0)
    with pytest.raises(ValueError, match=words):
        env.step(actions)
    # Nothing was stepped: the next valid step equals a fresh env's first step.
    ref = ArmReachVectorEnv(num_envs=4, num_threads=1)
    ref.reset(seed=0)
    np.testing.assert_array_equal(env.step(np.zeros((4, 4)))[0], ref.step(np.zeros((4, 4)))[0])


def test_vector_env_accepts_float32_actions_from_its_space():
    env = ArmReachVectorEnv(num_envs=3, num_threads=1)
    env.reset(seed=0)
    env.action_space.seed(0)
    a = env.action_space.sample()
    assert a.dtype == np.float32
    obs, *_ = env.step(a)
    assert obs.shape == (3, env.single_observation_space.shape[0])


def test_reset_target_option_is_checked_not_reshaped():
    env = ArmReachEnv()
    with pytest.raises(ValueError, match=r"target has shape \(1, 2\), expected \(2,\)"):
        env.reset(options={"target": [[0.1, 0.0]]})
    with pytest.raises(ValueError, match=r"target must be finite: entry \[1\] is NaN"):
        env.reset(options={"target": [0.1, np.nan]})
    with pytest.raises(ValueError, match=r"unknown key\(s\) 'targets'; allowed: 'target'"):
        env.reset(options={"targets": [0.1, 0.0]})
    obs, _ = env.reset(options={"target": np.array([1, 0], np.int64) / 10})
    np.testing.assert_allclose(obs[-10:-8], [0.5, 0.0])
    batch = octoarm.ArmBatch(n_envs=2)
    with pytest.raises(ValueError, match=r"targets must be finite: entry \[1, 0\] is inf"):
        batch.reset(np.array([[0.1, 0.0], [np.inf, 0.0]]))
    with pytest.raises(ValueError, match=r"index = 2 is outside the allowed range \[0, 1\]"):
        batch.reset(np.zeros((1, 2)), [2])
    with pytest.raises(ValueError, match="twice"):
        batch.reset(np.zeros((2, 2)), [1, 1])
