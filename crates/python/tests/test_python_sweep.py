"""Sweeps on Ray (issue 14): a local Ray cluster on the loopback interface (two worker CPUs,
started by a ``ray.init`` fixture and shut down after) runs a 12-run sweep through the command
line (``octoarm sweep --ray ADDRESS``) and through ``octoarm.sweep``. Its ``results.csv`` equals
the local sweep's byte for byte, every run's ``trajectory.npz`` equals a standalone ``octoarm run``
of its ``scenario.toml`` byte for byte, a worker killed mid-sweep loses no run, and a missing
Ray or octoarm gives a clear error with nothing written. Skipped without ``ray``."""

import os
import signal
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

import octoarm

ray = pytest.importorskip("ray")
psutil = pytest.importorskip("psutil")

from test_python_scenario import _cli_binary  # noqa: E402

BASE = """
[rod]
n_elements = {n}
length = 0.2
base_diameter = 0.02
tip_diameter = 0.01
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3

[time]
dt = 2.0e-5
duration = {duration}
save_interval = 2.0e-3

[damping]
rate = 10.0

[[load]]
kind = "tip_force"
value = [0.0, 1.0e-4, 0.0]
"""

GRID = """
scenario = "base.toml"

[[parameter]]
path = "rod.youngs_modulus"
range = { start = 1.0e4, stop = 1.0e5, num = 4, scale = "log" }

[[parameter]]
path = "load[0].value"
values = [[0.0, 1.0e-4, 0.0], [0.0, 2.0e-4, 0.0], [0.0, 0.0, 3.0e-4]]
"""


@pytest.fixture(scope="module")
def ray_address():
    """A local Ray cluster on 127.0.0.1 with 2 CPUs (two task workers), stopped afterwards
    (loopback: see conftest.py)."""
    ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1",
             log_to_driver=False, logging_level="ERROR")
    try:
        address = ray.get_runtime_context().gcs_address
        assert address.startswith("127.0.0.1:"), address
        yield address
    finally:
        ray.shutdown()


def _sweep_dir(tmp_path, duration=0.02, n=20):
    (tmp_path / "base.toml").write_text(BASE.format(duration=duration, n=n))
    (tmp_path / "sweep.toml").write_text(GRID)
    return tmp_path


def _cli(args, cwd, **kw):
    return subprocess.run([_cli_binary(), *args], cwd=cwd, capture_output=True, text=True, **kw)


def _completed_rows(out):
    lines = (out / "results.csv").read_text().splitlines()[1:]
    return [line for line in lines if line.split(",")[2] == "completed"]


def test_ray_sweep_equals_local_sweep_and_standalone_runs(tmp_path, ray_address):
    d = _sweep_dir(tmp_path)
    local = _cli(["sweep", "sweep.toml", "--out", "local", "-q"], d)
    assert local.returncode == 0, local.stderr
    on_ray = _cli(["sweep", "sweep.toml", "--out", "ray", "--ray", ray_address,
                   "--python", sys.executable, "-q"], d)
    assert on_ray.returncode == 0, on_ray.stderr
    a, b = (d / "local" / "results.csv").read_bytes(), (d / "ray" / "results.csv").read_bytes()
    assert len(a.splitlines()) == 13 and len(_completed_rows(d / "ray")) == 12
    assert a == b
    assert '"kind": "ray"' in (d / "ray" / "sweep.json").read_text()
    runs = sorted((d / "ray" / "runs").iterdir())
    runs = [r for r in runs if r.is_dir()]
    assert len(runs) == 12
    for k, run in enumerate(runs):
        alone = d / f"alone{k}"
        r = _cli(["run", str(run / "scenario.toml"), "--out", str(alone), "-q"], d)
        assert r.returncode == 0, r.stderr
        npz = (run / "trajectory.npz").read_bytes()
        assert npz == (alone / "trajectory.npz").read_bytes(), run.name
        assert npz == (d / "local" / "runs" / run.name / "trajectory.npz").read_bytes()
        assert (run / "scenario.toml").read_bytes() == \
            (d / "local" / "runs" / run.name / "scenario.toml").read_bytes()


