//! The `octoarm` command line: parses arguments, sets up logging and maps failures to exit
//! codes (2: bad input, nothing written; 1: the run failed, what was recorded is kept). All the
//! work is in the library (`octoarm::runner`, `octoarm::scenario`).

use anyhow::Result;
use clap::{ArgAction, Parser, Subcommand};
use octoarm::figures::CliFigures;
use octoarm::output::{OutputDir, OutputError};
use octoarm::paper;
use octoarm::pipeline::{self, RunOptions};
use octoarm::progress::Progress;
use octoarm::scenario::{Scenario, ScenarioError};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

/// The compiled-in experiment suites of `octoarm paper`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum Suite {
    /// The CDC-2020 paper's four experiments.
    Paper,
    /// The muscular arm's experiments (muscles-3d spec §7).
    Muscles,
}

/// Simulate a soft octopus arm (a discrete 3D Cosserat rod) described by a TOML scenario.
///
/// A scenario has the sections [rod] (or [[rod]] for several rods), [time], and optionally
/// [damping], [numerics], [contact], [[load]], [[obstacle]], [[joint]] and [initial_state]; a
/// controlled run adds [controller], [solver], [[target]], [via_path] or [grasp], and
/// [[acceptance]]. See the files in scenarios/ and the README.
#[derive(Debug, Parser)]
#[command(name = "octoarm", version, propagate_version = true)]
#[command(
    after_help = "Exit codes: 0 success; 1 the run failed (e.g. became unstable; the frames \
recorded so far are written); 2 invalid scenario or arguments (nothing is written); 3 (paper) \
every experiment ran but an acceptance check failed (report.md lists it)."
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
    /// Print only errors (no progress bar, no warnings).
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    quiet: bool,
    /// Print what is being done (-v) or more (-vv) on stderr.
    #[arg(short, long, global = true, action = ArgAction::Count)]
    verbose: u8,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Run a scenario and write trajectory.npz, summary.json, scenario.toml, shapes.png and
    /// energy.png (a controlled run adds series.npz, distance.csv and shapes.gif) into the
    /// output directory.
    ///
    /// The directory is written under a temporary name and moved into place at the end, so an
    /// earlier output is replaced whole or not at all. If the rod becomes unstable, the frames
    /// recorded until then are written, summary.json records the failure, and the exit code is 1.
    Run {
        /// The scenario file (TOML).
        scenario: PathBuf,
        /// Output directory [default: results/<scenario file name without .toml>].
        #[arg(short, long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Override [time] duration, in simulated seconds (recorded in the output's scenario.toml).
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        duration: Option<f64>,
        /// Refuse a run whose outputs would exceed this size before compression (bytes, or with
        /// a unit: 500MB, 2GB, 1.5TB; "unlimited" for no limit) [default: 2GB].
        #[arg(long, value_name = "SIZE", value_parser = parse_size, allow_negative_numbers = true)]
        max_output: Option<MaxOutput>,
        /// Watch the run in the browser: serve the viewer on 127.0.0.1, print its URL, wait
        /// (at most 30 s) for the page to connect, then stream frames to it while the run goes.
        /// After the run the page stays served until Ctrl-C.
        #[arg(long)]
        view: bool,
        /// The viewer's port (with --view); 0 picks a free one [default: 0].
        #[arg(long, value_name = "N", requires = "view")]
        port: Option<u16>,
        /// Do not open a browser (with --view); open the printed URL yourself.
        #[arg(long, requires = "view")]
        no_open: bool,
    },
    /// Show recorded runs in the browser: serve a local page (127.0.0.1 only) that replays a
    /// run folder, a sweep folder (pick a run) or a results folder such as `octoarm paper`'s
    /// (pick an experiment): the rods in 3D with their radii, obstacles, targets and desired
    /// shape, a time slider and the run's series. Prints the URL; Ctrl-C stops the server.
    View {
        /// A run folder (with trajectory.npz), a sweep folder (with runs/) or a folder of runs.
        path: PathBuf,
        /// Port to listen on; 0 picks a free one [default: 0].
        #[arg(long, value_name = "N")]
        port: Option<u16>,
        /// Do not open a browser; open the printed URL yourself.
        #[arg(long)]
        no_open: bool,
    },
    /// Run the paper's four experiments (scenarios/paper/*.toml, compiled in) in parallel and
    /// write, into OUT, one folder per experiment (two-targets/, moving-target/, obstacles/,
    /// grasp/: trajectory.npz, series.npz, distance.csv, shapes.png, shapes.gif, energy.png,
    /// summary.json, scenario.toml) as each completes, then distance.png and report.md with
    /// the acceptance checks each scenario file declares.
    ///
    /// If an experiment fails, the others' outputs are still written and the exit code is 1;
    /// if all ran but an acceptance check failed, the exit code is 3.
    Paper {
        /// Output directory.
        #[arg(short, long, value_name = "DIR", default_value = "results")]
        out: PathBuf,
        /// Shorten (or lengthen) every experiment to this many simulated seconds (the paper's
        /// runs last 4 s; acceptance checks about later times are reported as undecided).
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        duration: Option<f64>,
        /// Worker threads, 1 to 256 [default: the number of cores, at most the number of
        /// experiments].
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=256))]
        threads: Option<u64>,
        /// Run the scenarios of this folder instead of the paper's (every *.toml, by name).
        #[arg(long, value_name = "DIR")]
        scenarios: Option<PathBuf>,
        /// Which compiled-in experiments: "paper" (the CDC-2020 paper's four, scenarios/paper/)
        /// or "muscles" (the muscular arm of muscles-3d spec §7, scenarios/muscles/: reach,
        /// rolled reach, grasp, planar case; 15 s each, designs solved first).
        #[arg(long, value_enum, default_value_t = Suite::Paper)]
        suite: Suite,
        /// Refuse if any experiment's outputs would exceed this size before compression (as
        /// for `run`) [default: 2GB].
        #[arg(long, value_name = "SIZE", value_parser = parse_size, allow_negative_numbers = true)]
        max_output: Option<MaxOutput>,
    },
    /// Run a parameter sweep: the base scenario named in SWEEP (a TOML file of [[parameter]]
    /// tables: scenario key paths with lists, linear/log ranges or seeded random samples,
    /// crossed or zipped) run once per combination, each into OUT/runs/<id>/ (id: a content
    /// hash of the resolved scenario), with OUT/results.csv and results.npz (one row per run:
    /// parameters, scalar results, status, error), OUT/sweep.json (the resolved plan) and
    /// OUT/figures/.
    ///
    /// Runs on this machine's cores, or with --ray on a Ray cluster (through the Python
    /// package). A run that fails is recorded and the others go on (exit code 1 at the end);
    /// --resume continues an interrupted sweep, skipping its complete runs.
    Sweep {
        /// The sweep file (TOML).
        sweep: PathBuf,
        /// Output directory [default: results/<sweep file name without .toml>].
        #[arg(short, long, value_name = "DIR")]
        out: Option<PathBuf>,
        /// Continue the sweep in OUT: runs whose folder is complete (same scenario hash) are
        /// kept and skipped; the others run.
        #[arg(long)]
        resume: bool,
        /// Worker threads of the local executor, 1 to 256 [default: the number of cores].
        #[arg(long, value_name = "N", value_parser = clap::value_parser!(u64).range(1..=256), conflicts_with = "ray")]
        threads: Option<u64>,
        /// Run each scenario as a Ray task: "auto" (the running cluster, as `ray start` left
        /// it or RAY_ADDRESS), "local" (a new Ray instance on this machine, for this sweep), or
        /// a cluster address (HOST:PORT). Needs Python with the octoarm package and ray.
        #[arg(long, value_name = "auto|local|ADDRESS")]
        ray: Option<String>,
        /// The Python interpreter of the Ray executor.
        #[arg(long, value_name = "PATH", default_value = "python3")]
        python: String,
        /// Override [time] duration of every run, in simulated seconds.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        duration: Option<f64>,
        /// Refuse a sweep whose outputs in total would exceed this size before compression (as
        /// for `run`) [default: 2GB].
        #[arg(long, value_name = "SIZE", value_parser = parse_size, allow_negative_numbers = true)]
        max_output: Option<MaxOutput>,
        /// Print the plan (runs, ids, parameter values, invalid combinations) and write nothing.
        #[arg(long)]
        plan: bool,
    },
    /// Validate a scenario without running it; print the rod's stable time step, the number of
    /// steps and frames, and any warnings.
    Check {
        /// The scenario file (TOML).
        scenario: PathBuf,
        /// Override [time] duration, in simulated seconds.
        #[arg(long, value_name = "SECONDS", allow_negative_numbers = true)]
        duration: Option<f64>,
    },
}

