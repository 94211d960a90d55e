"""octoarm.run_scenario writes the same trajectory.npz as the command line, to the last bit."""

import json
import os
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

import octoarm

ROOT = Path(__file__).resolve().parents[3]


def _cli_binary():
    if os.environ.get("OCTOARM_BIN"):
        return os.environ["OCTOARM_BIN"]
    # CI has just built it (cargo test --workspace); elsewhere this builds the debug binary.
    subprocess.run(["cargo", "build", "--quiet", "-p", "octoarm", "--bin", "octoarm"],
                   cwd=ROOT, check=True)
    meta = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"],
                          cwd=ROOT, check=True, capture_output=True, text=True)
    return str(Path(json.loads(meta.stdout)["target_directory"]) / "debug" / "octoarm")


@pytest.mark.parametrize("scenario", ["arm_tip_force.toml", "arm_sphere_contact.toml"])
def test_run_scenario_matches_command_line_bit_for_bit(tmp_path, scenario):
    path = ROOT / "scenarios" / scenario
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([_cli_binary(), "run", "--duration", "0.05", "--out", str(cli_out), str(path)],
                   check=True, capture_output=True)
    report = octoarm.run_scenario(str(path), str(py_out), duration=0.05, figures=False)
    assert report["frames"] > 1 and report["steps"] == report["planned_steps"]
    a, b = np.load(cli_out / "trajectory.npz"), np.load(py_out / "trajectory.npz")
    assert sorted(a.files) == sorted(b.files) and "position" in a.files
    for k in a.files:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
        assert a[k].tobytes() == b[k].tobytes(), k
    with zipfile.ZipFile(cli_out / "trajectory.npz") as za, \
            zipfile.ZipFile(py_out / "trajectory.npz") as zb:
        for name in za.namelist():
            assert za.read(name) == zb.read(name), name


def test_run_scenario_bad_input(tmp_path):
    with pytest.raises(ValueError):
        octoarm.run_scenario(str(tmp_path / "missing.toml"), str(tmp_path / "out"))
    bad = tmp_path / "bad.toml"
    bad.write_text((ROOT / "scenarios" / "arm_tip_force.toml").read_text()
                   .replace("dt = 1.0e-5", "dt = -1.0e-5"))
    with pytest.raises(ValueError, match="dt"):
        octoarm.run_scenario(str(bad), str(tmp_path / "out"))
