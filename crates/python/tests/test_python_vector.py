"""Vector environment (issue 16, items 10 and 11): one unstable arm ends only its own episode
(truncated, info["unstable"] with the guard's message), bit-identical for any thread count;
the vector env honours reset(options={"target": ...}) and gives the same targets, observations,
rewards, flags and infos as Gymnasium's sync vectorisation for the same seed."""

import warnings

import gymnasium as gym
import numpy as np
import pytest

import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv

# With these settings a bang-bang command on every segment makes the arm shear past the
# stability guard within one control period, while small commands are stable.
FRAGILE = dict(max_curvature=200.0, activation_time=0.0)
BANG = np.array([1.0, -1.0, 1.0, -1.0])


def _actions(t, num_envs, unstable_arm=1, at=3):
    """Small smooth commands; arm `unstable_arm` gets a bang-bang command at step `at`."""
    a = 0.02 * np.sin(0.3 * t + np.arange(num_envs)[:, None] + np.arange(4)[None, :])
    if t == at:
        a[unstable_arm] = BANG
    return a


# -- item 10: per-arm failures ----------------------------------------------------------------


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_arm_batch_reports_per_arm_failures_bit_identically(threads):
    def run(num_threads):
        b = octoarm.ArmBatch(n_envs=4, num_threads=num_threads, **FRAGILE)
        b.reset(np.full((4, 2), 0.1))
        out = []
        for t in range(6):
            out.append(b.step(_actions(t, 4, at=2)))
        return out

    ref, got = run(1), run(threads)
    for (o1, r1, d1, f1), (o2, r2, d2, f2) in zip(ref, got):
        np.testing.assert_array_equal(o1, o2)
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(d1, d2)
        assert [None if f is None else str(f) for f in f1] == [
            None if f is None else str(f) for f in f2]
    failures = got[2][3]
    assert failures[0] is None and failures[2] is None and failures[3] is None
    e = failures[1]
    assert isinstance(e, octoarm.InstabilityError) and isinstance(e, RuntimeError)
    assert "unstable" in str(e) and e.dt == 5e-5 and 0 < e.suggested_dt < e.dt
    assert e.time == pytest.approx(0.03, abs=0.0101)  # during the third period


def test_failed_arm_is_back_at_the_start_of_its_period_others_advance():
    b = octoarm.ArmBatch(n_envs=3, num_threads=2, **FRAGILE)
    b.reset(np.full((3, 2), 0.1))
    o1, *_ = b.step(np.full((3, 4), 0.02))
    a = np.full((3, 4), 0.02)
    a[1] = BANG
    o2, r2, d2, f2 = b.step(a)
    assert f2[1] is not None and f2[0] is None and f2[2] is None
    np.testing.assert_array_equal(o2[1], o1[1])  # observation of the last state the guard passed
    assert b.simulation(1).time == pytest.approx(0.01) and b.simulation(0).time == pytest.approx(0.02)
    assert np.isfinite(o2).all() and np.isfinite(r2).all() and np.isfinite(d2).all()
    # The other arms are exactly what they would be without the failing neighbour.
    c = octoarm.ArmBatch(n_envs=3, num_threads=1, **FRAGILE)
    c.reset(np.full((3, 2), 0.1))
    c.step(np.full((3, 4), 0.02))
    o3, r3, _, f3 = c.step(np.full((3, 4), 0.02))
    assert f3 == [None, None, None]
    np.testing.assert_array_equal(o2[[0, 2]], o3[[0, 2]])
    np.testing.assert_array_equal(r2[[0, 2]], r3[[0, 2]])


def test_vector_env_unstable_arm_truncates_alone_and_autoresets():
    env = ArmReachVectorEnv(num_envs=4, num_threads=2, **FRAGILE)
    space = env.single_observation_space
    env.reset(seed=3)
    for t in range(3):
        obs, r, term, trunc, info = env.step(_actions(t, 4))
        assert not trunc.any() and "unstable" not in info
    first_targets = env.targets.copy()
    obs, r, term, trunc, info = env.step(_actions(3, 4))
    assert trunc.tolist() == [False, True, False, False] and not term.any()
    assert info["_unstable"].tolist() == [False, True, False, False]
    msg = info["unstable"][1]
    assert isinstance(msg, str) and msg.startswith("unstable:") and "dt" in msg
    assert info["unstable"][0] is None
    assert all(space.contains(o) for o in obs) and np.isfinite(r).all()
    # Next step: arm 1 starts a new episode (next-step autoreset), the others go on.
    obs, r, term, trunc, info = env.step(_actions(4, 4))
    assert r[1] == 0.0 and not trunc.any() and "unstable" not in info
    assert info["_tip_distance"].tolist() == [True, False, True, True]
    np.testing.assert_array_equal(obs[1, -8:], 0.0)  # actuator state and last action reset
    assert not np.array_equal(env.targets[1], first_targets[1])
    np.testing.assert_array_equal(env.targets[[0, 2, 3]], first_targets[[0, 2, 3]])
    assert env._elapsed.tolist() == [5, 0, 5, 5]