/// The `--max-output` limit: bytes, or none.
#[derive(Debug, Clone, Copy)]
struct MaxOutput(Option<u64>);

impl MaxOutput {
    /// The limit in bytes (`u64::MAX` for "unlimited"); the default is 2 GB.
    fn bytes(limit: Option<MaxOutput>) -> u64 {
        limit.map_or(octoarm::estimate::OUTPUT_WARN_BYTES, |m| {
            m.0.unwrap_or(u64::MAX)
        })
    }
}

/// A size: a number of bytes (`1e9`, `2000000000`), optionally followed by a unit (kB, MB, GB,
/// TB, powers of 1000; KiB, MiB, GiB, TiB, powers of 1024), or `unlimited`.
fn parse_size(text: &str) -> Result<MaxOutput, String> {
    let t = text.trim();
    if t.eq_ignore_ascii_case("unlimited") {
        return Ok(MaxOutput(None));
    }
    let split = t
        .find(|c: char| c.is_ascii_alphabetic() && c != 'e' && c != 'E')
        .unwrap_or(t.len());
    let (number, unit) = t.split_at(split);
    let scale: f64 = match unit.trim().to_ascii_lowercase().as_str() {
        "" | "b" => 1.0,
        "k" | "kb" => 1e3,
        "m" | "mb" => 1e6,
        "g" | "gb" => 1e9,
        "t" | "tb" => 1e12,
        "kib" => 1024.0,
        "mib" => 1024.0 * 1024.0,
        "gib" => 1024.0 * 1024.0 * 1024.0,
        "tib" => 1024.0 * 1024.0 * 1024.0 * 1024.0,
        other => {
            return Err(format!(
                "unknown unit {other:?}; use bytes or kB, MB, GB, TB, KiB, MiB, GiB, TiB, or \
                 \"unlimited\""
            ))
        }
    };
    let value: f64 = number
        .trim()
        .parse()
        .map_err(|_| format!("{text:?} is not a size (e.g. 500MB, 2GB, 1e9 or \"unlimited\")"))?;
    let bytes = value * scale;
    if !(bytes.is_finite() && bytes >= 1.0 && bytes < u64::MAX as f64) {
        return Err(format!(
            "{text:?} is outside the allowed range [1 B, 18 EB] (or \"unlimited\")"
        ));
    }
    Ok(MaxOutput(Some(bytes as u64)))
}