def test_python_api_sweeps_locally_and_on_ray_alike(tmp_path, ray_address):
    d = _sweep_dir(tmp_path)
    local = octoarm.sweep(d / "sweep.toml", d / "local")
    assert local["completed"] == 12 and local["failed"] == 0
    assert [r["run"] for r in local["rows"]] == list(range(12))
    on_ray = octoarm.sweep(d / "sweep.toml", d / "ray", ray=ray_address)
    assert on_ray["completed"] == 12
    assert (d / "local" / "results.csv").read_bytes() == (d / "ray" / "results.csv").read_bytes()
    # resume=True over a complete sweep runs nothing.
    again = octoarm.sweep(d / "sweep.toml", d / "ray", ray=ray_address, resume=True)
    assert again["skipped"] == 12 and again["completed"] == 12
    # The command line's table is the Python API's.
    cli = _cli(["sweep", "sweep.toml", "--out", "cli", "-q"], d)
    assert cli.returncode == 0, cli.stderr
    assert (d / "cli" / "results.csv").read_bytes() == (d / "ray" / "results.csv").read_bytes()
    with pytest.raises(ValueError, match=r"bad.toml:\d+:\d+: .*did you mean `youngs_modulus`"):
        (d / "bad.toml").write_text(GRID.replace("youngs_modulus", "youngs_modulu"))
        octoarm.sweep(d / "bad.toml", d / "bad")
    assert not (d / "bad").exists()


def _task_workers():
    """Ray worker processes currently running a sweep task (their title is ray::_run_one)."""
    found = []
    for p in psutil.process_iter(["cmdline"]):
        try:
            if any("_run_one" in part for part in (p.info["cmdline"] or [])):
                found.append(p)
        except (psutil.NoSuchProcess, psutil.AccessDenied):
            pass
    return found


def test_a_worker_killed_mid_sweep_loses_no_run(tmp_path, ray_address):
    d = _sweep_dir(tmp_path, duration=1.0, n=100)  # runs of ~0.3 s: caught running
    proc = subprocess.Popen([_cli_binary(), "sweep", "sweep.toml", "--out", "ray", "--ray",
                             ray_address, "--python", sys.executable], cwd=d,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    killed = []

    def killer():
        deadline = time.time() + 120
        while time.time() < deadline and proc.poll() is None:
            workers = _task_workers()
            if workers and len(_completed_rows_or_none(d / "ray")) >= 2:
                workers[0].send_signal(signal.SIGKILL)
                killed.append(workers[0].pid)
                return
            time.sleep(0.01)

    t = threading.Thread(target=killer)
    t.start()
    out, err = proc.communicate(timeout=600)
    t.join()
    assert killed, "no worker was caught running a task"
    assert proc.returncode == 0, err
    assert "running it again" in err, err
    assert len(_completed_rows(d / "ray")) == 12
    # The retried run is as if nothing had happened.
    local = _cli(["sweep", "sweep.toml", "--out", "local", "-q"], d)
    assert local.returncode == 0, local.stderr
    assert (d / "local" / "results.csv").read_bytes() == (d / "ray" / "results.csv").read_bytes()


def _completed_rows_or_none(out):
    try:
        return _completed_rows(out)
    except (FileNotFoundError, IndexError):
        return []


def test_missing_python_or_ray_is_a_clear_error_with_nothing_written(tmp_path):
    d = _sweep_dir(tmp_path)
    r = _cli(["sweep", "sweep.toml", "--out", "out", "--ray", "auto",
              "--python", str(tmp_path / "no-such-python")], d)
    assert r.returncode == 2, r.stderr
    assert "cannot start the Python interpreter" in r.stderr and "pip install" in r.stderr
    # A Python without octoarm (isolated from this environment's packages).
    bare = tmp_path / "bare-python"
    bare.write_text(f"#!/bin/sh\nexec {sys.executable} -I -S \"$@\"\n")
    bare.chmod(0o755)
    r = _cli(["sweep", "sweep.toml", "--out", "out", "--ray", "auto", "--python", str(bare)], d)
    assert r.returncode == 2, r.stderr
    assert "octoarm" in r.stderr and "pip install" in r.stderr, r.stderr
    assert not (d / "out").exists()
