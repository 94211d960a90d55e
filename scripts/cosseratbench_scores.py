"""Score octoarm beside the other solvers in cosseratbench (issue 11) and print the README table.

Run by hand, not in CI (PyElastica takes minutes to hours on the contact experiments):

    python3 -m venv /tmp/cb && /tmp/cb/bin/pip install "./crates/python[bench]" pyelastica "mujoco<4"
    /tmp/cb/bin/python scripts/cosseratbench_scores.py --out results/cosseratbench \
        [--solver octoarm --solver pyelastica ...] [--experiment cantilever ...]
    /tmp/cb/bin/python scripts/cosseratbench_scores.py --out results/cosseratbench --table

Every experiment runs at its default parameters and element count with cosseratbench's own
`run` (a warm-up run first, then the timed one) and metrics; solvers that do not install are
left out. Each result's summary is written as JSON under --out/<experiment>/<solver>/, so
solvers can be run in separate processes (in parallel, or one after another); the table is
printed from every result found under --out: experiment, elements, then per solver its
metrics, wall time after warm-up and outcome. `--table` only prints it.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

SOLVERS = ["octoarm", "pyelastica", "mujoco", "dismech"]


def table(out: Path) -> None:
    """Print the markdown table of every result.json under `out`."""
    from cosseratbench import registry

    print("| experiment | N | solver | metrics (cosseratbench's) | wall time [s] | outcome |")
    print("|---|---|---|---|---|---|")
    for ename in registry.names(registry.EXPERIMENTS):
        for sname in SOLVERS:
            f = out / ename / sname / "result.json"
            if not f.exists():
                continue
            s = json.loads(f.read_text())
            metrics = ", ".join(f"{k} {v:.3g}" for k, v in s["metrics"].items() if v is not None)
            wall = "" if s["wall_time"] is None else f"{s['wall_time']:.2f}"
            outcome = s["outcome"]
            if s["missing"]:
                outcome = f"unsupported ({', '.join(s['missing'])})"
            if s["failure"]:
                outcome = f"diverged at {s['diverged_at']}: {s['failure'][:80]}"
            print(f"| {ename} | {s['n_elements']} | {sname} | {metrics} | {wall} | {outcome} |")


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--solver", action="append", help="default: every installed solver")
    p.add_argument("--experiment", action="append", help="default: all seven")
    p.add_argument("--out", type=Path, default=Path("results/cosseratbench"))
    p.add_argument("--table", action="store_true", help="only print the table from --out")
    a = p.parse_args()
    if a.table:
        table(a.out)
        return
    from cosseratbench import registry
    from cosseratbench.experiment import run

    experiments = a.experiment or registry.names(registry.EXPERIMENTS)
    loaded = {}
    for name in a.solver or SOLVERS:
        try:
            loaded[name] = registry.load_solver(name)
        except Exception as e:  # not installed here
            print(f"# {name}: not available ({type(e).__name__}: {e})")
    for ename in experiments:
        exp = registry.load_experiment(ename)
        for sname, solver in loaded.items():
            try:
                r = run(exp, solver)
            except Exception as e:  # a peer's adapter failing (e.g. MuJoCo 4 for 0.3.0's) ends only its run
                print(f"# {ename} / {sname}: failed ({type(e).__name__}: {e})", flush=True)
                continue
            summary = r.summary()
            d = a.out / ename / sname
            d.mkdir(parents=True, exist_ok=True)
            (d / "result.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
            print(f"# {ename} / {sname}: {r.outcome}; {summary['metrics']}; wall {r.wall_time} s", flush=True)
    print()
    table(a.out)


if __name__ == "__main__":
    main()