/// A bad path or port for the viewer (exit code 2).
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct ViewerInput(String);

/// Start the viewer's server on 127.0.0.1:`port`, print its URL on stdout and open a browser
/// unless `no_open` (or there is none).
fn start_viewer(
    source: octoarm_viewer::server::Source,
    port: Option<u16>,
    no_open: bool,
) -> Result<octoarm_viewer::server::Server> {
    use std::io::Write;
    let server = octoarm_viewer::server::Server::start(source, port.unwrap_or(0))
        .map_err(|e| ViewerInput(format!("{e:#}")))?;
    let url = server.url();
    println!("octoarm viewer: {url}");
    let _ = std::io::stdout().flush();
    if !no_open && !octoarm_viewer::server::open_browser(&url) {
        tracing::warn!("no browser to open (no display): open {url} yourself");
    }
    Ok(server)
}

/// Block until SIGINT / SIGTERM sets `stop`.
fn wait_for_signal(stop: &std::sync::atomic::AtomicUsize) {
    while stop.load(std::sync::atomic::Ordering::Relaxed) == 0 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
}

/// A run that stopped early; its outputs are written.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct RunFailed {
    message: String,
}

/// Every experiment of `paper` ran and wrote its outputs, but an acceptance check failed
/// (exit code 3).
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct ChecksFailed {
    message: String,
}

/// A run stopped by SIGINT / SIGTERM; its outputs are written (exit 128 + signal).
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct Interrupted {
    message: String,
    signal: i32,
}

