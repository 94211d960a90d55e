"""render_mode="rgb_array" (issue 15): the environments draw the arm, its target and the clamp
in Rust (no display) as (H, W, 3) uint8 images. Checked: shape and dtype; the arm's pixels
(its purple) lie on the simulated centreline, mapped through the fixed window independently of
the renderer; the image changes when the arm moves and the target is drawn where it is;
Gymnasium's RecordVideo and SB3's VecVideoRecorder write videos (skipped without moviepy / SB3
outside CI)."""

import importlib.util
import os
import warnings

import gymnasium as gym
import numpy as np
import pytest

from octoarm.env import ArmReachEnv, ArmReachVectorEnv

PURPLE = np.array([123, 63, 196])
HALF = 0.22  # the rendered window: +-0.22 m about the base, x right, y up


def is_purple(img):
    return np.all(np.abs(img.astype(int) - PURPLE) <= 6, axis=-1)


def to_px(p, w, h):
    scale = min(w, h) / (2 * HALF)
    return (p[0] + 0.5 * w / scale) * scale, (0.5 * h / scale - p[1]) * scale


def test_frames_have_the_shape_and_show_the_arm_where_it_is():
    env = ArmReachEnv(render_mode="rgb_array", render_width=320, render_height=240)
    assert env.metadata["render_fps"] == 100
    env.reset(seed=0, options={"target": [0.1, 0.12]})
    first = env.render()
    assert first.shape == (240, 320, 3) and first.dtype == np.uint8
    for _ in range(15):
        env.step(np.array([1.0, 1.0, 1.0, 1.0]))
    later = env.render()
    assert (first != later).any(), "the image does not change when the arm moves"
    # Every node of the simulated arm is purple in the image; the image's purple pixels all lie
    # within the arm's radius (+ a pixel) of the centreline.
    x = env.simulation().positions
    ys, xs = np.nonzero(is_purple(later))
    assert len(xs) > 50
    nodes = np.array([to_px(p, 320, 240) for p in x])
    for (c, r) in nodes[:-3]:
        assert is_purple(later)[int(r), int(c)], "no arm at a node"
    scale = min(320, 240) / (2 * HALF)
    d = np.min(np.hypot(xs[:, None] + 0.5 - nodes[None, :, 0], ys[:, None] + 0.5 - nodes[None, :, 1]), axis=1)
    assert d.max() <= 0.01 * scale + 2, "purple pixels away from the arm"
    # The target is red where it is.
    tc, tr = to_px([0.1, 0.12], 320, 240)
    assert tuple(later[int(tr) + 2, int(tc)]) == (220, 20, 30)
    assert env.render() is not None and ArmReachEnv().render() is None


def test_vector_env_renders_every_arm():
    venv = ArmReachVectorEnv(num_envs=3, num_threads=1, render_mode="rgb_array",
                             render_width=64, render_height=48)
    venv.reset(seed=1)
    frames = venv.render()
    assert len(frames) == 3 and all(f.shape == (48, 64, 3) and f.dtype == np.uint8 for f in frames)
    assert not np.array_equal(frames[0], frames[1]), "different targets, same picture"
    with pytest.raises(ValueError, match="render_width = 8 is outside the allowed range"):
        ArmReachVectorEnv(num_envs=1, render_mode="rgb_array", render_width=8)


needs_moviepy = pytest.mark.skipif(
    importlib.util.find_spec("moviepy") is None and not os.environ.get("CI"),
    reason="moviepy is not installed",
)


@needs_moviepy
def test_record_video_writes_a_video(tmp_path):
    env = gym.make("octoarm/ArmReach-v0", render_mode="rgb_array", max_episode_steps=20)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.wrappers.RecordVideo(env, str(tmp_path), episode_trigger=lambda e: True,
                                       disable_logger=True)
    env.reset(seed=0)
    done = False
    while not done:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        done = terminated or truncated
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000


@pytest.mark.skipif(importlib.util.find_spec("stable_baselines3") is None and not os.environ.get("CI"),
                    reason="stable-baselines3 is not installed")
@needs_moviepy
def test_sb3_vec_video_recorder_writes_a_video(tmp_path):
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from octoarm.sb3 import RustVecEnv

    venv = RustVecEnv(num_envs=2, num_threads=1, render_mode="rgb_array",
                      render_width=128, render_height=96)
    assert venv.get_images()[0].shape == (96, 128, 3)
    rec = VecVideoRecorder(venv, str(tmp_path), record_video_trigger=lambda s: s == 0,
                           video_length=10)
    rec.reset()
    for _ in range(12):
        rec.step(np.zeros((2, 4), np.float32))
    rec.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert videos and videos[0].stat().st_size > 1000
