//! `octoarm paper`: the paper's four experiments, defined only by the scenario files in
//! `scenarios/paper/` (compiled in; `--scenarios DIR` runs another folder), run in parallel
//! through the one run pipeline, each into its own folder as it completes, then `distance.png`
//! and `report.md` with the derived figures and the acceptance checks each file declares.

use crate::acceptance::Check;
use crate::outdir::{check_replaceable, new_run_id, parent_and_name, Lock, Marker, OutputError};
use crate::output::OutputDir;
use crate::paper_figures::{self, DistanceCurve};
use crate::pipeline::{self, RunOptions, RunReport};
use crate::progress::Progress;
use crate::scenario::{MuscleTaskKind, Scenario, ScenarioError, TipFrameKind};
use anyhow::{Context, Result};
use std::fmt::Write as _;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;
use std::time::Instant;

/// The paper's scenarios compiled in: (file name, text), in the order A–D.
pub const SCENARIOS: [(&str, &str); 4] = [
    (
        "two-targets.toml",
        include_str!("../../../scenarios/paper/two-targets.toml"),
    ),
    (
        "moving-target.toml",
        include_str!("../../../scenarios/paper/moving-target.toml"),
    ),
    (
        "obstacles.toml",
        include_str!("../../../scenarios/paper/obstacles.toml"),
    ),
    (
        "grasp.toml",
        include_str!("../../../scenarios/paper/grasp.toml"),
    ),
];

/// The muscular arm's experiments of muscles-3d spec §7 compiled in (`octoarm paper --suite
/// muscles`): (file name, text), in the order A (reach), B (rolled reach), C (grasp), and the
/// planar case.
pub const MUSCLE_SCENARIOS: [(&str, &str); 4] = [
    (
        "reach.toml",
        include_str!("../../../scenarios/muscles/reach.toml"),
    ),
    (
        "reach-rolled.toml",
        include_str!("../../../scenarios/muscles/reach-rolled.toml"),
    ),
    (
        "grasp.toml",
        include_str!("../../../scenarios/muscles/grasp.toml"),
    ),
    (
        "planar.toml",
        include_str!("../../../scenarios/muscles/planar.toml"),
    ),
];

/// The compiled-in muscle experiments (named `scenarios/muscles/<file>`), with the duration
/// replaced if given.
pub fn muscle_scenarios(duration: Option<f64>) -> Result<Vec<Scenario>, ScenarioError> {
    let mut out = Vec::new();
    for (file, text) in MUSCLE_SCENARIOS {
        let mut scn = Scenario::from_str(&Path::new("scenarios/muscles").join(file), text)?;
        if let Some(d) = duration {
            crate::override_duration(&mut scn, d)?;
        }
        out.push(scn);
    }
    Ok(out)
}

/// The scenarios of `dir` (every `*.toml`, sorted by name), or the compiled-in paper scenarios
/// (named `scenarios/paper/<file>`), with the duration replaced if given.
pub fn paper_scenarios(
    duration: Option<f64>,
    dir: Option<&Path>,
) -> Result<Vec<Scenario>, ScenarioError> {
    let mut out = Vec::new();
    match dir {
        None => {
            for (file, text) in SCENARIOS {
                out.push(Scenario::from_str(
                    &Path::new("scenarios/paper").join(file),
                    text,
                )?);
            }
        }
        Some(dir) => {
            let entries = std::fs::read_dir(dir).map_err(|e| ScenarioError {
                file: dir.to_path_buf(),
                line: None,
                message: format!("--scenarios: cannot read the folder: {e}"),
            })?;
            let mut files: Vec<_> = entries
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|p| p.extension().is_some_and(|x| x == "toml"))
                .collect();
            files.sort();
            if files.is_empty() {
                return Err(ScenarioError {
                    file: dir.to_path_buf(),
                    line: None,
                    message: "--scenarios: the folder holds no .toml scenario".into(),
                });
            }
            for f in files {
                out.push(Scenario::load(&f)?);
            }
        }
    }
    if let Some(d) = duration {
        for scn in &mut out {
            crate::override_duration(scn, d)?;
        }
    }
    Ok(out)
}

