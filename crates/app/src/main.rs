//! The `octoarm` command line: parses arguments, sets up logging and maps failures to exit
//! codes (2: bad input, nothing written; 1: the run failed, what was recorded is kept). All the
//! work is in the library (`octoarm::runner`, `octoarm::scenario`).

use anyhow::Result;
use clap::{ArgAction, Parser, Subcommand};
use octoarm::output::{OutputDir, OutputError};
use octoarm::progress::Progress;
use octoarm::runner::{self, RunOptions};
use octoarm::scenario::{Scenario, ScenarioError};
use octoarm::{controlled, paper};
use std::io::IsTerminal;
use std::path::PathBuf;
use std::process::ExitCode;

/// Simulate a soft octopus arm (a discrete 3D Cosserat rod) described by a TOML scenario.
///
/// A scenario has the sections [rod], [time], and optionally [damping], [numerics], [contact],
/// [[load]] and [[obstacle]]; a controlled run adds [controller], [solver], [[target]],
/// [via_path] or [grasp]. See the files in scenarios/ and the README.
#[derive(Debug, Parser)]
#[command(name = "octoarm", version, propagate_version = true)]
#[command(
    after_help = "Exit codes: 0 success; 1 the run failed (e.g. became unstable; the frames \
recorded so far are written); 2 invalid scenario or arguments (nothing is written)."
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
    /// energy.png into the output directory.
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
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
    /// Run the paper's four experiments (scenarios/paper/*.toml, compiled in) in parallel and
    /// write, into OUT, one folder per experiment (two-targets/, moving-target/, obstacles/,
    /// grasp/: trajectory.npz, series.npz, distance.csv, shapes.png, shapes.gif, summary.json,
    /// scenario.toml) as each completes, then distance.png and report.md.
    ///
    /// If an experiment fails, the others' outputs are still written and the exit code is 1.
    Paper {
        /// Output directory.
        #[arg(short, long, value_name = "DIR", default_value = "results")]
        out: PathBuf,
        /// Shorten (or lengthen) every experiment to this many simulated seconds (the paper's
        /// runs last 4 s; acceptance checks about later times are reported as undecided).
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
        /// Worker threads [default: the number of cores, at most 4].
        #[arg(long, value_name = "N")]
        threads: Option<usize>,
    },
    /// Validate a scenario without running it; print the rod's stable time step, the number of
    /// steps and frames, and any warnings.
    Check {
        /// The scenario file (TOML).
        scenario: PathBuf,
        /// Override [time] duration, in simulated seconds.
        #[arg(long, value_name = "SECONDS")]
        duration: Option<f64>,
    },
}

/// A run that stopped early; its outputs are written.
#[derive(Debug, thiserror::Error)]
#[error("{message}")]
struct RunFailed {
    message: String,
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    init_logging(&cli);
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            if e.downcast_ref::<ScenarioError>().is_some()
                || e.downcast_ref::<OutputError>().is_some()
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
        } => {
            let scenarios = paper::paper_scenarios(duration)?;
            for scn in &scenarios {
                runner::build_simulation(scn)?;
            }
            paper::prepare_root(&out)?;
            let threads = threads.unwrap_or_else(paper::default_threads);
            let bars = Progress::new(show_progress(cli.quiet));
            let report = paper::run_paper(&scenarios, &out, threads, true, !cli.quiet, &bars)?;
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
                    "wrote {} (4 experiments, distance.png, report.md) in {:.1} s",
                    out.display(),
                    report.wall_seconds
                );
            }
            Ok(())
        }
        Command::Run {
            scenario,
            out,
            duration,
        } => {
            let scn = load(&scenario, duration)?;
            // Everything about the input is checked, and the output directory created, before
            // the first step.
            runner::build_simulation(&scn)?;
            let target = out.unwrap_or_else(|| octoarm::default_out_dir(&scn));
            let out = OutputDir::prepare(&target)?;
            if let Some(spec) = controlled::experiment_spec(&scn) {
                let bar =
                    Progress::new(show_progress(cli.quiet)).bar(controlled::total_steps(&spec), "");
                let run = controlled::run(&scn, &spec, out, true, bar)?;
                if let Some(failure) = run.failure {
                    return Err(RunFailed {
                        message: format!(
                            "{failure}\n  wrote the {} frames recorded before the failure to {} (see summary.json)",
                            run.frames,
                            run.out_dir.display()
                        ),
                    }
                    .into());
                }
                if !cli.quiet {
                    let o = run
                        .outcome
                        .as_ref()
                        .expect("a completed run has an outcome");
                    println!(
                        "wrote {} ({} frames, final distance {:.2e} L0, {:.1} s wall)",
                        run.out_dir.display(),
                        run.frames,
                        o.summary.final_distance,
                        run.wall_seconds
                    );
                }
                return Ok(());
            }
            let opts = RunOptions {
                progress: show_progress(cli.quiet),
                no_figures: false,
            };
            let report = runner::run(&scn, out, opts)?;
            if let Some(failure) = report.failure {
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
                println!(
                    "wrote {} ({} frames, {} steps, {:.1} s wall, {:.2} µs per step)",
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
