//! Checks of a resolved scenario: every value against its allowed range, names and references
//! (rods, joint ends, load targets), and the rules between sections. The first violation is
//! returned as an `Invalid` naming the dotted key, the value and the range.

use super::config::*;
use super::Invalid;

/// Largest accepted element count per rod (memory and time grow with it; a typo guard).
pub const MAX_ELEMENTS: usize = 100_000;
/// Largest accepted total element count of all rods.
pub const MAX_TOTAL_ELEMENTS: usize = 1_000_000;
/// Largest accepted number of rods.
pub const MAX_RODS: usize = 10_000;
/// Largest accepted number of steps (a typo guard: 1e10 steps are days of computing).
pub const MAX_STEPS: f64 = 1.0e10;
/// Largest accepted number of `[[load]]`, `[[obstacle]]`, `[[joint]]` and `[[target]]` tables
/// each (every one is evaluated at every step or update).
pub const MAX_ITEMS: usize = 10_000;
/// Largest accepted number of `[[acceptance]]` claims.
pub const MAX_CLAIMS: usize = 1_000;
/// Largest accepted number of samples of a schedule, a driven end's motion, a rest-strain
/// profile `{ s, value }` or a via path.
pub const MAX_SAMPLES: usize = 1_000_000;
/// Largest accepted work of one online design update: `iterations_per_update` × (N + 1)
/// node-iterations of the forward–backward sweep. Measured on the paper's arm (N = 100): 70 to
/// 200 ns per node and sweep, an iteration taking one sweep or a few (line search), so at most
/// about 2 to 10 s per update: a run always shows progress.
pub const MAX_UPDATE_WORK: f64 = 2.0e7;
/// Largest accepted work of the offline design solves before t = 0 in the worst case (every
/// solve running to `max_sweeps`): designs × grasp stages × `max_sweeps` × (N + 1) node-sweeps,
/// 2 to 6 hours at the rates above. Solves stop far earlier in practice (the paper's grasp,
/// 4 stages: 4.4e6 node-sweeps, 0.3 s); the bound stops typos such as `grasp_stages = 1000` with
/// `max_sweeps = 10000000`.
pub const MAX_OFFLINE_WORK: f64 = 1.0e11;
/// Largest accepted memory of the L-BFGS pairs, 16 × `lbfgs_memory` × (6N − 3) bytes.
pub const MAX_LBFGS_BYTES: f64 = 1.0e9;

/// A value as shown in a message: written as TOML would if that takes at most 6 significant
/// digits and 12 characters (`0.00001`, `-0.2`, `700`, `NaN`), else rounded to 6 significant
/// digits (`1e300`, `1.23457e-7`, `0.333333`). Never a 300-digit number.
pub fn fmt_num(v: f64) -> String {
    let plain = v.to_string();
    if !v.is_finite() || v == 0.0 {
        return plain;
    }
    let digits = plain
        .trim_start_matches('-')
        .replace('.', "")
        .trim_start_matches('0')
        .trim_end_matches('0')
        .len();
    if digits <= 6 && plain.len() <= 12 {
        return plain;
    }
    let sci = format!("{v:.5e}");
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let exp: i32 = exp.parse().unwrap_or(0);
    if (-4..6).contains(&exp) {
        let fixed = format!("{:.*}", (5 - exp) as usize, v);
        if fixed.contains('.') {
            return fixed
                .trim_end_matches('0')
                .trim_end_matches('.')
                .to_string();
        }
        return fixed;
    }
    let mantissa = if mantissa.contains('.') {
        mantissa.trim_end_matches('0').trim_end_matches('.')
    } else {
        mantissa
    };
    format!("{mantissa}e{exp}")
}

/// A value in scientific notation as `{:e}` writes it (`1e-4`, `2.5e-5`), rounded to 6
/// significant digits when it has more.
pub fn fmt_sci(v: f64) -> String {
    let full = format!("{v:e}");
    let mantissa_digits = full
        .split('e')
        .next()
        .unwrap_or("")
        .trim_start_matches('-')
        .replace('.', "")
        .len();
    if !v.is_finite() || mantissa_digits <= 6 {
        return full;
    }
    let sci = format!("{v:.5e}");
    let (mantissa, exp) = sci.split_once('e').unwrap_or((&sci, "0"));
    let mantissa = mantissa.trim_end_matches('0').trim_end_matches('.');
    format!("{mantissa}e{exp}")
}

