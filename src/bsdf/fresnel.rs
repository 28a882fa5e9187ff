//! Fresnel reflectance and the laws of specular reflection and refraction, in
//! the local shading frame (normal = +z).
//!
//! - [`fr_dielectric`]: the exact unpolarised Fresnel reflectance of a smooth
//!   boundary between two dielectrics (pbrt-v4, section 9.3.2, "The Fresnel
//!   Equations"), with total internal reflection.
//! - [`fr_conductor`]: the same equations with a complex index of refraction
//!   `eta + i k` for metals (pbrt-v4, section 9.3.6, "The Fresnel Equations for
//!   Conductors").
//! - [`reflect`] and [`refract`]: mirror reflection about the normal and
//!   Snell's law (pbrt-v4, sections 9.3.1 and 9.3.2).
//!
//! Relative indices of refraction follow pbrt: `eta = eta_t / eta_i` is the
//! index below the surface (the `-z` side) over the index above it; a
//! direction with `cos < 0` is below the surface, and the formulas then swap
//! the media by using `1 / eta`.

use crate::math::Vec3;

/// Fresnel reflectance of a smooth dielectric boundary for light arriving at
/// `cos_theta_i` from the normal, where `eta` is the index below the surface
/// over the index above it. A negative cosine means the light arrives from
/// below. Returns 1 under total internal reflection. Exact (no Schlick
/// approximation).
pub fn fr_dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    let mut cos_i = cos_theta_i.clamp(-1.0, 1.0);
    let mut eta = eta;
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if !(sin2_t < 1.0) {
        // total internal reflection (or a NaN input: reflect, never refract)
        return 1.0;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let r_parl = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let r_perp = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (r_parl * r_parl + r_perp * r_perp)
}

/// A complex number, only as much of one as the conductor Fresnel equations
/// need.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Complex {
    re: f32,
    im: f32,
}

impl Complex {
    fn new(re: f32, im: f32) -> Self {
        Complex { re, im }
    }

    fn add(self, o: Complex) -> Complex {
        Complex::new(self.re + o.re, self.im + o.im)
    }

    fn sub(self, o: Complex) -> Complex {
        Complex::new(self.re - o.re, self.im - o.im)
    }

    fn mul(self, o: Complex) -> Complex {
        Complex::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }

    fn scale(self, s: f32) -> Complex {
        Complex::new(self.re * s, self.im * s)
    }

    /// `|z|^2`.
    fn norm(self) -> f32 {
        self.re * self.re + self.im * self.im
    }

    fn div(self, o: Complex) -> Complex {
        let scale = 1.0 / o.norm();
        Complex::new(
            scale * (self.re * o.re + self.im * o.im),
            scale * (self.im * o.re - self.re * o.im),
        )
    }

    /// The principal square root, computed without cancellation: the larger
    /// of the two parts comes from `sqrt((|z| + |re|) / 2)` and the other
    /// from dividing by it.
    fn sqrt(self) -> Complex {
        let n = self.norm().sqrt();
        if n == 0.0 {
            return Complex::new(0.0, 0.0);
        }
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        if self.re >= 0.0 {
            Complex::new(t1, t2)
        } else {
            Complex::new(t2.abs(), t1.copysign(self.im))
        }
    }
}

/// Fresnel reflectance of a conductor with complex index `eta + i k` (relative
/// to the medium above) for light arriving at `cos_theta_i`, one channel.
/// Light never arrives from inside a metal, so the cosine is clamped to
/// `[0, 1]`.
fn fr_complex(cos_theta_i: f32, eta: f32, k: f32) -> f32 {
    let cos_i = cos_theta_i.clamp(0.0, 1.0);
    let eta = Complex::new(eta, k);
    let sin2_i = 1.0 - cos_i * cos_i;
    let sin2_t = Complex::new(sin2_i, 0.0).div(eta.mul(eta));
    let cos_t = Complex::new(1.0, 0.0).sub(sin2_t).sqrt();
    let ci = Complex::new(cos_i, 0.0);
    let r_parl = eta.scale(cos_i).sub(cos_t).div(eta.scale(cos_i).add(cos_t));
    let r_perp = ci.sub(eta.mul(cos_t)).div(ci.add(eta.mul(cos_t)));
    0.5 * (r_parl.norm() + r_perp.norm())
}

/// Fresnel reflectance of a conductor, per RGB channel: `eta` and `k` are the
/// real and imaginary parts of its index of refraction relative to the medium
/// above. `eta` must be positive or `k` non-zero in every channel. A purely
/// imaginary index (`eta = 0`, `k > 0`) is a lossless ideal conductor: both
/// polarisations reflect with `|r| = 1`, so `F = 1` at every angle.
pub fn fr_conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    Vec3::new(
        fr_complex(cos_theta_i, eta.x, k.x),
        fr_complex(cos_theta_i, eta.y, k.y),
        fr_complex(cos_theta_i, eta.z, k.z),
    )
}

/// Mirror reflection of `w` about the normal `n`: `-w + 2 (w . n) n`.
pub fn reflect(w: Vec3, n: Vec3) -> Vec3 {
    -w + 2.0 * w.dot(n) * n
}

/// The refracted direction and the relative index it saw.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Refraction {
    /// The transmitted direction, on the other side of the surface from `wi`,
    /// pointing away from it; unit length when `wi` is.
    pub wt: Vec3,
    /// The relative index `eta_t / eta_i` that `wi`'s side sees: `eta` when
    /// `wi` is above the surface, `1 / eta` when it is below.
    pub etap: f32,
}

