"""octoarm.run_scenario is `octoarm run`: the same trajectory.npz (and, for controlled runs,
distance.csv) as the command line, to the last bit, for passive and controlled scenarios."""

import json
import os
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

import octoarm

ROOT = Path(__file__).resolve().parents[3]
PAPER = sorted((ROOT / "scenarios" / "paper").glob("*.toml"))


def _cli_binary():
    if os.environ.get("OCTOARM_BIN"):
        return os.environ["OCTOARM_BIN"]
    # CI has just built it (cargo test --workspace); elsewhere this builds the debug binary.
    subprocess.run(["cargo", "build", "--quiet", "-p", "octoarm", "--bin", "octoarm"],
                   cwd=ROOT, check=True)
    meta = subprocess.run(["cargo", "metadata", "--format-version", "1", "--no-deps"],
                          cwd=ROOT, check=True, capture_output=True, text=True)
    return str(Path(json.loads(meta.stdout)["target_directory"]) / "debug" / "octoarm")


def _run_both(tmp_path, path, duration=0.05):
    cli_out, py_out = tmp_path / "cli", tmp_path / "py"
    subprocess.run([_cli_binary(), "run", "--quiet", "--duration", str(duration),
                    "--out", str(cli_out), str(path)], check=True, capture_output=True)
    report = octoarm.run_scenario(str(path), str(py_out), duration=duration)
    return cli_out, py_out, report


def _assert_same_trajectory(cli_out, py_out):
    a, b = np.load(cli_out / "trajectory.npz"), np.load(py_out / "trajectory.npz")
    assert sorted(a.files) == sorted(b.files) and any(k.endswith("position") for k in a.files)
    for k in a.files:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
        assert a[k].tobytes() == b[k].tobytes(), k
    with zipfile.ZipFile(cli_out / "trajectory.npz") as za, \
            zipfile.ZipFile(py_out / "trajectory.npz") as zb:
        assert sorted(za.namelist()) == sorted(zb.namelist())
        for name in za.namelist():
            assert za.read(name) == zb.read(name), name


@pytest.mark.parametrize("scenario", ["arm_tip_force.toml", "arm_sphere_contact.toml"])
def test_run_scenario_matches_command_line_bit_for_bit(tmp_path, scenario):
    cli_out, py_out, report = _run_both(tmp_path, ROOT / "scenarios" / scenario)
    assert report["frames"] > 1 and report["steps"] == report["planned_steps"]
    assert report["status"] == "completed" and report["controlled"] is False
    assert "final_distance" not in report
    _assert_same_trajectory(cli_out, py_out)
    assert not (py_out / "distance.csv").exists() and not (py_out / "series.npz").exists()
    assert not list(py_out.glob("*.png")) and not list(py_out.glob("*.gif"))  # no figures


@pytest.mark.parametrize("path", PAPER, ids=[p.stem for p in PAPER])
def test_paper_scenarios_match_command_line_bit_for_bit(tmp_path, path):
    assert len(PAPER) >= 4
    cli_out, py_out, report = _run_both(tmp_path, path)
    assert report["controlled"] is True and report["status"] == "completed"
    assert report["steps"] == report["planned_steps"] == 5000
    _assert_same_trajectory(cli_out, py_out)
    a = (cli_out / "distance.csv").read_bytes()
    assert len(a.splitlines()) > 2
    assert a == (py_out / "distance.csv").read_bytes()
    assert (py_out / "series.npz").is_file()
    assert not list(py_out.glob("*.png")) and not list(py_out.glob("*.gif"))  # no figures


def test_controlled_scenario_is_run_controlled(tmp_path):
    """The old run_scenario ran a controlled scenario as a passive one, silently."""
    out = tmp_path / "two"
    report = octoarm.run_scenario(ROOT / "scenarios" / "paper" / "two-targets.toml", out,
                                  duration=0.02)
    assert report["controlled"] is True and report["status"] == "completed"
    assert Path(report["out_dir"]) == out
    assert (out / "distance.csv").is_file() and (out / "series.npz").is_file()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["controlled"] is True and summary["status"] == "completed"
    assert summary["steps"] == report["steps"] == 2000
    rows = np.loadtxt(out / "distance.csv", delimiter=",", skiprows=1)
    # d / L0 starts at |(0.2, 0) - (0.09, 0.09)| / 0.2; the controller moves the arm (a passive
    # run of this unloaded arm would stay at rest, at that distance).
    assert rows[0, 1] == pytest.approx(np.hypot(0.11, 0.09) / 0.2, rel=1e-9)
    series = np.load(out / "series.npz")
    assert report["final_distance"] == series["distance"][-1]
    assert abs(series["distance"][-1] - series["distance"][0]) > 1e-4
    assert np.abs(series["tip"][-1] - series["tip"][0]).max() > 1e-5  # m
    assert rows[-1, 1] == pytest.approx(report["final_distance"], rel=1e-9)  # 10 digits in CSV
    assert (out / "scenario.toml").is_file() and "duration = 0.02" in (
        out / "scenario.toml").read_text()


