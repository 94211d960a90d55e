//! Scenario → physics and control objects: the rods (models shared where the geometry is
//! identical), their end conditions, rest strains and schedules, damping, loads, obstacles,
//! joints and initial state (`build_system`), and the controllers (`build_controllers`, which
//! runs the offline design solves). The only place where scenario sections turn into physics or
//! control types; a rejection is reported at the key it concerns.

use crate::initial;
use crate::scenario::*;
use octoarm_control::{
    ControlError, Controller, DesignMode, GraspSpec, ShapingController, ShapingControllerConfig,
    SphereSpec, Statics, StaticsError, StrainSpace, TargetPhase, TaskError, TaskSchedule,
    UpdateRule,
};
use octoarm_physics::{
    AnalyticalDamper, ContactParams, Damping, EndCondition, Joint, JointEnd, JointKind,
    JointParams, Load, Material, ModelError, Motion, RestChange, RodGeometry, RodModel, RodSpec,
    RodSystem, Schedule, Settings, Side, Sphere, StraightRod, SystemBuilder, SystemState,
};
use std::sync::Arc;

/// The straight rod of a rod section (tip diameter resolved to the base's if absent).
pub fn straight_rod(r: &RodConfig) -> StraightRod {
    StraightRod {
        n_elements: r.n_elements,
        length: r.length,
        base_diameter: r.base_diameter,
        tip_diameter: r.tip_diameter.unwrap_or(r.base_diameter),
        material: Material {
            density: r.density,
            youngs_modulus: r.youngs_modulus,
            shear_modulus: r.shear_modulus,
            shear_coefficient: r.shear_coefficient,
        },
        base_position: r.base_position,
        direction: r.direction,
        normal: r.normal,
        rest_curvature: r.rest_curvature,
    }
}

/// The physics damping of `[damping]`.
pub fn damping(d: &DampingConfig) -> Damping {
    match d.protocol {
        DampingProtocol::Exact => Damping {
            rate: d.rate,
            gamma: d.gamma,
            analytical: None,
        },
        DampingProtocol::Pyelastica => Damping {
            rate: 0.0,
            gamma: 0.0,
            analytical: (d.rate > 0.0).then_some(AnalyticalDamper::Uniform { nu: d.rate }),
        },
    }
}

/// A schedule of the scenario (validated).
pub fn schedule(s: &ScheduleConfig) -> Schedule {
    match s.kind {
        ScheduleKind::Constant => Schedule::Constant,
        ScheduleKind::Ramp => Schedule::Ramp {
            duration: s.duration.unwrap_or(1.0),
        },
        ScheduleKind::Step => Schedule::Step {
            time: s.time.unwrap_or(0.0),
        },
        ScheduleKind::PiecewiseLinear => Schedule::PiecewiseLinear {
            times: s.times.clone().unwrap_or_default(),
            values: s.values.clone().unwrap_or_default(),
        },
    }
}

/// A physics error in words, numbers with at most 6 significant digits.
fn model_message(e: &ModelError) -> String {
    match e {
        ModelError::OutOfRange {
            field,
            value,
            range,
        } => format!(
            "{field} = {} is outside the allowed range {range}",
            fmt_num(*value)
        ),
        ModelError::BadVector {
            field,
            value,
            reason,
        } => format!("{field} = {} is invalid: {reason}", fmt_vec(*value)),
        other => other.to_string(),
    }
}

fn field_of(e: &ModelError) -> &'static str {
    match e {
        ModelError::OutOfRange { field, .. }
        | ModelError::CountOutOfRange { field, .. }
        | ModelError::BadVector { field, .. }
        | ModelError::DuplicateName { field, .. }
        | ModelError::BadLength { field, .. } => field,
    }
}

/// Values of a profile at the given arc lengths (`at`, one per entry).
fn profile_values(p: &Profile, at: &[f64]) -> Vec<[f64; 3]> {
    match p {
        Profile::Uniform(v) => vec![*v; at.len()],
        Profile::PerEntry(v) => v.clone(),
        Profile::Function(f) => at
            .iter()
            .map(|&s| {
                let n = f.s.len();
                if s <= f.s[0] {
                    return f.value[0];
                }
                if s >= f.s[n - 1] {
                    return f.value[n - 1];
                }
                let i = f.s.partition_point(|&x| x <= s) - 1;
                let u = (s - f.s[i]) / (f.s[i + 1] - f.s[i]);
                let (a, b) = (f.value[i], f.value[i + 1]);
                [
                    a[0] + u * (b[0] - a[0]),
                    a[1] + u * (b[1] - a[1]),
                    a[2] + u * (b[2] - a[2]),
                ]
            })
            .collect(),
    }
}

