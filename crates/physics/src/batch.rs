//! `RodBatch`: many rods of one model stepped together, with SIMD lanes across rods (issue 13
//! item 2, the layout of reinforcement-learning batches). It owns the batched state and the
//! batched step; the physics is `step`'s, through the same inline formulas (`internal`,
//! `step::kick_component`, `math`), so every lane equals `Simulation::step` on that rod bit for
//! bit. It does not own the guard (each lane keeps a `Simulation` for `check`) nor anything a
//! batch does not need: contact, joints, loads, muscles, driven ends are refused.
//!
//! Layout: lanes are grouped in chunks of `LANES` rods, and a chunk stores every field as
//! `[component][node or element][lane]`, so each kernel loop is "for each element, for each
//! lane" with lane-wise arithmetic only (no reductions across lanes, no branches on lanes except
//! the rare rotation fallbacks). The last chunk is padded with copies of a real lane whose
//! results are never read. Chunks are independent: stepping them in parallel (rayon) gives the
//! same bits for any thread count.

use crate::damping::KickFactors;
use crate::ends::EndCondition;
use crate::error::{ModelError, StepError};
use crate::internal::{element_loads, voronoi_loads};
use crate::kernel::Kernel;
use crate::lanes::{log_relative_x, s, L, X};
use crate::math::{
    bjorck, dot_r, exp_neg_skew, exp_neg_skew_series_r, mat_mul, mat_mul_r, orthonormality_defect,
    Mat3, Vec3, EXP_SERIES_MAX_SQ,
};
use crate::model::RodModel;
use crate::simulation::Simulation;
use crate::step::{kick_component, REORTHONORMALISE_ABOVE};
use rayon::prelude::*;
use std::sync::Arc;

/// Rods per chunk: the lanes of `lanes::X`, 4 f64 that fill one AVX2 register. (AVX-512's 8
/// lanes would halve the instruction count again on CPUs that have it, but the library
/// dispatches only baseline and AVX2 code; with 4 lanes a batch of 8 arms still makes two chunks
/// for two cores.)
pub const LANES: usize = crate::lanes::LANES;

const ZERO: L = [0.0; LANES];

/// A system a `RodBatch` cannot step, or a lane index out of range.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum BatchError {
    /// The simulation uses something the batched step does not implement.
    #[error("a RodBatch cannot step this simulation: {what}; allowed: {allowed}")]
    Unsupported {
        /// What the simulation has.
        what: &'static str,
        /// What a batch supports instead.
        allowed: &'static str,
    },
    /// Bad input (a count, a length, a lane's simulation that does not fit).
    #[error(transparent)]
    Model(#[from] ModelError),
}

/// Model data every lane shares, laid out for the kernels.
#[derive(Debug, Clone)]
struct Shared {
    model: Arc<RodModel>,
    kick: KickFactors,
    base_position: Vec3,
    base_frame: Mat3,
    dt: f64,
    guard_interval: u64,
    orthonormality_interval: u64,
}

/// One chunk of `LANES` rods: state, per-lane rest strains, scratch and the lanes' guards.
#[derive(Debug, Clone)]
struct Chunk {
    /// Lanes of this chunk that hold real rods (the rest are padding).
    real: usize,
    position: [Vec<L>; 3],
    velocity: [Vec<L>; 3],
    director: [Vec<L>; 9],
    omega: [Vec<L>; 3],
    rest_sigma: [Vec<L>; 3],
    rest_kappa: [Vec<L>; 3],
    step: [u64; LANES],
    origin: L,
    time: L,
    dissipated: L,
    // Scratch of the force evaluation.
    inv_length: Vec<L>,
    dilatation: Vec<L>,
    inv_eps_cubed: Vec<L>,
    elem_force: [Vec<L>; 3],
    couple_pad: [Vec<L>; 3],
    coupling_pad: [Vec<L>; 3],
    torque: [Vec<L>; 3],
    // One lane's rest curvatures, handed to the caller's update between steps.
    kappa_buf: Vec<Vec3>,
    /// Per lane: the simulation whose `check` is the lane's guard (its state is written from
    /// the chunk before each check), and the guard's error once the lane failed.
    guards: Vec<Simulation>,
    failed: Vec<Option<StepError>>,
}

