#!/usr/bin/env bash
# Speed comparison with PyElastica, measured in one sitting (README "Speed"). Not part of CI.
#
#   scripts/bench_pyelastica.sh            # N = 100
#   N=200 scripts/bench_pyelastica.sh      # another element count (25, 50, 100, 200 or 400)
#
# 1. Makes a throw-away venv under /tmp and installs PyElastica from PyPI (PYELASTICA_VERSION,
#    default 1.0.0, the version current when this was written). Set PYELASTICA_VENV to reuse a venv.
# 2. Times PyElastica on the paper's arm (scripts/bench_pyelastica.py; that file's docstring lists
#    what differs between the two setups: damping module, force ramp, guard).
# 3. Runs octoarm's criterion bench for the same N and prints both medians and their ratio.
# Run it on an otherwise idle machine; both programs use one core.
set -euo pipefail

root=$(cd "$(dirname "$0")/.." && pwd)
n=${N:-100}
version=${PYELASTICA_VERSION:-1.0.0}

if [[ -n "${PYELASTICA_VENV:-}" ]]; then
    venv=$PYELASTICA_VENV
else
    venv=$(mktemp -d /tmp/pyelastica-venv.XXXXXX)
    trap 'rm -rf "$venv"' EXIT
fi
if [[ ! -x "$venv/bin/python" ]]; then
    python3 -m venv "$venv"
fi
"$venv/bin/pip" install --quiet --disable-pip-version-check "pyelastica==$version"

echo "== PyElastica $version, N = $n"
py_out=$("$venv/bin/python" "$root/scripts/bench_pyelastica.py" --elements "$n")
echo "$py_out"
py_us=$(echo "$py_out" | awk '/^pyelastica_us_per_step/ {print $2}')

echo "== octoarm (criterion), N = $n"
cd "$root"
cargo bench -p octoarm-physics --bench step -- "paper_arm/$n\$" 2>&1 | grep -E 'paper_arm|time:' || true
estimates="${CARGO_TARGET_DIR:-$root/target}/criterion/step/paper_arm/$n/new/estimates.json"
rs_us=$(python3 -c 'import json, sys; print(json.load(open(sys.argv[1]))["median"]["point_estimate"] / 1e3)' "$estimates")

echo
echo "machine: $(lscpu | sed -n 's/^Model name: *//p'), one core; $(date -u +%Y-%m-%dT%H:%MZ)"
python3 - "$n" "$py_us" "$rs_us" "$version" <<'PY'
import sys
n, py, rs, version = int(sys.argv[1]), float(sys.argv[2]), float(sys.argv[3]), sys.argv[4]
print(f"{'N':>5} {'octoarm [us/step]':>18} {'PyElastica ' + version + ' [us/step]':>28} {'ratio':>7}")
print(f"{n:>5} {rs:>18.2f} {py:>28.2f} {py / rs:>6.1f}x")
PY
