//! The one stepper of a rod system (spec §6): position Verlet with end conditions (§7), the
//! exponential damping kick (§8a) or PyElastica's multiplicative damper (§8b), external loads,
//! contact and joints (§9–§10), actuation read as data, periodic re-orthonormalisation (§5) and
//! the stability guard (§11). The stage order lives once, in `step`; `Workspace` holds every
//! scratch array so that a step never allocates.

use crate::actuation::{Actuation, ActuationScratch};
use crate::contact::add_contact_forces;
use crate::damping::{AnalyticalDamper, KickFactors};
use crate::energy::{energies_with_rest, Energies};
use crate::error::StepError;
use crate::internal::{turning_angle, InternalLoads};
use crate::kernel::Kernel;
use crate::lanes::{gather3, load3, s, LANES, X};
use crate::loads::ExternalLoads;
use crate::math::{
    bjorck, cross, dot, dot_r, exp_neg_skew, exp_neg_skew_series, exp_neg_skew_series_r,
    log_relative, mat_mul, mat_mul_r, mat_vec, orthonormality_defect, Real, Vec3,
    EXP_SERIES_MAX_SQ,
};
use crate::rod_contact::{add_rod_contact_forces, RodContactScratch};
use crate::state::{RodAccess, SystemState};
use crate::system::RodSystem;

/// Length of the guard's energy window in checks (spec §11: the last 1e4 steps).
const ENERGY_WINDOW: usize = 128;

#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
struct Guard {
    reference_energy: f64,
    window: Vec<f64>,
    window_pos: usize,
    rest_checksum: f64,
    floor: f64,
}

/// Scratch of the stepper for one system: internal and external loads of the last force
/// evaluation, kick factors, actuation results, guard history. Allocated once by `new`.
#[derive(Debug, Clone)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct Workspace {
    /// Internal loads and strains of the last force evaluation (at the mid-step state).
    pub internal: InternalLoads,
    /// External loads of the last force evaluation (loads, contact, joints, actuation).
    pub external: ExternalLoads,
    kick: KickFactors,
    // J_j / e_j per element: the divisions of the dissipation sum, in their own vectorised loop.
    inertia_over_e: [Vec<f64>; 3],
    actuation: ActuationScratch,
    actuation_used: bool,
    // Per rod: whether its muscles were on in the last force evaluation.
    muscles_on: Vec<bool>,
    // Rest strains in force when the system has scheduled changes.
    rest_sigma: Vec<Vec3>,
    rest_kappa: Vec<Vec3>,
    guard: Guard,
    /// Broad phase and Verlet list of rod–rod and self contact.
    pub rod_contact: RodContactScratch,
    // The machine code `step` runs (not saved: a restored simulation picks its own machine's).
    #[cfg_attr(feature = "serde", serde(skip))]
    kernel: Kernel,
}

impl Workspace {
    /// Scratch for `system`, with the guard's energy reference taken from `state`.
    pub fn new(system: &RodSystem, state: &SystemState) -> Self {
        let (nn, ne, ni) = (system.n_nodes, system.n_elements, system.n_interior);
        // Energy floor for the blow-up test: the strain energy of a 0.1 % uniform stretch.
        let floor: f64 = system
            .rods
            .iter()
            .map(|r| {
                let m = &r.model;
                (0..m.n_elements)
                    .map(|j| 0.5 * m.rest_length[j] * m.shear_stiffness[j][2] * 1e-6)
                    .sum::<f64>()
            })
            .sum();
        let mut ws = Self {
            internal: InternalLoads::new(nn, ne, ni),
            external: ExternalLoads::zeros(nn, ne),
            kick: KickFactors::new(system.rods.len(), nn, ne),
            inertia_over_e: std::array::from_fn(|_| vec![0.0; ne]),
            actuation: ActuationScratch::new(nn, ne),
            actuation_used: false,
            muscles_on: vec![false; system.rods.len()],
            rest_sigma: system.rest_sigma.clone(),
            rest_kappa: system.rest_kappa.clone(),
            guard: Guard {
                reference_energy: 0.0,
                window: vec![0.0; ENERGY_WINDOW],
                window_pos: 0,
                rest_checksum: 0.0,
                floor,
            },
            rod_contact: RodContactScratch::new(system),
            kernel: Kernel::selected(),
        };
        ws.reset_energy_reference(system, state);
        ws.refresh_kick(system);
        ws
    }

    fn refresh_kick(&mut self, system: &RodSystem) {
        let dt = system.settings.dt;
        for (r, rod) in system.rods.iter().enumerate() {
            self.kick
                .refresh_rod(r, &rod.model, &rod.damping, dt, rod.at.node, rod.at.element);
        }
    }

    /// The kernel `step` runs with this workspace (initially `Kernel::selected()`).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Run `step` with `kernel` from now on; refused (returning false, nothing changed) when this
    /// CPU cannot run it. Every kernel gives bit-identical results; this is for testing and
    /// benchmarking the variants.
    pub fn set_kernel(&mut self, kernel: Kernel) -> bool {
        kernel.switch(&mut self.kernel)
    }

    /// Nodal forces [N] (lab) the actuation produced in the last step, system node order; None
    /// when no actuation was on in that step.
    pub fn actuation_force(&self) -> Option<&crate::store::Vec3s> {
        self.actuation_used.then_some(&self.actuation.force)
    }

    /// Element couples [N m] (material) the actuation produced in the last step; None when no
    /// actuation was on in that step.
    pub fn actuation_couple(&self) -> Option<&crate::store::Vec3s> {
        self.actuation_used.then_some(&self.actuation.couple)
    }

    fn reset_energy_reference(&mut self, system: &RodSystem, state: &SystemState) {
        let h = total_energy(system, state, &mut self.rest_sigma, &mut self.rest_kappa);
        self.guard.reference_energy = h;
        self.guard.window.fill(h);
        self.guard.rest_checksum = rest_checksum(&self.rest_sigma, &self.rest_kappa);
    }
}

/// The rest strains in force at time t: the system's arrays, or `buf` filled with the scheduled
/// values.
fn rest_in_force<'a>(
    system: &'a RodSystem,
    t: f64,
    sigma: &'a mut [Vec3],
    kappa: &'a mut [Vec3],
) -> (&'a [Vec3], &'a [Vec3]) {
    if system.rest_changes.is_empty() {
        (&system.rest_sigma, &system.rest_kappa)
    } else {
        system.rest_at(t, sigma, kappa);
        (sigma, kappa)
    }
}

