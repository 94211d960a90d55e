//! Criterion benchmark: the cost of recording and writing on top of stepping, at the default
//! save_interval = 1e-3 s (every 100 steps at dt = 1e-5 s). For the paper's arm with its tip
//! force and N = 50, 100, 200 elements, 1 s of simulated time (100 000 steps, 1001 frames;
//! long enough that the fixed costs —
//! writer thread start, spool files, the final zip assembly — weigh as in a real run):
//! - `step_only`: the stepper loop alone;
//! - `record_npz`: the run pipeline without figures: the same loop with the recorder (guard
//!   check, energies, frame copy, strains and compression on the writer thread) and
//!   `trajectory.npz`, `summary.json`, `scenario.toml` written at the end;
//! - `whole_run/100`: `pipeline::run` with everything (npz, summary.json, scenario.toml, figures).
//!
//! Setup (scenario parsing, model building) is outside the timed closures except in `whole_run`.
#![allow(missing_docs)] // criterion's macros generate undocumented items

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion};
use octoarm::build::build_system;
use octoarm::figures::CliFigures;
use octoarm::output::OutputDir;
use octoarm::pipeline::{self, RunOptions};
use octoarm::scenario::Scenario;
use octoarm_physics::Simulation;
use std::path::Path;
use std::time::Duration;

fn scenario(n: usize) -> Scenario {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenarios/arm_tip_force.toml");
    let text = std::fs::read_to_string(&path)
        .unwrap()
        .replace("n_elements = 100", &format!("n_elements = {n}"))
        .replace("duration = 2.0", "duration = 1.0")
        .replace("value = [0.0, 2.0e-5, 0.0]", "value = [0.0, 1.0e-5, 0.0]");
    Scenario::from_str(&path, &text).unwrap()
}

fn bench_recording(c: &mut Criterion) {
    let mut group = c.benchmark_group("arm_1s");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(20))
        .warm_up_time(Duration::from_secs(1));
    let tmp = tempfile::tempdir().unwrap();
    for n in [50usize, 100, 200] {
        let scn = scenario(n);
        let steps = scn.config.n_steps();
        group.bench_with_input(BenchmarkId::new("step_only", n), &n, |b, _| {
            b.iter_batched(
                || {
                    let (system, state) = build_system(&scn).unwrap();
                    Simulation::from_parts(system, state)
                },
                |mut sim| {
                    for _ in 0..steps {
                        sim.step().unwrap();
                    }
                    sim
                },
                criterion::BatchSize::LargeInput,
            );
        });
        let dir = tmp.path().join(format!("rec{n}"));
        group.bench_with_input(BenchmarkId::new("record_npz", n), &n, |b, _| {
            b.iter_batched(
                || {
                    (
                        pipeline::prepare(&scn).unwrap(),
                        OutputDir::prepare(&dir).unwrap(),
                    )
                },
                |(prepared, out)| {
                    let report =
                        pipeline::run(&scn, prepared, out, &RunOptions::default()).unwrap();
                    assert!(report.failure.is_none());
                    report.steps
                },
                criterion::BatchSize::LargeInput,
            );
        });
    }
    let scn = scenario(100);
    let out = tmp.path().join("whole");
    group.bench_function(BenchmarkId::new("whole_run", 100), |b| {
        let opts = RunOptions {
            progress: None,
            figures: Some(&CliFigures),
            stop: None,
        };
        b.iter(|| {
            pipeline::run(
                &scn,
                pipeline::prepare(&scn).unwrap(),
                OutputDir::prepare(&out).unwrap(),
                &opts,
            )
            .unwrap()
            .steps
        });
    });
    group.finish();
}

criterion_group!(benches, bench_recording);
criterion_main!(benches);
