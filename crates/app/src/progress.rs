//! Progress bars on stderr for `octoarm run` (passive and controlled), `octoarm paper` and
//! `octoarm sweep`: one set of bars that stays hidden until the command has run for a second, so
//! that short runs print nothing. Whether to show them at all (stderr a terminal, no `--quiet`) is the caller's choice;
//! what is being run is not this module's business.

use indicatif::{MultiProgress, ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// How long a command runs before its bars appear.
const DELAY: Duration = Duration::from_secs(1);

/// The progress bars of one command (cheap to clone; the clones share the bars). Disabled, it
/// hands out bars that draw nothing.
#[derive(Debug, Clone)]
pub struct Progress {
    /// The bars, drawn to a hidden target until `DELAY` has passed; None when disabled.
    multi: Option<MultiProgress>,
    start: Instant,
    shown: Arc<AtomicBool>,
}

impl Progress {
    /// Bars that appear on stderr once the command has run for a second (if `enabled`), or
    /// none at all.
    pub fn new(enabled: bool) -> Self {
        Self {
            multi: enabled.then(|| MultiProgress::with_draw_target(ProgressDrawTarget::hidden())),
            start: Instant::now(),
            shown: Arc::new(AtomicBool::new(false)),
        }
    }

    /// A bar for a run of `steps` steps, labelled `label` (none if empty), below the others.
    pub fn bar(&self, steps: u64, label: &str) -> RunBar {
        let bar = self.multi.as_ref().map(|multi| {
            let template = if label.is_empty() {
                "{elapsed_precise} [{wide_bar}] {percent:>3}%  t = {msg} s  eta {eta}"
            } else {
                "{prefix} {elapsed_precise} [{wide_bar}] {percent:>3}%  t = {msg} s  eta {eta}"
            };
            let bar = ProgressBar::new(steps)
                .with_style(
                    ProgressStyle::with_template(template)
                        .expect("a valid template")
                        .progress_chars("=> "),
                )
                .with_prefix(label.to_string());
            multi.add(bar)
        });
        RunBar {
            bar,
            progress: self.clone(),
        }
    }

    /// Run `f` (which prints to stderr) with the bars cleared, then redraw them.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        match &self.multi {
            Some(multi) => multi.suspend(f),
            None => f(),
        }
    }

    /// Whether the bars are visible; makes them so once `DELAY` has passed.
    fn reveal(&self) -> bool {
        if self.shown.load(Ordering::Relaxed) {
            return true;
        }
        if self.start.elapsed() <= DELAY {
            return false;
        }
        if let Some(multi) = &self.multi {
            if !self.shown.swap(true, Ordering::Relaxed) {
                multi.set_draw_target(ProgressDrawTarget::stderr_with_hz(5));
            }
        }
        true
    }
}

/// One run's bar in a `Progress`.
#[derive(Debug)]
pub struct RunBar {
    bar: Option<ProgressBar>,
    progress: Progress,
}

impl RunBar {
    /// The run has taken `step` steps and reached simulated time `time` [s].
    pub fn update(&self, step: u64, time: f64) {
        if let Some(bar) = &self.bar {
            if self.progress.reveal() {
                bar.set_message(format!("{time:.3}"));
                bar.set_position(step);
            }
        }
    }

    /// Remove the bar (the run's stepping is over); also done when it is dropped.
    pub fn finish(&self) {
        if let (Some(bar), Some(multi)) = (&self.bar, &self.progress.multi) {
            bar.finish_and_clear();
            multi.remove(bar);
        }
    }
}

impl Drop for RunBar {
    // A run that ends early (an error before its first step) must not leave a stale bar behind.
    fn drop(&mut self) {
        self.finish();
    }
}

/// The bar of a sweep: runs ended out of the total, with done / failed / running / remaining
/// counts and an ETA.
#[derive(Debug)]
pub struct SweepBar {
    bar: Option<ProgressBar>,
    progress: Progress,
    counts: std::sync::Mutex<[u64; 3]>,
    total: u64,
}

impl Progress {
    /// A bar for a sweep of `total` runs to execute.
    pub fn sweep_bar(&self, total: u64) -> SweepBar {
        let bar = self.multi.as_ref().map(|multi| {
            let bar = ProgressBar::new(total).with_style(
                ProgressStyle::with_template(
                    "{elapsed_precise} [{wide_bar}] {pos}/{len} runs  {msg}  eta {eta}",
                )
                .expect("a valid template")
                .progress_chars("=> "),
            );
            multi.add(bar)
        });
        SweepBar {
            bar,
            progress: self.clone(),
            counts: std::sync::Mutex::new([0; 3]),
            total,
        }
    }
}

impl SweepBar {
    fn update(&self, f: impl FnOnce(&mut [u64; 3])) {
        let mut c = self.counts.lock().unwrap_or_else(|p| p.into_inner());
        f(&mut c);
        let [done, failed, running] = *c;
        if let Some(bar) = &self.bar {
            if self.progress.reveal() {
                let remaining = self.total.saturating_sub(done + failed + running);
                bar.set_message(format!(
                    "done {done}, failed {failed}, running {running}, remaining {remaining}"
                ));
                bar.set_position(done + failed);
            }
        }
    }

    /// A run started.
    pub fn started(&self) {
        self.update(|c| c[2] += 1);
    }

    /// A run ended, completed (`ok`) or not.
    pub fn finished(&self, ok: bool) {
        self.update(|c| {
            c[usize::from(!ok)] += 1;
            c[2] = c[2].saturating_sub(1);
        });
    }

    /// Run `f` (which prints to stderr) with the bars cleared.
    pub fn suspend<R>(&self, f: impl FnOnce() -> R) -> R {
        self.progress.suspend(f)
    }

    /// Remove the bar.
    pub fn finish(&self) {
        if let (Some(bar), Some(multi)) = (&self.bar, &self.progress.multi) {
            bar.finish_and_clear();
            multi.remove(bar);
        }
    }
}