fn end_condition(e: &EndConfig) -> EndCondition {
    match e.kind() {
        EndKind::Free => EndCondition::Free,
        EndKind::Pinned => EndCondition::Pinned,
        EndKind::Clamped => EndCondition::Clamped,
        EndKind::Driven => {
            let EndConfig::Table(t) = e else {
                unreachable!("validated: a driven end is a table")
            };
            let times = t.times.clone().unwrap_or_default();
            let n = times.len();
            EndCondition::Driven(Motion {
                displacement: t.displacement.clone().unwrap_or(vec![[0.0; 3]; n]),
                rotation: t.rotation.clone().unwrap_or(vec![[0.0; 3]; n]),
                times,
                slides_along: None,
            })
        }
    }
}

/// The rest strains a rod section gives (σ° per element, κ° per interior node), or None when
/// it gives only the uniform `rest_curvature` (built by `StraightRod` itself).
/// Rest strains of a rod: σ° per element and κ° per interior node.
type RestFields = (Vec<[f64; 3]>, Vec<[f64; 3]>);

fn rest_strains(r: &RodConfig, model: &RodModel) -> Option<RestFields> {
    if r.rest_sigma.is_none() && r.rest_kappa.is_none() {
        return None;
    }
    let n = model.n_elements;
    let mid: Vec<f64> = (0..n)
        .map(|j| model.element_midpoint_arc_length(j))
        .collect();
    let interior: Vec<f64> = (0..n - 1).map(|k| model.node_arc_length[k + 1]).collect();
    let sigma = r
        .rest_sigma
        .as_ref()
        .map_or(vec![[0.0; 3]; n], |p| profile_values(p, &mid));
    let kappa = match &r.rest_kappa {
        Some(p) => profile_values(p, &interior),
        None => vec![r.rest_curvature; n - 1],
    };
    Some((sigma, kappa))
}

