//! Rod–rod and self contact between cylindrical elements (docs/physics.md "Rod–rod and self
//! contact"): the closest points of two element segments, penetration r_a + r_b − d against the
//! current radii, the penalty spring and damper of obstacle contact with the smaller of the two
//! elements' stiffnesses and their reduced mass, regularised Coulomb friction, equal and opposite
//! forces on the two elements' nodes. Elements of one rod closer along it than
//! 1 + ⌈0.8 π r / l̂⌉ are neighbours, not contact (PyElastica's and cosseratbench's rule).
//!
//! Broad phase: a hashed cell grid of element midpoints (cell = the cutoff) builds a Verlet list
//! of candidate pairs with a skin; it is rebuilt only when some midpoint has moved, or some
//! element grown, enough that a pair outside the list could touch. Cost per step is linear in
//! elements plus the candidate pairs; nothing is allocated once the list has reached its size.

use crate::contact::{closest_points, friction_force};
use crate::loads::ExternalLoads;
use crate::math::{dot, norm, scale, sub, Vec3};
use crate::state::SystemState;
use crate::system::RodSystem;

/// Scratch of the rod–rod contact: per-element geometry, the cell grid, the Verlet list.
#[derive(Debug, Clone, Default)]
#[cfg_attr(feature = "serde", derive(serde::Serialize, serde::Deserialize))]
pub struct RodContactScratch {
    elem_rod: Vec<u32>,
    elem_local: Vec<u32>,
    mid: Vec<Vec3>,
    mid_at_build: Vec<Vec3>,
    length: Vec<f64>,
    radius: Vec<f64>,
    cell: Vec<[i64; 3]>,
    bucket_start: Vec<u32>,
    bucket_items: Vec<u32>,
    bucket_fill: Vec<u32>,
    pairs: Vec<(u32, u32)>,
    cutoff: f64,
    built_for: (bool, bool),
    valid: bool,
    rebuilds: u64,
}

fn hash_cell(c: [i64; 3], mask: usize) -> usize {
    let h = (c[0].wrapping_mul(73_856_093))
        ^ (c[1].wrapping_mul(19_349_663))
        ^ (c[2].wrapping_mul(83_492_791));
    (h as u64 as usize) & mask
}

impl RodContactScratch {
    /// Scratch for `system` (sized once).
    pub(crate) fn new(system: &RodSystem) -> Self {
        let ne = system.n_elements;
        let mut elem_rod = Vec::with_capacity(ne);
        let mut elem_local = Vec::with_capacity(ne);
        for (r, rod) in system.rods.iter().enumerate() {
            for j in 0..rod.n_elements() {
                elem_rod.push(r as u32);
                elem_local.push(j as u32);
            }
        }
        let table = (2 * ne).next_power_of_two().max(16);
        Self {
            elem_rod,
            elem_local,
            mid: vec![[0.0; 3]; ne],
            mid_at_build: vec![[0.0; 3]; ne],
            length: vec![0.0; ne],
            radius: vec![0.0; ne],
            cell: vec![[0; 3]; ne],
            bucket_start: vec![0; table + 1],
            bucket_items: vec![0; ne],
            bucket_fill: vec![0; table],
            pairs: Vec::with_capacity(8 * ne),
            cutoff: 0.0,
            built_for: (false, false),
            valid: false,
            rebuilds: 0,
        }
    }

    /// Number of Verlet-list rebuilds so far.
    pub fn rebuilds(&self) -> u64 {
        self.rebuilds
    }

    /// Candidate pairs (global element indices, first < second) of the last rebuild.
    pub fn candidate_pairs(&self) -> &[(u32, u32)] {
        &self.pairs
    }

