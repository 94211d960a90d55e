//! `octoarm paper`: the paper's four experiments (control spec §5) from the scenarios in
//! `scenarios/paper/` (compiled in), run in parallel, each into its own folder as it completes,
//! then `distance.png` and `report.md` with the derived figures and the acceptance checks. The
//! runs themselves are `controlled.rs`; the figures `paper_figures.rs`.

use crate::controlled::{self, ControlledRun};
use crate::output::OutputDir;
use crate::output::OutputError;
use crate::paper_figures::{self, DistanceCurve};
use crate::progress::Progress;
use crate::scenario::{Scenario, ScenarioError};
use anyhow::{Context, Result};
use octoarm_control::{ExperimentOutcome, ExperimentSpec};
use std::fmt::Write as _;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The paper's scenarios: (letter, file name, text), in the order A–D.
pub const SCENARIOS: [(&str, &str, &str); 4] = [
    (
        "A",
        "two-targets.toml",
        include_str!("../../../scenarios/paper/two-targets.toml"),
    ),
    (
        "B",
        "moving-target.toml",
        include_str!("../../../scenarios/paper/moving-target.toml"),
    ),
    (
        "C",
        "obstacles.toml",
        include_str!("../../../scenarios/paper/obstacles.toml"),
    ),
    (
        "D",
        "grasp.toml",
        include_str!("../../../scenarios/paper/grasp.toml"),
    ),
];

/// The four scenarios as loaded (named `scenarios/paper/<file>`), with the duration replaced if
/// given.
pub fn paper_scenarios(duration: Option<f64>) -> Result<Vec<Scenario>, ScenarioError> {
    SCENARIOS
        .iter()
        .map(|(_, file, text)| {
            let path = Path::new("scenarios/paper").join(file);
            let mut scn = Scenario::from_str(&path, text)?;
            if let Some(d) = duration {
                crate::override_duration(&mut scn, d)?;
            }
            Ok(scn)
        })
        .collect()
}

/// Letter of a paper experiment by its folder name.
pub fn letter(name: &str) -> &'static str {
    SCENARIOS
        .iter()
        .find(|(_, file, _)| file.trim_end_matches(".toml") == name)
        .map_or("-", |(l, _, _)| l)
}

/// One acceptance check of control spec §5: the claim, what was measured, and the verdict
/// (None when the run is too short to decide).
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// The claim, e.g. "d(4 s) <= 0.01".
    pub claim: String,
    /// The measured value(s), in words.
    pub measured: String,
    /// Pass, fail, or not decidable (the run ended before the time the claim is about).
    pub pass: Option<bool>,
}

/// Largest penetration tolerated (C: 1 mm = 0.005 L0; D: 1e-3 L0), metres.
fn check(claim: &str, measured: String, pass: Option<bool>) -> Check {
    Check {
        claim: claim.to_string(),
        measured,
        pass,
    }
}

