//! Checks of a resolved scenario: every value against its allowed range, names and references
//! (rods, joint ends, load targets), and the rules between sections. The first violation is
//! returned as an `Invalid` naming the dotted key, the value and the range.

use super::config::*;
use super::Invalid;
use std::fmt;

/// Largest accepted element count per rod (memory and time grow with it; a typo guard).
pub const MAX_ELEMENTS: usize = 100_000;
/// Largest accepted total element count of all rods.
pub const MAX_TOTAL_ELEMENTS: usize = 1_000_000;
/// Largest accepted number of rods.
pub const MAX_RODS: usize = 10_000;
/// Largest accepted number of steps (a typo guard: 1e10 steps are days of computing).
pub const MAX_STEPS: f64 = 1.0e10;

pub(crate) fn bad(key: &str, value: impl fmt::Display, range: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: value.to_string(),
        range: range.into(),
    }
}

/// A rule about a key or section as a whole, not a value out of range.
pub(crate) fn rule(key: &str, what: impl Into<String>) -> Invalid {
    bad(key, "", what)
}

fn bad_vec(key: &str, value: Vec3, range: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: fmt_vec(value),
        range: range.into(),
    }
}

/// `[x, y, z]` as TOML writes it.
pub fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", v[0], v[1], v[2])
}

pub(crate) fn positive(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v > 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "(0, inf), finite"))
    }
}

pub(crate) fn non_negative(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() && v >= 0.0 {
        Ok(())
    } else {
        Err(bad(key, v, "[0, inf), finite"))
    }
}

fn finite(key: &str, v: f64) -> Result<(), Invalid> {
    if v.is_finite() {
        Ok(())
    } else {
        Err(bad(key, v, "finite numbers"))
    }
}

pub(crate) fn finite_vec(key: &str, v: Vec3) -> Result<(), Invalid> {
    if v.iter().all(|c| c.is_finite()) {
        Ok(())
    } else {
        Err(bad_vec(key, v, "of vectors with finite components"))
    }
}

fn unit_vec(key: &str, v: Vec3) -> Result<Vec3, Invalid> {
    finite_vec(key, v)?;
    let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    if l > 0.0 && l.is_finite() {
        Ok([v[0] / l, v[1] / l, v[2] / l])
    } else {
        Err(bad_vec(key, v, "of non-zero vectors"))
    }
}

fn count(key: &str, v: usize, lo: usize, hi: usize) -> Result<(), Invalid> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(bad(key, v, format!("[{lo}, {hi}]")))
    }
}

fn increasing(key: &str, t: &[f64]) -> Result<(), Invalid> {
    for (i, w) in t.windows(2).enumerate() {
        if w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater) {
            return Err(bad(
                &format!("{key}[{}]", i + 1),
                w[1],
                format!("({key}[{i}] = {}, inf): strictly increasing", w[0]),
            ));
        }
    }
    Ok(())
}

impl ScenarioConfig {
    /// The key prefix of rod i: `rod` for a single `[rod]` table, `rod[i]` otherwise.
    pub fn rod_key(&self, i: usize) -> String {
        if self.rods.single {
            "rod".to_string()
        } else {
            format!("rod[{i}]")
        }
    }

    /// Index of the rod called `name`.
    pub fn rod_index(&self, name: &str) -> Option<usize> {
        self.rods
            .list
            .iter()
            .position(|r| r.name.as_deref() == Some(name))
    }

