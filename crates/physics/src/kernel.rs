//! Runtime choice of the stepper's machine code. The library is built for baseline x86-64 (no
//! compile-time `target-cpu`), so one binary runs on any x86-64 CPU; the hot part of the step
//! (drift, internal loads, kick) is compiled twice from the same source — once for the baseline
//! and once with AVX2/FMA enabled — and `step` calls the variant chosen here. Rust never fuses
//! `a * b + c` into an FMA by itself and the step calls no `mul_add`, so both variants perform
//! the same IEEE operations in the same order: their results are bit-identical (tested by
//! `crates/physics/tests/kernel_dispatch.rs`; CI also runs the tests with the baseline forced).
//!
//! The choice is made once per process: the best kernel the CPU supports, unless the environment
//! variable `OCTOARM_KERNEL` says `baseline` (or `avx2`, which falls back to the baseline on a
//! CPU without AVX2/FMA). A `Workspace` starts with that choice; `Workspace::set_kernel` changes
//! it for one simulation.

use std::sync::OnceLock;

/// Environment variable that forces a kernel: `baseline`, `avx2` or `auto` (the default).
pub const KERNEL_ENV: &str = "OCTOARM_KERNEL";

/// A compiled variant of the hot part of the step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Kernel {
    /// Baseline x86-64 (SSE2) code, or the target's default code on other architectures.
    Baseline,
    /// Code compiled with AVX2 and FMA enabled (x86-64 only; no fused multiply–adds are used,
    /// so results equal the baseline's).
    Avx2,
}

impl Kernel {
    /// Every kernel, baseline first.
    pub const ALL: [Kernel; 2] = [Kernel::Baseline, Kernel::Avx2];

    /// The kernel's name as `OCTOARM_KERNEL` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Kernel::Baseline => "baseline",
            Kernel::Avx2 => "avx2",
        }
    }

    /// Whether this CPU can run the kernel.
    pub fn is_available(self) -> bool {
        match self {
            Kernel::Baseline => true,
            Kernel::Avx2 => avx2_available(),
        }
    }

    /// Set `current` to this kernel when the CPU can run it; returns whether `current` is now
    /// this kernel (the rule of `Workspace::set_kernel` and `RodBatch::set_kernel`).
    pub(crate) fn switch(self, current: &mut Kernel) -> bool {
        if self.is_available() {
            *current = self;
        }
        *current == self
    }

    /// The best kernel this CPU supports, ignoring `OCTOARM_KERNEL`.
    pub fn best() -> Kernel {
        if Kernel::Avx2.is_available() {
            Kernel::Avx2
        } else {
            Kernel::Baseline
        }
    }

    /// The process-wide choice: `OCTOARM_KERNEL` if set to an available kernel, else the best
    /// one. An unknown value or an unavailable kernel falls back to the best available one
    /// (with one warning on stderr). Detected once, then cached.
    pub fn selected() -> Kernel {
        static SELECTED: OnceLock<Kernel> = OnceLock::new();
        *SELECTED.get_or_init(|| {
            let requested = std::env::var(KERNEL_ENV).ok();
            let (kernel, warning) = Self::resolve(requested.as_deref());
            if let Some(w) = warning {
                eprintln!("octoarm: {w}");
            }
            kernel
        })
    }

    /// The kernel a value of `OCTOARM_KERNEL` selects, and a warning when the value cannot be
    /// honoured.
    pub fn resolve(requested: Option<&str>) -> (Kernel, Option<String>) {
        let best = Self::best();
        let Some(value) = requested.map(str::trim).filter(|v| !v.is_empty()) else {
            return (best, None);
        };
        if value.eq_ignore_ascii_case("auto") {
            return (best, None);
        }
        match Self::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(value))
        {
            Some(k) if k.is_available() => (k, None),
            Some(k) => (
                best,
                Some(format!(
                    "{KERNEL_ENV}={value}: this CPU cannot run the {} kernel; using {}",
                    k.name(),
                    best.name()
                )),
            ),
            None => (
                best,
                Some(format!(
                    "{KERNEL_ENV}={value:?} is not a kernel (allowed: auto, baseline, avx2); \
                     using {}",
                    best.name()
                )),
            ),
        }
    }
}

impl Default for Kernel {
    fn default() -> Self {
        Kernel::selected()
    }
}

#[cfg(target_arch = "x86_64")]
fn avx2_available() -> bool {
    std::arch::is_x86_feature_detected!("avx2") && std::arch::is_x86_feature_detected!("fma")
}

#[cfg(not(target_arch = "x86_64"))]
fn avx2_available() -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn environment_values_resolve() {
        assert_eq!(Kernel::resolve(None), (Kernel::best(), None));
        assert_eq!(Kernel::resolve(Some("")), (Kernel::best(), None));
        assert_eq!(Kernel::resolve(Some("auto")), (Kernel::best(), None));
        assert_eq!(Kernel::resolve(Some("Baseline")), (Kernel::Baseline, None));
        let (k, w) = Kernel::resolve(Some("sse9"));
        assert_eq!(k, Kernel::best());
        assert!(w.unwrap().contains("allowed: auto, baseline, avx2"));
        let (k, w) = Kernel::resolve(Some("avx2"));
        if Kernel::Avx2.is_available() {
            assert_eq!((k, w), (Kernel::Avx2, None));
        } else {
            assert_eq!(k, Kernel::Baseline);
            assert!(w.unwrap().contains("cannot run"));
        }
    }
}