/// Stop flags for SIGINT and SIGTERM: the first signal sets `STOP` to its number (the run then
/// records its state and writes its outputs); a second one ends the process at once.
fn install_signal_handlers() -> std::sync::Arc<std::sync::atomic::AtomicUsize> {
    use signal_hook::consts::{SIGINT, SIGTERM};
    use std::sync::atomic::{AtomicBool, AtomicUsize};
    use std::sync::Arc;
    let stop = Arc::new(AtomicUsize::new(0));
    let seen = Arc::new(AtomicBool::new(false));
    for sig in [SIGINT, SIGTERM] {
        // Order matters: the shutdown is armed by the flag the first signal sets.
        let _ = signal_hook::flag::register_conditional_shutdown(sig, 128 + sig, Arc::clone(&seen));
        let _ = signal_hook::flag::register(sig, Arc::clone(&seen));
        let _ = signal_hook::flag::register_usize(sig, Arc::clone(&stop), sig as usize);
    }
    stop
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(&cli);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if let Some(i) = e.downcast_ref::<Interrupted>() {
                ExitCode::from((128 + i.signal) as u8)
            } else if e.downcast_ref::<ChecksFailed>().is_some() {
                ExitCode::from(3)
            } else if e.downcast_ref::<ScenarioError>().is_some()
                || e.downcast_ref::<OutputError>().is_some()
                || e.downcast_ref::<octoarm::sweep::ray::RayUnavailable>()
                    .is_some()
                || e.downcast_ref::<ViewerInput>().is_some()
                || e.downcast_ref::<clap::Error>().is_some()
            {
                ExitCode::from(2)
            } else {
                ExitCode::from(1)
            }
        }
    }
}

fn init_logging(cli: &Cli) {
    let level = match (cli.quiet, cli.verbose) {
        (true, _) => "error",
        (false, 0) => "warn",
        (false, 1) => "info",
        (false, _) => "debug",
    };
    let filter = tracing_subscriber::EnvFilter::try_from_env("OCTOARM_LOG").unwrap_or_else(|_| {
        tracing_subscriber::EnvFilter::new(format!("octoarm={level},octoarm_physics={level}"))
    });
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .without_time()
        .with_target(false)
        .with_ansi(std::io::stderr().is_terminal())
        .init();
}

/// Progress bars go to stderr, only if it is a terminal, and not with `--quiet`.
fn show_progress(quiet: bool) -> bool {
    !quiet && std::io::stderr().is_terminal()
}

fn load(path: &std::path::Path, duration: Option<f64>) -> Result<Scenario> {
    let mut scn = Scenario::load(path)?;
    if let Some(d) = duration {
        octoarm::override_duration(&mut scn, d)?;
    }
    Ok(scn)
}

