"""Score octoarm beside the other solvers in cosseratbench (issue 11) and print the README table.

Run by hand, not in CI (PyElastica takes minutes to hours on the contact experiments):

    python3 -m venv /tmp/cb && /tmp/cb/bin/pip install "./crates/python[bench]" pyelastica mujoco
    /tmp/cb/bin/python scripts/cosseratbench_scores.py --out results/cosseratbench \
        [--solver octoarm --solver pyelastica ...] [--experiment cantilever ...]

Every experiment runs at its default parameters and element count with cosseratbench's own
`run` (a warm-up run first, then the timed one) and metrics; solvers that do not install are
left out. Writes each result's summary as JSON under --out and prints one markdown table:
experiment, elements, then per solver its metrics, wall time after warm-up and outcome.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from cosseratbench import registry
from cosseratbench.experiment import run


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawTextHelpFormatter)
    p.add_argument("--solver", action="append", help="default: every installed solver")
    p.add_argument("--experiment", action="append", help="default: all seven")
    p.add_argument("--out", type=Path, default=Path("results/cosseratbench"))
    a = p.parse_args()
    solvers = a.solver or ["octoarm", "pyelastica", "mujoco", "dismech"]
    experiments = a.experiment or registry.names(registry.EXPERIMENTS)
    loaded = {}
    for name in solvers:
        try:
            loaded[name] = registry.load_solver(name)
        except Exception as e:  # not installed here
            print(f"# {name}: not available ({type(e).__name__}: {e})")
    rows = []
    for ename in experiments:
        exp = registry.load_experiment(ename)
        for sname, solver in loaded.items():
            r = run(exp, solver)
            summary = r.summary()
            d = a.out / ename / sname
            d.mkdir(parents=True, exist_ok=True)
            (d / "result.json").write_text(json.dumps(summary, indent=2, default=str) + "\n")
            metrics = ", ".join(
                f"{k} {v:.3g}" for k, v in summary["metrics"].items() if v is not None
            )
            wall = "" if r.wall_time is None else f"{r.wall_time:.2f}"
            outcome = r.outcome if not r.missing else f"unsupported ({', '.join(r.missing)})"
            if r.failure:
                outcome = f"diverged at {r.diverged_at}: {r.failure[:80]}"
            rows.append((ename, r.n_elements, sname, metrics, wall, outcome))
            print(f"# {ename} / {sname}: {outcome}; {metrics}; wall {wall} s", flush=True)
    print()
    print("| experiment | N | solver | metrics (cosseratbench's) | wall time [s] | outcome |")
    print("|---|---|---|---|---|---|")
    for e, n, s, m, w, o in rows:
        print(f"| {e} | {n} | {s} | {m} | {w} | {o} |")


if __name__ == "__main__":
    main()