/// Build the rod system and its initial state of a scenario (fast: no controller solves).
pub fn build_system(scn: &Scenario) -> Result<(RodSystem, SystemState), ScenarioError> {
    let cfg = &scn.config;
    let located =
        |key: String, e: ModelError| scn.error_at(&key, format!("{key}: {}", model_message(&e)));
    let settings = Settings {
        dt: cfg.time.dt,
        energy_consistent: cfg.numerics.energy_consistent,
        guard_interval: cfg.numerics.guard_interval,
        clamp_order: cfg.numerics.clamp_order.unwrap_or(1),
        max_dt_fraction: cfg.time.auto_dt.then_some(octoarm_physics::AUTO_DT_RECHECK),
        ..Settings::default()
    };
    let mut builder = SystemBuilder::new(settings);
    // (geometry, model) of rods already built: identical sections share one model.
    let mut models: Vec<(StraightRod, Option<RestFields>, Arc<RodModel>)> = Vec::new();
    let mut changes = Vec::new();
    let mut rod_models: Vec<Arc<RodModel>> = Vec::new();
    let damping = damping(&cfg.damping);
    for (i, r) in cfg.rods.list.iter().enumerate() {
        let key = cfg.rod_key(i);
        let mut rod = straight_rod(r);
        if r.rest_schedule.is_some() {
            rod.rest_curvature = [0.0; 3];
        }
        let (mut model, state) = rod
            .build()
            .map_err(|e| located(format!("{key}.{}", field_of(&e)), e))?;
        let given = if r.rest_schedule.is_some() {
            let mut plain = r.clone();
            if plain.rest_kappa.is_none() {
                plain.rest_kappa = Some(Profile::Uniform(r.rest_curvature));
            }
            rest_strains(&plain, &model)
        } else {
            rest_strains(r, &model)
        };
        if let (Some((s, k)), None) = (&given, &r.rest_schedule) {
            model
                .set_rest_strains(s, k)
                .map_err(|e| located(format!("{key}.{}", field_of(&e)), e))?;
        }
        check_derived(scn, &key, r, &model, given.as_ref(), &state)?;
        let shared_key = (
            rod.clone(),
            given.clone().filter(|_| r.rest_schedule.is_none()),
        );
        let model = match models
            .iter()
            .find(|(g, s, _)| *g == shared_key.0 && *s == shared_key.1)
        {
            Some((_, _, m)) => Arc::clone(m),
            None => {
                let m = Arc::new(model);
                models.push((shared_key.0, shared_key.1, Arc::clone(&m)));
                m
            }
        };
        if let (Some((s, k)), Some(sch)) = (given, &r.rest_schedule) {
            changes.push(RestChange {
                rod: i,
                sigma: s,
                kappa: k,
                schedule: schedule(sch),
            });
        }
        rod_models.push(Arc::clone(&model));
        builder.rod(RodSpec {
            name: r.name.clone().unwrap_or_else(|| format!("rod{i}")),
            model,
            state,
            base: end_condition(&r.base),
            tip: end_condition(&r.tip),
            damping,
        });
    }
    for (i, j) in cfg.joints.iter().enumerate() {
        let key = format!("joint[{i}]");
        let end = |k: &str, s: &str| -> Result<JointEnd, ScenarioError> {
            let (rod, tip) = cfg
                .joint_end(k, s)
                .map_err(|b| scn.error_at(&b.key, b.to_string()))?;
            Ok(JointEnd {
                rod,
                side: if tip { Side::Tip } else { Side::Base },
            })
        };
        let a = end(&format!("{key}.first"), &j.first)?;
        let b = end(&format!("{key}.second"), &j.second)?;
        let mut params =
            JointParams::default_for((&rod_models[a.rod], a.side), (&rod_models[b.rod], b.side));
        if let Some(v) = j.stiffness {
            params.stiffness = v;
        }
        if let Some(v) = j.damping {
            params.damping = v;
        }
        if let Some(v) = j.rotational_stiffness {
            params.rotational_stiffness = v;
        }
        if let Some(v) = j.rotational_damping {
            params.rotational_damping = v;
        }
        let kind = match j.kind {
            JointKindConfig::Free => JointKind::Free,
            JointKindConfig::Fixed => JointKind::Fixed,
            JointKindConfig::Hinge => JointKind::Hinge {
                axis: j.axis.unwrap_or([0.0, 0.0, 1.0]),
            },
        };
        builder.joint(Joint::new(kind, a, b, params));
    }
    let (mut system, mut state) = builder
        .build()
        .map_err(|e| located(format!("rod ({})", field_of(&e)), e))?;
    for ch in changes {
        let key = format!("{}.rest_schedule", cfg.rod_key(ch.rod));
        system
            .add_rest_change(ch)
            .map_err(|e| located(key.clone(), e))?;
    }
    system
        .set_contact(ContactParams {
            beta: cfg.contact.beta,
            zeta: cfg.contact.zeta,
            rods: cfg.contact.rods,
            self_contact: cfg.contact.self_contact,
            rod_friction: friction(cfg.contact.rod_friction, cfg.contact.rod_kinetic_friction),
            friction_eta: cfg
                .contact
                .friction_eta
                .unwrap_or(ContactParams::default().friction_eta),
            stick_stiffness: cfg
                .contact
                .stick_stiffness
                .unwrap_or(ContactParams::default().stick_stiffness),
            slip_velocity: cfg
                .contact
                .slip_velocity
                .unwrap_or(ContactParams::default().slip_velocity),
            rod_geometry: match cfg.contact.rod_geometry {
                None | Some(RodGeometryName::Polyline) => RodGeometry::Polyline,
                Some(RodGeometryName::Smooth) => RodGeometry::Smooth,
            },
        })
        .map_err(|e| located("contact".into(), e))?;
    // The contact stiffness β E Â / l̂ (and its damping) must be a number.
    if !cfg.obstacles.is_empty()
        || !cfg.planes.is_empty()
        || !cfg.cylinders.is_empty()
        || cfg.contact.rods
        || cfg.contact.self_contact
        || cfg.grasp.is_some()
    {
        let k = system
            .rods()
            .iter()
            .flat_map(|r| {
                let m = &r.model;
                (0..m.n_elements).map(move |j| {
                    cfg.contact.beta * m.material.youngs_modulus * m.area[j] / m.rest_length[j]
                })
            })
            .fold(0.0f64, f64::max);
        if !k.is_finite() {
            return Err(scn.error_at(
                "contact.beta",
                format!(
                    "contact.beta = {}: the contact stiffness beta E A / l overflows ({}); use \
                     a factor of order 1",
                    fmt_num(cfg.contact.beta),
                    fmt_num(k)
                ),
            ));
        }
    }
    for (i, l) in cfg.loads.iter().enumerate() {
        let key = format!("load[{i}]");
        let sched = match (&l.schedule, l.ramp_time) {
            (Some(s), _) => schedule(s),
            (None, Some(t)) if t > 0.0 => Schedule::Ramp { duration: t },
            _ => Schedule::Constant,
        };
        let rods: Vec<usize> = match (&l.rod, l.kind) {
            (None, LoadKind::Gravity) => (0..cfg.rods.list.len()).collect(),
            (name, _) => vec![cfg
                .find_rod(&format!("{key}.rod"), name.as_deref())
                .map_err(|b| scn.error_at(&b.key, b.to_string()))?],
        };
        for r in rods {
            let m = &system.rod(r).model;
            let n = m.n_elements;
            let node = l.node.unwrap_or_else(|| {
                let s = l.s.unwrap_or(0.0);
                (0..=n)
                    .min_by(|&a, &b| {
                        (m.node_arc_length[a] - s)
                            .abs()
                            .total_cmp(&(m.node_arc_length[b] - s).abs())
                    })
                    .unwrap_or(0)
            });
            let element = l.element.unwrap_or_else(|| {
                let s = l.s.unwrap_or(0.0);
                (0..n).rfind(|&j| m.node_arc_length[j] <= s).unwrap_or(0)
            });
            let v = l.value;
            let load = match l.kind {
                LoadKind::Gravity => Load::Gravity { acceleration: v },
                LoadKind::TipForce => Load::NodeForce { node: n, force: v },
                LoadKind::NodeForce => Load::NodeForce { node, force: v },
                LoadKind::UniformForce => Load::UniformForce {
                    force_per_length: v,
                },
                LoadKind::TipCouple => Load::ElementCouple {
                    element: n - 1,
                    couple: v,
                },
                LoadKind::ElementCouple => Load::ElementCouple { element, couple: v },
                LoadKind::FollowerCouple => Load::FollowerElementCouple { element, couple: v },
                LoadKind::UniformCouple => Load::UniformCouple {
                    couple_per_length: v,
                },
                LoadKind::UniformFollowerCouple => Load::FollowerCouple {
                    couple_per_length: v,
                },
            };
            system
                .add_load(r, load, sched.clone())
                .map_err(|e| located(format!("{key}.value"), e))?;
        }
    }
    for (i, o) in cfg.obstacles.iter().enumerate() {
        let sphere = match o.kind {
            ObstacleKind::Sphere => Sphere {
                center: o.center,
                radius: 0.5 * o.diameter,
                velocity: o.velocity,
                friction: friction(o.friction, o.kinetic_friction),
            },
        };
        system
            .add_obstacle(sphere)
            .map_err(|e| located(format!("obstacle[{i}]"), e))?;
    }
    for (i, p) in cfg.planes.iter().enumerate() {
        system
            .add_plane(octoarm_physics::Plane::new(
                p.point,
                p.normal,
                friction(p.friction, p.kinetic_friction),
            ))
            .map_err(|e| located(format!("plane[{i}]"), e))?;
    }
    for (i, c) in cfg.cylinders.iter().enumerate() {
        let mut cyl = octoarm_physics::Cylinder::fixed(
            c.center,
            c.axis,
            0.5 * c.diameter,
            c.length,
            friction(c.friction, c.kinetic_friction),
        );
        cyl.velocity = c.velocity;
        system
            .add_cylinder(cyl)
            .map_err(|e| located(format!("cylinder[{i}]"), e))?;
    }
    if let Some(g) = &cfg.grasp {
        // The grasped object is also a physical obstacle.
        system
            .add_obstacle(Sphere::fixed(g.center, 0.5 * g.diameter))
            .map_err(|e| located("grasp".into(), e))?;
    }
    if let Some(m) = &cfg.muscles {
        add_muscles(scn, m, &mut system)?;
    }
    // The friction springs of the obstacles (relaxed), part of the state from the first frame.
    system.fit_stick(&mut state);
    if let Some(init) = &cfg.initial_state {
        initial::apply(scn, init, &system, &mut state)?;
    }
    validate_tasks(scn, &system, &state)?;
    Ok((system, state))
}

