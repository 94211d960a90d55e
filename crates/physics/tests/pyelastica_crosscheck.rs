//! Claim: octoarm's rod model and stepper reproduce another simulator, PyElastica 1.0.0, in
//! general 3D motion — a tapered clamped rod with twist and out-of-plane motion (every
//! internal-load term, gyroscopic and unsteady-dilatation torques included); a clamped rod under
//! gravity, a lab tip couple and a tip force on all three axes with the uniform analytical damper;
//! a free rod with a 3D rest curvature (κ1, κ2, κ3 ≠ 0) curling up under the physical damper; and
//! an obliquely oriented clamped rod with a rest shear/stretch σ°, a uniform lab couple, a tip
//! force and the legacy damper. Positions, velocities, directors and angular velocities agree at
//! every stored time (up to 5000 steps, displacements up to 40 % of the rod length, director
//! changes up to 1.1) to 1e-9 of each quantity's scale. Measured (max over cases): positions
//! 7e-13, directors 3.4e-12, velocities 1.5e-11, angular velocities 1.1e-10 of scale; PyElastica's
//! derived model arrays equal ours to 2e-16 (docs/physics.md, "Cross-check against PyElastica").
//!
//! Independent reference: tests/data/pyelastica_reference.json, written by
//! scripts/pyelastica_reference.py with PyElastica's own CosseratRod, PositionVerlet,
//! OneEndFixedBC, GravityForces, EndpointForces, UniformTorques and AnalyticalLinearDamper. The
//! file also holds the rest lengths and radii PyElastica built, its initial state, and its derived
//! model arrays (node masses, inertias, shear and bend stiffnesses, rest Voronoi lengths), which
//! are checked first and separately. Both codes run the same algorithm (spec §1–§9) but are
//! written independently with a different floating-point order, and PyElastica's kernels carry a
//! few deliberate epsilons (element lengths + 1e-14 m, rotation axes normalised by |ω| + 1e-14,
//! the curvature Log through arccos(trace) + 1e-14, the dilatation rate from x·v products): relative
//! perturbations of 3e-13 (forces, via 1/e) to 1e-12 (couples, via 1/ε³) here. Adding the same
//! 1e-14 m to our element lengths (a diagnostic, not kept) cut the position differences by 5–24×
//! to ≤ 5e-14 and the director differences by 3–50× to ≤ 1.3e-13 of scale.
//!
//! Tolerance: for each case and quantity, max |ours − PyElastica| over all nodes/elements and
//! stored times ≤ 1e-9 × the quantity's scale (positions: the largest displacement from the
//! initial state; directors: the largest change |Q − Q0|; velocities and angular velocities: their
//! largest magnitude). None of the motions is chaotic over these short runs: the differences grow
//! about linearly in time. They are largest in ω because ω carries the stiff shear–rotation modes
//! (ω_max ≈ 10⁴ rad/s), whose phase error after t = 0.2 s is ω_max t ≈ 2000 times a relative
//! round-off perturbation; so 1e-9 leaves a factor of 10 for ω (1e3 or more elsewhere) to absorb
//! a different round-off pattern, and is still seven orders of magnitude below the effect of the
//! smallest modelling change tried (below).
//!
//! How a wrong implementation fails: a sign, factor or index error in any internal load (shear
//! coefficient, 1/e or 1/ε³ factors, the ½(h_j + h_{j−1}) bend–twist average, the shear–stretch
//! couple, the gyroscopic or unsteady-dilatation torque, Voronoi stiffness weighting), in the
//! lumped masses or inertias, in the rotation update or curvature Log, in the stage order of the
//! step, in the clamp, in a load mapping (lab vs material couples, ramps, gravity on node
//! masses, UniformTorques' 1/n share) or in a damper parameterisation (exponent e on the
//! rotational factors, the legacy element masses) changes the trajectory at first order in that
//! term. Even the energy-consistent correction (eq. 4.5), second order in strain, moves the
//! result by far more than the tolerance (checked below), as does α_c = 4/3 instead of 27/28.

