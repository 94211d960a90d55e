#!/usr/bin/env bash
# Speed comparison with PyElastica, measured in one sitting (README "Speed"). Not part of CI.
#
#   scripts/bench_pyelastica.sh                       # N = 100
#   N="25 50 100 200 400" scripts/bench_pyelastica.sh  # the README table (counts of the bench)
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
py_out=$("$venv/bin/python" "$root/scripts/bench_pyelastica.py" --elements $n)
echo "$py_out"

echo "== octoarm (criterion), N = $n"
cd "$root"
filter=$(echo "$n" | sed 's/ \+/|/g')
cargo bench -p octoarm-physics --bench step -- "paper_arm/[a-z0-9]+/($filter)\$" 2>&1 | grep -E 'paper_arm|time:' || true
criterion_dir="${CARGO_TARGET_DIR:-$root/target}/criterion/step"

echo
echo "machine: $(lscpu | sed -n 's/^Model name: *//p'), one core; $(date -u +%Y-%m-%dT%H:%MZ)"
python3 - "$criterion_dir" "$version" "$py_out" <<'PY'
import json, sys
criterion_dir, version, py_out = sys.argv[1], sys.argv[2], sys.argv[3]
py = {int(w[1]): float(w[2]) for w in (l.split() for l in py_out.splitlines()) if w and w[0] == "pyelastica_us_per_step"}
import os
print(f"{'N':>5} {'kernel':>9} {'octoarm [us/step]':>18} {'ns/element':>11} {'PyElastica ' + version + ' [us/step]':>28} {'ratio':>7}")
for n, p in sorted(py.items()):
    for kernel in ("baseline", "avx2"):
        path = f"{criterion_dir}/paper_arm_{kernel}/{n}/new/estimates.json"
        if not os.path.exists(path):
            continue
        with open(path) as f:
            rs = json.load(f)["median"]["point_estimate"] / 1e3
        print(f"{n:>5} {kernel:>9} {rs:>18.2f} {rs * 1e3 / n:>11.1f} {p:>28.2f} {p / rs:>6.1f}x")
PY