    fn refresh_geometry(&mut self, system: &RodSystem, state: &SystemState) -> (f64, f64) {
        let (mut l_max, mut r_max) = (0.0f64, 0.0f64);
        for rod in &system.rods {
            let m = &rod.model;
            for j in 0..m.n_elements {
                let e = rod.at.element + j;
                let a = state.position.get(rod.at.node + j);
                let b = state.position.get(rod.at.node + j + 1);
                let d = sub(b, a);
                let l = norm(d);
                self.mid[e] = [a[0] + 0.5 * d[0], a[1] + 0.5 * d[1], a[2] + 0.5 * d[2]];
                self.length[e] = l;
                let r = m.radius[j] / (l / m.rest_length[j]).sqrt();
                self.radius[e] = r;
                l_max = l_max.max(l);
                r_max = r_max.max(r);
            }
        }
        (l_max, r_max)
    }

    fn needs_rebuild(&self, reach: f64, flags: (bool, bool)) -> bool {
        if !self.valid || !(reach.is_finite()) || flags != self.built_for {
            return true;
        }
        let mut d2: f64 = 0.0;
        for (m, m0) in self.mid.iter().zip(&self.mid_at_build) {
            let d = sub(*m, *m0);
            d2 = d2.max(dot(d, d));
        }
        reach + 2.0 * d2.sqrt() > self.cutoff
    }

    fn rebuild(&mut self, system: &RodSystem, reach: f64) {
        let params = &system.contact;
        self.rebuilds += 1;
        self.cutoff = 1.5 * reach;
        self.mid_at_build.copy_from_slice(&self.mid);
        self.built_for = (params.rods, params.self_contact);
        self.pairs.clear();
        self.valid = true;
        let h = self.cutoff;
        if !(h > 0.0 && h.is_finite()) {
            return;
        }
        let ne = self.mid.len();
        let table = self.bucket_fill.len();
        let mask = table - 1;
        self.bucket_fill.fill(0);
        for e in 0..ne {
            let m = self.mid[e];
            let c = [
                (m[0] / h).floor() as i64,
                (m[1] / h).floor() as i64,
                (m[2] / h).floor() as i64,
            ];
            self.cell[e] = c;
            self.bucket_fill[hash_cell(c, mask)] += 1;
        }
        self.bucket_start[0] = 0;
        for b in 0..table {
            self.bucket_start[b + 1] = self.bucket_start[b] + self.bucket_fill[b];
        }
        self.bucket_fill.fill(0);
        for e in 0..ne {
            let b = hash_cell(self.cell[e], mask);
            self.bucket_items[(self.bucket_start[b] + self.bucket_fill[b]) as usize] = e as u32;
            self.bucket_fill[b] += 1;
        }
        let cut2 = h * h;
        for e in 0..ne {
            let c = self.cell[e];
            let mut buckets = [0usize; 27];
            let mut nb = 0;
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        buckets[nb] = hash_cell([c[0] + dx, c[1] + dy, c[2] + dz], mask);
                        nb += 1;
                    }
                }
            }
            buckets.sort_unstable();
            let mut last = usize::MAX;
            for &b in &buckets {
                if b == last {
                    continue;
                }
                last = b;
                let (s0, s1) = (
                    self.bucket_start[b] as usize,
                    self.bucket_start[b + 1] as usize,
                );
                for idx in s0..s1 {
                    let k = self.bucket_items[idx] as usize;
                    if k <= e {
                        continue;
                    }
                    if !self.allowed(system, e, k, params.rods, params.self_contact) {
                        continue;
                    }
                    let d = sub(self.mid[k], self.mid[e]);
                    if dot(d, d) <= cut2 {
                        self.pairs.push((e as u32, k as u32));
                    }
                }
            }
        }
        self.pairs.sort_unstable();
    }

    fn allowed(
        &self,
        system: &RodSystem,
        e: usize,
        k: usize,
        rods: bool,
        self_contact: bool,
    ) -> bool {
        let (ra, rb) = (self.elem_rod[e] as usize, self.elem_rod[k] as usize);
        if ra != rb {
            return rods;
        }
        if !self_contact {
            return false;
        }
        let m = &system.rods[ra].model;
        let (ja, jb) = (self.elem_local[e] as usize, self.elem_local[k] as usize);
        let r = m.radius[ja].max(m.radius[jb]);
        let l = m.rest_length[ja].min(m.rest_length[jb]);
        jb - ja >= neighbour_elements(r, l)
    }
}

