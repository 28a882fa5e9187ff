//! The watertight test of [`super::triangle`] sixteen triangles at a time,
//! for brute force over scenes of a few dozen triangles, where a tree's
//! traversal costs more than testing everything: the same `f32` operations
//! in the same order per lane as [`WatertightRay::intersect4`], written as
//! loops over the lanes that the compiler vectorises for whatever
//! instruction set [`crate::simd`] dispatched, so every lane answers bit for
//! bit as the four-wide routine (vector instructions are IEEE-exact per
//! lane, nothing is contracted into fused multiply-adds, and `max`/`min`
//! follow SSE's `maxps`/`minps`: the second operand unless the first is
//! greater, or less). The comparisons that decide which lanes go on are
//! bit masks, on AVX-512 compared straight into a mask register through
//! `pulp`'s safe wrappers of the intrinsics ([`mask`]).

use super::triangle::{Lanes, WatertightRay};
use super::{Hit, HitFilter};
use crate::math::{Vec3, gamma};

/// Lanes of a [`Tri16`].
pub const LANES: usize = 16;

type Wide = [f32; LANES];

/// Sixteen triangles coordinate by coordinate (`p[corner][axis][lane]`),
/// with their original indices. Unused lanes repeat lane 0 and are masked
/// out by the caller's lane mask.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(C, align(64))]
pub struct Tri16 {
    /// Corner coordinates: `p[corner][axis][lane]`.
    pub p: [[Wide; 3]; 3],
    /// Original triangle index of each lane.
    pub ids: [u32; LANES],
}

impl Tri16 {
    /// A block of 1 to 16 triangles `(id, corners)`; unused lanes repeat
    /// the first. Panics on an empty or too long slice.
    pub fn new(tris: &[(u32, [Vec3; 3])]) -> Tri16 {
        assert!(
            (1..=LANES).contains(&tris.len()),
            "a block holds 1 to 16 triangles"
        );
        let mut b = Tri16 {
            p: [[[0.0; LANES]; 3]; 3],
            ids: [0; LANES],
        };
        for l in 0..LANES {
            let (id, p) = tris[if l < tris.len() { l } else { 0 }];
            for (c, corner) in p.iter().enumerate() {
                for k in 0..3 {
                    b.p[c][k][l] = corner[k];
                }
            }
            b.ids[l] = id;
        }
        b
    }
}

/// SSE's `maxps`: `a` if greater, else `b` (glam's `Vec4::max`).
#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

/// SSE's `minps`: `a` if less, else `b` (glam's `Vec4::min`).
#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Which lanes of a [`Tri16`] a ray hit, and where.
#[derive(Debug, Clone, Copy)]
pub struct Hits16 {
    /// Bit `l` set: lane `l` hit.
    pub mask: u32,
    /// Per lane: the hit's distance,
    pub t: Wide,
    /// and its barycentrics (of the second and third corner).
    pub u: Wide,
    /// See `u`.
    pub v: Wide,
}

impl Hits16 {
    /// Fold these hits into the closest hit so far, lane by lane in order,
    /// as [`super::triangle::Hits4::fold_closest`] does.
    #[inline(always)]
    pub fn fold_closest<F: HitFilter>(
        &self,
        block: &Tri16,
        best: &mut Option<Hit>,
        t_max: &mut f32,
        filter: &F,
    ) {
        self.lanes(block).fold_closest(best, t_max, filter);
    }

    /// Whether some hit counts under `filter`.
    #[inline(always)]
    pub fn any_kept<F: HitFilter>(&self, block: &Tri16, filter: &F) -> bool {
        self.lanes(block).any_kept(filter)
    }

    /// These hits of `block`, lane by lane.
    #[inline(always)]
    fn lanes<'a>(&'a self, block: &'a Tri16) -> Lanes<'a, LANES> {
        Lanes {
            mask: self.mask,
            ids: &block.ids,
            t: &self.t,
            u: &self.u,
            v: &self.v,
        }
    }
}

/// An ordered comparison of two lanes' values (false where either is NaN,
/// as Rust's `<`, `>`, `<=`, `>=` and `==` on `f32`).
#[derive(Debug, Clone, Copy)]
enum Cmp {
    Lt,
    Gt,
    Le,
    Ge,
    Eq,
}