/// The largest |factor| of a schedule (1 for constant, ramp and step).
fn max_factor(s: &ScheduleConfig) -> f64 {
    match s.kind {
        ScheduleKind::PiecewiseLinear => s
            .values
            .as_deref()
            .unwrap_or(&[])
            .iter()
            .fold(0.0f64, |m, v| m.max(v.abs())),
        _ => 1.0,
    }
}

/// Quantities derived from a rod section (masses, areas, inertias, stiffnesses, their
/// inverses, the stable time step and the strain energy of the rest strains) must be finite
/// and positive: inputs far outside physical values (`youngs_modulus = 1e300`,
/// `rest_curvature = [1e300, 0, 0]`) would otherwise put `inf` into the outputs.
fn check_derived(
    scn: &Scenario,
    key: &str,
    r: &RodConfig,
    model: &RodModel,
    given: Option<&RestFields>,
    straight: &octoarm_physics::RodState,
) -> Result<(), ScenarioError> {
    let diameter = if r.tip_diameter.unwrap_or(r.base_diameter) < r.base_diameter {
        "tip_diameter"
    } else {
        "base_diameter"
    };
    let fail = |input: &str, what: &str, value: f64, index: usize| {
        let k = format!("{key}.{input}");
        let shown = match input {
            "density" => fmt_num(r.density),
            "youngs_modulus" => fmt_num(r.youngs_modulus),
            "shear_modulus" => fmt_num(r.shear_modulus),
            "length" => fmt_num(r.length),
            "base_diameter" => fmt_num(r.base_diameter),
            "tip_diameter" => fmt_num(r.tip_diameter.unwrap_or(r.base_diameter)),
            _ => String::new(),
        };
        let given = if shown.is_empty() {
            String::new()
        } else {
            format!(" = {shown}")
        };
        Err(scn.error_at(
            &k,
            format!(
                "{k}{given}: the {what} of element {index} is {} (it must be a finite positive \
                 number of float64); use values of physical size in SI units",
                fmt_num(value)
            ),
        ))
    };
    let ok = |x: f64| x.is_finite() && x > 0.0 && (1.0 / x).is_finite();
    let n = model.n_elements;
    for j in 0..n {
        // Strains and energies square element lengths.
        let l = model.rest_length[j];
        if !ok(l * l) {
            return fail("length", "squared rest length", l * l, j);
        }
        if !ok(model.area[j]) {
            return fail(diameter, "cross-section area", model.area[j], j);
        }
        for c in 0..3 {
            if !ok(model.second_moment[j][c]) {
                return fail(
                    diameter,
                    "second moment of area",
                    model.second_moment[j][c],
                    j,
                );
            }
        }
        if !ok(model.element_mass[j]) {
            return fail("density", "mass", model.element_mass[j], j);
        }
        for c in 0..3 {
            if !ok(model.inertia[j][c]) {
                return fail("density", "rotational inertia", model.inertia[j][c], j);
            }
            let input = if c == 2 {
                "youngs_modulus"
            } else {
                "shear_modulus"
            };
            if !ok(model.shear_stiffness[j][c]) {
                return fail(
                    input,
                    "shear/stretch stiffness",
                    model.shear_stiffness[j][c],
                    j,
                );
            }
        }
    }
    for (i, m) in model.node_mass.iter().enumerate() {
        if !ok(*m) {
            return fail("density", "node mass", *m, i);
        }
    }
    for (k, b) in model.bend_stiffness.iter().enumerate() {
        for (c, &v) in b.iter().enumerate() {
            let input = if c == 2 {
                "shear_modulus"
            } else {
                "youngs_modulus"
            };
            if !ok(v) {
                return fail(input, "bend/twist stiffness", v, k);
            }
        }
    }
    let stable = model.stable_dt();
    if !(stable.is_finite() && stable > 0.0) {
        let k = format!("{key}.youngs_modulus");
        return Err(scn.error_at(
            &k,
            format!(
                "{k}: the stable time step 2/ω_max is {} s (youngs_modulus = {}, shear_modulus = \
                 {}, density = {}): no time step can integrate this rod; use values of physical size",
                fmt_num(stable),
                fmt_num(r.youngs_modulus),
                fmt_num(r.shear_modulus),
                fmt_num(r.density)
            ),
        ));
    }
    // The strain energy of the straight rod against its rest strains (scaled by the largest
    // factor of a rest schedule) must be finite: it is the largest the rest strains make.
    let factor = r.rest_schedule.as_ref().map_or(1.0, max_factor);
    let (sigma, kappa): (Vec<[f64; 3]>, Vec<[f64; 3]>) = match given {
        Some((s, k)) => (s.clone(), k.clone()),
        None => (model.rest_sigma.clone(), model.rest_kappa.clone()),
    };
    let scale = |v: &[[f64; 3]]| -> Vec<[f64; 3]> {
        v.iter()
            .map(|x| [x[0] * factor, x[1] * factor, x[2] * factor])
            .collect()
    };
    let (sigma, kappa) = (scale(&sigma), scale(&kappa));
    let e = octoarm_physics::energies_with_rest(
        model,
        straight,
        &sigma,
        &kappa,
        scn.config.numerics.energy_consistent,
    );
    let input = if r.rest_kappa.is_some() {
        "rest_kappa"
    } else if !e.stretch.is_finite() && r.rest_sigma.is_some() {
        "rest_sigma"
    } else {
        "rest_curvature"
    };
    let overflow = !e.stretch.is_finite() || !e.bend.is_finite();
    let huge = sigma.iter().chain(&kappa).flatten().any(|v| !v.is_finite());
    if overflow || huge {
        let k = format!("{key}.{input}");
        let what = if r.rest_schedule.is_some() {
            format!(
                " (times the largest rest_schedule factor {})",
                fmt_num(factor)
            )
        } else {
            String::new()
        };
        return Err(scn.error_at(
            &k,
            format!(
                "{k}: the strain energy of the straight rod against these rest strains{what} \
                 overflows (stretch {} J, bend {} J): rest strains of physical size are at most \
                 about 1/radius (curvature) and 1 (shear, stretch)",
                fmt_num(e.stretch),
                fmt_num(e.bend)
            ),
        ));
    }
    Ok(())
}