/// B rods sharing one model, each with its own state and rest strains, stepped with SIMD lanes
/// across rods and chunks in parallel (on the current rayon pool). Supported: one rod clamped
/// at its base and free at its tip, mass-proportional damping (`Damping::rate`), the
/// first-order clamp, the plain (not energy-consistent) internal loads, and the guard on
/// `Simulation::step`'s schedule. Every lane equals `Simulation::step` on its rod bit for bit.
#[derive(Debug, Clone)]
pub struct RodBatch {
    shared: Shared,
    chunks: Vec<Chunk>,
    n_lanes: usize,
    kernel: Kernel,
}

fn vecs<const K: usize>(len: usize) -> [Vec<L>; K] {
    std::array::from_fn(|_| vec![ZERO; len])
}

/// Check that `sim` is something the batched step implements, with clear refusals.
fn supported(sim: &Simulation) -> Result<(), BatchError> {
    let sys = &sim.system;
    let no = |what, allowed| Err(BatchError::Unsupported { what, allowed });
    if sys.rods.len() != 1 {
        return no("several rods in one simulation", "one rod per simulation");
    }
    let rod = &sys.rods[0];
    if !matches!(rod.base.condition, EndCondition::Clamped) {
        return no("a base that is not clamped", "a clamped base");
    }
    if !matches!(rod.tip.condition, EndCondition::Free) {
        return no("a tip that is not free", "a free tip");
    }
    if !sys.joints.is_empty() {
        return no("joints", "no joints");
    }
    if !sys.loads.is_empty() {
        return no("external loads", "no loads (rest strains are the input)");
    }
    if !sys.obstacle_set().is_empty() || sys.contact.rod_contact() {
        return no("contact", "no obstacles and no rod–rod contact");
    }
    if !sys.rest_changes.is_empty() {
        return no(
            "scheduled rest-strain changes",
            "rest strains set between steps",
        );
    }
    if rod.muscles.is_some() || sim.actuation.has_muscles() {
        return no("muscles", "no muscles");
    }
    if sim.actuation.has_internal() || sim.actuation.has_external() {
        return no("actuation", "no actuation (rest strains are the input)");
    }
    if rod.damping.gamma != 0.0 || rod.damping.analytical.is_some() {
        return no(
            "per-length or analytical damping",
            "mass-proportional damping (damping.rate) only",
        );
    }
    if sys.settings.clamp_order != 1 {
        return no("clamp_order = 2", "clamp_order = 1");
    }
    if sys.settings.energy_consistent {
        return no("energy_consistent = true", "energy_consistent = false");
    }
    Ok(())
}

impl RodBatch {
    /// A batch of `n_lanes` ≥ 1 copies of `sim` (state, rest strains and guard history
    /// included). Errors when `sim` uses something the batch does not step (naming it) or
    /// `n_lanes` is 0.
    pub fn new(sim: &Simulation, n_lanes: usize) -> Result<Self, BatchError> {
        supported(sim)?;
        if n_lanes == 0 {
            return Err(ModelError::CountOutOfRange {
                field: "n_lanes",
                value: 0,
                range: "[1, inf)",
            }
            .into());
        }
        let sys = &sim.system;
        let rod = &sys.rods[0];
        let model = rod.model.clone();
        let n = model.n_elements;
        let mut kick = KickFactors::new(1, n + 1, n);
        kick.refresh_rod(0, &model, &rod.damping, sys.settings.dt, 0, 0);
        let (base_position, base_frame) = rod.base.pose(0.0);
        let shared = Shared {
            model,
            kick,
            base_position,
            base_frame,
            dt: sys.settings.dt,
            guard_interval: sys.settings.guard_interval,
            orthonormality_interval: sys.settings.orthonormality_interval,
        };
        let n_chunks = n_lanes.div_ceil(LANES);
        let chunk = Chunk {
            real: LANES,
            position: vecs(n + 1),
            velocity: vecs(n + 1),
            director: vecs(n),
            omega: vecs(n),
            rest_sigma: vecs(n),
            rest_kappa: vecs(n - 1),
            step: [0; LANES],
            origin: ZERO,
            time: ZERO,
            dissipated: ZERO,
            inv_length: vec![ZERO; n],
            dilatation: vec![ZERO; n],
            inv_eps_cubed: vec![ZERO; n - 1],
            elem_force: vecs(n + 1),
            couple_pad: vecs(n + 1),
            coupling_pad: vecs(n + 1),
            torque: vecs(n),
            kappa_buf: vec![[0.0; 3]; n - 1],
            guards: vec![sim.clone(); LANES],
            failed: vec![None; LANES],
        };
        let mut chunks = vec![chunk; n_chunks];
        for (c, ch) in chunks.iter_mut().enumerate() {
            ch.real = (n_lanes - c * LANES).min(LANES);
            for l in 0..LANES {
                ch.load_lane(l, sim);
            }
        }
        Ok(Self {
            shared,
            chunks,
            n_lanes,
            kernel: Kernel::selected(),
        })
    }

