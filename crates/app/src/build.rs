//! Scenario → physics and control objects: the rods (models shared where the geometry is
//! identical), their end conditions, rest strains and schedules, damping, loads, obstacles,
//! joints and initial state (`build_system`), and the controllers (`build_controllers`, which
//! runs the offline design solves). The only place where scenario sections turn into physics or
//! control types; a rejection is reported at the key it concerns.

use crate::initial;
use crate::scenario::*;
use octoarm_control::{
    ControlError, Controller, DesignMode, GraspSpec, ShapingController, ShapingControllerConfig,
    SphereSpec, StrainSpace, TargetPhase, TaskSchedule, UpdateRule,
};
use octoarm_physics::{
    AnalyticalDamper, ContactParams, Damping, EndCondition, Joint, JointEnd, JointKind,
    JointParams, Load, Material, ModelError, Motion, RestChange, RodModel, RodSpec, RodSystem,
    Schedule, Settings, Side, Sphere, StraightRod, SystemBuilder, SystemState,
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
    let located = |key: String, e: ModelError| scn.error_at(&key, format!("{key}: {e}"));
    let settings = Settings {
        dt: cfg.time.dt,
        energy_consistent: cfg.numerics.energy_consistent,
        guard_interval: cfg.numerics.guard_interval,
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
        })
        .map_err(|e| located("contact".into(), e))?;
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
            },
        };
        system
            .add_obstacle(sphere)
            .map_err(|e| located(format!("obstacle[{i}]"), e))?;
    }
    if let Some(g) = &cfg.grasp {
        // The grasped object is also a physical obstacle.
        system
            .add_obstacle(Sphere::fixed(g.center, 0.5 * g.diameter))
            .map_err(|e| located("grasp".into(), e))?;
    }
    if let Some(init) = &cfg.initial_state {
        initial::apply(scn, init, &system, &mut state)?;
    }
    Ok((system, state))
}

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