fn total_energy(
    system: &RodSystem,
    state: &SystemState,
    sigma: &mut [Vec3],
    kappa: &mut [Vec3],
) -> f64 {
    let (rs, rk) = rest_in_force(system, state.time, sigma, kappa);
    let ec = system.settings.energy_consistent;
    system
        .rods
        .iter()
        .enumerate()
        .map(|(r, rod)| {
            let v = system.view(state, r);
            energies_with_rest(&rod.model, &v, &rs[rod.elements()], rs_k(rk, rod), ec).total()
        })
        .sum()
}

#[inline]
fn rs_k<'a>(rk: &'a [Vec3], rod: &crate::system::Rod) -> &'a [Vec3] {
    &rk[rod.interior()]
}

fn rest_checksum(sigma: &[Vec3], kappa: &[Vec3]) -> f64 {
    let mut sum = 0.0;
    for (i, v) in sigma.iter().chain(kappa.iter()).enumerate() {
        sum += (i as f64 + 1.0) * (v[0] + 2.0 * v[1] + 3.0 * v[2]);
    }
    sum
}

/// System indices of a joint's two end nodes and two end elements.
fn joint_indices(system: &RodSystem, j: &crate::joints::Joint) -> ([usize; 2], [usize; 2]) {
    let (a, b) = (&system.rods[j.first.rod], &system.rods[j.second.rod]);
    (
        [
            a.at.node + j.first.side.node(a.n_elements()),
            b.at.node + j.second.side.node(b.n_elements()),
        ],
        [
            a.at.element + j.first.side.element(a.n_elements()),
            b.at.element + j.second.side.element(b.n_elements()),
        ],
    )
}

/// Elastic energy stored in the joints' springs [J] (½ k |Δx|² + ½ k_t |θ|² per joint).
pub fn joint_energy(system: &RodSystem, state: &SystemState) -> f64 {
    system
        .joints
        .iter()
        .map(|j| {
            let (node, elem) = joint_indices(system, j);
            let (q1, q2) = (state.director.get(elem[0]), state.director.get(elem[1]));
            j.energy(
                [state.position.get(node[0]), state.position.get(node[1])],
                [&q1, &q2],
            )
        })
        .sum()
}

/// Energies of rod `r` of `state` against the rest strains in force at the state's time [J].
pub fn rod_energies(system: &RodSystem, state: &SystemState, r: usize) -> Energies {
    let rod = &system.rods[r];
    let v = system.view(state, r);
    let ec = system.settings.energy_consistent;
    if system.rest_changes.is_empty() {
        energies_with_rest(
            &rod.model,
            &v,
            &system.rest_sigma[rod.elements()],
            &system.rest_kappa[rod.interior()],
            ec,
        )
    } else {
        let mut s = system.rest_sigma.clone();
        let mut k = system.rest_kappa.clone();
        system.rest_at(state.time, &mut s, &mut k);
        energies_with_rest(&rod.model, &v, &s[rod.elements()], &k[rod.interior()], ec)
    }
}

/// Advance `state` by one step of `system.settings().dt` under `actuation` (held constant over
/// the step). The stability guard runs every `guard_interval` steps; on failure the state is
/// left as it was when the guard fired. Runs the workspace's kernel (`crate::kernel`).
pub fn step(
    system: &RodSystem,
    state: &mut SystemState,
    actuation: &Actuation,
    ws: &mut Workspace,
) -> Result<(), StepError> {
    match ws.kernel {
        #[cfg(target_arch = "x86_64")]
        // SAFETY: a workspace holds `Kernel::Avx2` only when the CPU has AVX2 and FMA
        // (`Kernel::selected`, `Workspace::set_kernel` check `is_available`).
        Kernel::Avx2 => unsafe { step_avx2(system, state, actuation, ws) },
        _ => step_body(system, state, actuation, ws),
    }
}

/// `step_body` compiled with AVX2/FMA enabled; the kernels it calls are `inline(always)` so
/// that they are compiled into it with the same features.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn step_avx2(
    system: &RodSystem,
    state: &mut SystemState,
    actuation: &Actuation,
    ws: &mut Workspace,
) -> Result<(), StepError> {
    step_body(system, state, actuation, ws)
}