use octoarm_physics::{
    AnalyticalDamper, Damping, EndCondition, Load, Mat3, Material, RodModel, RodState, Schedule,
    Settings, Simulation, Vec3,
};
use std::collections::BTreeMap;

/// Relative agreement required for every quantity (see the header).
const TOL: f64 = 1e-9;
/// Relative agreement required for PyElastica's derived model arrays (one or two roundings).
const MODEL_TOL: f64 = 1e-14;

// ---------------------------------------------------------------------------------------------
// A minimal JSON reader: the physics crate has no serde, and `str::parse::<f64>` is correctly
// rounded, so Python's repr floats come back bit for bit.

#[derive(Debug, Clone)]
enum Json {
    Null,
    Num(f64),
    Str(String),
    Arr(Vec<Json>),
    Obj(BTreeMap<String, Json>),
}

struct Parser<'a> {
    s: &'a [u8],
    i: usize,
}

impl Parser<'_> {
    fn ws(&mut self) {
        while self.i < self.s.len() && self.s[self.i].is_ascii_whitespace() {
            self.i += 1;
        }
    }

    fn eat(&mut self, c: u8) {
        self.ws();
        assert_eq!(
            self.s[self.i], c,
            "JSON: expected '{}' at {}",
            c as char, self.i
        );
        self.i += 1;
    }

    fn value(&mut self) -> Json {
        self.ws();
        match self.s[self.i] {
            b'{' => {
                self.i += 1;
                let mut m = BTreeMap::new();
                self.ws();
                if self.s[self.i] == b'}' {
                    self.i += 1;
                    return Json::Obj(m);
                }
                loop {
                    self.ws();
                    let Json::Str(k) = self.value() else {
                        panic!("JSON: object key at {}", self.i)
                    };
                    self.eat(b':');
                    let v = self.value();
                    m.insert(k, v);
                    self.ws();
                    self.i += 1;
                    match self.s[self.i - 1] {
                        b',' => continue,
                        b'}' => return Json::Obj(m),
                        c => panic!("JSON: unexpected '{}' at {}", c as char, self.i),
                    }
                }
            }
            b'[' => {
                self.i += 1;
                let mut a = Vec::new();
                self.ws();
                if self.s[self.i] == b']' {
                    self.i += 1;
                    return Json::Arr(a);
                }
                loop {
                    a.push(self.value());
                    self.ws();
                    self.i += 1;
                    match self.s[self.i - 1] {
                        b',' => continue,
                        b']' => return Json::Arr(a),
                        c => panic!("JSON: unexpected '{}' at {}", c as char, self.i),
                    }
                }
            }
            b'"' => {
                self.i += 1;
                let mut out = String::new();
                loop {
                    let c = self.s[self.i];
                    self.i += 1;
                    match c {
                        b'"' => return Json::Str(out),
                        b'\\' => {
                            let e = self.s[self.i];
                            self.i += 1;
                            out.push(match e {
                                b'n' => '\n',
                                b't' => '\t',
                                b'"' | b'\\' | b'/' => e as char,
                                _ => panic!("JSON: unsupported escape at {}", self.i),
                            });
                        }
                        _ => {
                            // Copy one UTF-8 character.
                            let start = self.i - 1;
                            let mut end = self.i;
                            while end < self.s.len() && (self.s[end] & 0xC0) == 0x80 {
                                end += 1;
                            }
                            out.push_str(std::str::from_utf8(&self.s[start..end]).unwrap());
                            self.i = end;
                        }
                    }
                }
            }
            b'n' => {
                self.i += 4;
                Json::Null
            }
            _ => {
                let start = self.i;
                while self.i < self.s.len()
                    && matches!(
                        self.s[self.i],
                        b'-' | b'+' | b'.' | b'e' | b'E' | b'0'..=b'9'
                    )
                {
                    self.i += 1;
                }
                let text = std::str::from_utf8(&self.s[start..self.i]).unwrap();
                Json::Num(
                    text.parse()
                        .unwrap_or_else(|_| panic!("JSON: bad number {text:?}")),
                )
            }
        }
    }
}

