//! Scenario files: loading, resolving defaults that depend on other keys, validation, and error
//! messages that name the file, line, column, key and allowed range (unknown keys get the
//! nearest valid name). It builds nothing and runs nothing: see `build.rs` and `pipeline.rs`.
//! To add a section: a `…Config` struct in `config.rs`, a field in `ScenarioConfig`, its checks
//! in `validate.rs`, its use in `build.rs`.

pub mod config;
pub mod toml_errors;
pub mod validate;

pub use config::*;
pub use toml_errors::{key_span, line_col, nearest};
pub use validate::{
    fmt_bytes, fmt_num, fmt_sci, fmt_vec, MAX_CLAIMS, MAX_ELEMENTS, MAX_ITEMS, MAX_LBFGS_BYTES,
    MAX_OFFLINE_WORK, MAX_RODS, MAX_SAMPLES, MAX_STEPS, MAX_TOTAL_ELEMENTS, MAX_UPDATE_WORK,
};

use std::fmt;
use std::ops::Range;
use std::path::{Path, PathBuf};

/// Largest scenario file read, 16 MiB (a scenario is a few kB; the cap keeps `/dev/zero` or a
/// wrong file from being read into memory).
pub const MAX_SCENARIO_BYTES: u64 = 16 << 20;

/// A scenario that failed to load: unreadable, not TOML, unknown or missing keys, wrong types,
/// or values outside their range. Display gives `file:line:col: …`.
#[derive(Debug, Clone, PartialEq)]
pub struct ScenarioError {
    /// The scenario file.
    pub file: PathBuf,
    /// 1-based line and column of the offending key, when known.
    pub line: Option<(usize, usize)>,
    /// The message after the location.
    pub message: String,
}

impl fmt::Display for ScenarioError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.line {
            Some((line, col)) => {
                write!(f, "{}:{line}:{col}: {}", self.file.display(), self.message)
            }
            None => write!(f, "{}: {}", self.file.display(), self.message),
        }
    }
}

impl std::error::Error for ScenarioError {}

/// One value outside its range, found by `ScenarioConfig::validate`.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    /// Dotted key path as written in the file, e.g. `rod.tip_diameter` or `load[1].value`
    /// (index 0-based among the `[[load]]` tables).
    pub key: String,
    /// The value, formatted as in TOML (empty for a rule about the key as a whole).
    pub value: String,
    /// The allowed range or rule, in words.
    pub range: String,
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.value.is_empty() {
            return write!(f, "{}: {}", self.key, self.range);
        }
        write!(
            f,
            "{} = {} is outside the allowed range {}",
            self.key, self.value, self.range
        )
    }
}

/// A scenario as loaded: the file it came from, its text and the resolved configuration.
#[derive(Debug, Clone)]
pub struct Scenario {
    /// Path of the scenario file.
    pub path: PathBuf,
    /// Name used for the default output folder: the file stem.
    pub name: String,
    /// The resolved configuration (defaults filled in, validated).
    pub config: ScenarioConfig,
    /// What to change in a valid scenario that uses deprecated keys (shown as warnings).
    pub notes: Vec<String>,
    source: String,
}

impl Scenario {
    /// Read, parse, resolve and validate a scenario file. Every failure is a `ScenarioError`
    /// naming the file and, where possible, the line and key.
    pub fn load(path: &Path) -> Result<Self, ScenarioError> {
        use std::io::Read;
        let fail = |message: String| ScenarioError {
            file: path.to_path_buf(),
            line: None,
            message,
        };
        // Read at most one byte past the limit: `/dev/zero` or a huge file is refused, not
        // read into memory.
        let mut bytes = Vec::new();
        std::fs::File::open(path)
            .and_then(|f| f.take(MAX_SCENARIO_BYTES + 1).read_to_end(&mut bytes))
            .map_err(|e| fail(format!("cannot read the scenario file: {e}")))?;
        if bytes.len() as u64 > MAX_SCENARIO_BYTES {
            return Err(fail(format!(
                "the scenario file is larger than {} MiB, the limit (a scenario is a few kB of \
                 TOML; is this the right file?)",
                MAX_SCENARIO_BYTES >> 20
            )));
        }
        let source = String::from_utf8(bytes).map_err(|e| {
            let at = e.utf8_error().valid_up_to();
            let text = String::from_utf8_lossy(&e.as_bytes()[..at]).into_owned();
            ScenarioError {
                file: path.to_path_buf(),
                line: Some(line_col(&text, at)),
                message: "the scenario file is not UTF-8 text (a TOML file must be)".into(),
            }
        })?;
        Self::from_str(path, &source)
    }