#[inline(always)]
fn step_body(
    system: &RodSystem,
    state: &mut SystemState,
    actuation: &Actuation,
    ws: &mut Workspace,
) -> Result<(), StepError> {
    let settings = system.settings;
    let dt = settings.dt;
    let h = 0.5 * dt;
    // Sizes are fixed when the actuation is made (`Actuation::for_system`); a mismatch is a
    // programming error, not an input error.
    debug_assert_eq!(
        actuation.shape(),
        (system.n_nodes, system.n_elements, system.n_interior),
        "actuation sized for another system"
    );
    ws.refresh_kick(system);
    let n_step = state.step;

    // 1–2. Kinematic half-step and value constraints.
    drift(system, state, h);
    state.time = state.origin + (n_step as f64 + 0.5) * dt;
    hold_values(system, state);

    // 3. Internal loads at x(t+h), Q(t+h) with v(t), ω(t), against the rest strains in force.
    let (rs, rk) = rest_in_force(system, state.time, &mut ws.rest_sigma, &mut ws.rest_kappa);
    for (r, rod) in system.rods.iter().enumerate() {
        let muscles = match &rod.muscles {
            Some(m) if actuation.has_muscles() => {
                Some((&**m, actuation.rod_activations(rod.elements())))
            }
            _ => None,
        };
        ws.muscles_on[r] = muscles.is_some();
        ws.internal.compute_rod_with_muscles(
            &rod.model,
            state,
            rod.at,
            &rs[rod.elements()],
            &rk[rod.interior()],
            true,
            settings.energy_consistent,
            muscles,
        );
    }
    if settings.clamp_order == 2 {
        add_clamp_couples(system, state, &mut ws.internal, rk);
    }

    // 4. External loads: scheduled loads, contact, joints, then the actuation.
    let t = state.time;
    ws.external.clear();
    for l in &system.loads {
        let rod = &system.rods[l.rod];
        let v = state.view(rod.at.node, rod.at.element, rod.n_elements());
        let k = l.schedule.factor(t);
        l.load.apply(
            &rod.model,
            &v,
            k,
            rod.at.node,
            rod.at.element,
            &mut ws.external,
        );
    }
    let obstacles = system.obstacle_set();
    if !obstacles.is_empty() {
        // Obstacles may be added between steps: (re)size the stick springs then, not per step.
        system.fit_stick(state);
        // The springs are moved out of the state while its rods are borrowed (no copy).
        let mut stick = std::mem::take(&mut state.stick);
        for rod in &system.rods {
            let v = state.view(rod.at.node, rod.at.element, rod.n_elements());
            add_contact_forces(
                &rod.model,
                &v,
                obstacles,
                &system.contact,
                t,
                dt,
                rod.at.node,
                rod.at.element,
                system.n_elements,
                &mut stick,
                &mut ws.external,
            );
        }
        state.stick = stick;
    }
    if system.contact.rod_contact() {
        add_rod_contact_forces(system, state, &mut ws.rod_contact, dt, &mut ws.external);
    }
    for j in &system.joints {
        let (node, elem) = joint_indices(system, j);
        let (q1, q2) = (state.director.get(elem[0]), state.director.get(elem[1]));
        j.apply(
            [state.position.get(node[0]), state.position.get(node[1])],
            [state.velocity.get(node[0]), state.velocity.get(node[1])],
            [&q1, &q2],
            [state.omega.get(elem[0]), state.omega.get(elem[1])],
            node,
            elem,
            &mut ws.external,
        );
    }
    ws.actuation_used = actuation.has_internal() || actuation.has_external();
    if actuation.has_internal() {
        for rod in &system.rods {
            let v = state.view(rod.at.node, rod.at.element, rod.n_elements());
            ws.actuation.add_internal_rod(
                &rod.model,
                &v.director,
                &ws.internal,
                &actuation.internal_stress()[rod.elements()],
                &actuation.internal_couple()[rod.interior()],
                (&rs[rod.elements()], &rk[rod.interior()]),
                settings.energy_consistent,
                rod.at,
                &mut ws.external,
            );
        }
    } else if ws.actuation_used {
        ws.actuation.force.fill_zero();
        ws.actuation.couple.fill_zero();
    }
    if actuation.has_external() {
        for (i, f) in actuation.force().iter().enumerate() {
            ws.external.force.add(i, *f);
            ws.actuation.force.add(i, *f);
        }
        for (j, c) in actuation.couple().iter().enumerate() {
            ws.external.couple.add(j, *c);
            ws.actuation.couple.add(j, *c);
        }
    }

    // 5–6. Kick with exact damping, rate constraints, then the multiplicative damper.
    kick(system, state, ws, dt);
    hold_rates(system, state, &ws.internal, &ws.external, dt);
    apply_analytical_dampers(system, state, ws, dt);

    // 7. Second kinematic half-step and value constraints.
    drift(system, state, h);
    state.step = n_step + 1;
    state.time = state.origin + state.step as f64 * dt;
    hold_values(system, state);

    // 8. Orthonormality and guard.
    if state.step % settings.orthonormality_interval == 0 {
        reorthonormalise(system, state);
    }
    if state.step % settings.guard_interval == 0 {
        check(system, state, ws)?;
    }
    Ok(())
}

#[inline(always)]
fn drift(system: &RodSystem, state: &mut SystemState, h: f64) {
    let _ = system;
    let p = &mut state.position;
    let v = &state.velocity;
    for (x, vx) in p.x.iter_mut().zip(&v.x) {
        *x += h * vx;
    }
    for (y, vy) in p.y.iter_mut().zip(&v.y) {
        *y += h * vy;
    }
    for (z, vz) in p.z.iter_mut().zip(&v.z) {
        *z += h * vz;
    }
    let w = &state.omega;
    // |h ω| < 0.1 everywhere (the guard enforces |ω| dt ≤ 0.2) lets every frame take the
    // series form with no per-frame branch or libm call; it is bit-identical to
    // `exp_neg_skew` there.
    let n = w.len();
    let mut series_ok = true;
    for j in 0..n {
        let a = [h * w.x[j], h * w.y[j], h * w.z[j]];
        series_ok &= dot(a, a) < EXP_SERIES_MAX_SQ;
    }
    if series_ok {
        // Nine entry slices of one length and the three ω slices, cut to n so that the loops
        // index without bounds checks.
        let [m0, m1, m2, m3, m4, m5, m6, m7, m8] = &mut state.director.m;
        let (m0, m1, m2) = (&mut m0[..n], &mut m1[..n], &mut m2[..n]);
        let (m3, m4, m5) = (&mut m3[..n], &mut m4[..n], &mut m5[..n]);
        let (m6, m7, m8) = (&mut m6[..n], &mut m7[..n], &mut m8[..n]);
        let (wx, wy, wz) = (&w.x[..n], &w.y[..n], &w.z[..n]);
        // Lanes across elements, the last n mod 4 one by one (the same formula, the same bits).
        let n4 = n - n % LANES;
        for j in (0..n4).step_by(LANES) {
            let r = exp_neg_skew_series_r([
                s(h) * X::load(wx, j),
                s(h) * X::load(wy, j),
                s(h) * X::load(wz, j),
            ]);
            let qj = [
                [X::load(m0, j), X::load(m1, j), X::load(m2, j)],
                [X::load(m3, j), X::load(m4, j), X::load(m5, j)],
                [X::load(m6, j), X::load(m7, j), X::load(m8, j)],
            ];
            let p = mat_mul_r(&r, &qj);
            p[0][0].store(m0, j);
            p[0][1].store(m1, j);
            p[0][2].store(m2, j);
            p[1][0].store(m3, j);
            p[1][1].store(m4, j);
            p[1][2].store(m5, j);
            p[2][0].store(m6, j);
            p[2][1].store(m7, j);
            p[2][2].store(m8, j);
        }
        for j in n4..n {
            let r = exp_neg_skew_series([h * wx[j], h * wy[j], h * wz[j]]);
            let qj = [
                [m0[j], m1[j], m2[j]],
                [m3[j], m4[j], m5[j]],
                [m6[j], m7[j], m8[j]],
            ];
            let p = mat_mul(&r, &qj);
            (m0[j], m1[j], m2[j]) = (p[0][0], p[0][1], p[0][2]);
            (m3[j], m4[j], m5[j]) = (p[1][0], p[1][1], p[1][2]);
            (m6[j], m7[j], m8[j]) = (p[2][0], p[2][1], p[2][2]);
        }
    } else {
        let q = &mut state.director;
        for j in 0..n {
            let r = exp_neg_skew([h * w.x[j], h * w.y[j], h * w.z[j]]);
            let qj = q.get(j);
            q.set(j, &mat_mul(&r, &qj));
        }
    }
}

