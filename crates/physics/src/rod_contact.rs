//! Rod–rod and self contact between cylindrical elements (docs/physics.md "Rod–rod and self
//! contact"): the closest points of two element segments, penetration r_a + r_b − d against the
//! current radii, the penalty spring and damper of obstacle contact with the smaller of the two
//! elements' stiffnesses and their reduced mass, regularised Coulomb friction, equal and opposite
//! forces on the two elements' nodes. Elements of one rod closer along it than
//! 1 + ⌈0.8 π r / l̂⌉ are neighbours, not contact (PyElastica's and cosseratbench's rule).
//!
//! With `RodGeometry::Smooth` the gap is measured between the uniform cubic B-splines of the
//! nodes instead of the straight segments: closest points by Newton's method from the segments'
//! ones, each contact owned by the one element pair whose pieces hold it inside, and the force
//! spread over the four nodes of each piece with the curve's own weights (the gradient of the
//! penalty energy, so momentum and angular momentum are kept).
//!
//! Broad phase: a hashed cell grid of element midpoints (cell = the cutoff) builds a Verlet list
//! of candidate pairs with a skin; it is rebuilt only when some midpoint has moved, or some
//! element grown, enough that a pair outside the list could touch. Cost per step is linear in
//! elements plus the candidate pairs; nothing is allocated once the list has reached its size.

use crate::contact::{closest_points, friction_force, RodGeometry};
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
    if params.rod_geometry == RodGeometry::Smooth {
        add_smooth_contact_forces(system, state, sc, dt, out);
        return;
    }
    for &(e, k) in &sc.pairs {
        polyline_pair(system, state, sc, (e as usize, k as usize), dt, out);
    }
}

/// The force of one candidate pair on the polyline (straight segments between nodes).
fn polyline_pair(
    system: &RodSystem,
    state: &SystemState,
    sc: &RodContactScratch,
    (e, k): (usize, usize),
    dt: f64,
    out: &mut ExternalLoads,
) {
    let (ra, rb) = (sc.elem_rod[e] as usize, sc.elem_rod[k] as usize);
    let (ja, jb) = (sc.elem_local[e] as usize, sc.elem_local[k] as usize);
    let (rod_a, rod_b) = (&system.rods[ra], &system.rods[rb]);
    let (na, nb) = (rod_a.at.node + ja, rod_b.at.node + jb);
    // Cheap rejection on midpoints before the segment test.
    let dm = sub(sc.mid[k], sc.mid[e]);
    let reach_pair = 0.5 * (sc.length[e] + sc.length[k]) + sc.radius[e] + sc.radius[k];
    if dot(dm, dm) > reach_pair * reach_pair {
        return;
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
        return;
    }
    let n = scale(1.0 / dist, d);
    let lerp = |x: Vec3, y: Vec3, w: f64| {
        [
            (1.0 - w) * x[0] + w * y[0],
            (1.0 - w) * x[1] + w * y[1],
            (1.0 - w) * x[2] + w * y[2],
        ]
    };
    let vp = lerp(state.velocity.get(na), state.velocity.get(na + 1), s);
    let vq = lerp(state.velocity.get(nb), state.velocity.get(nb + 1), t);
    let f = pair_force(system, (e, k), sc, g, n, sub(vp, vq), da, dt);
    out.force.add(na, scale(1.0 - s, f));
    out.force.add(na + 1, scale(s, f));
    out.force.add(nb, scale(-(1.0 - t), f));
    out.force.add(nb + 1, scale(-t, f));
}