    /// Parse, resolve and validate scenario text; `path` is used in messages, for the name and
    /// to resolve relative file references (`initial_state.file`).
    pub fn from_str(path: &Path, source: &str) -> Result<Self, ScenarioError> {
        let err = |span: Option<Range<usize>>, message: String| ScenarioError {
            file: path.to_path_buf(),
            line: span.map(|s| line_col(source, s.start)),
            message,
        };
        let mut config: ScenarioConfig = toml::from_str(source)
            .map_err(|e| err(e.span(), toml_errors::explain_toml_error(source, &e)))?;
        let notes = config.resolve();
        if config.time.auto_dt {
            // Validate everything else with a provisional dt that every interval check accepts.
            let d = config.time.duration;
            let d = (d.is_finite() && d > 0.0).then_some(d);
            config.time.dt = config
                .auto_dt_interval()
                .into_iter()
                .chain(d)
                .min_by(f64::total_cmp)
                .unwrap_or(1.0);
        }
        config
            .validate()
            .map_err(|bad| err(key_span(source, &bad.key), bad.to_string()))?;
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_else(|| "scenario".into());
        let mut scn = Self {
            path: path.to_path_buf(),
            name,
            config,
            notes,
            source: source.to_string(),
        };
        if scn.config.time.auto_dt {
            scn.resolve_auto_dt()?;
        }
        Ok(scn)
    }

    /// `dt = "auto"`: build the system, take `AUTO_DT_FRACTION` of its stable limit rounded
    /// down to divide the shortest sampling interval, and validate again with that dt.
    fn resolve_auto_dt(&mut self) -> Result<(), ScenarioError> {
        let (system, _) = crate::build::build_system(self)?;
        let limit = system.stable_dt();
        let interval = self.config.auto_dt_interval().unwrap_or(f64::NAN);
        let Some(dt) = octoarm_physics::auto_dt(limit, interval) else {
            return Err(self.error_at(
                "time.dt",
                format!(
                    "time.dt = \"auto\": the stable time step of this system is {limit:.3e} s, \
                     so no automatic time step exists; check youngs_modulus, shear_modulus, \
                     density, the diameters and contact stiffness"
                ),
            ));
        };
        self.config.time.dt = dt;
        let source = &self.source;
        self.config.validate().map_err(|bad| ScenarioError {
            file: self.path.clone(),
            line: key_span(source, &bad.key).map(|s| line_col(source, s.start)),
            message: format!("{bad} (with the automatic time step dt = {dt:e} s)"),
        })
    }

    /// The original text of the file.
    pub fn source(&self) -> &str {
        &self.source
    }

    /// Line and column of a key path in the original file, if it is there.
    pub fn locate(&self, key: &str) -> Option<(usize, usize)> {
        key_span(&self.source, key).map(|s| line_col(&self.source, s.start))
    }

    /// An error at a key of this scenario.
    pub fn error_at(&self, key: &str, message: String) -> ScenarioError {
        ScenarioError {
            file: self.path.clone(),
            line: self.locate(key),
            message,
        }
    }

    /// A path named in the scenario, relative to the scenario file's folder.
    pub fn relative_path(&self, p: &str) -> PathBuf {
        let p = Path::new(p);
        if p.is_absolute() {
            return p.to_path_buf();
        }
        match self.path.parent() {
            Some(dir) if !dir.as_os_str().is_empty() => dir.join(p),
            _ => p.to_path_buf(),
        }
    }

