//! The watertight ray/triangle test of Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013. The ray is sheared so that it
//! points down +z from the origin; the three 2D edge functions then decide
//! inside/outside consistently for neighbouring triangles (no ray slips
//! through a shared edge or vertex). Edge functions that come out exactly zero
//! are recomputed in `f64`, as the paper recommends. There is no determinant
//! epsilon: thin triangles are hit; only exactly degenerate ones (`det == 0`)
//! are not. A hit whose `t` is not conservatively positive (within the
//! rounding-error bound of `t`, pbrt-v4 section 6.8.4) is rejected.

use super::Hit;
use crate::math::{Ray, Vec3, gamma};

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
    o: Vec3,
    kx: usize,
    ky: usize,
    kz: usize,
    sx: f32,
    sy: f32,
    sz: f32,
    t_max: f32,
}

impl WatertightRay {
    /// Prepare `ray` (its direction must be non-zero and finite).
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
    /// hit has `prim = 0`; the caller sets it.
    #[inline]
    pub fn intersect(&self, p0: Vec3, p1: Vec3, p2: Vec3, t_max: f32) -> Option<Hit> {
        let (kx, ky, kz) = (self.kx, self.ky, self.kz);
        // Arrays indexed at run time compile to indexed loads; indexing a
        // `Vec3` would be a chain of branches per component. Same values.
        let a = (p0 - self.o).to_array();
        let b = (p1 - self.o).to_array();
        let c = (p2 - self.o).to_array();
        let ax = a[kx] - self.sx * a[kz];
        let ay = a[ky] - self.sy * a[kz];
        let bx = b[kx] - self.sx * b[kz];
        let by = b[ky] - self.sy * b[kz];
        let cx = c[kx] - self.sx * c[kz];
        let cy = c[ky] - self.sy * c[kz];
        let mut u = cx * by - cy * bx;
        let mut v = ax * cy - ay * cx;
        let mut w = bx * ay - by * ax;
        // `|` rather than `||`: one branch instead of three (same result)
        if (u == 0.0) | (v == 0.0) | (w == 0.0) {
            let f =
                |p: f32, q: f32, r: f32, s: f32| (p as f64 * q as f64 - r as f64 * s as f64) as f32;
            u = f(cx, by, cy, bx);
            v = f(ax, cy, ay, cx);
            w = f(bx, ay, by, ax);
        }
        if ((u < 0.0) | (v < 0.0) | (w < 0.0)) & ((u > 0.0) | (v > 0.0) | (w > 0.0)) {
            return None;
        }
        let det = u + v + w;
        if det == 0.0 || det.is_nan() {
            return None;
        }
        let az = self.sz * a[kz];
        let bz = self.sz * b[kz];
        let cz = self.sz * c[kz];
        let t_scaled = u * az + v * bz + w * cz;
        // t = t_scaled / det must be positive: same signs. The range check
        // against t_max happens after the division, on t itself, so the
        // answer for a triangle never depends on how t_max was reached (the
        // BVH and the naive backend pass different t_max sequences).
        if (det > 0.0 && t_scaled <= 0.0) || (det < 0.0 && t_scaled >= 0.0) {
            return None;
        }
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t > 0.0 && t <= t_max) {
            return None;
        }
        // t must be conservatively greater than zero: reject hits within the
        // rounding-error bound of t (pbrt-v4 section 6.8.4, "Bounding the
        // triangle t"), so a ray starting on or just off a triangle never
        // reports that triangle at a distance that is only rounding noise.
        let max_zt = az.abs().max(bz.abs()).max(cz.abs());
        let max_xt = ax.abs().max(bx.abs()).max(cx.abs());
        let max_yt = ay.abs().max(by.abs()).max(cy.abs());
        let delta_z = gamma(3) * max_zt;
        let delta_x = gamma(5) * (max_xt + max_zt);
        let delta_y = gamma(5) * (max_yt + max_zt);
        let delta_e = 2.0 * (gamma(2) * max_xt * max_yt + delta_y * max_xt + delta_x * max_yt);
        let max_e = u.abs().max(v.abs()).max(w.abs());
        let delta_t =
            3.0 * (gamma(3) * max_e * max_zt + delta_e * max_zt + delta_z * max_e) * inv.abs();
        if t <= delta_t {
            return None;
        }
        Some(Hit {
            t,
            prim: 0,
            u: v * inv,
            v: w * inv,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ray(o: Vec3, d: Vec3) -> WatertightRay {
        WatertightRay::new(&Ray::new(o, d.normalize()))
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