/// A value of a message: numbers are shown by `fmt_num`, everything else as it displays.
pub(crate) trait Shown {
    /// The text of the value.
    fn shown(&self) -> String;
}

impl Shown for f64 {
    fn shown(&self) -> String {
        fmt_num(*self)
    }
}

macro_rules! shown_by_display {
    ($($t:ty),*) => {$(
        impl Shown for $t {
            fn shown(&self) -> String {
                self.to_string()
            }
        }
    )*};
}
shown_by_display!(usize, u64, i64, String, &str, &String);

pub(crate) fn bad(key: &str, value: impl Shown, range: impl Into<String>) -> Invalid {
    Invalid {
        key: key.to_string(),
        value: value.shown(),
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

/// `[x, y, z]` as TOML writes it, each component by `fmt_num`.
pub fn fmt_vec(v: Vec3) -> String {
    format!("[{}, {}, {}]", fmt_num(v[0]), fmt_num(v[1]), fmt_num(v[2]))
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

fn nonzero_vec(key: &str, v: Vec3) -> Result<(), Invalid> {
    unit_vec(key, v).map(|_| ())
}

/// Friction coefficients: each ≥ 0 and finite, kinetic ≤ static in every direction.
fn check_friction(
    key: &str,
    kinetic_key: &str,
    stat: Option<FrictionValue>,
    kinetic: Option<FrictionValue>,
) -> Result<(), Invalid> {
    let s = stat.map_or([0.0; 3], FrictionValue::three);
    for v in s {
        non_negative(key, v)?;
    }
    if let Some(k) = kinetic {
        if stat.is_none() {
            return Err(rule(
                kinetic_key,
                format!("needs {key} (the static coefficient) too"),
            ));
        }
        for (c, v) in k.three().into_iter().enumerate() {
            non_negative(kinetic_key, v)?;
            if v > s[c] {
                return Err(bad(
                    kinetic_key,
                    v,
                    format!(
                        "[0, {}] (kinetic friction cannot exceed static)",
                        fmt_num(s[c])
                    ),
                ));
            }
        }
    }
    Ok(())
}

fn unit_vec(key: &str, v: Vec3) -> Result<Vec3, Invalid> {
    finite_vec(key, v)?;
    // Scaled by the largest component first: [1e-300, 0, 0] and [1e200, 0, 0] are directions.
    octoarm_physics::math::normalize(v).ok_or_else(|| bad_vec(key, v, "of non-zero vectors"))
}

fn count(key: &str, v: usize, lo: usize, hi: usize) -> Result<(), Invalid> {
    if (lo..=hi).contains(&v) {
        Ok(())
    } else {
        Err(bad(key, v, format!("[{lo}, {hi}]")))
    }
}

/// At most `max` entries (tables, samples, points) under `key`.
fn at_most(key: &str, n: usize, max: usize, what: &str) -> Result<(), Invalid> {
    if n <= max {
        Ok(())
    } else {
        Err(bad(
            key,
            format!("{n} {what}"),
            format!("of at most {max} {what}"),
        ))
    }
}

fn increasing(key: &str, t: &[f64]) -> Result<(), Invalid> {
    for (i, w) in t.windows(2).enumerate() {
        if w[1].partial_cmp(&w[0]) != Some(std::cmp::Ordering::Greater) {
            return Err(bad(
                &format!("{key}[{}]", i + 1),
                w[1],
                format!("({key}[{i}] = {}, inf): strictly increasing", fmt_num(w[0])),
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
                format!("[time.dt = {}, inf), finite", fmt_sci(t.dt)),
            ));
        }
        if t.duration / t.dt > MAX_STEPS {
            return Err(bad(
                "time.duration",
                t.duration,
                format!("of at most {MAX_STEPS:e} steps of dt = {} s", fmt_sci(t.dt)),
            ));
        }
        if !(t.save_interval.is_finite() && t.save_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "time.save_interval",
                t.save_interval,
                format!("[time.dt = {}, inf), finite", fmt_sci(t.dt)),
            ));
        }

        at_most("load", self.loads.len(), MAX_ITEMS, "[[load]] tables")?;
        at_most(
            "obstacle",
            self.obstacles.len(),
            MAX_ITEMS,
            "[[obstacle]] tables",
        )?;
        at_most("plane", self.planes.len(), MAX_ITEMS, "[[plane]] tables")?;
        at_most(
            "cylinder",
            self.cylinders.len(),
            MAX_ITEMS,
            "[[cylinder]] tables",
        )?;
        at_most("joint", self.joints.len(), MAX_ITEMS, "[[joint]] tables")?;
        at_most("target", self.targets.len(), MAX_ITEMS, "[[target]] tables")?;
        at_most(
            "acceptance",
            self.acceptance.len(),
            MAX_CLAIMS,
            "[[acceptance]] tables",
        )?;

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
        if let Some(o) = self.numerics.clamp_order {
            if !(1..=2).contains(&o) {
                return Err(bad(
                    "numerics.clamp_order",
                    f64::from(o),
                    "{1, 2}".to_string(),
                ));
            }
        }
        for (key, v, hi) in [
            ("contact.friction_eta", self.contact.friction_eta, 1.0),
            ("contact.stick_stiffness", self.contact.stick_stiffness, 1.0),
            (
                "contact.slip_velocity",
                self.contact.slip_velocity,
                f64::INFINITY,
            ),
        ] {
            if let Some(v) = v {
                if !(v.is_finite() && v > 0.0 && v <= hi) {
                    let range = if hi.is_finite() {
                        format!("(0, {hi}]")
                    } else {
                        "(0, inf), finite".to_string()
                    };
                    return Err(bad(key, v, range));
                }
            }
        }
        check_friction(
            "contact.rod_friction",
            "contact.rod_kinetic_friction",
            self.contact.rod_friction,
            self.contact.rod_kinetic_friction,
        )?;

        for (i, load) in self.loads.iter().enumerate() {
            self.validate_load(i, load)?;
        }
        for (i, ob) in self.obstacles.iter().enumerate() {
            finite_vec(&format!("obstacle[{i}].center"), ob.center)?;
            positive(&format!("obstacle[{i}].diameter"), ob.diameter)?;
            finite_vec(&format!("obstacle[{i}].velocity"), ob.velocity)?;
            check_friction(
                &format!("obstacle[{i}].friction"),
                &format!("obstacle[{i}].kinetic_friction"),
                ob.friction,
                ob.kinetic_friction,
            )?;
        }
        for (i, p) in self.planes.iter().enumerate() {
            finite_vec(&format!("plane[{i}].point"), p.point)?;
            nonzero_vec(&format!("plane[{i}].normal"), p.normal)?;
            check_friction(
                &format!("plane[{i}].friction"),
                &format!("plane[{i}].kinetic_friction"),
                p.friction,
                p.kinetic_friction,
            )?;
        }
        for (i, c) in self.cylinders.iter().enumerate() {
            finite_vec(&format!("cylinder[{i}].center"), c.center)?;
            nonzero_vec(&format!("cylinder[{i}].axis"), c.axis)?;
            positive(&format!("cylinder[{i}].diameter"), c.diameter)?;
            non_negative(&format!("cylinder[{i}].length"), c.length)?;
            finite_vec(&format!("cylinder[{i}].velocity"), c.velocity)?;
            check_friction(
                &format!("cylinder[{i}].friction"),
                &format!("cylinder[{i}].kinetic_friction"),
                c.friction,
                c.kinetic_friction,
            )?;
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
        self.validate_muscles()?;
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
                        return Err(bad(
                            &k("s"),
                            s,
                            format!("[0, {}] m (the rod's length)", fmt_num(l)),
                        ));
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
            if !self.acceptance.is_empty() && self.muscle_control.is_none() {
                return Err(needs("acceptance"));
            }
            for (i, a) in self.acceptance.iter().enumerate() {
                if !a.quantity.is_muscle() {
                    return Err(rule(
                        &format!("acceptance[{i}].quantity"),
                        "is a quantity of [controller] runs, not of [muscle_control] runs",
                    ));
                }
                validate_acceptance(i, a)?;
            }
            return Ok(());
        };
        if self.muscle_control.is_some() {
            return Err(rule(
                "muscle_control",
                "[muscle_control] and [controller] exclude each other: a rod has one controller",
            ));
        }
        if let Some(i) = self.acceptance.iter().position(|a| a.quantity.is_muscle()) {
            return Err(rule(
                &format!("acceptance[{i}].quantity"),
                "is a quantity of [muscle_control] runs, not of [controller] runs",
            ));
        }
        let t = &self.time;
        if !(ctrl.series_interval.is_finite() && ctrl.series_interval >= t.dt * (1.0 - 1e-9)) {
            return Err(bad(
                "controller.series_interval",
                ctrl.series_interval,
                format!("[time.dt = {}, inf), finite", fmt_sci(t.dt)),
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
                        "(target[{}].from = {}, inf): targets in time order",
                        i - 1,
                        fmt_num(last_from)
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
            at_most("via_path.points", v.points.len(), MAX_SAMPLES, "points")?;
            for (i, p) in v.points.iter().enumerate() {
                finite_vec(&format!("via_path.points[{i}]"), *p)?;
            }
            non_negative("via_path.start", v.start)?;
            if !(v.end.is_finite() && v.end > v.start) {
                return Err(bad(
                    "via_path.end",
                    v.end,
                    format!("(via_path.start = {}, inf), finite", fmt_num(v.start)),
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
                    format!("[{}, {}]", fmt_num(a), fmt_num(b)),
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
        self.validate_solver_work(rod)?;
        for (key, v) in [
            ("solver.update_interval", sv.update_interval),
            ("solver.ramp_interval", sv.ramp_interval),
        ] {
            let v = v.expect("resolve() fills the intervals");
            if !(v.is_finite() && v >= t.dt * (1.0 - 1e-9)) {
                return Err(bad(
                    key,
                    v,
                    format!("[time.dt = {}, inf), finite", fmt_sci(t.dt)),
                ));
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

impl ScenarioConfig {
    /// `[muscles]` and `[muscle_control]`: in range, on a rod clamped at its base and free at
    /// its tip.
    fn validate_muscles(&self) -> Result<(), Invalid> {
        let Some(m) = &self.muscles else {
            if self.muscle_control.is_some() {
                return Err(rule(
                    "muscle_control",
                    "needs [muscles] (the rod's muscles); add it or remove this section",
                ));
            }
            return Ok(());
        };
        let r = self.find_rod("muscles.rod", m.rod.as_deref())?;
        let rod = &self.rods.list[r];
        if rod.base.kind() != EndKind::Clamped || rod.tip.kind() != EndKind::Free {
            return Err(rule(
                "muscles.rod",
                format!(
                    "the muscular arm must be clamped at its base and free at its tip (rod \"{}\" is {:?} / {:?})",
                    rod.name.as_deref().unwrap_or(""),
                    rod.base.kind(),
                    rod.tip.kind()
                ),
            ));
        }
        if rod.rest_schedule.is_some()
            || rod.rest_kappa.is_some()
            || rod.rest_sigma.is_some()
            || rod.rest_curvature != [0.0; 3]
        {
            return Err(rule(
                "muscles.rod",
                "the muscular arm is straight at rest (spec §1.1): remove its rest strains",
            ));
        }
        if !(m.water_density.is_finite() && m.water_density >= 0.0) {
            return Err(bad(
                "muscles.water_density",
                m.water_density,
                "[0, inf), finite",
            ));
        }
        if !m.gravity.iter().all(|v| v.is_finite()) {
            return Err(bad_vec(
                "muscles.gravity",
                m.gravity,
                "every component finite",
            ));
        }
        let Some(c) = &self.muscle_control else {
            return Ok(());
        };
        let dt = self.time.dt;
        for (key, v) in [
            ("muscle_control.update_interval", c.update_interval),
            ("muscle_control.series_interval", c.series_interval),
        ] {
            if !(v.is_finite() && v >= dt * (1.0 - 1e-9)) {
                return Err(bad(
                    key,
                    v,
                    format!("[time.dt = {}, inf), finite", fmt_sci(dt)),
                ));
            }
        }
        non_negative("muscle_control.ramp", c.ramp)?;
        for (key, v) in [
            ("muscle_control.position_weight", c.position_weight),
            ("muscle_control.orientation_weight", c.orientation_weight),
            ("muscle_control.attraction_weight", c.attraction_weight),
            ("muscle_control.obstacle_weight", c.obstacle_weight),
            ("muscle_control.sucker_weight", c.sucker_weight),
        ] {
            non_negative(key, v)?;
        }
        count(
            "muscle_control.max_iterations",
            c.max_iterations,
            1,
            100_000,
        )?;
        count("muscle_control.stages", c.stages, 1, 10)?;
        if let Some(v) = c.max_starts {
            count("muscle_control.max_starts", v, 1, 1000)?;
        }
        if let Some(v) = c.max_total_iterations {
            count("muscle_control.max_total_iterations", v, 1, 10_000_000)?;
        }
        if let Some(groups) = &c.groups {
            for (i, g) in groups.iter().enumerate() {
                if !super::config::MUSCLE_GROUP_NAMES.contains(&g.as_str()) {
                    return Err(rule(
                        &format!("muscle_control.groups[{i}]"),
                        format!(
                            "\"{g}\" is not a group; the groups are {}",
                            super::config::MUSCLE_GROUP_NAMES.join(", ")
                        ),
                    ));
                }
            }
        }
        match c.task {
            super::config::MuscleTaskKind::Reach => match (c.target, c.target_seed) {
                (Some(t), None) => finite_vec("muscle_control.target", t)?,
                (None, Some(_)) => {}
                (None, None) => {
                    return Err(rule(
                        "muscle_control.target",
                        "missing: a reach needs the tip point [x, y, z] in m (or target_seed)",
                    ))
                }
                (Some(_), Some(_)) => {
                    return Err(rule(
                        "muscle_control.target_seed",
                        "give either target or target_seed, not both",
                    ))
                }
            },
            super::config::MuscleTaskKind::Grasp => {
                if self.cylinders.is_empty() {
                    return Err(rule(
                        "muscle_control.task",
                        "a grasp needs the object as [[cylinder]] (the first one is grasped)",
                    ));
                }
                if c.target.is_some() || c.target_seed.is_some() {
                    return Err(rule(
                        "muscle_control.target",
                        "a grasp has no tip target; remove target / target_seed",
                    ));
                }
            }
        }
        for (i, a) in self.acceptance.iter().enumerate() {
            if a.quantity == AcceptanceQuantity::MuscleGroupIntegral {
                match &a.group {
                    Some(g) if super::config::MUSCLE_GROUP_NAMES.contains(&g.as_str()) => {}
                    _ => {
                        return Err(rule(
                            &format!("acceptance[{i}].group"),
                            format!(
                                "muscle_group_integral needs group = one of {}",
                                super::config::MUSCLE_GROUP_NAMES.join(", ")
                            ),
                        ))
                    }
                }
            } else if a.group.is_some() {
                return Err(rule(
                    &format!("acceptance[{i}].group"),
                    "is not a key of this quantity",
                ));
            }
        }
        Ok(())
    }

    /// The solver's memory and work against their bounds (`MAX_LBFGS_BYTES`, `MAX_UPDATE_WORK`,
    /// `MAX_OFFLINE_WORK`): no setting may make the controller allocate gigabytes or compute
    /// for hours without the run showing progress.
    fn validate_solver_work(&self, rod: &RodConfig) -> Result<(), Invalid> {
        let Some(sv) = &self.solver else {
            return Ok(());
        };
        let n = rod.n_elements;
        let name = rod.name.as_deref().unwrap_or("rod");
        let strains = (6 * n - 3) as f64;
        if sv.rule == RuleKind::Lbfgs {
            let bytes = 16.0 * sv.lbfgs_memory as f64 * strains;
            if bytes > MAX_LBFGS_BYTES {
                let max = (MAX_LBFGS_BYTES / (16.0 * strains)).floor().max(1.0) as usize;
                return Err(bad(
                    "solver.lbfgs_memory",
                    sv.lbfgs_memory,
                    format!(
                        "[1, {max}] for the {n} elements of rod \"{name}\" (its L-BFGS pairs take \
                         16 x memory x (6N - 3) bytes = {}, at most {})",
                        fmt_bytes(bytes),
                        fmt_bytes(MAX_LBFGS_BYTES)
                    ),
                ));
            }
        }
        let nodes = (n + 1) as f64;
        match sv.mode {
            SolverModeKind::Online => {
                let work = sv.iterations_per_update as f64 * nodes;
                if work > MAX_UPDATE_WORK {
                    let max = (MAX_UPDATE_WORK / nodes).floor().max(1.0) as usize;
                    return Err(bad(
                        "solver.iterations_per_update",
                        sv.iterations_per_update,
                        format!(
                            "[1, {max}] for the {n} elements of rod \"{name}\": one update would take \
                             {} node-iterations (at most {:e}, seconds of computing); use fewer \
                             iterations per update or a shorter solver.update_interval",
                            fmt_num(work),
                            MAX_UPDATE_WORK
                        ),
                    ));
                }
            }
            SolverModeKind::Offline => {
                let designs = self.targets.len().max(1) as f64
                    + self
                        .via_path
                        .as_ref()
                        .map_or(0.0, |v| v.points.len() as f64 + 1.0);
                let stages = if self.grasp.is_some() {
                    sv.grasp_stages as f64
                } else {
                    1.0
                };
                let work = designs * stages * sv.max_sweeps as f64 * nodes;
                if work > MAX_OFFLINE_WORK {
                    // Blame the grasp stages when they are above their default of 4.
                    let (key, value) = if stages > 4.0 {
                        ("solver.grasp_stages", sv.grasp_stages)
                    } else {
                        ("solver.max_sweeps", sv.max_sweeps)
                    };
                    return Err(bad(
                        key,
                        value,
                        format!(
                            "of settings whose offline solves take at most {:e} node-sweeps before \
                             t = 0 (hours): {} design(s) x {} grasp stage(s) x max_sweeps \
                             {} x {} nodes = {}; lower solver.max_sweeps or solver.grasp_stages",
                            MAX_OFFLINE_WORK,
                            designs,
                            stages,
                            sv.max_sweeps,
                            n + 1,
                            fmt_num(work)
                        ),
                    ));
                }
            }
        }
        Ok(())
    }
}

/// Bytes in kB, MB, GB or TB with 3 significant digits (`19.3 GB`, `1.23 MB`).
pub fn fmt_bytes(bytes: f64) -> String {
    let (v, unit) = [(1e12, "TB"), (1e9, "GB"), (1e6, "MB"), (1e3, "kB")]
        .into_iter()
        .find(|(scale, _)| bytes >= *scale)
        .map_or((bytes, "B"), |(scale, unit)| (bytes / scale, unit));
    if unit == "B" {
        return format!("{} B", bytes.round());
    }
    let decimals = if v >= 100.0 {
        0
    } else if v >= 10.0 {
        1
    } else {
        2
    };
    let text = format!("{v:.decimals$}");
    // 999.6 kB rounds to "1000 kB": say 1.00 MB.
    if text.starts_with("1000") && unit != "TB" {
        let next = match unit {
            "kB" => "MB",
            "MB" => "GB",
            _ => "TB",
        };
        return format!("1.00 {next}");
    }
    format!("{text} {unit}")
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
            at_most(&ks, f.s.len(), MAX_SAMPLES, "samples")?;
            if f.value.len() != f.s.len() {
                return Err(bad(
                    &format!("{key}.value"),
                    format!("{} vectors", f.value.len()),
                    format!("of one vector per s ({})", f.s.len()),
                ));
            }
            for (i, s) in f.s.iter().enumerate() {
                if !(s.is_finite() && (0.0..=length).contains(s)) {
                    return Err(bad(
                        &format!("{ks}[{i}]"),
                        *s,
                        format!("[0, {}] m", fmt_num(length)),
                    ));
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
            at_most(&k("times"), times.len(), MAX_SAMPLES, "samples")?;
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
            at_most(&k("times"), times.len(), MAX_SAMPLES, "samples")?;
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
        Q::DistanceBefore
            | Q::DistanceAfter
            | Q::DistanceAt
            | Q::DesignTipError
            | Q::TipErrorAt
            | Q::OrientationErrorAt
            | Q::TipErrorRise
            | Q::HamiltonianRise
            | Q::HamiltonianChange
            | Q::NodeDeviation
            | Q::GraspPenetration
            | Q::GraspWrapAngle
            | Q::GraspMeanGap
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
                return Err(bad(&k("to"), t, format!("[from = {}, inf)", fmt_num(f))));
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