    /// The resolved scenario as TOML, with a header saying where it came from; parsing it
    /// gives the same configuration.
    pub fn resolved_toml(&self) -> String {
        let mut config = self.config.clone();
        // The copy sits in the output folder: make a relative initial-state file absolute.
        if let Some(init) = &mut config.initial_state {
            let p = self.relative_path(&init.file);
            init.file = std::fs::canonicalize(&p)
                .unwrap_or(p)
                .to_string_lossy()
                .into_owned();
        }
        let body = toml::to_string(&config).expect("a scenario always serialises");
        format!(
            "# Resolved by octoarm {} from {} (defaults filled in).\n# Re-run with: octoarm run scenario.toml\n\n{body}",
            env!("CARGO_PKG_VERSION"),
            self.path.display()
        )
    }
}

impl ScenarioConfig {
    /// Fill in defaults that depend on other keys, so that the written scenario is explicit.
    /// Returns notes about deprecated keys that were converted.
    pub fn resolve(&mut self) -> Vec<String> {
        let mut notes = Vec::new();
        let single = self.rods.list.len() == 1;
        for (i, r) in self.rods.list.iter_mut().enumerate() {
            if r.tip_diameter.is_none() {
                r.tip_diameter = Some(r.base_diameter);
            }
            if r.name.is_none() {
                r.name = Some(if single {
                    "rod".to_string()
                } else {
                    format!("rod{i}")
                });
            }
        }
        if self.controller.is_some() && self.solver.is_none() {
            self.solver = Some(toml::from_str("").expect("every [solver] key has a default"));
        }
        if let Some(c) = &mut self.controller {
            if c.rod.is_none() && single {
                c.rod = self.rods.list[0].name.clone();
            }
        }
        if let Some(m) = &mut self.muscles {
            if m.rod.is_none() && single {
                m.rod = self.rods.list[0].name.clone();
            }
        }
        let dt = self.time.dt;
        if let Some(sv) = &mut self.solver {
            match sv.rule {
                RuleKind::Lbfgs => {}
                RuleKind::Preconditioned => {
                    sv.eta.get_or_insert(1.0);
                }
                RuleKind::Paper => {
                    sv.eta.get_or_insert(0.005);
                    sv.min_stretch.get_or_insert(0.1);
                }
            }
            for (old, new, name, new_name) in [
                (
                    sv.update_every.take(),
                    &mut sv.update_interval,
                    "update_every",
                    "update_interval",
                ),
                (
                    sv.ramp_every.take(),
                    &mut sv.ramp_interval,
                    "ramp_every",
                    "ramp_interval",
                ),
            ] {
                if let Some(steps) = old {
                    if new.is_none() {
                        *new = Some(steps as f64 * dt);
                    }
                    notes.push(format!(
                        "solver.{name} = {steps} (steps) is deprecated: write solver.{new_name} = {:e} (seconds)",
                        steps as f64 * dt
                    ));
                }
                new.get_or_insert(1.0e-3);
            }
        }
        notes
    }

    /// The interval the automatic time step divides: the shortest of the recording interval
    /// and the controller's sampling, update and ramp intervals [s] (None if none is finite
    /// and positive).
    pub fn auto_dt_interval(&self) -> Option<f64> {
        let mut all = vec![self.time.save_interval];
        if let Some(c) = &self.controller {
            all.push(c.series_interval);
        }
        if let Some(sv) = &self.solver {
            all.extend(sv.update_interval);
            all.extend(sv.ramp_interval);
        }
        all.into_iter()
            .filter(|v| v.is_finite() && *v > 0.0)
            .min_by(f64::total_cmp)
    }

    /// Number of steps of the run: duration / dt rounded to the nearest integer (at least 1).
    pub fn n_steps(&self) -> u64 {
        ((self.time.duration / self.time.dt).round() as u64).max(1)
    }

    /// Steps between recorded frames: save_interval / dt rounded (at least 1).
    pub fn save_every(&self) -> u64 {
        steps_of(self.time.save_interval, self.time.dt)
    }