/// The contact force on element e from element k (−it on k): the penalty k_c g with
/// k_c = β min(E Â/l̂) of the two, damping 2ζ√(k_c m_red) on the normal relative velocity, never
/// adhesive, and regularised Coulomb friction along the plane normal to n (e's direction `along`
/// orients the anisotropic coefficients).
#[allow(clippy::too_many_arguments)]
fn pair_force(
    system: &RodSystem,
    (e, k): (usize, usize),
    sc: &RodContactScratch,
    g: f64,
    n: Vec3,
    vrel: Vec3,
    along: Vec3,
    dt: f64,
) -> Vec3 {
    let params = &system.contact;
    let (ra, rb) = (sc.elem_rod[e] as usize, sc.elem_rod[k] as usize);
    let (ja, jb) = (sc.elem_local[e] as usize, sc.elem_local[k] as usize);
    let (ma, mb) = (&system.rods[ra].model, &system.rods[rb].model);
    let ka = ma.material.youngs_modulus * ma.area[ja] / ma.rest_length[ja];
    let kb = mb.material.youngs_modulus * mb.area[jb] / mb.rest_length[jb];
    let kc = params.beta * ka.min(kb);
    let (m1, m2) = (ma.element_mass[ja], mb.element_mass[jb]);
    let m_red = m1 * m2 / (m1 + m2);
    let damping = 2.0 * params.zeta * (kc * m_red).sqrt();
    let vn = dot(vrel, n);
    let fnorm = (kc * g - damping * vn).max(0.0);
    let mut f = scale(fnorm, n);
    if !params.rod_friction.is_none() {
        let tangent = scale(1.0 / norm(along), along);
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
    f
}

/// Uniform cubic B-spline basis at u ∈ [0, 1]: the weights of the four control points P0…P3
/// of a piece (the curve runs from (P0 + 4 P1 + P2)/6 to (P1 + 4 P2 + P3)/6, C² across pieces)
/// and their first and second derivatives in u.
fn bspline(u: f64) -> [[f64; 4]; 3] {
    let v = 1.0 - u;
    let (u2, u3) = (u * u, u * u * u);
    [
        [
            v * v * v / 6.0,
            (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0,
            (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0,
            u3 / 6.0,
        ],
        [
            -0.5 * v * v,
            0.5 * (3.0 * u2 - 4.0 * u),
            0.5 * (-3.0 * u2 + 2.0 * u + 1.0),
            0.5 * u2,
        ],
        [v, 3.0 * u - 2.0, 1.0 - 3.0 * u, u],
    ]
}

/// Σ w_i P_i.
fn combine(p: &[Vec3; 4], w: &[f64; 4]) -> Vec3 {
    let mut out = [0.0; 3];
    for (pi, wi) in p.iter().zip(w) {
        for c in 0..3 {
            out[c] += wi * pi[c];
        }
    }
    out
}

/// One element's piece of the smooth centreline: its rod's first system node, its element
/// index, the rod's element count, and its control points (nodes j−1 … j+2; at a rod's end the
/// missing one reflected, P0 = 2 x_0 − x_1, so the curve ends at the end node along its chord).
struct Piece {
    node0: usize,
    j: usize,
    n: usize,
    points: [Vec3; 4],
}

impl Piece {
    fn new(access: &crate::store::Vec3s, node0: usize, j: usize, n: usize) -> Piece {
        Piece {
            node0,
            j,
            n,
            points: control_points(|i| access.get(node0 + i), j, n),
        }
    }

    /// Weights on nodes j−1 … j+2 of the rod equivalent to `w` on the control points (the
    /// reflected points folded onto the nodes they come from; a missing node gets 0).
    fn node_weights(&self, w: &[f64; 4]) -> [f64; 4] {
        let mut out = *w;
        if self.j == 0 {
            out[1] += 2.0 * w[0];
            out[2] -= w[0];
            out[0] = 0.0;
        }
        if self.j + 1 == self.n {
            out[2] += 2.0 * w[3];
            out[1] -= w[3];
            out[3] = 0.0;
        }
        out
    }

    /// Add `sign · w_i f` to the piece's nodes.
    fn spread(&self, out: &mut ExternalLoads, w: &[f64; 4], f: Vec3, sign: f64) {
        let nw = self.node_weights(w);
        for (i, wi) in nw.iter().enumerate() {
            if *wi != 0.0 {
                out.force
                    .add(self.node0 + self.j + i - 1, scale(sign * wi, f));
            }
        }
    }
}

/// Control points of element j's piece from a node accessor `x(i)` (rod-local node index).
fn control_points(x: impl Fn(usize) -> Vec3, j: usize, n: usize) -> [Vec3; 4] {
    let (p1, p2) = (x(j), x(j + 1));
    let reflect = |a: Vec3, b: Vec3| [2.0 * a[0] - b[0], 2.0 * a[1] - b[1], 2.0 * a[2] - b[2]];
    let p0 = if j > 0 { x(j - 1) } else { reflect(p1, p2) };
    let p3 = if j + 1 < n { x(j + 2) } else { reflect(p2, p1) };
    [p0, p1, p2, p3]
}

/// The closest points (u, t) of two pieces by projected Newton steps on ½|p(u) − q(t)|² from
/// the segments' closest points (s0, t0), each parameter kept in [0, 1]; near-parallel pieces
/// (no reliable 2×2 solve) take coordinate steps instead. Returns u, t, the gradient
/// (∂/∂u, ∂/∂t) of ½|p − q|² there, and whether the pieces cross (the 2×2 solve applied at
/// the last step): a point contact, rather than the line contact of side-by-side pieces.
fn curve_closest(a: &[Vec3; 4], b: &[Vec3; 4], s0: f64, t0: f64) -> (f64, f64, f64, f64, bool) {
    let (mut u, mut t) = (s0, t0);
    let (mut gu, mut gt) = (0.0, 0.0);
    let mut crossing = false;
    for iteration in 0..32 {
        let [wa, da, dda] = bspline(u);
        let [wb, db, ddb] = bspline(t);
        let d = sub(combine(a, &wa), combine(b, &wb));
        let (pu, puu) = (combine(a, &da), combine(a, &dda));
        let (qt, qtt) = (combine(b, &db), combine(b, &ddb));
        gu = dot(d, pu);
        gt = -dot(d, qt);
        if iteration == 31 {
            break;
        }
        let huu = dot(pu, pu) + dot(d, puu);
        let htt = dot(qt, qt) - dot(d, qtt);
        let hut = -dot(pu, qt);
        let det = huu * htt - hut * hut;
        crossing = huu > 0.0 && htt > 0.0 && det > 1e-2 * huu * htt;
        let newton = huu > 0.0 && htt > 0.0 && det > 1e-12 * huu * htt;
        // Active set: a parameter at its bound whose gradient pushes it out stays there, and
        // the other takes a one-dimensional Newton step; with neither held, the 2×2 Newton
        // step (projected onto the box), or where its matrix is singular (parallel pieces) one
        // coordinate step after the other.
        let hold_u = (u <= 0.0 && gu > 0.0) || (u >= 1.0 && gu < 0.0);
        let hold_t = (t <= 0.0 && gt > 0.0) || (t >= 1.0 && gt < 0.0);
        let (nu, nt) = match (hold_u, hold_t) {
            (true, true) => (u, t),
            (true, false) => (u, coordinate_step(t, gt, htt)),
            (false, true) => (coordinate_step(u, gu, huu), t),
            (false, false) if newton => {
                let nu = u - ((htt * gu - hut * gt) / det).clamp(-0.5, 0.5);
                let nt = t - ((huu * gt - hut * gu) / det).clamp(-0.5, 0.5);
                match ((0.0..=1.0).contains(&nu), (0.0..=1.0).contains(&nt)) {
                    (true, true) => (nu, nt),
                    // One parameter leaves the box: it stops at the bound, and the other
                    // takes its best step given that.
                    (false, true) => {
                        let cu = nu.clamp(0.0, 1.0);
                        (cu, coordinate_step(t, gt + hut * (cu - u), htt))
                    }
                    (true, false) => {
                        let ct = nt.clamp(0.0, 1.0);
                        (coordinate_step(u, gu + hut * (ct - t), huu), ct)
                    }
                    (false, false) => {
                        let nu = coordinate_step(u, gu, huu);
                        (nu, coordinate_step(t, gt + hut * (nu - u), htt))
                    }
                }
            }
            (false, false) => {
                // Parallel pieces or a valley of negative curvature: down the valley as far as
                // the box lets it, if that is lower, else a coordinate step.
                let valley = valley_step(a, b, (u, t), (gu, gt), (huu, hut, htt), dot(d, d));
                valley.unwrap_or_else(|| {
                    let nu = coordinate_step(u, gu, huu);
                    (nu, coordinate_step(t, gt + hut * (nu - u), htt))
                })
            }
        };
        let moved = (nu - u).abs() + (nt - t).abs();
        u = nu;
        t = nt;
        if moved < 1e-14 {
            // Converged; the gradient at (u, t).
            let [wa, da, _] = bspline(u);
            let [wb, db, _] = bspline(t);
            let d = sub(combine(a, &wa), combine(b, &wb));
            gu = dot(d, combine(a, &da));
            gt = -dot(d, combine(b, &db));
            break;
        }
    }
    (u, t, gu, gt, crossing)
}

/// From (u, t), along the Hessian's softest direction (turned downhill) to the box's edge or half
/// way: the lower of the two if it is lower than |d|² = `d2` now.
fn valley_step(
    a: &[Vec3; 4],
    b: &[Vec3; 4],
    (u, t): (f64, f64),
    (gu, gt): (f64, f64),
    (huu, hut, htt): (f64, f64, f64),
    d2: f64,
) -> Option<(f64, f64)> {
    let mean = 0.5 * (huu + htt);
    let lambda = mean - (0.25 * (huu - htt) * (huu - htt) + hut * hut).sqrt();
    let (v1, v2) = ([hut, lambda - huu], [lambda - htt, hut]);
    let mut v = if v1[0].hypot(v1[1]) >= v2[0].hypot(v2[1]) {
        v1
    } else {
        v2
    };
    let len = v[0].hypot(v[1]);
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    v = [v[0] / len, v[1] / len];
    if gu * v[0] + gt * v[1] > 0.0 {
        v = [-v[0], -v[1]];
    }
    let reach = |x: f64, vx: f64| {
        if vx > 0.0 {
            (1.0 - x) / vx
        } else if vx < 0.0 {
            -x / vx
        } else {
            f64::INFINITY
        }
    };
    let alpha = reach(u, v[0]).min(reach(t, v[1]));
    if !(alpha > 0.0 && alpha.is_finite()) {
        return None;
    }
    let dist2 = |x: f64, y: f64| {
        let d = sub(combine(a, &bspline(x)[0]), combine(b, &bspline(y)[0]));
        dot(d, d)
    };
    let mut best = None;
    let mut low = d2;
    for f in [1.0, 0.5] {
        let (x, y) = (
            (u + f * alpha * v[0]).clamp(0.0, 1.0),
            (t + f * alpha * v[1]).clamp(0.0, 1.0),
        );
        let e = dist2(x, y);
        if e < low {
            (low, best) = (e, Some((x, y)));
        }
    }
    best
}

/// One projected Newton step in one parameter (gradient g, curvature h), at most half a piece;
/// towards the bound the gradient points to where the curvature is not positive.
fn coordinate_step(x: f64, g: f64, h: f64) -> f64 {
    let step = if h > 0.0 {
        (-g / h).clamp(-0.5, 0.5)
    } else {
        -0.5 * g.signum()
    };
    (x + step).clamp(0.0, 1.0)
}

/// Whether a piece holds the point contact at parameter u (gradient g of the squared distance
/// in u): a contact pushed against the piece's end belongs to the next piece when there is one
/// (at u = 1 always, at u = 0 when it would move on into the previous piece), so that a point
/// contact is counted once as it slides from element to element. (Side-by-side pieces touch
/// along a line: every overlapping pair carries its share, as on the polyline.)
fn owns(u: f64, g: f64, j: usize, n: usize) -> bool {
    !((u >= 1.0 && j + 1 < n) || (u <= 0.0 && j > 0 && g > 0.0))
}

/// Rod–rod and self contact on the smooth (cubic B-spline) centrelines: the same pairs, penalty,
/// damping and friction as the polyline's, with the gap between the curves and the force spread
/// by the curves' weights.
fn add_smooth_contact_forces(
    system: &RodSystem,
    state: &SystemState,
    sc: &RodContactScratch,
    dt: f64,
    out: &mut ExternalLoads,
) {
    for &(e, k) in &sc.pairs {
        let (e, k) = (e as usize, k as usize);
        let (ra, rb) = (sc.elem_rod[e] as usize, sc.elem_rod[k] as usize);
        let (ja, jb) = (sc.elem_local[e] as usize, sc.elem_local[k] as usize);
        let (rod_a, rod_b) = (&system.rods[ra], &system.rods[rb]);
        let dm = sub(sc.mid[k], sc.mid[e]);
        let reach_pair = 0.5 * (sc.length[e] + sc.length[k]) + sc.radius[e] + sc.radius[k];
        if dot(dm, dm) > reach_pair * reach_pair {
            continue;
        }
        let (na, nb) = (rod_a.at.node + ja, rod_b.at.node + jb);
        let (s0, t0) = closest_points(
            state.position.get(na),
            state.position.get(na + 1),
            state.position.get(nb),
            state.position.get(nb + 1),
        );
        let (ma, mb) = (&rod_a.model, &rod_b.model);
        let pa = Piece::new(&state.position, rod_a.at.node, ja, ma.n_elements);
        let pb = Piece::new(&state.position, rod_b.at.node, jb, mb.n_elements);
        let (u, t, gu, gt, point) = curve_closest(&pa.points, &pb.points, s0, t0);
        if !point {
            // Side by side: a line contact, carried pair by pair on the segments.
            polyline_pair(system, state, sc, (e, k), dt, out);
            continue;
        }
        if !owns(u, gu, ja, ma.n_elements) || !owns(t, gt, jb, mb.n_elements) {
            continue;
        }
        let [wa, da, _] = bspline(u);
        let [wb, _, _] = bspline(t);
        let d = sub(combine(&pa.points, &wa), combine(&pb.points, &wb));
        let dist = norm(d);
        let g = sc.radius[e] + sc.radius[k] - dist;
        if g <= 0.0 || dist == 0.0 {
            continue;
        }
        let n = scale(1.0 / dist, d);
        let va = control_points(|i| state.velocity.get(rod_a.at.node + i), ja, ma.n_elements);
        let vb = control_points(|i| state.velocity.get(rod_b.at.node + i), jb, mb.n_elements);
        let vrel = sub(combine(&va, &wa), combine(&vb, &wb));
        let pu = combine(&pa.points, &da);
        let f = pair_force(system, (e, k), sc, g, n, vrel, pu, dt);
        pa.spread(out, &wa, f, 1.0);
        pb.spread(out, &wb, f, -1.0);
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

#[cfg(test)]
mod tests {
    use super::*;

    fn lcg(seed: &mut u64) -> f64 {
        *seed = seed
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        ((*seed >> 11) as f64) / ((1u64 << 53) as f64)
    }

    // The Newton closest points of two pieces against a dense search of the box [0, 1]² (a grid
    // only overestimates the minimum): the box's minimum in all but a few per cent of the pairs
    // within contact range (bent or side-by-side pieces can hold two valleys).
    #[test]
    fn curve_closest_finds_the_minimum_of_the_box() {
        let mut seed = 7u64;
        let (mut worst, mut worst_point): (f64, f64) = (0.0, 0.0);
        let (mut checked, mut missed) = (0usize, 0usize);
        for case in 0..4000 {
            let mut pts = [[[0.0; 3]; 4]; 2];
            // Unit chords turning by up to ~0.4 rad per node, pieces at any angle, up to a
            // chord apart.
            // Every fourth case starts both pieces along one direction (side by side).
            let shared = [
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
                lcg(&mut seed) - 0.5,
            ];
            for (r, piece) in pts.iter_mut().enumerate() {
                let mut dir = [
                    lcg(&mut seed) - 0.5,
                    lcg(&mut seed) - 0.5,
                    lcg(&mut seed) - 0.5,
                ];
                if case % 4 == 0 {
                    dir = shared;
                }
                let n = norm(dir);
                dir = scale(1.0 / n, dir);
                let mut p = [0.0; 3];
                for c in 0..3 {
                    p[c] = 0.6 * (lcg(&mut seed) - 0.5) + 0.2 * r as f64;
                }
                for q in piece.iter_mut() {
                    *q = p;
                    let kick = [
                        lcg(&mut seed) - 0.5,
                        lcg(&mut seed) - 0.5,
                        lcg(&mut seed) - 0.5,
                    ];
                    let turned = [
                        dir[0] + 0.4 * kick[0],
                        dir[1] + 0.4 * kick[1],
                        dir[2] + 0.4 * kick[2],
                    ];
                    dir = scale(1.0 / norm(turned), turned);
                    p = [p[0] + dir[0], p[1] + dir[1], p[2] + dir[2]];
                }
            }
            let (a, b) = (&pts[0], &pts[1]);
            let (s0, t0) = closest_points(a[1], a[2], b[1], b[2]);
            let (u, t, _, _, point) = curve_closest(a, b, s0, t0);
            let dist =
                |u: f64, t: f64| norm(sub(combine(a, &bspline(u)[0]), combine(b, &bspline(t)[0])));
            let found = dist(u, t);
            let (mut best, mut at) = (f64::INFINITY, (0.0, 0.0));
            let m = 200;
            for i in 0..=m {
                for k in 0..=m {
                    let (gu, gt) = (i as f64 / m as f64, k as f64 / m as f64);
                    let d = dist(gu, gt);
                    if d < best {
                        (best, at) = (d, (gu, gt));
                    }
                }
            }
            // Where pieces are within half a chord (contact range: r_a + r_b up to about l),
            // Newton must find the box's minimum; farther apart a second local minimum may hold it.
            if best > 0.5 {
                continue;
            }
            checked += 1;
            let excess = found - best;
            if excess > 1e-12 {
                missed += 1;
            }
            if point {
                worst_point = worst_point.max(excess / best);
            }
            if excess / best > worst {
                worst = excess / best;
                println!(
                    "case {case}: found {found:.6e} at ({u:.4}, {t:.4}), grid best {best:.6e} at {at:?}, start ({s0:.3}, {t0:.3})"
                );
            }
        }
        println!(
            "{checked} pairs within half a chord: {missed} at a local minimum other than the \
             box's; worst excess over the grid {worst:.2e} of the distance, {worst_point:.2e} \
             where the pieces cross"
        );
        assert!(checked > 500);
        // Measured: 6 of 747 (side by side, or bent pieces with two valleys), the worst 7.8 %
        // of the distance side by side and 1.2 % crossing.
        assert!(
            missed * 50 < checked,
            "{missed} of {checked} missed the minimum"
        );
        assert!(
            worst_point <= 0.02,
            "a crossing's point {worst_point} above the minimum"
        );
    }
}