/// Put every held end node and frame where its end condition says at the state's time.
fn hold_values(system: &RodSystem, state: &mut SystemState) {
    let t = state.time;
    for rod in &system.rods {
        let n = rod.n_elements();
        for (end, side) in [
            (&rod.base, crate::ends::Side::Base),
            (&rod.tip, crate::ends::Side::Tip),
        ] {
            if !end.condition.holds_position() {
                continue;
            }
            let (mut x, q) = end.pose(t);
            let node = rod.at.node + side.node(n);
            if let Some(a) = end.condition.slide_axis() {
                // Free along the slide direction: keep the node's own component there.
                let along = dot(a, crate::math::sub(state.position.get(node), x));
                x = [
                    x[0] + along * a[0],
                    x[1] + along * a[1],
                    x[2] + along * a[2],
                ];
            }
            state.position.set(node, x);
            if frame_held(end, &system.settings) {
                state.director.set(rod.at.element + side.element(n), &q);
            }
        }
    }
}

/// Give every held end node and frame the velocity and angular velocity of its end condition.
/// A driven end does work on the rod: −F_int · v − T_int · ω at its node and element (the
/// internal loads of this step; the clamp absorbs any external load on held DOFs), added to the
/// rod's external work so that the energy balance and the guard's bound include it.
fn hold_rates(
    system: &RodSystem,
    state: &mut SystemState,
    internal: &InternalLoads,
    external: &ExternalLoads,
    dt: f64,
) {
    // Rates belong to the mid-step (the kick integrates from t to t + dt).
    let t = state.time;
    for (r, rod) in system.rods.iter().enumerate() {
        let n = rod.n_elements();
        for (end, side) in [
            (&rod.base, crate::ends::Side::Base),
            (&rod.tip, crate::ends::Side::Tip),
        ] {
            if !end.condition.holds_position() {
                continue;
            }
            let e = rod.at.element + side.element(n);
            let node = rod.at.node + side.node(n);
            let q = state.director.get(e);
            let (mut v, w) = end.rates(t, &q);
            let held_frame = frame_held(end, &system.settings);
            let w_held = if held_frame { w } else { [0.0; 3] };
            if let Some(a) = end.condition.slide_axis() {
                // The node was kicked; keep its velocity along the slide direction. The
                // constraint force is the load across it.
                let along = dot(a, crate::math::sub(state.velocity.get(node), v));
                v = [
                    v[0] + along * a[0],
                    v[1] + along * a[1],
                    v[2] + along * a[2],
                ];
                let f = crate::math::add(internal.force.get(node), external.force.get(node));
                let fa = dot(f, a);
                let f_perp = [f[0] - fa * a[0], f[1] - fa * a[1], f[2] - fa * a[2]];
                let power = -dot(f_perp, v) - dot(internal.torque.get(e), w_held);
                state.work[r] += dt * power;
                state.velocity.set(node, v);
            } else {
                state.velocity.set(node, v);
                if matches!(end.condition, crate::ends::EndCondition::Driven(_)) {
                    let power =
                        -dot(internal.force.get(node), v) - dot(internal.torque.get(e), w_held);
                    state.work[r] += dt * power;
                }
            }
            if held_frame {
                state.omega.set(e, w);
            }
        }
    }
}

/// Whether the stepper holds an end's frame rigid (clamped and driven ends with the first-order
/// clamp; the second-order clamp joins the frame to the clamp by a spring instead).
#[inline]
fn frame_held(end: &crate::ends::End, settings: &crate::system::Settings) -> bool {
    end.condition.holds_frame() && settings.clamp_order < 2
}

/// The range of free nodes and elements of a rod (held end DOFs are not kicked).
fn free_ranges(
    rod: &crate::system::Rod,
    settings: &crate::system::Settings,
) -> (usize, usize, usize, usize) {
    let n = rod.n_elements();
    let first_node = usize::from(!rod.base.condition.node_moves());
    let last_node = n - usize::from(!rod.tip.condition.node_moves());
    let first_elem = usize::from(frame_held(&rod.base, settings));
    let end_elem = n - usize::from(frame_held(&rod.tip, settings));
    (first_node, last_node, first_elem, end_elem)
}

/// The second-order clamp (docs/physics.md): for each end whose frame the condition holds, a
/// bending/twisting spring between the clamp frame Q_c (at the end node) and the end element,
/// a Voronoi point at half an element's distance: κ = −Log(Q_right Q_leftᵀ) / (l̂/2),
/// τ = B (κ − κ°), added to the element's couple as the interior Voronoi points are
/// (−τ/ε³ on the base element, +τ/ε³ on the tip element, plus (κ × τ) D̂/(2ε³)).
fn add_clamp_couples(
    system: &RodSystem,
    state: &SystemState,
    internal: &mut InternalLoads,
    rk: &[Vec3],
) {
    let t = state.time;
    for rod in &system.rods {
        let m = &rod.model;
        let n = m.n_elements;
        let kap0 = &rk[rod.interior()];
        for (end, side) in [
            (&rod.base, crate::ends::Side::Base),
            (&rod.tip, crate::ends::Side::Tip),
        ] {
            if !end.condition.holds_frame() {
                continue;
            }
            let qc = end.node_frame_at(t);
            let j = side.element(n);
            let e = rod.at.element + j;
            let q = state.director.get(e);
            let (k_rest, bend) = match side {
                crate::ends::Side::Base => (kap0[0], m.bend_stiffness[0]),
                crate::ends::Side::Tip => (kap0[n - 2], m.bend_stiffness[n - 2]),
            };
            let d = 0.5 * m.rest_length[j];
            let theta = match side {
                crate::ends::Side::Base => log_relative(&q, &qc).0,
                crate::ends::Side::Tip => log_relative(&qc, &q).0,
            };
            let kap = [-theta[0] / d, -theta[1] / d, -theta[2] / d];
            let tau = [
                bend[0] * (kap[0] - k_rest[0]),
                bend[1] * (kap[1] - k_rest[1]),
                bend[2] * (kap[2] - k_rest[2]),
            ];
            let eps = internal.dilatation[e];
            let inv_e3 = 1.0 / (eps * eps * eps);
            let kt = cross(kap, tau);
            let sign = match side {
                crate::ends::Side::Base => -1.0,
                crate::ends::Side::Tip => 1.0,
            };
            let hf = 0.5 * d * inv_e3;
            internal.torque.add(
                e,
                [
                    sign * tau[0] * inv_e3 + kt[0] * hf,
                    sign * tau[1] * inv_e3 + kt[1] * hf,
                    sign * tau[2] * inv_e3 + kt[2] * hf,
                ],
            );
        }
    }
}