    /// Number of frames a complete run records (t = 0, every `save_every` steps, the end).
    pub fn n_frames(&self) -> u64 {
        frames_of(self.n_steps(), self.save_every())
    }

    /// Total elements of all rods.
    pub fn total_elements(&self) -> usize {
        self.rods.list.iter().map(|r| r.n_elements).sum()
    }
}

/// Steps in `interval` seconds of steps `dt`: rounded, at least 1.
pub fn steps_of(interval: f64, dt: f64) -> u64 {
    ((interval / dt).round() as u64).max(1)
}

/// Samples a run of `n_steps` takes every `every` steps: t = 0, each multiple, and the end.
pub fn frames_of(n_steps: u64, every: u64) -> u64 {
    1 + n_steps / every + u64::from(n_steps % every != 0)
}

#[cfg(test)]
mod tests {
    use super::*;

    const MINIMAL: &str = "[rod]\nn_elements = 10\nlength = 0.2\nbase_diameter = 0.02\ndensity = 700.0\n\
                           youngs_modulus = 1e4\nshear_modulus = 1e3\n\n[time]\ndt = 1e-5\nduration = 0.01\n";

    fn load(text: &str) -> Result<Scenario, ScenarioError> {
        Scenario::from_str(Path::new("s.toml"), text)
    }

    #[test]
    fn minimal_scenario_gets_defaults() {
        let s = load(MINIMAL).unwrap();
        let r = &s.config.rods.list[0];
        assert!(s.config.rods.single);
        assert_eq!(r.tip_diameter, Some(0.02));
        assert_eq!(r.name.as_deref(), Some("rod"));
        assert_eq!(r.shear_coefficient, 27.0 / 28.0);
        assert_eq!(r.base.kind(), EndKind::Clamped);
        assert_eq!(r.tip.kind(), EndKind::Free);
        assert_eq!(s.config.time.save_interval, 1e-3);
        assert_eq!(s.config.n_steps(), 1000);
        assert_eq!(s.config.save_every(), 100);
        assert_eq!(s.config.n_frames(), 11);
    }

    #[test]
    fn resolved_toml_round_trips() {
        let text = format!("{MINIMAL}\n[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1e-5, 0.0]\n\n[[obstacle]]\nkind = \"sphere\"\ncenter = [0.1, 0.05, 0.0]\ndiameter = 0.04\n");
        let s = load(&text).unwrap();
        let again = load(&s.resolved_toml()).unwrap();
        assert_eq!(s.config, again.config);
    }

    #[test]
    fn many_rods_ends_joints_and_schedules_round_trip() {
        let rod = |name: &str, extra: &str| {
            format!("[[rod]]\nname = \"{name}\"\nn_elements = 10\nlength = 0.2\nbase_diameter = 0.02\ndensity = 700.0\nyoungs_modulus = 1e4\nshear_modulus = 1e3\n{extra}\n")
        };
        let text = format!(
            "{}{}[time]\ndt = 1e-5\nduration = 0.01\n\n[[joint]]\nkind = \"fixed\"\nfirst = \"a.tip\"\nsecond = \"b.base\"\n\n[[load]]\nkind = \"node_force\"\nrod = \"b\"\ns = 0.1\nvalue = [0.0, 1e-5, 0.0]\nschedule = {{ kind = \"piecewise_linear\", times = [0.0, 1.0], values = [0.0, 1.0] }}\n",
            rod("a", "tip = \"free\"\nrest_kappa = { s = [0.0, 0.2], value = [[0.0, 1.0, 0.0], [0.0, 2.0, 0.0]] }"),
            rod("b", "base = \"free\"\ntip = { kind = \"driven\", times = [0.0, 1.0], rotation = [[0.0, 0.0, 0.0], [0.0, 0.0, 1.0]] }\nbase_position = [0.2, 0.0, 0.0]"),
        );
        let s = load(&text).unwrap();
        assert_eq!(s.config.rods.list.len(), 2);
        assert!(!s.config.rods.single);
        let again = load(&s.resolved_toml()).unwrap();
        assert_eq!(s.config, again.config);
    }