    /// Number of rods B.
    pub fn n_lanes(&self) -> usize {
        self.n_lanes
    }

    /// Number of elements n of every rod.
    pub fn n_elements(&self) -> usize {
        self.shared.model.n_elements
    }

    /// The shared rod model.
    pub fn model(&self) -> &RodModel {
        &self.shared.model
    }

    /// The kernel the batch runs (initially `Kernel::selected()`).
    pub fn kernel(&self) -> Kernel {
        self.kernel
    }

    /// Run with `kernel` from now on; refused (false, nothing changed) when the CPU cannot run
    /// it. Every kernel gives the same bits.
    pub fn set_kernel(&mut self, kernel: Kernel) -> bool {
        kernel.switch(&mut self.kernel)
    }

    fn lane_index(&self, lane: usize) -> Result<(usize, usize), BatchError> {
        if lane >= self.n_lanes {
            return Err(ModelError::CountOutOfRange {
                field: "lane",
                value: lane,
                range: "[0, n_lanes - 1]",
            }
            .into());
        }
        Ok((lane / LANES, lane % LANES))
    }

    /// Lane `lane` as a `Simulation` (a copy: state, rest strains, guard history). A lane the
    /// guard stopped is returned as it was when the guard fired. Errors for a lane out of range.
    pub fn simulation(&self, lane: usize) -> Result<Simulation, BatchError> {
        let (c, l) = self.lane_index(lane)?;
        let ch = &self.chunks[c];
        let mut sim = ch.guards[l].clone();
        if ch.failed[l].is_none() {
            ch.store_lane(l, &mut sim);
        }
        Ok(sim)
    }

    /// Node positions [m] (lab) of lane `lane` as x, y, z component arrays of n + 1 entries
    /// each, written into `out` (allocation-free; for observations). A stopped lane gives the
    /// state at which its guard fired.
    pub fn positions(&self, lane: usize, out: [&mut [f64]; 3]) -> Result<(), BatchError> {
        self.node_field(lane, out, |ch| &ch.position, |s| &s.position)
    }

    /// Node velocities [m/s] (lab) of lane `lane`, as `positions`.
    pub fn velocities(&self, lane: usize, out: [&mut [f64]; 3]) -> Result<(), BatchError> {
        self.node_field(lane, out, |ch| &ch.velocity, |s| &s.velocity)
    }

    fn node_field(
        &self,
        lane: usize,
        out: [&mut [f64]; 3],
        field: impl Fn(&Chunk) -> &[Vec<L>; 3],
        stopped: impl Fn(&crate::state::SystemState) -> &crate::store::Vec3s,
    ) -> Result<(), BatchError> {
        let (c, l) = self.lane_index(lane)?;
        let ch = &self.chunks[c];
        let nn = self.shared.model.n_elements + 1;
        for o in &out {
            check_len("output array", o.len(), nn)?;
        }
        if ch.failed[l].is_some() {
            let v = stopped(&ch.guards[l].state);
            for (o, src) in out.into_iter().zip([&v.x, &v.y, &v.z]) {
                o.copy_from_slice(src);
            }
        } else {
            for (o, src) in out.into_iter().zip(field(ch)) {
                for (d, s) in o.iter_mut().zip(src) {
                    *d = s[l];
                }
            }
        }
        Ok(())
    }