def test_single_env_instability_ends_the_episode():
    env = gym.make("octoarm/ArmReach-v0", **FRAGILE)
    env.reset(seed=0)
    obs0, *_ = env.step(np.full(4, 0.02))
    obs, reward, terminated, truncated, info = env.step(BANG)
    assert truncated and not terminated
    assert info["unstable"].startswith("unstable:") and "dt" in info["unstable"]
    np.testing.assert_array_equal(obs, obs0)
    assert env.observation_space.contains(obs) and np.isfinite(reward)
    obs, _ = env.reset()
    obs, reward, terminated, truncated, info = env.step(np.zeros(4))
    assert not truncated and "unstable" not in info


# -- item 11: the same results as sync vectorisation --------------------------------------


def _rollout(env, steps, actions, seed=5, options=None):
    obs, info = env.reset(seed=seed, options=options)
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
    n, steps = 3, 14
    modes = {}
    for mode in ["sync", "vector_entry_point"]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # the env checker's notes on the sync sub-envs
            env = gym.make_vec("octoarm/ArmReach-v0", num_envs=n, vectorization_mode=mode,
                               max_episode_steps=5, **config)
        modes[mode] = _rollout(env, steps, lambda t: _actions(t, n, at=7).astype(np.float32))
        if mode == "vector_entry_point":
            assert isinstance(env.unwrapped, ArmReachVectorEnv)
    _assert_same(modes["sync"], modes["vector_entry_point"])
    truncs = np.array([step[3] for step in modes["sync"][1:]])
    assert truncs.any(axis=0).all()  # every arm went through at least one autoreset
    if config:
        assert any("unstable" in step[4] for step in modes["sync"][1:])


def test_same_seed_same_targets_as_single_envs():
    venv = ArmReachVectorEnv(num_envs=3, num_threads=1, max_episode_steps=2)
    venv.reset(seed=11)
    targets = [venv.targets.copy()]
    for _ in range(3):  # step 2: truncated, step 3: autoreset with new targets
        venv.step(np.zeros((3, 4)))
    targets.append(venv.targets.copy())
    for i in range(3):
        single = ArmReachEnv()
        single.reset(seed=11 + i)  # what SyncVectorEnv passes to sub-environment i
        np.testing.assert_array_equal(single.target, targets[0][i])
        single.reset()
        np.testing.assert_array_equal(single.target, targets[1][i])


def test_vector_env_honours_target_options():
    n = 3
    venv = ArmReachVectorEnv(num_envs=n, num_threads=1)
    obs, _ = venv.reset(seed=0, options={"target": [0.1, -0.05]})  # every arm, as sync does
    np.testing.assert_array_equal(venv.targets, [[0.1, -0.05]] * n)
    np.testing.assert_allclose(obs[:, -10:-8], [[0.5, -0.25]] * n, rtol=1e-6)
    per_arm = np.array([[0.1, 0.0], [0.12, 0.05], [0.08, -0.1]])
    obs, _ = venv.reset(options={"target": per_arm})  # one per arm
    np.testing.assert_array_equal(venv.targets, per_arm)
    np.testing.assert_allclose(obs[:, -10:-8], per_arm / 0.2, rtol=1e-6)
    # The same target options give the same results as sync mode.
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        sync = gym.make_vec("octoarm/ArmReach-v0", num_envs=n, vectorization_mode="sync")
    a = _rollout(sync, 4, lambda t: np.full((n, 4), 0.3, np.float32),
                 options={"target": [0.1, -0.05]})
    b = _rollout(ArmReachVectorEnv(num_envs=n, num_threads=2), 4,
                 lambda t: np.full((n, 4), 0.3, np.float32), options={"target": [0.1, -0.05]})
    _assert_same(a, b)
    with pytest.raises(ValueError, match=r"target has shape \(2, 2\), expected \(3, 2\)"):
        venv.reset(options={"target": per_arm[:2]})
    with pytest.raises(ValueError, match=r"unknown key\(s\) 'targets'"):
        venv.reset(options={"targets": per_arm})
    with pytest.raises(ValueError, match="target x = 0.5 is outside the allowed range"):
        venv.reset(options={"target": [0.5, 0.0]})


def test_vector_env_reset_mask_and_seed_list():
    venv = ArmReachVectorEnv(num_envs=3, num_threads=1)
    venv.reset(seed=[4, 5, 6])
    ref = ArmReachVectorEnv(num_envs=3, num_threads=1)
    ref.reset(seed=4)  # the int seed s means [s, s + 1, s + 2]
    np.testing.assert_array_equal(venv.targets, ref.targets)
    before = venv.targets.copy()
    for _ in range(2):
        venv.step(np.full((3, 4), 0.5))
    mask = np.array([False, True, False])
    obs, _ = venv.reset(options={"reset_mask": mask, "target": [0.1, 0.1]})
    np.testing.assert_array_equal(venv.targets[1], [0.1, 0.1])
    np.testing.assert_array_equal(venv.targets[[0, 2]], before[[0, 2]])
    np.testing.assert_array_equal(obs[1, -8:], 0.0)
    assert (obs[[0, 2], -4:] == 0.5).all()  # the other arms were not reset
    assert venv._elapsed.tolist() == [2, 0, 2]
    with pytest.raises(ValueError, match="one per arm"):
        venv.reset(seed=[1, 2])
    with pytest.raises(ValueError, match="reset_mask"):
        venv.reset(options={"reset_mask": np.zeros(3, dtype=bool)})