/// The acceptance checks of control spec §5.2–§5.5 for a paper experiment (by its name); none
/// for other runs. Checks about times after the run's end are undecided.
pub fn acceptance(o: &ExperimentOutcome) -> Vec<Check> {
    let spec = &o.spec;
    let s = &o.summary;
    let length = o.length;
    let end = o.series.last().map_or(0.0, |x| x.time);
    let full = end >= 4.0 - 1e-9;
    let short = |t: f64| format!("run ends at {end:.3} s, before {t} s");
    let mut out = Vec::new();
    match spec.name.as_str() {
        "two-targets" => {
            let before = o.series.iter().rfind(|x| x.time < 1.8 - 1e-9);
            let after = o.series.iter().find(|x| x.time >= 1.8 - 1e-9);
            match (before, after) {
                (Some(b), Some(a)) => {
                    out.push(check(
                        "d(1.8⁻) ≤ 0.02",
                        format!("{:.4}", b.distance),
                        Some(b.distance <= 0.02),
                    ));
                    out.push(check(
                        "0.55 ≤ d(1.8⁺) ≤ 0.59",
                        format!("{:.4}", a.distance),
                        Some((0.55..=0.59).contains(&a.distance)),
                    ));
                }
                _ => {
                    out.push(check("d(1.8⁻) ≤ 0.02", short(1.8), None));
                    out.push(check("0.55 ≤ d(1.8⁺) ≤ 0.59", short(1.8), None));
                }
            }
            let settle = s.segments.get(1).and_then(|g| g.settling_time);
            out.push(match (full, settle) {
                (true, Some(t)) => check(
                    "settling after the switch ≤ 1.5 s",
                    format!("{:.3} s", t - 1.8),
                    Some(t - 1.8 <= 1.5),
                ),
                (true, None) => check(
                    "settling after the switch ≤ 1.5 s",
                    "never settles".into(),
                    Some(false),
                ),
                (false, _) => check("settling after the switch ≤ 1.5 s", short(4.0), None),
            });
            out.push(final_check(
                "d(4 s) ≤ 0.01",
                0.01,
                full,
                s.final_distance,
                &short,
            ));
        }
        "moving-target" => {
            let late = o
                .series
                .iter()
                .filter(|x| x.time >= 2.0 - 1e-9)
                .map(|x| x.distance)
                .fold(0.0, f64::max);
            out.push(if full {
                check(
                    "d ≤ 0.04 on [2, 4] s",
                    format!("max {late:.4}"),
                    Some(late <= 0.04),
                )
            } else {
                check("d ≤ 0.04 on [2, 4] s", short(4.0), None)
            });
            let d0 = o.series.first().map_or(f64::NAN, |x| x.distance);
            let max = o.series.iter().map(|x| x.distance).fold(0.0, f64::max);
            // Infeasible as stated: the arm starts at rest while the target recedes along the
            // tip-to-target line, so d'(0+) > 0 (docs/paper-experiments.md, "Experiment B").
            out.push(check(
                "d never exceeds d(0) (infeasible from rest: d'(0+) = +0.033 L0/s)",
                format!("d(0) = {d0:.4}, max {max:.4}"),
                Some(max <= d0),
            ));
            let worst = s
                .update_tip_errors
                .iter()
                .filter(|e| e.0 >= 0.5)
                .map(|e| e.1 / length)
                .fold(f64::NAN, f64::max);
            out.push(if worst.is_nan() {
                check("design tip error ≤ 0.005 L0 after 0.5 s", short(0.5), None)
            } else {
                check(
                    "design tip error ≤ 0.005 L0 after 0.5 s",
                    format!("max {worst:.2e} L0"),
                    Some(worst <= 0.005),
                )
            });
        }
        "obstacles" => {
            out.push(final_check(
                "d(4 s) ≤ 0.02",
                0.02,
                full,
                s.final_distance,
                &short,
            ));
            out.push(check(
                "penetration ≤ 1 mm (0.005 L0)",
                format!("{:.3} mm", s.max_penetration * 1e3),
                Some(s.max_penetration <= 0.005 * length),
            ));
        }
        "grasp" => {
            out.push(final_check(
                "d_D(4 s) ≤ 0.01",
                0.01,
                full,
                s.final_distance,
                &short,
            ));
            let settle = s.segments.first().and_then(|g| g.settling_time);
            out.push(match (settle, full) {
                (Some(t), _) => check("settling ≤ 2.5 s", format!("{t:.3} s"), Some(t <= 2.5)),
                (None, true) => check("settling ≤ 2.5 s", "never settles".into(), Some(false)),
                (None, false) if end > 2.5 => check(
                    "settling ≤ 2.5 s",
                    "not settled by 2.5 s".into(),
                    Some(false),
                ),
                (None, false) => check("settling ≤ 2.5 s", short(2.5), None),
            });
            out.push(check(
                "penetration ≤ 1e-3 L0 (0.2 mm)",
                format!("{:.3} mm", s.max_penetration * 1e3),
                Some(s.max_penetration <= 1e-3 * length),
            ));
        }
        _ => {}
    }
    out
}

