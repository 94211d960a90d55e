#!/usr/bin/env bash
# Sweep benchmark (issue 14; not in CI): 200 short runs (a 20-element arm, 2500 steps each),
# local (2 threads) against Ray (a local Ray cluster on 127.0.0.1 with 2 worker CPUs), with the
# release binary. Prints the wall times, the mean run time (from the runs' summary.json) and the
# Ray overhead per task: (T_ray - T_local) * workers / runs. Needs a Python with the octoarm
# package and ray (PYTHON=..., default target/ci-venv-python/bin/python).
set -euo pipefail
cd "$(dirname "$0")/.."
root="$PWD"
py="${PYTHON:-$root/target/ci-venv-python/bin/python}"
runs="${RUNS:-200}"
cargo build --release --quiet -p octoarm
bin="$root/target/release/octoarm"
work="$(mktemp -d)"
trap 'rm -rf "$work"' EXIT
cat > "$work/base.toml" <<'TOML'
[rod]
n_elements = 20
length = 0.2
base_diameter = 0.02
tip_diameter = 0.01
density = 700.0
youngs_modulus = 1.0e4
shear_modulus = 1.0e3
[time]
dt = 2.0e-5
duration = 0.05
save_interval = 1.0e-3
[damping]
rate = 10.0
[[load]]
kind = "tip_force"
value = [0.0, 1.0e-4, 0.0]
TOML
cat > "$work/sweep.toml" <<TOML
scenario = "base.toml"
[[parameter]]
path = "rod.youngs_modulus"
range = { start = 1.0e4, stop = 1.0e5, num = $runs, scale = "log" }
TOML
echo "machine: $(lscpu | sed -n 's/^Model name: *//p'); load: $(uptime | sed 's/.*load average: //')"
cd "$work"
t0=$(date +%s.%N)
"$bin" sweep sweep.toml --out local --threads 2 -q
t1=$(date +%s.%N)
export RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0   # loopback only
"$py" - "$bin" "$runs" "$t0" "$t1" <<'PY'
import json, subprocess, sys, time, glob
import ray
bin_, runs, t0, t1 = sys.argv[1], int(sys.argv[2]), float(sys.argv[3]), float(sys.argv[4])
ray.init(num_cpus=2, include_dashboard=False, _node_ip_address="127.0.0.1",
         log_to_driver=False, logging_level="ERROR")
address = ray.get_runtime_context().gcs_address
try:
    # Warm the two workers (imports) so that start-up is not counted per task.
    ray.get([ray.remote(lambda: __import__("octoarm")).remote() for _ in range(4)])
    s = time.perf_counter()
    subprocess.run([bin_, "sweep", "sweep.toml", "--out", "ray", "--ray", address,
                    "--python", sys.executable, "-q"], check=True)
    t_ray = time.perf_counter() - s
finally:
    ray.shutdown()
t_local = t1 - t0
same = open("local/results.csv", "rb").read() == open("ray/results.csv", "rb").read()
run_walls = [json.load(open(p))["wall_seconds"] for p in glob.glob("local/runs/*/summary.json")]
mean_run = sum(run_walls) / len(run_walls)
print(f"{runs} runs, 2 workers: local {t_local:.2f} s, Ray {t_ray:.2f} s; mean run "
      f"{mean_run * 1e3:.1f} ms; Ray overhead per task {(t_ray - t_local) * 2 / runs * 1e3:.1f} ms; "
      f"results.csv identical: {same}")
PY
echo "load after: $(uptime | sed 's/.*load average: //')"
