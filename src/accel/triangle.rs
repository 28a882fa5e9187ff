//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013. The ray is sheared so that it
//! points down +z from the origin; the three 2D edge functions then decide
//! inside/outside consistently for neighbouring triangles (no ray slips
//! through a shared edge or vertex). Edge functions that come out exactly zero
//! are recomputed in `f64`, as the paper recommends. There is no determinant
//! epsilon: thin triangles are hit; only exactly degenerate ones (`det == 0`)
//! are not. A hit whose `t` is not conservatively positive (within the
//! rounding-error bound of `t`, pbrt-v4 section 6.8.4) stands only if the
//! triangle's plane is certainly ahead of the origin, decided in `f64`
//! (near a concave edge a large wall can be hit closer than its bound); the
//! bound's edge-function term uses the spread of the corners' distances
//! where pbrt-v4 uses their largest value, which is the same where
//! self-intersection can happen and keeps small, distant triangles hit
//! (see [`WatertightRay::intersect4`]).

use super::{Hit, HitFilter};
use crate::math::{Ray, Vec3, gamma};
use glam::Vec4;

/// A bound on how far two correct `f32` ray/triangle tests (this one, or
/// Embree's) may place the hit along the ray: `gamma(16) * R / |cos|`, where
/// `R` is the largest distance from the origin to a corner and `cos` the
/// cosine between the ray and the triangle's normal.
///
/// Why: the edge functions are differences of products of corner
/// coordinates relative to the origin, so each carries an absolute error of
/// a few ulps of `R^2`; the determinant (twice the projected area) is about
/// `R^2 |cos|` for a triangle whose size is comparable to `R`, and `t` is the
/// corners' distances (up to `R`) weighted by edge function / determinant.
/// Hence `|dt| ~ eps R / |cos|`: a triangle much larger than the hit distance
/// pins `t` down no better than that, whichever routine computes it
/// (pbrt-v4 section 6.8.4 bounds the same terms). Returns infinity for a
/// degenerate triangle.
pub fn distance_error_bound(p: [Vec3; 3], ray: &Ray) -> f32 {
    let n = (p[1] - p[0]).cross(p[2] - p[0]);
    let cos = n.normalize_or_zero().dot(ray.d.normalize()).abs();
    let r = p
        .iter()
        .map(|q| (*q - ray.o).length())
        .fold(0.0f32, f32::max);
    if cos > 0.0 {
        gamma(16) * r / cos
    } else {
        f32::INFINITY
    }
}

/// A ray prepared for the watertight test: the permutation and shear.
#[derive(Debug, Clone, Copy)]
pub struct WatertightRay {
    pub(super) o: Vec3,
    /// The direction (for the exact side test of hits near the origin).
    d: Vec3,
    pub(super) kx: usize,
    pub(super) ky: usize,
    pub(super) kz: usize,
    pub(super) sx: f32,
    pub(super) sy: f32,
    pub(super) sz: f32,
    t_max: f32,
}

impl WatertightRay {
    /// Prepare `ray` (its direction must be non-zero and finite).
    #[inline]
    pub fn new(ray: &Ray) -> Self {
        let d = ray.d;
        let a = d.abs();
        let kz = if a.x > a.y {
            if a.x > a.z { 0 } else { 2 }
        } else if a.y > a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        WatertightRay {
            o: ray.o,
            d,
            kx,
            ky,
            kz,
            sx: d[kx] / d[kz],
            sy: d[ky] / d[kz],
            sz: 1.0 / d[kz],
            t_max: ray.t_max,
        }
    }

    /// The ray's current extent.
    pub fn t_max(&self) -> f32 {
        self.t_max
    }

    /// The axis along which hit distances are measured: the direction's
    /// largest component. A reported `t` is, up to a few roundings, a convex
    /// combination of the corners' distances `(p_i[kz] - o[kz]) / d[kz]`,
    /// hence never below the smallest of them (the BVH culls boxes with
    /// this bound).
    pub fn kz(&self) -> usize {
        self.kz
    }