#[inline(always)]
fn kick(system: &RodSystem, state: &mut SystemState, ws: &mut Workspace, dt: f64) {
    for (r, rod) in system.rods.iter().enumerate() {
        let m = &rod.model;
        let n = m.n_elements;
        let (nodes, elems) = (rod.nodes(), rod.elements());
        let (first_node, last_node, first_elem, end_elem) = free_ranges(rod, &system.settings);
        let k = &ws.kick;
        // Every array cut to this rod's range first: the loops then index without bounds checks.
        let (fix, fiy, fiz) = (
            &ws.internal.force.x[nodes.clone()],
            &ws.internal.force.y[nodes.clone()],
            &ws.internal.force.z[nodes.clone()],
        );
        let (fex, fey, fez) = (
            &ws.external.force.x[nodes.clone()],
            &ws.external.force.y[nodes.clone()],
            &ws.external.force.z[nodes.clone()],
        );
        let (decay, kick_n, rate_n) = (
            &k.node_decay[nodes.clone()],
            &k.node_kick[nodes.clone()],
            &k.node_rate[nodes.clone()],
        );
        let (vx, vy, vz) = (
            &mut state.velocity.x[nodes.clone()],
            &mut state.velocity.y[nodes.clone()],
            &mut state.velocity.z[nodes.clone()],
        );
        let inv_m = &m.inv_node_mass[..n + 1];
        let mass = &m.node_mass[..n + 1];
        let mut work = 0.0;
        let mut diss = 0.0;
        let muscles_on = ws.muscles_on[r];
        let muscle_f = [
            &ws.internal.muscle_force.x[nodes.clone()],
            &ws.internal.muscle_force.y[nodes.clone()],
            &ws.internal.muscle_force.z[nodes.clone()],
        ];
        // Lanes across nodes; the work and dissipation sums take the lanes' terms one by one in
        // node order, as the scalar loop below does (the same additions in the same order).
        let mut i = first_node;
        while i + LANES <= last_node + 1 {
            let (fi, fe) = (load3([fix, fiy, fiz], i), load3([fex, fey, fez], i));
            let im = X::load(inv_m, i);
            let a = [
                (fi[0] + fe[0]) * im,
                (fi[1] + fe[1]) * im,
                (fi[2] + fe[2]) * im,
            ];
            let (dc, kc) = (X::load(decay, i), X::load(kick_n, i));
            let mut mid = [s(0.0); 3];
            for (c, v) in [&mut *vx, &mut *vy, &mut *vz].into_iter().enumerate() {
                let new;
                (new, mid[c]) = kick_component(dc, kc, X::load(v, i), a[c]);
                new.store(v, i);
            }
            let w = dot_r(fe, mid).0;
            let m = if muscles_on {
                dot_r(load3(muscle_f, i), mid).0
            } else {
                [0.0; LANES]
            };
            let d = (X::load(mass, i) * X::load(rate_n, i) * dot_r(mid, mid)).0;
            for l in 0..LANES {
                work += w[l];
                if muscles_on {
                    work += m[l];
                }
                diss += d[l];
            }
            i += LANES;
        }
        for i in i..=last_node {
            let a = [
                (fix[i] + fex[i]) * inv_m[i],
                (fiy[i] + fey[i]) * inv_m[i],
                (fiz[i] + fez[i]) * inv_m[i],
            ];
            let old = [vx[i], vy[i], vz[i]];
            let (mut new, mut mid) = ([0.0; 3], [0.0; 3]);
            for c in 0..3 {
                (new[c], mid[c]) = kick_component(decay[i], kick_n[i], old[c], a[c]);
            }
            work += dot([fex[i], fey[i], fez[i]], mid);
            if muscles_on {
                work += dot(ws.internal.muscle_force.get(nodes.start + i), mid);
            }
            diss += mass[i] * rate_n[i] * dot(mid, mid);
            vx[i] = new[0];
            vy[i] = new[1];
            vz[i] = new[2];
        }
        let gamma_active = rod.damping.gamma > 0.0;
        let (tix, tiy, tiz) = (
            &ws.internal.torque.x[elems.clone()],
            &ws.internal.torque.y[elems.clone()],
            &ws.internal.torque.z[elems.clone()],
        );
        let (cex, cey, cez) = (
            &ws.external.couple.x[elems.clone()],
            &ws.external.couple.y[elems.clone()],
            &ws.external.couple.z[elems.clone()],
        );
        let dil = &ws.internal.dilatation[elems.clone()];
        let (wx, wy, wz) = (
            &mut state.omega.x[elems.clone()],
            &mut state.omega.y[elems.clone()],
            &mut state.omega.z[elems.clone()],
        );
        let [jex, jey, jez] = &mut ws.inertia_over_e;
        let (jex, jey, jez) = (
            &mut jex[elems.clone()],
            &mut jey[elems.clone()],
            &mut jez[elems.clone()],
        );
        let inertia = &m.inertia[..n];
        let inv_inertia = &m.inv_inertia[..n];
        for j in 0..n {
            let (jj, e) = (inertia[j], dil[j]);
            (jex[j], jey[j], jez[j]) = (jj[0] / e, jj[1] / e, jj[2] / e);
        }
        let (jex, jey, jez) = (&*jex, &*jey, &*jez);
        let mut first_scalar = first_elem;
        if !gamma_active {
            // Lanes across elements (constant factors; the per-length rate is scalar below).
            let (decay0, kick0, rate0) = (
                &k.element_decay0[elems.clone()],
                &k.element_kick0[elems.clone()],
                &k.element_rate0[elems.clone()],
            );
            let muscle_c = [
                &ws.internal.muscle_couple.x[elems.clone()],
                &ws.internal.muscle_couple.y[elems.clone()],
                &ws.internal.muscle_couple.z[elems.clone()],
            ];
            let mut j = first_elem;
            while j + LANES <= end_elem {
                let e = X::load(dil, j);
                let (dc, kc, rate) = (X::load(decay0, j), X::load(kick0, j), X::load(rate0, j));
                let tq = load3([tix, tiy, tiz], j);
                let cq = load3([cex, cey, cez], j);
                let inv_j = gather3(inv_inertia, j);
                let joe = load3([jex, jey, jez], j);
                let mc = muscles_on.then(|| load3(muscle_c, j));
                let mut terms = [[[0.0; LANES]; 3]; 3];
                for (c, w) in [&mut *wx, &mut *wy, &mut *wz].into_iter().enumerate() {
                    let alpha = e * (tq[c] + cq[c]) * inv_j[c];
                    let (new, mid) = kick_component(dc, kc, X::load(w, j), alpha);
                    new.store(w, j);
                    terms[0][c] = (cq[c] * mid).0;
                    if let Some(mc) = mc {
                        terms[1][c] = (mc[c] * mid).0;
                    }
                    terms[2][c] = (joe[c] * rate * mid * mid).0;
                }
                for l in 0..LANES {
                    for c in 0..3 {
                        work += terms[0][c][l];
                        if muscles_on {
                            work += terms[1][c][l];
                        }
                        diss += terms[2][c][l];
                    }
                }
                j += LANES;
            }
            first_scalar = j;
        }
        for j in first_scalar..end_elem {
            let e = dil[j];
            let (decay, kick, rate) = k.element(elems.start + j, e, dt, gamma_active);
            let inv_j = inv_inertia[j];
            let tq = [tix[j], tiy[j], tiz[j]];
            let cq = [cex[j], cey[j], cez[j]];
            let old = [wx[j], wy[j], wz[j]];
            let mut new = [0.0; 3];
            for c in 0..3 {
                let alpha = e * (tq[c] + cq[c]) * inv_j[c];
                let mid;
                (new[c], mid) = kick_component(decay, kick, old[c], alpha);
                work += cq[c] * mid;
                if muscles_on {
                    work += ws.internal.muscle_couple.get(elems.start + j)[c] * mid;
                }
                diss += [jex[j], jey[j], jez[j]][c] * rate * mid * mid;
            }
            wx[j] = new[0];
            wy[j] = new[1];
            wz[j] = new[2];
        }
        state.work[r] += dt * work;
        state.dissipated[r] += dt * diss;
    }
}

