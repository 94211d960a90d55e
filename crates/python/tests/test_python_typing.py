"""Type stubs of the extension module (issue 16, item 13): shipped (py.typed, _octoarm.pyi),
complete (every public name and member of the module is in the stub), accepted by
`mypy --strict` on a usage file, catching a wrong call, and consistent with the module
(`stubtest`). The mypy checks are skipped when mypy is not installed."""

import ast
import importlib.util
import inspect
import os
import subprocess
import sys
from pathlib import Path

import pytest

import octoarm
import octoarm._octoarm as ext

PACKAGE = Path(octoarm.__file__).parent
STUB = PACKAGE / "_octoarm.pyi"
HAVE_MYPY = importlib.util.find_spec("mypy") is not None
needs_mypy = pytest.mark.skipif(not HAVE_MYPY, reason="mypy is not installed")


def _stub_names():
    tree = ast.parse(STUB.read_text())
    top, members = set(), {}
    for node in tree.body:
        if isinstance(node, ast.ClassDef):
            top.add(node.name)
            members[node.name] = {
                n.name if isinstance(n, ast.FunctionDef) else n.target.id
                for n in node.body
                if isinstance(n, ast.FunctionDef)
                or (isinstance(n, ast.AnnAssign) and isinstance(n.target, ast.Name))
            }
        elif isinstance(node, ast.FunctionDef):
            top.add(node.name)
        elif isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name):
            top.add(node.target.id)
        elif isinstance(node, ast.Assign):
            top.update(t.id for t in node.targets if isinstance(t, ast.Name))
    return top, members


def test_stubs_are_shipped_and_cover_the_module():
    assert (PACKAGE / "py.typed").is_file() and STUB.is_file()
    top, members = _stub_names()
    missing = [name for name in dir(ext) if not name.startswith("__") and name not in top]
    assert not missing, f"not in _octoarm.pyi: {missing}"
    assert "__version__" in top
    for cls_name, stub_members in members.items():
        cls = getattr(ext, cls_name)
        if issubclass(cls, BaseException):
            continue  # attributes are set on instances
        public = {n for n, _ in inspect.getmembers(cls) if not n.startswith("_")}
        assert public <= stub_members, f"{cls_name}: not in the stub: {public - stub_members}"


USAGE = '''
import numpy as np
import numpy.typing as npt
import octoarm
from octoarm.env import ArmReachEnv, ArmReachVectorEnv


def tip_after(n: int) -> npt.NDArray[np.float64]:
    sim = octoarm.Simulation.paper_arm(n_elements=20)
    sim.add_node_force([0.0, 2e-5, 0.0], ramp_time=0.01)
    sim.set_rest_strains(np.zeros((20, 3), np.float32), np.zeros((19, 3)))
    sim.step(n)
    energies: dict[str, float] = sim.energies()
    assert energies["total"] >= 0.0
    return sim.tip


def control() -> float:
    sim = octoarm.Simulation.from_rods([octoarm.Rod("arm", n_elements=20)])
    design = octoarm.OfflineSolver(sim).solve(target=[0.1, 0.1, 0.0])
    ctrl = octoarm.EnergyShapingController(sim, damping_rate=10.0)
    ctrl.set_design(sim, design)
    ctrl.step(sim, 10)
    return ctrl.shaped_hamiltonian(sim) + design.tip_error


def rl() -> float:
    batch = octoarm.ArmBatch(n_envs=2)
    obs = batch.reset(np.zeros((2, 2)))
    o, r, d, failures = batch.step(np.zeros((2, 4)))
    first: octoarm.InstabilityError | None = failures[0]
    env = ArmReachEnv()
    env.reset(seed=0)
    _, reward, _, truncated, _ = env.step(np.zeros(4))
    venv = ArmReachVectorEnv(num_envs=2)
    venv.reset(seed=0, options={"target": [0.1, 0.0]})
    return float(obs.sum() + r.sum() + d.sum() + reward) + (first.dt if first else 0.0)


try:
    octoarm.Simulation.paper_arm(dt=1e-3).step(1000)
except octoarm.InstabilityError as e:
    print(e.suggested_dt, e.advice, e.rod)
'''

WRONG = '''
import octoarm

sim = octoarm.Simulation.paper_arm()
sim.step("ten")
t: str = sim.time
'''


@needs_mypy
def test_mypy_strict_accepts_a_usage_file_and_catches_wrong_calls(tmp_path):
    (tmp_path / "usage.py").write_text(USAGE)
    (tmp_path / "wrong.py").write_text(WRONG)
    env = {**os.environ, "MYPY_CACHE_DIR": str(tmp_path / ".mypy_cache")}
    r = subprocess.run([sys.executable, "-m", "mypy", "--strict", "usage.py", "wrong.py"],
                       capture_output=True, text=True, env=env, cwd=tmp_path)
    out = r.stdout + r.stderr
    assert r.returncode == 1, out
    errors = [line for line in r.stdout.splitlines() if ": error:" in line]
    assert errors and all(line.startswith("wrong.py:") for line in errors), out  # usage.py: clean
    assert '"step" of "Simulation" has incompatible type "str"' in out
    assert 'Incompatible types in assignment (expression has type "float"' in out


@needs_mypy
def test_stubtest_agrees_with_the_module(tmp_path):
    r = subprocess.run([sys.executable, "-m", "mypy.stubtest", "octoarm._octoarm"],
                       capture_output=True, text=True, cwd=tmp_path,
                       env={**os.environ, "MYPY_CACHE_DIR": str(tmp_path / ".mypy_cache")})
    assert r.returncode == 0, r.stdout + r.stderr
