"""NumPy-side check of octoarm's outputs: trajectory.npz loads with plain numpy, arrays have the
promised names, shapes, dtype and units (metres, m/s, unit directors), and the tip of the
tip-force scenario moves toward +y. Runs the octoarm binary built by `cargo test`."""

import json
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def octoarm():
    """Path of the octoarm binary (OCTOARM_BIN, or the one `cargo test` builds)."""
    if "OCTOARM_BIN" in os.environ:
        return os.environ["OCTOARM_BIN"]
    # A no-op after `cargo test --workspace`: same profile, same binary.
    subprocess.run(["cargo", "test", "-q", "-p", "octoarm", "--no-run"], cwd=ROOT, check=True)
    target = Path(os.environ.get("CARGO_TARGET_DIR", ROOT / "target"))
    return str(target / "debug" / "octoarm")


@pytest.fixture(scope="session")
def tip_force_run(octoarm, tmp_path_factory):
    out = tmp_path_factory.mktemp("runs") / "arm_tip_force"
    scenario = ROOT / "scenarios" / "arm_tip_force.toml"
    # Shortened from 2 s to 0.3 s of simulated time to keep the test quick.
    subprocess.run([octoarm, "run", str(scenario), "--out", str(out), "--duration", "0.3", "--quiet"], check=True)
    return out


def test_names_shapes_and_dtype(tip_force_run):
    with np.load(tip_force_run / "trajectory.npz") as npz:
        names = set(npz.files)
        assert {"time", "position", "velocity", "director", "sigma", "kappa"} <= names
        t = npz["time"]
        T, N = t.shape[0], 100
        assert t.shape == (T,) and T == 301  # t = 0, every 1 ms, to 0.3 s
        assert npz["position"].shape == (T, N + 1, 3)
        assert npz["velocity"].shape == (T, N + 1, 3)
        assert npz["director"].shape == (T, N, 3, 3)
        assert npz["sigma"].shape == (T, N, 3)
        assert npz["kappa"].shape == (T, N - 1, 3)
        for name in names:
            assert npz[name].dtype == np.float64, name
            assert np.all(np.isfinite(npz[name])), name


def test_units(tip_force_run):
    with np.load(tip_force_run / "trajectory.npz") as npz:
        t, x, v, q = npz["time"], npz["position"], npz["velocity"], npz["director"]
    # Time in seconds, sampled every save_interval = 1e-3 s.
    assert t[0] == 0.0
    np.testing.assert_allclose(np.diff(t), 1e-3, rtol=1e-9)
    # Positions in metres: the straight 0.2 m arm along +x, base clamped at the origin.
    np.testing.assert_allclose(x[0, :, 0], np.linspace(0.0, 0.2, 101), atol=1e-12)
    assert np.all(x[:, 0, :] == 0.0)
    assert np.abs(x).max() < 0.25
    # Velocities in m/s: the central difference of positions matches the recorded velocity.
    fd = (x[2:] - x[:-2]) / (t[2:] - t[:-2])[:, None, None]
    scale = np.abs(v).max()
    assert scale > 0
    assert np.abs(fd - v[1:-1]).max() < 0.05 * scale
    # Directors: rows d1, d2, d3 orthonormal; d3 of the rest arm is +x, d1 is +y.
    eye = np.einsum("tjab,tjcb->tjac", q, q)
    np.testing.assert_allclose(eye, np.broadcast_to(np.eye(3), eye.shape), atol=1e-9)
    np.testing.assert_allclose(q[0, 0], [[0, 1, 0], [0, 0, 1], [1, 0, 0]], atol=1e-12)


def test_tip_moves_toward_plus_y(tip_force_run):
    with np.load(tip_force_run / "trajectory.npz") as npz:
        tip = npz["position"][:, -1, :]
    assert tip[0, 1] == 0.0
    assert tip[-1, 1] > 1e-3  # metres
    assert abs(tip[-1, 2]) < 1e-9  # the load is in the x-y plane


def test_summary(tip_force_run):
    s = json.loads((tip_force_run / "summary.json").read_text())
    assert s["status"] == "completed"
    assert s["steps"] == 30000
    assert s["simulated_seconds"] == pytest.approx(0.3)
    assert s["wall_seconds"] > 0 and s["us_per_step"] > 0
    assert len(s["final_tip_position"]) == 3 and s["final_tip_position"][1] > 0
    assert {"kinetic", "strain", "total"} <= set(s["final_energies"])
    assert s["version"]
    assert s["arrays"]["position"]["unit"] == "m"