def test_figures_argument_is_gone(tmp_path):
    with pytest.raises(TypeError, match="figures"):
        octoarm.run_scenario(str(ROOT / "scenarios" / "arm_tip_force.toml"),
                             str(tmp_path / "out"), duration=0.01, figures=False)
    assert not (tmp_path / "out").exists()


def test_run_scenario_bad_input(tmp_path):
    with pytest.raises(ValueError):
        octoarm.run_scenario(str(tmp_path / "missing.toml"), str(tmp_path / "out"))
    bad = tmp_path / "bad.toml"
    bad.write_text((ROOT / "scenarios" / "arm_tip_force.toml").read_text()
                   .replace("dt = 1.0e-5", "dt = -1.0e-5"))
    with pytest.raises(ValueError, match=r"bad\.toml:\d+:\d+: .*dt") as info:
        octoarm.run_scenario(str(bad), str(tmp_path / "out"))
    assert "allowed" in str(info.value)
    with pytest.raises(ValueError, match="duration"):
        octoarm.run_scenario(str(ROOT / "scenarios" / "arm_tip_force.toml"),
                             str(tmp_path / "out"), duration=-1.0)
    assert not (tmp_path / "out").exists()  # nothing written for bad input


def test_output_directory_problem_is_os_error(tmp_path):
    occupied = tmp_path / "occupied"
    occupied.mkdir()
    (occupied / "precious.txt").write_text("not an octoarm output")
    # The app refuses a folder it did not write, naming what is in the way (issue 16, item 1).
    with pytest.raises(OSError, match="not an octoarm output") as info:
        octoarm.run_scenario(str(ROOT / "scenarios" / "arm_tip_force.toml"), str(occupied),
                             duration=0.01)
    assert "precious.txt" in str(info.value)
    assert (occupied / "precious.txt").read_text() == "not an octoarm output"


def test_unstable_run_raises_after_writing(tmp_path):
    path = tmp_path / "unstable.toml"
    path.write_text((ROOT / "scenarios" / "arm_tip_force.toml").read_text()
                    .replace("dt = 1.0e-5", "dt = 1.0e-3"))
    out = tmp_path / "out"
    with pytest.warns(UserWarning, match="stable limit"):
        with pytest.raises(octoarm.InstabilityError) as info:
            octoarm.run_scenario(str(path), str(out), duration=1.0)
    e = info.value
    assert isinstance(e, RuntimeError) and e.dt == 1e-3 and e.rod is None
    assert e.report["status"] == "unstable" and e.report["steps"] < e.report["planned_steps"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["status"] == "unstable" and summary["failure"]["kind"] == "unstable"
    t = np.load(out / "trajectory.npz")["time"]
    assert t.size == e.report["frames"] >= 1 and np.isfinite(t).all()


def test_ctrl_c_stops_run_scenario_and_keeps_what_was_recorded(tmp_path):
    """Ctrl-C during run_scenario (here: Python's interrupt of the main thread, as a SIGINT
    handler does) stops the run within a step: the outputs hold what was recorded, finite,
    summary.json says "interrupted", and KeyboardInterrupt carries the report."""
    import _thread
    import threading

    out = tmp_path / "out"
    timer = threading.Timer(1.0, _thread.interrupt_main)
    timer.start()
    try:
        with pytest.raises(KeyboardInterrupt) as caught:
            # 50 s of simulated time at dt = 1e-5 s: minutes of work, stopped after ~1 s.
            octoarm.run_scenario(str(ROOT / "scenarios" / "arm_tip_force.toml"), str(out),
                                 duration=50.0)
    finally:
        timer.cancel()
    report = caught.value.report
    assert report["status"] == "interrupted"
    assert 0 < report["steps"] < report["planned_steps"]
    traj = np.load(out / "trajectory.npz")
    assert traj["time"].shape == (report["frames"],)
    for k in traj.files:
        assert np.isfinite(traj[k]).all(), k
    assert json.loads((out / "summary.json").read_text())["status"] == "interrupted"
