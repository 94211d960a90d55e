"""The viewer in a real browser: `octoarm view` and `octoarm run --view` driven in headless
Chromium (Debian's `chromium`, over the DevTools protocol with Playwright; no browser download).

Claims, each checked against the recorded `trajectory.npz` read here with NumPy (independent of
the page's own data path):
* replay: the arm is drawn where the trajectory says: pixels of the tube's colour (purple) at
  the projected nodes of the shown frame, none at places the rod is not (the other frame's tip,
  the image corners); moving the slider to the last frame (End key) moves them there; the
  page logs no console error.
* live: frames arrive while the run is in progress (steps below the planned count), the page
  shows the final status, and the final frame equals the recorded last frame (float32).
A wrong projection, a rod drawn in the wrong place or not at all, a slider that does not move
the rod, or a stream that drops the final frame fails these tests.

Needs `/usr/bin/chromium` (or $OCTOARM_CHROMIUM) and the octoarm binary ($OCTOARM_BIN, default
target/debug/octoarm). Outside CI a missing browser skips; in CI (`CI` set) it fails.
"""

from __future__ import annotations

import colorsys
import io
import os
import shutil
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[3]
BIN = Path(os.environ.get("OCTOARM_BIN", ROOT / "target" / "debug" / "octoarm"))
CHROMIUM = os.environ.get("OCTOARM_CHROMIUM", "/usr/bin/chromium")
FLAGS = [
    "--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
    "--disable-background-networking", "--disable-component-update", "--disable-sync",
    # WebGL without a GPU: SwiftShader, which Chromium only enables on request.
    "--enable-unsafe-swiftshader", "--use-angle=swiftshader",
]

if not (Path(CHROMIUM).exists() and BIN.exists()):
    why = f"needs {CHROMIUM} and {BIN}"
    if os.environ.get("CI"):
        raise RuntimeError(f"viewer browser tests cannot run in CI: {why}")
    pytest.skip(why, allow_module_level=True)

from PIL import Image  # noqa: E402
from playwright.sync_api import sync_playwright  # noqa: E402

# A short run whose tip travels far: a thick-tipped 20-element arm curling to a rest curvature.
SCENARIO = """
[rod]
n_elements = 20
length = 0.2
base_diameter = 0.02
tip_diameter = 0.006
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3
rest_curvature = [0.0, 12.0, 0.0]
rest_schedule = {{ kind = "ramp", duration = 0.3 }}
[time]
dt = 2.0e-5
duration = {duration}
save_interval = 5.0e-3
[damping]
rate = 5.0
"""


def purple(px: tuple[int, int, int]) -> bool:
    """The tube's plain colour (0x7b3fc4) under any shading: hue 255-300 deg, saturated."""
    h, s, v = colorsys.rgb_to_hsv(*(c / 255 for c in px[:3]))
    return 255 <= h * 360 <= 300 and s > 0.35 and v > 0.12


def tube_near(img: Image.Image, xy: list[float], r: int) -> int:
    """Purple pixels within r pixels of xy."""
    x0, y0 = round(xy[0]), round(xy[1])
    count = 0
    for dy in range(-r, r + 1):
        for dx in range(-r, r + 1):
            x, y = x0 + dx, y0 + dy
            if 0 <= x < img.width and 0 <= y < img.height and dx * dx + dy * dy <= r * r:
                count += purple(img.getpixel((x, y)))
    return count


@pytest.fixture(scope="module")
def browser():
    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, args=FLAGS)
        yield b
        b.close()


def start(cmd: list[str]) -> tuple[subprocess.Popen[str], str]:
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    assert proc.stdout is not None
    line = proc.stdout.readline()
    if "octoarm viewer: " not in line:
        proc.kill()
        raise AssertionError(f"no URL on stdout: {line!r} {proc.stderr.read() if proc.stderr else ''}")
    return proc, line.split("octoarm viewer: ")[1].strip()


def stop(proc: subprocess.Popen[str]) -> int:
    proc.send_signal(signal.SIGINT)
    try:
        return proc.wait(timeout=20)
    except subprocess.TimeoutExpired:
        proc.kill()
        raise