    /// Replace lane `lane` by `sim` (state, rest strains, guard history), clearing a guard
    /// failure. `sim` must have the batch's model and settings (as `RodBatch::new` would accept
    /// it). Errors name what does not fit.
    pub fn set_lane(&mut self, lane: usize, sim: &Simulation) -> Result<(), BatchError> {
        let (c, l) = self.lane_index(lane)?;
        supported(sim)?;
        let rod = &sim.system.rods[0];
        let sh = &self.shared;
        if *rod.model != *sh.model
            || sim.system.settings.dt != sh.dt
            || sim.system.settings.guard_interval != sh.guard_interval
            || sim.system.settings.orthonormality_interval != sh.orthonormality_interval
            || rod.damping != self.chunks[c].guards[l].system.rods[0].damping
            || rod.base.pose(0.0) != (sh.base_position, sh.base_frame)
        {
            return Err(BatchError::Unsupported {
                what: "a lane with another model, dt, guard settings, damping or base",
                allowed: "the batch's model and settings",
            });
        }
        let ch = &mut self.chunks[c];
        ch.load_lane(l, sim);
        ch.guards[l].clone_from(sim);
        ch.failed[l] = None;
        Ok(())
    }

    /// The guard's error of lane `lane` if it stopped (cleared by `set_lane`).
    pub fn failure(&self, lane: usize) -> Option<&StepError> {
        let (c, l) = self.lane_index(lane).ok()?;
        self.chunks[c].failed[l].as_ref()
    }

    /// Rest curvatures κ° [1/m] of lane `lane` (n − 1 interior points, material) into `out`.
    pub fn rest_kappa(&self, lane: usize, out: &mut [Vec3]) -> Result<(), BatchError> {
        let (c, l) = self.lane_index(lane)?;
        let ch = &self.chunks[c];
        check_len("rest_kappa", out.len(), ch.kappa_buf.len())?;
        gather3(&ch.rest_kappa, l, out);
        Ok(())
    }

    /// Set lane `lane`'s rest curvatures κ° [1/m] (n − 1 finite entries).
    pub fn set_rest_kappa(&mut self, lane: usize, kappa: &[Vec3]) -> Result<(), BatchError> {
        let (c, l) = self.lane_index(lane)?;
        let ch = &mut self.chunks[c];
        check_len("rest_kappa", kappa.len(), ch.kappa_buf.len())?;
        finite("rest_kappa", kappa)?;
        scatter3(&mut ch.rest_kappa, l, kappa);
        Ok(())
    }

    /// Set lane `lane`'s rest shear/stretch strains σ° (n finite entries).
    pub fn set_rest_sigma(&mut self, lane: usize, sigma: &[Vec3]) -> Result<(), BatchError> {
        let (c, l) = self.lane_index(lane)?;
        let n = self.shared.model.n_elements;
        check_len("rest_sigma", sigma.len(), n)?;
        finite("rest_sigma", sigma)?;
        scatter3(&mut self.chunks[c].rest_sigma, l, sigma);
        Ok(())
    }

    /// Advance every lane one step (`run(1)`).
    pub fn step(&mut self) {
        self.run(1);
    }

    /// Advance every lane `steps` steps. A lane whose guard fires stops (see `failure`); the
    /// others go on. Chunks run in parallel on the current rayon pool.
    pub fn run(&mut self, steps: u64) {
        self.run_with(steps, None::<&fn(usize, &mut [Vec3])>);
    }