/// The exact-damping kick of one velocity component (spec eq. 8.3), v ← decay v + kick a:
/// the new value and the midpoint velocity the work and dissipation sums use. Shared with
/// `batch`, so that both perform the same IEEE operations.
#[inline(always)]
pub(crate) fn kick_component<S: Real>(decay: S, kick: S, old: S, accel: S) -> (S, S) {
    let new = decay * old + kick * accel;
    (new, S::splat(0.5) * (old + new))
}

fn apply_analytical_dampers(system: &RodSystem, state: &mut SystemState, ws: &Workspace, dt: f64) {
    for (r, rod) in system.rods.iter().enumerate() {
        let Some(damper) = rod.damping.analytical else {
            continue;
        };
        let m = &rod.model;
        let n = m.n_elements;
        let (n0, e0) = (rod.at.node, rod.at.element);
        let (first_node, last_node, first_elem, end_elem) = free_ranges(rod, &system.settings);
        let dil = &ws.internal.dilatation[e0..e0 + n];
        let mut removed = 0.0;
        if let AnalyticalDamper::Rates {
            translational,
            rotational,
        } = damper
        {
            // Constant factors: one exp per rod and component, not per DOF.
            let f = (-translational * dt).exp();
            let g = rotational.map(|r| (-r * dt).exp());
            let v = &mut state.velocity;
            for i in n0 + first_node..=n0 + last_node {
                let old = [v.x[i], v.y[i], v.z[i]];
                removed += 0.5 * m.node_mass[i - n0] * (1.0 - f * f) * dot(old, old);
                v.x[i] = f * old[0];
                v.y[i] = f * old[1];
                v.z[i] = f * old[2];
            }
            let w = &mut state.omega;
            for j in first_elem..end_elem {
                let (e, k) = (dil[j], e0 + j);
                let old = [w.x[k], w.y[k], w.z[k]];
                for c in 0..3 {
                    removed += 0.5 * m.inertia[j][c] / e * (1.0 - g[c] * g[c]) * old[c] * old[c];
                }
                w.x[k] = g[0] * old[0];
                w.y[k] = g[1] * old[1];
                w.z[k] = g[2] * old[2];
            }
            state.dissipated[r] += removed;
            continue;
        }
        let v = &mut state.velocity;
        for i in first_node..=last_node {
            let f = match damper {
                AnalyticalDamper::Uniform { nu } | AnalyticalDamper::Legacy { nu } => {
                    (-nu * dt).exp()
                }
                AnalyticalDamper::Physical { translational, .. } => {
                    (-translational * dt * m.inv_node_mass[i]).exp()
                }
                AnalyticalDamper::Rates { translational, .. } => (-translational * dt).exp(),
            };
            let g = n0 + i;
            let old = [v.x[g], v.y[g], v.z[g]];
            removed += 0.5 * m.node_mass[i] * (1.0 - f * f) * dot(old, old);
            v.x[g] = f * old[0];
            v.y[g] = f * old[1];
            v.z[g] = f * old[2];
        }
        let w = &mut state.omega;
        for j in first_elem..end_elem {
            let e = dil[j];
            let g = e0 + j;
            let comps = [&mut w.x[g], &mut w.y[g], &mut w.z[g]];
            for (c, wc) in comps.into_iter().enumerate() {
                let f = match damper {
                    AnalyticalDamper::Uniform { nu } => (-nu * dt).exp(),
                    AnalyticalDamper::Rates { rotational, .. } => (-rotational[c] * dt).exp(),
                    AnalyticalDamper::Physical { rotational, .. } => {
                        (-rotational * dt * m.inv_inertia[j][c]).exp().powf(e)
                    }
                    AnalyticalDamper::Legacy { nu } => {
                        let mut mass = 0.5 * (m.node_mass[j] + m.node_mass[j + 1]);
                        if j == 0 {
                            mass += 0.5 * m.node_mass[0];
                        }
                        if j == n - 1 {
                            mass += 0.5 * m.node_mass[n];
                        }
                        (-nu * dt * mass * m.inv_inertia[j][c]).exp().powf(e)
                    }
                };
                removed += 0.5 * m.inertia[j][c] / e * (1.0 - f * f) * *wc * *wc;
                *wc *= f;
            }
        }
        state.dissipated[r] += removed;
    }
}

/// Orthonormality defect above which a rod's frames are re-orthonormalised (see below).
pub(crate) const REORTHONORMALISE_ABOVE: f64 = 0.5e-12;