impl Json {
    fn parse(text: &str) -> Json {
        let mut p = Parser {
            s: text.as_bytes(),
            i: 0,
        };
        let v = p.value();
        p.ws();
        assert_eq!(p.i, p.s.len(), "JSON: trailing data");
        v
    }

    fn get(&self, key: &str) -> &Json {
        match self {
            Json::Obj(m) => m
                .get(key)
                .unwrap_or_else(|| panic!("JSON: missing key {key:?}")),
            _ => panic!("JSON: not an object (looking for {key:?})"),
        }
    }

    fn opt(&self, key: &str) -> Option<&Json> {
        match self {
            Json::Obj(m) => m.get(key).filter(|v| !matches!(v, Json::Null)),
            _ => None,
        }
    }

    fn f(&self) -> f64 {
        match self {
            Json::Num(x) => *x,
            _ => panic!("JSON: not a number: {self:?}"),
        }
    }

    fn s(&self) -> &str {
        match self {
            Json::Str(x) => x,
            _ => panic!("JSON: not a string: {self:?}"),
        }
    }

    fn arr(&self) -> &[Json] {
        match self {
            Json::Arr(a) => a,
            _ => panic!("JSON: not an array: {self:?}"),
        }
    }

    fn scalars(&self) -> Vec<f64> {
        self.arr().iter().map(Json::f).collect()
    }

    fn vec3(&self) -> Vec3 {
        let a = self.scalars();
        assert_eq!(a.len(), 3);
        [a[0], a[1], a[2]]
    }

    fn vec3s(&self) -> Vec<Vec3> {
        self.arr().iter().map(Json::vec3).collect()
    }

    fn mats(&self) -> Vec<Mat3> {
        self.arr()
            .iter()
            .map(|m| {
                let r = m.vec3s();
                assert_eq!(r.len(), 3);
                [r[0], r[1], r[2]]
            })
            .collect()
    }
}

fn reference() -> Json {
    let path = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/tests/data/pyelastica_reference.json"
    );
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{path}: {e}"));
    Json::parse(&text)
}

// ---------------------------------------------------------------------------------------------

fn state_of(snap: &Json) -> RodState {
    RodState {
        time: snap.get("time").f(),
        position: snap.get("position").vec3s(),
        velocity: snap.get("velocity").vec3s(),
        director: snap.get("director").mats(),
        omega: snap.get("omega").vec3s(),
    }
}

/// The end conditions (base, tip) of a case: PyElastica's OneEndFixedBC clamps the base.
fn ends_of(case: &Json) -> (EndCondition, EndCondition) {
    match case.get("boundary").s() {
        "clamped" => (EndCondition::Clamped, EndCondition::Free),
        "free" => (EndCondition::Free, EndCondition::Free),
        b => panic!("unknown boundary {b}"),
    }
}

/// The ramp of a PyElastica endpoint load: linear over `ramp_time` s, none for 0.
fn ramp_of(ramp_time: f64) -> Schedule {
    if ramp_time > 0.0 {
        Schedule::Ramp {
            duration: ramp_time,
        }
    } else {
        Schedule::Constant
    }
}

fn model_of(case: &Json, shear_coefficient: f64) -> RodModel {
    let material = Material {
        density: case.get("density").f(),
        youngs_modulus: case.get("youngs_modulus").f(),
        shear_modulus: case.get("shear_modulus").f(),
        shear_coefficient,
    };
    let mut model = RodModel::from_elements(
        &case.get("rest_length").scalars(),
        &case.get("radius").scalars(),
        material,
    )
    .unwrap();
    let n = model.n_elements;
    let sigma = case.get("rest_sigma").vec3();
    let kappa = case.get("rest_kappa").vec3();
    model
        .set_rest_strains(&vec![sigma; n], &vec![kappa; n - 1])
        .unwrap();
    model
}