/// The level's AVX-512 token when `S` is AVX-512's: known when the code is
/// compiled for `S`, so the test costs nothing at run time.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn avx512<S: pulp::Simd>(simd: S) -> Option<pulp::x86::V4> {
    (&simd as &dyn std::any::Any)
        .downcast_ref::<pulp::x86::V4>()
        .copied()
}

/// Bit `l` set where `a[l] op b[l]`. On AVX-512 one compare into a mask
/// register (its ordered, quiet predicates are Rust's comparisons); on
/// other levels a loop over the lanes. A bit mask built in a loop becomes,
/// on AVX-512, a chain of shuffles and ors across the vector that every
/// later branch waits on: under `perf`, a fifth of the brute force's time.
#[inline(always)]
fn mask<S: pulp::Simd>(simd: S, op: Cmp, a: &Wide, b: &Wide) -> u32 {
    #[cfg(target_arch = "x86_64")]
    if let Some(v4) = avx512(simd) {
        let (a, b): (pulp::f32x16, pulp::f32x16) =
            (pulp::bytemuck::cast(*a), pulp::bytemuck::cast(*b));
        let m = match op {
            Cmp::Lt => v4.cmp_lt_f32x16(a, b),
            Cmp::Gt => v4.cmp_gt_f32x16(a, b),
            Cmp::Le => v4.cmp_le_f32x16(a, b),
            Cmp::Ge => v4.cmp_ge_f32x16(a, b),
            Cmp::Eq => v4.cmp_eq_f32x16(a, b),
        };
        return u32::from(m.0);
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = simd;
    let mut m = 0u32;
    for l in 0..LANES {
        let (x, y) = (a[l], b[l]);
        let c = match op {
            Cmp::Lt => x < y,
            Cmp::Gt => x > y,
            Cmp::Le => x <= y,
            Cmp::Ge => x >= y,
            Cmp::Eq => x == y,
        };
        m |= u32::from(c) << l;
    }
    m
}

impl WatertightRay {
    /// [`WatertightRay::intersect4`] over the sixteen triangles of `block`
    /// in the lanes set in `lanes`, with `0 < t <= t_max`, compiled for the
    /// instruction set `simd` (the same answers on every one).
    #[inline(always)]
    pub fn intersect16<S: pulp::Simd>(
        &self,
        simd: S,
        block: &Tri16,
        lanes: u32,
        t_max: f32,
    ) -> Hits16 {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let o = self.o.to_array();
        let (sx, sy, sz) = (self.sx, self.sy, self.sz);
        let (mut ax, mut ay, mut a2) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut bx, mut by, mut b2) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut cx, mut cy, mut c2) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut u, mut v, mut w) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let p = &block.p;
        for l in 0..LANES {
            // corners relative to the origin in the ray's permuted axes,
            // sheared so that the ray points down +z
            let rel = |c: usize, k: usize| p[c][k][l] - o[k];
            a2[l] = rel(0, kz);
            b2[l] = rel(1, kz);
            c2[l] = rel(2, kz);
            ax[l] = rel(0, kx) - sx * a2[l];
            ay[l] = rel(0, ky) - sy * a2[l];
            bx[l] = rel(1, kx) - sx * b2[l];
            by[l] = rel(1, ky) - sy * b2[l];
            cx[l] = rel(2, kx) - sx * c2[l];
            cy[l] = rel(2, ky) - sy * c2[l];
            u[l] = cx[l] * by[l] - cy[l] * bx[l];
            v[l] = ax[l] * cy[l] - ay[l] * cx[l];
            w[l] = bx[l] * ay[l] - by[l] * ax[l];
        }
        let zero = [0.0; LANES];
        let cmp = |op, a: &Wide, b: &Wide| mask(simd, op, a, b);
        let zeros = cmp(Cmp::Eq, &u, &zero) | cmp(Cmp::Eq, &v, &zero) | cmp(Cmp::Eq, &w, &zero);
        let redo = zeros & lanes;
        if redo != 0 {
            // an edge function is exactly zero: that triangle's three in
            // f64, one rounding each
            let f =
                |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
            let mut m = redo;
            while m != 0 {
                let l = m.trailing_zeros() as usize;
                m &= m - 1;
                u[l] = f(cx[l], by[l], cy[l], bx[l]);
                v[l] = f(ax[l], cy[l], ay[l], cx[l]);
                w[l] = f(bx[l], ay[l], by[l], ax[l]);
            }
        }
        // most tests end here: no lane is inside its triangle (the lanes
        // that go on get exactly the arithmetic they would have anyway)
        let mut det = [0.0; LANES];
        for l in 0..LANES {
            det[l] = u[l] + v[l] + w[l];
        }
        let any_neg = cmp(Cmp::Lt, &u, &zero) | cmp(Cmp::Lt, &v, &zero) | cmp(Cmp::Lt, &w, &zero);
        let any_pos = cmp(Cmp::Gt, &u, &zero) | cmp(Cmp::Gt, &v, &zero) | cmp(Cmp::Gt, &w, &zero);
        // not `det != 0`: a NaN determinant must fail, as in the four-wide
        // test
        let det_neg = cmp(Cmp::Lt, &det, &zero);
        let det_pos = cmp(Cmp::Gt, &det, &zero);
        let inside = !(any_neg & any_pos) & (det_neg | det_pos);
        if inside & lanes == 0 {
            return Hits16 {
                mask: 0,
                t: [0.0; LANES],
                u: [0.0; LANES],
                v: [0.0; LANES],
            };
        }
        let (g2, g3, g5) = (gamma(2), gamma(3), gamma(5));
        let (mut t, mut uu, mut vv) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        let (mut t_scaled, mut delta_t, mut delta_t16) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        for l in 0..LANES {
            let (u, v, w) = (u[l], v[l], w[l]);
            let az = sz * a2[l];
            let bz = sz * b2[l];
            let cz = sz * c2[l];
            let ts = u * az + v * bz + w * cz;
            let inv = 1.0 / det[l];
            let max_zt = max(max(az.abs(), bz.abs()), cz.abs());
            let max_xt = max(max(ax[l].abs(), bx[l].abs()), cx[l].abs());
            let max_yt = max(max(ay[l].abs(), by[l].abs()), cy[l].abs());
            let delta_z = g3 * max_zt;
            let delta_x = g5 * (max_xt + max_zt);
            let delta_y = g5 * (max_yt + max_zt);
            let delta_e = 2.0 * (g2 * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
            let max_e = max(max(u.abs(), v.abs()), w.abs());
            let spread = max(max(az, bz), cz) - min(min(az, bz), cz) + 2.0 * delta_z;
            let dt = 3.0
                * (g3 * max_e * max_zt + delta_e * min(spread, max_zt) + delta_z * max_e)
                * inv.abs();
            t_scaled[l] = ts;
            delta_t[l] = dt;
            delta_t16[l] = dt * (1.0 / 16.0);
            t[l] = ts * inv;
            uu[l] = v * inv;
            vv[l] = w * inv;
        }
        // the side of the plane the distance's sign says, and a distance
        // within (0, t_max]
        let wrong_side =
            (det_pos & cmp(Cmp::Le, &t_scaled, &zero)) | (det_neg & cmp(Cmp::Ge, &t_scaled, &zero));
        let keep =
            inside & !wrong_side & cmp(Cmp::Gt, &t, &zero) & cmp(Cmp::Le, &t, &[t_max; LANES]);
        // beyond the distance's rounding bound: sure; within a sixteenth of
        // it: decided exactly below
        let sure = keep & cmp(Cmp::Gt, &t, &delta_t);
        let unsure = keep & !sure & cmp(Cmp::Gt, &t, &delta_t16);
        let mut mask = sure & lanes;
        let mut m = unsure & lanes;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            if self.plane_ahead_of(p.map(|c| c.map(|axis| axis[l]))) {
                mask |= 1 << l;
            }
        }
        Hits16 {
            mask,
            t,
            u: uu,
            v: vv,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::triangle::Tri4;
    use crate::math::Ray;
    use crate::sampler::mix64;

    fn unit(k: u64) -> f32 {
        (mix64(k) >> 40) as f32 / (1u64 << 24) as f32
    }

    /// Sixteen lanes' answers under `level`.
    struct Run<'a> {
        wr: &'a WatertightRay,
        block: &'a Tri16,
        lanes: u32,
        t_max: f32,
    }

    impl pulp::WithSimd for Run<'_> {
        type Output = Hits16;
        #[inline(always)]
        fn with_simd<S: pulp::Simd>(self, simd: S) -> Hits16 {
            self.wr
                .intersect16(simd, self.block, self.lanes, self.t_max)
        }
    }

    #[test]
    fn every_lane_answers_as_the_four_wide_test_on_every_instruction_set() {
        // triangles of a grid of squares (shared edges and vertices, where
        // edge functions come out exactly zero), degenerate ones, and
        // random ones; rays aimed at vertices, edges and anywhere, some
        // starting on a triangle (the exact side test near the origin)
        let mut tris: Vec<(u32, [Vec3; 3])> = Vec::new();
        for i in 0..4 {
            for j in 0..4 {
                let p = |a: i32, b: i32| Vec3::new((i + a) as f32, (j + b) as f32, 0.0);
                tris.push((0, [p(0, 0), p(1, 0), p(1, 1)]));
                tris.push((0, [p(0, 0), p(1, 1), p(0, 1)]));
            }
        }
        tris.push((0, [Vec3::ZERO, Vec3::X, 2.0 * Vec3::X]));
        tris.push((0, [Vec3::Y; 3]));
        for k in 0..30u64 {
            let c = |m: u64| Vec3::new(unit(9 * k + m), unit(9 * k + m + 3), unit(9 * k + m + 6));
            tris.push((0, [c(0) * 4.0, c(1) * 4.0, c(2) * 4.0 - Vec3::Z]));
        }
        for (i, t) in tris.iter_mut().enumerate() {
            t.0 = i as u32;
        }
        let mut rays = Vec::new();
        for k in 0..400u64 {
            let target = match k % 4 {
                0 => Vec3::new((k % 5) as f32, (k / 5 % 5) as f32, 0.0),
                1 => Vec3::new((k % 5) as f32 + 0.5 * unit(k), (k / 5 % 5) as f32, 0.0),
                2 => {
                    let t = tris[k as usize % tris.len()].1;
                    (t[0] + t[1] + t[2]) / 3.0
                }
                _ => Vec3::new(unit(k) * 4.0, unit(k + 1) * 4.0, unit(k + 2) - 0.5),
            };
            let from = Vec3::new(
                unit(3 * k) - 0.5,
                unit(3 * k + 1) - 0.5,
                unit(3 * k + 2) + 0.2,
            );
            let o = if k % 7 == 0 {
                // on a triangle's plane, a hair away
                let t = tris[k as usize % tris.len()].1;
                (t[0] + t[1] + t[2]) / 3.0 + Vec3::Z * 1e-6
            } else {
                target + from * 3.0
            };
            let d = (target - o).normalize();
            if d.is_finite() {
                rays.push(Ray {
                    o,
                    d,
                    t_max: if k % 3 == 0 { 2.5 } else { f32::INFINITY },
                });
            }
        }
        let mut hits = 0;
        for level in crate::simd::Level::supported() {
            let dispatch = level.dispatcher();
            for ray in &rays {
                let wr = WatertightRay::new(ray);
                for chunk in tris.chunks(LANES) {
                    let block = Tri16::new(chunk);
                    let lanes = (1u32 << chunk.len()).wrapping_sub(1);
                    let wide = dispatch.run(Run {
                        wr: &wr,
                        block: &block,
                        lanes,
                        t_max: ray.t_max,
                    });
                    for (l, &(_, p)) in chunk.iter().enumerate() {
                        let four = Tri4::new(&[(0, p)]);
                        let narrow = wr.intersect4(&four, 1, ray.t_max).hit(0);
                        let lane =
                            (wide.mask >> l & 1 != 0).then(|| (wide.t[l], wide.u[l], wide.v[l]));
                        let bits = |h: Option<(f32, f32, f32)>| {
                            h.map(|(t, u, v)| [t, u, v].map(f32::to_bits))
                        };
                        assert_eq!(
                            bits(lane),
                            bits(narrow.map(|h| (h.t, h.u, h.v))),
                            "{level}: ray {ray:?}, triangle {p:?}"
                        );
                        hits += usize::from(lane.is_some());
                    }
                }
            }
        }
        assert!(hits > 200, "{hits} hits: the rays must meet triangles");
    }
}