fn run(cli: Cli) -> Result<()> {
    let quiet = cli.quiet;
    match cli.command {
        Command::Check { scenario, duration } => {
            let scn = load(&scenario, duration)?;
            print!("{}", octoarm::check_report(&scn)?);
            Ok(())
        }
        Command::Paper {
            out,
            duration,
            threads,
            scenarios,
            suite,
            max_output,
        } => {
            let scenarios = match (suite, scenarios.as_deref()) {
                (Suite::Muscles, None) => paper::muscle_scenarios(duration)?,
                (_, dir) => paper::paper_scenarios(duration, dir)?,
            };
            for scn in &scenarios {
                octoarm::build::build_system(scn)?;
                octoarm::estimate::check_output_size(scn, MaxOutput::bytes(max_output))?;
            }
            let _lock = paper::prepare_root(&out)?;
            let threads = threads.map_or_else(paper::default_threads, |t| t as usize);
            let bars = Progress::new(show_progress(cli.quiet));
            let stop = install_signal_handlers();
            let report = paper::run_paper(
                &scenarios,
                &out,
                threads,
                true,
                !cli.quiet,
                &bars,
                Some(&stop),
            )?;
            let signal = stop.load(std::sync::atomic::Ordering::Relaxed);
            if signal != 0 {
                return Err(Interrupted {
                    message: format!(
                        "interrupted (signal {signal}): the experiments stopped where they were and \
                         wrote what they recorded; report.md in {} says which ran",
                        out.display()
                    ),
                    signal: signal as i32,
                }
                .into());
            }
            if !report.all_ok() {
                return Err(RunFailed {
                    message: format!(
                        "not every experiment completed; the others' outputs and report.md are in {}",
                        out.display()
                    ),
                }
                .into());
            }
            if !cli.quiet {
                println!(
                    "wrote {} ({} experiments, distance.png, report.md) in {:.1} s",
                    out.display(),
                    report.results.len(),
                    report.wall_seconds
                );
            }
            let failed = report.failed_checks();
            if !failed.is_empty() {
                return Err(ChecksFailed {
                    message: format!(
                        "{} acceptance check(s) failed (all outputs and report.md are in {}):\n  {}",
                        failed.len(),
                        out.display(),
                        failed.join("\n  ")
                    ),
                }
                .into());
            }
            Ok(())
        }
        Command::Sweep {
            sweep,
            out,
            resume,
            threads,
            ray,
            python,
            duration,
            max_output,
            plan,
        } => run_sweep(
            quiet,
            SweepArgs {
                sweep,
                out,
                resume,
                threads,
                ray,
                python,
                duration,
                max_output,
                plan,
            },
        ),
        Command::View {
            path,
            port,
            no_open,
        } => {
            let catalog =
                octoarm_viewer::runs::discover(&path).map_err(|e| ViewerInput(format!("{e:#}")))?;
            let stop = install_signal_handlers();
            let server = start_viewer(
                octoarm_viewer::server::Source::Folder(std::sync::Arc::new(catalog)),
                port,
                no_open,
            )?;
            if !cli.quiet {
                eprintln!("serving until Ctrl-C");
            }
            wait_for_signal(&stop);
            drop(server);
            Ok(())
        }
        Command::Run {
            scenario,
            out,
            duration,
            max_output,
            view,
            port,
            no_open,
        } => {
            let scn = load(&scenario, duration)?;
            octoarm::estimate::check_output_size(&scn, MaxOutput::bytes(max_output))?;
            // Everything about the input is checked (offline designs solved), and the output
            // directory created, before the first step.
            let prepared = pipeline::prepare(&scn)?;
            for warning in octoarm::advisories(&scn, &prepared.system, &prepared.state) {
                tracing::warn!("{warning}");
            }
            let target = out.unwrap_or_else(|| octoarm::default_out_dir(&scn));
            let stop = install_signal_handlers();
            // The live viewer: served and connected before the output folder is made, so an
            // interrupted wait leaves nothing behind.
            let live = if view {
                let mut scene = octoarm_viewer::scene::scene_of(Some(&scn.resolved_toml()));
                scene["name"] = serde_json::json!(scn.name);
                let hub = octoarm_viewer::live::LiveHub::new(scene);
                let server = start_viewer(
                    octoarm_viewer::server::Source::Live(std::sync::Arc::clone(&hub)),
                    port,
                    no_open,
                )?;
                if !cli.quiet {
                    eprintln!("waiting for the page to connect (at most 30 s) ...");
                }
                let connected = hub.wait_for_client(std::time::Duration::from_secs(30), || {
                    stop.load(std::sync::atomic::Ordering::Relaxed) != 0
                });
                let signal = stop.load(std::sync::atomic::Ordering::Relaxed);
                if signal != 0 {
                    return Err(Interrupted {
                        message: format!(
                            "interrupted (signal {signal}) before the run started; nothing written"
                        ),
                        signal: signal as i32,
                    }
                    .into());
                }
                if !connected {
                    tracing::warn!("no page connected within 30 s: running anyway");
                }
                Some((hub, server))
            } else {
                None
            };
            let out = OutputDir::prepare(&target)?;
            let bar =
                Progress::new(show_progress(cli.quiet)).bar(pipeline::planned_steps(&scn), "");
            let update = |k: u64, t: f64| bar.update(k, t);
            let opts = RunOptions {
                progress: Some(&update),
                figures: Some(&CliFigures),
                stop: Some(&stop),
            };
            let report = if let Some((hub, _)) = &live {
                let controlled = scn
                    .config
                    .controller
                    .as_ref()
                    .and_then(|c| c.rod.as_deref())
                    .and_then(|name| prepared.system.rod_index(name));
                let mut recorder = octoarm::live::LiveRecorder::new(
                    std::sync::Arc::clone(hub),
                    &prepared.system,
                    scn.config.save_every(),
                    pipeline::planned_steps(&scn),
                    controlled,
                );
                hub.set_status(octoarm_viewer::live::LiveStatus::Running);
                let report = pipeline::run_with(&scn, prepared, out, &opts, &mut [&mut recorder])?;
                let (status, message) = match &report.failure {
                    None => ("completed", None),
                    Some(f @ pipeline::Failure::Unstable(_)) => ("unstable", Some(f.to_string())),
                    Some(f @ pipeline::Failure::Control(_)) => ("failed", Some(f.to_string())),
                    Some(f @ pipeline::Failure::Interrupted(_)) => {
                        ("interrupted", Some(f.to_string()))
                    }
                };
                hub.set_status(octoarm_viewer::live::LiveStatus::Finished {
                    status: status.into(),
                    message,
                    out_dir: report.out_dir.display().to_string(),
                });
                report
            } else {
                pipeline::run(&scn, prepared, out, &opts)?
            };
            bar.finish();
            // With --view the page stays served after the run (not after an interrupt).
            if let Some((_, server)) = &live {
                if !matches!(report.failure, Some(pipeline::Failure::Interrupted(_))) {
                    if !cli.quiet {
                        eprintln!(
                            "run finished ({}); the viewer at {} stays open until Ctrl-C",
                            report.out_dir.display(),
                            server.url()
                        );
                    }
                    wait_for_signal(&stop);
                }
            }
            if let Some(pipeline::Failure::Interrupted(signal)) = &report.failure {
                return Err(Interrupted {
                    message: format!(
                        "interrupted (signal {signal}) at t = {:.6} s: wrote the {} frames recorded \
                         until then to {} (status \"interrupted\" in summary.json)",
                        report.data.trajectory.time.last().copied().unwrap_or(0.0),
                        report.frames,
                        report.out_dir.display()
                    ),
                    signal: *signal,
                }
                .into());
            }
            if let Some(failure) = &report.failure {
                return Err(RunFailed {
                    message: format!(
                        "{failure}\n  wrote the {} frames recorded before the failure to {} (see summary.json)",
                        report.frames,
                        report.out_dir.display()
                    ),
                }
                .into());
            }
            if !cli.quiet {
                let distance = report
                    .data
                    .series
                    .as_ref()
                    .and_then(|s| s.summary.as_ref())
                    .map(|s| format!(", final distance {:.2e} L0", s.final_distance))
                    .unwrap_or_default();
                println!(
                    "wrote {} ({} frames, {} steps{distance}, {:.1} s wall, {:.2} µs per step)",
                    report.out_dir.display(),
                    report.frames,
                    report.steps,
                    report.wall_seconds,
                    report.loop_seconds * 1e6 / report.steps.max(1) as f64
                );
            }
            Ok(())
        }
    }
}