/// Check the controller's tasks against the controlled rod without solving anything (control
/// spec §3.4: targets within 1.5 L0 of the base, points of a planar task in its plane, no
/// obstacle or grasped sphere containing the base), at every target (at the start and the end
/// of its phase, for a moving one) and every via point: what the solver would reject before or
/// during the run is an input error, found by `check` and before `run` writes anything.
pub fn validate_tasks(
    scn: &Scenario,
    system: &RodSystem,
    state: &SystemState,
) -> Result<(), ScenarioError> {
    let cfg = &scn.config;
    let (Some(ctrl), Some(sv)) = (&cfg.controller, &cfg.solver) else {
        return Ok(());
    };
    let rod = cfg
        .find_rod("controller.rod", ctrl.rod.as_deref())
        .map_err(|b| scn.error_at(&b.key, b.to_string()))?;
    let Some(schedule) = task_schedule(cfg) else {
        return Ok(());
    };
    let r = system.rod(rod);
    let space = if sv.planar {
        StrainSpace::Planar
    } else {
        StrainSpace::Full
    };
    let statics = Statics::new(
        &r.model,
        &system.rod_state(state, rod),
        space,
        sv.design_floor_diameter,
    )
    .map_err(|e| match e {
        StaticsError::NotPlanar { .. } => scn.error_at(
            "solver.planar",
            format!(
                "solver.planar = true needs the controlled rod \"{}\" in the x-y plane: direction \
                 in that plane and normal along +z or -z (or set solver.planar = false)",
                r.name
            ),
        ),
        other => scn.error_at("controller", format!("controller: {other}")),
    })?;
    // The design's stiffness floor (a rod of that diameter) must be a number.
    let d = sv.design_floor_diameter;
    let m = &r.model.material;
    let floor = [
        m.youngs_modulus * std::f64::consts::PI * d.powi(4) / 64.0,
        m.shear_modulus * std::f64::consts::PI * d * d / 4.0,
    ];
    if floor.iter().any(|x| !x.is_finite()) {
        return Err(scn.error_at(
            "solver.design_floor_diameter",
            format!(
                "solver.design_floor_diameter = {} m: the stiffness of a rod of that diameter \
                 overflows; the floor is a few millimetres (default 4e-3 m)",
                fmt_num(d)
            ),
        ));
    }
    let n_obstacles = cfg.obstacles.len();
    let t0 = state.time;
    let t_end = t0 + cfg.time.duration;
    // (key of the task's tip point, the point, when) for every target phase end and via point.
    let mut points: Vec<(String, Vec3, f64)> = Vec::new();
    for (i, tg) in schedule.targets.iter().enumerate() {
        let start = if i == 0 { t0.min(tg.from) } else { tg.from };
        let end = schedule
            .targets
            .get(i + 1)
            .map_or(t_end, |next| next.from)
            .min(t_end)
            .max(start);
        points.push((format!("target[{i}].position"), tg.at(tg.from), tg.from));
        if tg.velocity != [0.0; 3] {
            for t in [start, end] {
                points.push((format!("target[{i}].velocity"), tg.at(t), t));
            }
        }
    }
    if let Some(v) = &cfg.via_path {
        for (k, p) in v.points.iter().enumerate() {
            points.push((format!("via_path.points[{k}]"), *p, v.start));
        }
    }
    let located = |tip_key: &str, when: f64, e: TaskError| -> ScenarioError {
        let obstacle_key = |index: usize| {
            if index < n_obstacles {
                format!("obstacle[{index}]")
            } else {
                "grasp".to_string()
            }
        };
        let moving = tip_key.ends_with(".velocity");
        let at_time = if moving {
            format!(" (the target's position at t = {} s)", fmt_num(when))
        } else {
            String::new()
        };
        let (key, message) = match e {
            TaskError::TargetTooFar {
                value,
                distance,
                limit,
            } => (
                tip_key.to_string(),
                format!(
                    "{tip_key}: the target {}{at_time} is {} m from the base of rod \"{}\"; a \
                     target must be within 1.5 L0 = {} m of the base",
                    fmt_vec(value),
                    fmt_num(distance),
                    r.name,
                    fmt_num(limit)
                ),
            ),
            TaskError::OffPlane {
                field,
                value,
                plane_z,
            } => {
                let key = match field.split_once('.') {
                    Some(("tip", _)) => tip_key.to_string(),
                    Some(("grasp", _)) => "grasp.center".to_string(),
                    _ => field
                        .split_once(']')
                        .and_then(|(head, _)| head.split_once('['))
                        .and_then(|(_, i)| i.parse::<usize>().ok())
                        .map_or_else(
                            || "grasp.center".to_string(),
                            |i| format!("{}.center", obstacle_key(i)),
                        ),
                };
                (
                    key.clone(),
                    format!(
                        "{key}: {}{at_time} is off the plane z = {} of the planar controller \
                         (solver.planar = true); put it in that plane or set solver.planar = false",
                        fmt_vec(value),
                        fmt_num(plane_z)
                    ),
                )
            }
            TaskError::ObstacleContainsBase {
                index,
                center,
                diameter,
                distance,
                limit,
            } => {
                let key = obstacle_key(index);
                (
                    format!("{key}.center"),
                    format!(
                        "{key}: the sphere (center {}, diameter {} m) contains the base of the \
                         controlled rod \"{}\": its centre is {} m from the base, at least \
                         (diameter + base diameter) / 2 = {} m is needed",
                        fmt_vec(center),
                        fmt_num(diameter),
                        r.name,
                        fmt_num(distance),
                        fmt_num(limit)
                    ),
                )
            }
            TaskError::OutOfRange {
                field,
                value,
                range,
            } => (
                "controller".to_string(),
                format!(
                    "controller: task {field} = {} is outside the allowed range {range}",
                    fmt_num(value)
                ),
            ),
            other => ("controller".to_string(), format!("controller: {other}")),
        };
        scn.error_at(&key, message)
    };
    if points.is_empty() {
        // A grasp: no tip target.
        return schedule
            .task(None)
            .validate(&statics)
            .map_err(|e| located("grasp", t0, e));
    }
    for (key, p, when) in &points {
        schedule
            .task(Some(*p))
            .validate(&statics)
            .map_err(|e| located(key, *when, e))?;
    }
    Ok(())
}