fn final_check(
    claim: &str,
    bound: f64,
    full: bool,
    d: f64,
    short: &dyn Fn(f64) -> String,
) -> Check {
    if full {
        check(claim, format!("{d:.2e}"), Some(d <= bound))
    } else {
        check(claim, short(4.0), None)
    }
}

/// Check the output root before anything runs: new, empty, or an earlier `octoarm paper`
/// output (it has `report.md`). Creates it.
pub fn prepare_root(root: &Path) -> Result<(), OutputError> {
    if root.exists() {
        if !root.is_dir() {
            return Err(OutputError(format!(
                "--out {}: exists and is not a directory; choose another --out",
                root.display()
            )));
        }
        let mut entries = std::fs::read_dir(root).map_err(|e| {
            OutputError(format!(
                "--out {}: cannot read the directory: {e}",
                root.display()
            ))
        })?;
        if entries.next().is_some() && !root.join("report.md").is_file() {
            return Err(OutputError(format!(
                "--out {}: exists and is not an `octoarm paper` output (no report.md); refusing \
                 to write into it: choose another --out or remove it",
                root.display()
            )));
        }
    }
    std::fs::create_dir_all(root)
        .map_err(|e| OutputError(format!("--out {}: cannot create it: {e}", root.display())))
}

/// The outcome of one experiment of `octoarm paper`.
#[derive(Debug)]
pub enum PaperResult {
    /// It ran (its own failure, if any, is inside).
    Ran(Box<ControlledRun>),
    /// Its outputs could not be written.
    Error(String),
}

/// What `octoarm paper` did.
#[derive(Debug)]
pub struct PaperReport {
    /// Per experiment, in the order A–D: name and result.
    pub results: Vec<(String, PaperResult)>,
    /// Wall time of the whole command [s].
    pub wall_seconds: f64,
    /// Worker threads used.
    pub threads: usize,
}

impl PaperReport {
    /// Whether every experiment ran to the end and wrote its outputs.
    pub fn all_ok(&self) -> bool {
        self.results
            .iter()
            .all(|(_, r)| matches!(r, PaperResult::Ran(run) if run.failure.is_none()))
    }
}

