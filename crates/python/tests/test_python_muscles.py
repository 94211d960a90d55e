"""COOMM's muscular arm from Python (issue 12, item 7): the arm with (7, n) activation arrays,
the equilibrium and the SE(3) reach design over activations (`MuscleDesign`), the shaping
controller, and the Gymnasium environment `octoarm/MuscleReach3D-v0` with its vectorised twin.

Independent references: the design's reported tip and orientation errors are recomputed here in
NumPy from the returned pose (a rotation log written anew); the environment's target pose comes
from the statics and the dynamics must reach it when the arm holds the activations that made it
(statics = dynamics, spec §4.1); the vector env equals Gymnasium's own `sync` vectorisation bit
for bit."""

import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import octoarm
from octoarm.muscle_env import MuscleReach3DEnv, MuscleReach3DVectorEnv

N = 20


def _rotation_angle(qa, qb):
    """|Log(qa qb^T)| from the trace (independent of the Rust rotation log)."""
    c = (np.trace(qa @ qb.T) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def _lm(a, n=N):
    """Activations with LM1 and LM2 at `a` (bending between +d2 and -d1: towards +y and +z)."""
    act = np.zeros((7, n))
    act[octoarm.MUSCLE_GROUPS.index("LM1")] = a
    act[octoarm.MUSCLE_GROUPS.index("LM2")] = a
    return act


# -- the arm -----------------------------------------------------------------------------------


def test_coomm_arm_takes_activation_arrays_and_refuses_bad_ones():
    sim = octoarm.Simulation.coomm_arm(dt=5e-5, n_elements=N)
    assert sim.n_elements == N and octoarm.MUSCLE_GROUPS[0] == "TM"
    np.testing.assert_array_equal(sim.activations, np.zeros((7, N)))
    a = np.linspace(0.0, 1.0, 7 * N).reshape(7, N)
    sim.set_activations(a.astype(np.float32).astype(np.float64))
    np.testing.assert_array_equal(sim.activations, a.astype(np.float32))
    with pytest.raises(ValueError, match=r"activations has shape \(20, 7\), expected \(7, 20\)"):
        sim.set_activations(np.zeros((N, 7)))
    bad = np.zeros((7, N))
    bad[3, 5] = 1.5
    with pytest.raises(ValueError, match=r"activations\[3, 5\] = 1.5 is outside the allowed range \[0, 1\]"):
        sim.set_activations(bad)
    bad[3, 5] = np.nan
    with pytest.raises(ValueError, match=r"entry \[3, 5\] is NaN"):
        sim.set_activations(bad)
    with pytest.raises(ValueError, match="has no muscles"):
        octoarm.Simulation.paper_arm(n_elements=N).set_activations(np.zeros((7, N)))
    with pytest.raises(ValueError, match="n_elements = 2"):
        octoarm.Simulation.coomm_arm(n_elements=2)


def test_longitudinal_muscles_bend_the_arm_towards_their_side():
    # LM1 lies on +d2 = +e_y, LM2 on -d1 = +e_z (COOMM frame): together they curl the arm
    # towards +y and +z, symmetrically (y = z for every node).
    sim = octoarm.Simulation.coomm_arm(dt=5e-5, n_elements=N)
    sim.set_activations(_lm(0.5))
    sim.step(2000)
    x = sim.positions
    assert x[-1, 1] > 0.005 and x[-1, 2] > 0.005
    np.testing.assert_allclose(x[:, 1], x[:, 2], rtol=1e-9, atol=1e-15)


# -- statics and design ------------------------------------------------------------------------


def test_equilibrium_of_the_bent_arm_is_symmetric_and_reported():
    d = octoarm.MuscleDesign(n_elements=N)
    eq = d.equilibrium(_lm(0.5))
    x, q = eq["positions"], eq["directors"]
    assert x.shape == (N + 1, 3) and q.shape == (N, 3, 3)
    assert eq["residual"] <= 1e-12 and eq["newton_iterations"] >= 1
    np.testing.assert_allclose(x[:, 1], x[:, 2], rtol=1e-9, atol=1e-15)
    np.testing.assert_allclose(eq["tip"], 0.5 * (x[-2] + x[-1]), rtol=0, atol=1e-15)
    np.testing.assert_array_equal(eq["tip_orientation"], q[-1])
    for qj in q:
        np.testing.assert_allclose(qj @ qj.T, np.eye(3), atol=1e-12)
    with pytest.raises(ValueError, match=r"activations\[0, 0\] = -0.1"):
        d.equilibrium(np.full((7, N), -0.1))


def test_reach_design_meets_its_target_pose():
    d = octoarm.MuscleDesign(n_elements=N)
    # A reachable pose: the equilibrium of a known activation field.
    a_true = _lm(0.4)
    a_true[octoarm.MUSCLE_GROUPS.index("OM+")] = 0.3
    eq = d.equilibrium(a_true)
    target, frame = np.asarray(eq["tip"]), eq["tip_orientation"]
    a, rep = d.solve(target, orientation=frame, max_iterations=400)
    assert a.shape == (7, N) and a.min() >= 0.0 and a.max() <= 1.0
    assert rep["outcome"] in ("converged", "stalled", "not_converged")
    # The report's errors, recomputed from the returned pose.
    x, q = rep["positions"], rep["directors"]
    tip = 0.5 * (x[-2] + x[-1])
    assert np.linalg.norm(tip - target) == pytest.approx(rep["tip_error"], rel=1e-9, abs=1e-15)
    assert _rotation_angle(q[-1], frame) == pytest.approx(rep["orientation_error"], abs=1e-7)
    assert rep["tip_error"] <= 1e-4 * 0.2 and rep["orientation_error"] <= 1e-2
    # J = R + Phi_p + Phi_Q with R = 1/2 sum l a^2 (l = L0 / n).
    r = 0.5 * (0.2 / N) * float(np.sum(a**2))
    assert rep["activation_cost"] == pytest.approx(r, rel=1e-12)
    assert rep["cost"] == pytest.approx(
        rep["activation_cost"] + rep["position_cost"] + rep["orientation_cost"], rel=1e-12)
    # The returned activations hold the returned pose.
    np.testing.assert_allclose(d.equilibrium(a)["positions"], x, rtol=0, atol=1e-12)
    # Masked groups stay at zero.
    a2, _ = d.solve(target, groups=[True, True, True, True, True, False, False], max_iterations=30)
    np.testing.assert_array_equal(a2[5:], 0.0)


def _random_field(rng, n=N):
    """Per group, with probability 1/2 a linear profile between two U(0, 1) ends (the sweep's
    rule, docs/muscles.md "Target sweep")."""
    a = np.zeros((7, n))
    for g in range(7):
        if rng.random() < 0.5:
            a[g] = np.linspace(rng.random(), rng.random(), n)
    return a


def test_multi_start_reaches_a_target_whose_first_start_stalls():
    # The 74th field of seed 3 is a reachable pose (the equilibrium of known activations) whose
    # design from a = 0 stops in a local minimum 8 % of L0 away; the restarts (Halton group
    # levels) find one that meets spec §7 A's bounds.
    rng = np.random.default_rng(3)
    for _ in range(73):
        _random_field(rng)
    a_true = _random_field(rng)
    eq = octoarm.MuscleDesign(n_elements=N).equilibrium(a_true)
    target, frame = np.asarray(eq["tip"]), eq["tip_orientation"]
    bounds = (1.5e-4 * 0.2, 1e-3, 1e9)
    _, single = octoarm.MuscleDesign(n_elements=N).solve(
        target, orientation=frame, stop_when=bounds, max_starts=1)
    assert single["outcome"] != "bounds_met" and single["starts"] == 1
    assert single["tip_error"] > 0.01 * 0.2
    a, multi = octoarm.MuscleDesign(n_elements=N).solve(target, orientation=frame, stop_when=bounds)
    assert multi["outcome"] == "bounds_met" and multi["starts"] >= 2 and multi["winner"] >= 1
    assert multi["tip_error"] <= bounds[0] and multi["orientation_error"] <= bounds[1]
    # The returned activations hold the reported pose (independent of the solver's bookkeeping).
    x = octoarm.MuscleDesign(n_elements=N).equilibrium(a)["positions"]
    assert np.linalg.norm(0.5 * (x[-2] + x[-1]) - target) <= bounds[0]
    with pytest.raises(ValueError, match=r"max_starts = 0 is outside the allowed range \[1, inf\)"):
        octoarm.MuscleDesign(n_elements=N).solve(target, max_starts=0)
    with pytest.raises(ValueError, match=r"max_starts = 1001 is outside the allowed range \[1, 1000\]"):
        octoarm.MuscleDesign(n_elements=N).solve(target, max_starts=1001)


def test_design_refuses_bad_inputs_naming_them():
    d = octoarm.MuscleDesign(n_elements=N)
    with pytest.raises(ValueError, match=r"target has shape \(2,\), expected \(3,\)"):
        d.solve([0.1, 0.1])
    with pytest.raises(ValueError, match="orientation must be a rotation"):
        d.solve([0.1, 0.1, 0.0], orientation=2 * np.eye(3))
    with pytest.raises(ValueError, match="position_weight = -1"):
        d.solve([0.1, 0.1, 0.0], position_weight=-1.0)
    with pytest.raises(ValueError, match=r"initial\[6, 19\] = 2"):
        init = np.zeros((7, N))
        init[6, 19] = 2.0
        d.solve([0.1, 0.1, 0.0], initial=init)
    with pytest.raises(ValueError, match="groups has 3 entries"):
        d.solve([0.1, 0.1, 0.0], groups=[True] * 3)
    with pytest.raises(ValueError, match="max_iterations = 0"):
        d.solve([0.1, 0.1, 0.0], max_iterations=0)
    q, w = d.coomm_orientation([0.01, 0.15, 0.06])
    assert q.shape == (1, 3, 3) and len(w) == 3
    np.testing.assert_allclose(q[0] @ q[0].T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(w[0], w[1]) and np.testing.assert_allclose(w[2], w[0] ** 2)


def test_shaping_controller_ramps_then_holds_the_design():
    sim = octoarm.Simulation.coomm_arm(dt=5e-5, n_elements=N)
    a = _lm(0.5)
    ctrl = octoarm.MuscleShapingController(a, ramp=0.1, period=0.002)
    np.testing.assert_array_equal(ctrl.activations, a)
    assert ctrl.factor(0.05) == pytest.approx(0.5) and ctrl.factor(1.0) == 1.0
    ctrl.step(sim, 1000)  # 50 ms: last update at t = 48 ms
    np.testing.assert_allclose(sim.activations, 0.48 * a, rtol=1e-12)
    ctrl.step(sim, 2000)
    np.testing.assert_array_equal(sim.activations, a)
    with pytest.raises(ValueError, match=r"one muscular rod of 20 elements"):
        ctrl.step(octoarm.Simulation.coomm_arm(n_elements=10))
    with pytest.raises(ValueError, match=r"expected \(7, n\)"):
        octoarm.MuscleShapingController(np.zeros(7))
    with pytest.raises(ValueError, match="ramp"):
        octoarm.MuscleShapingController(a, ramp=-1.0)


# -- the environment ---------------------------------------------------------------------------


def test_registered_and_check_env_passes():
    assert "octoarm/MuscleReach3D-v0" in gym.registry
    env = gym.make("octoarm/MuscleReach3D-v0", render_mode="rgb_array")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        check_env(env.unwrapped)
    assert not caught, [str(w.message) for w in caught]
    space = env.observation_space
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    assert space.shape == (206,) and env.action_space.shape == (28,)
    assert env.spec.max_episode_steps == 100
    obs, _ = env.reset(seed=1)
    assert obs.dtype == np.float32 and space.contains(obs)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
    assert space.contains(obs) and isinstance(reward, float) and reward < 0
    assert not terminated and not truncated
    assert -reward >= info["tip_distance"] / 0.2 > 0 and info["orientation_error"] >= 0
    frame = env.render()
    assert frame.shape == (400, 800, 3) and frame.dtype == np.uint8


def test_holding_the_target_activations_reaches_the_target_pose():
    # The target is the static pose of the drawn activations: commanding exactly them, the
    # dynamic arm (drag, damping) settles onto it (statics = dynamics).
    env = MuscleReach3DEnv()
    rng = np.random.default_rng(4)
    a = octoarm.muscle_env._sample_activations(rng, 4)
    p, q = env._batch.reachable_pose(a)
    env.reset(options={"target": p, "orientation": q[0]})
    first = None
    for _ in range(100):
        _, _, _, truncated, info = env.step(a.reshape(-1))
        first = info["tip_distance"] if first is None else first
        assert not truncated
    assert info["tip_distance"] < 0.01 * first and info["tip_distance"] < 2e-3
    assert info["orientation_error"] < 0.05 and info["is_success"]


def test_env_refuses_bad_inputs_naming_them():
    env = MuscleReach3DEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match=r"action has shape \(7,\), expected \(28,\)"):
        env.step(np.zeros(7))
    bad = np.zeros(28)
    bad[4] = np.inf
    with pytest.raises(ValueError, match=r"action must be finite: entry \[4\] is inf"):
        env.step(bad)
    with pytest.raises(ValueError, match="both 'target'"):
        env.reset(options={"target": [0.1, 0.0, 0.0]})
    with pytest.raises(ValueError, match=r"positions\[0, 1\] = 0.5 is outside"):
        env.reset(options={"target": [0.1, 0.5, 0.0], "orientation": np.eye(3)})
    with pytest.raises(ValueError, match="must be a rotation"):
        env.reset(options={"target": [0.1, 0.0, 0.0], "orientation": np.zeros((3, 3))})
    with pytest.raises(ValueError, match="unknown key"):
        env.reset(options={"goal": 1})
    with pytest.raises(ValueError, match="n_segments = 0"):
        MuscleReach3DEnv(n_segments=0)
    with pytest.raises(ValueError, match="control_period = 0.00123 must be a whole multiple"):
        MuscleReach3DEnv(control_period=0.00123)
    with pytest.raises(ValueError, match="success_radius"):
        MuscleReach3DEnv(success_radius=0.0)
    with pytest.raises(TypeError, match="render_mode='human'"):
        MuscleReach3DEnv(render_mode="human")
    b = octoarm.MuscleBatch()
    with pytest.raises(ValueError, match=r"activations\[2, 1\] = 3"):
        a = np.zeros((7, 4))
        a[2, 1] = 3.0
        b.reachable_pose(a)


# dt = 1 ms with instant activations: full activation on every group makes the arm blow up
# within one control period, zero activation is stable.
FRAGILE = dict(dt=1e-3, activation_time=0.0)


def _actions(t, n, at=3, unstable_arm=1):
    a = 0.3 + 0.2 * np.sin(0.5 * t + np.arange(n)[:, None] + np.arange(28)[None, :])
    if t == at:
        a[unstable_arm] = 1.0
    return a.astype(np.float32)


def _rollout(env, steps, actions, seed=5):
    obs, info = env.reset(seed=seed)
    out = [(obs, None, None, None, info)]
    for t in range(steps):
        out.append(env.step(actions(t)))
    return out


def _assert_same(a, b):
    assert len(a) == len(b)
    for (o1, r1, te1, tr1, i1), (o2, r2, te2, tr2, i2) in zip(a, b):
        np.testing.assert_array_equal(o1, o2)
        if r1 is not None:
            np.testing.assert_array_equal(r1, r2)
            np.testing.assert_array_equal(te1, te2)
            np.testing.assert_array_equal(tr1, tr2)
        assert sorted(i1) == sorted(i2)
        for k in i1:
            np.testing.assert_array_equal(i1[k], i2[k], err_msg=k)


@pytest.mark.parametrize("config", [{}, FRAGILE], ids=["default", "with-instability"])
def test_sync_and_vector_entry_point_give_the_same_results(config):
    n, steps = 3, 9
    modes = {}
    for mode, threads in [("sync", None), ("vector_entry_point", 1), ("vector_entry_point", 2)]:
        kwargs = {} if threads is None else {"num_threads": threads}
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = gym.make_vec("octoarm/MuscleReach3D-v0", num_envs=n, vectorization_mode=mode,
                               max_episode_steps=4, control_period=0.01, **config, **kwargs)
        modes[(mode, threads)] = _rollout(env, steps, lambda t: _actions(t, n))
        if mode == "vector_entry_point":
            assert isinstance(env.unwrapped, MuscleReach3DVectorEnv)
    ref = modes[("sync", None)]
    _assert_same(ref, modes[("vector_entry_point", 1)])
    _assert_same(ref, modes[("vector_entry_point", 2)])
    truncs = np.array([step[3] for step in ref[1:]])
    assert truncs.any(axis=0).all()  # every arm went through at least one autoreset
    if config:
        assert any("unstable" in step[4] for step in ref[1:])
        unstable = [step[4].get("_unstable") for step in ref[1:] if "unstable" in step[4]]
        assert unstable[0].tolist() == [False, True, False]
