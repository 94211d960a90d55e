#!/usr/bin/env bash
# The muscular arm's target sweep (issue 12): reachable 3D target poses, each designed from a = 0
# (to spec §7 A's bounds, with the design's multi-start) and simulated with the muscle controller
# in water; then the distributions of design time and final errors (scripts/muscle_sweep_summary.py).
# Resumable: run it again with the same OUT and it continues (`octoarm sweep --resume`), keeping
# the complete runs. Not in CI (hours: ≈ 1 s design + the dynamics, ≈ 30 µs per step).
#
#   scripts/muscle_sweep.sh [OUT] [DURATION_S] [THREADS] [COUNT]
#   scripts/muscle_sweep.sh results/muscle-sweep 15 2 1000
#   scripts/muscle_sweep.sh results/muscle-designs 1e-5 1 1000   # designs only: one 10 µs step
#
# Targets: docs/muscles.md "Target sweep" (target_seed k = 0..COUNT-1: the tip point and frame
# of the static equilibrium under random activations drawn from seed k).
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-results/muscle-sweep}
duration=${2:-15}
threads=${3:-1}
count=${4:-1000}
cargo build --release -p octoarm
sweep=$(mktemp -d)/muscle_targets.toml
sed -e "s#^scenario = .*#scenario = \"$PWD/scenarios/muscles/target-sweep-base.toml\"#" \
    -e "s#stop = 999, num = 1000#stop = $((count - 1)), num = $count#" \
    scenarios/sweeps/muscle_targets.toml > "$sweep"
resume=()
if [ -f "$out/sweep.json" ]; then resume=(--resume); fi
target/release/octoarm sweep "$sweep" --out "$out" --duration "$duration" --threads "$threads" \
    "${resume[@]}" || echo "some runs failed or the sweep was interrupted; run again to resume"
python3 scripts/muscle_sweep_summary.py "$out/results.csv"