fn reorthonormalise(system: &RodSystem, state: &mut SystemState) {
    let q = &mut state.director;
    // Per rod, so that a rod's frames do not depend on the other rods of its system.
    for rod in &system.rods {
        let elems = rod.elements();
        let mut worst: f64 = 0.0;
        for j in elems.clone() {
            worst = worst.max(orthonormality_defect(&q.get(j)));
        }
        // Trigger at half the 1e-12 bound that frames must keep (spec §5): under steady bending
        // the defect grows by up to ~5e-14 per 1000-step interval, so triggering at the bound
        // itself let it exceed 1e-12 between checks (1.09e-12 measured, tests/orthonormality.rs).
        if worst > REORTHONORMALISE_ABOVE {
            for j in elems {
                let b = bjorck(&q.get(j));
                q.set(j, &b);
            }
        }
    }
}

/// Largest suggested time step after an instability: min(dt/2, 0.2 · stable dt) [s].
pub fn suggested_dt(system: &RodSystem) -> f64 {
    (0.5 * system.settings.dt).min(0.2 * system.stable_dt())
}

struct Failure {
    what: &'static str,
    value: f64,
    domain: &'static str,
    index: usize,
    zigzag: bool,
    rod: Option<usize>,
}

/// The quantity of a guard failure whose value left the range of float64 (an energy or the
/// work of the loads): no time step helps.
const ENERGY_OVERFLOW: &str = "total energy H [J] (not finite)";
/// The quantity of the automatic time step's re-check (`Settings::max_dt_fraction`).
const DT_RECHECK: &str = "dt / stable limit of the deformed state (automatic time step)";
const WORK_OVERFLOW: &str = "external work or dissipated energy [J] (not finite)";

fn unstable(system: &RodSystem, state: &SystemState, f: Failure) -> StepError {
    let dt = system.settings.dt;
    let suggested_dt = suggested_dt(system);
    let limit = system.stable_dt();
    let advice = if f.what == ENERGY_OVERFLOW || f.what == WORK_OVERFLOW {
        "an energy or the work of the loads overflows the range of float64 numbers: a rest strain \
         (rest_curvature, rest_kappa, rest_sigma), a load value, a stiffness or a mass is far too \
         large; reduce it (a smaller dt does not help)"
            .to_string()
    } else if !(suggested_dt.is_finite() && suggested_dt > 0.0) {
        let shown = if limit == 0.0 {
            "0".to_string()
        } else {
            format!("{limit:.3e}")
        };
        format!(
            "the stable time step of this system is {shown} s: a stiffness, mass or inertia \
             overflows or vanishes; check youngs_modulus, shear_modulus, density and the \
             diameters (no time step can make it stable)"
        )
    } else if f.what == DT_RECHECK {
        let now = system.stable_dt_at(state);
        format!(
            "the deformation raised the highest natural frequency: the stable limit is now \
             {now:.3e} s (at rest {limit:.3e} s), and the automatic dt = {dt:e} s is above {} × \
             that; set a fixed dt ≤ {:.2e} s",
            system.settings.max_dt_fraction.unwrap_or(1.0),
            crate::system::AUTO_DT_FRACTION * now
        )
    } else if dt > 0.2 * limit {
        format!(
            "dt = {dt:e} s is above the recommended 0.2 × stable limit ({limit:.3e} s): reduce dt to {suggested_dt:e} s"
        )
    } else if f.zigzag {
        format!(
            "neighbouring elements alternate in sign (zig-zag growth of the non-variational model): \
             set energy_consistent = true, or reduce dt from {dt:e} s to {suggested_dt:e} s"
        )
    } else {
        format!(
            "the rod may have no equilibrium under its loads (reduce the loads or add damping), \
             or reduce dt from {dt:e} s to {suggested_dt:e} s"
        )
    };
    let rod = match f.rod {
        Some(r) if system.rods.len() > 1 => Some(system.rods[r].name.clone().into_boxed_str()),
        _ => None,
    };
    StepError::Unstable {
        what: f.what,
        value: f.value,
        domain: f.domain,
        index: f.index,
        rod,
        time: state.time,
        step: state.step,
        dt,
        suggested_dt,
        advice,
    }
}