def open_page(browser, url: str):
    page = browser.new_page(viewport={"width": 1200, "height": 800}, device_scale_factor=1)
    errors: list[str] = []
    page.on("console", lambda m: errors.append(m.text) if m.type == "error" else None)
    page.on("pageerror", lambda e: errors.append(str(e)))
    page.goto(url)
    return page, errors


def shot(page) -> Image.Image:
    return Image.open(io.BytesIO(page.screenshot())).convert("RGB")


@pytest.fixture(scope="module")
def recorded(tmp_path_factory):
    d = tmp_path_factory.mktemp("run")
    scn = d / "bend.toml"
    scn.write_text(SCENARIO.format(duration=0.6))
    subprocess.run([str(BIN), "run", str(scn), "--out", str(d / "out"), "-q"], check=True)
    return d / "out"


def test_replay_draws_the_arm_where_the_trajectory_says(browser, recorded):
    position = np.load(recorded / "trajectory.npz")["position"]
    first, last = position[0], position[-1]
    assert np.linalg.norm(first[-1] - last[-1]) > 0.05, "the tip must travel for this test"
    proc, url = start([str(BIN), "view", str(recorded), "--no-open", "--port", "0"])
    try:
        page, errors = open_page(browser, url)
        page.wait_for_function("window.__octoarm && window.__octoarm.ready", timeout=60_000)
        page.wait_for_function("window.__octoarm.rendered() > 0")
        assert page.evaluate("window.__octoarm.frameIndex()") == 0
        project = lambda p: page.evaluate("(p) => window.__octoarm.project(p)", [float(x) for x in p])  # noqa: E731

        def check(shown: np.ndarray, other: np.ndarray, img: Image.Image) -> None:
            # The tube's colour at every other projected node of the shown frame (the tip: within
            # a few pixels), and none at the other frame's tip (away from the shown rod).
            for i in range(0, len(shown) - 1, 2):
                assert tube_near(img, project(shown[i]), 2) > 0, f"no tube at node {i}"
            assert tube_near(img, project(shown[-1]), 4) > 0, "no tube near the tip"
            assert tube_near(img, project(other[-1]), 4) == 0, "tube where the rod is not"
            for corner in ([5, 40], [img.width - 260, 40], [5, img.height - 230]):
                assert tube_near(img, corner, 4) == 0

        check(first, last, shot(page))
        # The slider to the last frame (keyboard, as a user would) moves the drawn rod.
        page.focus("#frame")
        page.keyboard.press("End")
        page.wait_for_function(f"window.__octoarm.frameIndex() === window.__octoarm.frameCount() - 1")
        check(last, first, shot(page))
        assert errors == [], errors
        page.close()
    finally:
        assert stop(proc) == 0


def test_live_frames_arrive_and_the_last_equals_the_recording(browser, tmp_path):
    scn = tmp_path / "live.toml"
    scn.write_text(SCENARIO.format(duration=3.0))
    out = tmp_path / "out"
    proc, url = start(
        [str(BIN), "run", str(scn), "--out", str(out), "--view", "--no-open", "--port", "0", "-q"]
    )
    try:
        page, errors = open_page(browser, url)
        page.wait_for_function(
            "window.__octoarm && window.__octoarm.status && window.__octoarm.status.state === 'finished'",
            timeout=300_000,
        )
        during = page.evaluate("window.__octoarm.liveStepsBeforeFinish()")
        planned = page.evaluate("window.__octoarm.livePlanned()")
        assert planned > 0
        in_progress = [s for s in during if s < planned]
        assert len(in_progress) >= 2, f"frames seen during the run: {during}"
        assert page.evaluate("window.__octoarm.status.status") == "completed"
        last = page.evaluate("window.__octoarm.lastLive()")
        recorded = np.load(out / "trajectory.npz")
        assert last["step"] == planned
        assert last["time"] == pytest.approx(float(recorded["time"][-1]), abs=1e-12)
        want = recorded["position"][-1].astype(np.float32).ravel()
        np.testing.assert_array_equal(np.array(last["position"], dtype=np.float32), want)
        assert errors == [], errors
        page.close()
    finally:
        assert stop(proc) == 0