/// How far apart along a rod two of its elements must be before they can touch:
/// 1 + ⌈0.8 π r / l̂⌉ (PyElastica's and cosseratbench's rule).
pub fn neighbour_elements(radius: f64, segment_length: f64) -> usize {
    1 + (0.8 * std::f64::consts::PI * radius / segment_length).ceil() as usize
}

/// Add the forces of every touching element pair to `out` (system node order).
pub(crate) fn add_rod_contact_forces(
    system: &RodSystem,
    state: &SystemState,
    sc: &mut RodContactScratch,
    dt: f64,
    out: &mut ExternalLoads,
) {
    let (l_max, r_max) = sc.refresh_geometry(system, state);
    let reach = l_max + 2.0 * r_max;
    let flags = (system.contact.rods, system.contact.self_contact);
    if sc.needs_rebuild(reach, flags) {
        sc.rebuild(system, reach);
    }
    let params = &system.contact;
    for &(e, k) in &sc.pairs {
        let (e, k) = (e as usize, k as usize);
        let (ra, rb) = (sc.elem_rod[e] as usize, sc.elem_rod[k] as usize);
        let (ja, jb) = (sc.elem_local[e] as usize, sc.elem_local[k] as usize);
        let (rod_a, rod_b) = (&system.rods[ra], &system.rods[rb]);
        let (na, nb) = (rod_a.at.node + ja, rod_b.at.node + jb);
        // Cheap rejection on midpoints before the segment test.
        let dm = sub(sc.mid[k], sc.mid[e]);
        let reach_pair = 0.5 * (sc.length[e] + sc.length[k]) + sc.radius[e] + sc.radius[k];
        if dot(dm, dm) > reach_pair * reach_pair {
            continue;
        }
        let (a0, a1) = (state.position.get(na), state.position.get(na + 1));
        let (b0, b1) = (state.position.get(nb), state.position.get(nb + 1));
        let (s, t) = closest_points(a0, a1, b0, b1);
        let da = sub(a1, a0);
        let db = sub(b1, b0);
        let p = [a0[0] + s * da[0], a0[1] + s * da[1], a0[2] + s * da[2]];
        let q = [b0[0] + t * db[0], b0[1] + t * db[1], b0[2] + t * db[2]];
        let d = sub(p, q);
        let dist = norm(d);
        let g = sc.radius[e] + sc.radius[k] - dist;
        if g <= 0.0 || dist == 0.0 {
            continue;
        }
        let n = scale(1.0 / dist, d);
        let (ma, mb) = (&rod_a.model, &rod_b.model);
        let ka = ma.material.youngs_modulus * ma.area[ja] / ma.rest_length[ja];
        let kb = mb.material.youngs_modulus * mb.area[jb] / mb.rest_length[jb];
        let kc = params.beta * ka.min(kb);
        let (m1, m2) = (ma.element_mass[ja], mb.element_mass[jb]);
        let m_red = m1 * m2 / (m1 + m2);
        let damping = 2.0 * params.zeta * (kc * m_red).sqrt();
        let lerp = |x: Vec3, y: Vec3, w: f64| {
            [
                (1.0 - w) * x[0] + w * y[0],
                (1.0 - w) * x[1] + w * y[1],
                (1.0 - w) * x[2] + w * y[2],
            ]
        };
        let vp = lerp(state.velocity.get(na), state.velocity.get(na + 1), s);
        let vq = lerp(state.velocity.get(nb), state.velocity.get(nb + 1), t);
        let vrel = sub(vp, vq);
        let vn = dot(vrel, n);
        let fnorm = (kc * g - damping * vn).max(0.0);
        let mut f = scale(fnorm, n);
        if !params.rod_friction.is_none() {
            let tangent = scale(1.0 / norm(da), da);
            let vt = sub(vrel, scale(vn, n));
            let c = params.friction_eta * m_red / dt;
            let ft = friction_force(
                vt,
                tangent,
                n,
                fnorm,
                &params.rod_friction,
                c,
                params.slip_velocity,
            );
            f = [f[0] + ft[0], f[1] + ft[1], f[2] + ft[2]];
        }
        out.force.add(na, scale(1.0 - s, f));
        out.force.add(na + 1, scale(s, f));
        out.force.add(nb, scale(-(1.0 - t), f));
        out.force.add(nb + 1, scale(-t, f));
    }
}