    /// Intersect triangle `(p0, p1, p2)` with `0 < t <= t_max`. The returned
    /// hit has `prim = 0`; the caller sets it. This is [`Self::intersect4`]
    /// on a block holding the one triangle, so it answers bit for bit alike.
    #[inline]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<Hit> {
        let mut block = Tri4::default();
        block.set(0, [p0, p1, p2], 0);
        self.intersect4(&block, 1, t_max).hit(0)
    }

    /// Whether the plane of lane `l`'s triangle is certainly ahead of the
    /// origin along the ray: `(p0 - o) . n / (d . n) > 0`, in `f64` from the
    /// exact `f32` inputs, its numerator's sign beyond its rounding error.
    #[cold]
    fn plane_ahead(&self, block: &Tri4, l: usize) -> bool {
        self.plane_ahead_of(block.p.map(|c| c.map(|axis| axis[l])))
    }

    /// [`WatertightRay::plane_ahead`] for the triangle of corners `p`
    /// (`p[corner][axis]`).
    #[cold]
    pub(super) fn plane_ahead_of(&self, p: [[f32; 3]; 3]) -> bool {
        let c = |k: usize| glam::DVec3::from(p[k].map(f64::from));
        let (p0, p1, p2) = (c(0), c(1), c(2));
        // differences of f32 values are exact in f64 unless their
        // exponents are far apart; the cross product rounds twice per term
        let n = (p1 - p0).cross(p2 - p0);
        let r = p0 - self.o.as_dvec3();
        let num = r.dot(n);
        let den = self.d.as_dvec3().dot(n);
        // every term of num is a product of roundings: 1e-12 of the sum of
        // the terms' sizes bounds the error with a wide margin (f64's
        // epsilon is 1.1e-16)
        let err = 1e-12 * (r.abs().dot(n.abs()) + 1e-300);
        den != 0.0 && num.abs() > err && (num > 0.0) == (den > 0.0)
    }

    /// Intersect the triangles of `block` in the lanes set in `lanes` with
    /// `0 < t <= t_max`, four at a time. Every lane's answer is the one the
    /// routine gives that triangle alone: the same `f32` operations in the
    /// same order, lane by lane (vector instructions are IEEE-exact per
    /// lane, and nothing is contracted into fused multiply-adds).
    #[inline(always)]
    pub fn intersect4(&self, block: &Tri4, lanes: u32, t_max: f32) -> Hits4 {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        let o = self.o.to_array();
        let (sx, sy, sz) = (
            Vec4::splat(self.sx),
            Vec4::splat(self.sy),
            Vec4::splat(self.sz),
        );
        // corner coordinates relative to the origin, in the ray's permuted
        // axes: `rel(c, k)` is `p_c[k] - o[k]` for the four triangles
        let rel = |c: usize, k: usize| Vec4::from(block.p[c][k]) - Vec4::splat(o[k]);
        let (a, b, c) = (
            (rel(0, kx), rel(0, ky), rel(0, kz)),
            (rel(1, kx), rel(1, ky), rel(1, kz)),
            (rel(2, kx), rel(2, ky), rel(2, kz)),
        );
        // shear so that the ray points down +z
        let ax = a.0 - sx * a.2;
        let ay = a.1 - sy * a.2;
        let bx = b.0 - sx * b.2;
        let by = b.1 - sy * b.2;
        let cx = c.0 - sx * c.2;
        let cy = c.1 - sy * c.2;
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        let zero = Vec4::ZERO;
        let redo = (u.cmpeq(zero) | v.cmpeq(zero) | w.cmpeq(zero)).bitmask() & lanes;
        if redo != 0 {
            // an edge function is exactly zero: recompute that triangle's
            // three in f64, as Woop et al. recommend (one rounding each)
            let f =
                |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
            let [axs, ays, bxs, bys, cxs, cys] = [ax, ay, bx, by, cx, cy].map(|x| x.to_array());
            let (mut us, mut vs, mut ws) = (u.to_array(), v.to_array(), w.to_array());
            for l in (0..4).filter(|l| redo >> l & 1 != 0) {
                us[l] = f(cxs[l], bys[l], cys[l], bxs[l]);
                vs[l] = f(axs[l], cys[l], ays[l], cxs[l]);
                ws[l] = f(bxs[l], ays[l], bys[l], axs[l]);
            }
            (u, v, w) = (Vec4::from(us), Vec4::from(vs), Vec4::from(ws));
        }
        // inside: all three edge functions of one sign (zeros allowed)
        let any_neg = u.cmplt(zero) | v.cmplt(zero) | w.cmplt(zero);
        let any_pos = u.cmpgt(zero) | v.cmpgt(zero) | w.cmpgt(zero);
        let det = u + v + w;
        // det != 0 and not NaN: exactly degenerate triangles are never hit
        let mut keep = !(any_neg & any_pos) & (det.cmplt(zero) | det.cmpgt(zero));
        // most leaf tests end here: no lane is inside its triangle, so the
        // distance and its error bound need not be computed (the lanes that
        // go on get exactly the arithmetic they got before)
        if keep.bitmask() & lanes == 0 {
            return Hits4::MISS;
        }
        let az = sz * a.2;
        let bz = sz * b.2;
        let cz = sz * c.2;
        let t_scaled = u * az + v * bz + w * cz;
        // t = t_scaled / det must be positive: same signs. The range check
        // against t_max happens after the division, on t itself, so the
        // answer for a triangle never depends on how t_max was reached (the
        // BVH and the naive backend pass different t_max sequences).
        keep &=
            !((det.cmpgt(zero) & t_scaled.cmple(zero)) | (det.cmplt(zero) & t_scaled.cmpge(zero)));
        let inv = Vec4::ONE / det;
        let t = t_scaled * inv;
        keep &= t.cmpgt(zero) & t.cmple(Vec4::splat(t_max));
        // t must be conservatively greater than zero: reject hits within the
        // rounding-error bound of t (pbrt-v4 section 6.8.4, "Bounding the
        // triangle t"), so a ray starting on or just off a triangle never
        // reports that triangle at a distance that is only rounding noise.
        let max_zt = az.abs().max(bz.abs()).max(cz.abs());
        let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
        let max_yt = ay.abs().max(by.abs()).max(cy.abs());
        let g = |n: i32| Vec4::splat(gamma(n));
        let delta_z = g(3) * max_zt;
        let delta_x = g(5) * (max_xt + max_zt);
        let delta_y = g(5) * (max_yt + max_zt);
        let delta_e =
            Vec4::splat(2.0) * (g(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        // The edge functions' errors move t as weights move an average: t
        // is the average of the corners' z weighted by u, v, w (which sum to
        // det), so with errors du, dv, dw the exact identity
        //   t' - t = (du (az - t) + dv (bz - t) + dw (cz - t)) / det'
        // holds, and |z - t| is at most the spread of the corners' z when
        // the hit lies inside. pbrt-v4 bounds it by max |z|: the same where
        // the corners straddle the origin's plane (where self-intersection
        // happens), but 500 times too loose for a small triangle far away,
        // whose hits it then rejects as "not certainly positive" (a 5e-3
        // sliver 1.3 away, hit squarely at t = 1.318, got delta_t = 3).
        let spread = az.max(bz).max(cz) - az.min(bz).min(cz) + Vec4::splat(2.0) * delta_z;
        let delta_t = Vec4::splat(3.0)
            * (g(3) * max_e * max_zt + delta_e * spread.min(max_zt) + delta_z * max_e)
            * inv.abs();
        let sure = keep & t.cmpgt(delta_t);
        // Hits within that bound are rounding noise only when the origin lies
        // on the triangle's plane. A ray that starts within 1e-5 of a
        // concave edge meets the adjacent wall at such a distance, while the
        // bound, which grows with the wall's size, can be larger (issue 21's
        // corner leaks: t = 1.5e-5 against a bound of 2e-5). For those lanes
        // the side of the plane decides, computed from the same f32 corners
        // in f64 with its own error bound: the hit stands when the origin is
        // certainly in front of the plane. Self-intersection stays excluded:
        // the offset policy puts a spawned origin on the side its ray leaves,
        // where this test finds the plane behind it.
        // (a hit far below the bound is a ray leaving its own triangle,
        // whose t is noise: the exact test, which costs more than the rest
        // of the routine, runs only from a sixteenth of the bound up)
        let unsure = (keep & !sure & t.cmpgt(delta_t * Vec4::splat(1.0 / 16.0))).bitmask() & lanes;
        let mut mask = sure.bitmask() & lanes;
        for l in (0..4).filter(|l| unsure >> l & 1 != 0) {
            if self.plane_ahead(block, l) {
                mask |= 1 << l;
            }
        }
        Hits4 {
            mask,
            t: t.to_array(),
            u: (v * inv).to_array(),
            v: (w * inv).to_array(),
        }
    }
}

/// Four triangles stored coordinate by coordinate (`p[corner][axis][lane]`),
/// with their original indices: the unit [`WatertightRay::intersect4`]
/// tests at once. Unused lanes repeat lane 0 and are masked out by the
/// caller's lane mask.
#[derive(Debug, Clone, Copy, Default, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C, align(16))]
pub struct Tri4 {
    /// Corner coordinates: `p[corner][axis][lane]`.
    pub p: [[[f32; 4]; 3]; 3],
    /// Original triangle index of each lane.
    pub ids: [u32; 4],
}

impl Tri4 {
    /// A block of up to four triangles `(id, corners)`; unused lanes repeat
    /// the first triangle. Panics on an empty or too long slice.
    pub fn new(tris: &[(u32, [Vec3; 3])]) -> Tri4 {
        assert!(
            (1..=4).contains(&tris.len()),
            "a block holds 1 to 4 triangles"
        );
        let mut b = Tri4::default();
        for l in 0..4 {
            let (id, p) = tris[if l < tris.len() { l } else { 0 }];
            b.set(l, p, id);
        }
        b
    }

    /// Put triangle `id` with corners `p` in lane `l`.
    #[inline]
    pub fn set(&mut self, l: usize, p: [Vec3; 3], id: u32) {
        for (c, q) in p.iter().enumerate() {
            for k in 0..3 {
                self.p[c][k][l] = q[k];
            }
        }
        self.ids[l] = id;
    }
}

/// The answers of [`WatertightRay::intersect4`]: lane `l` hit when bit `l`
/// of `mask` is set, at `t[l]` with barycentrics `(u[l], v[l])`.
#[derive(Debug, Clone, Copy)]
pub struct Hits4 {
    /// Lanes that hit.
    pub mask: u32,
    /// Distances.
    pub t: [f32; 4],
    /// Barycentric of the second corner.
    pub u: [f32; 4],
    /// Barycentric of the third corner.
    pub v: [f32; 4],
}

impl Hits4 {
    /// No lane hit.
    pub const MISS: Hits4 = Hits4 {
        mask: 0,
        t: [0.0; 4],
        u: [0.0; 4],
        v: [0.0; 4],
    };

    /// Lane `l` as a hit (with `prim = 0`), if it hit.
    #[inline]
    pub fn hit(&self, l: usize) -> Option<Hit> {
        (self.mask >> l & 1 != 0).then(|| Hit {
            t: self.t[l],
            prim: 0,
            u: self.u[l],
            v: self.v[l],
        })
    }

    /// Whether some hit of `block` counts under `filter`.
    #[inline]
    pub fn any_kept<F: HitFilter>(&self, block: &Tri4, filter: &F) -> bool {
        self.lanes(block).any_kept(filter)
    }

    /// Fold these hits of `block` into the closest hit so far, as if its
    /// triangles were tested one by one in lane order: a hit replaces `best`
    /// if it is closer than `t_max`, or at `t_max` with a lower original
    /// index (the tie rule of every backend). `t_max` follows `best`.
    ///
    /// `filter` is asked only about hits that would replace `best`, so an
    /// [`Opaque`](super::Opaque) one costs nothing and a mask is evaluated
    /// as rarely as the order allows; the result is the closest kept hit
    /// whatever the order.
    #[inline]
    pub fn fold_closest<F: HitFilter>(
        &self,
        block: &Tri4,
        best: &mut Option<Hit>,
        t_max: &mut f32,
        filter: &F,
    ) {
        self.lanes(block).fold_closest(best, t_max, filter);
    }

    /// These hits of `block`, lane by lane.
    #[inline(always)]
    fn lanes<'a>(&'a self, block: &'a Tri4) -> Lanes<'a, 4> {
        Lanes {
            mask: self.mask,
            ids: &block.ids,
            t: &self.t,
            u: &self.u,
            v: &self.v,
        }
    }
}

/// The hits of a block of any width, lane by lane: what
/// [`Hits4::fold_closest`] and [`Hits4::any_kept`] (and their sixteen-wide
/// twins, [`super::wide::Hits16`]) fold.
pub(super) struct Lanes<'a, const N: usize> {
    /// Bit `l` set: lane `l` hit.
    pub mask: u32,
    /// Per lane: the triangle's original index, the hit's distance and
    /// barycentrics.
    pub ids: &'a [u32; N],
    pub t: &'a [f32; N],
    pub u: &'a [f32; N],
    pub v: &'a [f32; N],
}