/// Letter of the i-th experiment (A, B, …).
pub fn letter(i: usize) -> char {
    (b'A' + (i % 26) as u8) as char
}

/// Check the output root before anything runs — new, empty, or an earlier `octoarm paper`
/// output holding nothing octoarm did not write (its `.octoarm` marker lists every entry) —,
/// create it and lock it against a second `octoarm paper`. Keep the lock until the report is
/// written.
pub fn prepare_root(root: &Path) -> Result<Lock, OutputError> {
    let what = "--out";
    let (parent, name) = parent_and_name(root, what)?;
    let lock = Lock::take(&parent, &name, what, root)?;
    if root.exists() {
        check_replaceable(root, what)?;
        if let Some(m) = Marker::read(root) {
            if m.kind != "paper" {
                return Err(OutputError(format!(
                    "{what} {}: is the output of one `octoarm run`, not of `octoarm paper`; choose \
                     another --out",
                    root.display()
                )));
            }
        }
    }
    std::fs::create_dir_all(root)
        .map_err(|e| OutputError(format!("--out {}: cannot create it: {e}", root.display())))?;
    Ok(lock)
}

/// The outcome of one experiment of `octoarm paper`.
pub enum PaperResult {
    /// It ran (its own failure, if any, is inside).
    Ran(Box<RunReport>),
    /// It could not be prepared or its outputs could not be written.
    Error(String),
}

/// What `octoarm paper` did.
pub struct PaperReport {
    /// Per experiment, in the order given: name and result.
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
    /// The acceptance checks that failed, as "experiment: claim (measured)" (undecided checks,
    /// e.g. claims about times after a shortened run's end, and claims the scenario marks
    /// `infeasible` are not counted).
    pub fn failed_checks(&self) -> Vec<String> {
        let mut out = Vec::new();
        for (name, r) in &self.results {
            if let PaperResult::Ran(run) = r {
                let muscle = run.data.muscle.as_ref().map_or(&[][..], |m| &m.checks[..]);
                for c in checks(run).iter().chain(muscle) {
                    if c.pass == Some(false) && !c.infeasible {
                        out.push(format!("{name}: {} ({})", c.claim, c.measured));
                    }
                }
            }
        }
        out
    }
}

fn checks(run: &RunReport) -> &[Check] {
    run.data.series.as_ref().map_or(&[], |s| &s.checks)
}

/// A run's acceptance verdict for the summary table: "pass (k/n)", "**f failed** (k/n pass)"
/// (undecided checks count in n only), or "—" without checks.
fn verdict(checks: &[Check]) -> String {
    let decided: Vec<bool> = checks.iter().filter_map(|c| c.pass).collect();
    let passed = decided.iter().filter(|p| **p).count();
    if checks.is_empty() {
        "—".into()
    } else if passed == decided.len() {
        format!("pass ({passed}/{})", checks.len())
    } else {
        format!(
            "**{} failed** ({passed}/{} pass)",
            decided.len() - passed,
            checks.len()
        )
    }
}

/// One row of an acceptance table: experiment label, claim (with the scenario's note),
/// measured value, verdict.
fn check_row(s: &mut String, label: &str, c: &Check) {
    let verdict = match c.pass {
        Some(true) => "pass",
        Some(false) if c.infeasible => "**fail** (infeasible as stated)",
        Some(false) => "**fail**",
        None => "undecided",
    };
    let note = c
        .note
        .as_ref()
        .map(|n| format!(" ({n})"))
        .unwrap_or_default();
    let _ = writeln!(
        s,
        "| {label} | {}{note} | {} | {verdict} |",
        c.claim, c.measured
    );
}