    /// The names of the rods (resolved), for messages.
    pub fn rod_names(&self) -> String {
        self.rods
            .list
            .iter()
            .map(|r| format!("\"{}\"", r.name.as_deref().unwrap_or("")))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// Resolve a rod reference: the named rod, or the only rod when `name` is None.
    pub(crate) fn find_rod(&self, key: &str, name: Option<&str>) -> Result<usize, Invalid> {
        match name {
            Some(n) => self.rod_index(n).ok_or_else(|| {
                bad(
                    key,
                    format!("\"{n}\""),
                    format!("of the rod names: {}", self.rod_names()),
                )
            }),
            None if self.rods.list.len() == 1 => Ok(0),
            None => Err(rule(
                key,
                format!(
                    "missing: with several rods, name one of {}",
                    self.rod_names()
                ),
            )),
        }
    }

    /// Check every value against its range; the first violation is returned.
    pub fn validate(&self) -> Result<(), Invalid> {
        let rods = &self.rods.list;
        if rods.is_empty() {
            return Err(rule("rod", "needs at least one [[rod]] table"));
        }
        count("rod", rods.len(), 1, MAX_RODS)?;
        let mut total = 0usize;
        for (i, r) in rods.iter().enumerate() {
            self.validate_rod(i, r)?;
            total += r.n_elements;
        }
        if total > MAX_TOTAL_ELEMENTS {
            return Err(bad(
                "rod",
                format!("{total} elements in all"),
                format!("of at most {MAX_TOTAL_ELEMENTS} elements in all rods"),
            ));
        }

        let t = &self.time;
        positive("time.dt", t.dt)?;
        if !(t.duration.is_finite() && t.duration >= t.dt) {
            return Err(bad(
                "time.duration",
                t.duration,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }
        if t.duration / t.dt > MAX_STEPS {
            return Err(bad(
                "time.duration",
                t.duration,
                format!("of at most {MAX_STEPS:e} steps of dt = {:e} s", t.dt),
            ));
        }
        if !(t.save_interval.is_finite() && t.save_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "time.save_interval",
                t.save_interval,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }

        non_negative("damping.rate", self.damping.rate)?;
        non_negative("damping.gamma", self.damping.gamma)?;
        if self.damping.protocol == DampingProtocol::Pyelastica && self.damping.gamma != 0.0 {
            return Err(bad(
                "damping.gamma",
                self.damping.gamma,
                "of 0 with protocol = \"pyelastica\" (its damper has one rate: use damping.rate)",
            ));
        }
        if !(1..=1_000_000).contains(&self.numerics.guard_interval) {
            return Err(bad(
                "numerics.guard_interval",
                self.numerics.guard_interval,
                "[1, 1000000]",
            ));
        }
        positive("contact.beta", self.contact.beta)?;
        non_negative("contact.zeta", self.contact.zeta)?;

        for (i, load) in self.loads.iter().enumerate() {
            self.validate_load(i, load)?;
        }
        for (i, ob) in self.obstacles.iter().enumerate() {
            finite_vec(&format!("obstacle[{i}].center"), ob.center)?;
            positive(&format!("obstacle[{i}].diameter"), ob.diameter)?;
            finite_vec(&format!("obstacle[{i}].velocity"), ob.velocity)?;
        }
        for (i, j) in self.joints.iter().enumerate() {
            self.validate_joint(i, j)?;
        }
        if let Some(init) = &self.initial_state {
            if init.file.is_empty() {
                return Err(rule(
                    "initial_state.file",
                    "must name a trajectory.npz file",
                ));
            }
            if init.frame.is_some() && init.time.is_some() {
                return Err(rule(
                    "initial_state.time",
                    "give either frame or time, not both",
                ));
            }
            if let Some(t) = init.time {
                finite("initial_state.time", t)?;
            }
        }
        self.validate_control()
    }

    fn validate_rod(&self, i: usize, r: &RodConfig) -> Result<(), Invalid> {
        let p = self.rod_key(i);
        let k = |name: &str| format!("{p}.{name}");
        if let Some(name) = &r.name {
            let ok = !name.is_empty()
                && name.len() <= 64
                && name
                    .chars()
                    .all(|c| c.is_ascii_alphanumeric() || c == '_' || c == '-');
            if !ok {
                return Err(bad(
                    &k("name"),
                    format!("\"{name}\""),
                    "of 1 to 64 letters, digits, '_' and '-'",
                ));
            }
            if self.rods.list[..i]
                .iter()
                .any(|o| o.name.as_deref() == Some(name))
            {
                return Err(bad(
                    &k("name"),
                    format!("\"{name}\""),
                    "of names not used by another rod",
                ));
            }
        }
        count(&k("n_elements"), r.n_elements, 2, MAX_ELEMENTS)?;
        positive(&k("length"), r.length)?;
        positive(&k("base_diameter"), r.base_diameter)?;
        positive(
            &k("tip_diameter"),
            r.tip_diameter.unwrap_or(r.base_diameter),
        )?;
        positive(&k("density"), r.density)?;
        positive(&k("youngs_modulus"), r.youngs_modulus)?;
        positive(&k("shear_modulus"), r.shear_modulus)?;
        positive(&k("shear_coefficient"), r.shear_coefficient)?;
        finite_vec(&k("base_position"), r.base_position)?;
        let d3 = unit_vec(&k("direction"), r.direction)?;
        let d1 = unit_vec(&k("normal"), r.normal)?;
        let cos = d1[0] * d3[0] + d1[1] * d3[1] + d1[2] * d3[2];
        if cos.abs() > 1e-10 {
            return Err(bad_vec(
                &k("normal"),
                r.normal,
                format!(
                    "of vectors perpendicular to {} = {} (cosine between them is {cos:.3e})",
                    k("direction"),
                    fmt_vec(r.direction)
                ),
            ));
        }
        finite_vec(&k("rest_curvature"), r.rest_curvature)?;
        if r.rest_kappa.is_some() && r.rest_curvature != [0.0; 3] {
            return Err(rule(
                &k("rest_kappa"),
                "give either rest_curvature (uniform) or rest_kappa, not both",
            ));
        }
        let n = r.n_elements;
        if let Some(p) = &r.rest_kappa {
            validate_profile(&k("rest_kappa"), p, n - 1, r.length)?;
        }
        if let Some(p) = &r.rest_sigma {
            validate_profile(&k("rest_sigma"), p, n, r.length)?;
        }
        if let Some(s) = &r.rest_schedule {
            validate_schedule(&k("rest_schedule"), s)?;
            if r.rest_kappa.is_none() && r.rest_sigma.is_none() && r.rest_curvature == [0.0; 3] {
                return Err(rule(
                    &k("rest_schedule"),
                    "schedules rest strains, but the rod has none (give rest_kappa, rest_sigma or rest_curvature)",
                ));
            }
        }
        for (side, e) in [("base", &r.base), ("tip", &r.tip)] {
            validate_end(&k(side), e)?;
        }
        Ok(())
    }

    fn validate_load(&self, i: usize, load: &LoadConfig) -> Result<(), Invalid> {
        let k = |name: &str| format!("load[{i}].{name}");
        finite_vec(&k("value"), load.value)?;
        let rod = match (&load.rod, load.kind) {
            (None, LoadKind::Gravity) => None,
            (name, _) => Some(self.find_rod(&k("rod"), name.as_deref())?),
        };
        let n = rod.map(|r| self.rods.list[r].n_elements);
        let length = rod.map(|r| self.rods.list[r].length);
        let kind = load.kind.name();
        let only = |field: &str, what: &str| {
            rule(
                &k(field),
                format!("is not a key of kind = \"{kind}\" ({what})"),
            )
        };
        if !load.kind.at_node() && load.node.is_some() {
            return Err(only("node", "only node_force acts on one node"));
        }
        if !load.kind.at_element() && load.element.is_some() {
            return Err(only(
                "element",
                "only element_couple and follower_couple act on one element",
            ));
        }
        if !(load.kind.at_node() || load.kind.at_element()) && load.s.is_some() {
            return Err(only(
                "s",
                "only node_force, element_couple and follower_couple are placed along the rod",
            ));
        }
        if load.kind.at_node() || load.kind.at_element() {
            let (index, name, last) = if load.kind.at_node() {
                (load.node, "node", n.unwrap_or(0))
            } else {
                (load.element, "element", n.unwrap_or(1) - 1)
            };
            match (index, load.s) {
                (Some(_), Some(_)) => {
                    return Err(rule(&k("s"), format!("give either {name} or s, not both")))
                }
                (None, None) => {
                    return Err(rule(
                        &k(name),
                        format!("missing: give the {name} index or its rest arc length s"),
                    ))
                }
                (Some(j), None) if j > last => {
                    return Err(bad(&k(name), j, format!("[0, {last}]")));
                }
                (None, Some(s)) => {
                    let l = length.unwrap_or(0.0);
                    if !(s.is_finite() && (0.0..=l).contains(&s)) {
                        return Err(bad(&k("s"), s, format!("[0, {l}] m (the rod's length)")));
                    }
                }
                _ => {}
            }
        }
        if let Some(ramp) = load.ramp_time {
            non_negative(&k("ramp_time"), ramp)?;
            if load.schedule.is_some() && ramp != 0.0 {
                return Err(rule(
                    &k("ramp_time"),
                    "give either ramp_time or schedule, not both",
                ));
            }
        }
        if let Some(s) = &load.schedule {
            validate_schedule(&k("schedule"), s)?;
        }
        Ok(())
    }

    /// Rod index and side of a joint end `"<rod>.base"` / `"<rod>.tip"`.
    pub(crate) fn joint_end(&self, key: &str, end: &str) -> Result<(usize, bool), Invalid> {
        let (name, side) = end.rsplit_once('.').ok_or_else(|| {
            bad(
                key,
                format!("\"{end}\""),
                "of the form \"<rod name>.base\" or \"<rod name>.tip\"",
            )
        })?;
        let tip = match side {
            "base" => false,
            "tip" => true,
            _ => {
                return Err(bad(
                    key,
                    format!("\"{end}\""),
                    "of the form \"<rod name>.base\" or \"<rod name>.tip\"",
                ))
            }
        };
        let r = self.rod_index(name).ok_or_else(|| {
            bad(
                key,
                format!("\"{end}\""),
                format!("of ends of the rods {}", self.rod_names()),
            )
        })?;
        Ok((r, tip))
    }

    fn validate_joint(&self, i: usize, j: &JointConfig) -> Result<(), Invalid> {
        let k = |name: &str| format!("joint[{i}].{name}");
        let a = self.joint_end(&k("first"), &j.first)?;
        let b = self.joint_end(&k("second"), &j.second)?;
        if a == b {
            return Err(rule(&k("second"), "must be another rod end than first"));
        }
        match (j.kind, j.axis) {
            (JointKindConfig::Hinge, None) => {
                return Err(rule(&k("axis"), "missing: a hinge joint needs its axis"))
            }
            (JointKindConfig::Hinge, Some(axis)) => {
                unit_vec(&k("axis"), axis)?;
            }
            (_, Some(_)) => {
                return Err(rule(&k("axis"), "is only a key of kind = \"hinge\""));
            }
            _ => {}
        }
        for (name, v) in [
            ("stiffness", j.stiffness),
            ("damping", j.damping),
            ("rotational_stiffness", j.rotational_stiffness),
            ("rotational_damping", j.rotational_damping),
        ] {
            if let Some(v) = v {
                non_negative(&k(name), v)?;
            }
        }
        if j.kind == JointKindConfig::Free
            && (j.rotational_stiffness.is_some() || j.rotational_damping.is_some())
        {
            return Err(rule(
                &k("rotational_stiffness"),
                "a free joint has no rotational spring; remove it or use kind = \"fixed\" / \"hinge\"",
            ));
        }
        Ok(())
    }

    /// The sections of a controlled run: present only with `[controller]`, in range.
    fn validate_control(&self) -> Result<(), Invalid> {
        let Some(ctrl) = &self.controller else {
            let needs = |key: &str| {
                rule(
                    key,
                    "allowed only with [controller] (kind = \"energy_shaping\"); add it or remove this section",
                )
            };
            if self.solver.is_some() {
                return Err(needs("solver"));
            }
            if !self.targets.is_empty() {
                return Err(needs("target"));
            }
            if self.via_path.is_some() {
                return Err(needs("via_path"));
            }
            if self.grasp.is_some() {
                return Err(needs("grasp"));
            }
            if !self.acceptance.is_empty() {
                return Err(needs("acceptance"));
            }
            return Ok(());
        };
        let t = &self.time;
        if !(ctrl.series_interval.is_finite() && ctrl.series_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "controller.series_interval",
                ctrl.series_interval,
                format!("[time.dt = {:e}, inf), finite", t.dt),
            ));
        }
        let r = self.find_rod("controller.rod", ctrl.rod.as_deref())?;
        let rod = &self.rods.list[r];
        if rod.base.kind() != EndKind::Clamped || rod.tip.kind() != EndKind::Free {
            return Err(rule(
                "controller.rod",
                format!(
                    "the energy-shaping controller needs rod \"{}\" clamped at its base and free at its tip (it is {:?} / {:?})",
                    rod.name.as_deref().unwrap_or(""),
                    rod.base.kind(),
                    rod.tip.kind()
                ),
            ));
        }
        if self.targets.is_empty() && self.grasp.is_none() {
            return Err(rule(
                "controller",
                "a controlled run needs at least one [[target]] or a [grasp]; add one",
            ));
        }
        if !self.targets.is_empty() && self.grasp.is_some() {
            return Err(rule(
                "grasp",
                "a grasp has no tip target: give either [[target]] or [grasp], not both",
            ));
        }
        let mut last_from = 0.0;
        for (i, tg) in self.targets.iter().enumerate() {
            finite_vec(&format!("target[{i}].position"), tg.position)?;
            finite_vec(&format!("target[{i}].velocity"), tg.velocity)?;
            non_negative(&format!("target[{i}].from"), tg.from)?;
            if i > 0 && tg.from <= last_from {
                return Err(bad(
                    &format!("target[{i}].from"),
                    tg.from,
                    format!(
                        "(target[{}].from = {last_from}, inf): targets in time order",
                        i - 1
                    ),
                ));
            }
            last_from = tg.from;
        }
        if let Some(v) = &self.via_path {
            if self.targets.is_empty() {
                return Err(rule(
                    "via_path",
                    "needs a [[target]]: the path leads to the task target",
                ));
            }
            if v.points.len() < 2 {
                return Err(bad(
                    "via_path.points",
                    v.points.len(),
                    "of at least 2 points",
                ));
            }
            for p in &v.points {
                finite_vec("via_path.points", *p)?;
            }
            non_negative("via_path.start", v.start)?;
            if !(v.end.is_finite() && v.end > v.start) {
                return Err(bad(
                    "via_path.end",
                    v.end,
                    format!("(via_path.start = {}, inf), finite", v.start),
                ));
            }
        }
        if let Some(g) = &self.grasp {
            finite_vec("grasp.center", g.center)?;
            positive("grasp.diameter", g.diameter)?;
            positive("grasp.mu_grasp", g.mu_grasp)?;
            let [a, b] = g.interval;
            if !(a.is_finite() && (0.0..1.0).contains(&a) && b == 1.0) {
                return Err(bad(
                    "grasp.interval",
                    format!("[{a}, {b}]"),
                    "[a, 1.0] with 0 <= a < 1 (the interval ends at the tip)",
                ));
            }
        }
        let sv = self
            .solver
            .as_ref()
            .expect("resolve() fills [solver] for a controlled run");
        count("solver.lbfgs_memory", sv.lbfgs_memory, 1, 1000)?;
        if let Some(eta) = sv.eta {
            positive("solver.eta", eta)?;
            if sv.rule == RuleKind::Preconditioned && eta > 1.0 {
                return Err(bad(
                    "solver.eta",
                    eta,
                    "(0, 1] for rule = \"preconditioned\"",
                ));
            }
        }
        if let Some(m) = sv.min_stretch {
            positive("solver.min_stretch", m)?;
        }
        non_negative("solver.mu_tip", sv.mu_tip)?;
        non_negative("solver.xi", sv.xi)?;
        non_negative("solver.design_floor_diameter", sv.design_floor_diameter)?;
        positive("solver.tolerance", sv.tolerance)?;
        non_negative("solver.stall_tolerance", sv.stall_tolerance)?;
        count("solver.stall_window", sv.stall_window, 1, 1_000_000)?;
        count("solver.max_sweeps", sv.max_sweeps, 1, 10_000_000)?;
        count(
            "solver.iterations_per_update",
            sv.iterations_per_update,
            1,
            100_000,
        )?;
        count("solver.grasp_stages", sv.grasp_stages, 1, 1000)?;
        for (key, v) in [
            ("solver.update_interval", sv.update_interval),
            ("solver.ramp_interval", sv.ramp_interval),
        ] {
            let v = v.expect("resolve() fills the intervals");
            if !(v.is_finite() && v >= t.dt * (1.0 - 1e-9)) {
                return Err(bad(key, v, format!("[time.dt = {:e}, inf), finite", t.dt)));
            }
        }
        if let Some(tf) = sv.trust_form_time {
            positive("solver.trust_form_time", tf)?;
        }
        non_negative("solver.ramp_time", sv.ramp_time)?;
        for (i, a) in self.acceptance.iter().enumerate() {
            validate_acceptance(i, a)?;
        }
        Ok(())
    }
}

fn validate_profile(key: &str, p: &Profile, entries: usize, length: f64) -> Result<(), Invalid> {
    match p {
        Profile::Uniform(v) => finite_vec(key, *v),
        Profile::PerEntry(v) => {
            if v.len() != entries {
                return Err(bad(
                    key,
                    format!("{} vectors", v.len()),
                    format!("of exactly {entries} vectors (one per entry) or one uniform vector"),
                ));
            }
            for (i, x) in v.iter().enumerate() {
                finite_vec(&format!("{key}[{i}]"), *x)?;
            }
            Ok(())
        }
        Profile::Function(f) => {
            let ks = format!("{key}.s");
            if f.s.is_empty() {
                return Err(rule(&ks, "needs at least one sample"));
            }
            if f.value.len() != f.s.len() {
                return Err(bad(
                    &format!("{key}.value"),
                    format!("{} vectors", f.value.len()),
                    format!("of one vector per s ({})", f.s.len()),
                ));
            }
            for (i, s) in f.s.iter().enumerate() {
                if !(s.is_finite() && (0.0..=length).contains(s)) {
                    return Err(bad(&format!("{ks}[{i}]"), s, format!("[0, {length}] m")));
                }
            }
            increasing(&ks, &f.s)?;
            for (i, v) in f.value.iter().enumerate() {
                finite_vec(&format!("{key}.value[{i}]"), *v)?;
            }
            Ok(())
        }
    }
}

pub(crate) fn validate_schedule(key: &str, s: &ScheduleConfig) -> Result<(), Invalid> {
    let k = |name: &str| format!("{key}.{name}");
    let kind = format!("{:?}", s.kind).to_lowercase();
    let unused = |name: &str| rule(&k(name), format!("is not a key of kind = \"{kind}\""));
    let need = |name: &str| rule(&k(name), format!("missing: kind = \"{kind}\" needs it"));
    match s.kind {
        ScheduleKind::Constant => {
            if s.duration.is_some() {
                return Err(unused("duration"));
            }
            if s.time.is_some() {
                return Err(unused("time"));
            }
            if s.times.is_some() {
                return Err(unused("times"));
            }
            if s.values.is_some() {
                return Err(unused("values"));
            }
        }
        ScheduleKind::Ramp => {
            positive(&k("duration"), s.duration.ok_or_else(|| need("duration"))?)?;
            if s.time.is_some() || s.times.is_some() || s.values.is_some() {
                return Err(unused(if s.time.is_some() { "time" } else { "times" }));
            }
        }
        ScheduleKind::Step => {
            finite(&k("time"), s.time.ok_or_else(|| need("time"))?)?;
            if s.duration.is_some() || s.times.is_some() || s.values.is_some() {
                return Err(unused(if s.duration.is_some() {
                    "duration"
                } else {
                    "times"
                }));
            }
        }
        ScheduleKind::PiecewiseLinear => {
            let times = s.times.as_ref().ok_or_else(|| need("times"))?;
            let values = s.values.as_ref().ok_or_else(|| need("values"))?;
            if times.is_empty() {
                return Err(rule(&k("times"), "needs at least one sample"));
            }
            if values.len() != times.len() {
                return Err(bad(
                    &k("values"),
                    format!("{} values", values.len()),
                    format!("of one value per time ({})", times.len()),
                ));
            }
            for (i, t) in times.iter().enumerate() {
                finite(&format!("{}[{i}]", k("times")), *t)?;
            }
            increasing(&k("times"), times)?;
            for (i, v) in values.iter().enumerate() {
                finite(&format!("{}[{i}]", k("values")), *v)?;
            }
            if s.duration.is_some() || s.time.is_some() {
                return Err(unused(if s.duration.is_some() {
                    "duration"
                } else {
                    "time"
                }));
            }
        }
    }
    Ok(())
}

fn validate_end(key: &str, e: &EndConfig) -> Result<(), Invalid> {
    match e {
        EndConfig::Kind(EndKind::Driven) => Err(rule(
            key,
            "a driven end is a table: { kind = \"driven\", times = [...], displacement = [...], rotation = [...] }",
        )),
        EndConfig::Kind(_) => Ok(()),
        EndConfig::Table(t) => {
            let k = |name: &str| format!("{key}.{name}");
            if t.kind != EndKind::Driven {
                if t.times.is_some() || t.displacement.is_some() || t.rotation.is_some() {
                    return Err(rule(
                        &k("times"),
                        "times, displacement and rotation are keys of kind = \"driven\" only",
                    ));
                }
                return Ok(());
            }
            let times = t.times.as_ref().ok_or_else(|| {
                rule(&k("times"), "missing: a driven end needs its sample times")
            })?;
            if times.len() < 2 {
                return Err(bad(&k("times"), times.len(), "of at least 2 samples"));
            }
            if times[0] != 0.0 {
                return Err(bad(
                    &format!("{}[0]", k("times")),
                    times[0],
                    "{0}: a motion starts at t = 0",
                ));
            }
            for (i, x) in times.iter().enumerate() {
                finite(&format!("{}[{i}]", k("times")), *x)?;
            }
            increasing(&k("times"), times)?;
            for (name, v) in [("displacement", &t.displacement), ("rotation", &t.rotation)] {
                if let Some(v) = v {
                    if v.len() != times.len() {
                        return Err(bad(
                            &k(name),
                            format!("{} vectors", v.len()),
                            format!("of one vector per time ({})", times.len()),
                        ));
                    }
                    for (i, x) in v.iter().enumerate() {
                        finite_vec(&format!("{}[{i}]", k(name)), *x)?;
                    }
                    if v[0] != [0.0; 3] {
                        return Err(bad_vec(
                            &format!("{}[0]", k(name)),
                            v[0],
                            "{[0, 0, 0]}: a motion starts where the end is",
                        ));
                    }
                }
            }
            Ok(())
        }
    }
}

fn validate_acceptance(i: usize, a: &AcceptanceConfig) -> Result<(), Invalid> {
    let k = |name: &str| format!("acceptance[{i}].{name}");
    use AcceptanceQuantity as Q;
    let needs_time = matches!(
        a.quantity,
        Q::DistanceBefore | Q::DistanceAfter | Q::DistanceAt | Q::DesignTipError
    );
    match (needs_time, a.time) {
        (true, None) => return Err(rule(&k("time"), "missing: this quantity is about a time")),
        (true, Some(t)) => non_negative(&k("time"), t)?,
        (false, Some(_)) => return Err(rule(&k("time"), "is not a key of this quantity")),
        _ => {}
    }
    match (a.quantity == Q::MaxDistance, a.from, a.to) {
        (true, Some(f), Some(t)) => {
            non_negative(&k("from"), f)?;
            if !(t.is_finite() && t >= f) {
                return Err(bad(&k("to"), t, format!("[from = {f}, inf)")));
            }
        }
        (true, _, _) => {
            return Err(rule(
                &k("from"),
                "missing: max_distance needs from and to [s]",
            ))
        }
        (false, None, None) => {}
        (false, _, _) => return Err(rule(&k("from"), "is not a key of this quantity")),
    }
    match (a.quantity == Q::SettlingTime, a.segment) {
        (true, None) => {
            return Err(rule(
                &k("segment"),
                "missing: settling_time needs a segment",
            ))
        }
        (false, Some(_)) => return Err(rule(&k("segment"), "is not a key of this quantity")),
        _ => {}
    }
    if a.min.is_none() && a.max.is_none() {
        return Err(rule(&k("max"), "missing: give min, max or both"));
    }
    for (name, v) in [("min", a.min), ("max", a.max)] {
        if let Some(v) = v {
            finite(&k(name), v)?;
        }
    }
    Ok(())
}