    #[test]
    fn frame_count_includes_a_final_partial_interval() {
        let mut s = load(MINIMAL).unwrap().config;
        s.time.duration = 0.01 + 5e-5; // 1005 steps, frames at 0, 100, ..., 1000, 1005
        assert_eq!(s.n_frames(), 12);
    }

    #[test]
    fn unknown_key_suggests_the_nearest() {
        let e = load(&MINIMAL.replace("density", "densty")).unwrap_err();
        assert_eq!(e.line.map(|l| l.0), Some(5));
        assert!(
            e.message
                .contains("unknown key `densty` in [rod]; did you mean `density`?"),
            "{e}"
        );
    }

    #[test]
    fn unknown_key_in_an_array_of_rods_suggests_the_nearest() {
        let text = MINIMAL
            .replace("[rod]", "[[rod]]")
            .replace("density", "densty");
        let e = load(&text).unwrap_err();
        assert_eq!(e.line.map(|l| l.0), Some(5));
        assert!(e.message.contains("did you mean `density`?"), "{e}");
    }

    #[test]
    fn out_of_range_names_line_key_and_range() {
        let e = load(&MINIMAL.replace("length = 0.2", "length = -0.2")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.toml:3:1: rod.length = -0.2 is outside the allowed range (0, inf), finite"
        );
        let e = load(
            &MINIMAL
                .replace("[rod]", "[[rod]]")
                .replace("length = 0.2", "length = -0.2"),
        )
        .unwrap_err();
        assert_eq!(
            e.to_string(),
            "s.toml:3:1: rod[0].length = -0.2 is outside the allowed range (0, inf), finite"
        );
    }

    #[test]
    fn bad_rest_profile_and_end_are_named() {
        let e = load(&MINIMAL.replace(
            "shear_modulus = 1e3",
            "shear_modulus = 1e3\nrest_kappa = [[0.0, 1.0, 0.0]]",
        ))
        .unwrap_err();
        assert!(e.message.contains("rod.rest_kappa"), "{e}");
        assert!(e.message.contains("exactly 9 vectors"), "{e}");
        let e = load(&MINIMAL.replace(
            "shear_modulus = 1e3",
            "shear_modulus = 1e3\nbase = \"clampd\"",
        ))
        .unwrap_err();
        assert!(e.message.contains("rod.base"), "{e}");
        assert!(e.message.contains("clamped"), "{e}");
    }

    #[test]
    fn key_span_finds_array_of_table_entries() {
        let text = format!("{MINIMAL}\n[[load]]\nkind = \"gravity\"\nvalue = [0.0, 0.0, 0.0]\n[[load]]\nkind = \"tip_force\"\nvalue = [0.0, 1.0, 0.0]\n");
        let span = key_span(&text, "load[1].value").unwrap();
        assert_eq!(line_col(&text, span.start).0, 18);
    }

    #[test]
    fn numbers_in_messages_have_at_most_six_significant_digits() {
        for (v, shown) in [
            (0.00001, "0.00001"),
            (-0.2, "-0.2"),
            (700.0, "700"),
            (0.0, "0"),
            (f64::NAN, "NaN"),
            (1e300, "1e300"),
            (-1e-300, "-1e-300"),
            (1.0 / 3.0, "0.333333"),
            (0.1 + 0.2, "0.3"),
            (123456789.0, "1.23457e8"),
            (999999.7, "1e6"),
            (1e18, "1e18"),
            (2.5e-5, "0.000025"),
        ] {
            assert_eq!(fmt_num(v), shown, "{v:e}");
        }
        assert_eq!(fmt_sci(1e-4), "1e-4");
        assert_eq!(fmt_sci(1.0 / 3.0), "3.33333e-1");
        assert_eq!(fmt_vec([1e300, 0.0, -1e-300]), "[1e300, 0, -1e-300]");
        assert_eq!(fmt_bytes(19.28e12), "19.3 TB");
        assert_eq!(fmt_bytes(546_000.0), "546 kB");
        assert_eq!(fmt_bytes(999_999.0), "1.00 MB");
        assert_eq!(fmt_bytes(2e9), "2.00 GB");
        let e = load(&MINIMAL.replace("length = 0.2", "length = -1e300")).unwrap_err();
        assert!(e.message.contains("rod.length = -1e300 is outside"), "{e}");
    }