    /// Advance every lane `steps` steps, calling `update(lane, rest_kappa)` before each step
    /// for every running lane, with that lane's rest curvatures to change in place (a
    /// controller's per-step command; it must leave them finite). Bit-identical to setting
    /// `system.rest_kappa` and calling `Simulation::step` per rod. No allocation.
    pub fn run_with<F>(&mut self, steps: u64, update: Option<&F>)
    where
        F: Fn(usize, &mut [Vec3]) + Sync,
    {
        let (sh, kernel) = (&self.shared, self.kernel);
        let body = |(c, ch): (usize, &mut Chunk)| {
            for _ in 0..steps {
                if let Some(f) = update {
                    ch.update_rest(c * LANES, f);
                }
                match kernel {
                    #[cfg(target_arch = "x86_64")]
                    // SAFETY: `kernel` is `Avx2` only when the CPU has AVX2 and FMA
                    // (`Kernel::selected`, `set_kernel` check `is_available`).
                    Kernel::Avx2 => unsafe { chunk_step_avx2(sh, ch) },
                    _ => chunk_step(sh, ch),
                }
                ch.after_step(sh);
            }
        };
        if self.chunks.len() == 1 {
            body((0, &mut self.chunks[0]));
        } else {
            self.chunks
                .par_iter_mut()
                .enumerate()
                .with_max_len(1)
                .for_each(body);
        }
    }

    /// Run the guard on every running lane now (as `Simulation::check`); a lane that fails
    /// stops. Returns the number of lanes stopped so far.
    pub fn check(&mut self) -> usize {
        let mut failed = 0;
        for ch in &mut self.chunks {
            for l in 0..ch.real {
                if ch.failed[l].is_none() {
                    ch.check_lane(l);
                }
                failed += usize::from(ch.failed[l].is_some());
            }
        }
        failed
    }
}

fn check_len(field: &'static str, len: usize, expected: usize) -> Result<(), BatchError> {
    if len != expected {
        return Err(ModelError::BadLength {
            field,
            len,
            expected,
        }
        .into());
    }
    Ok(())
}

fn finite(field: &'static str, v: &[Vec3]) -> Result<(), BatchError> {
    match v.iter().flatten().find(|x| !x.is_finite()) {
        Some(&value) => Err(ModelError::OutOfRange {
            field,
            value,
            range: "finite",
        }
        .into()),
        None => Ok(()),
    }
}

fn comps3(v: &crate::store::Vec3s) -> [&Vec<f64>; 3] {
    [&v.x, &v.y, &v.z]
}

fn comps3_mut(v: &mut crate::store::Vec3s) -> [&mut Vec<f64>; 3] {
    [&mut v.x, &mut v.y, &mut v.z]
}

fn gather3(src: &[Vec<L>; 3], l: usize, out: &mut [Vec3]) {
    for (k, o) in out.iter_mut().enumerate() {
        *o = [src[0][k][l], src[1][k][l], src[2][k][l]];
    }
}

fn scatter3(dst: &mut [Vec<L>; 3], l: usize, v: &[Vec3]) {
    for (k, a) in v.iter().enumerate() {
        for c in 0..3 {
            dst[c][k][l] = a[c];
        }
    }
}

impl Chunk {
    /// Copy `sim`'s rod state and rest strains into lane `l`.
    fn load_lane(&mut self, l: usize, sim: &Simulation) {
        let s = &sim.state;
        for (dst, src) in [
            (&mut self.position, comps3(&s.position)),
            (&mut self.velocity, comps3(&s.velocity)),
            (&mut self.omega, comps3(&s.omega)),
        ] {
            for c in 0..3 {
                for (d, v) in dst[c].iter_mut().zip(src[c]) {
                    d[l] = *v;
                }
            }
        }
        for k in 0..9 {
            for (d, v) in self.director[k].iter_mut().zip(&s.director.m[k]) {
                d[l] = *v;
            }
        }
        scatter3(&mut self.rest_sigma, l, &sim.system.rest_sigma);
        scatter3(&mut self.rest_kappa, l, &sim.system.rest_kappa);
        self.step[l] = s.step;
        self.origin[l] = s.origin;
        self.time[l] = s.time;
        self.dissipated[l] = s.dissipated[0];
    }