impl<const N: usize> Lanes<'_, N> {
    /// As [`Hits4::fold_closest`].
    #[inline(always)]
    pub fn fold_closest<F: HitFilter>(&self, best: &mut Option<Hit>, t_max: &mut f32, filter: &F) {
        let mut m = self.mask;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            let (t, id) = (self.t[l], self.ids[l]);
            if (t < *t_max || (t == *t_max && best.is_none_or(|b| id < b.prim)))
                && (F::OPAQUE || filter.keep(id, self.u[l], self.v[l]))
            {
                *t_max = t;
                *best = Some(Hit {
                    t,
                    prim: id,
                    u: self.u[l],
                    v: self.v[l],
                });
            }
        }
    }

    /// As [`Hits4::any_kept`].
    #[inline(always)]
    pub fn any_kept<F: HitFilter>(&self, filter: &F) -> bool {
        if F::OPAQUE {
            return self.mask != 0;
        }
        let mut m = self.mask;
        while m != 0 {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            if filter.keep(self.ids[l], self.u[l], self.v[l]) {
                return true;
            }
        }
        false
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: Vec3, d: Vec3) -> WatertightRay {
        WatertightRay::new(&Ray::new(o, d.normalize()))
    }

    /// Issue 21's concave-corner leaks: rays that start within 1e-5 of a
    /// room's concave edge (floor y = 0, ceiling y = 2, back wall z = -1,
    /// side walls x = +-1) and reach the adjacent wall at t ~ 1e-5, where
    /// Embree hits it. Each wall is the triangle pair Embree reported on.
    #[test]
    fn walls_next_to_a_concave_corner_are_hit() {
        let quad = |c: [Vec3; 4]| [[c[0], c[1], c[2]], [c[0], c[2], c[3]]];
        let v = Vec3::new;
        let ceiling = quad([
            v(-1., 2., -1.),
            v(1., 2., -1.),
            v(1., 2., 1.),
            v(-1., 2., 1.),
        ]);
        let floor = quad([
            v(-1., 0., -1.),
            v(-1., 0., 1.),
            v(1., 0., 1.),
            v(1., 0., -1.),
        ]);
        let back = quad([
            v(-1., 0., -1.),
            v(1., 0., -1.),
            v(1., 2., -1.),
            v(-1., 2., -1.),
        ]);
        let cases = [
            (
                v(0.4746351, 1.9999912, -0.9999964),
                v(0.07330299, 0.59815276, 0.79802257),
                1.4747884e-5,
                &ceiling,
            ),
            (
                v(0.36931226, 4.351139e-6, -0.3962573),
                v(0.42001775, -0.32104725, 0.8488308),
                1.3553e-5,
                &floor,
            ),
            (
                v(-0.9753108, 0.050036192, -0.9999908),
                v(-0.6185184, 0.5091974, -0.5984589),
                1.5338e-5,
                &back,
            ),
            (
                v(0.34797928, -2.7418137e-6, 0.17485863),
                v(-0.7416075, 0.3049615, -0.5975088),
                8.99e-6,
                &floor,
            ),
        ];
        for (o, d, t, wall) in cases {
            let ray = Ray::new(o, d);
            let r = WatertightRay::new(&ray);
            let hit = wall
                .iter()
                .filter_map(|p| r.intersect(p[0], p[1], p[2], f32::INFINITY))
                .map(|h| h.t)
                .fold(f32::INFINITY, f32::min);
            // as close as two correct f32 tests can agree on a wall this
            // large (a few 1e-8 here)
            let tol = distance_error_bound(wall[0], &ray);
            assert!(
                (hit - t).abs() <= tol + 1e-4 * t,
                "ray from {o} along {d}: hit at {hit}, Embree at {t} (tolerance {tol})"
            );
        }
    }

    #[test]
    fn hits_centre_with_barycentrics() {
        let r = ray(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        let h = r
            .intersect(Vec3::ZERO, Vec3::X, Vec3::Y, f32::INFINITY)
            .expect("hit");
        assert!((h.t - 1.0).abs() < 1e-6);
        assert!((h.u - 0.25).abs() < 1e-6 && (h.v - 0.25).abs() < 1e-6);
        // both faces are hit (no culling)
        let r = ray(Vec3::new(0.25, 0.25, -1.0), Vec3::Z);
        assert!(
            r.intersect(Vec3::ZERO, Vec3::X, Vec3::Y, f32::INFINITY)
                .is_some()
        );
    }

    #[test]
    fn respects_extent_and_direction() {
        let r = ray(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        assert!(r.intersect(Vec3::ZERO, Vec3::X, Vec3::Y, 0.999).is_none());
        assert!(r.intersect(Vec3::ZERO, Vec3::X, Vec3::Y, 1.0).is_some());
        let r = ray(Vec3::new(0.25, 0.25, 1.0), Vec3::Z);
        assert!(
            r.intersect(Vec3::ZERO, Vec3::X, Vec3::Y, f32::INFINITY)
                .is_none()
        );
    }

    /// Each lane of a block answers as its triangle does alone, whatever
    /// its neighbours: degenerate ones, ones that need the f64 edge
    /// functions (rays at vertices and edges), hits and misses mixed.
    #[test]
    fn lanes_answer_independently() {
        let mut s = crate::sampler::Sampler::new(5, 0, 0);
        let mut r =
            |scale: f32| Vec3::new(s.next_1d() - 0.5, s.next_1d() - 0.5, s.next_1d() - 0.5) * scale;
        let mut hits = 0;
        for i in 0..20_000usize {
            let scale = 10f32.powi(i as i32 % 9 - 4);
            let base = r(scale);
            let tris: Vec<(u32, [Vec3; 3])> = (0..4)
                .map(|k| {
                    let mut p = [base + r(scale), base + r(scale), base + r(scale)];
                    match (i + k) % 5 {
                        0 => p[2] = p[1],                       // repeated vertex
                        1 => p[2] = p[0] + 0.5 * (p[1] - p[0]), // collinear
                        _ => {}
                    }
                    (k as u32, p)
                })
                .collect();
            // aimed at a vertex, an edge midpoint or inside of one of them
            let p = tris[i % 4].1;
            let target = match i % 3 {
                0 => p[0],
                1 => 0.5 * (p[0] + p[1]),
                _ => (p[0] + p[1] + p[2]) / 3.0,
            };
            let o = target + r(3.0 * scale);
            let Some(d) = (target - o).try_normalize() else {
                continue;
            };
            let wr = WatertightRay::new(&Ray::new(o, d));
            let lanes = if i % 7 == 0 { 0b0111 } else { 0b1111 };
            let block = Tri4::new(&tris);
            let all = wr.intersect4(&block, lanes, f32::INFINITY);
            for (l, (_, p)) in tris.iter().enumerate() {
                let alone = wr.intersect4(&Tri4::new(&[(0, *p)]), 1, f32::INFINITY);
                let want = if lanes >> l & 1 != 0 {
                    alone.hit(0)
                } else {
                    None
                };
                let got = all.hit(l);
                assert_eq!(
                    got.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits())),
                    want.map(|h| (h.t.to_bits(), h.u.to_bits(), h.v.to_bits())),
                    "lane {l} of block {i}"
                );
                hits += got.is_some() as usize;
            }
        }
        assert!(hits > 10_000, "too few hits ({hits}) to mean anything");
    }

    #[test]
    fn fold_keeps_the_lowest_index_on_ties() {
        let r = ray(Vec3::new(0.25, 0.25, 1.0), -Vec3::Z);
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let block = Tri4::new(&[(9, tri), (3, tri), (5, tri)]);
        let hits = r.intersect4(&block, 0b111, f32::INFINITY);
        assert_eq!(hits.mask, 0b111);
        let (mut best, mut t_max) = (None, f32::INFINITY);
        hits.fold_closest(&block, &mut best, &mut t_max, &super::super::Opaque);
        assert_eq!(best.map(|h| h.prim), Some(3));
        // an earlier block's hit at the same t with a lower index stays
        let mut best = Some(Hit {
            prim: 1,
            ..best.unwrap()
        });
        let mut t_max = best.unwrap().t;
        hits.fold_closest(&block, &mut best, &mut t_max, &super::super::Opaque);
        assert_eq!(best.map(|h| h.prim), Some(1));
    }

    #[test]
    fn a_small_sliver_far_away_is_hit() {
        // A sliver at the pole of the 1.2M-triangle benchmark sphere (4.7e-3
        // long, 3e-5 wide), met squarely by a shadow ray 1.318 away (exact
        // barycentrics 0.865, 0.123, 0.012 in rational arithmetic): pbrt-v4's
        // bound on t was 3 and rejected it; Embree reports it
        let o = Vec3::new(0.3717262, -0.110167295, 1.2371176);
        let d = Vec3::new(-0.2816396, 0.19782123, -0.9389068);
        let r = WatertightRay::new(&Ray::new(o, d));
        let p = [
            Vec3::new(-6.551138e-8, 0.15063721, 0.0),
            Vec3::new(0.0039254026, 0.15005273, -0.0025896206),
            Vec3::new(0.003941596, 0.15004653, -0.0025649772),
        ];
        let h = r.intersect(p[0], p[1], p[2], f32::INFINITY).expect("hit");
        assert!((h.t - 1.3179863).abs() < 1e-6, "{h:?}");
    }

    #[test]
    fn degenerate_triangles_never_hit() {
        let r = ray(Vec3::new(0.5, 0.0, 1.0), -Vec3::Z);
        assert!(
            r.intersect(Vec3::ZERO, Vec3::X, 2.0 * Vec3::X, f32::INFINITY)
                .is_none()
        );
        assert!(
            r.intersect(Vec3::ZERO, Vec3::ZERO, Vec3::X, f32::INFINITY)
                .is_none()
        );
        let nan = Vec3::new(f32::NAN, 0.0, 0.0);
        assert!(r.intersect(nan, Vec3::X, Vec3::Y, f32::INFINITY).is_none());
    }

    #[test]
    fn shared_edge_is_watertight() {
        // Unit square split along its diagonal, rotated off the axes; rays aimed
        // exactly at points of the diagonal hit exactly one or both halves.
        let rot = glam::Quat::from_euler(glam::EulerRot::XYZ, 0.3, 0.7, 1.1);
        let q = |x: f32, y: f32| rot * Vec3::new(x, y, 0.0);
        let (a, b, c, d) = (q(0.0, 0.0), q(1.0, 0.0), q(1.0, 1.0), q(0.0, 1.0));
        let n = rot * Vec3::Z;
        for i in 0..32 {
            for j in 0..32 {
                let s = (i as f32 + 0.5) / 32.0;
                let target = a + s * (c - a);
                let jitter = rot * Vec3::new(j as f32 * 0.01 - 0.16, 0.1, 0.0);
                let o = target + 2.0 * n + jitter;
                let r = WatertightRay::new(&Ray::new(o, (target - o).normalize()));
                let h1 = r.intersect(a, b, c, f32::INFINITY);
                let h2 = r.intersect(a, c, d, f32::INFINITY);
                assert!(h1.is_some() || h2.is_some(), "ray {i},{j} slipped through");
            }
        }
    }
}