/// Run the experiments into `root` (already prepared) on `threads` workers, each folder
/// committed as it completes; then write `distance.png` and `report.md` and the root's marker.
/// `progress` prints one line per finished experiment on stderr; `bars` shows one bar per
/// running experiment. When `stop` is set (a signal), running experiments stop and write what
/// they recorded (status "interrupted"), no new one starts, and the report says which folders
/// hold this invocation's runs.
pub fn run_paper(
    scenarios: &[Scenario],
    root: &Path,
    threads: usize,
    figures: bool,
    progress: bool,
    bars: &Progress,
    stop: Option<&std::sync::atomic::AtomicUsize>,
) -> Result<PaperReport> {
    let run_id = new_run_id();
    let wall = Instant::now();
    let threads = threads.clamp(1, scenarios.len().max(1));
    // Longest first, so that the workers finish together: a rough cost from the scenario — steps
    // × elements, more for online design updates and for obstacles in them (the paper's C, an
    // online solve against two spheres, takes as long as the other three together).
    let cost = |scn: &Scenario| {
        let c = &scn.config;
        let online = c
            .solver
            .as_ref()
            .is_some_and(|s| s.mode == crate::scenario::SolverModeKind::Online);
        let factor = 1.0 + f64::from(u8::from(online)) * (1.0 + c.obstacles.len() as f64);
        c.n_steps() as f64 * c.total_elements() as f64 * factor
    };
    let mut order: Vec<usize> = (0..scenarios.len()).collect();
    order.sort_by(|&a, &b| cost(&scenarios[b]).total_cmp(&cost(&scenarios[a])));
    let results: Mutex<Vec<Option<PaperResult>>> =
        Mutex::new((0..scenarios.len()).map(|_| None).collect());
    let next = AtomicUsize::new(0);
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .thread_name(|i| format!("octoarm-paper-{i}"))
        .build()
        .context("cannot start the worker threads")?;
    let cli_figures = crate::figures::CliFigures;
    pool.scope(|s| {
        for _ in 0..threads {
            s.spawn(|_| loop {
                let k = next.fetch_add(1, Ordering::SeqCst);
                let Some(&i) = order.get(k) else { break };
                let scn = &scenarios[i];
                if stop.is_some_and(|s| s.load(Ordering::Relaxed) != 0) {
                    results.lock().expect("no worker panics holding the lock")[i] = Some(
                        PaperResult::Error(format!("{}: not run (interrupted)", scn.name)),
                    );
                    continue;
                }
                let name = &scn.name;
                let bar = bars.bar(
                    pipeline::planned_steps(scn),
                    &format!("{} {:<13}", letter(i), name),
                );
                let update = |k: u64, t: f64| bar.update(k, t);
                let opts = RunOptions {
                    progress: Some(&update),
                    figures: figures.then_some(&cli_figures as &dyn pipeline::Figures),
                    stop,
                };
                let result = pipeline::prepare(scn)
                    .map_err(anyhow::Error::from)
                    .and_then(|prepared| {
                        let out = OutputDir::prepare(&root.join(name))?;
                        pipeline::run(scn, prepared, out, &opts)
                    });
                bar.finish();
                let result = match result {
                    Ok(run) => {
                        if progress {
                            let status = match (&run.failure, &run.data.muscle) {
                                (None, Some(m)) => match m.summary {
                                    Some(s) if s.grasp.is_some() => format!(
                                        "final wrap angle {:.0}°",
                                        s.grasp.map_or(f64::NAN, |g| g.wrap_angle)
                                    ),
                                    s => format!(
                                        "final tip error {:.2e} L0",
                                        s.map_or(f64::NAN, |s| s.final_tip_error)
                                    ),
                                },
                                (None, None) => format!(
                                    "final distance {:.2e}",
                                    run.data
                                        .series
                                        .as_ref()
                                        .and_then(|s| s.summary.as_ref())
                                        .map_or(f64::NAN, |s| s.final_distance)
                                ),
                                (Some(f), _) => format!("FAILED: {f}"),
                            };
                            bars.suspend(|| {
                                eprintln!(
                                    "{} {name}: {status}, {:.1} s wall -> {}",
                                    letter(i),
                                    run.wall_seconds,
                                    run.out_dir.display()
                                )
                            });
                        }
                        PaperResult::Ran(Box::new(run))
                    }
                    Err(e) => {
                        let msg = format!("{name}: {e:#}");
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
        .zip(scenarios)
        .map(|(r, scn)| {
            (
                scn.name.clone(),
                r.unwrap_or_else(|| PaperResult::Error(format!("{}: did not run", scn.name))),
            )
        })
        .collect();

    let muscles =
        !scenarios.is_empty() && scenarios.iter().all(|s| s.config.muscle_control.is_some());
    if figures && !muscles {
        let points: Vec<(usize, Vec<(f64, f64)>)> = results
            .iter()
            .enumerate()
            .filter_map(|(i, (_, r))| match r {
                PaperResult::Ran(run) => run
                    .data
                    .series
                    .as_ref()
                    .map(|s| (i, s.samples.iter().map(|x| (x.time, x.distance)).collect())),
                PaperResult::Error(_) => None,
            })
            .collect();
        let curves: Vec<DistanceCurve> = points
            .iter()
            .map(|(i, p)| DistanceCurve {
                label: format!("{} {}", letter(*i), results[*i].0),
                colour: paper_figures::experiment_colour(*i),
                points: p,
            })
            .collect();
        // The first target switch of any experiment (the paper's A), marked on the figure.
        let switch = scenarios.iter().enumerate().find_map(|(i, scn)| {
            scn.config
                .targets
                .iter()
                .skip(1)
                .map(|t| (letter(i).to_string(), t.from))
                .next()
        });
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
    let text = if muscles {
        muscles_report_md(scenarios, &report)
    } else {
        report_md(scenarios, &report)
    };
    let tmp = root.join(".report.md.partial");
    std::fs::write(&tmp, text).with_context(|| format!("cannot write {}", tmp.display()))?;
    std::fs::rename(&tmp, root.join("report.md"))
        .with_context(|| format!("cannot write {}", root.join("report.md").display()))?;
    // The root's marker: everything octoarm wrote here (earlier experiment folders included).
    let mut entries: Vec<String> = Vec::new();
    for f in ["report.md", "distance.png"] {
        if root.join(f).is_file() {
            entries.push(f.into());
        }
    }
    let previous = Marker::read(root).map(|m| m.entries).unwrap_or_default();
    for scn in scenarios {
        let dir = format!("{}/", scn.name);
        if root.join(&scn.name).is_dir() && !entries.contains(&dir) {
            entries.push(dir);
        }
    }
    for e in previous {
        if e.ends_with('/') && root.join(e.trim_end_matches('/')).is_dir() && !entries.contains(&e)
        {
            entries.push(e);
        }
    }
    Marker {
        kind: "paper".into(),
        run: run_id,
        entries,
    }
    .write(root)?;
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
        scenarios
            .first()
            .map_or(0, |x| x.config.rods.list[0].n_elements),
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
    let interrupted = report.results.iter().any(|(_, r)| match r {
        PaperResult::Ran(run) => matches!(run.failure, Some(pipeline::Failure::Interrupted(_))),
        PaperResult::Error(e) => e.ends_with("(interrupted)"),
    });
    if interrupted {
        let _ = writeln!(
            s,
            "**Interrupted** (SIGINT/SIGTERM): experiments that were running stopped where they were and \
             wrote what they recorded (status \"interrupted\"); those marked \"not run\" were not \
             started, and a folder of theirs left here holds an earlier run (its summary.json says when).\n"
        );
    }
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
    for (i, (name, r)) in report.results.iter().enumerate() {
        let label = format!("{} {name}", letter(i));
        match r {
            PaperResult::Ran(run) => match run
                .data
                .series
                .as_ref()
                .and_then(|s| s.summary.as_ref())
                .filter(|_| run.failure.is_none())
            {
                Some(sm) => {
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
                    let overshoot: Vec<String> = if scenarios[i].config.grasp.is_some() {
                        vec!["—".into()]
                    } else {
                        sm.segments
                            .iter()
                            .map(|g| format!("{:.3}", g.overshoot))
                            .collect()
                    };
                    let verdict = verdict(checks(run));
                    let _ = writeln!(
                        s,
                        "| {label} | {:.2e} | {} | {} | {:.3e} | {:.3e} | {:.3} | {} | {:.1} | {verdict} |",
                        sm.final_distance,
                        settling.join("; "),
                        overshoot.join("; "),
                        sm.force_effort,
                        sm.couple_effort,
                        sm.max_penetration * 1e3,
                        sm.report.sweeps,
                        run.wall_seconds,
                    );
                }
                None => {
                    let _ = writeln!(
                        s,
                        "| {label} | failed: {} | — | — | — | — | — | — | {:.1} | fail |",
                        run.failure
                            .as_ref()
                            .map(|f| f.to_string())
                            .unwrap_or_default()
                            .replace('|', "/"),
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
    for (i, (name, r)) in report.results.iter().enumerate() {
        if let PaperResult::Ran(run) = r {
            for c in checks(run) {
                check_row(&mut s, &format!("{} {name}", letter(i)), c);
            }
        }
    }
    let _ = writeln!(
        s,
        "\nFolders: one per experiment, named after its scenario file (trajectory.npz, \
         series.npz, distance.csv, shapes.png, shapes.gif, energy.png, summary.json, \
         scenario.toml); `distance.png` beside this file. Each folder's `scenario.toml` re-runs \
         it with `octoarm run`; the claims checked are the scenario files' [[acceptance]] tables."
    );
    s
}

/// `report.md` of the muscle experiments (muscles-3d spec §7): per experiment the design
/// (outcome, iterations, time, J, errors) and the dynamics (final errors, times to 5 % and 1 %
/// of L0, deviation from the design pose, 𝓗), then every acceptance check.
pub fn muscles_report_md(scenarios: &[Scenario], report: &PaperReport) -> String {
    let mut s = String::new();
    let first = scenarios.first().map(|x| &x.config);
    let _ = writeln!(s, "# The muscular arm's experiments (muscles-3d spec §7)\n");
    let _ = writeln!(
        s,
        "`octoarm paper --suite muscles` (octoarm {}): COOMM's arm, N = {}, dt = {:e} s, {} s per run; \
         {} experiments on {} worker threads, {:.1} s wall in total (designs and figures included).\n",
        env!("CARGO_PKG_VERSION"),
        first.map_or(0, |c| c.rods.list[0].n_elements),
        first.map_or(0.0, |c| c.time.dt),
        first.map_or(0.0, |c| c.time.duration),
        report.results.len(),
        report.threads,
        report.wall_seconds
    );
    let _ = writeln!(
        s,
        "Errors are normalised by L0 (tip point: the last element's midpoint; θ_Q = |Log(Q Q*ᵀ)|). \
         Design: projected L-BFGS over a ∈ [0, 1] from a = 0 (grasp: the continuation of spec §5.6). \
         Dynamics: the design's activations with a 1 s ramp at 500 Hz, drag and `coomm` damping. \
         𝓗 = kinetic + elastic + the fibres' stored energy; its largest rise is between 10 ms samples after the ramp.\n"
    );
    let _ = writeln!(
        s,
        "| experiment | design (outcome, iterations, evaluations) | design time [s] | J | design tip error / L0 | design θ_Q [rad] | final tip error / L0 | final θ_Q [rad] | t(0.05 L0) [s] | t(0.01 L0) [s] | max node deviation / L0 | largest 𝓗 rise [J] | wall [s] | acceptance |"
    );
    let _ = writeln!(
        s,
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    let opt = |t: Option<f64>| t.map_or("—".to_string(), |t| format!("{t:.2}"));
    let mut twists: Vec<(String, f64)> = Vec::new();
    for (i, (name, r)) in report.results.iter().enumerate() {
        let label = format!("{} {name}", letter(i));
        match r {
            PaperResult::Ran(run) => {
                let Some(m) = &run.data.muscle else {
                    let _ = writeln!(s, "| {label} | not a muscle run | | | | | | | | | | | | |");
                    continue;
                };
                let d = m.design();
                twists.push((name.clone(), d.twist));
                let c = &d.report.costs;
                let sm = m.summary.unwrap_or_default();
                let mut verdict = verdict(&m.checks);
                if let Some(f) = &run.failure {
                    verdict = format!("**run failed**: {}", f.to_string().replace('|', "/"));
                }
                // A grasp has no tip target, a point reach no target frame: "—" there.
                let (point, frame) = match &scenarios[i].config.muscle_control {
                    Some(mc) if mc.task == MuscleTaskKind::Reach => {
                        (true, mc.frame != TipFrameKind::None)
                    }
                    _ => (false, false),
                };
                let e2 = |applies: bool, v: f64| {
                    if applies {
                        format!("{v:.2e}")
                    } else {
                        "—".to_string()
                    }
                };
                let _ = writeln!(
                    s,
                    "| {label} | {:?}, {}, {} | {:.2} | {:.4} | {} | {} | {} | {} | {} | {} | {:.2e} | {} | {:.1} | {verdict} |",
                    d.report.outcome,
                    d.report.iterations,
                    d.report.evaluations,
                    d.report.seconds,
                    c.total,
                    e2(point, c.tip_error / d.length),
                    e2(frame, c.orientation_error),
                    e2(point, sm.final_tip_error),
                    e2(frame, sm.final_orientation_error),
                    opt(sm.time_to_5_percent),
                    opt(sm.time_to_1_percent),
                    sm.node_deviation,
                    // No sample after the ramp (a run shorter than it): nothing to report.
                    e2(sm.hamiltonian_ramp.is_finite(), sm.hamiltonian_rise),
                    run.wall_seconds,
                );
            }
            PaperResult::Error(e) => {
                let _ = writeln!(
                    s,
                    "| {label} | error: {} | | | | | | | | | | | | fail |",
                    e.replace('|', "/")
                );
            }
        }
    }
    let _ = writeln!(s, "\n## Acceptance (muscles-3d spec §7)\n");
    let _ = writeln!(s, "| experiment | claim | measured | result |");
    let _ = writeln!(s, "|---|---|---|---|");
    for (i, (name, r)) in report.results.iter().enumerate() {
        if let PaperResult::Ran(run) = r {
            if let Some(m) = &run.data.muscle {
                for c in &m.checks {
                    check_row(&mut s, &format!("{} {name}", letter(i)), c);
                }
            }
            if run.failure.is_some() {
                let _ = writeln!(
                    s,
                    "| {} {name} | no guard trip, run complete | {} | **fail** |",
                    letter(i),
                    run.failure
                        .as_ref()
                        .map(|f| f.to_string().replace('|', "/"))
                        .unwrap_or_default()
                );
            } else {
                let _ = writeln!(
                    s,
                    "| {} {name} | no guard trip, run complete | completed | pass |",
                    letter(i)
                );
            }
        }
    }
    // Spec §7 B: the rolled reach's twist differs from the reach's by at least 1 rad.
    let find = |n: &str| twists.iter().find(|(x, _)| x == n).map(|(_, t)| *t);
    if let (Some(a), Some(b)) = (find("reach"), find("reach-rolled")) {
        let d = (b - a).abs();
        let _ = writeln!(
            s,
            "| B reach-rolled | total twist differs from A's by ≥ 1 rad | {b:.3} vs {a:.3} rad (difference {d:.3}) | {} |",
            if d >= 1.0 { "pass" } else { "**fail**" }
        );
    }
    let _ = writeln!(
        s,
        "\nFolders: one per experiment, named after its scenario file: design.json (the design report), \
         activations.npy [7, N] (groups TM, LM0–LM3, OM+, OM−), design_pose.npz, trajectory.npz, series.npz \
         (time, tip, tip_error, orientation_error, hamiltonian every 10 ms; grasp: penetration, wrap_angle, mean_gap), \
         design.png (the design pose in three projections and a perspective view, coloured by activation), \
         shapes.png, energy.png, summary.json, scenario.toml (re-run with `octoarm run`)."
    );
    s
}

/// The default number of workers: the machine's cores, at most one per experiment.
pub fn default_threads() -> usize {
    std::thread::available_parallelism()
        .map_or(1, |n| n.get())
        .min(SCENARIOS.len())
}