    /// Write lane `l`'s state and rest strains into `sim` (allocation-free). The work of the
    /// external loads is left as it is: a batch has none, and `step` adds only zeros to it.
    fn store_lane(&self, l: usize, sim: &mut Simulation) {
        let s = &mut sim.state;
        for (src, dst) in [
            (&self.position, comps3_mut(&mut s.position)),
            (&self.velocity, comps3_mut(&mut s.velocity)),
            (&self.omega, comps3_mut(&mut s.omega)),
        ] {
            for (c, d) in dst.into_iter().enumerate() {
                for (d, v) in d.iter_mut().zip(&src[c]) {
                    *d = v[l];
                }
            }
        }
        for k in 0..9 {
            for (d, v) in s.director.m[k].iter_mut().zip(&self.director[k]) {
                *d = v[l];
            }
        }
        s.step = self.step[l];
        s.origin = self.origin[l];
        s.time = self.time[l];
        s.dissipated[0] = self.dissipated[l];
        gather3(&self.rest_sigma, l, &mut sim.system.rest_sigma);
        gather3(&self.rest_kappa, l, &mut sim.system.rest_kappa);
    }

    fn update_rest<F: Fn(usize, &mut [Vec3])>(&mut self, first_lane: usize, f: &F) {
        for l in 0..self.real {
            if self.failed[l].is_some() {
                continue;
            }
            let mut buf = std::mem::take(&mut self.kappa_buf);
            gather3(&self.rest_kappa, l, &mut buf);
            f(first_lane + l, &mut buf);
            scatter3(&mut self.rest_kappa, l, &buf);
            self.kappa_buf = buf;
        }
    }

    /// The per-lane end of a step, on `step`'s schedule: re-orthonormalisation, then the guard.
    fn after_step(&mut self, sh: &Shared) {
        for l in 0..self.real {
            if self.failed[l].is_some() {
                continue;
            }
            let s = self.step[l];
            if s % sh.orthonormality_interval == 0 {
                self.reorthonormalise_lane(l);
            }
            if s % sh.guard_interval == 0 {
                self.check_lane(l);
            }
        }
    }

    fn reorthonormalise_lane(&mut self, l: usize) {
        let d = &mut self.director;
        let n = d[0].len();
        let get = |d: &[Vec<L>; 9], j: usize| -> Mat3 {
            std::array::from_fn(|r| std::array::from_fn(|c| d[3 * r + c][j][l]))
        };
        let mut worst: f64 = 0.0;
        for j in 0..n {
            worst = worst.max(orthonormality_defect(&get(d, j)));
        }
        if worst > REORTHONORMALISE_ABOVE {
            for j in 0..n {
                let b = bjorck(&get(d, j));
                for k in 0..9 {
                    d[k][j][l] = b[k / 3][k % 3];
                }
            }
        }
    }

    /// The guard of lane `l`: its simulation gets the lane's state and runs `check`.
    fn check_lane(&mut self, l: usize) {
        // Taken out and put back (no allocation) so that the lane can be written into it.
        let mut guards = std::mem::take(&mut self.guards);
        self.store_lane(l, &mut guards[l]);
        if let Err(e) = guards[l].check() {
            self.failed[l] = Some(e);
        }
        self.guards = guards;
    }
}

/// `chunk_step` compiled with AVX2/FMA enabled (no FMA is used: the same bits).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
unsafe fn chunk_step_avx2(sh: &Shared, ch: &mut Chunk) {
    chunk_step(sh, ch)
}

/// One step of every lane of a chunk, stage for stage as `step::step_body` does it for a lone
/// clamped–free rod without loads (drift, hold, internal loads, kick, hold rates, drift, hold),
/// without the periodic re-orthonormalisation and guard (`Chunk::after_step`).
#[inline(always)]
fn chunk_step(sh: &Shared, ch: &mut Chunk) {
    let dt = sh.dt;
    let h = 0.5 * dt;
    drift(ch, h);
    hold_values(sh, ch);
    internal_loads(sh, ch);
    kick(sh, ch, dt);
    // Hold rates: the clamped base node and element do not move.
    for c in 0..3 {
        ch.velocity[c][0] = ZERO;
        ch.omega[c][0] = ZERO;
    }
    drift(ch, h);
    for l in 0..LANES {
        ch.step[l] += 1;
        ch.time[l] = ch.origin[l] + ch.step[l] as f64 * dt;
    }
    hold_values(sh, ch);
}

