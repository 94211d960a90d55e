#!/usr/bin/env python3
"""The automatic time step on the paper's four experiments (issue 13, item 4; not in CI).

Runs each of `scenarios/paper/{two-targets,moving-target,obstacles,grasp}.toml` twice with the
release binary, one run at a time: as shipped (dt = 1e-5 s) and with `dt = "auto"` (a copy of the
file with only that line changed), and prints a Markdown table: the automatic dt, the wall time
of each run (the whole `octoarm run` process, outputs included), the speed-up, the largest
difference max_t |d_auto(t) - d_fixed(t)| of the distance curves (`distance.csv`, d in L0, at
every 1 ms sample) and whether the acceptance claims give the same verdicts.

Usage (from anywhere; builds the binary first):

    python3 scripts/auto_dt_table.py            # all four
    python3 scripts/auto_dt_table.py obstacles  # some of them, by file stem
    OCTOARM=target/release/octoarm python3 scripts/auto_dt_table.py   # skip the build

Wall times depend on the machine's load: the script prints `lscpu`'s model name and the load
average before and after; compare the two columns of one sitting only.
"""

import csv
import json
import os
import re
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
NAMES = ["two-targets", "moving-target", "obstacles", "grasp"]
LETTER = {"two-targets": "A", "moving-target": "B", "obstacles": "C", "grasp": "D"}


def machine() -> str:
    try:
        out = subprocess.run(["lscpu"], capture_output=True, text=True, check=True).stdout
        model = next(
            (l.split(":", 1)[1].strip() for l in out.splitlines() if l.startswith("Model name")),
            "?",
        )
    except (OSError, subprocess.CalledProcessError):
        model = "?"
    return f"{model}, {os.cpu_count()} CPUs"


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def distance(path: Path) -> list[tuple[float, float]]:
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    return [(float(t), float(d)) for t, d in rows[1:]]


def run(binary: str, scenario: Path, out: Path) -> tuple[float, dict]:
    t0 = time.perf_counter()
    p = subprocess.run(
        [binary, "run", str(scenario), "--out", str(out), "-q"],
        capture_output=True,
        text=True,
    )
    wall = time.perf_counter() - t0
    if p.returncode != 0:
        sys.exit(f"{scenario.name}: octoarm run failed ({p.returncode}):\n{p.stderr}")
    with open(out / "summary.json") as f:
        return wall, json.load(f)


def verdicts(summary: dict) -> list[str]:
    return [str(c.get("pass")) for c in summary.get("acceptance") or []]


def main() -> None:
    names = sys.argv[1:] or NAMES
    for n in names:
        if n not in NAMES:
            sys.exit(f"unknown experiment {n!r}; choose from {', '.join(NAMES)}")
    binary = os.environ.get("OCTOARM")
    if not binary:
        subprocess.run(
            ["cargo", "build", "--release", "--quiet", "-p", "octoarm"], cwd=ROOT, check=True
        )
        binary = str(ROOT / "target" / "release" / "octoarm")
    print(f"machine: {machine()}; load average before: {load()}", file=sys.stderr)
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        for name in names:
            text = (ROOT / "scenarios" / "paper" / f"{name}.toml").read_text()
            auto, k = re.subn(r"(?m)^dt = 1\.0e-5\b", 'dt = "auto"', text)
            if k != 1:
                sys.exit(f"{name}.toml: expected one line `dt = 1.0e-5` in [time]")
            # The copies sit in the temporary folder; the relative paths of the scenarios (none
            # today) would need the original folder.
            fixed_path, auto_path = tmp / f"{name}.toml", tmp / f"{name}-auto.toml"
            fixed_path.write_text(text)
            auto_path.write_text(auto)
            w_fixed, s_fixed = run(binary, fixed_path, tmp / f"{name}-fixed-out")
            w_auto, s_auto = run(binary, auto_path, tmp / f"{name}-auto-out")
            a = distance(tmp / f"{name}-fixed-out" / "distance.csv")
            b = distance(tmp / f"{name}-auto-out" / "distance.csv")
            if len(a) != len(b) or any(abs(ta - tb) > 1e-9 for (ta, _), (tb, _) in zip(a, b)):
                sys.exit(f"{name}: the two runs sampled the distance at different times")
            worst, at = max((abs(da - db), t) for (t, da), (_, db) in zip(a, b))
            dt_auto = s_auto.get("dt", float("nan"))
            same = verdicts(s_fixed) == verdicts(s_auto)
            rows.append((name, dt_auto, w_fixed, w_auto, worst, at, same))
            print(f"{name}: done", file=sys.stderr)
    print(f"machine: {machine()}; load average after: {load()}", file=sys.stderr)
    print(
        "| experiment | auto dt [s] | wall, dt = 1e-5 s [s] | wall, auto [s] | speed-up "
        "| max \\|Δd\\| [L0] (at t [s]) | same acceptance verdicts |"
    )
    print("|---|---:|---:|---:|---:|---:|---|")
    for name, dt, wf, wa, worst, at, same in rows:
        print(
            f"| {LETTER[name]} {name} | {dt:.4e} | {wf:.1f} | {wa:.1f} | {wf / wa:.1f}× "
            f"| {worst:.1e} ({at:.3f}) | {'yes' if same else 'NO'} |"
        )


if __name__ == "__main__":
    main()