/// Run the four experiments into `root` (already prepared) on `threads` workers, longest first,
/// each folder committed as it completes; then write `distance.png` and `report.md`. `progress`
/// prints one line per finished experiment on stderr; `bars` shows one bar per running
/// experiment.
pub fn run_paper(
    scenarios: &[Scenario],
    root: &Path,
    threads: usize,
    figures: bool,
    progress: bool,
    bars: &Progress,
) -> Result<PaperReport> {
    let wall = Instant::now();
    let specs: Vec<ExperimentSpec> = scenarios
        .iter()
        .map(|s| controlled::experiment_spec(s).expect("paper scenarios have a [controller]"))
        .collect();
    // Longest first (C ≈ 15 s, D ≈ 8 s, A ≈ 6.5 s, B ≈ 5 s on one core), so that two workers
    // finish together.
    let cost = |name: &str| match name {
        "obstacles" => 0,
        "grasp" => 1,
        "two-targets" => 2,
        _ => 3,
    };
    let mut order: Vec<usize> = (0..specs.len()).collect();
    order.sort_by_key(|&i| cost(&specs[i].name));
    let threads = threads.clamp(1, specs.len().max(1));
    let results: Mutex<Vec<Option<PaperResult>>> =
        Mutex::new((0..specs.len()).map(|_| None).collect());
    let next = AtomicUsize::new(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("octoarm-paper-{i}"))
        .build()
        .context("cannot start the worker threads")?;
    pool.scope(|s| {
        for _ in 0..threads {
            s.spawn(|_| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(&i) = order.get(k) else { break };
                let (scn, spec) = (&scenarios[i], &specs[i]);
                let bar = bars.bar(
                    controlled::total_steps(spec),
                    &format!("{} {:<13}", letter(&spec.name), spec.name),
                );
                let result = OutputDir::prepare(&root.join(&spec.name))
                    .map_err(anyhow::Error::from)
                    .and_then(|out| controlled::run(scn, spec, out, figures, bar));
                let result = match result {
                    Ok(run) => {
                        if progress {
                            let status = match &run.failure {
                                None => format!(
                                    "final distance {:.2e}",
                                    run.outcome
                                        .as_ref()
                                        .map_or(f64::NAN, |o| o.summary.final_distance)
                                ),
                                Some(f) => format!("FAILED: {f}"),
                            };
                            bars.suspend(|| {
                                eprintln!(
                                    "{} {}: {status}, {:.1} s wall -> {}",
                                    letter(&spec.name),
                                    spec.name,
                                    run.wall_seconds,
                                    run.out_dir.display()
                                )
                            });
                        }
                        PaperResult::Ran(Box::new(run))
                    }
                    Err(e) => {
                        let msg = format!("{}: {e:#}", spec.name);
                        bars.suspend(|| eprintln!("error: {msg}"));
                        PaperResult::Error(msg)
                    }
                };
                results.lock().expect("no worker panics holding the lock")[i] = Some(result);
            });
        }
    });
    let results: Vec<(String, PaperResult)> = results
        .into_inner()
        .expect("workers are done")
        .into_iter()
        .zip(&specs)
        .map(|(r, spec)| {
            (
                spec.name.clone(),
                r.unwrap_or_else(|| PaperResult::Error(format!("{}: did not run", spec.name))),
            )
        })
        .collect();

    let outcomes: Vec<&ExperimentOutcome> = results
        .iter()
        .filter_map(|(_, r)| match r {
            PaperResult::Ran(run) => run.outcome.as_ref(),
            PaperResult::Error(_) => None,
        })
        .collect();
    if figures {
        let points: Vec<Vec<(f64, f64)>> = outcomes
            .iter()
            .map(|o| o.series.iter().map(|s| (s.time, s.distance)).collect())
            .collect();
        let curves: Vec<DistanceCurve> = outcomes
            .iter()
            .zip(&points)
            .map(|(o, p)| DistanceCurve {
                label: format!("{} {}", letter(&o.spec.name), o.spec.name),
                colour: paper_figures::experiment_colour(&o.spec.name),
                points: p,
            })
            .collect();
        let switch = outcomes
            .iter()
            .find(|o| o.spec.name == "two-targets")
            .and_then(|o| o.spec.targets.get(1).map(|t| t.from));
        if let Err(e) = paper_figures::distance_png(&root.join("distance.png"), &curves, switch) {
            tracing::warn!("distance.png not written: {e:#}");
        }
    }
    let mut report = PaperReport {
        results,
        wall_seconds: 0.0,
        threads,
    };
    report.wall_seconds = wall.elapsed().as_secs_f64();
    let text = report_md(scenarios, &report);
    let tmp = root.join(".report.md.partial");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, root.join("report.md"))
        .with_context(|| format!("cannot write {}", root.join("report.md").display()))?;
    Ok(report)
}