#[inline(always)]
fn hold_values(sh: &Shared, ch: &mut Chunk) {
    for c in 0..3 {
        ch.position[c][0] = [sh.base_position[c]; LANES];
    }
    for k in 0..9 {
        ch.director[k][0] = [sh.base_frame[k / 3][k % 3]; LANES];
    }
}

#[inline(always)]
fn s3(v: Vec3) -> [X; 3] {
    [s(v[0]), s(v[1]), s(v[2])]
}

#[inline(always)]
fn at3(v: &[Vec<L>; 3], i: usize) -> [X; 3] {
    [X(v[0][i]), X(v[1][i]), X(v[2][i])]
}

#[inline(always)]
fn frame_at(d: &[Vec<L>; 9], j: usize) -> [[X; 3]; 3] {
    [
        [X(d[0][j]), X(d[1][j]), X(d[2][j])],
        [X(d[3][j]), X(d[4][j]), X(d[5][j])],
        [X(d[6][j]), X(d[7][j]), X(d[8][j])],
    ]
}

#[inline(always)]
fn drift(ch: &mut Chunk, h: f64) {
    for c in 0..3 {
        for (x, v) in ch.position[c].iter_mut().zip(&ch.velocity[c]) {
            *x = (X(*x) + s(h) * X(*v)).0;
        }
    }
    let n = ch.omega[0].len();
    let turn = |w: &[Vec<L>; 3], j: usize| {
        let w = at3(w, j);
        [s(h) * w[0], s(h) * w[1], s(h) * w[2]]
    };
    let mut series_ok = true;
    for j in 0..n {
        let a = turn(&ch.omega, j);
        let t2 = dot_r(a, a);
        for l in 0..LANES {
            series_ok &= t2.0[l] < EXP_SERIES_MAX_SQ;
        }
    }
    let d = &mut ch.director;
    for j in 0..n {
        let a = turn(&ch.omega, j);
        let p = if series_ok {
            mat_mul_r(&exp_neg_skew_series_r(a), &frame_at(d, j))
        } else {
            // Some lane turns by |a| ≥ 0.1 somewhere: every frame takes `exp_neg_skew` (libm
            // inside), per lane, as `step` does then; it equals the series below the bound.
            let q = frame_at(d, j);
            let mut p = q;
            for l in 0..LANES {
                let r = exp_neg_skew([a[0].0[l], a[1].0[l], a[2].0[l]]);
                let ql: Mat3 = q.map(|row| row.map(|x| x.0[l]));
                let pl = mat_mul(&r, &ql);
                for (pr, plr) in p.iter_mut().zip(pl) {
                    for (pc, v) in pr.iter_mut().zip(plr) {
                        pc.0[l] = v;
                    }
                }
            }
            p
        };
        for k in 0..9 {
            d[k][j] = p[k / 3][k % 3].0;
        }
    }
}