/// The octoarm simulation of one reference case, built from the file alone.
fn simulation_of(case: &Json, shear_coefficient: f64, energy_consistent: bool) -> Simulation {
    let model = model_of(case, shear_coefficient);
    let n = model.n_elements;
    let length = model.length();
    let mut settings = Settings::with_dt(case.get("dt").f());
    settings.energy_consistent = energy_consistent;
    let (base, tip) = ends_of(case);
    let mut sim =
        Simulation::with_ends(model, state_of(case.get("initial")), base, tip, settings).unwrap();
    let loads = case.get("loads");
    if let Some(g) = loads.opt("gravity") {
        sim.add_load(Load::Gravity {
            acceleration: g.vec3(),
        })
        .unwrap();
    }
    if let Some(p) = loads.opt("tip_force") {
        sim.add_scheduled_load(
            Load::NodeForce {
                node: n,
                force: p.get("force").vec3(),
            },
            ramp_of(p.get("ramp_time").f()),
        )
        .unwrap();
    }
    if let Some(m) = loads.opt("tip_couple") {
        sim.add_scheduled_load(
            Load::ElementCouple {
                element: n - 1,
                couple: m.get("couple").vec3(),
            },
            ramp_of(m.get("ramp_time").f()),
        )
        .unwrap();
    }
    if let Some(m) = loads.opt("uniform_torque") {
        // UniformTorques puts Q_j M / n on every element; ours adds Q_j c l̂_j, so c = M / L.
        let m = m.vec3();
        sim.add_load(Load::UniformCouple {
            couple_per_length: [m[0] / length, m[1] / length, m[2] / length],
        })
        .unwrap();
    }
    if let Some(d) = case.opt("damper") {
        let analytical = match d.get("kind").s() {
            "uniform" => AnalyticalDamper::Uniform {
                nu: d.get("nu").f(),
            },
            "physical" => AnalyticalDamper::Physical {
                translational: d.get("translational").f(),
                rotational: d.get("rotational").f(),
            },
            "legacy" => AnalyticalDamper::Legacy {
                nu: d.get("nu").f(),
            },
            k => panic!("unknown damper {k}"),
        };
        sim.set_damping(Damping {
            analytical: Some(analytical),
            ..Damping::default()
        })
        .unwrap();
    }
    sim
}

/// Largest differences over all stored times, each divided by its scale (see the header), in the
/// order position, velocity, director, omega.
fn compare(case: &Json, sim: &mut Simulation) -> [f64; 4] {
    let initial = state_of(case.get("initial"));
    let snaps: Vec<RodState> = case.get("snapshots").arr().iter().map(state_of).collect();
    let steps: Vec<u64> = case
        .get("snapshots")
        .arr()
        .iter()
        .map(|s| s.get("step").f() as u64)
        .collect();
    let max3 = |a: Vec3, b: Vec3| (0..3).map(|c| (a[c] - b[c]).abs()).fold(0.0, f64::max);
    let max9 = |a: &Mat3, b: &Mat3| (0..3).map(|r| max3(a[r], b[r])).fold(0.0, f64::max);
    let mut scale = [0.0f64; 4];
    for s in std::iter::once(&initial).chain(&snaps) {
        for (x, x0) in s.position.iter().zip(&initial.position) {
            scale[0] = scale[0].max(max3(*x, *x0));
        }
        for v in &s.velocity {
            scale[1] = scale[1].max(max3(*v, [0.0; 3]));
        }
        for (q, q0) in s.director.iter().zip(&initial.director) {
            scale[2] = scale[2].max(max9(q, q0));
        }
        for w in &s.omega {
            scale[3] = scale[3].max(max3(*w, [0.0; 3]));
        }
    }
    let mut err = [0.0f64; 4];
    for (snap, &step) in snaps.iter().zip(&steps) {
        sim.run(step - sim.steps()).unwrap();
        let s = sim.rod_state();
        assert!(
            (s.time - snap.time).abs() < 1e-12,
            "time {} vs {}",
            s.time,
            snap.time
        );
        for (a, b) in s.position.iter().zip(&snap.position) {
            err[0] = err[0].max(max3(*a, *b));
        }
        for (a, b) in s.velocity.iter().zip(&snap.velocity) {
            err[1] = err[1].max(max3(*a, *b));
        }
        for (a, b) in s.director.iter().zip(&snap.director) {
            err[2] = err[2].max(max9(a, b));
        }
        for (a, b) in s.omega.iter().zip(&snap.omega) {
            err[3] = err[3].max(max3(*a, *b));
        }
    }
    for k in 0..4 {
        assert!(scale[k] > 0.0, "case without motion in quantity {k}");
        err[k] /= scale[k];
    }
    err
}