/// `report.md`: one row of derived figures per experiment and the acceptance checks.
pub fn report_md(scenarios: &[Scenario], report: &PaperReport) -> String {
    let mut s = String::new();
    let duration = scenarios.first().map_or(0.0, |x| x.config.time.duration);
    let _ = writeln!(s, "# The paper's four experiments\n");
    let _ = writeln!(
        s,
        "`octoarm paper` (octoarm {}): paper arm, N = {}, dt = {:e} s, {duration} s per experiment{}; \
         {} experiments on {} worker threads, {:.1} s wall in total (figures included).\n",
        env!("CARGO_PKG_VERSION"),
        scenarios.first().map_or(0, |x| x.config.rod.n_elements),
        scenarios.first().map_or(0.0, |x| x.config.time.dt),
        if (duration - 4.0).abs() > 1e-9 {
            " (**shortened** with --duration; the paper's runs last 4 s, checks about later times are undecided)"
        } else {
            ""
        },
        report.results.len(),
        report.threads,
        report.wall_seconds
    );
    let _ = writeln!(
        s,
        "Distance d = |tip − target| / L0 (A–C) or the μ_grasp-weighted mean gap to the object's \
         surface / L0 (D). Settling time: first time after which d ≤ 0.02 for the rest of the \
         segment (A: two segments, the second measured from the switch at 1.8 s). Overshoot: \
         max(0, progress along the start-to-target line − 1). Control effort: ∫ Σ|F^u|²/ω dt \
         (force, N²·s/m) and ∫ Σ|C^u|²/ℓ̂ dt (couple, N²·m·s). Sweeps: forward–backward sweeps \
         of all solves.\n"
    );
    let _ = writeln!(
        s,
        "| experiment | final distance / L0 | settling time [s] | overshoot | force effort [N²·s/m] | couple effort [N²·m·s] | max penetration [mm] | sweeps | wall time [s] | acceptance |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|---|");
    for (name, r) in &report.results {
        let label = format!("{} {name}", letter(name));
        match r {
            PaperResult::Ran(run) => match &run.outcome {
                Some(o) => {
                    let sm = &o.summary;
                    let settling: Vec<String> = sm
                        .segments
                        .iter()
                        .map(|g| match g.settling_time {
                            Some(t) if g.start > 0.0 => {
                                format!("{:.2} ({:.2} after {})", t, t - g.start, g.start)
                            }
                            Some(t) => format!("{t:.2}"),
                            None => "not settled".into(),
                        })
                        .collect();
                    let overshoot: Vec<String> = if o.spec.grasp.is_some() {
                        vec!["—".into()]
                    } else {
                        sm.segments
                            .iter()
                            .map(|g| format!("{:.3}", g.overshoot))
                            .collect()
                    };
                    let decided: Vec<bool> = run.checks.iter().filter_map(|c| c.pass).collect();
                    let passed = decided.iter().filter(|p| **p).count();
                    let verdict = if run.checks.is_empty() {
                        "—".into()
                    } else if passed == decided.len() {
                        format!("pass ({passed}/{})", run.checks.len())
                    } else {
                        format!(
                            "**{} failed** ({passed}/{} pass)",
                            decided.len() - passed,
                            run.checks.len()
                        )
                    };
                    let _ = writeln!(
                        s,
                        "| {label} | {:.2e} | {} | {} | {:.3e} | {:.3e} | {:.3} | {} | {:.1} | {verdict} |",
                        sm.final_distance,
                        settling.join("; "),
                        overshoot.join("; "),
                        sm.force_effort,
                        sm.couple_effort,
                        sm.max_penetration * 1e3,
                        sm.sweeps,
                        run.wall_seconds,
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        "| {label} | failed: {} | — | — | — | — | — | — | {:.1} | fail |",
                        run.failure.clone().unwrap_or_default().replace('|', "/"),
                        run.wall_seconds
                    );
                }
            },
            PaperResult::Error(e) => {
                let _ = writeln!(
                    s,
                    "| {label} | error: {} | — | — | — | — | — | — | — | fail |",
                    e.replace('|', "/")
                );
            }
        }
    }
    let _ = writeln!(s, "\n## Acceptance (control spec §5)\n");
    let _ = writeln!(s, "| experiment | claim | measured | result |");
    let _ = writeln!(s, "|---|---|---|---|");
    for (name, r) in &report.results {
        if let PaperResult::Ran(run) = r {
            for c in &run.checks {
                let verdict = match c.pass {
                    Some(true) => "pass",
                    Some(false) => "**fail**",
                    None => "undecided",
                };
                let _ = writeln!(
                    s,
                    "| {} {name} | {} | {} | {verdict} |",
                    letter(name),
                    c.claim,
                    c.measured
                );
            }
        }
    }
    let _ = writeln!(
        s,
        "\nFolders: `two-targets/`, `moving-target/`, `obstacles/`, `grasp/` (trajectory.npz, \
         series.npz, distance.csv, shapes.png, shapes.gif, summary.json, scenario.toml); \
         `distance.png` beside this file. Each folder's `scenario.toml` re-runs it with \
         `octoarm run`."
    );
    s
}

/// The default number of workers: the machine's cores, at most one per experiment.
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(SCENARIOS.len())
}