/// Things worth changing in a valid controlled scenario (shown by `octoarm check`): a target
/// inside an obstacle (the tip cannot get there; the design presses the arm into the sphere),
/// a grasped sphere overlapping the rod at rest.
pub fn task_advisories(scn: &Scenario, system: &RodSystem, state: &SystemState) -> Vec<String> {
    let cfg = &scn.config;
    let mut out = Vec::new();
    if cfg.controller.is_none() {
        return out;
    }
    for (i, tg) in cfg.targets.iter().enumerate() {
        for (j, o) in cfg.obstacles.iter().enumerate() {
            let c = [
                o.center[0] + o.velocity[0] * tg.from,
                o.center[1] + o.velocity[1] * tg.from,
                o.center[2] + o.velocity[2] * tg.from,
            ];
            let d = octoarm_physics::math::norm(octoarm_physics::math::sub(tg.position, c));
            if d < 0.5 * o.diameter {
                out.push(format!(
                    "target[{i}].position = {} lies inside obstacle[{j}] (center {}, diameter {} m at \
                     t = {} s): the tip cannot reach it and the design presses the arm into the \
                     sphere; move the target or the obstacle",
                    fmt_vec(tg.position),
                    fmt_vec(c),
                    fmt_num(o.diameter),
                    fmt_num(tg.from)
                ));
            }
        }
    }
    if let Some(g) = &cfg.grasp {
        let radius = 0.5 * g.diameter;
        let overlap = system.rods().iter().any(|rod| {
            let nodes = rod.nodes();
            (0..rod.n_elements()).any(|j| {
                let (a, b) = (
                    state.position.get(nodes.start + j),
                    state.position.get(nodes.start + j + 1),
                );
                let mid = [
                    0.5 * (a[0] + b[0]),
                    0.5 * (a[1] + b[1]),
                    0.5 * (a[2] + b[2]),
                ];
                octoarm_physics::math::norm(octoarm_physics::math::sub(mid, g.center))
                    < radius + rod.model.radius[j]
            })
        });
        if overlap {
            out.push(format!(
                "grasp (center {}, diameter {} m) overlaps a rod at rest: the contact force will push \
                 the rod out violently; move the sphere",
                fmt_vec(g.center),
                fmt_num(g.diameter)
            ));
        }
    }
    out
}