    #[test]
    fn vectors_are_exactly_three_numbers() {
        let with_load = |value: &str| {
            load(&format!(
                "{MINIMAL}\n[[load]]\nkind = \"tip_force\"\nvalue = {value}\n"
            ))
        };
        assert!(with_load("[0, 2e-5, 0]").is_ok());
        for (value, found) in [
            (
                "[0, 2e-5, 0, 99, \"junk\", true]",
                "6 entries: 4 numbers, a string and a boolean",
            ),
            ("[0, 2e-5, 0, 99]", "4 entries: 4 numbers"),
            ("[0, 2e-5]", "2 entries: 2 numbers"),
            ("[0, \"y\", 0]", "3 entries: 2 numbers and a string"),
        ] {
            let e = with_load(value).unwrap_err();
            assert!(e.message.contains("load[0].value"), "{e}");
            assert!(e.message.contains("3 numbers"), "{e}");
            assert!(e.message.contains(found), "{e}");
        }
        // Lists of vectors name the entry.
        let text = MINIMAL.replace(
            "shear_modulus = 1e3",
            "shear_modulus = 1e3\nrest_kappa = { s = [0.0, 0.1], value = [[0, 1, 0], [0, 1, 0, 7]] }",
        );
        let e = load(&text).unwrap_err();
        assert!(
            e.message
                .contains("rod.rest_kappa.value: entry [1]: expected 3 numbers"),
            "{e}"
        );
        let e = load(&format!(
            "{MINIMAL}\n[[obstacle]]\nkind = \"sphere\"\ncenter = [0.1, 0.0]\ndiameter = 0.01\n"
        ))
        .unwrap_err();
        assert!(
            e.message.contains("obstacle[0].center: expected 3 numbers"),
            "{e}"
        );
    }

    #[test]
    fn tiny_and_huge_directions_are_directions() {
        for d in ["[1e-300, 0, 0]", "[1e200, 0, 0]"] {
            let s = load(&MINIMAL.replace(
                "shear_modulus = 1e3",
                &format!("shear_modulus = 1e3\ndirection = {d}"),
            ))
            .unwrap();
            let (system, _) = crate::build::build_system(&s).unwrap();
            assert_eq!(system.rods().len(), 1);
        }
        let e = load(&MINIMAL.replace(
            "shear_modulus = 1e3",
            "shear_modulus = 1e3\ndirection = [0, 0, 0]",
        ))
        .unwrap_err();
        assert!(e.message.contains("non-zero"), "{e}");
    }

    #[test]
    fn integer_keys_reject_floats_and_overflow_by_name() {
        let e = load(&MINIMAL.replace("n_elements = 10", "n_elements = 1e18")).unwrap_err();
        assert!(
            e.message
                .contains("rod.n_elements: expected a whole number"),
            "{e}"
        );
        assert!(e.message.contains("found 1e18"), "{e}");
        let e = load(&MINIMAL.replace("n_elements = 10", "n_elements = 100000000000000000000"))
            .unwrap_err();
        assert!(
            e.message
                .contains("rod.n_elements: the number is too large"),
            "{e}"
        );
        let e = load(&format!(
            "{MINIMAL}\n[load]\nkind = \"gravity\"\nvalue = [0, -9.81, 0]\n"
        ))
        .unwrap_err();
        assert!(e.message.contains("[load] must be written [[load]]"), "{e}");
    }

    #[test]
    fn nearest_name() {
        let c: Vec<String> = ["gravity", "tip_force", "uniform_force", "tip_couple"]
            .map(String::from)
            .to_vec();
        assert_eq!(nearest("tipforce", &c), Some("tip_force"));
        assert_eq!(nearest("zzzzzzzzzz", &c), None);
    }
}