/// Run the stability guard on the current state now (spec §11). The stepper calls it every
/// `guard_interval` steps; call it before recording a frame so that no non-finite data is ever
/// written.
pub fn check(system: &RodSystem, state: &SystemState, ws: &mut Workspace) -> Result<(), StepError> {
    let fail = |f: Failure| Err(unstable(system, state, f));
    for (r, rod) in system.rods.iter().enumerate() {
        let n = rod.n_elements();
        let s = system.view(state, r);
        let at = |what, domain, index| Failure {
            what,
            value: f64::NAN,
            domain,
            index,
            zigzag: false,
            rod: Some(r),
        };
        // Non-finite values first: nothing else is meaningful after them.
        for i in 0..=n {
            if s.position(i).iter().any(|v| !v.is_finite()) {
                return fail(at("position", "node", i));
            }
            if s.velocity(i).iter().any(|v| !v.is_finite()) {
                return fail(at("velocity", "node", i));
            }
        }
        for j in 0..n {
            if s.director(j).iter().flatten().any(|v| !v.is_finite()) {
                return fail(at("director", "element", j));
            }
            if s.omega(j).iter().any(|v| !v.is_finite()) {
                return fail(at("angular velocity", "element", j));
            }
        }
    }
    // Strains, against the rest strains in force.
    let (rs_all, rk_all) =
        rest_in_force(system, state.time, &mut ws.rest_sigma, &mut ws.rest_kappa);
    let dt = system.settings.dt;
    for (r, rod) in system.rods.iter().enumerate() {
        let n = rod.n_elements();
        let m = &rod.model;
        let s = system.view(state, r);
        let rest_sigma = &rs_all[rod.elements()];
        let strain_dev = |j: usize| -> Vec3 {
            let (a, b) = (s.position(j), s.position(j + 1));
            let dx = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let q = mat_vec(&s.director(j), dx);
            [
                q[0] * m.inv_rest_length[j] - rest_sigma[j][0],
                q[1] * m.inv_rest_length[j] - rest_sigma[j][1],
                q[2] * m.inv_rest_length[j] - 1.0 - rest_sigma[j][2],
            ]
        };
        let zigzag = |j: usize, c: usize| -> bool {
            if j == 0 || j + 1 >= n {
                return false;
            }
            let (a, b, d) = (strain_dev(j - 1)[c], strain_dev(j)[c], strain_dev(j + 1)[c]);
            a * b < 0.0 && b * d < 0.0
        };
        let failure = |what, value, domain, index, zigzag| Failure {
            what,
            value,
            domain,
            index,
            zigzag,
            rod: Some(r),
        };
        for j in 0..n {
            let (a, b) = (s.position(j), s.position(j + 1));
            let dx = [b[0] - a[0], b[1] - a[1], b[2] - a[2]];
            let e = dot(dx, dx).sqrt() * m.inv_rest_length[j];
            if !(0.5..=2.0).contains(&e) {
                return fail(failure(
                    "dilatation e (allowed [0.5, 2])",
                    e,
                    "element",
                    j,
                    zigzag(j, 2),
                ));
            }
            let d = strain_dev(j);
            // The signed component is reported (its sign tells compression from stretch).
            const STRAIN: [&str; 3] = [
                "shear strain σ₁ − σ°₁ (allowed [−0.5, 0.5])",
                "shear strain σ₂ − σ°₂ (allowed [−0.5, 0.5])",
                "stretch strain σ₃ − σ°₃ (allowed [−0.5, 0.5])",
            ];
            for c in 0..3 {
                if d[c].abs() > 0.5 {
                    return fail(failure(STRAIN[c], d[c], "element", j, zigzag(j, c)));
                }
            }
        }
        for k in 0..n - 1 {
            let angle = turning_angle(&s.director(k + 1), &s.director(k));
            if angle > 0.9 * std::f64::consts::PI {
                return fail(failure(
                    "turning angle |κ|D̂ (allowed ≤ 0.9π)",
                    angle,
                    "voronoi point",
                    k,
                    false,
                ));
            }
        }
        // Rates.
        for j in 0..n {
            let wj = s.omega(j);
            let w = dot(wj, wj).sqrt();
            if w * dt > 0.2 {
                return fail(failure(
                    "angular speed |ω| dt (allowed ≤ 0.2)",
                    w * dt,
                    "element",
                    j,
                    false,
                ));
            }
        }
        for i in 0..=n {
            let l = if i == 0 {
                m.rest_length[0]
            } else if i == n {
                m.rest_length[n - 1]
            } else {
                m.rest_length[i - 1].min(m.rest_length[i])
            };
            let vi = s.velocity(i);
            let v = dot(vi, vi).sqrt();
            if v * dt > 0.1 * l {
                return fail(failure(
                    "speed |v| dt / l̂ (allowed ≤ 0.1)",
                    v * dt / l,
                    "node",
                    i,
                    false,
                ));
            }
        }
    }
    // An automatic time step stays inside the stable limit of the deformed state.
    if let Some(fraction) = system.settings.max_dt_fraction {
        let (w_rods, r, j) = system.fastest_element_at(state);
        let w = w_rods.max(system.other_max_frequency());
        let ratio = dt * w / 2.0;
        if ratio.is_nan() || ratio > fraction {
            return fail(Failure {
                what: DT_RECHECK,
                value: ratio,
                domain: "element",
                index: j,
                zigzag: false,
                rod: (w_rods >= w).then_some(r),
            });
        }
    }
    // Energy blow-up, with the reference reset whenever the rest strains were changed.
    let checksum = rest_checksum(rs_all, rk_all);
    if checksum != ws.guard.rest_checksum {
        ws.reset_energy_reference(system, state);
    }
    let h = total_energy(system, state, &mut ws.rest_sigma, &mut ws.rest_kappa);
    let work: f64 = state.work.iter().sum();
    // Every part of H is non-negative: a finite H means finite recorded energies.
    if !h.is_finite() {
        return fail(Failure {
            what: ENERGY_OVERFLOW,
            value: h,
            domain: "element",
            index: 0,
            zigzag: false,
            rod: None,
        });
    }
    if let Some(r) = (0..system.rods.len())
        .find(|&r| !(state.work[r].is_finite() && state.dissipated[r].is_finite()))
    {
        return fail(Failure {
            what: WORK_OVERFLOW,
            value: state.work[r] + state.dissipated[r],
            domain: "element",
            index: 0,
            zigzag: false,
            rod: Some(r),
        });
    }
    let window_max = ws.guard.window.iter().copied().fold(0.0, f64::max);
    let bound = 100.0
        * ws.guard
            .reference_energy
            .max(window_max)
            .max(ws.guard.floor)
        + work.abs();
    if h > bound {
        return fail(Failure {
            what: "total energy H [J]",
            value: h,
            domain: "element",
            index: 0,
            zigzag: false,
            rod: None,
        });
    }
    let window_len =
        ((10_000 / system.settings.guard_interval.max(1)) as usize).clamp(1, ENERGY_WINDOW);
    ws.guard.window_pos = (ws.guard.window_pos + 1) % window_len;
    ws.guard.window[ws.guard.window_pos] = h;
    Ok(())
}

#[cfg(test)]
mod tests {
    use crate::{Settings, Simulation, StepError, StraightRod};

    // A state that is finite and passes every rate check (dt is tiny) but whose kinetic energy
    // overflows (an absurd density): the guard must stop it, with advice that does not suggest a time step.
    #[test]
    fn an_overflowing_energy_is_a_guard_failure() {
        let mut arm = StraightRod::paper_arm();
        arm.material.density = 1e300;
        let (model, mut state) = arm.build().unwrap();
        let settings = Settings {
            dt: 1e-300,
            ..Settings::default()
        };
        // |v| is finite, ½ m v² (m ~ 1e293 kg) is not.
        for v in &mut state.velocity {
            *v = [0.0, 1e10, 0.0];
        }
        let mut sim = Simulation::new(model, state, settings).unwrap();
        let e = sim.check().unwrap_err();
        let StepError::Unstable { what, advice, .. } = &e;
        assert!(what.contains("total energy"), "{e}");
        assert!(advice.contains("does not help"), "{e}");
        assert!(!advice.contains("reduce dt to"), "{e}");
    }

    // A rod whose stable time step is 0 (a stiffness overflows the frequency estimate): the
    // advice says what to change instead of "reduce dt to 0e0 s".
    #[test]
    fn no_time_step_advice_when_the_stable_step_vanishes() {
        let mut arm = StraightRod::paper_arm();
        arm.material.youngs_modulus = 1e308;
        let (model, mut state) = arm.build().unwrap();
        assert_eq!(model.stable_dt(), 0.0);
        state.velocity[100] = [0.0, 1.0, 0.0];
        let mut sim = Simulation::new(model, state, Settings::default()).unwrap();
        let e = (0..1000)
            .find_map(|_| sim.step().and_then(|()| sim.check()).err())
            .expect("the guard fires");
        let StepError::Unstable { advice, .. } = &e;
        assert!(advice.contains("no time step can make it stable"), "{e}");
        assert!(!advice.contains("reduce dt"), "{e}");
    }
}