/// `[muscles]` (muscles-3d spec §1–3): the muscle table on its rod, COOMM's drag, the damping
/// preset and the optional net weight.
fn add_muscles(
    scn: &Scenario,
    m: &MusclesConfig,
    system: &mut RodSystem,
) -> Result<(), ScenarioError> {
    let cfg = &scn.config;
    let located =
        |key: &str, e: ModelError| scn.error_at(key, format!("{key}: {}", model_message(&e)));
    let r = cfg
        .find_rod("muscles.rod", m.rod.as_deref())
        .map_err(|b| scn.error_at(&b.key, b.to_string()))?;
    let model = Arc::clone(&system.rod(r).model);
    let spec = match m.table {
        MuscleTableKind::Coomm => octoarm_physics::MuscleSpec::coomm(),
    };
    let muscles =
        octoarm_physics::MuscleModel::new(spec, &model).map_err(|e| located("muscles.table", e))?;
    system
        .set_muscles(r, Some(muscles))
        .map_err(|e| located("muscles", e))?;
    if m.drag {
        system
            .add_load(r, Load::coomm_drag(&model), Schedule::Constant)
            .map_err(|e| located("muscles.drag", e))?;
    }
    if m.damping == MuscleDampingKind::Coomm {
        let rc = &cfg.rods.list[r];
        system
            .set_damping(r, Damping::coomm(rc.density, 0.5 * rc.base_diameter))
            .map_err(|e| located("muscles.damping", e))?;
    }
    if m.net_weight {
        let load = Load::net_weight(&model, m.water_density, m.gravity)
            .map_err(|e| located("muscles.net_weight", e))?;
        system
            .add_load(r, load, Schedule::Constant)
            .map_err(|e| located("muscles.net_weight", e))?;
    }
    Ok(())
}

/// Density of the water of the muscular arm, ρ_w [kg/m³] (muscles-3d spec §3.1): the drag's
/// and the default of `[muscles] water_density`.
pub const WATER_DENSITY: f64 = 1022.0;