/// Snell's law for `wi` (pointing away from the surface) through the surface
/// with normal `n`, where `eta` is the index on `n`'s back side over the index
/// on its front side. `None` under total internal reflection.
pub fn refract(wi: Vec3, n: Vec3, eta: f32) -> Option<Refraction> {
    let mut cos_i = n.dot(wi);
    let (mut eta, mut n) = (eta, n);
    if cos_i < 0.0 {
        eta = 1.0 / eta;
        cos_i = -cos_i;
        n = -n;
    }
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if !(sin2_t < 1.0) {
        return None;
    }
    let cos_t = (1.0 - sin2_t).max(0.0).sqrt();
    let wt = -wi / eta + (cos_i / eta - cos_t) * n;
    Some(Refraction { wt, etap: eta })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The dielectric equations at normal incidence reduce to
    /// `((eta - 1) / (eta + 1))^2`, from either side.
    #[test]
    fn dielectric_normal_incidence() {
        for eta in [1.0f32, 1.33, 1.5, 2.4] {
            let r0 = ((eta - 1.0) / (eta + 1.0)).powi(2);
            assert!((fr_dielectric(1.0, eta) - r0).abs() < 1e-6);
            assert!((fr_dielectric(-1.0, eta) - r0).abs() < 1e-6);
        }
    }

    /// Glass (eta 1.5): Brewster's angle atan(1.5) has no parallel
    /// reflection, so F = r_perp^2 / 2; past the critical angle asin(1/1.5)
    /// inside, everything reflects; grazing incidence reflects everything.
    #[test]
    fn dielectric_brewster_critical_grazing() {
        let eta = 1.5f64;
        let tb = eta.atan();
        let (ci, si) = (tb.cos(), tb.sin());
        let ct = (1.0 - (si / eta).powi(2)).sqrt();
        let r_perp = (ci - eta * ct) / (ci + eta * ct);
        let f = fr_dielectric(ci as f32, eta as f32) as f64;
        // f32 evaluation of a value of order 0.07: a few ulp
        assert!((f - 0.5 * r_perp * r_perp).abs() < 1e-6, "{f}");
        let crit = (1.0 / eta).asin();
        assert_eq!(fr_dielectric(-(crit + 1e-3).cos() as f32, 1.5), 1.0);
        assert!(fr_dielectric(-(crit - 1e-3).cos() as f32, 1.5) < 1.0);
        assert_eq!(fr_dielectric(0.0, 1.5), 1.0);
        assert_eq!(fr_dielectric(-0.0, 1.5), 1.0);
    }

    /// With `k = 0` the conductor equations are the dielectric ones.
    #[test]
    fn conductor_with_no_absorption_is_a_dielectric() {
        for c in [1.0f32, 0.8, 0.5, 0.2, 0.01] {
            let fc = fr_conductor(c, Vec3::splat(1.5), Vec3::ZERO);
            let fd = fr_dielectric(c, 1.5);
            assert!((fc - Vec3::splat(fd)).abs().max_element() < 1e-6, "{c}");
        }
    }

    /// Normal incidence on a metal: `((n - 1)^2 + k^2) / ((n + 1)^2 + k^2)`;
    /// grazing incidence reflects everything; values stay in [0, 1].
    #[test]
    fn conductor_normal_and_grazing() {
        let eta = Vec3::new(0.2, 0.92, 1.1);
        let k = Vec3::new(3.9, 2.45, 2.2);
        let f = fr_conductor(1.0, eta, k);
        let r0 = ((eta - 1.0) * (eta - 1.0) + k * k) / ((eta + 1.0) * (eta + 1.0) + k * k);
        assert!((f - r0).abs().max_element() < 1e-6, "{f} vs {r0}");
        assert!((fr_conductor(0.0, eta, k) - Vec3::ONE).abs().max_element() < 1e-6);
        for i in 0..=100 {
            let f = fr_conductor(i as f32 / 100.0, eta, k);
            assert!(f.min_element() >= 0.0 && f.max_element() <= 1.0 + 1e-6);
            // a purely imaginary index reflects everything (f32 rounding)
            let ideal = fr_conductor(i as f32 / 100.0, Vec3::ZERO, Vec3::new(0.1, 1.0, 10.0));
            assert!((ideal - Vec3::ONE).abs().max_element() < 1e-6, "{ideal}");
        }
    }

    #[test]
    fn snell_and_tir() {
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let r = refract(wi, Vec3::Z, 1.5).unwrap();
        assert_eq!(r.etap, 1.5);
        assert!(r.wt.z < 0.0 && (r.wt.length() - 1.0).abs() < 1e-6);
        // sin_t = sin_i / eta
        assert!((r.wt.x.abs() - 0.6 / 1.5).abs() < 1e-6);
        assert!(
            r.wt.x < 0.0,
            "the transmitted ray crosses to the other side"
        );
        // and back: the reverse path refracts to the original direction
        let back = refract(r.wt, Vec3::Z, 1.5).unwrap();
        assert!((back.etap - 1.0 / 1.5).abs() < 1e-7);
        assert!((back.wt - wi).abs().max_element() < 1e-6);
        // from inside past the critical angle
        assert!(refract(Vec3::new(0.8, 0.0, -0.6), Vec3::Z, 1.5).is_none());
        assert_eq!(reflect(wi, Vec3::Z), Vec3::new(-0.6, 0.0, 0.8));
    }
}