/// The arguments of `octoarm sweep`.
struct SweepArgs {
    sweep: PathBuf,
    out: Option<PathBuf>,
    resume: bool,
    threads: Option<u64>,
    ray: Option<String>,
    python: String,
    duration: Option<f64>,
    max_output: Option<MaxOutput>,
    plan: bool,
}

/// `octoarm sweep`: plan (every input error found before anything is written), connect the
/// executor, prepare the folder, run, write the table, sweep.json and figures.
fn run_sweep(quiet: bool, a: SweepArgs) -> Result<()> {
    use octoarm::sweep::{self, Event, RunCheck, SweepDir, SweepPlan};
    let wall = std::time::Instant::now();
    let plan = SweepPlan::load(&a.sweep, a.duration)?;
    // The outputs of all runs together against --max-output.
    let limit = MaxOutput::bytes(a.max_output);
    let mut total: u64 = 0;
    let mut largest = 0u64;
    for r in plan.runs.iter().filter(|r| r.check == RunCheck::Valid) {
        let scn = plan.scenario(r.index)?;
        let bytes = octoarm::estimate::estimate_output_bytes(&scn);
        total = total.saturating_add(bytes);
        largest = largest.max(bytes);
    }
    if total > limit {
        return Err(ScenarioError {
            file: a.sweep.clone(),
            line: None,
            message: format!(
                "the sweep's runs would write about {} in all (the largest run {}), above the \
                 limit of {} (--max-output): lower time.save_interval or --duration, sweep fewer \
                 runs, or allow it with --max-output <bytes>",
                octoarm::scenario::fmt_bytes(total as f64),
                octoarm::scenario::fmt_bytes(largest as f64),
                octoarm::scenario::fmt_bytes(limit as f64),
            ),
        }
        .into());
    }
    let invalid: Vec<_> = plan
        .runs
        .iter()
        .filter_map(|r| match &r.check {
            RunCheck::Invalid(m) => Some((r.index, m)),
            RunCheck::Valid => None,
        })
        .collect();
    if a.plan {
        println!(
            "{}: {} runs of {} ({} invalid), outputs about {}",
            a.sweep.display(),
            plan.runs.len(),
            plan.base.path.display(),
            invalid.len(),
            octoarm::scenario::fmt_bytes(total as f64)
        );
        for p in &plan.parameters {
            println!(
                "  {} ({}): {} values, group {}",
                p.path,
                p.how,
                p.values.len(),
                p.group
            );
        }
        for r in &plan.runs {
            let why = match &r.check {
                RunCheck::Valid => String::new(),
                RunCheck::Invalid(m) => format!("  INVALID: {m}"),
            };
            println!(
                "  run {} {}: {}{why}",
                r.index,
                r.id,
                plan.describe_choice(&r.choice)
            );
        }
        return Ok(());
    }
    for (i, m) in &invalid {
        tracing::warn!("run {i} is not a valid scenario (recorded as invalid): {m}");
    }
    // Ray is connected before the folder is touched: without it, nothing is written.
    let mut executor = match &a.ray {
        Some(address) => Some(sweep::ray::RayExecutor::start(&a.python, address)?),
        None => None,
    };
    let target = a.out.unwrap_or_else(|| {
        PathBuf::from("results").join(
            a.sweep
                .file_stem()
                .map_or_else(|| "sweep".into(), |s| s.to_string_lossy().into_owned()),
        )
    });
    let (dir, pending) = SweepDir::prepare(&target, &plan, a.resume)?;
    let skipped = plan.runs.len() - invalid.len() - pending.len();
    if skipped > 0 && !quiet {
        eprintln!(
            "--resume: {skipped} complete runs kept; running the other {}",
            pending.len()
        );
    }
    let bars = Progress::new(show_progress(quiet));
    let bar = bars.sweep_bar(pending.len() as u64);
    let on_event = |ev: Event<'_>| match ev {
        Event::Started(_) => bar.started(),
        Event::Finished(row) => {
            bar.finished(row.completed());
            if !row.completed() && row.status != "interrupted" && !quiet {
                bar.suspend(|| {
                    eprintln!(
                        "run {} ({}) {}: {}",
                        row.index, row.id, row.status, row.error
                    )
                });
            }
        }
    };
    let stop = install_signal_handlers();
    let executor_json = match &mut executor {
        Some(ex) => {
            let info = serde_json::json!({"kind": "ray", "address": ex.address, "cpus": ex.cpus});
            ex.run(&plan, &dir, &pending, Some(&stop), Some(&on_event))?;
            info
        }
        None => {
            let threads = a.threads.map_or_else(
                || std::thread::available_parallelism().map_or(1, |n| n.get()),
                |t| t as usize,
            );
            let opts = sweep::LocalOptions {
                threads,
                stop: Some(&stop),
                events: Some(&on_event),
            };
            sweep::run_local(&plan, &dir, &pending, &opts)?;
            serde_json::json!({"kind": "local", "threads": threads})
        }
    };
    drop(executor);
    bar.finish();
    let (rows, counts) = dir.finish(&plan, executor_json, wall.elapsed().as_secs_f64())?;
    let figures = octoarm::sweep_figures::draw(dir.root(), &plan, &rows);
    if !figures.is_empty() {
        dir.add_entries(&figures)?;
    }
    let signal = stop.load(std::sync::atomic::Ordering::Relaxed);
    let summary = format!(
        "{} runs: {} completed, {} failed, {} interrupted, {} not run",
        counts.total, counts.completed, counts.failed, counts.interrupted, counts.not_run
    );
    if signal != 0 {
        return Err(Interrupted {
            message: format!(
                "interrupted (signal {signal}): {summary}; results.csv in {} lists the runs that \
                 ended; continue with --resume",
                target.display()
            ),
            signal: signal as i32,
        }
        .into());
    }
    if counts.failed > 0 {
        return Err(RunFailed {
            message: format!(
                "{summary}; results.csv in {} has each failed run's error",
                target.display()
            ),
        }
        .into());
    }
    if !quiet {
        println!(
            "wrote {} ({summary}) in {:.1} s",
            target.display(),
            wall.elapsed().as_secs_f64()
        );
    }
    Ok(())
}