/// The task schedule of a controlled scenario.
pub fn task_schedule(cfg: &ScenarioConfig) -> Option<TaskSchedule> {
    let ctrl = cfg.controller.as_ref()?;
    let sv = cfg.solver.as_ref()?;
    let r = cfg
        .rod_index(ctrl.rod.as_deref().unwrap_or("rod"))
        .unwrap_or(0);
    let (via_points, via_until) = match &cfg.via_path {
        Some(v) => (TargetPhase::polyline(&v.points, v.start, v.end), v.end),
        None => (Vec::new(), 0.0),
    };
    Some(TaskSchedule {
        targets: cfg
            .targets
            .iter()
            .map(|t| TargetPhase {
                from: t.from,
                position: t.position,
                velocity: t.velocity,
            })
            .collect(),
        via_points,
        via_until,
        obstacles: cfg
            .obstacles
            .iter()
            .map(|o| SphereSpec {
                center: o.center,
                diameter: o.diameter,
            })
            .collect(),
        grasp: cfg.grasp.as_ref().map(|g| GraspSpec {
            object: SphereSpec {
                center: g.center,
                diameter: g.diameter,
            },
            weight: g.mu_grasp,
            from_fraction: g.interval[0],
        }),
        mu_tip: sv.mu_tip,
        xi: sv.xi,
        length: cfg.rods.list[r].length,
    })
}

/// The controller settings of a controlled scenario.
pub fn controller_config(cfg: &ScenarioConfig) -> Option<ShapingControllerConfig> {
    let sv = cfg.solver.as_ref()?;
    let rule = match sv.rule {
        RuleKind::Lbfgs => UpdateRule::Lbfgs {
            memory: sv.lbfgs_memory,
        },
        RuleKind::Preconditioned => UpdateRule::Preconditioned {
            eta: sv.eta.unwrap_or(1.0),
        },
        RuleKind::Paper => UpdateRule::Paper {
            eta: sv.eta.unwrap_or(0.005),
            min_stretch: sv.min_stretch.unwrap_or(0.1),
        },
    };
    let (mode, period) = match sv.mode {
        SolverModeKind::Offline => (
            DesignMode::Offline {
                ramp_time: sv.ramp_time,
                grasp_stages: sv.grasp_stages,
            },
            sv.ramp_interval.unwrap_or(1e-3),
        ),
        SolverModeKind::Online => (
            DesignMode::Online {
                iterations_per_update: sv.iterations_per_update,
                trust_form_time: sv.trust_form_time,
                presolve: sv.presolve,
            },
            sv.update_interval.unwrap_or(1e-3),
        ),
    };
    Some(ShapingControllerConfig {
        solver: octoarm_control::SolverConfig {
            space: if sv.planar {
                StrainSpace::Planar
            } else {
                StrainSpace::Full
            },
            floor_diameter: sv.design_floor_diameter,
            rule,
            tolerance: sv.tolerance,
            stall_window: sv.stall_window,
            stall_tolerance: sv.stall_tolerance,
            max_sweeps: sv.max_sweeps,
        },
        mode,
        period,
    })
}

/// The controllers of a scenario (none for a passive run), solving every offline design now.
/// A task the solver rejects (a target out of reach, an obstacle over the base, …) is reported
/// as a scenario error.
pub fn build_controllers(
    scn: &Scenario,
    system: &RodSystem,
    state: &SystemState,
) -> Result<Vec<Box<dyn Controller>>, ScenarioError> {
    let cfg = &scn.config;
    let Some(ctrl) = &cfg.controller else {
        return Ok(Vec::new());
    };
    let rod = cfg
        .find_rod("controller.rod", ctrl.rod.as_deref())
        .map_err(|b| scn.error_at(&b.key, b.to_string()))?;
    let schedule = task_schedule(cfg).expect("a controlled scenario has a task");
    let config = controller_config(cfg).expect("a controlled scenario has a [solver]");
    let c = ShapingController::new(system, state, rod, schedule, config).map_err(|e| {
        let key = match &e {
            ControlError::Solve(_) if !cfg.targets.is_empty() => "target",
            ControlError::Solve(_) if cfg.grasp.is_some() => "grasp",
            _ => "controller",
        };
        scn.error_at(key, format!("{key}: {e}"))
    })?;
    Ok(vec![Box::new(c)])
}

/// Physics friction from a scenario's static and kinetic coefficients (checked by validate).
fn friction(
    stat: Option<crate::scenario::config::FrictionValue>,
    kinetic: Option<crate::scenario::config::FrictionValue>,
) -> octoarm_physics::Friction {
    match stat {
        None => octoarm_physics::Friction::NONE,
        Some(s) => {
            let s = s.three();
            octoarm_physics::Friction {
                static_mu: s,
                kinetic_mu: kinetic.map_or(s, |k| k.three()),
            }
        }
    }
}
