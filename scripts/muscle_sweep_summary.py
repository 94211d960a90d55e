#!/usr/bin/env python3
"""Distributions of the muscular arm's target sweep (scripts/muscle_sweep.sh): design time,
iterations and starts, design and final tip / orientation errors, from the sweep's results.csv
(final errors omitted for a design-only sweep, DURATION_S = 1e-5). Prints a Markdown table
(quantiles) for the README. Standard library only."""
import csv
import math
import sys


def quantiles(values, qs=(0.0, 0.5, 0.9, 1.0)):
    v = sorted(x for x in values if math.isfinite(x))
    if not v:
        return [float("nan")] * len(qs)
    out = []
    for q in qs:
        k = q * (len(v) - 1)
        lo, hi = math.floor(k), math.ceil(k)
        out.append(v[lo] + (v[hi] - v[lo]) * (k - lo))
    return out


def main(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    done = [r for r in rows if r.get("status") == "completed"]
    print(f"{len(rows)} runs in the table, {len(done)} completed; "
          f"statuses: { {s: sum(r['status'] == s for r in rows) for s in sorted({r['status'] for r in rows})} }\n")
    # A design-only sweep (`--duration 1e-5`: one step of dynamics) has no meaningful final pose.
    design_only = all(float(r.get("final_time") or "nan") < 1.0 for r in done) and done
    cols = [
        ("design_seconds", "design time [s]", 1.0),
        ("design_iterations", "design iterations (all starts)", 1.0),
        ("design_starts", "design starts", 1.0),
        ("design_tip_error_l0", "design tip error / L0", 1.0),
        ("design_orientation_error", "design θ_Q [rad]", 1.0),
    ]
    if not design_only:
        cols += [
            ("final_tip_error_l0", "final tip error / L0", 1.0),
            ("final_orientation_error", "final θ_Q [rad]", 1.0),
            ("node_deviation_l0", "final max node deviation / L0", 1.0),
        ]
    print("| quantity | min | median | p90 | max |")
    print("|---|---:|---:|---:|---:|")
    for key, label, scale in cols:
        vals = []
        for r in done:
            try:
                vals.append(float(r[key]) * scale)
            except (KeyError, ValueError):
                pass
        q = quantiles(vals)
        print(f"| {label} | " + " | ".join(f"{x:.3g}" for x in q) + " |")
    met = [r for r in done if float(r.get("design_tip_error_l0", "nan")) <= 1.5e-4
           and float(r.get("design_orientation_error", "nan")) <= 1e-3]
    fin = [r for r in done if float(r.get("final_tip_error_l0", "nan")) <= 1e-2]
    print(f"\ndesigns meeting §7 A's bounds: {len(met)}/{len(done)}"
          + ("" if design_only else f"; final tip error ≤ 0.01 L0: {len(fin)}/{len(done)}"))
    winners = {}
    for r in done:
        w = r.get("design_winner") or ""
        key = "n/a" if w == "" else str(int(float(w)))
        winners[key] = winners.get(key, 0) + 1
    print("winning start (0: from a = 0; k: restart k): "
          + ", ".join(f"{k}: {v}" for k, v in sorted(winners.items(), key=lambda kv: (len(kv[0]), kv[0]))))
    if design_only:
        print("design only (one step of dynamics): final errors not reported")


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "results/muscle-sweep/results.csv")