const NAMES: [&str; 4] = ["position", "velocity", "director", "omega"];

fn cases() -> Vec<Json> {
    let data = reference();
    assert_eq!(data.get("pyelastica_version").s(), "1.0.0");
    let cases = data.get("cases").arr().to_vec();
    assert_eq!(cases.len(), 4);
    cases
}

/// PyElastica's derived model arrays (spec §1, §3) equal ours from the same rest lengths and radii.
#[test]
fn model_arrays_match_pyelastica() {
    for case in cases() {
        let name = case.get("name").s();
        let m = model_of(&case, Material::DEFAULT_SHEAR_COEFFICIENT);
        let py = case.get("pyelastica_model");
        let rel = |a: f64, b: f64| (a - b).abs() / b.abs();
        let mut worst = 0.0f64;
        for (a, b) in m.node_mass.iter().zip(py.get("node_mass").scalars()) {
            worst = worst.max(rel(*a, b));
        }
        for (field, ours) in [
            ("inertia", &m.inertia),
            ("shear_stiffness", &m.shear_stiffness),
            ("bend_stiffness", &m.bend_stiffness),
        ] {
            let theirs = py.get(field).vec3s();
            assert_eq!(ours.len(), theirs.len(), "{name}: {field} length");
            for (a, b) in ours.iter().zip(&theirs) {
                for c in 0..3 {
                    worst = worst.max(rel(a[c], b[c]));
                }
            }
        }
        for (a, b) in m
            .rest_voronoi_length
            .iter()
            .zip(py.get("rest_voronoi_length").scalars())
        {
            worst = worst.max(rel(*a, b));
        }
        println!("{name}: model arrays max relative difference {worst:.2e}");
        assert!(worst < MODEL_TOL, "{name}: {worst:.3e}");
    }
}

/// The trajectories of all four cases agree with PyElastica's to 1e-9 of their scales.
#[test]
fn trajectories_match_pyelastica() {
    for case in cases() {
        let name = case.get("name").s();
        let mut sim = simulation_of(&case, Material::DEFAULT_SHEAR_COEFFICIENT, false);
        let err = compare(&case, &mut sim);
        println!(
            "{name}: max |Δ|/scale  x {:.2e}  v {:.2e}  Q {:.2e}  ω {:.2e}",
            err[0], err[1], err[2], err[3]
        );
        for k in 0..4 {
            assert!(
                err[k] <= TOL,
                "{name}: {} differs from PyElastica by {:.3e} of its scale (allowed {TOL:e})",
                NAMES[k],
                err[k]
            );
        }
    }
}

/// The comparison is sensitive: modelling changes far smaller than a typical bug (the
/// second-order energy-consistent tension of eq. 4.5; PyElastica's old α_c = 4/3) fail it by
/// orders of magnitude.
#[test]
fn crosscheck_detects_small_model_changes() {
    let case = &cases()[0];
    for (label, alpha, consistent) in [
        (
            "energy_consistent",
            Material::DEFAULT_SHEAR_COEFFICIENT,
            true,
        ),
        ("alpha_c = 4/3", 4.0 / 3.0, false),
    ] {
        let mut sim = simulation_of(case, alpha, consistent);
        let err = compare(case, &mut sim);
        let worst = err.iter().copied().fold(0.0, f64::max);
        println!("{label}: max |Δ|/scale {worst:.2e}");
        assert!(worst > 1e3 * TOL, "{label}: only {worst:.3e}");
    }
}