#[inline(always)]
fn internal_loads(sh: &Shared, ch: &mut Chunk) {
    let m = &*sh.model;
    let n = m.n_elements;
    let (pos, vel, omega, d) = (&ch.position, &ch.velocity, &ch.omega, &ch.director);
    let edge = |v: &[Vec<L>; 3], j: usize| {
        let (a, b) = (at3(v, j), at3(v, j + 1));
        [b[0] - a[0], b[1] - a[1], b[2] - a[2]]
    };
    let (inv_len, dil) = (&mut ch.inv_length, &mut ch.dilatation);
    for j in 0..n {
        let dx = edge(pos, j);
        let len = dot_r(dx, dx).sqrt();
        inv_len[j] = (s(1.0) / len).0;
        dil[j] = (len * s(m.inv_rest_length[j])).0;
    }
    let (f, tq) = (&mut ch.elem_force, &mut ch.torque);
    for j in 0..n {
        let rates = (edge(vel, j), at3(omega, j), s3(m.inertia[j]));
        let el = element_loads(
            edge(pos, j),
            X(inv_len[j]),
            X(dil[j]),
            s(m.rest_length[j]),
            s(m.inv_rest_length[j]),
            &frame_at(d, j),
            s3(m.shear_stiffness[j]),
            at3(&ch.rest_sigma, j),
            Some(rates),
        );
        for c in 0..3 {
            f[c][j] = el.force[c].0;
            tq[c][j] = el.torque[c].0;
        }
    }
    for fc in f.iter_mut() {
        fc[n] = ZERO;
    }
    let nk = n - 1;
    let inv_e3 = &mut ch.inv_eps_cubed;
    for k in 0..nk {
        let lr = &m.rest_length;
        let eps = s(0.5)
            * (X(dil[k]) * s(lr[k]) + X(dil[k + 1]) * s(lr[k + 1]))
            * s(m.inv_rest_voronoi[k]);
        inv_e3[k] = (s(1.0) / (eps * eps * eps)).0;
    }
    let (tb, hh) = (&mut ch.couple_pad, &mut ch.coupling_pad);
    for k in 0..nk {
        let theta = log_relative_x(&frame_at(d, k + 1), &frame_at(d, k));
        let v = voronoi_loads(
            theta,
            s(m.inv_rest_voronoi[k]),
            s(m.rest_voronoi_length[k]),
            s3(m.bend_stiffness[k]),
            at3(&ch.rest_kappa, k),
            X(inv_e3[k]),
        );
        for c in 0..3 {
            tb[c][k + 1] = v.scaled_couple[c].0;
            hh[c][k + 1] = v.coupling[c].0;
        }
    }
    for c in 0..3 {
        tb[c][0] = ZERO;
        hh[c][0] = ZERO;
        tb[c][n] = ZERO;
        hh[c][n] = ZERO;
    }
    // Loop C of `InternalLoads`: bend/twist difference and coupling average onto elements.
    for c in 0..3 {
        for j in 0..n {
            let t = X(tq[c][j]) + (X(tb[c][j + 1]) - X(tb[c][j]) + X(hh[c][j + 1]) + X(hh[c][j]));
            tq[c][j] = t.0;
        }
    }
}

#[inline(always)]
fn kick(sh: &Shared, ch: &mut Chunk, dt: f64) {
    let m = &*sh.model;
    let k = &sh.kick;
    let n = m.n_elements;
    let f = &ch.elem_force;
    let mut diss = s(0.0);
    // Nodes 1..=n (the clamped base node is not kicked); the nodal force is f_i − f_{i−1}
    // (loop D), plus the external force, zero here (added all the same: x + 0 turns −0 to +0).
    for i in 1..=n {
        let mut mid = [s(0.0); 3];
        for c in 0..3 {
            let force = X(f[c][i]) - X(f[c][i - 1]);
            let a = (force + s(0.0)) * s(m.inv_node_mass[i]);
            let v = &mut ch.velocity[c][i];
            let new;
            (new, mid[c]) = kick_component(s(k.node_decay[i]), s(k.node_kick[i]), X(*v), a);
            *v = new.0;
        }
        diss = diss + s(m.node_mass[i]) * s(k.node_rate[i]) * dot_r(mid, mid);
    }
    let (dil, tq) = (&ch.dilatation, &ch.torque);
    for j in 1..n {
        let e = X(dil[j]);
        for c in 0..3 {
            let j_over_e = s(m.inertia[j][c]) / e;
            let alpha = e * (X(tq[c][j]) + s(0.0)) * s(m.inv_inertia[j][c]);
            let w = &mut ch.omega[c][j];
            let (new, mid) =
                kick_component(s(k.element_decay0[j]), s(k.element_kick0[j]), X(*w), alpha);
            *w = new.0;
            diss = diss + j_over_e * s(k.element_rate0[j]) * mid * mid;
        }
    }
    ch.dissipated = (X(ch.dissipated) + s(dt) * diss).0;
}