/// Closest approach between the surfaces of any two elements that may touch (pairs of
/// different rods when `rods`, pairs of one rod beyond the neighbour exclusion when
/// `self_contact`), by brute force over all pairs: the signed gap d − r_a − r_b [m] and the two
/// global element indices. For checks and tests (O(n²)).
pub fn min_rod_gap(
    system: &RodSystem,
    state: &SystemState,
    rods: bool,
    self_contact: bool,
) -> (f64, usize, usize) {
    let mut sc = RodContactScratch::new(system);
    sc.refresh_geometry(system, state);
    let ne = sc.mid.len();
    let mut best = (f64::INFINITY, 0, 0);
    for e in 0..ne {
        for k in e + 1..ne {
            if !sc.allowed(system, e, k, rods, self_contact) {
                continue;
            }
            let (ra, rb) = (sc.elem_rod[e] as usize, sc.elem_rod[k] as usize);
            let na = system.rods[ra].at.node + sc.elem_local[e] as usize;
            let nb = system.rods[rb].at.node + sc.elem_local[k] as usize;
            let (a0, a1) = (state.position.get(na), state.position.get(na + 1));
            let (b0, b1) = (state.position.get(nb), state.position.get(nb + 1));
            let (s, t) = closest_points(a0, a1, b0, b1);
            let p = [
                a0[0] + s * (a1[0] - a0[0]),
                a0[1] + s * (a1[1] - a0[1]),
                a0[2] + s * (a1[2] - a0[2]),
            ];
            let q = [
                b0[0] + t * (b1[0] - b0[0]),
                b0[1] + t * (b1[1] - b0[1]),
                b0[2] + t * (b1[2] - b0[2]),
            ];
            let gap = norm(sub(p, q)) - sc.radius[e] - sc.radius[k];
            if gap < best.0 {
                best = (gap, e, k);
            }
        }
    }
    best
}

/// Every pair of elements (global indices, first < second) that may touch and whose midpoints
/// lie within `cutoff`, by brute force (for testing the broad phase).
pub fn brute_force_pairs(system: &RodSystem, state: &SystemState, cutoff: f64) -> Vec<(u32, u32)> {
    let mut sc = RodContactScratch::new(system);
    sc.refresh_geometry(system, state);
    let p = &system.contact;
    let ne = sc.mid.len();
    let mut out = Vec::new();
    for e in 0..ne {
        for k in e + 1..ne {
            let d = sub(sc.mid[k], sc.mid[e]);
            if sc.allowed(system, e, k, p.rods, p.self_contact) && dot(d, d) <= cutoff * cutoff {
                out.push((e as u32, k as u32));
            }
        }
    }
    out
}

/// The broad phase's candidate pairs for `state` built from scratch, and its cutoff (for tests).
pub fn broad_phase_pairs(system: &RodSystem, state: &SystemState) -> (Vec<(u32, u32)>, f64) {
    let mut sc = RodContactScratch::new(system);
    let (l, r) = sc.refresh_geometry(system, state);
    sc.rebuild(system, l + 2.0 * r);
    (sc.pairs.clone(), sc.cutoff)
}
